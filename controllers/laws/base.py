"""The one interface every control law of the compensator implements (LQR, PID family, RL).

A law is built for a loop (:class:`LoopSpec`: task, free joints, observation and action layout,
control period), is batched over environments, and sees only what the rig's real-time loop gives it:
the observation vector.  So any law runs unchanged in :class:`rig_env.envs.RigVectorEnv`, in the
comparison, and on the rig.

    law = make_controller("pid", LoopSpec.from_env(env), num_envs=env.num_envs)
    obs, _ = env.reset(seed=0)
    law.reset()
    while ...:
        obs, rew, term, trunc, info = env.step(law.act(obs))
        law.reset(term | trunc)          # same-step autoreset: restart the finished environments' laws

Signals are found by name (``spec.index("rig_roll_rate")``), never by bare index.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping

import numpy as np


AERO_MODELS = ("linear", "tables", "unsteady")
"""The aerodynamic models a loop's rig can fly: ``rig_env``'s ``aero_model`` names (the laws import nothing of
rig_env; ``tests/test_law_artefacts.py`` checks the two lists agree)."""


@dataclass(frozen=True)
class LoopSpec:
    """What a law may know of the loop it flies: read off an environment, stored in a deployed artefact.

    task: task name (``rig_env.envs.TASKS``); free_dofs: free joints (``rig_env.JOINTS`` order);
    obs_labels: names of the observation entries; action_names: names of the action entries (each
    normalised to [-1, 1] for +-``action_scale_deg``); dt: control period, s; airspeed_range: m/s;
    task_options: the task's ``task_options`` (e.g. ``{"axis": "sway_yaw"}`` of ForcedOscillation);
    aero_model: the aerodynamic model the loop's rig flies (``rig_env``'s ``aero_model``: "linear", "tables"
    or "unsteady"), which the designed laws linearise (:func:`controllers.design.model.design_aero_model`).
    """

    task: str
    free_dofs: tuple[str, ...]
    obs_labels: tuple[str, ...]
    action_names: tuple[str, ...]
    dt: float
    airspeed_range: tuple[float, float]
    action_scale_deg: float = 40.0
    task_options: Mapping[str, Any] = field(default_factory=dict)
    aero_model: str = "linear"

    def __post_init__(self) -> None:
        # the numbers every design and runtime divide by or grid over, checked as the artefact checks a stored spec:
        # a reversed or NaN airspeed range was designed silently at one airspeed, action_scale_deg = 0 divided by zero
        def real(v: Any) -> bool:
            return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) and math.isfinite(v)

        if not (real(self.dt) and 0.0 < self.dt <= 1.0):
            raise ValueError(f"dt = {self.dt!r}: the control period, s; allowed range (0, 1]")
        ar = self.airspeed_range
        if not (isinstance(ar, (tuple, list)) and len(ar) == 2 and all(real(v) for v in ar) and 0.0 <= ar[0] <= ar[1]):
            raise ValueError(f"airspeed_range = {ar!r}: allowed two finite speeds lo <= hi, m/s, lo >= 0")
        if not (real(self.action_scale_deg) and 0.0 < self.action_scale_deg <= 90.0):
            raise ValueError(f"action_scale_deg = {self.action_scale_deg!r}: allowed range (0, 90] deg")
        if self.aero_model not in AERO_MODELS:
            raise ValueError(f"aero_model = {self.aero_model!r}; allowed {list(AERO_MODELS)}")

    @classmethod
    def from_env(cls, env: Any) -> "LoopSpec":
        """From a ``RigVectorEnv`` or ``RigEnv`` (or anything wrapping one: ``.unwrapped``/``.vec``); reads its attributes only."""
        vec = getattr(env, "vec", None) or getattr(getattr(env, "unwrapped", env), "vec", None) or getattr(env, "unwrapped", env)
        return cls(
            task=vec.config.task,
            free_dofs=tuple(vec.free_dofs),
            obs_labels=tuple(vec.obs_labels),
            action_names=tuple(vec.action_names),
            dt=float(vec.dt),
            airspeed_range=tuple(float(v) for v in vec.airspeed_range),
            action_scale_deg=float(vec.action_scale_deg),
            task_options=dict(vec.config.task_options),
            aero_model=str(vec.aero_model),
        )

    @property
    def obs_dim(self) -> int:
        return len(self.obs_labels)

    @property
    def n_actions(self) -> int:
        return len(self.action_names)

    def index(self, label: str) -> int:
        """Column of the observation entry ``label``; a KeyError lists the available names."""
        try:
            return self.obs_labels.index(label)
        except ValueError:
            raise KeyError(f"observation has no entry {label!r}; entries: {list(self.obs_labels)}") from None

    def action_index(self, name: str) -> int:
        try:
            return self.action_names.index(name)
        except ValueError:
            raise KeyError(f"action has no entry {name!r}; entries: {list(self.action_names)}") from None


class UnsupportedTask(ValueError):
    """Raised by a law's constructor when it cannot fly the given task or joint set (e.g. a roll law
    with rig_roll locked); the comparison skips that pairing with a printed note."""


class Controller(abc.ABC):
    """A control law over a batch of ``num_envs`` environments.

    ``act`` takes observations ``(num_envs, obs_dim)`` and returns actions ``(num_envs, n_actions)``
    in [-1, 1], float64; it advances the law's internal state (integrators, filters, estimators) by
    one control period ``spec.dt``.  ``reset(mask)`` restarts the state of the masked environments
    (all when ``mask`` is None); call it after every ``env.reset`` and for every finished environment.
    """

    kind: ClassVar[str]
    artefact_kind: ClassVar[str]
    """The law's kind in the one file format (:mod:`controllers.laws.artefact`); default: its ``kind``."""
    built_from_spec: ClassVar[bool] = True
    """Whether ``make_controller(kind, spec)`` builds it from the loop spec alone (designed, or a shipped policy);
    False for a law that takes its numbers as arguments (LinearLaw's gains), which the comparison leaves out."""

    def __init__(self, spec: LoopSpec, num_envs: int = 1) -> None:
        if not isinstance(num_envs, (int, np.integer)) or isinstance(num_envs, bool) or num_envs < 1:
            raise ValueError(f"num_envs = {num_envs!r}: must be a positive integer")
        self.spec, self.num_envs = spec, int(num_envs)

    @classmethod
    def supports(cls, spec: LoopSpec) -> str | None:
        """None when :func:`law_for` should route ``spec`` to this class, else the reason it does not (numpy only)."""
        return None

    def to_data(self) -> dict[str, Any]:
        """The law as plain data: numpy arrays (stored as the artefact's ``arrays``) and JSON values (its ``params``)."""
        raise NotImplementedError(f"{type(self).__name__}: no to_data(); it cannot be saved as an artefact")

    @classmethod
    def from_data(cls, data: Mapping[str, Any], spec: LoopSpec, num_envs: int = 1) -> "Controller":
        """The law that :meth:`to_data` gave ``data`` (a ValueError naming what is refused)."""
        raise NotImplementedError(f"{cls.__name__}: no from_data(); it cannot be loaded from an artefact")

    @classmethod
    def data_of(cls, law: "Controller") -> dict[str, Any]:
        """``law`` as this class's artefact data: ``law.to_data()`` (a class may accept other laws: LinearLaw)."""
        if not isinstance(law, cls):
            raise TypeError(f"artefact kind {cls.artefact_kind!r} stores a {cls.__name__}; got {type(law).__name__}")
        return law.to_data()

    @abc.abstractmethod
    def reset(self, mask: np.ndarray | None = None) -> None: ...

    @abc.abstractmethod
    def act(self, obs: np.ndarray) -> np.ndarray: ...

    def _check_obs(self, obs: np.ndarray) -> np.ndarray:
        raw = np.asarray(obs) if isinstance(obs, np.ndarray) else _as_array(obs)
        if raw.dtype.kind not in "biuf":  # a string or object array reached numpy's "could not convert string to float"
            raise ValueError(f"obs: dtype {raw.dtype}; allowed real numbers of shape {(self.num_envs, self.spec.obs_dim)}")
        o = np.asarray(raw, dtype=np.float64)
        if o.shape != (self.num_envs, self.spec.obs_dim):
            raise ValueError(f"obs: expected shape {(self.num_envs, self.spec.obs_dim)}, got {o.shape}")
        if not np.all(np.isfinite(o)):
            raise ValueError("obs: non-finite value(s)")
        return o

    def _mask(self, mask: np.ndarray | None) -> np.ndarray:
        if mask is None:
            return np.ones(self.num_envs, dtype=bool)
        raw = np.asarray(mask)
        if raw.shape != (self.num_envs,):
            raise ValueError(f"mask: expected shape ({self.num_envs},), got {raw.shape}")
        # a mask of indices ([0, 3]) or of fractions was cast to bool silently and reset the wrong environments
        if raw.dtype != bool and not (raw.dtype.kind in "iuf" and np.all((raw == 0) | (raw == 1))):
            raise ValueError(f"mask = {raw.tolist()[:8]}: one flag per environment; allowed bools (or 0 / 1), not indices")
        return raw.astype(bool)


