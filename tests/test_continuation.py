"""Continuation (rig_env.bifurcation) against closed forms, and the rig's continuation against trim, linearize and simulate.

Closed forms: the fold of x' = p - x^2 (branches x = -+sqrt(p), eigenvalue -2x); the Brusselator's Hopf
point (b = 1 + a^2, omega = a) and its equilibria's eigenvalues; the Hopf normal form's periodic orbits
(radius sqrt(mu), period 2 pi / omega, non-trivial Floquet multiplier exp(-+2 mu T)).  The rig: its
equilibria are rig_env.trim's, its eigenvalues rig_env.linearize's, a Hopf point's eigenvalues from
linearize sit on the imaginary axis at the Hopf frequency, and a limit cycle found by shooting is the
one a long rig_env.simulate run settles on.
"""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

import rig_env
from rig_env.bifurcation import equilibria, orbits, rk4_flow
from rig_env.bifurcation.plot import plot_branch
from rig_env.bifurcation.result import SpecialPoint, readable


@pytest.fixture(scope="module")
def params() -> rig_env.RigParams:
    """The paper's model: the rig's branches below, and the analysis of Figs. 8 and 9 (docs/MODEL.md 7), were made on it."""
    return rig_env.RigParams.paper()


# ---------------------------------------------------------------------------- closed forms
def test_fold_of_p_minus_x_squared_is_passed_by_pseudo_arclength():
    """x' = p - x^2 from the unstable branch x = -sqrt(p) at p = 1 down through the fold at p = 0 and back up
    the stable branch x = +sqrt(p): the fold is located at (0, 0) and every sample is on its branch."""
    values = np.linspace(1.0, -1.0, 9)
    br = equilibria(lambda x, p: np.array([p - x[0] ** 2]), [-0.9], values)
    assert br.folds == pytest.approx([0.0], abs=1e-8)
    fold = br.points("fold")[0]
    assert abs(fold.state[0]) < 1e-4
    # the branch crosses 1, 0.75, 0.5, 0.25 twice each (0 only at the fold itself), in the order of the curve
    assert br.values == pytest.approx([1.0, 0.75, 0.5, 0.25, 0.25, 0.5, 0.75, 1.0], abs=1e-12)
    x = br.states[:, 0]
    expected = np.sqrt(br.values) * np.array([-1, -1, -1, -1, 1, 1, 1, 1])
    assert x == pytest.approx(expected, abs=1e-9)
    assert br.eigenvalues[:, 0].real == pytest.approx(-2 * expected, abs=1e-6)
    assert list(br.stable) == [False] * 4 + [True] * 4


def test_hopf_point_of_the_brusselator_is_at_b_equals_1_plus_a_squared():
    """Brusselator x' = a - (b + 1) x + x^2 y, y' = b x - x^2 y: equilibrium (a, b/a), Jacobian trace b - 1 - a^2
    and determinant a^2, so a Hopf point at b = 1 + a^2 with frequency omega = a."""
    a = 1.5

    def f(z, b):
        x, y = z
        return np.array([a - (b + 1) * x + x * x * y, b * x - x * x * y])

    values = np.linspace(2.0, 4.0, 21)
    br = equilibria(f, [1.4, 1.4], values)
    assert br.hopf == pytest.approx([1 + a * a], abs=1e-7)
    h = br.hopf_points()[0]
    assert h.omega == pytest.approx(a, rel=1e-6)
    assert h.state == pytest.approx([a, (1 + a * a) / a], abs=1e-7)
    assert br.states[:, 0] == pytest.approx(np.full(values.size, a), abs=1e-9)
    assert br.states[:, 1] == pytest.approx(values / a, abs=1e-9)
    lam = br.eigenvalues
    assert lam.sum(axis=1).real == pytest.approx(values - 1 - a * a, abs=1e-6)  # trace
    assert np.prod(lam, axis=1).real == pytest.approx(np.full(values.size, a * a), rel=1e-6)  # determinant
    assert list(br.stable) == list(values < 1 + a * a)
    assert br.folds.size == 0 and br.branch_points.size == 0


@pytest.mark.parametrize("sign", [-1.0, 1.0], ids=["supercritical", "subcritical"])
def test_periodic_orbits_of_the_hopf_normal_form(sign):
    """r' = mu r + sign r^3, theta' = omega (in x, y): orbits of radius sqrt(-sign mu) with period 2 pi / omega and
    non-trivial Floquet multiplier exp(-2 |mu| T) (stable, supercritical) or exp(+2 |mu| T) (unstable)."""
    w = 2.0

    def field(X, P):
        r2 = (X**2).sum(axis=1)
        return np.stack([P * X[:, 0] - w * X[:, 1] + sign * X[:, 0] * r2, w * X[:, 0] + P * X[:, 1] + sign * X[:, 1] * r2], axis=1)

    br = equilibria(lambda x, p: field(x[None, :], np.array([p]))[0], [0.0, 0.0], np.linspace(-0.5, 0.5, 11))
    assert br.hopf == pytest.approx([0.0], abs=1e-8)
    ob = orbits(field, rk4_flow(field, 200), br.hopf_points()[0], (-0.5, 0.5), amplitude=0.01, max_orbits=30)
    assert ob.values.size >= 8
    mu = ob.values
    assert np.all(-sign * mu > 0)
    radius = np.sqrt(-sign * mu)
    assert ob.upper[:, 0] == pytest.approx(radius, rel=2e-4)
    assert ob.lower[:, 1] == pytest.approx(-radius, rel=2e-4)
    assert ob.periods == pytest.approx(np.full(mu.size, 2 * np.pi / w), rel=1e-8)
    nontrivial = np.abs(ob.multipliers).min(axis=1) if sign < 0 else np.abs(ob.multipliers).max(axis=1)
    assert nontrivial == pytest.approx(np.exp(2 * sign * np.abs(mu) * 2 * np.pi / w), rel=1e-4)
    assert np.all(ob.stable == (sign < 0))
    assert ob.criticality == ("supercritical" if sign < 0 else "subcritical")
    assert ob.special_points == () and ob.folds.size == 0


