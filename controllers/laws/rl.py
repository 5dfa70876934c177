"""RL laws (PPO, SAC) run from plain data with numpy only: the trained policy as a rig-law artefact.

``rig train`` writes the policy as an artefact of kind ``"ppo"`` or ``"sac"`` (:mod:`controllers.laws.artefact`,
the one file format of every law; :func:`controllers.design.rl_export.export_sb3` reads the weights off
the trained model); this module runs it.  Nothing here imports torch or stable-baselines3, and nothing
is unpickled: a policy file is data, never code.

    law = make_controller("ppo", LoopSpec.from_env(env), num_envs=env.num_envs)        # shipped policy
    law = make_controller("sac", spec, 64, path="runs/vvr_sac/policy.json")              # any trained policy

The runtime reproduces SB3's ``model.predict(obs, deterministic=True)`` (to float32 rounding):

| stage | PPO (``ActorCriticPolicy``) | SAC (``SACPolicy`` actor) |
|---|---|---|
| 1. observation | cast to float32 (what the SB3 adapter hands the policy) | same |
| 2. VecNormalize (if trained with it) | ``clip((o - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)``, cast to float32 | same |
| 3. hidden layers | ``h = act(h @ W.T + b)``, ``act`` = tanh or relu as trained | same |
| 4. output layer | Gaussian mean ``mu = h @ W.T + b`` | ``mu = h @ W.T + b``, then ``tanh(mu)`` |
| 5. to the action space | ``clip(mu, low, high)`` | ``low + (tanh(mu) + 1) (high - low) / 2`` |

The law's data (``to_data`` / ``from_data``, stored in the artefact):

| name | stored as | content |
|---|---|---|
| ``weight_<i>``, ``bias_<i>`` | arrays, (out, in) and (out,) | layer i = 0 .. n - 1 (the last is the output layer), torch's ``nn.Linear`` layout; float32 values held as float64 |
| ``obs_mean``, ``obs_var`` | arrays, (obs_dim,) | SB3's VecNormalize statistics (absent when trained without it) |
| ``action_low``, ``action_high`` | arrays, (n_actions,) | the action space |
| ``activation`` | param | ``"tanh"`` or ``"relu"`` |
| ``postprocess`` | param | ``"clip"`` (PPO) or ``"tanh_unscale"`` (SAC, and PPO trained with ``squash_output``: gSDE's tanh-squashed actions) |
| ``obs_norm`` | param | ``{"clip_obs", "epsilon"}`` of VecNormalize, or null |

Loading checks all of it (names, shapes, finite values, that the layers chain from obs_dim to
n_actions) and raises a ValueError naming the entry; :class:`MLPPolicy` also refuses a file of
another kind or trained for another loop (:class:`PolicyFileError`, naming the file and the field).
The training record (command, hyperparameters, curve, final evaluation, versions, ``env_overrides``)
is the artefact's ``provenance`` (``law.provenance``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from controllers.laws.artefact import ArtefactError, load
from controllers.laws.base import Controller, LoopSpec, register

POLICY_DIR = Path(__file__).resolve().parents[1] / "policies"
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda x: np.maximum(x, 0.0)}
POSTPROCESS = {"ppo": "clip", "sac": "tanh_unscale"}
"""Each kind's default output stage."""
ALLOWED_POSTPROCESS = {"ppo": ("clip", "tanh_unscale"), "sac": ("tanh_unscale",)}
"""What each kind may use: a PPO policy trained with SB3's ``squash_output`` (gSDE) ends in tanh, as SAC's does."""
_LAYER = re.compile(r"(weight|bias)_(\d+)$")
_PARAMS = {"activation", "postprocess", "obs_norm"}


class PolicyFileError(ArtefactError):
    """A policy file that cannot be flown here: of another kind, or trained for another loop."""


def policy_path(task: str, kind: str) -> Path:
    """Where the shipped policy of ``kind`` for ``task`` lives: ``controllers/policies/<task>_<kind>.json``."""
    return POLICY_DIR / f"{task}_{kind}.json"


def rowwise(h: np.ndarray, WT: np.ndarray) -> np.ndarray:
    """``h @ WT`` computed row by row (a stack of (1, k) products): each row's result is bit for bit the same
    whatever the batch it sits in (one environment on the rig, 64 in a comparison, a chunk of them on Ray).
    A plain ``h @ WT`` is one BLAS call whose kernels, picked by the batch's shape, round differently in the
    last bit; this costs about 1.3 times as much."""
    return np.matmul(h[:, None, :], WT)[:, 0, :]