def _as_array(v: Any) -> np.ndarray:
    """``np.asarray(v)``, or an object array when ``v`` is ragged (numpy raises on it), for a dtype check."""
    try:
        return np.asarray(v)
    except (ValueError, TypeError):
        return np.array(None)


class TabledLaw(Controller):
    """A model-based law: it runs the tables its design made (``self.tables``, numpy arrays and numbers).

    Its constructor takes ``tables=`` as the tables object or their plain data, so the law's artefact
    data is its tables' (:meth:`to_data`) and :meth:`from_data` is the constructor.
    """

    tables: Any

    @classmethod
    def from_data(cls, data: Mapping[str, Any], spec: LoopSpec, num_envs: int = 1) -> "TabledLaw":
        """The runtime of a deployed artefact (numpy only): ``cls(spec, num_envs, tables=data)``."""
        return cls(spec, num_envs, tables=data)

    def to_data(self) -> dict[str, Any]:
        return self.tables.to_data()


LAWS: dict[str, list[type[Controller]]] = {}
"""Law classes by kind (``"lqr"``, ``"pid"``, ``"ppo"``, ``"sac"``, ``"linear"``), filled by :func:`register`.

A kind may hold several classes, each for the loops it flies (the roll-axis PID and the heave/sway
PID); each says which :class:`LoopSpec` it takes through :meth:`Controller.supports`, and no two
classes of one kind take the same spec (:func:`law_for` refuses an ambiguous spec), so the class a
spec gets never depends on the order in which modules were imported."""