def test_subcritical_hopf_orbits_turn_at_the_fold_of_cycles_where_mu_is_minus_a_quarter():
    """r' = r (mu + r^2 - r^4), theta' = omega: a subcritical Hopf point at mu = 0; orbits where mu = r^4 - r^2, so the
    family turns at mu = -1/4, r^2 = 1/2 (a fold of cycles, period 2 pi / omega), unstable on the inner branch (the
    amplitude's multiplier exp(2 r^2 (1 - 2 r^2) T) > 1) and stable on the outer one, which reaches mu = 0.5 at
    r^2 = (1 + sqrt 3) / 2.  The jump and hysteresis of a subcritical loss of stability, from closed form."""
    w = 2.0

    def field(X, P):
        r2 = (X**2).sum(axis=1)
        g = P + r2 - r2 * r2
        return np.stack([g * X[:, 0] - w * X[:, 1], w * X[:, 0] + g * X[:, 1]], axis=1)

    br = equilibria(lambda x, p: field(x[None, :], np.array([p]))[0], [0.0, 0.0], np.linspace(-0.5, 0.5, 11))
    ob = orbits(field, rk4_flow(field, 200), br.hopf_points()[0], (-0.5, 0.5), amplitude=0.05, max_orbits=60)
    assert ob.criticality == "subcritical"
    assert [c.kind for c in ob.special_points] == ["cycle_fold"]
    fold = ob.points("cycle_fold")[0]
    assert ob.folds == pytest.approx([-0.25], abs=1e-6)
    assert fold.upper[0] == pytest.approx(math.sqrt(0.5), rel=1e-4) and fold.period == pytest.approx(math.pi, rel=1e-8)
    assert np.sort(np.abs(fold.multipliers)) == pytest.approx([1.0, 1.0], abs=1e-5)  # the amplitude's multiplier at +1 too
    r2 = ob.upper[:, 0] ** 2
    assert ob.values == pytest.approx(r2 * r2 - r2, abs=1e-4)
    assert np.all(ob.stable == (r2 > 0.5))
    assert ob.stable[0] == False and ob.stable[-1] == True and ob.values[-1] > 0.4  # noqa: E712
    assert ob.multiplier_errors.max() < 1e-6 and ob.reliable.all()  # a smooth flow: the monodromy matrices are exact to 1e-6


def test_an_orbit_s_stability_is_read_only_where_its_multipliers_stand_clear_of_the_error():
    """readable(multipliers, error): every multiplier but the trivial one more than 3 errors off the unit circle, the
    error at least the trivial multiplier's distance from 1; else the verdict would be the finite differences' noise."""
    assert readable(np.array([1.0 + 1e-9, 0.5, 1e-8]), 1e-9)
    assert readable(np.array([0.9886, 0.918, 1.8e-5]), 0.003)  # the rig's lower band at the 1 ms step: stable, clearly
    assert not readable(np.array([1.0, 0.99]), 0.01)  # could be either side of the circle
    assert not readable(np.array([0.97, 0.93]), 0.001)  # the trivial multiplier 0.03 off: so may the other be
    assert not readable(np.array([1.373, 0.426]), 0.02)  # no multiplier near 1 at all: the matrix is noise
    assert not readable(np.array([1.0, np.nan]), 0.0) and not readable(np.array([1.0, 0.5]), math.nan)


def _hopf_at_origin(w: float, rest: list[complex]) -> SpecialPoint:
    """The Hopf point at p = 0 of a field whose first two states are the normal form r' = p r - r^3 at frequency w."""
    return SpecialPoint("hopf", 0.0, np.zeros(2 + len(rest)), np.array([1j * w, -1j * w, *rest]), omega=w,
                        eigenvector=np.array([1.0, -1j] + [0.0] * len(rest)) / math.sqrt(2.0))


def test_period_doubling_where_a_half_turning_transverse_mode_loses_its_damping():
    """Normal-form orbits r = sqrt(p) in (x, y) and a transverse pair (u, v) whose axes turn half a turn per
    revolution, with rates l1 = p - 0.3 and l2 = -1 along them: over a period T the pair maps to -exp(l1 T),
    -exp(l2 T) (the half turn flips both), so a real multiplier passes -1 at p = 0.3 exactly and the orbits lose
    their stability there."""
    w = 2.0

    def field(X, P):
        x, y, u, v = X.T
        r2 = x * x + y * y
        r = np.sqrt(r2 + 1e-30)  # finite (and c = s = 0) at the equilibrium; the orbits keep r > 0.03
        c, s = x / r, y / r  # cos, sin of the orbit's angle
        m, d = 0.5 * ((P - 0.3) - 1.0), 0.5 * ((P - 0.3) + 1.0)  # R(theta / 2) diag(l1, l2) R(theta / 2)^T = m I + d [[c, s], [s, -c]]
        return np.stack([P * x - w * y - x * r2, w * x + P * y - y * r2,
                         -0.5 * w * v + (m + d * c) * u + d * s * v, 0.5 * w * u + d * s * u + (m - d * c) * v], axis=1)

    ob = orbits(field, rk4_flow(field, 200), _hopf_at_origin(w, [-0.5, -0.5]), (0.0, 0.6), amplitude=0.05, max_orbits=40)
    assert ob.criticality == "supercritical"
    assert [c.kind for c in ob.special_points] == ["period_doubling"]
    pd = ob.points("period_doubling")[0]
    assert pd.value == pytest.approx(0.3, abs=1e-6)
    T = 2 * math.pi / w
    assert np.sort(pd.multipliers.real) == pytest.approx(sorted([-1.0, -math.exp(-T), math.exp(-2 * 0.3 * T), 1.0]), abs=1e-5)
    assert np.all(ob.stable == (ob.values < 0.3))


def test_torus_bifurcation_where_a_turning_transverse_pair_loses_its_damping():
    """Normal-form orbits in (x, y) and a transverse pair u + i v with rate (p - 0.3) + i kappa w: over a period T its
    multipliers are exp((p - 0.3) T) exp(+-2 pi i kappa), a complex pair through the unit circle at p = 0.3 with
    argument 2 pi kappa (Neimark-Sacker)."""
    w, kappa = 2.0, 0.3

    def field(X, P):
        x, y, u, v = X.T
        r2 = x * x + y * y
        return np.stack([P * x - w * y - x * r2, w * x + P * y - y * r2, (P - 0.3) * u - kappa * w * v, kappa * w * u + (P - 0.3) * v], axis=1)

    ob = orbits(field, rk4_flow(field, 200), _hopf_at_origin(w, [-0.3 + kappa * w * 1j, -0.3 - kappa * w * 1j]), (0.0, 0.6),
                amplitude=0.05, max_orbits=40)
    assert [c.kind for c in ob.special_points] == ["torus"]
    ns = ob.points("torus")[0]
    assert ns.value == pytest.approx(0.3, abs=1e-6)
    pair = ns.multipliers[np.abs(ns.multipliers.imag) > 0.1]
    assert np.abs(pair) == pytest.approx([1.0, 1.0], abs=1e-6)
    assert np.sort(np.angle(pair)) == pytest.approx([-2 * math.pi * kappa, 2 * math.pi * kappa], abs=1e-5)
    assert np.all(ob.stable == (ob.values < 0.3))
    with pytest.raises(ValueError, match="the bifurcations of an orbit family are"):
        ob.points("hopf")


