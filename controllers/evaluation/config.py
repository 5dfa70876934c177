"""A comparison as configuration: the ``rig compare --config compare.toml`` file.

Every key is optional (the command's defaults apply); an unknown key, a wrong type or a value out of
range is a ValueError naming the key and what it allows.  Paths are relative to the file's folder.

```toml
tasks = ["bank_to_bank", "velocity_vector_roll"]   # rig_env.envs.TASKS (default: all)
laws = ["pid", "lqr"]                              # registered kinds (default: pid, lqr, ppo, ...)
policies = ["runs/bank_to_bank_ppo_s1/policy.json"] # law artefacts, each a contender named after its file
episodes = 24                                      # per law, task and mode, 1..100000 (default 64, quick 12)
seed = 0                                           # 0 .. 4294967295
quick = false
modes = ["nominal", "robust", "gusty"]             # default nominal and robust
params = "identified.toml"                         # a rig parameter file (rig compare --params)
backend = "ray"                                    # "local" (default) or "ray" (rig compare --backend)
address = "auto"                                   # the Ray cluster (default: a local one)
chunk_size = 16                                    # episodes per Ray task, 1..100000

[conditions]          # overrides of every mode's conditions
airspeed = [15.0, 25.0]   # m/s, low and high of the uniform draw, 0..40
turbulence = 0.01         # gusts, fraction of airspeed (1 sigma), 0..0.3
angle_noise_deg = 0.05    # joint-angle sensor noise, deg (1 sigma), 0..5
link_delay_steps = 1      # telemetry delay, control steps, 0..50

[score]               # controllers.evaluation.score.ScoreRule
min_success = 0.8     # the criterion: success rate at least this, 0..1
w_saturation = 0.5    # weights, 0..10
w_chatter = 0.25
w_stop = 0.5
rate_ref_deg_s = 350.0
stop_ref_s = 1.0
```
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from controllers.evaluation.score import ScoreRule

CONDITION_FIELDS: dict[str, tuple[str, float, float]] = {  # key -> (unit, low, high)
    "airspeed": ("m/s", 0.0, 40.0),
    "turbulence": ("fraction of airspeed", 0.0, 0.3),
    "angle_noise_deg": ("deg", 0.0, 5.0),
    "link_delay_steps": ("control steps", 0, 50),
}
MAX_EPISODES = 100_000


@dataclass(frozen=True)
class CompareConfig:
    """The parsed file: ``None`` where the file leaves the command's default."""

    tasks: list[str] | None = None
    laws: list[str] | None = None
    policies: list[str] = field(default_factory=list)
    episodes: int | None = None
    seed: int | None = None
    quick: bool | None = None
    modes: list[str] | None = None
    params: str | None = None
    conditions: dict[str, Any] = field(default_factory=dict)
    score: ScoreRule | None = None
    backend: str | None = None
    address: str | None = None
    chunk_size: int | None = None


BACKENDS = ("local", "ray")


def _names(where: str, v: Any, allowed: list[str] | None) -> list[str]:
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise ValueError(f"{where} = {v!r}: must be a non-empty list of names" + (f" from {allowed}" if allowed else ""))
    bad = [x for x in v if allowed is not None and x not in allowed]
    if bad:
        raise ValueError(f"{where}: unknown {bad}; allowed: {allowed}")
    twice = sorted({x for x in v if v.count(x) > 1})
    if twice:  # a name twice would fly twice (duplicated rows and work): refused here, naming the file's key
        raise ValueError(f"{where} = {v!r}: {', '.join(twice)} given more than once; give each once")
    return list(v)


def _number(where: str, v: Any, lo: float, hi: float, unit: str, integer: bool = False) -> float:
    ok = isinstance(v, int) if integer else isinstance(v, (int, float))
    if isinstance(v, bool) or not ok or not math.isfinite(v) or not lo <= v <= hi:
        kind = "an integer" if integer else "a number"
        bounds = f"[{lo}, {hi}]" if integer else f"[{lo:g}, {hi:g}]"  # an integer's bounds in full (4294967295, not 4.29e+09)
        raise ValueError(f"{where} = {v!r}: must be {kind} in {bounds} {unit}".rstrip())
    return v


