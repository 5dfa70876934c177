"""Aerodynamics against eq. (23) written out independently, and the compensator's cruciform equivalence."""

import math

import numpy as np
import pytest

from rig_env.params import RigParams

from rig_env.physics import aero
from rig_env.physics.vec import mm, rot_x, rot_y, rot_z

IDENT = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def hawk_coefficients(params, F, M, V, alpha):
    """Back out CL, CD, CY, Cl, CM, Cn from body-axis loads (level wings, beta from side force)."""
    a = params.hawk_aero
    qS = 0.5 * params.environment.air_density * V**2 * a.S
    # wind axes in the x-z plane: drag along -v, lift perpendicular, pointing up
    ca, sa = math.cos(alpha), math.sin(alpha)
    lift = F[0] * sa - F[2] * ca
    drag = -(F[0] * ca + F[2] * sa)
    return lift / qS, drag / qS, M[0] / (qS * a.b), M[1] / (qS * a.c), M[2] / (qS * a.b)


@pytest.mark.parametrize("alpha_deg, de_deg, q_rate", [(0.0, 0.0, 0.0), (5.0, 2.0, 0.0), (-3.0, -4.0, 1.5), (8.0, 0.0, -2.0)])
def test_hawk_eq23_linear(params, alpha_deg, de_deg, q_rate):
    p = params.to_vector()
    tabs = params.tables()
    V = 20.0
    al = math.radians(alpha_deg)
    # body pitched up by alpha with the air along -x world: body velocity (V cos a, 0, V sin a) in body axes
    A = rot_y(al)
    v_air = (-V, 0.0, 0.0)
    F, M = aero.hawk_aero(p, A, (0.0, 0.0, 0.0), tuple(np.array(A).reshape(3, 3) @ [0.0, q_rate, 0.0]), v_air,
                          math.radians(de_deg), 0.0, 0.0, False, *tabs[:3])
    Fb = np.array(A).reshape(3, 3).T @ F
    Mb = np.array(A).reshape(3, 3).T @ M
    CL, CD, Cl, CM, Cn = hawk_coefficients(params, Fb, Mb, V, al)
    a = params.hawk_aero
    qh = q_rate * a.c / (2 * V)
    CL_ref = a.CL0 + a.CLalpha * (al - a.alpha0) + a.CLq * qh + a.CLde * math.radians(de_deg)
    CD_ref = a.CD0 + CL_ref**2 / (math.pi * a.e_oswald * a.b**2 / a.S)
    CM_ref = a.CM0 + a.CMalpha * (al - a.alpha0) + a.CMq * qh + a.CMde * math.radians(de_deg)
    assert CL == pytest.approx(CL_ref, rel=1e-12, abs=1e-12)
    assert CD == pytest.approx(CD_ref, rel=1e-12)
    assert CM == pytest.approx(CM_ref, rel=1e-12, abs=1e-12)
    assert abs(Cl) < 1e-12 and abs(Cn) < 1e-12


def test_hawk_sideslip_and_gust(params):
    """A lateral gust gives sideslip beta = asin(v/V); Cn = (Cnbeta_body + Cnbeta) beta (weathercock, the fin unblanked
    at zero incidence), Cl = (Clbeta + Clbeta_CL CL) beta."""
    p = params.to_vector()
    a = params.hawk_aero
    V, vg = 20.0, 2.0
    F, M = aero.hawk_aero(p, IDENT, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (-V, vg, 0.0), 0.0, 0.0, 0.0, False, *params.tables()[:3])
    Vt = math.hypot(V, vg)
    beta = math.asin(-vg / Vt)  # air from the right, relative velocity of the body to the left
    qSb = 0.5 * params.environment.air_density * Vt**2 * a.S * a.b
    CL_static = a.CL0 + a.CLalpha * (0.0 - a.alpha0)  # zero incidence: the fin is not blanked
    assert M[2] / qSb == pytest.approx((a.Cnbeta_body + a.Cnbeta) * beta, rel=1e-12)
    assert M[0] / qSb == pytest.approx((a.Clbeta + a.Clbeta_CL * CL_static) * beta, rel=1e-12)
    assert M[2] < 0.0  # nose turns into the wind (to the right, the gust's origin... negative yaw = nose left)


