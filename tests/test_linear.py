"""Trim and linearisation against the nonlinear model and against theory."""

import control
import numpy as np
import pytest

import rig_env


def test_trim_is_an_equilibrium(params):
    op = rig_env.trim(params, free_dofs=["model_pitch", "rig_pitch"], controls={"hawk_elevator": 1.0}, q_guess=[0, 0, 0, 0.1, 0])
    r = rig_env.simulate(params, op.q, op.qd, 3.0, free_dofs=op.free_dofs, controls={"hawk_elevator": 1.0}, friction=False, servo=False)
    assert np.abs(r.q - r.q[0]).max() < 1e-6


@pytest.mark.parametrize(("controls", "match"), [
    ({"comp_elevator": float("nan")}, r"controls: comp_elevator = nan: deflections must be finite"),
    ({"hawk_elevator": 1e6}, r"controls: hawk_elevator = 1e\+06 deg is beyond the servo's travel \[-40, 40\] deg \(servos.hawk.limit_deg\)"),
    # each within +-40 deg, but flap 1 = aileron + elevator - rudder = 45 deg
    ({"comp_aileron": 30.0, "comp_elevator": 15.0}, r"put flap 1 at 45 deg, beyond the servos' travel \[-40, 40\] deg"),
])
def test_trim_refuses_surfaces_that_are_not_finite_or_beyond_the_servos_travel(params, controls, match):
    """A NaN deflection used to give a trim with NaN controls and a residual of 1e-16, and 1e6 deg the trim at
    the stop (40 deg) under another name; both are refused by name, and so is a mix that puts a flap past its travel."""
    with pytest.raises(ValueError, match=match):
        rig_env.trim(params, free_dofs=["rig_pitch", "model_pitch"], controls=controls, q_guess=[0, 0, 0, 0.1, 0])
    ok = rig_env.trim(params, free_dofs=["rig_pitch", "model_pitch"], controls={"comp_aileron": 25.0, "comp_elevator": 15.0},
                      q_guess=[0, 0, 0, 0.1, 0])
    assert ok.controls_deg["comp_elevator"] == 15.0  # flaps at 40, 10, -10, -40 deg: at the travel, not beyond


def test_linearize_refuses_what_is_not_an_operating_point(params):
    with pytest.raises(ValueError, match=r"op: expected the OperatingPoint rig_env.trim returns, not NoneType"):
        rig_env.linearize(params, None)


def test_linear_model_matches_nonlinear_small_response(params):
    free = ["rig_pitch", "model_pitch"]
    op = rig_env.trim(params, free_dofs=free, q_guess=[0, 0, 0, 0.1, 0])
    sys = rig_env.linearize(params, op, inputs=["comp_elevator", "hawk_elevator"])
    assert sys.state_labels == ["rig_pitch", "model_pitch", "rig_pitch_rate", "model_pitch_rate"]
    assert sys.input_labels == ["comp_elevator", "hawk_elevator"]
    step_deg = 0.05
    T = np.arange(0, 3.0 + 1e-9, 1 / 200)
    lin = control.forced_response(sys, T, np.vstack([np.zeros_like(T), np.full_like(T, np.radians(step_deg))]))
    r = rig_env.simulate(params, op.q, op.qd, 3.0, free_dofs=free, controls={"hawk_elevator": step_deg},
                         friction=False, servo=False, control_rate=200.0)
    dq = r.q - op.q[[1, 3]]
    err = np.abs(dq - lin.outputs[:2].T).max()
    assert np.abs(dq).max() > 1e-4
    assert err < 0.03 * np.abs(dq).max()


def test_linear_pitch_mode_matches_theory(params):
    from test_calibration import pitch_theory

    op = rig_env.trim(params, free_dofs=["model_pitch"], q_guess=[0, 0, 0, 0.1, 0])
    sys = rig_env.linearize(params, op, inputs=["hawk_elevator"])
    eig = np.linalg.eigvals(sys.A)
    f_lin = abs(eig[0]) / (2 * np.pi)
    f_th, zeta_th = pitch_theory(params, alpha=op.q[3])
    assert f_lin == pytest.approx(f_th, rel=0.05)
    assert -eig[0].real / abs(eig[0]) == pytest.approx(zeta_th, rel=0.3)


def test_linearize_rejects_bad_names(params):
    op = rig_env.trim(params, free_dofs=["model_pitch"], q_guess=[0, 0, 0, 0.1, 0])
    with pytest.raises(ValueError, match=r"inputs: unknown input\(s\) \['flap9'\].*gust_z"):
        rig_env.linearize(params, op, inputs=["flap9"])