CONTROLLERS = LAWS
"""The same registry under its earlier name."""


def register(kind: str) -> Callable[[type[Controller]], type[Controller]]:
    """Class decorator: file the law under ``kind`` (once) and name its kind.

    The class's ``artefact_kind`` (its own class attribute, default ``kind``) is its file kind
    (:mod:`controllers.laws.artefact`): one registered class per artefact kind.  Registering a class of
    the same module and name again (a module reloaded) replaces the earlier one; another class
    claiming a taken artefact kind is a ValueError.
    """

    def deco(cls: type[Controller]) -> type[Controller]:
        cls.kind = kind
        if "artefact_kind" not in cls.__dict__:
            cls.artefact_kind = kind
        art = cls.artefact_kind
        if not isinstance(art, str) or not art.isidentifier():
            raise ValueError(f"{cls.__name__}.artefact_kind = {art!r}: must be an identifier string")
        for classes in LAWS.values():
            for other in list(classes):
                if other is not cls and other.artefact_kind == art:
                    if (other.__module__, other.__qualname__) != (cls.__module__, cls.__qualname__):
                        raise ValueError(f"artefact kind {art!r}: already that of {other.__module__}.{other.__qualname__}; "
                                         f"{cls.__name__} needs its own artefact_kind")
                    classes.remove(other)
        LAWS.setdefault(kind, [])
        if cls not in LAWS[kind]:
            LAWS[kind].append(cls)
        return cls

    return deco


def law_for(kind: str, spec: LoopSpec) -> type[Controller]:
    """The one registered class of ``kind`` that :meth:`~Controller.supports` ``spec``.

    ValueError for an unknown kind (naming the known ones) or a spec two classes claim;
    :class:`UnsupportedTask` (naming every class's reason) when none does.
    """
    if kind not in LAWS:
        raise ValueError(f"controller kind {kind!r}: unknown; known kinds: {sorted(LAWS)}")
    reasons, takers = [], []
    for cls in LAWS[kind]:
        why = cls.supports(spec)
        (reasons.append(f"{cls.__name__}: {why}") if why else takers.append(cls))
    if len(takers) > 1:
        raise ValueError(f"{kind!r} laws {[c.__name__ for c in takers]} all claim task {spec.task!r}; a spec must have one law per kind")
    if not takers:
        raise UnsupportedTask(f"no {kind!r} law for task {spec.task!r} with free_dofs {list(spec.free_dofs)} ({'; '.join(reasons)})")
    return takers[0]
