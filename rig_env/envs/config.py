"""``RigEnvConfig``: every setting of a rig environment, validated on construction.

Errors are ``ValueError`` naming the field and its allowed range.  ``None`` in a task-dependent field
(``free_dofs``, ``airspeed``, ``episode_seconds``, ``aero_model``) means "the task's default" (see
:mod:`rig_env.envs.tasks`); :meth:`RigEnvConfig.with_overrides` rejects unknown names.

| field | default | unit / range | meaning |
|---|---|---|---|
| task | "velocity_vector_roll" | name in ``tasks.TASKS`` | the task object |
| task_options | {} | name -> value, checked by the task | e.g. ``{"axis": "sway_yaw"}`` for forced_oscillation |
| free_dofs | None (task's) | a name or a sequence of distinct names of rig_env.JOINTS | free joints; the others are locked |
| locked_deg | {} | joint -> deg, [-89, 89] | angles of locked joints (default 0) |
| airspeed | None (task's) | m/s, a number or a (lo, hi) pair, [0, 40] | tunnel speed, drawn per episode |
| control_rate | 80.0 | Hz, [1, 2000] | real-time loop rate (244 for the later rig) |
| physics_dt | None | s | physics step; control step must be an integer multiple |
| episode_seconds | None (task's) | s, (0, 600] | time limit (truncation) |
| angle_noise_deg | 0.05 | deg (1 sigma), [0, 5] | noise on joint angles |
| flap_noise_deg | 0.05 | deg (1 sigma), [0, 5] | noise on measured flap positions |
| airspeed_noise | 0.1 | m/s (1 sigma), [0, 5] | noise on the airspeed reading |
| quantise | True | bool | pots 12-bit over 360 deg, encoders 13-bit (0.044 deg) |
| pot_bits, encoder_bits | 12, 13 | [6, 24] | converter resolution over one turn |
| link_delay_steps | 1 | control steps, [0, 50] | wireless telemetry delay |
| rate_filter_hz | None: min(10, control_rate / 2) | Hz, [0.1, control_rate / 2] | low-pass of the rate estimate (None: 10 Hz, or the Nyquist frequency below 20 Hz control rates; the attribute holds the value in use) |
| turbulence | 0.0 | fraction of airspeed, [0, 0.3] | gust intensity (1 sigma, per axis) |
| turbulence_model | "gauss_markov" | "gauss_markov", "dryden" or "von_karman" | gust spectrum: first-order Gauss-Markov per world axis (correlation time ``turbulence_tau``), or Dryden's or von Karman's longitudinal, lateral and vertical forms at length scale ``turbulence_scale`` (von Karman's within 0.5 % up to T omega = 100, T = L / V: :mod:`rig_env.turbulence`) |
| turbulence_tau | 0.2 | s, [0.01, 10] | gust correlation time (gauss_markov) |
| turbulence_scale | 0.76 | m, [0.01, 10] | longitudinal integral scale L (dryden, von_karman); estimate: half the 5 ft height of the tunnel's test section (``turbulence.TUNNEL_SCALE``) |
| turbulence_convected | None (model's) | bool | True: the compensator meets the Hawk's gust d / V later (frozen turbulence, d = 1.18 m on the default rig); False: the same gust at both at once; None: True with "dryden" and "von_karman", False with "gauss_markov" (its gusts as they always were, bit for bit) |
| randomise | {} | param -> (lo, hi), file units | per-episode uniform draw of rig parameters |
| hawk_surfaces | False | bool | Hawk elevator, aileron, rudder are actions too |
| aero_model | None (task's) | "linear", "tables" or "unsteady" | aerodynamic model: stability derivatives, static high-incidence tables, or the tables through the Hawk's flow-separation state (departure_recovery: "tables" by default) |
| nonlinear_aero | None | bool | older name: True is aero_model "tables", False "linear" (contradicting aero_model is an error) |
| params_file | None | path of a file | rig parameter file (None: the default rig) |
| pilot_inputs | None | ``rig_env.signals.InputSchedule``, deg | test inputs flown from every episode's start instead of the task's pilot inputs (below) |

``pilot_inputs``: at each control step the schedule is evaluated at the episode's time and held (as
:func:`rig_env.simulate` holds ``controls``).  Its Hawk surfaces replace the task's pilot inputs (all
three: a Hawk surface the schedule leaves out is held at 0), and with ``hawk_surfaces`` are added to
the action's Hawk commands, as the task's are.  Its compensator surfaces are added to the action's
compensator commands (after the action's clipping to +-40 deg); the servos' position and rate limits
clip the sum.  So a schedule flies in an environment as in the rig's loop, where a test input is added
to the law's command before the output limits.  The task's reference, reward and success still follow
the task's own pilot input (free_flight_emulation's free-Hawk model flies its own 3-2-1-1), so a
schedule is for identification and test runs, not for scoring those tasks.

Numbers may be Python's or numpy's (``np.float32(20)``, ``np.int64(2)``); they are stored as Python
``float`` and ``int``.  ``rate_filter_hz`` None (the default) is :func:`default_rate_filter_hz` of the
control rate, resolved on construction: ``config.rate_filter_hz`` is the corner in use, and
:meth:`RigEnvConfig.with_overrides` derives it again from a new ``control_rate`` unless it was given.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from rig_env.params import JOINTS, PARAM_INDEX
from rig_env.physics.pipeline import check_aero_model, resolve_aero_model
from rig_env.signals import InputSchedule
from rig_env.envs.ranges import CONTROL_RATE_HZ, CONVERTER_BITS, LINK_DELAY_STEPS, MAX_AIRSPEED, RATE_FILTER_MIN_HZ
from rig_env.turbulence import SCALE_RANGE, SPECTRAL_MODELS, TUNNEL_SCALE, TURBULENCE_MODELS

RATE_FILTER_HZ = 10.0
"""Hz: the rate estimate's low-pass corner on the rig (its 80 and 244 Hz loops)."""