def test_an_orbit_family_between_two_hopf_points_ends_where_it_shrinks_back():
    """r' = mu(p) r - r^3, theta' = omega with mu(p) = p (1 - p): Hopf points at p = 0 and p = 1 and, between them,
    stable orbits of radius sqrt(p (1 - p)) (at most 1/2 at p = 1/2).  The family from p = 0 grows and shrinks back
    to the equilibrium at p = 1, where it ends; the curve is not traced on along the equilibrium as orbits of zero
    size (with room for 300 orbits, the tracing stops within a few of the second Hopf point)."""
    w = 2.0

    def field(X, P):
        mu = P * (1.0 - P)
        r2 = (X**2).sum(axis=1)
        return np.stack([mu * X[:, 0] - w * X[:, 1] - X[:, 0] * r2, w * X[:, 0] + mu * X[:, 1] - X[:, 1] * r2], axis=1)

    br = equilibria(lambda x, p: field(x[None, :], np.array([p]))[0], [0.0, 0.0], np.linspace(-0.2, 1.2, 15))
    assert br.hopf == pytest.approx([0.0, 1.0], abs=1e-7)
    calls = [0]
    flow = rk4_flow(field, 200)

    def counted(X, T, P, samples):
        calls[0] += 1
        return flow(X, T, P, samples)

    ob = orbits(field, counted, br.hopf_points()[0], (-0.2, 1.2), amplitude=0.02, max_orbits=300)
    assert ob.end.startswith("shrank back")
    assert ob.values.max() > 0.9 and ob.values.min() > 0.0
    assert ob.upper[:, 0] == pytest.approx(np.sqrt(ob.values * (1.0 - ob.values)), rel=1e-3)
    assert ob.stable.all()
    assert ob.values.size < 100
    assert calls[0] < 10 * ob.values.size  # the Newton steps of the orbits kept (and the one shrunk), not 300 orbits'


@pytest.mark.parametrize("period", [-0.5, 0.0, 1e18, math.inf, math.nan])
def test_shooting_never_integrates_a_period_outside_its_range(period):
    """A Newton step that throws the period to 1e18 s (it did, for the default rig's lower band, and the rig's flow
    then asked for 1e18 elements) or below zero gets a NaN residual, which the correctors take as a failed step;
    the flow is not called.  Inside the range the residual is the flow's."""
    from rig_env.bifurcation.periodic import Shooting, _solve_square
    from rig_env.bifurcation.core import Settings

    def field(X, P):
        return np.stack([-2.0 * X[:, 1], 2.0 * X[:, 0]], axis=1)

    calls = []

    def flow(X, T, P, samples):
        calls.append(T)
        return rk4_flow(field, 400)(X, T, P, samples)

    sh = Shooting(field, flow, np.ones(4), max_period=20.0)
    F, J = sh(np.array([0.3, 0.0, period, 0.0]))
    assert np.all(np.isnan(F[:2])) and np.all(np.isnan(J[:2])) and calls == []  # the closing rows; the phase row needs no flow
    assert _solve_square(sh, np.array([0.3, 0.0, period, 0.0]), Settings()) is None and calls == []
    F, J = sh(np.array([0.3, 0.0, math.pi, 0.0]))  # the harmonic oscillator's orbit through (0.3, 0) closes after pi
    assert calls == [math.pi] and np.abs(F[:2]).max() < 1e-8 and np.all(np.isfinite(J))



def test_an_orbit_family_whose_period_grows_ends_at_the_largest_period():
    """r' = mu r - r^3, theta' = omega - r^2: orbits of radius sqrt(mu) and period 2 pi / (omega - mu), which grows
    with mu.  With max_period 1.2 times the Hopf period the family ends where T reaches it (mu = omega / 6), for that
    reason, every orbit kept below it; the shooting's guard against thrown periods does not end it earlier."""
    w = 2.0

    def field(X, P):
        r2 = (X**2).sum(axis=1)
        return np.stack([P * X[:, 0] - (w - r2) * X[:, 1] - X[:, 0] * r2, (w - r2) * X[:, 0] + P * X[:, 1] - X[:, 1] * r2], axis=1)

    br = equilibria(lambda x, p: field(x[None, :], np.array([p]))[0], [0.0, 0.0], np.linspace(-0.5, 0.5, 11))
    T0 = 2 * np.pi / w
    ob = orbits(field, rk4_flow(field, 200), br.hopf_points()[0], (-0.5, 0.5), amplitude=0.01, max_period=1.2 * T0, max_orbits=200)
    assert ob.end == "left the parameter range or reached the largest period"
    assert ob.periods.max() < 1.2 * T0 and ob.values.max() > w / 6 - 0.05
    assert ob.periods == pytest.approx(2 * np.pi / (w - ob.values), rel=1e-6)


@pytest.mark.parametrize("max_orbits", [1, 2, 5])
def test_an_orbit_family_cut_by_max_orbits_holds_that_many(max_orbits):
    """max_orbits counts every orbit the family keeps, the first (not traced) included: it kept one more than asked
    ("41 orbits, ended: stopped after max_points = 40 points"), and says so in its own words."""
    w = 2.0

    def field(X, P):
        r2 = (X**2).sum(axis=1)
        return np.stack([P * X[:, 0] - w * X[:, 1] - X[:, 0] * r2, w * X[:, 0] + P * X[:, 1] - X[:, 1] * r2], axis=1)

    br = equilibria(lambda x, p: field(x[None, :], np.array([p]))[0], [0.0, 0.0], np.linspace(-0.5, 0.5, 11))
    ob = orbits(field, rk4_flow(field, 200), br.hopf_points()[0], (-0.5, 0.5), amplitude=0.01, max_orbits=max_orbits)
    assert ob.values.size == max_orbits and ob.end == f"stopped after max_orbits = {max_orbits} orbits"
    assert ob.upper[:, 0] == pytest.approx(np.sqrt(ob.values), rel=1e-3)  # r = sqrt(mu): the orbits kept are orbits