def test_hawk_high_incidence_table(params):
    p = params.to_vector()
    tabs = params.tables()
    V = 20.0
    for alpha_deg in (4.0, 13.0, 20.0, 25.0):
        al = math.radians(alpha_deg)
        A = rot_y(al)
        F, M = aero.hawk_aero(p, A, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (-V, 0.0, 0.0), 0.0, 0.0, 0.0, True, *tabs[:3])
        R = np.array(A).reshape(3, 3)
        CL, CD, Cl, CM, Cn = hawk_coefficients(params, R.T @ F, R.T @ M, V, al)
        assert CL == pytest.approx(np.interp(alpha_deg, params.high_incidence.alpha_deg, params.high_incidence.hawk_CL), rel=1e-12)
        assert CM == pytest.approx(np.interp(alpha_deg, params.high_incidence.alpha_deg, params.high_incidence.hawk_CM), rel=1e-12, abs=1e-14)
    # stall: at 20 deg the table lift is below the linear model's
    a = params.hawk_aero
    assert np.interp(20.0, params.high_incidence.alpha_deg, params.high_incidence.hawk_CL) < a.CL0 + a.CLalpha * (math.radians(20) - a.alpha0)


def comp(params, A=IDENT, v=(0.0, 0.0, 0.0), w=(0.0, 0.0, 0.0), V=20.0, da=0.0, de=0.0, dr=0.0, nonlinear=False):
    flaps = np.array([aero.mix(da, de, dr, i) for i in range(4)])
    tabs = params.tables()
    F, M = aero.comp_aero(params.to_vector(), A, v, w, (-V, 0.0, 0.0), flaps, nonlinear, tabs[3], tabs[4])
    R = np.array(A).reshape(3, 3)
    return R.T @ np.array(F), R.T @ np.array(M)


def test_compensator_is_table4_in_pitch_and_yaw(params):
    """The X of four panels has the Table 4 derivatives of the compensator (exact cruciform equivalent
    in the linear range; checked by central differences about zero incidence)."""
    c = params.comp_aero
    V = 20.0
    qS = 0.5 * params.environment.air_density * V**2 * c.S
    chord = c.S / c.span
    e = 1e-5

    def coeffs(al=0.0, be=0.0, de=0.0, dr=0.0, q=0.0, r=0.0):
        A = mm(rot_z(-be), rot_y(al))
        F, M = comp(params, A=A, w=(0.0, q, r), de=de, dr=dr)
        Fw = np.array(A).reshape(3, 3) @ F  # world (wind) axes: lift is -z, side force +y
        return -Fw[2] / qS, Fw[1] / qS, M[1] / (qS * chord), M[2] / (qS * chord), M[0]

    def d(key):
        return (np.array(coeffs(**{key: e})) - np.array(coeffs(**{key: -e}))) / (2 * e)

    rate = 2 * V / chord  # d/dq of q c / 2V
    assert d("al")[0] == pytest.approx(c.CLalpha, rel=1e-6)
    assert d("de")[0] == pytest.approx(c.CLde, rel=1e-6)
    assert d("q")[0] * rate == pytest.approx(c.CLq, rel=1e-6)
    assert d("al")[2] == pytest.approx(c.CMalpha, rel=1e-6)
    assert d("de")[2] == pytest.approx(c.CMde, rel=1e-6)
    # pitching moves the upper and lower strips fore and aft: their drag differs and adds a small
    # pitch damping of order CD0 (span / chord)^2 / 8 ~ 0.1 on top of Table 4's CMq
    assert d("q")[2] * rate == pytest.approx(c.CMq, rel=0.01)
    # yaw: the same derivatives (positive rudder: side force to starboard, sideslip from the left)
    # (nose yawed left by beta: the flow meets the panels from starboard and pushes them to port)
    assert d("be")[1] == pytest.approx(-c.CLalpha, rel=1e-6)
    assert d("dr")[1] == pytest.approx(c.CLde, rel=1e-6)
    assert d("be")[3] == pytest.approx(-c.CMalpha, rel=1e-6)  # weathercock: nose-left yaw gives nose-right moment
    # pitch and yaw inputs give no roll; drag at zero incidence is CD0
    for key in ("al", "de", "be", "dr"):
        assert abs(d(key)[4]) < 1e-9
    F0, M0 = comp(params)
    assert -F0[0] / qS == pytest.approx(c.CD0, rel=1e-12)
    assert np.allclose(M0, 0.0, atol=1e-12)


