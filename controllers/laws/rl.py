"""RL laws (PPO, SAC) run from plain data with numpy only: the shipped policy file, its loader and runtime.

A policy trained by ``rig train`` is exported (:func:`controllers.design.rl_export.export_sb3`) to one
JSON file; this module loads it, validates it and runs it.  Nothing here imports torch or
stable-baselines3, and nothing is unpickled: a policy file is data, never code.

    law = make_controller("ppo", LoopSpec.from_env(env), num_envs=env.num_envs)        # shipped policy
    law = make_controller("sac", spec, 64, path="runs/vvr_sac/policy.json")              # any exported file

The runtime reproduces SB3's ``model.predict(obs, deterministic=True)`` (to float32 rounding):

| stage | PPO (``ActorCriticPolicy``) | SAC (``SACPolicy`` actor) |
|---|---|---|
| 1. observation | cast to float32 (what the SB3 adapter hands the policy) | same |
| 2. VecNormalize (if trained with it) | ``clip((o - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)``, cast to float32 | same |
| 3. hidden layers | ``h = act(h @ W.T + b)``, ``act`` = tanh or relu as trained | same |
| 4. output layer | Gaussian mean ``mu = h @ W.T + b`` | ``mu = h @ W.T + b``, then ``tanh(mu)`` |
| 5. to the action space | ``clip(mu, low, high)`` | ``low + (tanh(mu) + 1) (high - low) / 2`` |

File format (``format = "rig_env.rl_policy"``, ``format_version = 1``), one JSON object:

| key | content |
|---|---|
| kind | ``"ppo"`` or ``"sac"`` |
| loop_spec | the :class:`LoopSpec` it was trained for (task, free_dofs, obs_labels, action_names, dt s, airspeed_range m/s, action_scale_deg) |
| env_overrides | the ``RigEnvConfig`` fields it was trained and evaluated with (beyond the task defaults) |
| network | ``activation``; ``layers``: list of ``{"weight": (out, in), "bias": (out,)}`` as nested lists, torch's ``nn.Linear`` layout, float32 values |
| obs_norm | ``null`` or ``{"mean": (obs_dim,), "var": (obs_dim,), "clip_obs", "epsilon"}`` of SB3's VecNormalize |
| action | ``postprocess`` (``"clip"`` for PPO, ``"tanh_unscale"`` for SAC), ``low``, ``high`` (n_actions,) |
| provenance | command, seed, timesteps, wall time, versions, evaluation metrics (free-form, informative) |
| sha256 | SHA-256 of the canonical JSON of every other key (sorted keys, no spaces) |

Loading checks all of it (format and version, checksum, shapes, finite values, that the layers chain
from obs_dim to n_actions, and that the file's loop equals the one asked for) and raises
:class:`PolicyFileError` (a ValueError) naming the file and the field.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from controllers.laws.base import Controller, LoopSpec, register

FORMAT = "rig_env.rl_policy"
FORMAT_VERSION = 1
POLICY_DIR = Path(__file__).resolve().parents[1] / "policies"
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda x: np.maximum(x, 0.0)}
POSTPROCESS = {"ppo": "clip", "sac": "tanh_unscale"}


class PolicyFileError(ValueError):
    """A policy file that cannot be used: unreadable, tampered with, malformed, or for another loop."""


def policy_path(task: str, kind: str) -> Path:
    """Where the shipped policy of ``kind`` for ``task`` lives: ``controllers/policies/<task>_<kind>.json``."""
    return POLICY_DIR / f"{task}_{kind}.json"


@dataclass(frozen=True)
class PolicyData:
    """A validated policy: everything the runtime needs, as float64 arrays of float32 values."""

    kind: str
    spec: LoopSpec
    activation: str
    weights: tuple[np.ndarray, ...]  # (out, in) each
    biases: tuple[np.ndarray, ...]  # (out,) each
    action_low: np.ndarray  # (n_actions,)
    action_high: np.ndarray  # (n_actions,)
    obs_mean: np.ndarray | None = None  # (obs_dim,)
    obs_var: np.ndarray | None = None  # (obs_dim,)
    clip_obs: float = math.inf
    epsilon: float = 1e-8
    env_overrides: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)

    @property
    def postprocess(self) -> str:
        return POSTPROCESS[self.kind]

    def forward(self, obs: np.ndarray) -> np.ndarray:
        """Actions (m, n_actions) float64 for observations (m, obs_dim): stages 1-5 of the module table."""
        h = np.asarray(obs, dtype=np.float32)
        if self.obs_mean is not None:
            h = np.clip((h - self.obs_mean) / np.sqrt(self.obs_var + self.epsilon), -self.clip_obs, self.clip_obs)
            h = h.astype(np.float32)
        h = h.astype(np.float64)
        act = ACTIVATIONS[self.activation]
        for W, b in zip(self.weights[:-1], self.biases[:-1]):
            h = act(h @ W.T + b)
        mu = h @ self.weights[-1].T + self.biases[-1]
        if self.postprocess == "clip":
            return np.clip(mu, self.action_low, self.action_high)
        return self.action_low + 0.5 * (np.tanh(mu) + 1.0) * (self.action_high - self.action_low)


# ---------------------------------------------------------------------- file <-> data
def checksum(payload: dict[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of ``payload`` without its ``sha256`` key."""
    body = {k: v for k, v in payload.items() if k != "sha256"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def save_policy(payload: dict[str, Any], path: str | Path) -> Path:
    """Write ``payload`` (from ``export_sb3``) with its checksum; validates it first (round trip)."""
    payload = dict(payload)
    payload["sha256"] = checksum(payload)
    parse_policy(payload, str(path))
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"{json.dumps(k)}: {json.dumps(v, separators=(',', ':'), allow_nan=False)}" for k, v in payload.items()]
    p.write_text("{\n" + ",\n".join(lines) + "\n}\n", encoding="utf-8")  # one top-level key per line
    return p


