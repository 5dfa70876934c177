"""Artefact kinds ``"ppo"`` and ``"sac"``: a trained policy file carried inside a deploy artefact.

The artefact's arrays are the policy file's arrays (float64 copies of its float32 values, bit for
bit); its ``params`` hold the rest of the policy file verbatim (format, loop spec, activation,
normalisation constants, action post-processing, the training provenance and the policy file's own
SHA-256).  Loading reassembles the policy file from the two, validates it with
:func:`controllers.laws.rl.parse_policy` (fields, shapes, finiteness) and checks that it hashes to the
SHA-256 it claims, so the weights that fly are provably the ones training shipped.  The runtime is
:class:`controllers.laws.rl.PPOPolicy` / :class:`~controllers.laws.rl.SACPolicy` itself (one MLP forward pass,
:meth:`controllers.laws.rl.PolicyData.forward`); nothing imports torch or stable-baselines3.

| arrays | shape | policy file field |
|---|---|---|
| ``weight_<i>``, ``bias_<i>`` | (out, in), (out,) | ``network.layers[i]`` (i = 0 .. n_layers - 1, the last is the output layer) |
| ``obs_mean``, ``obs_var`` | (obs_dim,) | ``obs_norm.mean``, ``obs_norm.var`` (absent when trained without VecNormalize) |
| ``action_low``, ``action_high`` | (n_actions,) | ``action.low``, ``action.high`` |

| params | content |
|---|---|
| ``policy`` | the policy file without the arrays above: ``format``, ``format_version``, ``kind``, ``loop_spec``, ``env_overrides``, ``network.activation``, ``obs_norm.clip_obs`` / ``epsilon`` (or null), ``action.postprocess``, ``provenance``, ``sha256`` |
| ``policy_file`` | name of the file it was exported from (informative) |

A law built from an artefact keeps the reassembled policy file as ``law.policy_source`` (payload,
file name), so it exports again to the same content without the file.
"""

from __future__ import annotations

import copy
import json
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from controllers.laws.base import Controller, LoopSpec
from controllers.deploy.artefact import register_kind
from controllers.laws.rl import MLPPolicy, PPOPolicy, SACPolicy, checksum, load_policy, parse_policy

RUNTIMES: dict[str, type[MLPPolicy]] = {"ppo": PPOPolicy, "sac": SACPolicy}
_PARAMS = {"policy", "policy_file"}
_LAYER = re.compile(r"(weight|bias)_(\d+)$")