def test_compensator_roll_from_strip_theory(params):
    """Rolling moment of the aileron and roll damping equal the closed-form strip integrals."""
    c, g = params.comp_aero, params.geometry
    V = 20.0
    rho = params.environment.air_density
    r0, r1 = g.arm_radius, c.span / 2
    chord_eff = (c.S / 2) / (r1 - r0)  # each panel carries half the reference area
    da = math.radians(10.0)
    F, M = comp(params, da=da)
    # four panels, lift slope CLde/sqrt2 per panel, lever int r dr
    ref = 4 * 0.5 * rho * V**2 * chord_eff * (c.CLde / math.sqrt(2)) * da * (r1**2 - r0**2) / 2
    assert M[0] == pytest.approx(ref, rel=1e-9)
    assert M[0] > 0  # positive aileron rolls the rig right-wing-down
    p = 0.5
    F, M = comp(params, w=(p, 0.0, 0.0))
    # lift slope plus the panels' profile drag (CD0/2 each), which acts along the strip velocity
    damp = -4 * 0.5 * rho * V**2 * chord_eff * (c.CLalpha + c.CD0 / 2) * (p / V) * (r1**3 - r0**3) / 3
    assert M[0] == pytest.approx(damp, rel=1e-4)  # small-angle: atan(pr/V) ~ pr/V


def test_mixing_signs_match_rig_code():
    # flap_i = da +- de +- dr with signs (+,+,-), (+,-,-), (+,-,+), (+,+,+) (rig-code, docs/PARAMETERS.md)
    signs = [(1, 1, -1), (1, -1, -1), (1, -1, 1), (1, 1, 1)]
    for i, (sa, se, sr) in enumerate(signs):
        assert aero.mix(1.0, 0.0, 0.0, i) == sa
        assert aero.mix(0.0, 1.0, 0.0, i) == se
        assert aero.mix(0.0, 0.0, 1.0, i) == sr


def test_wind_off_no_load(params):
    F, M = comp(params, V=0.0)
    assert np.all(F == 0) and np.all(M == 0)


def lateral_coefficients(params, alpha_deg, beta_deg=2.0, dr=0.0, nonlinear=False):
    """(CY, Cl, Cn) at body incidence alpha and sideslip beta, no rates, 20 m/s (body axes)."""
    p = params.to_vector()
    V = 20.0
    al, be = math.radians(alpha_deg), math.radians(beta_deg)
    vb = (V * math.cos(be) * math.cos(al), V * math.sin(be), V * math.cos(be) * math.sin(al))  # body velocity relative to the air
    F, M = aero.hawk_aero(p, IDENT, vb, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0, dr, nonlinear, *params.tables()[:3])
    qS = 0.5 * params.environment.air_density * V**2 * params.hawk_aero.S
    a = params.hawk_aero
    CL = a.CL0 + a.CLalpha * (al - a.alpha0)
    CD = a.CD0 + CL**2 / (math.pi * a.e_oswald * a.b**2 / a.S)
    CY = F[1] / qS + CD * math.sin(be)  # the drag's side component taken out
    return CY, M[0] / (qS * a.b), M[2] / (qS * a.b)


def smoothstep_blanking(a, alpha_deg):
    """The fin's share at alpha (deg), written from docs/MODEL.md 3.1: 1 below the onset, blanked_fraction
    beyond onset + width, 3 t^2 - 2 t^3 in between."""
    t = min(max((alpha_deg - a.blanking_alpha_deg) / a.blanking_width_deg, 0.0), 1.0)
    return 1.0 - (1.0 - a.blanked_fraction) * (3 * t * t - 2 * t**3)