@dataclass(frozen=True)
class PolicyData:
    """A validated policy: everything the runtime needs, as float64 arrays (of float32 values for the network)."""

    kind: str
    activation: str
    weights: tuple[np.ndarray, ...]  # (out, in) each
    biases: tuple[np.ndarray, ...]  # (out,) each
    action_low: np.ndarray  # (n_actions,)
    action_high: np.ndarray  # (n_actions,)
    obs_mean: np.ndarray | None = None  # (obs_dim,)
    obs_var: np.ndarray | None = None  # (obs_dim,)
    clip_obs: float = math.inf
    epsilon: float = 1e-8
    post: str | None = None  # None: the kind's default (POSTPROCESS)

    @property
    def postprocess(self) -> str:
        return self.post or POSTPROCESS[self.kind]

    def forward(self, obs: np.ndarray) -> np.ndarray:
        """Actions (m, n_actions) float64 for observations (m, obs_dim): stages 1-5 of the module table."""
        h = np.asarray(obs, dtype=np.float32)
        if self.obs_mean is not None:
            h = np.clip((h - self.obs_mean) / np.sqrt(self.obs_var + self.epsilon), -self.clip_obs, self.clip_obs)
            h = h.astype(np.float32)
        h = h.astype(np.float64)
        act = ACTIVATIONS[self.activation]
        for W, b in zip(self.weights[:-1], self.biases[:-1]):
            h = act(rowwise(h, W.T) + b)
        mu = rowwise(h, self.weights[-1].T) + self.biases[-1]
        if self.postprocess == "clip":
            return np.clip(mu, self.action_low, self.action_high)
        return self.action_low + 0.5 * (np.tanh(mu) + 1.0) * (self.action_high - self.action_low)

    def to_data(self) -> dict[str, Any]:
        """As the artefact stores it (module table)."""
        d: dict[str, Any] = {"activation": self.activation, "postprocess": self.postprocess, "obs_norm": None,
                             "action_low": self.action_low.copy(), "action_high": self.action_high.copy()}
        for i, (W, b) in enumerate(zip(self.weights, self.biases)):
            d[f"weight_{i}"], d[f"bias_{i}"] = W.copy(), b.copy()
        if self.obs_mean is not None:
            d.update(obs_mean=self.obs_mean.copy(), obs_var=self.obs_var.copy(), obs_norm={"clip_obs": self.clip_obs, "epsilon": self.epsilon})
        return d


# ---------------------------------------------------------------------- data -> policy
def _array(where: str, name: str, value: Any, shape: tuple[int | None, ...]) -> np.ndarray:
    if not isinstance(value, np.ndarray) or not (np.issubdtype(value.dtype, np.floating) or np.issubdtype(value.dtype, np.integer)):
        raise ValueError(f"{where}: {name} is not a numeric array")
    a = value.astype(np.float64)
    if a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape)):
        raise ValueError(f"{where}: {name} has shape {a.shape}, expected {shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{where}: {name} has non-finite value(s)")
    return a


def parse_data(kind: str, data: Mapping[str, Any], spec: LoopSpec) -> PolicyData:
    """Validate a ``kind`` policy's data (module table) for ``spec``'s observation and action sizes; ValueError naming the entry."""
    where = kind
    extra = sorted(k for k, v in data.items() if not isinstance(v, np.ndarray) and k not in _PARAMS)
    missing = sorted(_PARAMS - set(data))
    if extra or missing:
        hint = " (an artefact exported before policies became rig-law artefacts: export it again)" if "policy" in extra else ""
        raise ValueError(f"{where}: params {sorted(k for k in data if not isinstance(data[k], np.ndarray))}; expected {sorted(_PARAMS)}{hint}")
    activation = data.get("activation")
    if activation not in ACTIVATIONS:
        raise ValueError(f"{where}: activation = {activation!r}, expected one of {sorted(ACTIVATIONS)}")
    post = data.get("postprocess")
    if post not in ALLOWED_POSTPROCESS[kind]:
        need = " or ".join(repr(p) for p in ALLOWED_POSTPROCESS[kind])
        raise ValueError(f"{where}: postprocess = {post!r}, a {kind} policy needs {need}")
    norm = data.get("obs_norm")
    arrays = {k for k, v in data.items() if isinstance(v, np.ndarray)}
    n = len([k for k in arrays if (m := _LAYER.match(k)) and m.group(1) == "weight"])
    want = {"action_low", "action_high"} | ({"obs_mean", "obs_var"} if norm is not None else set())
    want |= {f"{p}_{i}" for i in range(n) for p in ("weight", "bias")}
    if n == 0 or arrays != want:
        raise ValueError(f"{where}: arrays {sorted(arrays)}; expected {sorted(want)} (weight_i, bias_i for i = 0 .. n_layers - 1)")
    weights, biases, n_in = [], [], spec.obs_dim
    for i in range(n):
        W = _array(where, f"weight_{i}", data[f"weight_{i}"], (None, n_in))
        biases.append(_array(where, f"bias_{i}", data[f"bias_{i}"], (W.shape[0],)))
        weights.append(W)
        n_in = W.shape[0]
    if n_in != spec.n_actions:
        raise ValueError(f"{where}: the last layer has {n_in} outputs, the loop has {spec.n_actions} actions")
    low = _array(where, "action_low", data["action_low"], (spec.n_actions,))
    high = _array(where, "action_high", data["action_high"], (spec.n_actions,))
    if not np.all(low < high):
        raise ValueError(f"{where}: action_low must be below action_high")
    extra_norm: dict[str, Any] = {}
    if norm is not None:
        if not isinstance(norm, dict) or set(norm) != {"clip_obs", "epsilon"} or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in norm.values()):
            raise ValueError(f"{where}: obs_norm = {norm!r}: expected null or numbers clip_obs, epsilon")
        mean = _array(where, "obs_mean", data["obs_mean"], (spec.obs_dim,))
        var = _array(where, "obs_var", data["obs_var"], (spec.obs_dim,))
        clip, eps = float(norm["clip_obs"]), float(norm["epsilon"])
        if np.any(var < 0) or not clip > 0 or not eps > 0:
            raise ValueError(f"{where}: obs_norm needs var >= 0, clip_obs > 0, epsilon > 0")
        extra_norm = dict(obs_mean=mean, obs_var=var, clip_obs=clip, epsilon=eps)
    return PolicyData(kind=kind, activation=activation, weights=tuple(weights), biases=tuple(biases), action_low=low,
                      action_high=high, post=post, **extra_norm)