def load_policy(path: str | Path) -> PolicyData:
    """Read and validate a policy file; PolicyFileError (a ValueError) naming what failed."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"no policy file {p}")
    try:
        payload = json.loads(p.read_text(encoding="utf-8"), parse_constant=_reject_constant)
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise PolicyFileError(f"{p}: not a readable JSON policy file (truncated or corrupted?): {e}") from None
    return parse_policy(payload, str(p))


def _reject_constant(name: str) -> None:
    raise json.JSONDecodeError(f"non-finite number {name}", name, 0)


def _array(where: str, name: str, value: Any, shape: tuple[int | None, ...]) -> np.ndarray:
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise PolicyFileError(f"{where}: {name} is not a numeric array of shape {shape}") from None
    if a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape)):
        raise PolicyFileError(f"{where}: {name} has shape {a.shape}, expected {shape}")
    if not np.all(np.isfinite(a)):
        raise PolicyFileError(f"{where}: {name} has non-finite value(s)")
    return a


def _get(where: str, d: Any, key: str, kind: type | tuple[type, ...]) -> Any:
    if not isinstance(d, dict) or key not in d:
        raise PolicyFileError(f"{where}: missing field {key!r}")
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, kind):
        raise PolicyFileError(f"{where}: field {key!r} = {v!r} has the wrong type")
    return v


def parse_policy(payload: Any, where: str = "<policy>") -> PolicyData:
    """Validate a decoded policy file (format, checksum, fields, shapes, finiteness) into PolicyData."""
    if not isinstance(payload, dict):
        raise PolicyFileError(f"{where}: not a JSON object")
    if payload.get("format") != FORMAT:
        raise PolicyFileError(f"{where}: format = {payload.get('format')!r}, expected {FORMAT!r}")
    if payload.get("format_version") != FORMAT_VERSION:
        raise PolicyFileError(f"{where}: format_version = {payload.get('format_version')!r}, this runtime reads {FORMAT_VERSION}")
    digest = _get(where, payload, "sha256", str)
    if digest != checksum(payload):
        raise PolicyFileError(f"{where}: sha256 does not match the content (file modified or damaged)")
    kind = _get(where, payload, "kind", str)
    if kind not in POSTPROCESS:
        raise PolicyFileError(f"{where}: kind = {kind!r}, expected one of {sorted(POSTPROCESS)}")
    ls = _get(where, payload, "loop_spec", dict)
    try:
        spec = LoopSpec(
            task=str(ls["task"]), free_dofs=tuple(ls["free_dofs"]), obs_labels=tuple(ls["obs_labels"]),
            action_names=tuple(ls["action_names"]), dt=float(ls["dt"]),
            airspeed_range=tuple(float(v) for v in ls["airspeed_range"]), action_scale_deg=float(ls["action_scale_deg"]),
        )
    except (KeyError, TypeError, ValueError) as e:
        raise PolicyFileError(f"{where}: loop_spec is incomplete or malformed ({e!r})") from None
    if not (spec.dt > 0 and math.isfinite(spec.dt)) or spec.obs_dim == 0 or spec.n_actions == 0:
        raise PolicyFileError(f"{where}: loop_spec needs dt > 0 and non-empty obs_labels, action_names")

    net = _get(where, payload, "network", dict)
    activation = _get(where, net, "activation", str)
    if activation not in ACTIVATIONS:
        raise PolicyFileError(f"{where}: network.activation = {activation!r}, expected one of {sorted(ACTIVATIONS)}")
    layers = _get(where, net, "layers", list)
    if not layers:
        raise PolicyFileError(f"{where}: network.layers is empty")
    weights, biases, n_in = [], [], spec.obs_dim
    for i, layer in enumerate(layers):
        W = _array(where, f"network.layers[{i}].weight", _get(where, layer, "weight", list), (None, n_in))
        b = _array(where, f"network.layers[{i}].bias", _get(where, layer, "bias", list), (W.shape[0],))
        weights.append(W)
        biases.append(b)
        n_in = W.shape[0]
    if n_in != spec.n_actions:
        raise PolicyFileError(f"{where}: the last layer has {n_in} outputs, the loop has {spec.n_actions} actions")

    act = _get(where, payload, "action", dict)
    post = _get(where, act, "postprocess", str)
    if post != POSTPROCESS[kind]:
        raise PolicyFileError(f"{where}: action.postprocess = {post!r}, a {kind} policy needs {POSTPROCESS[kind]!r}")
    low = _array(where, "action.low", _get(where, act, "low", list), (spec.n_actions,))
    high = _array(where, "action.high", _get(where, act, "high", list), (spec.n_actions,))
    if not np.all(low < high):
        raise PolicyFileError(f"{where}: action.low must be below action.high")

    norm = payload.get("obs_norm")
    extra: dict[str, Any] = {}
    if norm is not None:
        mean = _array(where, "obs_norm.mean", _get(where, norm, "mean", list), (spec.obs_dim,))
        var = _array(where, "obs_norm.var", _get(where, norm, "var", list), (spec.obs_dim,))
        clip = float(_get(where, norm, "clip_obs", (int, float)))
        eps = float(_get(where, norm, "epsilon", (int, float)))
        if np.any(var < 0) or not clip > 0 or not eps > 0:
            raise PolicyFileError(f"{where}: obs_norm needs var >= 0, clip_obs > 0, epsilon > 0")
        extra = dict(obs_mean=mean, obs_var=var, clip_obs=clip, epsilon=eps)
    return PolicyData(
        kind=kind, spec=spec, activation=activation, weights=tuple(weights), biases=tuple(biases), action_low=low,
        action_high=high, env_overrides=dict(payload.get("env_overrides") or {}),
        provenance=dict(payload.get("provenance") or {}), **extra,
    )


def check_spec(data: PolicyData, spec: LoopSpec, where: str) -> None:
    """PolicyFileError unless the policy was trained for ``spec``'s loop (task, signals, actions, rate)."""
    have, want = data.spec, spec
    for name in ("task", "free_dofs", "obs_labels", "action_names", "action_scale_deg"):
        if getattr(have, name) != getattr(want, name):
            raise PolicyFileError(f"{where}: trained for {name} = {getattr(have, name)!r}, the loop has {getattr(want, name)!r}")
    if not math.isclose(have.dt, want.dt, rel_tol=1e-9):
        raise PolicyFileError(f"{where}: trained for dt = {have.dt} s, the loop has dt = {want.dt} s")