def default_rate_filter_hz(control_rate: float) -> float:
    """Hz: the rate filter's corner when ``rate_filter_hz`` is None: ``RATE_FILTER_HZ`` (10 Hz), or the Nyquist
    frequency ``control_rate / 2`` at control rates below 20 Hz (the highest corner a sampled filter has; there
    the backward difference over the long control step already averages the rate).  10 Hz at every rate from
    20 Hz: environments at those rates are those of a fixed 10 Hz corner."""
    return min(RATE_FILTER_HZ, float(control_rate) / 2.0)


def _is_number(v: Any) -> bool:
    """A real number, Python's or numpy's (``numbers.Real``, which numpy's bool is not), not a bool."""
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _is_integer(v: Any) -> bool:
    """An integer, Python's or numpy's (not a bool)."""
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def _range(name: str, v: Any, lo: float, hi: float, unit: str = "", lo_open: bool = False) -> None:
    ok = _is_number(v) and math.isfinite(v)
    ok = ok and (lo < v if lo_open else lo <= v) and v <= hi
    if not ok:
        br = "(" if lo_open else "["
        raise ValueError(f"{name} = {v!r} {unit}: allowed range {br}{lo}, {hi}] {unit}".replace("  ", " "))


@dataclass(frozen=True)
class RigEnvConfig:
    """Configuration of a rig environment; see the module docstring for the table of fields."""

    task: str = "velocity_vector_roll"
    task_options: Mapping[str, Any] = field(default_factory=dict)
    free_dofs: tuple[str, ...] | None = None
    locked_deg: Mapping[str, float] = field(default_factory=dict)
    airspeed: float | tuple[float, float] | None = None
    control_rate: float = 80.0
    physics_dt: float | None = None
    episode_seconds: float | None = None
    angle_noise_deg: float = 0.05
    flap_noise_deg: float = 0.05
    airspeed_noise: float = 0.1
    quantise: bool = True
    pot_bits: int = 12
    encoder_bits: int = 13
    link_delay_steps: int = 1
    rate_filter_hz: float | None = None
    """Hz: corner of the rate estimate's low-pass, [0.1, control_rate / 2].  None (the default):
    :func:`default_rate_filter_hz`, 10 Hz, or ``control_rate / 2`` (the Nyquist frequency) below 20 Hz; the
    attribute then holds that value, derived again by :meth:`with_overrides` from a new ``control_rate``."""
    turbulence: float = 0.0
    turbulence_model: str = "gauss_markov"
    turbulence_tau: float = 0.2
    turbulence_scale: float = TUNNEL_SCALE
    turbulence_convected: bool | None = None
    randomise: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    hawk_surfaces: bool = False
    aero_model: str | None = None
    nonlinear_aero: bool | None = None
    params_file: str | None = None
    pilot_inputs: InputSchedule | None = None

    def __post_init__(self) -> None:
        from rig_env.envs.tasks import TASKS  # late: tasks import this module

        if not isinstance(self.task, str) or self.task not in TASKS:
            raise ValueError(f"task = {self.task!r}: unknown; valid names: {sorted(TASKS)}")
        if not isinstance(self.task_options, Mapping):
            raise ValueError(f"task_options = {self.task_options!r}: must be a mapping of option names to values")
        TASKS[self.task].check_options(self.task_options)  # ValueError naming a bad option; defaults stay the task's
        object.__setattr__(self, "task_options", dict(self.task_options))
        if self.free_dofs is not None:
            try:
                fd = (self.free_dofs,) if isinstance(self.free_dofs, str) else tuple(self.free_dofs)
            except TypeError:
                fd = None
            if fd is None or not fd or any(j not in JOINTS for j in fd) or len(set(fd)) != len(fd):
                shown = list(fd) if fd else self.free_dofs
                raise ValueError(f"free_dofs = {shown!r}: must be a joint name or distinct names from {list(JOINTS)}, at least one")
            object.__setattr__(self, "free_dofs", tuple(j for j in JOINTS if j in fd))
        try:
            locked = dict(self.locked_deg)
        except (TypeError, ValueError):
            raise ValueError(f"locked_deg = {self.locked_deg!r}: must be a mapping of joint names to angles, "
                             "deg, each in [-89.0, 89.0] deg (e.g. {'rig_pitch': 5.0})") from None
        for j, a in locked.items():
            if j not in JOINTS:
                raise ValueError(f"locked_deg: unknown joint {j!r}; valid names: {list(JOINTS)}")
            _range(f"locked_deg[{j!r}]", a, -89.0, 89.0, "deg")
            locked[j] = float(a)
        object.__setattr__(self, "locked_deg", locked)
        if self.airspeed is not None:
            spd: Any = self.airspeed
            pair: Any = (spd, spd) if _is_number(spd) else None
            if pair is None and not isinstance(spd, (str, bytes)):
                try:
                    pair = tuple(spd)
                except TypeError:
                    pass
            if pair is None or len(pair) != 2:
                raise ValueError(f"airspeed = {spd!r}: must be a number or a (low, high) pair, allowed range [0.0, {MAX_AIRSPEED}] m/s")
            lo, hi = pair
            _range("airspeed (low)", lo, 0.0, MAX_AIRSPEED, "m/s")
            _range("airspeed (high)", hi, lo, MAX_AIRSPEED, "m/s")
            object.__setattr__(self, "airspeed", (float(lo), float(hi)))
        _range("control_rate", self.control_rate, *CONTROL_RATE_HZ, "Hz")
        object.__setattr__(self, "control_rate", float(self.control_rate))
        if self.physics_dt is not None:
            _range("physics_dt", self.physics_dt, 1e-6, 0.05, "s")
            object.__setattr__(self, "physics_dt", float(self.physics_dt))
            ratio = 1.0 / (self.control_rate * self.physics_dt)
            if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
                raise ValueError(f"physics_dt = {self.physics_dt} s: the control step 1/{self.control_rate} s must be an integer multiple of it")
        if self.episode_seconds is not None:
            _range("episode_seconds", self.episode_seconds, 0.0, 600.0, "s", lo_open=True)
            object.__setattr__(self, "episode_seconds", float(self.episode_seconds))
        _range("angle_noise_deg", self.angle_noise_deg, 0.0, 5.0, "deg")
        _range("flap_noise_deg", self.flap_noise_deg, 0.0, 5.0, "deg")
        _range("airspeed_noise", self.airspeed_noise, 0.0, 5.0, "m/s")
        for name in ("pot_bits", "encoder_bits", "link_delay_steps"):
            v = getattr(self, name)
            if not _is_integer(v):
                raise ValueError(f"{name} = {v!r}: must be an integer")
            object.__setattr__(self, name, int(v))
        _range("pot_bits", self.pot_bits, *CONVERTER_BITS)
        _range("encoder_bits", self.encoder_bits, *CONVERTER_BITS)
        _range("link_delay_steps", self.link_delay_steps, *LINK_DELAY_STEPS, "control steps")
        nyquist, rf = self.control_rate / 2.0, self.rate_filter_hz
        object.__setattr__(self, "_rate_filter_derived", rf is None)
        if rf is None:
            object.__setattr__(self, "rate_filter_hz", default_rate_filter_hz(self.control_rate))
        elif not (_is_number(rf) and math.isfinite(rf) and RATE_FILTER_MIN_HZ <= rf <= nyquist):
            raise ValueError(f"rate_filter_hz = {rf!r} Hz: allowed range [{RATE_FILTER_MIN_HZ:g}, {nyquist:g}] Hz (at most control_rate / 2 "
                             f"at control_rate = {self.control_rate:g} Hz; None: {default_rate_filter_hz(self.control_rate):g} Hz)")
        _range("turbulence", self.turbulence, 0.0, 0.3, "(fraction of airspeed)")
        if not isinstance(self.turbulence_model, str) or self.turbulence_model not in TURBULENCE_MODELS:
            raise ValueError(f"turbulence_model = {self.turbulence_model!r}: one of {list(TURBULENCE_MODELS)}")
        _range("turbulence_tau", self.turbulence_tau, 0.01, 10.0, "s")
        _range("turbulence_scale", self.turbulence_scale, SCALE_RANGE[0], SCALE_RANGE[1], "m")
        for name in ("angle_noise_deg", "flap_noise_deg", "airspeed_noise", "rate_filter_hz", "turbulence", "turbulence_tau", "turbulence_scale"):
            object.__setattr__(self, name, float(getattr(self, name)))
        try:
            randomise = dict(self.randomise)
        except (TypeError, ValueError):
            raise ValueError(f"randomise = {self.randomise!r}: must be a mapping of parameter names to (low, high) pairs, file units") from None
        rnd: dict[str, tuple[float, float]] = {}
        for name, bounds in randomise.items():
            if name not in PARAM_INDEX:
                raise ValueError(f"randomise: unknown parameter {name!r}; valid names: rig_env.PARAM_NAMES")
            try:
                lo, hi = (float(b) for b in bounds)
            except (TypeError, ValueError):
                raise ValueError(f"randomise[{name!r}] = {bounds!r}: must be a (low, high) pair") from None
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"randomise[{name!r}] = ({lo}, {hi}): need finite low <= high")
            rnd[name] = (lo, hi)
        object.__setattr__(self, "randomise", rnd)
        if self.pilot_inputs is not None and not isinstance(self.pilot_inputs, InputSchedule):
            raise ValueError(f"pilot_inputs = {self.pilot_inputs!r}: must be a rig_env.signals.InputSchedule or None "
                             "(InputSchedule.from_data / load build one from plain data)")
        for name in ("quantise", "hawk_surfaces", "turbulence_convected", "nonlinear_aero"):
            v = getattr(self, name)
            if not isinstance(v, (bool, np.bool_)) and not (name in ("nonlinear_aero", "turbulence_convected") and v is None):
                default = {"nonlinear_aero": " (or None: the task's default)", "turbulence_convected": " (or None: the turbulence model's default)"}
                raise ValueError(f"{name} = {v!r}: must be True or False" + default.get(name, ""))
            if v is not None:
                object.__setattr__(self, name, bool(v))
        if self.params_file is not None:
            pf = self.params_file
            if not isinstance(pf, (str, os.PathLike)):
                raise ValueError(f"params_file = {pf!r}: must be the path (str or pathlib.Path) of a rig parameter file, or None (the default rig)")
            if os.path.exists(pf) and not os.path.isfile(pf):
                kind = "a directory" if os.path.isdir(pf) else "not a regular file"
                raise ValueError(f"params_file = {os.fspath(pf)!r}: {kind}; must be the path of a rig parameter file (.toml), or None (the default rig)")
        if self.aero_model is not None:
            check_aero_model(self.aero_model)  # ValueError naming aero_model and the allowed values
            resolve_aero_model(self.aero_model, self.nonlinear_aero)  # and the older switch must not contradict it

    @property
    def gusts_convected(self) -> bool:
        """Whether the compensator meets the Hawk's gust d / V later: ``turbulence_convected``, or when that is
        None, True for the "dryden" and "von_karman" models and False for "gauss_markov" (uniform gusts, as they
        always were)."""
        return self.turbulence_model in SPECTRAL_MODELS if self.turbulence_convected is None else self.turbulence_convected

    @property
    def rate_filter_derived(self) -> bool:
        """Whether ``rate_filter_hz`` was derived from the control rate (given as None), not set."""
        return bool(getattr(self, "_rate_filter_derived", False))

    def with_overrides(self, **overrides: Any) -> "RigEnvConfig":
        """A copy with fields replaced; an unknown name is a ValueError listing the valid ones.  A derived
        ``rate_filter_hz`` (given as None) is derived again, from the copy's ``control_rate``."""
        valid = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(overrides) - valid)
        if unknown:
            raise ValueError(f"unknown configuration name(s) {unknown}; valid names: {sorted(valid)}")
        if self.rate_filter_derived and "rate_filter_hz" not in overrides:
            overrides = {**overrides, "rate_filter_hz": None}
        return dataclasses.replace(self, **overrides)
