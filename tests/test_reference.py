"""The fixed-step joint-space integrator against a converged stiff reference (rig_env.reference).

rig_env.simulate advances the LuGre bristle ODE (eq. 19) by its exact frozen-rate solution on either
side of each RK4 step (Strang splitting); rig_env.reference puts eq. (19) in the state and integrates
everything together with scipy's Radau (or DOP853 without friction) at tolerances 1e-10 .. 1e-13.
Both call the same acceleration kernel, so the differences below are integration error only, and
their rate of decrease with the step tests the claimed orders: 4 without friction (RK4), 2 with it
(the symmetric split).  Servos are ideal on both sides (simulate(..., servo=False)), aero on at
20 m/s, stops on (not reached from these states).  Horizons are 2 s: rig yaw has no restoring
moment, and the reference must stay reliable (rtol 1e-10 and 1e-12 runs agree to about 1e-10 rad).
"""

from __future__ import annotations

import numpy as np
import pytest

import rig_env
from rig_env import JOINTS
from rig_env.reference import simulate_scipy

T_END = 2.0  # s
N_ENV = 2  # random initial states per free set
H_FRICTION = (0.0025, 0.00125, 0.000625)  # physics steps of the friction-on runs, s (12.5 ms / 5, 10, 20)
H_SMOOTH = (0.0125, 0.00625, 0.003125)  # friction off: larger steps keep RK4's error far above the reference's
FREE_SETS = {
    "model_pitch": ("model_pitch",),
    "roll+model_pitch": ("rig_roll", "model_pitch"),
    "all-five": JOINTS,
}

# Tolerances (measured on the default rig: max error 3e-6 .. 1.2e-5 rad at 2.5 ms, order 1.7-2.0)
TOL_2P5MS = 3e-5  # rad, max over joints, samples and environments at h = 2.5 ms
MIN_SHRINK_4X = 10.0  # error(2.5 ms) / error(0.625 ms); exactly second order gives 16
MIN_ORDER_FRICTION = 1.8  # least-squares order over all free sets (aggregated RMS error)
MIN_ORDER_SMOOTH = 3.5  # RK4 without friction


@pytest.fixture(scope="module")
def params() -> rig_env.RigParams:
    return rig_env.RigParams.default()


def _states(free: tuple[str, ...], seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = len(free)
    return rng.uniform(-0.1, 0.1, (N_ENV, n)), rng.uniform(-0.3, 0.3, (N_ENV, n))


def _order(h, err) -> float:
    """Least-squares slope of log(error) against log(step)."""
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


@pytest.fixture(scope="module")
def friction_errors(params) -> dict[str, np.ndarray]:
    """free set -> (len(H_FRICTION), N_ENV, n_t, n_free) fixed-step minus reference angles, friction on."""
    out = {}
    for seed, (name, free) in enumerate(FREE_SETS.items()):
        Q0, QD0 = _states(free, seed)
        ref = np.stack([simulate_scipy(params, Q0[i], QD0[i], T_END, free_dofs=free, rtol=1e-10, atol=1e-12).q for i in range(N_ENV)])
        errs = []
        for h in H_FRICTION:
            r = rig_env.simulate(params, Q0, QD0, T_END, free_dofs=free, servo=False, physics_dt=h)
            assert not r.failed.any()
            errs.append(r.q - ref)
        out[name] = np.stack(errs)
    return out


@pytest.mark.parametrize("name", list(FREE_SETS))
def test_agrees_with_stiff_reference_friction_on(friction_errors, name):
    """Aero + friction at 20 m/s: within TOL_2P5MS at 2.5 ms, and about 4x smaller per halving."""
    e = np.abs(friction_errors[name]).reshape(len(H_FRICTION), -1).max(axis=1)
    assert e[0] < TOL_2P5MS, f"max error {e[0]:.3g} rad at h = 2.5 ms"
    assert e[0] / e[-1] > MIN_SHRINK_4X, f"errors {e} for h = {H_FRICTION}: not second order"


def test_order_with_friction_is_two(friction_errors):
    """Strang splitting keeps the friction model second order (a one-sided update would give 1)."""
    rms = np.array([np.sqrt(np.mean(np.concatenate([e[k].ravel() ** 2 for e in friction_errors.values()]))) for k in range(len(H_FRICTION))])
    order = _order(H_FRICTION, rms)
    assert order > MIN_ORDER_FRICTION, f"RMS errors {rms} for h = {H_FRICTION}: order {order:.2f}"


def test_order_without_friction_is_four(params):
    """Aero on, friction off: RK4's error falls 16x per halving against a DOP853 rtol 1e-13 reference."""
    free = JOINTS
    Q0, QD0 = _states(free, 7)
    ref = np.stack(
        [
            simulate_scipy(params, Q0[i], QD0[i], T_END, free_dofs=free, friction=False, method="DOP853", rtol=1e-13, atol=1e-15).q
            for i in range(N_ENV)
        ]
    )
    err = []
    for h in H_SMOOTH:
        r = rig_env.simulate(params, Q0, QD0, T_END, free_dofs=free, servo=False, friction=False, physics_dt=h)
        err.append(np.abs(r.q - ref).max())
    order = _order(H_SMOOTH, err)
    assert err[-1] > 1e-11, "errors too close to the reference's own accuracy to measure an order"
    assert order > MIN_ORDER_SMOOTH, f"max errors {err} for h = {H_SMOOTH}: order {order:.2f}"