# ---------------------------------------------------------------------------- the rig
PITCH_HEAVE = ("rig_pitch", "model_pitch")


def test_rig_equilibria_are_trims_and_eigenvalues_are_linearize_s(params):
    """Rig pitch and model pitch free, linear aero, over the Hawk elevator: every sampled equilibrium is the one
    rig_env.trim finds from zero, and the eigenvalues are those of rig_env.linearize there."""
    values = np.linspace(-3.0, 3.0, 7)
    br = rig_env.continuation(params, free_dofs=PITCH_HEAVE, parameter="hawk_elevator", values=values, airspeed=20.0)
    assert br.values == pytest.approx(values, abs=1e-12)
    assert br.state_names == ("rig_pitch", "model_pitch", "rig_pitch_rate", "model_pitch_rate")
    for k, v in enumerate(values):
        op = rig_env.trim(params, PITCH_HEAVE, airspeed=20.0, controls={"hawk_elevator": float(v)})
        assert br.column("rig_pitch")[k] == pytest.approx(op.q[1], abs=1e-9)
        assert br.column("model_pitch")[k] == pytest.approx(op.q[3], abs=1e-9)
        assert br.states[k, 2:] == pytest.approx([0.0, 0.0], abs=1e-12)
        lam = np.linalg.eigvals(rig_env.linearize(params, op, inputs=[]).A)
        lam = lam[np.lexsort((-lam.imag, -lam.real))]
        assert br.eigenvalues[k] == pytest.approx(lam, abs=1e-5 * np.abs(lam).max())
        assert br.stable[k] == bool(np.all(lam.real < 0))


def test_rig_parameter_continuation_agrees_with_trim_of_the_changed_rig(params):
    """A rig parameter by its dotted name (the Hawk c.g. offset, m): the equilibria are trims of params.replace(...)."""
    values = np.linspace(-0.02, 0.0, 3)
    br = rig_env.continuation(params, free_dofs=("model_pitch",), parameter="geometry.hawk_cg_x", values=values, periodic=False)
    assert br.parameter_unit == "m"
    for k, v in enumerate(values):
        op = rig_env.trim(params.replace(**{"geometry.hawk_cg_x": float(v)}), ("model_pitch",))
        assert br.states[k, 0] == pytest.approx(op.q[3], abs=1e-9)


def test_rig_stop_is_reported_where_trim_holds_the_joint_at_it(params):
    """Model pitch alone, linear aero: the branch reaches the 25 deg upper stop at the elevator that rig_env.trim
    needs to hold model pitch at 25 deg; the note says so and the samples past it are flagged."""
    br = rig_env.continuation(params, free_dofs=("model_pitch",), parameter="hawk_elevator", values=np.linspace(0.0, -8.0, 9),
                              periodic=False)
    stop = br.points("stop:model_pitch:upper")
    assert len(stop) == 1
    op = rig_env.trim(params, ("model_pitch",), [0, 0, 0, math.radians(25.0), 0], hold={"model_pitch": math.radians(25.0)},
                      unknown_inputs=["hawk_elevator"])
    assert stop[0].value == pytest.approx(op.controls_deg["hawk_elevator"], abs=1e-6)
    assert any("upper stop (25 deg)" in n for n in br.notes)
    assert list(br.at_stop) == list(np.degrees(br.states[:, 0]) > 25.0)
    assert br.at_stop.sum() >= 2


def test_rig_hopf_point_of_the_heave_mode_is_on_the_imaginary_axis_of_linearize(params):
    """Rig pitch and model pitch free, linear aero: lowering the compensator's CLq (the paper's 75.34 is suspect; it
    supplies half the heave damping) loses the heave mode's damping at a Hopf point, where linearize of the trim
    of that rig has a pair on the imaginary axis at the Hopf frequency."""
    br = rig_env.continuation(params, free_dofs=PITCH_HEAVE, parameter="comp_aero.CLq", values=np.linspace(40.0, 10.0, 7),
                              periodic=False)
    assert br.hopf.size == 1
    h = br.hopf_points()[0]
    assert 15.0 < h.value < 35.0
    rig = params.replace(**{"comp_aero.CLq": float(h.value)})
    lam = np.linalg.eigvals(rig_env.linearize(rig, rig_env.trim(rig, PITCH_HEAVE), inputs=[]).A)
    crossing = lam[np.argmin(np.abs(lam.real))]
    assert abs(crossing.real) < 1e-5 * abs(crossing)
    assert abs(crossing.imag) == pytest.approx(h.omega, rel=1e-6)
    assert list(br.stable) == list(br.values > h.value)


def test_rig_limit_cycle_by_shooting_is_the_one_a_long_simulation_settles_on(params):
    """Rig pitch and model pitch free, stall tables, compensator CLq lowered past its Hopf point: the stable
    orbit found by shooting (its extremes and period) is the limit cycle that rig_env.simulate reaches from a
    small disturbance of the equilibrium (friction, servos and stops off: the model continuation analyses)."""
    br = rig_env.continuation(params, free_dofs=PITCH_HEAVE, parameter="comp_aero.CLq", values=np.linspace(30.0, 10.0, 5),
                              aero_model="tables", max_orbits=10)
    assert br.hopf.size == 1 and len(br.orbits) == 1
    ob = br.orbits[0]
    # the largest multiplier after the trivial one (nearest 1): how fast a disturbed orbit settles, per period
    settle = np.array([np.abs(np.delete(mu, np.argmin(np.abs(mu - 1)))).max() for mu in ob.multipliers])
    k = int(np.flatnonzero(ob.stable & (settle < 0.85))[0])
    value, period = float(ob.values[k]), float(ob.periods[k])
    assert value < 20.0
    rig = params.replace(**{"comp_aero.CLq": value})
    eq = rig_env.trim(rig, PITCH_HEAVE)
    q0 = eq.q[[1, 3]] + np.radians([3.0, 0.0])
    r = rig_env.simulate(rig, q0, [0.0, 0.0], 60.0, free_dofs=PITCH_HEAVE, nonlinear_aero=True, friction=False, servo=False,
                         stops=False, control_rate=200.0)
    tail = r.t > 60.0 - 4 * period
    for a in range(2):
        q = r.q[tail, a]
        assert np.degrees(q.max()) == pytest.approx(np.degrees(ob.upper[k, a]), abs=0.03)
        assert np.degrees(q.min()) == pytest.approx(np.degrees(ob.lower[k, a]), abs=0.03)
    q = r.q[tail, 0] - 0.5 * (ob.upper[k, 0] + ob.lower[k, 0])
    ups = np.flatnonzero((q[:-1] < 0) & (q[1:] >= 0))
    t_up = r.t[tail][ups] - q[ups] / (q[ups + 1] - q[ups]) * (r.t[1] - r.t[0])
    assert np.mean(np.diff(t_up)) == pytest.approx(period, rel=2e-3)
    amp = np.degrees(ob.amplitudes[k, 0])
    assert amp > 2.0  # a real limit cycle of several degrees, not the equilibrium
    # a small disturbance grew smoothly onto a stable orbit, with stable orbits from the Hopf point on: supercritical
    assert ob.criticality == "supercritical" and ob.stable[0] and ob.special_points == ()


