"""Design of the cascaded PID family (:class:`controllers.laws.pid.PIDLaw`): every number its runtime needs.

:func:`design_pid` runs at construction in simulation and at export: it tunes each axis on the
linearised rig (:func:`controllers.design.tuning.tune_axis`, python-control), tabulates the roll trim over
the roll angle (:func:`controllers.design.model.operating_point`, the numba model) and reads the roll
axis's damping and control power; the result is plain data (numpy arrays and JSON values) that
:class:`controllers.laws.pid.PIDTables` checks and the numpy-only runtime executes.  Design targets and
achieved margins travel with it under ``design`` (the artefact's provenance of the law).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from controllers.laws.axes import axes_of
from controllers.laws.base import LoopSpec
from controllers.design.model import check_flag, check_params, check_positive, check_steps, design_aero_model, design_model, operating_point
from controllers.design.signals import signal_scales
from controllers.design.tuning import plain, tune_axis
from rig_env.params import RigParams

RATE_DEMAND_MAX = {"rig_roll": math.radians(400.0), "rig_pitch": math.radians(60.0), "rig_yaw": math.radians(60.0)}
"""Limits of the outer loops' rate demands, rad/s."""
N_PHI = 37  # roll-angle grid of the trim table, -180..180 deg every 10 deg
TARGETS = {"pm_inner": 50.0, "gm_inner": 8.0, "pm_outer": 60.0, "gm_outer": 10.0}
"""Margins the tuning must meet (deg, dB): :func:`controllers.design.tuning.tune_axis`'s defaults."""


def design_pid(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1, rate_filter_hz: float = 10.0,
               feedforward: bool = True) -> dict[str, Any]:
    """The tables of :class:`controllers.laws.pid.PIDTables` for ``spec`` (see the module docstring).

    Design point: the middle of ``spec.airspeed_range`` (ValueError unless > 1 m/s) and roll 0, on the model the
    loop's rig flies (``spec.aero_model``, :func:`controllers.design.model.design_aero_model`).  ValueError, before any
    design work, unless ``link_delay_steps`` is an integer in [0, 100], ``rate_filter_hz`` a finite number > 0,
    ``feedforward`` a bool and ``params`` a RigParams or None.
    """
    check_params(params)
    link_delay_steps = check_steps("link_delay_steps", link_delay_steps)
    rate_filter_hz = check_positive("rate_filter_hz", rate_filter_hz)
    feedforward = check_flag("feedforward", feedforward)
    p = params or RigParams.default()
    v_design = 0.5 * (spec.airspeed_range[0] + spec.airspeed_range[1])
    if v_design <= 1.0:
        raise ValueError(f"airspeed_range = {spec.airspeed_range}: the PID design needs airspeed > 1 m/s")
    axes = axes_of(spec.free_dofs)
    aero = design_aero_model(spec.aero_model)
    tunings = {j: tune_axis(p, spec.free_dofs, j, v_design, spec.dt, link_delay_steps=link_delay_steps, rate_filter_hz=rate_filter_hz,
                            aero_model=aero, **TARGETS) for j in axes}
    rate_lim = p.servos.compensator.rate_limit_deg_s / spec.action_scale_deg  # 1/s, normalised
    phi_grid = np.linspace(-math.pi, math.pi, N_PHI)
    trim_roll = np.array([operating_point(p, spec.free_dofs, v_design, f, aero_model=aero)[1][0] for f in phi_grid])
    sys = design_model(p, spec.free_dofs, v_design, 0.0, aero_model=aero).sys
    r = sys.state_labels.index("rig_roll_rate")
    return {
        "axes": list(axes),
        "kp": np.array([tunings[j].kp for j in axes]), "ki": np.array([tunings[j].ki for j in axes]),
        "k_angle": np.array([tunings[j].k_angle for j in axes]),
        "rate_demand_max": np.array([RATE_DEMAND_MAX[j] for j in axes]),
        "v_design": float(v_design), "rate_limit": float(rate_lim), "feedforward": bool(feedforward),
        "phi_grid": phi_grid, "trim_roll": trim_roll,
        "b_roll": float(sys.B[r, 0]),  # rad/s^2 per unit aileron at V_design
        "damp_roll": float(-sys.A[r, r]),  # 1/s at V_design
        **signal_scales(spec).to_data(),
        "design": {"method": "controllers.design.tuning.tune_axis (loop shaping on the linearised rig)", "targets": dict(TARGETS),
                   "airspeed_design": float(v_design), "airspeed_range": list(spec.airspeed_range), "link_delay_steps": int(link_delay_steps),
                   "rate_filter_hz": float(rate_filter_hz), "params_default": params is None, "aero_model": aero,
                   "tunings": plain({j: t.as_dict() for j, t in tunings.items()})},
    }