def parse(path: str | Path, tasks: list[str], kinds: list[str], modes: list[str]) -> CompareConfig:
    """Read and check a comparison file against the known ``tasks``, law ``kinds`` and ``modes``."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except OSError as e:
        raise ValueError(f"{p}: cannot read ({e.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"{p}: not valid TOML ({e})") from None
    known = [f.name for f in fields(CompareConfig)]
    bad = sorted(set(data) - set(known))
    if bad:
        raise ValueError(f"{p}: unknown key(s) {bad}; allowed: {known}")
    out: dict[str, Any] = {}
    w = lambda k: f"{p}: {k}"  # noqa: E731
    if "tasks" in data:
        out["tasks"] = _names(w("tasks"), data["tasks"], tasks)
    if "laws" in data:
        out["laws"] = _names(w("laws"), data["laws"], kinds)
    if "modes" in data:
        out["modes"] = _names(w("modes"), data["modes"], modes)
    if "policies" in data:
        out["policies"] = [str((p.parent / x).resolve()) if not Path(x).is_absolute() else x for x in _names(w("policies"), data["policies"], None)]
    if "episodes" in data:
        out["episodes"] = int(_number(w("episodes"), data["episodes"], 1, MAX_EPISODES, "", integer=True))
    if "seed" in data:
        out["seed"] = int(_number(w("seed"), data["seed"], 0, 2**32 - 1, "", integer=True))
    if "quick" in data:
        if not isinstance(data["quick"], bool):
            raise ValueError(f"{w('quick')} = {data['quick']!r}: must be true or false")
        out["quick"] = data["quick"]
    if "params" in data:
        if not isinstance(data["params"], str):
            raise ValueError(f"{w('params')} = {data['params']!r}: must be a path (string)")
        out["params"] = str(p.parent / data["params"])
    if "backend" in data:
        if data["backend"] not in BACKENDS:
            raise ValueError(f"{w('backend')} = {data['backend']!r}: allowed {list(BACKENDS)}")
        out["backend"] = data["backend"]
    if "address" in data:
        if not isinstance(data["address"], str) or not data["address"].strip():
            raise ValueError(f"{w('address')} = {data['address']!r}: must be a Ray address (auto, HOST:PORT, ray://HOST:PORT)")
        out["address"] = data["address"]
    if "chunk_size" in data:
        out["chunk_size"] = int(_number(w("chunk_size"), data["chunk_size"], 1, MAX_EPISODES, "episodes", integer=True))
    if "conditions" in data:
        out["conditions"] = _conditions(w("conditions"), data["conditions"])
    if "score" in data:
        sc = data["score"]
        allowed = [f.name for f in fields(ScoreRule)]
        if not isinstance(sc, dict) or set(sc) - set(allowed):
            raise ValueError(f"{w('score')}: unknown key(s) {sorted(set(sc) - set(allowed)) if isinstance(sc, dict) else sc!r}; allowed: {allowed}")
        try:
            out["score"] = ScoreRule(**sc)
        except ValueError as e:
            raise ValueError(f"{p}: {e}") from None
    return CompareConfig(**out)


def _conditions(where: str, c: Any) -> dict[str, Any]:
    if not isinstance(c, dict):
        raise ValueError(f"{where}: must be a table with keys from {list(CONDITION_FIELDS)}")
    bad = sorted(set(c) - set(CONDITION_FIELDS))
    if bad:
        raise ValueError(f"{where}: unknown key(s) {bad}; allowed: {list(CONDITION_FIELDS)}")
    out: dict[str, Any] = {}
    for k, v in c.items():
        unit, lo, hi = CONDITION_FIELDS[k]
        if k == "airspeed":
            if not (isinstance(v, list) and len(v) == 2):
                raise ValueError(f"{where}.airspeed = {v!r}: must be [low, high] in m/s within [0, 40]")
            a, b = (_number(f"{where}.airspeed", x, lo, hi, unit) for x in v)
            if a > b:
                raise ValueError(f"{where}.airspeed = {v!r}: low must not exceed high")
            out[k] = (float(a), float(b))
        else:
            out[k] = _number(f"{where}.{k}", v, lo, hi, unit, integer=k == "link_delay_steps")
    return out
