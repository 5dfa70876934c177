"""Joint friction from wind-off tests (the paper's Sec. IV): the test set-up, its simulation, the
friction-velocity loop and the first estimates of the seven LuGre parameters (eqs. 19-21).

The paper's test (Fig. 4(a)) hangs springs and masses on one joint, the others held, wind off, and
records the joint's angle while the spring-mass system oscillates and friction dissipates it
(Fig. 4(b)).  In the model that set-up is the joint's test fixture (``fixture.<joint>.*``, see
:class:`rig_env.params.Fixture`), carried by a record's ``setup``: :func:`fig4_setup` writes it and
:func:`simulate_friction_test` makes the record.  Such a record is an ordinary
:class:`~rig_env.sysid.records.FlightRecord` (one free joint, airspeed 0, the fixture in its set-up), so
the fitting core refines the estimates below by fitting the angle history.

First estimates (the paper's "basic estimates from the experimental friction-velocity graph"), module
:mod:`rig_env.sysid.friction_loop`; free decays of a joint under gravity or a spring (the later rig's
rig-roll drops): :mod:`rig_env.sysid.free_decay`.  Both are re-exported here.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from rig_env.params import LIMITED_JOINTS, ParameterError, RigParams
from rig_env.simulate import simulate
from rig_env.sysid.checks import is_integer, number
from rig_env.sysid.free_decay import free_decay_estimates  # noqa: F401  (re-exported)
from rig_env.sysid.friction_loop import FrictionLoop, friction_first_estimates, friction_velocity_loop, steady_sliding  # noqa: F401
from rig_env.sysid.friction_loop import check_joint, check_rig
from rig_env.sysid.records import FlightRecord

ENCODER_13BIT = 2.0 * math.pi / 2**13
"""rad: one count of a 13-bit encoder (0.044 deg), the resolution of the model gimbal's angle sensors."""

FIXTURE_FIELDS = ("stiffness", "neutral", "inertia", "torque")


def fig4_setup(
    joint: str,
    stiffness: float,
    inertia: float,
    neutral: float = 0.0,
    torque: float = 0.0,
    stops_deg: float | None = None,
) -> dict[str, float]:
    """The set-up overrides (a record's ``setup``) of the paper's Fig. 4(a) test on ``joint``.

    stiffness: N m/rad, the springs' torsional stiffness about the joint (k r^2 of springs of linear
    stiffness k at lever r); inertia: kg m^2, the masses turning with the joint (m r^2); neutral: rad,
    the joint angle at which the springs are relaxed; torque: N m, a constant torque (a hanging
    weight's m g r).  stops_deg: for a joint with stops (:data:`rig_env.params.LIMITED_JOINTS`), the
    symmetric stop angle of the test (deg), when its swing exceeds the rig's flight stops; None keeps
    the rig's.  Returns {dotted parameter name: value} in the parameter file's units.  Each value is
    checked against its parameter's allowed range (ParameterError naming the argument and the parameter).
    """
    check_joint(joint)
    args = {"stiffness": stiffness, "neutral": neutral, "inertia": inertia, "torque": torque}
    setup = {f"fixture.{joint}.{f}": number(f, args[f]) for f in FIXTURE_FIELDS}
    rig = RigParams.default()
    for f in FIXTURE_FIELDS:  # each against its range, as the parameter file checks it
        try:
            rig.replace(**{f"fixture.{joint}.{f}": setup[f"fixture.{joint}.{f}"]})
        except ParameterError as e:
            raise ParameterError(f"{f} = {args[f]!r}: {e}") from None
    if stops_deg is not None:
        if joint not in LIMITED_JOINTS:
            raise ValueError(f"stops_deg: {joint} has no stops (joints with stops: {list(LIMITED_JOINTS)})")
        allowed = "a finite number > 0 (deg: the stops at -stops_deg and +stops_deg)"
        deg = number("stops_deg", stops_deg, allowed=allowed)
        if not deg > 0.0:
            raise ValueError(f"stops_deg = {stops_deg!r}: must be {allowed}")
        stops = {f"stops.{joint}.lower_deg": -deg, f"stops.{joint}.upper_deg": deg}
        try:
            rig.replace(**stops)
        except ParameterError as e:
            raise ParameterError(f"stops_deg = {stops_deg!r}: {e}") from None
        setup.update(stops)
    return setup


def simulate_friction_test(
    params: RigParams,
    joint: str,
    setup: Mapping[str, float],
    q0: float,
    duration: float,
    rate_hz: float = 80.0,
    noise_std: float = 0.0,
    seed: int = 0,
    *,
    qd0: float = 0.0,
    resolution: float | None = None,
    name: str | None = None,
) -> FlightRecord:
    """A simulated wind-off friction test: ``joint`` alone free from rest at q0 (rad), the others held at 0.

    The rig ``params`` with the ``setup`` overrides (:func:`fig4_setup`) are simulated by the joint-space
    model with LuGre friction and the stops on, airspeed 0 and the aerodynamics off (wind off: the
    model's quasi-steady aerodynamics is a model of the tunnel flow, not of a body swinging through
    still air), for ``duration`` s, sampled at ``rate_hz`` (the control rate, an integer divisor of the
    physics rate's 400 Hz, or as :func:`rig_env.simulate` allows).  The recorded angle is the true one
    plus white Gaussian noise of ``noise_std`` rad (seeded by ``seed``), then rounded to the encoder's
    ``resolution`` (rad per count, e.g. :data:`ENCODER_13BIT`; None: not quantised).  qd0: initial rate,
    rad/s.  Returns a :class:`FlightRecord` with no rate measurement (``qd`` None), surfaces at zero,
    airspeed 0 and the set-up in ``setup``.
    """
    check_rig(params)
    check_joint(joint)
    if setup is not None and not isinstance(setup, Mapping):
        raise ValueError(f"setup = {setup!r:.80}: give a mapping {{dotted parameter name: value}} (fig4_setup) or None")
    q0, qd0, duration, rate_hz = (number(label, v) for label, v in (("q0", q0), ("qd0", qd0), ("duration", duration), ("rate_hz", rate_hz)))
    noise_std = number("noise_std", noise_std, allowed="a finite number >= 0 (rad)")
    if noise_std < 0.0:
        raise ValueError(f"noise_std = {noise_std}: must be a finite number >= 0 (rad)")
    if resolution is not None and not number("resolution", resolution, allowed="a positive number of rad per count, or None") > 0.0:
        raise ValueError(f"resolution = {resolution}: must be a positive number of rad per count, or None")
    if not is_integer(seed):
        raise ValueError(f"seed = {seed!r}: must be an integer (of numpy.random.default_rng)")
    if name is not None and not isinstance(name, str):
        raise ValueError(f"name = {name!r}: must be a string or None")
    p = params.replace(**dict(setup)) if setup else params
    r = simulate(
        p, [q0], [qd0], duration, free_dofs=[joint], airspeed=0.0,
        aero=False, friction=True, stops=True, servo=False, control_rate=rate_hz,
    )  # fmt: skip
    if r.failed.any():
        raise RuntimeError(f"simulate_friction_test: the simulation of {joint} failed ({r.status_text()[0]})")
    q = r.q[:, 0].copy()
    if noise_std > 0.0:
        q += np.random.default_rng(seed).normal(0.0, noise_std, q.shape)
    if resolution is not None:
        q = np.round(q / resolution) * resolution
    label = name or f"friction test {joint} from {math.degrees(q0):.0f} deg"
    return FlightRecord(t=r.t, free_dofs=(joint,), q=q[:, None], airspeed=0.0, setup=dict(setup or {}), name=label)