def test_tail_blanking_off_below_the_break_and_falls_above(params):
    """Fin derivatives (CYbeta, Cnbeta, and the rudder's) unchanged below 12 deg, falling to a quarter by
    18 deg (paper Sec. VII: the fuselage wake blanks the fin at the onset of the upper limit cycle); the
    fuselage's Cnbeta_body is not blanked."""
    params = RigParams.default()  # the set with the new terms on (paper_rig.toml keeps them off)
    a = params.hawk_aero
    be = math.radians(2.0)
    for alpha_deg in (0.0, 5.0, 11.9):
        CY, Cl, Cn = lateral_coefficients(params, alpha_deg)
        assert Cn == pytest.approx((a.Cnbeta_body + a.Cnbeta) * be, rel=1e-12)
        assert CY == pytest.approx(a.CYbeta * be, rel=1e-9)
    assert a.Cnbeta_body == -0.05
    dr = math.radians(5.0)
    for alpha_deg, eta in ((15.0, 1.0 - 0.75 * 0.5), (18.0, 0.25), (25.0, 0.25)):  # the smoothstep at t = 1/2, 1, beyond
        assert smoothstep_blanking(a, alpha_deg) == pytest.approx(eta)
        CY, Cl, Cn = lateral_coefficients(params, alpha_deg)
        assert Cn == pytest.approx((a.Cnbeta_body + eta * a.Cnbeta) * be, rel=1e-12)
        assert CY == pytest.approx(eta * a.CYbeta * be, rel=1e-9)
        # rudder: the difference of two deflections at zero sideslip
        CY1, Cl1, Cn1 = lateral_coefficients(params, alpha_deg, beta_deg=0.0, dr=dr)
        CY0, Cl0, Cn0 = lateral_coefficients(params, alpha_deg, beta_deg=0.0, dr=0.0)
        assert (Cn1 - Cn0) == pytest.approx(eta * a.Cndr * dr, rel=1e-12)
        assert (Cl1 - Cl0) == pytest.approx(eta * a.Cldr * dr, rel=1e-12)
    # continuous across the onset (no jump for a limit-cycle or continuation study)
    assert lateral_coefficients(params, 12.0 + 1e-6)[2] == pytest.approx(lateral_coefficients(params, 12.0 - 1e-6)[2], rel=1e-9)


def test_clbeta_grows_with_lift(params):
    """Clbeta = Clbeta (dihedral) + Clbeta_CL CL(alpha): the swept wing's dihedral effect, which is
    proportional to lift; with the stall tables it follows the table's CL."""
    params = RigParams.default()  # the set with the new terms on (paper_rig.toml keeps them off)
    a = params.hawk_aero
    be = math.radians(2.0)
    for alpha_deg in (0.0, 6.0, 10.0):
        CL = a.CL0 + a.CLalpha * (math.radians(alpha_deg) - a.alpha0)
        assert lateral_coefficients(params, alpha_deg)[1] == pytest.approx((a.Clbeta + a.Clbeta_CL * CL) * be, rel=1e-12)
    hi = params.high_incidence
    for alpha_deg in (13.0, 20.0):
        CL = np.interp(alpha_deg, hi.alpha_deg, hi.hawk_CL)
        assert lateral_coefficients(params, alpha_deg, nonlinear=True)[1] == pytest.approx((a.Clbeta + a.Clbeta_CL * CL) * be, rel=1e-12)
    assert lateral_coefficients(params, 10.0)[1] < lateral_coefficients(params, 0.0)[1] < 0.0  # more stable with lift


def test_alphadot_split_leaves_pure_pitching_unchanged(params):
    """Pitching about the c.g. (no plunge) has alpha-dot = q: the split share of CLq and CMq gives the
    paper's combined derivatives back, whatever the share."""
    params = RigParams.default()  # the set with the new terms on (paper_rig.toml keeps them off)
    tabs = params.tables()[:3]
    V = 20.0
    for f in (0.0, 0.37, 0.8):
        p = params.replace(**{"hawk_aero.alphadot_fraction": f}).to_vector()
        for alpha_deg, q_rate in ((3.0, 1.2), (8.0, -2.0)):
            A = rot_y(math.radians(alpha_deg))
            w = tuple(np.array(A).reshape(3, 3) @ [0.0, q_rate, 0.0])
            F, M = aero.hawk_aero(p, A, (0.0, 0.0, 0.0), w, (-V, 0.0, 0.0), 0.0, 0.0, 0.0, False, *tabs)
            F0, M0 = aero.hawk_aero(params.replace(**{"hawk_aero.alphadot_fraction": 0.0}).to_vector(), A, (0.0, 0.0, 0.0), w, (-V, 0.0, 0.0), 0.0, 0.0, 0.0, False, *tabs)
            assert np.allclose(F, F0, rtol=1e-13, atol=1e-13) and np.allclose(M, M0, rtol=1e-13, atol=1e-13)


