"""``rig-deploy convert-policy OLD NEW``: a policy file of the earlier separate format to a rig-law artefact.

Before every law shared the one artefact format (:mod:`controllers.laws.artefact`), ``rig train``
wrote policies as their own JSON format (``"format": "rig_env.rl_policy"``, version 1: ``loop_spec``,
``env_overrides``, ``network.layers`` as nested lists of float32 values, ``obs_norm``, ``action``,
``provenance`` and its own ``sha256``).  :func:`load` refuses such a file with the command that
converts it; this module is that conversion, numpy and json only, and recomputes nothing:

| old field | artefact |
|---|---|
| ``kind`` | ``kind`` (``"ppo"``, ``"sac"``) |
| ``loop_spec`` | ``spec`` (no task options) |
| ``network.layers[i].weight``, ``.bias`` | arrays ``weight_<i>``, ``bias_<i>``: the float64 values the JSON decimals read as, bit for bit what the earlier reader gave the runtime (the file wrote each float32 value as its shortest decimal) |
| ``obs_norm.mean``, ``.var`` | arrays ``obs_mean``, ``obs_var``; ``clip_obs``, ``epsilon`` -> param ``obs_norm`` |
| ``action.low``, ``.high``, ``.postprocess`` | arrays ``action_low``, ``action_high``; param ``postprocess`` |
| ``network.activation`` | param ``activation`` |
| ``provenance``, ``env_overrides`` | ``provenance`` (the training record) with ``env_overrides`` and ``converted_from`` (old format, its sha256, file name) |
| -- | ``sensors``: :data:`~controllers.laws.artefact.DEFAULT_SENSORS` with the file's ``env_overrides`` of those names; ``limits``: the defaults |

The old file's checksum is verified first (a damaged file is refused, not converted).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from controllers.laws.artefact import DEFAULT_SENSORS, OLD_POLICY_FORMAT, Artefact, ArtefactError, artefact_class, default_limits, save
from controllers.laws.base import LoopSpec

OLD_FORMAT_VERSION = 1


def _old_checksum(payload: dict[str, Any]) -> str:
    body = {k: v for k, v in payload.items() if k != "sha256"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False).encode("utf-8")).hexdigest()


def _floats(where: str, name: str, value: Any) -> np.ndarray:
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ArtefactError(f"{where}: {name} is not a numeric array") from None
    if a.ndim == 0 or not np.all(np.isfinite(a)):
        raise ArtefactError(f"{where}: {name} is not a finite numeric array")
    return a


def old_policy_to_artefact(payload: Any, where: str = "<old policy>") -> Artefact:
    """The artefact holding the same law as a decoded old-format policy file (ArtefactError naming what failed)."""
    if not isinstance(payload, dict) or payload.get("format") != OLD_POLICY_FORMAT:
        raise ArtefactError(f"{where}: not an old-format policy file (format {OLD_POLICY_FORMAT!r})")
    if payload.get("format_version") != OLD_FORMAT_VERSION:
        raise ArtefactError(f"{where}: format_version = {payload.get('format_version')!r}; the conversion reads {OLD_FORMAT_VERSION}")
    if payload.get("sha256") != _old_checksum(payload):
        raise ArtefactError(f"{where}: sha256 does not match the content (file modified or damaged); not converted")
    try:
        kind, ls, net, act = payload["kind"], payload["loop_spec"], payload["network"], payload["action"]
        spec = LoopSpec(task=str(ls["task"]), free_dofs=tuple(ls["free_dofs"]), obs_labels=tuple(ls["obs_labels"]),
                        action_names=tuple(ls["action_names"]), dt=float(ls["dt"]),
                        airspeed_range=tuple(float(v) for v in ls["airspeed_range"]), action_scale_deg=float(ls["action_scale_deg"]))
        data: dict[str, Any] = {"activation": net["activation"], "postprocess": act["postprocess"], "obs_norm": None,
                                "action_low": _floats(where, "action.low", act["low"]), "action_high": _floats(where, "action.high", act["high"])}
        for i, layer in enumerate(net["layers"]):
            data[f"weight_{i}"] = _floats(where, f"network.layers[{i}].weight", layer["weight"])
            data[f"bias_{i}"] = _floats(where, f"network.layers[{i}].bias", layer["bias"])
        norm = payload.get("obs_norm")
        if norm is not None:
            data.update(obs_mean=_floats(where, "obs_norm.mean", norm["mean"]), obs_var=_floats(where, "obs_norm.var", norm["var"]),
                        obs_norm={"clip_obs": norm["clip_obs"], "epsilon": norm["epsilon"]})
        overrides = dict(payload.get("env_overrides") or {})
        prov = dict(payload.get("provenance") or {})
    except ArtefactError:
        raise
    except ValueError as e:  # a number that is not one, or LoopSpec refusing a field (its message names it)
        raise ArtefactError(f"{where}: loop_spec: {e}") from None
    except (KeyError, TypeError, AttributeError) as e:
        raise ArtefactError(f"{where}: old-format policy file incomplete or malformed ({e!r})") from None
    sensors = {k: overrides.get(k, v) for k, v in DEFAULT_SENSORS.items()}
    prov.update(env_overrides=overrides, converted_from={"format": OLD_POLICY_FORMAT, "format_version": OLD_FORMAT_VERSION,
                                                         "sha256": payload["sha256"], "file": Path(where).name})
    art = Artefact(str(kind), spec, sensors, default_limits(spec), data, prov)
    try:
        artefact_class(art.kind).from_data(art.data, spec)  # the policy runtime validates names, shapes, the layer chain
    except ValueError as e:
        raise ArtefactError(f"{where}: {e}") from None
    return art


def convert_policy_file(old: str | os.PathLike, new: str | os.PathLike, key: bytes | None = None, overwrite: bool = True) -> str:
    """Convert the old-format policy file ``old`` to the artefact ``new``; returns its SHA-256."""
    p = Path(old)
    try:
        payload = json.loads(p.read_text(encoding="utf-8"))
    except OSError as e:
        raise ArtefactError(f"{p}: cannot read ({e.strerror})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ArtefactError(f"{p}: not a readable JSON policy file (truncated or corrupted?): {e}") from None
    return save(old_policy_to_artefact(payload, str(p)), new, key, overwrite=overwrite)
