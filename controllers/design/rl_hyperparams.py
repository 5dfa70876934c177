"""``rig train``'s settings per (algorithm, task): TOML files, read with tomllib and checked field by field.

The package ships one file per algorithm (``controllers/design/hyperparams/ppo.toml``, ``sac.toml``);
``rig train --hyperparams FILE`` reads a user's own file of the same shape instead:

.. code-block:: toml

    [defaults]                       # every task starts from these
    num_envs = 256                   # environments in the training batch
    timesteps = 3_000_000            # budget, environment steps
    eval_every = 200_000             # environment steps between evaluations
    normalize = true                 # VecNormalize of observations (rewards never)
    clip_obs = 10.0
    [defaults.algo]                  # keyword arguments of SB3's PPO / SAC
    n_steps = 64
    [defaults.algo.policy_kwargs]
    net_arch = [64, 64]

    [velocity_vector_roll]           # one table per task: overrides the defaults key by key
    source = "what these settings are based on"
    error_reset = { entry = "roll_error", bound = 1.0 }   # optional curriculum (rl_callbacks.ErrorReset)
    env = { episode_seconds = 8.0 }                        # optional RigEnvConfig overrides

A task without a table trains on the defaults (a note says so).  Unknown keys, wrong types and values
out of range raise :class:`HyperparamError` naming the file, the table, the field and what is allowed.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

HYPERPARAM_DIR = Path(__file__).resolve().parent / "hyperparams"
ALGOS = ("ppo", "sac")


class HyperparamError(ValueError):
    """A settings file that cannot be used: the message names the file, table and field."""


def _pos_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v > 0


def _nonneg_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _pos(v: Any) -> bool:
    return _num(v) and v > 0


def _frac(v: Any) -> bool:
    return _num(v) and 0.0 < v <= 1.0


def _nonneg(v: Any) -> bool:
    return _num(v) and v >= 0


def _bool(v: Any) -> bool:
    return isinstance(v, bool)


def _layers(v: Any) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(_pos_int(x) for x in v)


def _net_arch(v: Any) -> bool:
    return _layers(v) or (isinstance(v, dict) and set(v) == {"pi", "vf"} and all(_layers(x) for x in v.values()))


Check = tuple[Callable[[Any], bool], str]
RUN_FIELDS: dict[str, Check] = {
    "source": (lambda v: isinstance(v, str), "a string"),
    "num_envs": (_pos_int, "a positive integer"),
    "timesteps": (_pos_int, "a positive integer"),
    "eval_every": (_pos_int, "a positive integer"),
    "normalize": (_bool, "true or false"),
    "clip_obs": (_pos, "a positive number"),
    "acting_surfaces": (_bool, "true or false"),
    "error_reset": (lambda v: isinstance(v, dict), "a table {entry = OBSERVATION_LABEL, bound = POSITIVE_NUMBER}"),
    "env": (lambda v: isinstance(v, dict), "a table of RigEnvConfig fields"),
    "algo": (lambda v: isinstance(v, dict), "a table of the algorithm's keyword arguments"),
}
_COMMON_ALGO: dict[str, Check] = {
    "learning_rate": (_pos, "a positive number"),
    "gamma": (_frac, "a number in (0, 1]"),
    "batch_size": (_pos_int, "a positive integer"),
    "use_sde": (_bool, "true or false"),
    "sde_sample_freq": (lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= -1, "an integer >= -1"),
    "policy_kwargs": (lambda v: isinstance(v, dict), "a table"),
}
ALGO_FIELDS: dict[str, dict[str, Check]] = {
    "ppo": _COMMON_ALGO | {
        "n_steps": (_pos_int, "a positive integer"),
        "n_epochs": (_pos_int, "a positive integer"),
        "gae_lambda": (_frac, "a number in (0, 1]"),
        "clip_range": (_pos, "a positive number"),
        "normalize_advantage": (_bool, "true or false"),
        "ent_coef": (_nonneg, "a number >= 0"),
        "vf_coef": (_nonneg, "a number >= 0"),
        "max_grad_norm": (_pos, "a positive number"),
        "target_kl": (_pos, "a positive number"),
    },
    "sac": _COMMON_ALGO | {
        "buffer_size": (_pos_int, "a positive integer"),
        "learning_starts": (_nonneg_int, "an integer >= 0"),
        "tau": (_frac, "a number in (0, 1]"),
        "train_freq": (_pos_int, "a positive integer"),
        "gradient_steps": (_pos_int, "a positive integer"),
        "ent_coef": (lambda v: v == "auto" or (isinstance(v, str) and v.startswith("auto_")) or _pos(v), '"auto", "auto_X" or a positive number'),
        "target_update_interval": (_pos_int, "a positive integer"),
    },
}
ACTIVATIONS = ("tanh", "relu")
POLICY_FIELDS: dict[str, Check] = {
    "net_arch": (_net_arch, "a list of positive layer widths, or a table {pi = [...], vf = [...]}"),
    "log_std_init": (_num, "a number"),
    "activation_fn": (lambda v: v in ACTIVATIONS, f"one of {list(ACTIVATIONS)}"),
    "ortho_init": (_bool, "true or false"),
    "squash_output": (_bool, "true or false (PPO with use_sde only: tanh-squashed actions)"),
}
REQUIRED = ("num_envs", "timesteps", "eval_every", "normalize", "clip_obs")


@dataclass(frozen=True)
class RunSettings:
    """One (algorithm, task)'s training settings: the defaults merged with the task's table, checked."""

    algo: str
    task: str
    file: str
    source: str
    num_envs: int
    timesteps: int
    eval_every: int
    normalize: bool
    clip_obs: float
    error_reset: tuple[str, float] | None = None
    acting_surfaces: bool = False
    env: Mapping[str, Any] = field(default_factory=dict)
    algo_kwargs: Mapping[str, Any] = field(default_factory=dict)

    def sb3_kwargs(self) -> dict[str, Any]:
        """``algo_kwargs`` as SB3 takes them (activation names as torch classes)."""
        import torch

        kw = {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in self.algo_kwargs.items()}
        pk = kw.get("policy_kwargs")
        if pk and "activation_fn" in pk:
            pk["activation_fn"] = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[pk["activation_fn"]]
        return kw

    def record(self) -> dict[str, Any]:
        """JSON-able, for the policy's provenance."""
        return {"file": self.file, "source": self.source, "num_envs": self.num_envs, "timesteps": self.timesteps,
                "eval_every": self.eval_every, "normalize": self.normalize, "clip_obs": self.clip_obs,
                "acting_surfaces": self.acting_surfaces, "error_reset": list(self.error_reset) if self.error_reset else None, "env": dict(self.env),
                "algo_kwargs": _plain(self.algo_kwargs)}