# ---------------------------------------------------------------------- the laws
class MLPPolicy(Controller):
    """A trained policy as a control law: stateless, ``act`` = :meth:`PolicyData.forward`.

    ``MLPPolicy(spec, num_envs=1, *, path=None)``: ``path`` None loads the shipped policy
    ``controllers/policies/<spec.task>_<kind>.json`` (FileNotFoundError naming it when none exists).
    The file must be of this kind and trained for ``spec``'s loop (PolicyFileError otherwise).
    ``MLPPolicy.from_data(data, spec, num_envs)`` builds the same law from validated
    :class:`PolicyData` held elsewhere (a deploy artefact); ``path`` is then None.
    """

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, path: str | Path | None = None) -> None:
        super().__init__(spec, num_envs)
        p = Path(path) if path is not None else policy_path(spec.task, self.kind)
        if not p.is_file():
            raise FileNotFoundError(f"{self.kind} policy for task {spec.task!r}: no file {p} (train one with rig train)")
        self.path: Path | None = p
        self._adopt(load_policy(p), str(p))

    @classmethod
    def from_data(cls, data: PolicyData, spec: LoopSpec, num_envs: int = 1, where: str = "<policy data>") -> MLPPolicy:
        """The law running ``data`` (already validated by :func:`parse_policy`) for ``spec``'s loop."""
        law = cls.__new__(cls)
        Controller.__init__(law, spec, num_envs)
        law.path = None
        law._adopt(data, where)
        return law

    def _adopt(self, data: PolicyData, where: str) -> None:
        if data.kind != self.kind:
            raise PolicyFileError(f"{where}: holds a {data.kind} policy, not {self.kind}")
        check_spec(data, self.spec, where)
        self.data = data

    def reset(self, mask: np.ndarray | None = None) -> None:
        self._mask(mask)  # validates the mask; a feed-forward policy has no state

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.data.forward(self._check_obs(obs))


@register("ppo")
class PPOPolicy(MLPPolicy):
    """PPO policy (Gaussian mean, clipped to the action space); see :class:`MLPPolicy`."""


@register("sac")
class SACPolicy(MLPPolicy):
    """SAC policy (tanh-squashed Gaussian mean, unscaled to the action space); see :class:`MLPPolicy`."""
