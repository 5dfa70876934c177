"""``PIDLaw`` (kind ``"pid"``): cascaded angle/rate loops per rig axis, as a rig engineer writes them.

| axis | when | measured | outer loop (P) | inner loop (PI) | surface |
|---|---|---|---|---|---|
| roll | always | roll error, roll rate | rate demand from roll error (+ task's rate reference) | roll rate | compensator aileron |
| heave | rig_pitch free | rig_pitch angle, rate | rate demand from the rig_pitch error (0 - angle unless the task sets a reference) | rig_pitch rate | elevator, resolved by roll angle |
| sway | rig_yaw free | rig_yaw angle, rate | rate demand from the rig_yaw error (likewise) | rig_yaw rate | rudder, resolved by roll angle |

Each loop is a :class:`controllers.laws.pid_element.PID` (explicit dt, anti-windup by back-calculation,
output limit +-1 = +-40 deg, rate limit = the servo's 350 deg/s, bumpless engagement).  Heave and
sway demands are turned into elevator and rudder with the measured roll angle
(:func:`controllers.laws.axes.resolve`).  The rate loop acts on the measured, filtered rate, so the
cascade is a PID on the angle whose derivative is on the measurement, filtered by the sensor.

Gains: :func:`controllers.design.tuning.tune_axis` at construction (stated margins; ``describe()`` gives
gains and achieved margins) at the middle of ``spec.airspeed_range``; the rate-loop gains are
scaled by ``(V_design / V)^2`` with the measured airspeed.  Feedforward on the roll axis: the trim
aileron that holds the arm's gravity imbalance at the measured roll angle (a table over the roll
angle from :func:`controllers.design.model.operating_point`), and, when the task gives a rate reference,
the aileron that balances the roll damping at that rate plus its rate of change, from the linear
model.  ``reset(mask)`` re-engages the masked environments bumplessly from the measured flaps.

Design and runtime are apart: :func:`controllers.design.pid.design_pid` (python-control, the numba
model; imported only when a law is designed) produces :class:`PIDTables`, plain data; this module
runs them with numpy alone, in simulation and from a deployed artefact (kind ``"pid"``:
``law.to_data()`` / ``PIDLaw.from_data(data, spec)``), one implementation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.laws.axes import AXIS_OF, axes_of, resolve, unresolve
from controllers.laws.base import LoopSpec, TabledLaw, register
from controllers.laws.pid_element import PID
from controllers.laws.signals import Signals, SignalScales, require_roll, roll_reason, table_array



@dataclass(frozen=True)
class PIDTables:
    """Everything :class:`PIDLaw` executes, checked against a :class:`LoopSpec` (``axes`` = its tracked joints).

    | field | shape | unit |
    |---|---|---|
    | axes | names | tracked rig joints, :data:`controllers.laws.axes.AXES` order |
    | kp, ki | (n_axes,) | rate-loop PI: command per rad/s, per rad s |
    | k_angle | (n_axes,) | angle loop: rad/s per rad |
    | rate_demand_max | (n_axes,) | outer loops' output limits, rad/s |
    | v_design | scalar | design airspeed, m/s |
    | rate_limit | scalar | surface rate limit, normalised units / s |
    | feedforward | bool | roll trim and rate-reference feedforward on |
    | phi_grid, trim_roll | (m,), (m,) | roll angle, rad (increasing, -pi..pi); trim aileron, normalised |
    | b_roll, damp_roll | scalars | roll control power (rad/s^2 per unit) and damping (1/s) at V_design |
    | scales | :class:`SignalScales` | the observation's normalisation |
    | design | dict | provenance: targets, achieved margins, design point, sensor layout assumed |
    """

    axes: tuple[str, ...]
    kp: np.ndarray
    ki: np.ndarray
    k_angle: np.ndarray
    rate_demand_max: np.ndarray
    v_design: float
    rate_limit: float
    feedforward: bool
    phi_grid: np.ndarray
    trim_roll: np.ndarray
    b_roll: float
    damp_roll: float
    scales: SignalScales
    design: dict[str, Any]

    def to_data(self) -> dict[str, Any]:
        """Artefact entries: numpy arrays and JSON values."""
        return {"axes": list(self.axes), "kp": self.kp.copy(), "ki": self.ki.copy(), "k_angle": self.k_angle.copy(),
                "rate_demand_max": self.rate_demand_max.copy(), "v_design": self.v_design, "rate_limit": self.rate_limit,
                "feedforward": self.feedforward, "phi_grid": self.phi_grid.copy(), "trim_roll": self.trim_roll.copy(),
                "b_roll": self.b_roll, "damp_roll": self.damp_roll, **self.scales.to_data(), "design": dict(self.design)}

    @classmethod
    def from_data(cls, d: Mapping[str, Any], spec: LoopSpec) -> PIDTables:
        """Check ``d`` (from :func:`controllers.design.pid.design_pid` or an artefact); a ValueError names the entry."""
        missing = [k for k in ("axes", "kp", "ki", "k_angle", "rate_demand_max", "v_design", "rate_limit", "feedforward",
                               "phi_grid", "trim_roll", "b_roll", "damp_roll", "design") if k not in d]
        if missing:
            raise ValueError(f"pid: missing entries {missing}")
        axes = tuple(d["axes"]) if isinstance(d["axes"], (list, tuple)) else ()
        if list(axes) != axes_of(spec.free_dofs):
            raise ValueError(f"pid: axes = {d['axes']!r}; the spec's free joints need {axes_of(spec.free_dofs)}")
        n = len(axes)
        grid = table_array(d, "phi_grid", (None,), "pid")
        if grid.size < 2 or np.any(np.diff(grid) <= 0):
            raise ValueError("pid: phi_grid must increase, with at least 2 points")
        for k in ("v_design", "rate_limit", "b_roll", "damp_roll"):
            v = d[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (k != "b_roll" and v <= 0) or v == 0:
                raise ValueError(f"pid: {k} = {v!r}: must be a finite number{' > 0' if k != 'b_roll' else ', not 0'}")
        if not isinstance(d["feedforward"], bool) or not isinstance(d["design"], dict):
            raise ValueError("pid: feedforward must be a bool and design an object")
        rdm = table_array(d, "rate_demand_max", (n,), "pid")
        if np.any(rdm <= 0):
            raise ValueError(f"pid: rate_demand_max = {rdm.tolist()}: each must be > 0 rad/s")
        return cls(axes, table_array(d, "kp", (n,), "pid"), table_array(d, "ki", (n,), "pid"), table_array(d, "k_angle", (n,), "pid"), rdm, float(d["v_design"]), float(d["rate_limit"]),
                   d["feedforward"], grid, table_array(d, "trim_roll", (grid.size,), "pid"), float(d["b_roll"]), float(d["damp_roll"]),
                   SignalScales.from_data(d, spec), dict(d["design"]))


@register("pid")
class PIDLaw(TabledLaw):
    """Cascaded PID family; see the module docstring.

    ``tables``: the design (:class:`PIDTables` or its data), made by
    :func:`controllers.design.pid.design_pid` (or read from an artefact); ``make_controller("pid", spec)``
    designs and builds in one call.
    """

    artefact_kind = "pid"

    @classmethod
    def supports(cls, spec: LoopSpec) -> str | None:
        """The roll-axis cascade flies any task with rig_roll free."""
        return roll_reason(spec)

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, tables: PIDTables | Mapping[str, Any]) -> None:
        super().__init__(spec, num_envs)
        require_roll(spec)
        t = self.tables = tables if isinstance(tables, PIDTables) else PIDTables.from_data(tables, spec)
        self.sig = Signals(spec, t.scales)
        self.v_design, self.feedforward = t.v_design, t.feedforward
        n = self.num_envs
        self.outer = {j: PID(n, kp=t.k_angle[k], dt=spec.dt, u_min=-t.rate_demand_max[k], u_max=t.rate_demand_max[k]) for k, j in enumerate(t.axes)}
        self.inner = {j: PID(n, kp=t.kp[k], ki=t.ki[k], dt=spec.dt, rate=t.rate_limit) for k, j in enumerate(t.axes)}
        self._pending = np.ones(n, dtype=bool)
        self._p_ref_prev = np.zeros(n)

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        for e in (*self.outer.values(), *self.inner.values()):
            e.reset(m)
        self._pending |= m

    def act(self, obs: np.ndarray) -> np.ndarray:
        t = self.tables
        s = self.sig(self._check_obs(obs))
        v_air = np.maximum(s.airspeed, 5.0)
        q_scale = (t.v_design / v_air) ** 2
        ff_roll = np.zeros(self.num_envs)
        if t.feedforward:
            ff_roll = np.interp(s.phi, t.phi_grid, t.trim_roll) * q_scale
            p_dot = np.where(self._pending, 0.0, (s.roll_rate_ref - self._p_ref_prev) / self.spec.dt)
            ff_roll = ff_roll + (t.damp_roll * (v_air / t.v_design) * s.roll_rate_ref + p_dot) / (t.b_roll / q_scale)
        self._p_ref_prev = s.roll_rate_ref.copy()
        virt = np.zeros((self.num_envs, 3))
        now = unresolve(s.phi, s.surfaces)  # measured surfaces as virtual (roll, heave, sway) commands
        for j in t.axes:
            demand = self.outer[j].update(s.error[j], 0.0) + s.rate_ref[j]
            ff = ff_roll if j == "rig_roll" else 0.0
            k = AXIS_OF[j]
            if np.any(self._pending):
                self.inner[j].engage(self._pending, demand, s.rate[j], now[:, k], ff=ff, gain_scale=q_scale)
            virt[:, k] = self.inner[j].update(demand, s.rate[j], ff=ff, gain_scale=q_scale)
        self._pending[:] = False
        return np.clip(resolve(s.phi, virt), -1.0, 1.0)

    def describe(self) -> dict[str, Any]:
        """Gains and margins per axis (for the report)."""
        return dict(self.tables.design["tunings"])