def _plain(v: Any) -> Any:
    if isinstance(v, Mapping):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v


def _check(table: Mapping[str, Any], fields: Mapping[str, Check], where: str) -> None:
    for k, v in table.items():
        if k not in fields:
            raise HyperparamError(f"{where}.{k}: unknown field; allowed: {sorted(fields)}")
        ok, allowed = fields[k]
        if not ok(v):
            raise HyperparamError(f"{where}.{k} = {v!r}: must be {allowed}")


def default_file(algo: str) -> Path:
    """The shipped settings file of ``algo``."""
    if algo not in ALGOS:
        raise HyperparamError(f"algo {algo!r}: allowed {list(ALGOS)}")
    return HYPERPARAM_DIR / f"{algo}.toml"


def load_file(path: Path) -> dict[str, Any]:
    """The file's tables, parsed (a TOML syntax error names the file)."""
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise HyperparamError(f"{path}: no such settings file") from None
    except tomllib.TOMLDecodeError as exc:
        raise HyperparamError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise HyperparamError(f"{path}: not a text file (TOML is UTF-8 text)") from None
    except IsADirectoryError:
        raise HyperparamError(f"{path}: a folder, not a settings file") from None


def nested(overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted keys as tables: ``{"algo.learning_rate": 1e-3, "num_envs": 16}`` -> ``{"algo": {"learning_rate": 1e-3}, "num_envs": 16}``."""
    out: dict[str, Any] = {}
    for key, v in overrides.items():
        *path, last = str(key).split(".")
        node = out
        for p in path:
            node = node.setdefault(p, {})
            if not isinstance(node, dict):
                raise HyperparamError(f"override {key!r}: {p!r} is a value, not a table")
        node[last] = v
    return out


def _merge(a: Mapping[str, Any], b: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), Mapping) else v
    return out


def settings(algo: str, task: str, path: Path | None = None, overrides: Mapping[str, Any] | None = None) -> RunSettings:
    """The checked settings of ``task`` for ``algo`` from ``path`` (default: the shipped file); ``overrides``:
    fields over the task's table, dotted keys for nested ones (``"algo.learning_rate"``; a sweep's grid point),
    checked like the file's (a :class:`HyperparamError` names the field)."""
    path = Path(path) if path is not None else default_file(algo)
    if algo not in ALGOS:
        raise HyperparamError(f"algo {algo!r}: allowed {list(ALGOS)}")
    data = load_file(path)
    for name, table in data.items():  # every table is checked, not only the one used: a typo elsewhere is still a typo
        if not isinstance(table, dict):
            raise HyperparamError(f"{path}: top-level key {name!r} = {table!r}: expected a table ([defaults] or [TASK])")
        _check_table(algo, table, f"{path} [{name}]")
    from rig_env.envs.tasks import TASKS

    unknown = sorted(set(data) - set(TASKS) - {"defaults"})
    if unknown:
        raise HyperparamError(f"{path}: table(s) {unknown}: not a task; allowed: ['defaults'] + {sorted(TASKS)}")
    base, own = data.get("defaults", {}), data.get(task)
    if own is None:
        print(f"note: {path.name} has no [{task}] table: its [defaults]", flush=True)
        own = {"source": f"[defaults] of {path.name}, untuned for {task}"}
    if overrides:
        extra = nested(overrides)
        _check_table(algo, extra, f"{path} [{task}] overrides")
        own = _merge(own, extra)
    merged = {**base, **own}
    algo_kw = {**base.get("algo", {}), **own.get("algo", {})}
    pk = {**base.get("algo", {}).get("policy_kwargs", {}), **own.get("algo", {}).get("policy_kwargs", {})}
    if pk:
        algo_kw["policy_kwargs"] = pk
    missing = [k for k in REQUIRED if k not in merged]
    if missing:
        raise HyperparamError(f"{path} [{task}] (with [defaults]): missing field(s) {missing}")
    er = merged.get("error_reset")
    return RunSettings(
        algo=algo, task=task, file=str(path), source=str(merged.get("source", "")), num_envs=merged["num_envs"],
        timesteps=merged["timesteps"], eval_every=merged["eval_every"], normalize=merged["normalize"],
        clip_obs=float(merged["clip_obs"]), error_reset=(er["entry"], float(er["bound"])) if er else None,
        acting_surfaces=bool(merged.get("acting_surfaces", False)), env=dict(merged.get("env", {})), algo_kwargs=algo_kw,
    )


def _check_table(algo: str, table: Mapping[str, Any], where: str) -> None:
    _check(table, RUN_FIELDS, where)
    er = table.get("error_reset")
    if er is not None:
        _check(er, {"entry": (lambda v: isinstance(v, str), "an observation label"), "bound": (_pos, "a positive number")},
               f"{where}.error_reset")
        if set(er) != {"entry", "bound"}:
            raise HyperparamError(f"{where}.error_reset: needs both 'entry' and 'bound', got {sorted(er)}")
    algo_t = table.get("algo", {})
    _check(algo_t, ALGO_FIELDS[algo], f"{where}.algo")
    _check(algo_t.get("policy_kwargs", {}), POLICY_FIELDS, f"{where}.algo.policy_kwargs")