def test_heave_acceleration_drives_a_pitch_moment_through_alphadot(params):
    """Rig pitch (heave) and model pitch free, at rest at zero angles, 20 m/s.  Accelerating the model
    upwards at theta'' changes its plunge velocity: alpha-dot = -l theta'' / V (l = arm length; no q at
    rest), which acts through f CMq on the model (and f CLq on the rig).  Hand computation of the 2x2
    system (M - D G^T) qdd = r with

        G = (-l / V, 0)                                     alpha-dot per rig- and model-pitch acceleration
        D = (l kL + kM, kM),  kL = qS f CLq c/2V,  kM = qS c f CMq c/2V   load per unit alpha-dot

    (the lift kL at the c.g., l ahead of the pivot, on the rig; the moment kM on both joints), with M
    from the independent numpy model and r = M qdd_0 from the kernel's accelerations without the split:
    the kernel's accelerations with the split must match it.  The sign: heaving up (theta'' > 0) gives
    alpha-dot < 0 and, CMq < 0, a nose-up moment D_model G_rig theta'' > 0 on the model."""
    params = RigParams.default()  # the set with the new terms on (paper_rig.toml keeps them off)
    from rig_env import numpy_model as nm
    from rig_env.physics import layout as L
    from rig_env.reference import continuous_rhs
    from rig_env.simulate import flags_of

    base = params.replace(**{"geometry.hawk_cg_z": 0.0, "geometry.hawk_cg_x": 0.0})  # c.g. at the gimbal: J_v as above exactly
    a, V = base.hawk_aero, 20.0
    free_idx = np.array([L.J_RIG_PITCH, L.J_MODEL_PITCH], dtype=np.int64)
    u = np.zeros(L.N_INPUTS)
    u[L.U_AIRSPEED] = V
    flags = flags_of(aero=True, friction=False, stops=False, servo=False, nonlinear_aero=False)
    y = np.zeros(15)  # at rest, all angles zero

    def qdd(pr):
        return continuous_rhs(0.0, y, np.zeros(7), u, pr.to_vector(), flags, free_idx, pr.tables())[5:10][free_idx]

    qdd0 = qdd(base.replace(**{"hawk_aero.alphadot_fraction": 0.0}))
    qdd_f = qdd(base)
    kin, bs = nm.bodies(y[:5], y[5:10], base.to_vector())
    M = nm.mass_matrix_and_bias(bs, y[5:10])[0][np.ix_(free_idx, free_idx)]
    qS = 0.5 * base.environment.air_density * V**2 * a.S
    f, l, c = a.alphadot_fraction, base.geometry.arm_length, a.c
    kL = qS * f * a.CLq * c / (2 * V)
    kM = qS * c * f * a.CMq * c / (2 * V)
    G = np.array([-l / V, 0.0])
    D = np.array([l * kL + kM, kM])
    expected = np.linalg.solve(M - np.outer(D, G), M @ qdd0)
    assert np.allclose(qdd_f, expected, rtol=1e-10, atol=1e-12)
    assert abs(qdd_f[1] - qdd0[1]) > 1e-3 * abs(qdd0[1])  # the effect is there, not lost in rounding
    assert D[1] * G[0] > 0.0  # heave acceleration up: nose-up moment on the model


def test_heave_locked_pitch_motion_unchanged_by_the_split(params):
    """1-DOF model pitch (heave locked): with the c.g. at the gimbal alpha-dot is q, so the split changes
    nothing (to rounding); with the default 1 cm offset the c.g.'s own acceleration, |rho| (theta'' +
    theta'^2) / V ~ 0.01 x 40 / 20 = 0.02 rad/s against q ~ 1 rad/s, changes alpha-dot by a few per cent of
    the split share's damping, far below a degree over a 3 s ring-down."""
    params = RigParams.default()  # the set with the new terms on (paper_rig.toml keeps them off)
    import rig_env

    def run(p):
        r = rig_env.simulate(p, [0, 0, 0, math.radians(12.0), 0], np.zeros(5), 3.0, free_dofs=["model_pitch"], friction=False, servo=False)
        return r.q[:, 0]

    at_gimbal = {"geometry.hawk_cg_z": 0.0}
    a = run(params.replace(**at_gimbal))
    b = run(params.replace(**at_gimbal, **{"hawk_aero.alphadot_fraction": 0.0}))
    assert np.max(np.abs(a - b)) < 1e-10
    c = run(params)
    d = run(params.replace(**{"hawk_aero.alphadot_fraction": 0.0}))
    assert 0.0 < np.max(np.abs(c - d)) < math.radians(0.1)