def test_rig_pitch_only_over_the_elevator_has_no_hopf_point(params):
    """Model pitch alone at 20 m/s: no Hopf point with either aerodynamic model (its damping is CMq's and the
    lift's, neither of which the elevator changes sign); the linear model's branch turns at two folds."""
    for model in ("linear", "tables"):
        br = rig_env.continuation(params, free_dofs=("model_pitch",), parameter="hawk_elevator",
                                  values=np.linspace(-15.0, 15.0, 31), aero_model=model)
        assert br.hopf.size == 0 and not br.orbits
        assert np.all(br.stable[np.abs(br.states[:, 0]) < math.radians(25.0)])


def test_continuation_refuses_bad_input_by_name(params):
    kw = dict(free_dofs=("model_pitch",), parameter="hawk_elevator", values=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"aero_model = 'stall'.*\['linear', 'tables', 'unsteady'\]"):
        rig_env.continuation(params, **{**kw, "aero_model": "stall"})
    with pytest.raises(ValueError, match=r"parameter = 'hawk_flap': unknown; valid names.*hawk_elevator.*airspeed.*rig_env.PARAM_NAMES") as err:
        rig_env.continuation(params, **{**kw, "parameter": "hawk_flap"})
    assert len(str(err.value)) < 400  # the surfaces and where the rig's names are, not all of them
    with pytest.raises(ValueError, match=r"parameter = 'hawk_aero.cmq': unknown \(did you mean 'hawk_aero.CMq'"):
        rig_env.continuation(params, **{**kw, "parameter": "hawk_aero.cmq"})
    with pytest.raises(ValueError, match=r"friction = 'lugre'"):
        rig_env.continuation(params, **{**kw, "friction": "lugre"})
    with pytest.raises(ValueError, match=r"controls: 'hawk_elevator' is the continuation parameter"):
        rig_env.continuation(params, **{**kw, "controls": {"hawk_elevator": 1.0}})
    with pytest.raises(rig_env.ParameterError, match=r"geometry.hawk_cg_x = 0.5 m is outside the allowed range"):
        rig_env.continuation(params, **{**kw, "parameter": "geometry.hawk_cg_x", "values": [0.0, 0.5]})
    with pytest.raises(ValueError, match=r"values: expected at least two"):
        rig_env.continuation(params, **{**kw, "values": [1.0]})
    with pytest.raises(ValueError, match=r"orbit_kernel = 'dae': allowed values: 'lanes', 'joint'"):
        rig_env.continuation(params, **{**kw, "orbit_kernel": "dae"})
    # the orbits' options: a 1e-8 s step asked numpy for 79 GiB; an amplitude of 0 or NaN read as "no orbit found"
    for dt in (1e-8, 0.02, math.nan):
        with pytest.raises(ValueError, match=r"physics_dt = .*: the orbits' RK4 step must lie in \[0.0001, 0.005\] s"):
            rig_env.continuation(params, **{**kw, "physics_dt": dt})
    for a in (0.0, -1.0, math.nan, 2.0):
        with pytest.raises(ValueError, match=r"orbit_amplitude = .*: must lie in \(0, 0.5\]"):
            rig_env.continuation(params, **{**kw, "orbit_amplitude": a})
    for m in (0, -3, 2.5, True, 1001):
        with pytest.raises(ValueError, match=r"max_orbits = .*: must be an integer from 1 to 1000"):
            rig_env.continuation(params, **{**kw, "max_orbits": m})
    with pytest.raises(ValueError, match=r"values: hawk_elevator = -1000 deg is beyond the servo's travel \[-40, 40\] deg"):
        rig_env.continuation(params, **{**kw, "values": [-1000.0, 1000.0]})  # 500 and 1000 deg gave the same equilibrium
    with pytest.raises(ValueError, match=r"controls: comp_elevator = nan: deflections must be finite"):
        rig_env.continuation(params, **{**kw, "controls": {"comp_elevator": math.nan}})
    # below 0.5 m/s the unsteady model's states are held: the trace from 60 m/s turned back at a spurious fold
    with pytest.raises(ValueError, match=r"values: airspeed 0 m/s: with aero_model = 'unsteady' the airspeed must be at least 0.5 m/s"):
        rig_env.continuation(params, **{**kw, "parameter": "airspeed", "values": [60.0, 0.0], "aero_model": "unsteady"})
    with pytest.raises(ValueError, match=r"airspeed = 0.2 m/s: with aero_model = 'unsteady' the airspeed must be at least 0.5 m/s"):
        rig_env.continuation(params, **{**kw, "airspeed": 0.2, "aero_model": "unsteady"})
    with pytest.raises(ValueError, match=r"settings: expected a rig_env.bifurcation.core.Settings or None, not dict"):
        rig_env.continuation(params, **{**kw, "settings": {"bogus": 1}})


def test_continuation_is_public_with_a_real_signature_and_plots(params, tmp_path):
    sig = inspect.signature(rig_env.continuation)
    assert {"params", "free_dofs", "parameter", "values", "airspeed", "aero_model", "friction", "stops"} <= set(sig.parameters)
    assert "continuation" in rig_env.__all__
    br = rig_env.continuation(params, free_dofs=("model_pitch",), parameter="airspeed", values=np.linspace(10.0, 30.0, 5))
    assert br.parameter_unit == "m/s" and br.values == pytest.approx(np.linspace(10.0, 30.0, 5))
    fig = plot_branch(br, tmp_path / "diagram.png")
    assert (tmp_path / "diagram.png").stat().st_size > 1000
    ax = fig.axes[0]
    assert ax.get_xlabel() == "airspeed (m/s)" and ax.get_ylabel() == "model_pitch (deg)"