def check_spec(have: LoopSpec, want: LoopSpec, where: str) -> None:
    """PolicyFileError unless a policy trained for ``have`` flies ``want``'s loop (task, signals, actions, rate)."""
    for name in ("task", "free_dofs", "obs_labels", "action_names", "action_scale_deg"):
        if getattr(have, name) != getattr(want, name):
            raise PolicyFileError(f"{where}: trained for {name} = {getattr(have, name)!r}, the loop has {getattr(want, name)!r}")
    if not math.isclose(have.dt, want.dt, rel_tol=1e-9):
        raise PolicyFileError(f"{where}: trained for dt = {have.dt} s, the loop has dt = {want.dt} s")


# ---------------------------------------------------------------------- the laws
class MLPPolicy(Controller):
    """A trained policy as a control law: stateless, ``act`` = :meth:`PolicyData.forward`.

    ``MLPPolicy(spec, num_envs=1, *, path=None)`` loads the artefact at ``path``; None: the shipped
    policy ``controllers/policies/<spec.task>_<kind>.json`` (FileNotFoundError naming it when none
    exists).  The file must hold a policy of this kind trained for ``spec``'s loop
    (:class:`PolicyFileError` otherwise).  ``law.provenance`` is the file's training record.
    ``MLPPolicy.from_data(data, spec, num_envs)`` builds the same law from artefact data; ``path`` is then None.
    """

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, path: str | Path | None = None) -> None:
        super().__init__(spec, num_envs)
        p = Path(path) if path is not None else policy_path(spec.task, self.kind)
        if not p.is_file():
            raise FileNotFoundError(f"{self.kind} policy for task {spec.task!r}: no file {p} (train one with rig train)")
        art = load(p)
        if art.kind != self.artefact_kind:
            what = f"a {art.kind} policy" if art.kind in POSTPROCESS else f"a {art.kind!r} law, not a policy"
            raise PolicyFileError(f"{p}: holds {what}, not {self.kind}")
        check_spec(art.spec, spec, str(p))
        self.path: Path | None = p
        self.data = parse_data(self.kind, art.data, spec)
        self.provenance: dict[str, Any] = dict(art.provenance)
        self.artefact_source = {"sha256": art.sha256, "provenance": art.provenance}

    @classmethod
    def from_data(cls, data: Mapping[str, Any], spec: LoopSpec, num_envs: int = 1) -> MLPPolicy:
        """The law running the artefact data ``data`` (module table) for ``spec``'s loop."""
        law = cls.__new__(cls)
        Controller.__init__(law, spec, num_envs)
        law.path, law.provenance = None, {}
        law.data = parse_data(cls.kind, data, spec)
        return law

    def to_data(self) -> dict[str, Any]:
        return self.data.to_data()

    def reset(self, mask: np.ndarray | None = None) -> None:
        self._mask(mask)  # validates the mask; a feed-forward policy has no state

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.data.forward(self._check_obs(obs))


@register("ppo")
class PPOPolicy(MLPPolicy):
    """PPO policy (Gaussian mean, clipped to the action space); see :class:`MLPPolicy`."""

    artefact_kind = "ppo"


@register("sac")
class SACPolicy(MLPPolicy):
    """SAC policy (tanh-squashed Gaussian mean, unscaled to the action space); see :class:`MLPPolicy`."""

    artefact_kind = "sac"
