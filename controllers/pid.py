"""``PIDLaw`` (kind ``"pid"``): cascaded angle/rate loops per rig axis, as a rig engineer writes them.

| axis | when | measured | outer loop (P) | inner loop (PI) | surface |
|---|---|---|---|---|---|
| roll | always | roll error, roll rate | rate demand from roll error (+ task's rate reference) | roll rate | compensator aileron |
| heave | rig_pitch free | rig_pitch angle, rate | rate demand from the rig_pitch error (0 - angle unless the task sets a reference) | rig_pitch rate | elevator, resolved by roll angle |
| sway | rig_yaw free | rig_yaw angle, rate | rate demand from the rig_yaw error (likewise) | rig_yaw rate | rudder, resolved by roll angle |

Each loop is a :class:`controllers.pid_element.PID` (explicit dt, anti-windup by back-calculation,
output limit +-1 = +-40 deg, rate limit = the servo's 350 deg/s, bumpless engagement).  Heave and
sway demands are turned into elevator and rudder with the measured roll angle
(:func:`controllers.model.resolve`).  The rate loop acts on the measured, filtered rate, so the
cascade is a PID on the angle whose derivative is on the measurement, filtered by the sensor.

Gains: :func:`controllers.tuning.tune_axis` at construction (stated margins; ``law.tunings`` holds
gains and achieved margins) at the middle of ``spec.airspeed_range``; the rate-loop gains are
scaled by ``(V_design / V)^2`` with the measured airspeed.  Feedforward on the roll axis: the trim
aileron that holds the arm's gravity imbalance at the measured roll angle (a table over the roll
angle from :func:`controllers.model.operating_point`), and, when the task gives a rate reference,
the aileron that balances the roll damping at that rate plus its rate of change, from the linear
model.  ``reset(mask)`` re-engages the masked environments bumplessly from the measured flaps.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from controllers.base import Controller, LoopSpec, register
from controllers.model import AXIS_OF, design_model, operating_point, resolve
from controllers.pid_element import PID
from controllers.signals import Signals
from controllers.tuning import AxisTuning, axes_of, tune_axis
from rig_env.params import RigParams
from rig_env.physics import layout as L

RATE_DEMAND_MAX = {"rig_roll": math.radians(400.0), "rig_pitch": math.radians(60.0), "rig_yaw": math.radians(60.0)}
"""Limits of the outer loops' rate demands, rad/s."""
N_PHI = 37  # roll-angle grid of the trim table, -180..180 deg every 10 deg


@register("pid")
class PIDLaw(Controller):
    """Cascaded PID family; see the module docstring.  Keyword arguments:

    | argument | default | meaning |
    |---|---|---|
    | params | default rig | rig parameters of the design model |
    | link_delay_steps | 1 | telemetry delay the tuning accounts for, control steps |
    | rate_filter_hz | 10.0 | the rate sensor's filter the tuning accounts for, Hz |
    | feedforward | True | trim and rate-reference feedforward on the roll axis |
    """

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, params: RigParams | None = None, link_delay_steps: int = 1,
                 rate_filter_hz: float = 10.0, feedforward: bool = True) -> None:
        super().__init__(spec, num_envs)
        self.sig = Signals(spec)
        p = params or RigParams.default()
        self.v_design = 0.5 * (spec.airspeed_range[0] + spec.airspeed_range[1])
        if self.v_design <= 1.0:
            raise ValueError(f"airspeed_range = {spec.airspeed_range}: the PID design needs airspeed > 1 m/s")
        self.axes = axes_of(spec.free_dofs)
        self.tunings: dict[str, AxisTuning] = {
            j: tune_axis(p, spec.free_dofs, j, self.v_design, spec.dt, link_delay_steps=link_delay_steps, rate_filter_hz=rate_filter_hz)
            for j in self.axes
        }
        n = self.num_envs
        rate_lim = math.degrees(p.to_vector()[L.P_SERVOS_COMPENSATOR_RATE_LIMIT_DEG_S]) / spec.action_scale_deg  # 1/s, normalised (vector in rad/s)
        self.outer = {j: PID(n, kp=t.k_angle, dt=spec.dt, u_min=-RATE_DEMAND_MAX[j], u_max=RATE_DEMAND_MAX[j]) for j, t in self.tunings.items()}
        self.inner = {j: PID(n, kp=t.kp, ki=t.ki, dt=spec.dt, rate=rate_lim) for j, t in self.tunings.items()}
        self.feedforward = bool(feedforward)
        self.phi_grid = np.linspace(-math.pi, math.pi, N_PHI)
        self.trim_roll = np.array([operating_point(p, spec.free_dofs, self.v_design, f)[1][0] for f in self.phi_grid])
        sys = design_model(p, spec.free_dofs, self.v_design, 0.0).sys
        r = sys.state_labels.index("rig_roll_rate")
        self.b_roll = float(sys.B[r, 0])  # rad/s^2 per unit aileron at V_design
        self.damp_roll = float(-sys.A[r, r])  # 1/s at V_design
        self._pending = np.ones(n, dtype=bool)
        self._p_ref_prev = np.zeros(n)

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        for e in (*self.outer.values(), *self.inner.values()):
            e.reset(m)
        self._pending |= m

    def _errors(self, s: Signals) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(angle error, rate feedforward, measured rate) per axis, rad and rad/s."""
        return {j: (s.error[j], s.rate_ref[j], s.rate[j]) for j in self.tunings}

    def act(self, obs: np.ndarray) -> np.ndarray:
        s = self.sig(self._check_obs(obs))
        v_air = np.maximum(s.airspeed, 5.0)
        q_scale = (self.v_design / v_air) ** 2
        ff_roll = np.zeros(self.num_envs)
        if self.feedforward:
            ff_roll = np.interp(s.phi, self.phi_grid, self.trim_roll) * q_scale
            p_dot = np.where(self._pending, 0.0, (s.roll_rate_ref - self._p_ref_prev) / self.spec.dt)
            ff_roll = ff_roll + (self.damp_roll * (v_air / self.v_design) * s.roll_rate_ref + p_dot) / (self.b_roll / q_scale)
        self._p_ref_prev = s.roll_rate_ref.copy()
        virt = np.zeros((self.num_envs, 3))
        now = self._virtual_now(s)
        for j, (e, rate_ff, rate) in self._errors(s).items():
            demand = self.outer[j].update(e, 0.0) + rate_ff
            ff = ff_roll if j == "rig_roll" else 0.0
            k = AXIS_OF[j]
            if np.any(self._pending):
                self.inner[j].engage(self._pending, demand, rate, now[:, k], ff=ff, gain_scale=q_scale)
            virt[:, k] = self.inner[j].update(demand, rate, ff=ff, gain_scale=q_scale)
        self._pending[:] = False
        return np.clip(resolve(s.phi, virt), -1.0, 1.0)

    def _virtual_now(self, s: Signals) -> np.ndarray:
        """(n, 3) measured surfaces expressed as virtual (roll, heave, sway) commands (inverse of resolve)."""
        c, sn = np.cos(s.phi), np.sin(s.phi)
        a, de, dr = s.surfaces[:, 0], s.surfaces[:, 1], s.surfaces[:, 2]
        return np.stack([a, c * de - sn * dr, sn * de + c * dr], axis=1)

    def describe(self) -> dict[str, Any]:
        """Gains and margins per axis (for the report)."""
        return {j: t.as_dict() for j, t in self.tunings.items()}