def test_rig_pitch_only_with_the_stall_tables_folds_at_the_table_nodes(params):
    """Model pitch alone, stall tables, over the elevator: the pitch-up break of the CM table (its slope turns
    positive between the 13 and 16 deg nodes) makes a hysteresis window: the branch folds where the equilibrium
    reaches those nodes, at the elevator that zeroes the model's pitch acceleration at 13 and 16 deg
    (brentq on the kernel's accelerations directly)."""
    from scipy.optimize import brentq

    from rig_env.linear import joint_accelerations
    from rig_env.physics import layout as L

    br = rig_env.continuation(params, free_dofs=("model_pitch",), parameter="hawk_elevator", values=np.linspace(-15.0, 15.0, 61),
                              aero_model="tables")
    assert br.folds.size == 2
    pv, tabs, idx = params.to_vector(), params.tables(), np.array([3])

    def qdd(de: float, theta_deg: float) -> float:
        u = np.zeros(L.N_INPUTS)
        u[3], u[L.U_AIRSPEED] = math.radians(de), 20.0
        q = np.array([0.0, 0.0, 0.0, math.radians(theta_deg), 0.0])
        return float(joint_accelerations(q, np.zeros(5), u, pv, L.F_AERO | L.F_NONLINEAR, idx, tabs)[3])

    for fold in br.points("fold"):
        node = round(math.degrees(fold.state[0]))
        assert node in (13, 16) and math.degrees(fold.state[0]) == pytest.approx(node, abs=1e-3)
        assert fold.value == pytest.approx(brentq(qdd, -5.0, 5.0, args=(float(node),), xtol=1e-12), abs=1e-3)
    # inside the window (-1.36..-1.16 deg) three equilibria: stable below 13 deg, a saddle, stable above 16 deg
    inside = rig_env.continuation(params, free_dofs=("model_pitch",), parameter="hawk_elevator", values=np.linspace(-15.0, 15.0, 151),
                                  aero_model="tables", periodic=False)
    at = np.isclose(inside.values, -1.2)
    assert at.sum() == 3
    pitch = np.degrees(inside.states[at, 0])
    assert list(inside.stable[at][np.argsort(pitch)]) == [True, False, True]
    assert sorted(pitch)[0] < 13.0 < sorted(pitch)[1] < 16.0 < sorted(pitch)[2]


def test_the_upper_band_sits_at_the_same_angles_on_the_default_rig_at_lower_elevator(params):
    """The stall-onset band of Hopf points (centre-of-pressure travel k, 1-DOF model pitch, 20 m/s, the unsteady
    model; docs/MODEL.md 7) on the default rig: none at k = 0.08 c, a pair from 0.085 c, at k = 0.1 c from the
    tables' 10 deg breakpoint to 11.3 deg of model pitch, as on the paper's model to 0.02 deg, because the band is
    a property of the tables in angle of attack and the separation model's parameters, which the two sets share.
    The default's trim (Table 3's CM0 with its alpha0) is lower, so the elevator reaches the band 1.4-1.5 deg
    further down (about -2.5 to -2.65 deg against -1.0 to -1.2)."""
    kw = {"free_dofs": ("model_pitch",), "parameter": "hawk_elevator", "airspeed": 20.0, "aero_model": "unsteady", "periodic": False}
    default = rig_env.RigParams.default()
    assert rig_env.continuation(default.replace(**{"hawk_aero.sep_cp_travel": 0.08}), values=np.linspace(-2.0, -3.0, 51), **kw).hopf.size == 0
    found = {}
    for name, P, values in (("default", default, np.linspace(-2.0, -3.0, 51)), ("paper", params, np.linspace(-0.5, -1.5, 51))):
        br = rig_env.continuation(P.replace(**{"hawk_aero.sep_cp_travel": 0.1}), values=values, **kw)
        hopfs = sorted((sp for sp in br.special_points if sp.kind == "hopf"), key=lambda sp: sp.state[0])
        assert len(hopfs) == 2, name
        found[name] = [(sp.value, math.degrees(sp.state[0])) for sp in hopfs]
    (e0, a0), (e1, a1) = found["default"]
    assert a0 == pytest.approx(10.0, abs=0.05) and a1 == pytest.approx(11.3, abs=0.05)
    for (ed, ad), (ep, ap) in zip(found["default"], found["paper"]):
        assert ad == pytest.approx(ap, abs=0.02)
        assert 1.3 < ep - ed < 1.6


FIG9 = {  # rig: leading eigenvalue (1/s) at hawk_cg_z 0 and 8 cm, the Cnr of the Hopf point and its frequency (Hz)
    "paper": (-0.60, -0.45, 0.036, 0.945),
    "default": (-0.546, -0.464, 0.0054, 0.742),
}


@pytest.mark.parametrize("rig", ["paper", "default"])
def test_fig9_the_hawk_cg_offset_does_not_bring_a_hopf_point(rig):
    """Fig. 9's 4-DOF case (rig roll, sway, model pitch and yaw, 15 m/s, attached flow): the paper blames its
    limit cycle on the Hawk's c.g. offset.  Lowering the c.g. below the model gimbal from 0 to 8 cm (the
    default 1 cm) brings the leading eigenvalue from -0.60 towards -0.45 1/s (the default rig: -0.55 to -0.46)
    and no Hopf point (docs/MODEL.md 7); moving it along the body x axis sends the trim to a model-pitch stop
    within 2 cm; the compensator's CLq from 75.34 down to 0 gives none either, and the Hawk's yaw damping Cnr
    only once it has changed sign (at +0.036 on the paper's model, +0.005 on the default rig)."""
    params = getattr(rig_env.RigParams, rig)()
    lead0, lead8, cnr_hopf, cnr_hz = FIG9[rig]
    free = ("rig_roll", "rig_yaw", "model_pitch", "model_yaw")
    br = rig_env.continuation(params, free_dofs=free, parameter="geometry.hawk_cg_z", values=np.linspace(0.0, 0.08, 9), airspeed=15.0,
                              periodic=False, q_guess=[0, 0, 0, 0.1, 0])
    lead = np.array([max(e.real) for e in br.eigenvalues])
    assert br.hopf.size == 0 and br.stable.all()
    assert lead[0] == pytest.approx(lead0, abs=0.01) and lead[-1] == pytest.approx(lead8, abs=0.01) and np.all(np.diff(lead) > 0)
    fwd = rig_env.continuation(params, free_dofs=free, parameter="geometry.hawk_cg_x", values=np.linspace(0.0, 0.02, 5), airspeed=15.0,
                               periodic=False, q_guess=[0, 0, 0, 0.1, 0])
    assert any(sp.kind.startswith("stop:model_pitch") for sp in fwd.special_points)
    # nor the compensator's suspect CLq (75.34), which in heave has a Hopf point at 25.72 (above): none in these four
    clq = rig_env.continuation(params, free_dofs=free, parameter="comp_aero.CLq", values=np.linspace(75.34, 0.0, 12), airspeed=15.0,
                               periodic=False, q_guess=[0, 0, 0, 0.1, 0])
    assert clq.hopf.size == 0 and clq.stable.all()
    # the lateral derivatives are estimates: of those, only the Hawk's yaw damping brings a Hopf point, and only
    # when it changes sign (Cnr = +0.036 against the estimated -0.19): the model's 0.95 Hz yaw oscillation
    cnr = rig_env.continuation(params, free_dofs=free, parameter="hawk_aero.Cnr", values=np.linspace(-0.19, 0.2, 14), airspeed=15.0,
                               periodic=False, q_guess=[0, 0, 0, 0.1, 0])
    (hopf,) = [sp for sp in cnr.special_points if sp.kind == "hopf"]
    assert hopf.value == pytest.approx(cnr_hopf, abs=0.003) and hopf.omega / (2 * math.pi) == pytest.approx(cnr_hz, abs=0.01)


