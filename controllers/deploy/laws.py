"""Artefact kinds ``"pid"``, ``"lqr"``, ``"pid_heave_sway"``, ``"lqr_heave_sway"``, ``"lqr_emulation"``: the designed tables of the model-based laws as plain data.

The laws keep their design apart from their runtime (:class:`controllers.laws.pid.PIDTables`,
:class:`controllers.laws.lqr.LQRTables`, :class:`controllers.laws.heave_sway.HeaveSwayTables`), so the artefact stores the tables and loading builds the very
class that flies in simulation, from numpy alone (no python-control, scipy, numba or rig_env):

| kind | arrays | params |
|---|---|---|
| pid | ``kp``, ``ki``, ``k_angle``, ``rate_demand_max`` (n_axes,); ``phi_grid``, ``trim_roll`` (37,); ``sig_*`` | ``axes``, ``v_design``, ``rate_limit``, ``feedforward``, ``b_roll``, ``damp_roll``, ``sig_*``, ``design`` |
| lqr | ``airspeeds``, ``phis``; ``K``, ``u_trim``, ``q_op``, ``A_q``, ``A_w``, ``B`` over (V, phi); ``kalman_gain``; ``sig_*`` | ``phi_step``, ``link_delay_steps``, ``estimator``, ``sig_*``, ``design`` |
| pid_heave_sway | model over V: ``airspeeds``, ``cw``, ``b``, ``A_row``, ``q_op``, ``S``, ``static_theta``, ``static_u``, ``static_n``; ``sig_*`` | ``kp``, ``ki``, ``k_angle``, ``v_design``, ``rate_limit``, ``feedforward``, ``decouple``, ``ref_*``, ``sig_*``, ``design`` |
| lqr_heave_sway | the same model; ``K`` (V, 2 nq + 1), ``A_q``, ``A_w``, ``B`` over V; ``kalman_gain``; ``sig_*`` | ``link_delay_steps``, ``ref_*``, ``sig_*``, ``design`` |
| lqr_emulation | ``airspeeds``, ``K`` (V, 11 + d), ``q_op`` (V, 2); servo models ``comp_phi``, ``comp_gamma``, ``hawk_phi``, ``hawk_gamma``; ``ref_scales``; ``sig_*`` | ``hawk_delay_steps``, ``arm_length``, ``sig_*``, ``design`` |

``design`` is the law's provenance: tuning targets and achieved margins (pid), weights, grid, noise
model and loop margins (lqr), the airspeed range and the sensor layout assumed.  ``ref_*``: the
heave/sway reference parser's numbers (:class:`controllers.laws.references.ReferenceConstants`: driven
joint, sensor scales, g, the oscillation ramp time, arm length).  Importing this module also
registers the learned laws' kinds "ppo" and "sac" (:mod:`controllers.deploy.policy_kinds`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from controllers.laws.base import Controller, LoopSpec
from controllers.deploy.artefact import register_kind
from controllers.laws.emulation import EmulationLQR
from controllers.laws.heave_sway import HeaveSwayLQR, HeaveSwayPID
from controllers.laws.linear import LinearLaw
from controllers.laws.lqr import LQRLaw
from controllers.laws.pid import PIDLaw


def _exporter(cls: type[Controller]) -> Any:
    def to_arrays(law: Controller) -> dict[str, Any]:
        if not isinstance(law, cls):
            raise TypeError(f"kind {cls.artefact_kind!r} exports a {cls.__name__}; got {type(law).__name__}")
        return law.to_data()

    return to_arrays


def _pid(data: Mapping[str, Any], spec: LoopSpec) -> PIDLaw:
    return PIDLaw.from_data(data, spec)


def _lqr(data: Mapping[str, Any], spec: LoopSpec) -> LQRLaw:
    return LQRLaw.from_data(data, spec)


register_kind("pid", _exporter(PIDLaw), _pid)
register_kind("lqr", _exporter(LQRLaw), _lqr)
register_kind("pid_heave_sway", _exporter(HeaveSwayPID), HeaveSwayPID.from_data)
register_kind("lqr_heave_sway", _exporter(HeaveSwayLQR), HeaveSwayLQR.from_data)
register_kind("lqr_emulation", _exporter(EmulationLQR), EmulationLQR.from_data)


def _to_arrays(law: Controller) -> dict[str, Any]:
    """A LinearLaw's arrays, or ``law.linear_form()`` (a dict with K, obs0, u0, rate_limit) of another law
    that is static and linear in its observation (an LQR sets ``artefact_kind = "linear"`` and provides it)."""
    if isinstance(law, LinearLaw):
        return {"K": law.K.copy(), "obs0": law.obs0.copy(), "u0": law.u0.copy(), "rate_limit": law.rate_limit.copy()}
    form = getattr(law, "linear_form", None)
    if form is None:
        raise TypeError(f"kind 'linear' exports a LinearLaw or a law with linear_form(); got {type(law).__name__}")
    d = dict(form())
    unknown = sorted(set(d) - {"K", "obs0", "u0", "rate_limit"})
    if unknown:
        raise ValueError(f"linear_form(): unknown key(s) {unknown}; allowed K, obs0, u0, rate_limit")
    return _to_arrays(LinearLaw(law.spec, 1, **d))  # validates shapes and values, fills the defaults


def _from_arrays(data: Mapping[str, Any], spec: LoopSpec) -> LinearLaw:
    missing = [k for k in ("K", "obs0", "u0", "rate_limit") if k not in data]
    if missing:
        raise ValueError(f"linear: missing array(s) {missing}")
    return LinearLaw(spec, 1, K=data["K"], obs0=data["obs0"], u0=data["u0"], rate_limit=data["rate_limit"])



register_kind("linear", _to_arrays, _from_arrays)

from controllers.deploy import policy_kinds  # noqa: E402, F401  (registers "ppo" and "sac": the learned laws)