@pytest.mark.parametrize("free", [("model_pitch",), ("rig_pitch", "model_pitch")])
def test_gust_columns_are_an_angle_of_attack_change(params, free):
    """A uniform vertical gust w (m/s, down) at rest changes every lifting surface's angle of attack by -w / V and
    nothing else; pitching the whole rig (the first free joint, at zero rates) changes them all by the same angle
    and moves no air.  So d qdd / d w is -1/V times the aerodynamic part of the first joint's angle column
    (the linearisation with aero minus without), and the uniform gust is the Hawk's plus the compensator's.
    Without the alpha-dot split: its added-mass-like term (docs/MODEL.md 3.1) puts the aerodynamics into the mass
    matrix, so that "with aero minus without" also differences gravity's column through two mass matrices (0.15 %
    on the default rig, rig pitch free)."""
    V = 20.0
    params = params.replace(**{"hawk_aero.alphadot_fraction": 0.0})
    op = rig_env.trim(params, free_dofs=free, airspeed=V, q_guess=[0, 0, 0, 0.1, 0])
    sys = rig_env.linearize(params, op, inputs=["gust_z", "hawk_gust_z", "comp_gust_z", "gust_x"])
    n = len(free)
    B = np.asarray(sys.B)[n:]
    A_aero = np.asarray(sys.A)[n:, 0] - np.asarray(rig_env.linearize(params, op, aero=False).A)[n:, 0]
    assert np.abs(B[:, 0]).max() > 0.5
    np.testing.assert_allclose(B[:, 0], -A_aero / V, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(B[:, 0], B[:, 1] + B[:, 2], rtol=1e-6, atol=1e-8)
    assert sys.input_labels == ["gust_z", "hawk_gust_z", "comp_gust_z", "gust_x"]


@pytest.mark.parametrize("tiny", [0.0, 1.8e-17, -3e-15])
def test_trim_from_a_guess_of_rounding_level_angles(params, tiny):
    """A guess whose angles are rounding-level non-zeros (the zero-input trim of a symmetric pair of joints
    can come out at 1e-17 rad) reaches the same equilibrium as a guess of exact zeros.  Solved for the
    angles themselves, MINPACK's first step is 100 times the guess's norm and the solver stopped there
    (max |qdd| 1.1 rad/s^2 at 4 deg of rudder, sway and model yaw free)."""
    free = ("rig_yaw", "model_yaw")
    guess = np.zeros(5)
    guess[2], guess[4] = tiny, -tiny
    op = rig_env.trim(params, free_dofs=free, airspeed=20.0, controls={"comp_rudder": 4.0}, q_guess=guess)
    assert op.residual < 1e-12
    # the equilibrium of exact zeros: the arm at -1.08 deg of yaw, the model at +1.08 deg relative to it
    assert np.degrees(op.q[2]) == pytest.approx(-1.0799, abs=1e-3)
    assert np.degrees(op.q[4]) == pytest.approx(1.0799, abs=1e-3)


def test_trim_holds_joints_with_surfaces_as_unknowns(params):
    """Held rig_pitch at 3 deg by the compensator elevator (solved, deg); a plain trim with that elevator
    finds the same equilibrium, and the model joint settles where it did."""
    free = ["rig_pitch", "model_pitch"]
    op = rig_env.trim(params, free, [0, 0.1, 0, 0.1, 0], unknown_inputs=["comp_elevator"], hold={"rig_pitch": np.radians(3.0)})
    assert op.q[1] == np.radians(3.0) and op.residual < 1e-9
    de = op.controls_deg["comp_elevator"]
    assert op.inputs["comp_elevator"] == pytest.approx(de, rel=1e-12)
    plain = rig_env.trim(params, free_dofs=free, controls={"comp_elevator": de}, q_guess=op.q)
    np.testing.assert_allclose(plain.q, op.q, atol=1e-9)


def test_trim_with_an_input_mix_matches_the_surfaces(params):
    """A mix that rotates (heave, sway) onto (elevator, rudder) by 30 deg: the solved mix inputs give the
    surfaces in controls_deg, and holding rig_pitch and rig_yaw at 0 deg with them is an equilibrium."""
    from rig_env.linear import InputMix

    c, s = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
    mix = InputMix(("heave", "sway"), ("comp_elevator", "comp_rudder"), np.array([[c, s], [-s, c]]), unit_deg=40.0)
    free = ["rig_pitch", "rig_yaw", "model_pitch"]
    op = rig_env.trim(params, free, None, mix=mix, unknown_inputs=["heave", "sway"], hold={"rig_pitch": 0.0, "rig_yaw": 0.0})
    h, w = op.inputs["heave"], op.inputs["sway"]
    assert op.controls_deg["comp_elevator"] == pytest.approx(40.0 * (c * h + s * w), rel=1e-12)
    assert op.controls_deg["comp_rudder"] == pytest.approx(40.0 * (-s * h + c * w), abs=1e-9)
    plain = rig_env.trim(params, free_dofs=free, controls=op.controls_deg, q_guess=op.q)
    np.testing.assert_allclose(plain.q, op.q, atol=1e-8)
    with pytest.raises(ValueError, match="as many unknown inputs"):
        rig_env.trim(params, free, None, mix=mix, unknown_inputs=["heave"], hold={"rig_pitch": 0.0, "rig_yaw": 0.0})
    with pytest.raises(ValueError, match="not free"):
        rig_env.trim(params, free, None, mix=mix, unknown_inputs=["heave"], hold={"rig_roll": 0.0})
    with pytest.raises(ValueError, match="driven by the input mix"):
        rig_env.trim(params, free, None, controls={"comp_rudder": 1.0}, mix=mix, inputs={"sway": 0.1})


def test_trim_failing_at_the_wind_off_cut_says_why(params):
    """At exactly 0.5 m/s (aero.MIN_AIRSPEED) the unsteady model's loads switch on as a body's local airspeed crosses
    the cut, and trim finds no equilibrium; the error says so and what to do (it gave only the residual).  A little
    above the cut the same trim is found."""
    free = ("rig_pitch", "model_pitch")
    with pytest.raises(RuntimeError, match=r"no equilibrium found .*airspeed = 0.5 m/s is at the 0.5 m/s wind-off cut.*trim a little above or below it"):
        rig_env.trim(params, free_dofs=free, airspeed=0.5, aero_model="unsteady")
    assert rig_env.trim(params, free_dofs=free, airspeed=0.51, aero_model="unsteady").q[1] < 0.0