@pytest.mark.parametrize("elevator", [-4.0, -6.0])
def test_fig8_yaw_divergence_of_the_blanked_hawk_is_the_closed_form(elevator):
    """Fig. 8's yaw departure (the fin blanked above 12 deg): on the model-yaw gimbal, whose axis is the vertical,
    the static yaw stiffness at pitch theta is qSb (Cnbeta_eff cos theta - Clbeta_eff sin theta) plus the side
    force's moment at the c.g.'s lever, Cnbeta_eff = Cnbeta_body + eta Cnbeta.  Continuation over the
    fuselage's Cnbeta_body (the default rig, the consistent set, model pitch and yaw free, the stall tables, 20 m/s) finds the
    symmetric branch's pitchfork where that stiffness is zero (0.002).  The dihedral effect that grows with lift
    (Clbeta_CL) holds the yaw: the departure needs Cnbeta_body below -0.105 at 19.5 deg, twice the
    DATCOM estimate -0.05, with which the branch keeps its yaw stability up to the stop (docs/MODEL.md 7)."""
    P = rig_env.RigParams.default()
    free = ("model_pitch", "model_yaw")
    br = rig_env.continuation(P, free_dofs=free, parameter="hawk_aero.Cnbeta_body", values=np.linspace(0.0, -0.3, 61), airspeed=20.0,
                              controls={"hawk_elevator": elevator}, aero_model="tables", periodic=False, q_guess=[0, 0, 0, 0.35, 0])
    (bp,) = [sp for sp in br.special_points if sp.kind == "branch_point"]
    th = bp.state[0]
    h, g = P.hawk_aero, P.geometry
    cl = float(np.interp(th, P.tables()[0], P.tables()[1]))
    t = min(max((math.degrees(th) - h.blanking_alpha_deg) / h.blanking_width_deg, 0.0), 1.0)
    eta = 1.0 - (1.0 - h.blanked_fraction) * t * t * (3.0 - 2.0 * t)
    clb = h.Clbeta + h.Clbeta_CL * cl
    lever = g.hawk_cg_x * math.cos(th) + g.hawk_cg_z * math.sin(th)  # the c.g.'s streamwise offset from the yaw axis
    expect = (clb * math.sin(th) - eta * h.CYbeta * lever / h.b) / math.cos(th) - eta * h.Cnbeta
    assert bp.value == pytest.approx(expect, abs=0.002)
    assert P.hawk_aero.Cnbeta_body == -0.05 and bp.value < 2 * P.hawk_aero.Cnbeta_body  # twice the DATCOM estimate
    if elevator == -4.0:
        along = rig_env.continuation(P, free_dofs=free, parameter="hawk_elevator", values=np.linspace(5, -8, 27), airspeed=20.0,
                                     aero_model="tables", periodic=False)
        assert not any(sp.kind == "branch_point" for sp in along.special_points)


# ------------------------------------------------------------------ two parameters: continuation_sweep
def test_sweep_loci_are_each_branch_s_points_and_the_heave_hopf_locus_lies_on_linearize_s_axis(params, tmp_path):
    """continuation_sweep over the airspeed of the heave mode's Hopf point in the compensator's CLq: each locus row is
    the special point of the branch at that airspeed (the same as rig_env.continuation there), and at every
    point of the locus linearize of that rig at that airspeed has a pair on the imaginary axis at the Hopf
    frequency; the locus moves with the airspeed (the damping's parts scale differently)."""
    sw = rig_env.continuation_sweep(params, sweep="airspeed", sweep_values=[16.0, 20.0, 24.0], free_dofs=PITCH_HEAVE,
                                    parameter="comp_aero.CLq", values=np.linspace(40.0, 10.0, 7))
    assert sw.sweep_unit == "m/s" and sw.parameter_unit == "1/rad" and sw.errors == ("", "", "")
    loc = sw.locus("hopf")
    assert loc.shape == (3, 2) and list(loc[:, 0]) == [16.0, 20.0, 24.0]
    one = rig_env.continuation(params, free_dofs=PITCH_HEAVE, parameter="comp_aero.CLq", values=np.linspace(40.0, 10.0, 7), airspeed=20.0,
                               periodic=False)
    assert loc[1, 1] == one.hopf[0]
    for (V, clq), br in zip(loc, sw.branches):
        h = br.hopf_points()[0]
        rig = params.replace(**{"comp_aero.CLq": float(clq)})
        lam = np.linalg.eigvals(rig_env.linearize(rig, rig_env.trim(rig, PITCH_HEAVE, airspeed=float(V)), inputs=[]).A)
        crossing = lam[np.argmin(np.abs(lam.real))]
        assert abs(crossing.real) < 1e-5 * abs(crossing) and abs(crossing.imag) == pytest.approx(h.omega, rel=1e-6)
    assert np.ptp(loc[:, 1]) > 0.5
    un = sw.unstable()
    assert un.size and np.all(un[:, 1] < np.interp(un[:, 0], loc[:, 0], loc[:, 1]) + 1e-9)  # unstable below the Hopf CLq
    from rig_env.bifurcation.plot import plot_sweep

    plot_sweep(sw, tmp_path / "sweep.png")
    assert (tmp_path / "sweep.png").stat().st_size > 10_000


