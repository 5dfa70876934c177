"""``RigEnvConfig``: every setting of a rig environment, validated on construction.

Errors are ``ValueError`` naming the field and its allowed range.  ``None`` in a task-dependent field
(``free_dofs``, ``airspeed``, ``episode_seconds``, ``aero_model``) means "the task's default" (see
:mod:`rig_env.envs.tasks`); :meth:`RigEnvConfig.with_overrides` rejects unknown names.

| field | default | unit / range | meaning |
|---|---|---|---|
| task | "velocity_vector_roll" | name in ``tasks.TASKS`` | the task object |
| task_options | {} | name -> value, checked by the task | e.g. ``{"axis": "sway_yaw"}`` for forced_oscillation |
| free_dofs | None (task's) | subset of rig_env.JOINTS | free joints; the others are locked |
| locked_deg | {} | joint -> deg, [-89, 89] | angles of locked joints (default 0) |
| airspeed | None (task's) | m/s, float or (lo, hi), [0, 40] | tunnel speed, drawn per episode |
| control_rate | 80.0 | Hz, [1, 2000] | real-time loop rate (244 for the later rig) |
| physics_dt | None | s | physics step; control step must be an integer multiple |
| episode_seconds | None (task's) | s, (0, 600] | time limit (truncation) |
| angle_noise_deg | 0.05 | deg (1 sigma), [0, 5] | noise on joint angles |
| flap_noise_deg | 0.05 | deg (1 sigma), [0, 5] | noise on measured flap positions |
| airspeed_noise | 0.1 | m/s (1 sigma), [0, 5] | noise on the airspeed reading |
| quantise | True | bool | pots 12-bit over 360 deg, encoders 13-bit (0.044 deg) |
| pot_bits, encoder_bits | 12, 13 | [6, 24] | converter resolution over one turn |
| link_delay_steps | 1 | control steps, [0, 50] | wireless telemetry delay |
| rate_filter_hz | 10.0 | Hz, [0.1, control_rate / 2] | low-pass of the rate estimate |
| turbulence | 0.0 | fraction of airspeed, [0, 0.3] | gust intensity (1 sigma, per axis) |
| turbulence_model | "gauss_markov" | "gauss_markov", "dryden" or "von_karman" | gust spectrum: first-order Gauss-Markov per world axis (correlation time ``turbulence_tau``), or Dryden's or von Karman's longitudinal, lateral and vertical forms at length scale ``turbulence_scale`` (von Karman's within 0.5 % up to T omega = 100, T = L / V: :mod:`rig_env.turbulence`) |
| turbulence_tau | 0.2 | s, [0.01, 10] | gust correlation time (gauss_markov) |
| turbulence_scale | 0.76 | m, [0.01, 10] | longitudinal integral scale L (dryden, von_karman); estimate: half the 5 ft height of the tunnel's test section (``turbulence.TUNNEL_SCALE``) |
| turbulence_convected | None (model's) | bool | True: the compensator meets the Hawk's gust d / V later (frozen turbulence, d = 1.18 m on the default rig); False: the same gust at both at once; None: True with "dryden" and "von_karman", False with "gauss_markov" (its gusts as they always were, bit for bit) |
| randomise | {} | param -> (lo, hi), file units | per-episode uniform draw of rig parameters |
| hawk_surfaces | False | bool | Hawk elevator, aileron, rudder are actions too |
| aero_model | None (task's) | "linear", "tables" or "unsteady" | aerodynamic model: stability derivatives, static high-incidence tables, or the tables through the Hawk's flow-separation state (departure_recovery: "tables" by default) |
| nonlinear_aero | None | bool | older name: True is aero_model "tables", False "linear" (contradicting aero_model is an error) |
| params_file | None | path | rig parameter file (None: the default rig) |
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
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from rig_env.params import JOINTS, PARAM_INDEX
from rig_env.physics.pipeline import check_aero_model, resolve_aero_model
from rig_env.signals import InputSchedule
from rig_env.turbulence import SCALE_RANGE, SPECTRAL_MODELS, TUNNEL_SCALE, TURBULENCE_MODELS

MAX_AIRSPEED = 40.0  # m/s: the Bristol 7x5 ft tunnel's working range for the rig


def _range(name: str, v: Any, lo: float, hi: float, unit: str = "", lo_open: bool = False) -> None:
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
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
    rate_filter_hz: float = 10.0
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

        if self.task not in TASKS:
            raise ValueError(f"task = {self.task!r}: unknown; valid names: {sorted(TASKS)}")
        if not isinstance(self.task_options, Mapping):
            raise ValueError(f"task_options = {self.task_options!r}: must be a mapping of option names to values")
        TASKS[self.task].check_options(self.task_options)  # ValueError naming a bad option; defaults stay the task's
        object.__setattr__(self, "task_options", dict(self.task_options))
        if self.free_dofs is not None:
            fd = (self.free_dofs,) if isinstance(self.free_dofs, str) else tuple(self.free_dofs)
            bad = [j for j in fd if j not in JOINTS]
            if bad or not fd or len(set(fd)) != len(fd):
                raise ValueError(f"free_dofs = {list(fd)}: must be distinct names from {list(JOINTS)}, at least one")
            object.__setattr__(self, "free_dofs", tuple(j for j in JOINTS if j in fd))
        locked = dict(self.locked_deg)
        for j, a in locked.items():
            if j not in JOINTS:
                raise ValueError(f"locked_deg: unknown joint {j!r}; valid names: {list(JOINTS)}")
            _range(f"locked_deg[{j!r}]", a, -89.0, 89.0, "deg")
        object.__setattr__(self, "locked_deg", locked)
        if self.airspeed is not None:
            a = self.airspeed
            lo, hi = (a, a) if isinstance(a, (int, float)) else tuple(a)
            _range("airspeed (low)", lo, 0.0, MAX_AIRSPEED, "m/s")
            _range("airspeed (high)", hi, lo, MAX_AIRSPEED, "m/s")
            object.__setattr__(self, "airspeed", (float(lo), float(hi)))
        _range("control_rate", self.control_rate, 1.0, 2000.0, "Hz")
        if self.physics_dt is not None:
            _range("physics_dt", self.physics_dt, 1e-6, 0.05, "s")
            ratio = 1.0 / (self.control_rate * self.physics_dt)
            if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
                raise ValueError(f"physics_dt = {self.physics_dt} s: the control step 1/{self.control_rate} s must be an integer multiple of it")
        if self.episode_seconds is not None:
            _range("episode_seconds", self.episode_seconds, 0.0, 600.0, "s", lo_open=True)
        _range("angle_noise_deg", self.angle_noise_deg, 0.0, 5.0, "deg")
        _range("flap_noise_deg", self.flap_noise_deg, 0.0, 5.0, "deg")
        _range("airspeed_noise", self.airspeed_noise, 0.0, 5.0, "m/s")
        for name in ("pot_bits", "encoder_bits", "link_delay_steps"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool):
                raise ValueError(f"{name} = {v!r}: must be an integer")
        _range("pot_bits", self.pot_bits, 6, 24)
        _range("encoder_bits", self.encoder_bits, 6, 24)
        _range("link_delay_steps", self.link_delay_steps, 0, 50, "control steps")
        _range("rate_filter_hz", self.rate_filter_hz, 0.1, self.control_rate / 2.0, "Hz")
        _range("turbulence", self.turbulence, 0.0, 0.3, "(fraction of airspeed)")
        if self.turbulence_model not in TURBULENCE_MODELS:
            raise ValueError(f"turbulence_model = {self.turbulence_model!r}: one of {list(TURBULENCE_MODELS)}")
        _range("turbulence_tau", self.turbulence_tau, 0.01, 10.0, "s")
        _range("turbulence_scale", self.turbulence_scale, SCALE_RANGE[0], SCALE_RANGE[1], "m")
        rnd: dict[str, tuple[float, float]] = {}
        for name, bounds in dict(self.randomise).items():
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
            if not isinstance(v, bool) and not (name in ("nonlinear_aero", "turbulence_convected") and v is None):
                default = {"nonlinear_aero": " (or None: the task's default)", "turbulence_convected": " (or None: the turbulence model's default)"}
                raise ValueError(f"{name} = {v!r}: must be True or False" + default.get(name, ""))
        if self.aero_model is not None:
            check_aero_model(self.aero_model)  # ValueError naming aero_model and the allowed values
            resolve_aero_model(self.aero_model, self.nonlinear_aero)  # and the older switch must not contradict it

    @property
    def gusts_convected(self) -> bool:
        """Whether the compensator meets the Hawk's gust d / V later: ``turbulence_convected``, or when that is
        None, True for the "dryden" and "von_karman" models and False for "gauss_markov" (uniform gusts, as they
        always were)."""
        return self.turbulence_model in SPECTRAL_MODELS if self.turbulence_convected is None else self.turbulence_convected

    def with_overrides(self, **overrides: Any) -> "RigEnvConfig":
        """A copy with fields replaced; an unknown name is a ValueError listing the valid ones."""
        valid = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(overrides) - valid)
        if unknown:
            raise ValueError(f"unknown configuration name(s) {unknown}; valid names: {sorted(valid)}")
        return dataclasses.replace(self, **overrides)