def split_policy(payload: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A decoded, valid policy file as (header without arrays, arrays by artefact name); see the module tables."""
    data = parse_policy(dict(payload), "policy file")
    header = copy.deepcopy(dict(payload))
    header["network"] = {k: v for k, v in header["network"].items() if k != "layers"}
    header["action"] = {k: v for k, v in header["action"].items() if k not in ("low", "high")}
    arrays: dict[str, np.ndarray] = {"action_low": data.action_low, "action_high": data.action_high}
    if header.get("obs_norm") is not None:
        header["obs_norm"] = {k: v for k, v in header["obs_norm"].items() if k not in ("mean", "var")}
        arrays.update(obs_mean=data.obs_mean, obs_var=data.obs_var)
    for i, (W, b) in enumerate(zip(data.weights, data.biases)):
        arrays[f"weight_{i}"], arrays[f"bias_{i}"] = W, b
    return header, arrays


def join_policy(header: Any, arrays: Mapping[str, np.ndarray], where: str) -> dict[str, Any]:
    """The policy file that :func:`split_policy` split (ValueError naming a missing, unknown or misnamed part)."""
    if not isinstance(header, dict) or not all(isinstance(header.get(k), dict) for k in ("network", "action")):
        raise ValueError(f"{where}: params.policy must be an object with 'network' and 'action' objects")
    layers = sorted(int(m.group(2)) for name in arrays if (m := _LAYER.match(name)) and m.group(1) == "weight")
    norm = header.get("obs_norm")
    want = {"action_low", "action_high"} | ({"obs_mean", "obs_var"} if norm is not None else set())
    want |= {f"{p}_{i}" for i in range(len(layers)) for p in ("weight", "bias")}
    if not layers or layers != list(range(len(layers))) or set(arrays) != want:
        raise ValueError(f"{where}: arrays {sorted(arrays)}; expected {sorted(want)} (weight_i, bias_i for i = 0 .. n_layers - 1)")
    payload = copy.deepcopy(header)
    payload["network"]["layers"] = [{"weight": arrays[f"weight_{i}"].tolist(), "bias": arrays[f"bias_{i}"].tolist()} for i in layers]
    payload["action"].update(low=arrays["action_low"].tolist(), high=arrays["action_high"].tolist())
    if norm is not None:
        if not isinstance(norm, dict):
            raise ValueError(f"{where}: params.policy.obs_norm must be an object or null")
        payload["obs_norm"].update(mean=arrays["obs_mean"].tolist(), var=arrays["obs_var"].tolist())
    return payload


def to_arrays(law: Controller) -> dict[str, Any]:
    """A PPO/SAC law as artefact data: its policy file (or the policy it was itself loaded from) split."""
    if not isinstance(law, MLPPolicy) or law.kind not in RUNTIMES:
        raise TypeError(f"kinds {sorted(RUNTIMES)} export a controllers.laws.rl policy law; got {type(law).__name__}")
    source = getattr(law, "policy_source", None)
    if source is None:
        if law.path is None:
            raise ValueError(f"{law.kind}: the law has neither a policy file nor an artefact it came from")
        payload = json.loads(law.path.read_text(encoding="utf-8"))
        if not _same(load_policy(law.path), law.data):
            raise ValueError(f"{law.path}: the policy file changed since the law was loaded; reload it before exporting")
        source = (payload, law.path.name)
    header, arrays = split_policy(source[0])
    return {**arrays, "policy": header, "policy_file": source[1]}


def _same(a: Any, b: Any) -> bool:
    pairs = list(zip(a.weights + a.biases, b.weights + b.biases)) + [(a.action_low, b.action_low), (a.action_high, b.action_high)]
    return (len(a.weights) == len(b.weights) and all(x.shape == y.shape and np.array_equal(x, y) for x, y in pairs)
            and a.activation == b.activation and a.kind == b.kind and (a.obs_mean is None) == (b.obs_mean is None)
            and (a.obs_mean is None or (np.array_equal(a.obs_mean, b.obs_mean) and np.array_equal(a.obs_var, b.obs_var))))


def _from_arrays(kind: str) -> Any:
    def from_arrays(data: Mapping[str, Any], spec: LoopSpec) -> MLPPolicy:
        extra = sorted(k for k, v in data.items() if not isinstance(v, np.ndarray) and k not in _PARAMS)
        if extra or not isinstance(data.get("policy_file"), str):
            raise ValueError(f"{kind}: params must be exactly {sorted(_PARAMS)} (policy_file a string); unexpected {extra}")
        header = data["policy"]
        payload = join_policy(header, {k: v for k, v in data.items() if isinstance(v, np.ndarray)}, kind)
        claimed = header.get("sha256")
        payload["sha256"] = checksum(payload)  # validate the structure first, so a shape error is named as such
        policy = parse_policy(payload, kind)
        if payload["sha256"] != claimed:
            raise ValueError(f"{kind}: the weights are not those of the policy file they name (its sha256 {str(claimed)[:16]}..., "
                             f"the arrays hash to {payload['sha256'][:16]}...)")
        law = RUNTIMES[kind].from_data(policy, spec, 1, kind)
        law.policy_source = (dict(payload), data["policy_file"])  # re-exportable without the file
        return law

    return from_arrays


for _kind in RUNTIMES:
    register_kind(_kind, to_arrays, _from_arrays(_kind))