def test_sweep_of_the_centre_of_pressure_travel_opens_the_upper_band_between_0_08_and_0_1(params):
    """The stall onset's Hopf pair (docs/MODEL.md 7: from about 0.085 c) as a locus over sep_cp_travel: none at 0.06 and
    0.08 c, a pair at 0.1 and 0.12 c, the pair's elevators moving apart as the travel grows."""
    sw = rig_env.continuation_sweep(params, sweep="hawk_aero.sep_cp_travel", sweep_values=[0.06, 0.08, 0.1, 0.12], free_dofs=("model_pitch",),
                                    parameter="hawk_elevator", values=np.linspace(2, -3, 101), aero_model="unsteady")
    loc = sw.locus("hopf")
    assert sorted(set(loc[:, 0])) == [0.1, 0.12]
    width = {k: np.ptp(loc[loc[:, 0] == k, 1]) for k in (0.1, 0.12)}
    assert 0.0 < width[0.1] < width[0.12]
    assert sw.locus("fold").shape == (8, 2)  # the tables' hysteresis window at every travel (the equilibria are the tables')


def test_upper_band_hopf_point_is_subcritical_with_a_fold_of_cycles_and_simulate_shows_the_bistability(params):
    """Fig. 8's upper band (sep_cp_travel 0.12 c, model pitch alone, unsteady): the Hopf point near 12.2 deg is
    subcritical.  Its unstable orbits grow towards the stable side and turn at a fold of cycles into stable
    orbits of about 1 deg, so between the fold and the Hopf point a stable equilibrium and a stable limit
    cycle coexist, with the unstable orbit between them.  rig_env.simulate shows it: at an elevator inside
    that window a 0.3 deg disturbance (inside the unstable orbit, about 0.9 deg) dies away, a 1.2 deg one
    (outside it) grows onto the stable orbit, whose amplitude is the continuation's."""
    rig = params.replace(**{"hawk_aero.sep_cp_travel": 0.12})
    br = rig_env.continuation(rig, free_dofs=("model_pitch",), parameter="hawk_elevator", values=np.linspace(-1.2, -1.35, 16),
                              aero_model="unsteady", q_guess=[0.0, 0.0, 0.0, math.radians(12.3), 0.0], max_orbits=42)
    assert br.hopf.size == 1 and len(br.orbits) == 1
    ob = br.orbits[0]
    assert ob.criticality == "subcritical"
    assert [c.kind for c in ob.special_points] == ["cycle_fold"]
    fold = ob.points("cycle_fold")[0]
    assert br.hopf[0] - 0.02 < fold.value < br.hopf[0]  # on the stable side, a narrow window (0.014 deg)
    k = int(np.flatnonzero(ob.values == ob.values.min())[0])  # the family turns at the fold
    inner, outer = slice(0, k), slice(k + 1, None)
    # the inner orbits' multipliers can be read, and they are unstable; the outer ones' mostly cannot (errors of
    # 1e-2 at the 1 ms step against a multiplier near 0.95), so simulate judges them below
    assert not ob.stable[inner][ob.reliable[inner]].any() and ob.reliable[inner].sum() >= 10
    el = -1.296
    assert fold.value < el < br.hopf[0] and ob.values[outer].max() > el
    amp = lambda part: float(np.interp(el, *zip(*sorted(zip(ob.values[part], np.degrees(ob.amplitudes[part, 0]))))))  # noqa: E731
    assert 0.3 < amp(inner) < 1.0 < amp(outer)
    eq = rig_env.continuation(rig, free_dofs=("model_pitch",), parameter="hawk_elevator", values=[el, el - 0.001], aero_model="unsteady",
                              q_guess=[0.0, 0.0, 0.0, math.radians(12.3), 0.0], periodic=False)
    assert eq.stable[0]
    tails = []
    for d in (0.3, 1.2):
        r = rig_env.simulate(rig, [eq.states[0, 0] + math.radians(d)], [0.0], 150.0, free_dofs=("model_pitch",), controls={"hawk_elevator": el},
                             airspeed=20.0, aero_model="unsteady", friction=False, servo=False, stops=False, control_rate=200.0)
        q = np.degrees(r.q[r.t > 130.0, 0])
        tails.append(0.5 * (q.max() - q.min()))
    assert tails[0] < 0.01
    assert tails[1] == pytest.approx(amp(outer), abs=0.02)


def test_sweep_refuses_bad_input_by_name(params):
    kw = {"free_dofs": ("model_pitch",), "parameter": "hawk_elevator", "values": np.linspace(2, -2, 5)}
    with pytest.raises(ValueError, match=r"sweep = 'hawk_elevator': the swept parameter must differ"):
        rig_env.continuation_sweep(params, sweep="hawk_elevator", sweep_values=[0, 1], **kw)
    with pytest.raises(ValueError, match=r"parameter = 'hawk_nose': unknown"):
        rig_env.continuation_sweep(params, sweep="hawk_nose", sweep_values=[0, 1], **kw)
    with pytest.raises(ValueError, match=r"airspeed: the airspeed is the swept parameter"):
        rig_env.continuation_sweep(params, sweep="airspeed", sweep_values=[15, 20], airspeed=20.0, **kw)
    with pytest.raises(ValueError, match=r"sweep_values: airspeed 15..90 m/s is outside the allowed range \[0, 60\] m/s"):
        rig_env.continuation_sweep(params, sweep="airspeed", sweep_values=[15, 90], **kw)
    with pytest.raises(ValueError, match=r"sweep_values: .*hawk_aero.sep_cp_travel"):
        rig_env.continuation_sweep(params, sweep="hawk_aero.sep_cp_travel", sweep_values=[0.1, 0.9], **kw)
    with pytest.raises(ValueError, match=r"controls: 'hawk_rudder' is the swept parameter"):
        rig_env.continuation_sweep(params, sweep="hawk_rudder", sweep_values=[0, 1], controls={"hawk_rudder": 1.0}, **kw)
    with pytest.raises(ValueError, match=r"sweep_values: expected a 1-D sequence of finite numbers"):
        rig_env.continuation_sweep(params, sweep="hawk_rudder", sweep_values=[0, float("nan")], **kw)
    with pytest.raises(ValueError, match=r"free_dofs: unknown joint"):
        rig_env.continuation_sweep(params, sweep="hawk_rudder", sweep_values=[0, 1], **{**kw, "free_dofs": ("nose",)})
