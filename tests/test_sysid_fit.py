"""Identification by output error and filter error: parameters come back from simulated records.

Truth is the default rig; records are simulated by ``rig_env.simulate`` (the per-environment kernel,
not the lane kernel the fit integrates with), with measurement noise of a potentiometer (0.05-0.1 deg)
and, for the filter-error test, turbulence (white vertical gusts, the tunnel's integral scale of a few cm
being far below one 80 Hz sample at 20 m/s).  Statistics over seeded noise draws: the estimates scatter
about the truth as their Cramer-Rao standard errors say.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from rig_env import RigParams, simulate, sysid
from rig_env.params import PARAM_INDEX, ParameterError
from rig_env.sysid import FlightRecord, RecordError

P = RigParams.default()
D = math.pi / 180.0
PITCH_TRIM = 7.24 * D  # rad, the 1-DOF model pitch at rest at 20 m/s (simulated to rest)
EST_1DOF = ["hawk_aero.CM0", "hawk_aero.CMalpha", "hawk_aero.CMq", "hawk_aero.CMde"]


def truth(names):
    v = P.to_vector()
    return np.array([v[PARAM_INDEX[n]] for n in names])


def u3211(t, amp=-1.5, unit=0.28, t0=0.5):
    """The paper's 3-2-1-1 (deg): +amp 3 units, -amp 2, +amp 1, -amp 1."""
    k = (np.asarray(t) - t0) / unit
    return amp * np.select([k < 0, k < 3, k < 5, k < 6, k < 7], [0.0, 1.0, -1.0, 1.0, -1.0], 0.0)


def pitch_sim(T=8.0, gust=None):
    return simulate(P, [PITCH_TRIM], [0.0], T, free_dofs=("model_pitch",), controls={"hawk_elevator": u3211}, airspeed=20.0, gust=gust)


def record_of(res, noise_deg, seed, name="pitch"):
    rng = np.random.default_rng(seed)
    q = res.q + rng.normal(0.0, noise_deg * D, res.q.shape)
    return FlightRecord(t=res.t, free_dofs=("model_pitch",), q=q, surfaces={"hawk_elevator": u3211(res.t)}, airspeed=20.0, name=name)


@pytest.fixture(scope="module")
def pitch_run():
    return pitch_sim()


def test_noise_free_record_gives_back_the_parameters(pitch_run):
    rec = record_of(pitch_run, 0.0, 0)
    start = {n: v * 1.2 for n, v in zip(EST_1DOF, truth(EST_1DOF))}
    fit = sysid.fit(rec, P, EST_1DOF, start=start)
    assert fit.converged
    got = np.array([fit.values[n] for n in EST_1DOF])
    np.testing.assert_allclose(got, truth(EST_1DOF), rtol=2e-4)
    assert fit.params.hawk_aero.CMq == pytest.approx(fit.values["hawk_aero.CMq"])
    assert fit.correlation.shape == (4, 4) and np.allclose(np.diag(fit.correlation), 1.0)
    assert fit.residuals[0].shape == (rec.n_t, 1)


def _monte_carlo(make_record, names, n_draws, start_scale=1.05, **kw):
    true = truth(names)
    start = {n: v * start_scale for n, v in zip(names, true)}
    est, std = [], []
    for seed in range(n_draws):
        fit = sysid.fit(make_record(seed), P, names, start=start, **kw)
        est.append([fit.values[n] for n in names])
        std.append([fit.std[n] for n in names])
    return true, np.array(est), np.array(std)


def _check_honest(true, est, std, inside=0.9, ratio=(0.7, 1.5)):
    z = (est - true) / std
    frac = np.mean(np.abs(z) < 2.0)
    scatter = est.std(axis=0, ddof=1)
    r = np.median(std, axis=0) / scatter
    assert frac >= inside, f"only {frac:.0%} of the estimates within 2 standard errors; z: {np.round(z, 2)}"
    assert np.all((r > ratio[0]) & (r < ratio[1])), f"standard error / scatter = {np.round(r, 2)}"
    return frac, r


def test_output_error_1dof_pitch_standard_errors_are_honest(pitch_run):
    """50 noise draws (0.1 deg), 1-DOF model pitch, 3-2-1-1 on the elevator: Table 3's four derivatives."""
    true, est, std = _monte_carlo(lambda s: record_of(pitch_run, 0.1, 100 + s), EST_1DOF, 50)
    frac, r = _check_honest(true, est, std)
    print(f"1-DOF: {frac:.0%} within 2 sigma; std/scatter {np.round(r, 2)}")


def _rest(free, q_guess, V):
    """The free joints' angles at rest (rad) at airspeed V, by simulating to rest from q_guess."""
    r = simulate(P, q_guess, [0.0] * len(free), 20.0, free_dofs=free, airspeed=V)
    assert np.max(np.abs(r.qd[-1])) < 1e-6
    return r.q[-1]


@pytest.mark.slow
def test_output_error_2dof_pitch_heave_with_the_compensator_doublet():
    """2-DOF rig pitch (heave) + model pitch at 20 m/s, a Hawk-elevator 3-2-1-1 then a 1 s compensator-elevator
    doublet (the paper's 2-DOF test), 0.1 deg noise, 50 draws: Hawk lift and moment derivatives and the
    compensator's flap effectiveness."""
    free = ("rig_pitch", "model_pitch")
    q0 = _rest(free, [0.0, 7.0 * D], 20.0)
    elev = sysid.three_two_one_one("hawk_elevator", -1.5, start_s=0.5)
    comp = sysid.doublet("comp_elevator", 5.0, period_s=1.0, start_s=4.0)
    controls = {**elev.controls(), **comp.controls()}
    res = simulate(P, q0, [0.0, 0.0], 8.0, free_dofs=free, controls=controls, airspeed=20.0)
    clean = FlightRecord.from_sim(res, surfaces=controls, airspeed=20.0, name="pitch_heave")
    names = ["hawk_aero.CLalpha", "hawk_aero.CMalpha", "hawk_aero.CMq", "hawk_aero.CMde", "comp_aero.CLde"]
    true, est, std = _monte_carlo(lambda s: clean.with_noise(0.1 * D, seed=2000 + s), names, 50)
    frac, r = _check_honest(true, est, std)
    print(f"2-DOF: {frac:.0%} within 2 sigma; std/scatter {np.round(r, 2)}")


@pytest.mark.slow
def test_output_error_lateral_4dof():
    """4-DOF rig roll, rig yaw (sway), model pitch and model yaw at 15 m/s (the paper's Fig. 9 set-up), a rudder
    3-2-1-1 then an aileron one, 0.1 deg noise, 50 draws: the Hawk's directional derivatives and aileron power."""
    free = ("rig_roll", "rig_yaw", "model_pitch", "model_yaw")
    q0 = _rest(free, [0.0, 0.0, 7.0 * D, 0.0], 15.0)
    rud = sysid.three_two_one_one("hawk_rudder", 3.0, start_s=0.5)
    ail = sysid.three_two_one_one("hawk_aileron", 3.0, start_s=3.0)
    controls = {**rud.controls(), **ail.controls()}
    res = simulate(P, q0, [0.0] * 4, 6.0, free_dofs=free, controls=controls, airspeed=15.0)
    clean = FlightRecord.from_sim(res, surfaces=controls, airspeed=15.0, name="lateral")
    names = ["hawk_aero.Cnbeta", "hawk_aero.Cnr", "hawk_aero.Cndr", "hawk_aero.Clda"]
    true, est, std = _monte_carlo(lambda s: clean.with_noise(0.1 * D, seed=3000 + s), names, 50)
    frac, r = _check_honest(true, est, std)
    print(f"lateral 4-DOF: {frac:.0%} within 2 sigma; std/scatter {np.round(r, 2)}")


@pytest.mark.slow
def test_filter_error_beats_output_error_in_turbulence():
    """White vertical gusts (1 m/s rms at 20 m/s: 2.9 deg of incidence) plus 0.05 deg noise, 24 draws: the
    filter error's estimates are closer to the truth, and its standard errors honest (the output error's
    are not: the process noise makes its residuals coloured and its model wrong)."""

    def make(seed):
        rng = np.random.default_rng(500 + seed)
        w = rng.normal(0.0, 1.0, 2000)
        res = pitch_sim(gust=lambda t: np.array([0.0, 0.0, w[int(round(t * 80.0))]]))
        return record_of(res, 0.05, 900 + seed, name=f"turb{seed}")

    recs = [make(s) for s in range(24)]
    true = truth(EST_1DOF)
    start = {n: v * 1.1 for n, v in zip(EST_1DOF, true)}
    out, flagged = {}, {}
    for method in ("output_error", "filter_error"):
        est, std = [], []
        flagged[method] = 0
        for rec in recs:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sysid.FitWarning)
                fit = sysid.fit(rec, P, EST_1DOF, method, start=start)
            flagged[method] += bool(fit.warnings)
            est.append([fit.values[n] for n in EST_1DOF])
            std.append([fit.std[n] for n in EST_1DOF])
        est, std = np.array(est), np.array(std)
        out[method] = (np.sqrt(np.mean(((est - true) / true) ** 2)), np.mean(np.abs((est - true) / std) < 2.0),
                       np.median(std, axis=0) / est.std(axis=0, ddof=1))
        print(f"{method}: relative rms error {out[method][0]:.3f}, {out[method][1]:.0%} within 2 sigma, "
              f"std/scatter {np.round(out[method][2], 2)}")
    # measured: output error 0.128, 65 %, 0.3-0.87; filter error 0.077, 91 %, 0.77-1.18
    assert out["filter_error"][0] < out["output_error"][0]
    assert out["filter_error"][1] >= 0.85 and out["filter_error"][1] > out["output_error"][1]
    assert np.all((out["filter_error"][2] > 0.7) & (out["filter_error"][2] < 1.5))
    # the output error's coloured residuals are flagged (sysid.misfit_warnings) where its misfit is large, the filter error's never
    print(f"flagged: {flagged}")
    assert flagged["filter_error"] == 0 and flagged["output_error"] >= 1


def test_joint_fit_of_two_records_at_two_airspeeds():
    recs = []
    for V, seed in ((15.0, 1), (20.0, 2)):
        res = simulate(P, [PITCH_TRIM], [0.0], 6.0, free_dofs=("model_pitch",), controls={"hawk_elevator": u3211}, airspeed=V)
        rng = np.random.default_rng(seed)
        recs.append(FlightRecord(t=res.t, free_dofs=("model_pitch",), q=res.q + rng.normal(0, 0.1 * D, res.q.shape),
                                 surfaces={"hawk_elevator": u3211(res.t)}, airspeed=V, name=f"V{V:.0f}"))
    start = {n: v * 1.1 for n, v in zip(EST_1DOF, truth(EST_1DOF))}
    both = sysid.fit(recs, P, EST_1DOF, start=start)
    one = sysid.fit(recs[1], P, EST_1DOF, start=start)
    assert set(both.nuisance) == {f"x0.{r}.{j}" for r in ("V15", "V20") for j in ("model_pitch", "model_pitch_rate")}
    assert len(both.residuals) == 2
    for n, t in zip(EST_1DOF, truth(EST_1DOF)):
        assert abs(both.values[n] - t) < 3.0 * both.std[n]
        assert both.std[n] < one.std[n]


def test_bad_requests_are_refused_with_the_field_named(pitch_run):
    rec = record_of(pitch_run, 0.1, 0)
    with pytest.raises(ParameterError, match="unknown parameter"):
        sysid.fit(rec, P, ["hawk_aero.CMzz"])
    with pytest.raises(ParameterError, match="outside the allowed range"):
        sysid.fit(rec, P, ["hawk_aero.CMq"], bounds={"hawk_aero.CMq": (20.0, 30.0)})
    with pytest.raises(ParameterError, match="not among the estimated"):
        sysid.fit(rec, P, ["hawk_aero.CMq"], start={"hawk_aero.CMde": -1.0})
    with pytest.raises(ValueError, match="method"):
        sysid.fit(rec, P, ["hawk_aero.CMq"], method="magic")
    t = rec.t.copy()
    t[5:] += 0.003
    uneven = FlightRecord(t=t, free_dofs=rec.free_dofs, q=rec.q, surfaces=rec.surfaces, airspeed=20.0)
    with pytest.raises(RecordError, match="resample"):
        sysid.fit(uneven, P, ["hawk_aero.CMq"])
    with pytest.raises(RecordError, match="q has shape"):
        FlightRecord(t=rec.t, free_dofs=("model_pitch",), q=np.zeros((3, 1)))


def test_rig_identify_end_to_end_from_a_csv_record(tmp_path, pitch_run):
    """A record written as CSV, a configuration, ``rig identify``: the report and an identified parameter
    file that loads back with the estimates, their standard errors and provenance."""
    from rig_cli.main import main

    assert sysid.METHODS == __import__("rig_cli.identify", fromlist=["METHODS"]).METHODS
    rec = record_of(pitch_run, 0.1, 7, name="pitch_3211")
    rec.write(tmp_path / "pitch.csv")
    (tmp_path / "id.toml").write_text(
        'method = "output_error"\n'
        'estimate = ["hawk_aero.CM0", "hawk_aero.CMalpha", { name = "hawk_aero.CMq", start = -5.0 }, "hawk_aero.CMde"]\n'
        '[[record]]\npath = "pitch.csv"\n'
    )
    rc = main(["identify", str(tmp_path / "id.toml"), "--out", str(tmp_path / "out")])
    assert rc in (0, None)
    assert (tmp_path / "out" / "report.md").exists()
    got = RigParams.from_toml(tmp_path / "out" / "identified.toml")
    prov = got.provenance("hawk_aero.CMq")
    assert prov["source"] == "identified" and prov["records"] == ["pitch_3211"] and prov["std"] > 0.0
    assert abs(got.hawk_aero.CMq - P.hawk_aero.CMq) < 4.0 * prov["std"]
    assert got.hawk_aero.CLalpha == P.hawk_aero.CLalpha and got.source("hawk_aero.CLalpha") == P.source("hawk_aero.CLalpha")
    rc2 = main(["identify", str(tmp_path / "id.toml"), "--out", str(tmp_path / "out")])
    assert rc2 == 2  # an existing report is never overwritten silently


def test_equation_error_gives_start_values_that_output_error_finishes(pitch_run, tmp_path):
    """Equation error from 50 % off: within 10 % of the truth on a noise-free record (its known bias: the
    differentiator smears the elevator's steps); output error from there converges to the truth; the report
    plots accelerations at the samples the differentiator keeps."""
    far = {n: 0.5 * v for n, v in zip(EST_1DOF, truth(EST_1DOF))}
    ee = sysid.fit(record_of(pitch_run, 0.0, 0), P, EST_1DOF, "equation_error", start=far)
    got = np.array([ee.values[n] for n in EST_1DOF])
    np.testing.assert_allclose(got, truth(EST_1DOF), rtol=0.10)
    assert ee.outputs == (("model_pitch_accel",),) and ee.times[0].size == ee.residuals[0].shape[0]
    rec = record_of(pitch_run, 0.1, 3)
    ee = sysid.fit(rec, P, EST_1DOF, "equation_error", start=far)
    oe = sysid.fit(rec, P, EST_1DOF, start=ee.values)
    for n, t in zip(EST_1DOF, truth(EST_1DOF)):
        assert abs(oe.values[n] - t) < 3.0 * oe.std[n]
    sysid.write_report(ee, tmp_path / "ee")
    assert "deg/s^2" in (tmp_path / "ee" / "report.md").read_text()


def test_a_frame_log_of_the_loop_flying_the_simulated_rig_is_read_and_fitted(tmp_path):
    """The real-time loop flies the simulated rig (velocity-vector roll, the linear law), its frame log is read
    as a record and the compensator's flap effectiveness fitted from it: the loop's commands, the sim rig's
    sensors (noise, quantisation) and its measured airspeed, on the default rig, give the default value back.
    From two starts (sysid.fit_from_starts): the rig rolls over the top only with enough aileron power against its
    0.398 kg m roll imbalance, so from below the simulated roll falls back and the fit stops in a local minimum
    (1.42 from starts of 1.3 and 1.5, 1.64 from 1.6) of higher cost; from 1.8 or 2.0 it reaches 1.6943."""
    from test_sysid_records import fly_sim_rig

    log, rig, spec = fly_sim_rig(tmp_path, 4.0)
    rec = FlightRecord.read(log, allow_gaps=True)
    rec = rec.resample(80.0, allow_gaps=True) if np.ptp(np.diff(rec.t)) > 1e-6 else rec
    with warnings.catch_warnings():
        warnings.simplefilter("error", sysid.FitWarning)  # the local minimum of the first start is not told: the best fit has none
        fit = sysid.fit_from_starts(rec, P, ["comp_aero.CLde"], [{"comp_aero.CLde": 1.3}, {"comp_aero.CLde": 2.0}])
    assert "best of 2 starts" in fit.message and fit.initial["comp_aero.CLde"] == 2.0 and fit.warnings == ()
    with pytest.warns(sysid.FitWarning, match=r"rig_roll is not followed \(R\^2 -?\d+\.\d\d < 0\.9.*fit_from_starts"):
        low = sysid.fit(rec, P, ["comp_aero.CLde"], start={"comp_aero.CLde": 1.3})  # the local minimum below the truth
    assert low.values["comp_aero.CLde"] < 1.5 and low.cost_history[-1] > fit.cost_history[-1]
    assert len(low.warnings) == 1 and low.warnings[0].startswith(f"{rec.name}: rig_roll is not followed")
    z = (fit.values["comp_aero.CLde"] - P.comp_aero.CLde) / fit.std["comp_aero.CLde"]
    print(f"CLde {fit.values['comp_aero.CLde']:.4f} +- {fit.std['comp_aero.CLde']:.4f} (truth {P.comp_aero.CLde}), z = {z:.2f}")
    # 0.01 % (z = 3.9) measured on the default rig (0.06 %, z = -2.4, on the paper's model): the frames the loop missed on a loaded machine (resampled over) and the
    # sim rig's float32 wire leave a small bias beside a very small standard error; 0.5 % is the physical bar
    assert fit.converged and abs(fit.values["comp_aero.CLde"] / P.comp_aero.CLde - 1.0) < 0.005


def test_a_sensor_offset_is_estimated_as_a_bias_and_bounds_hold(pitch_run):
    """A potentiometer zeroed 0.5 deg off: with ``biases=True`` the offset comes back and the derivatives stay
    right (CM0 known: a constant angle offset and the trim moment CM0 are the same thing to a 1-DOF record).
    A bound that excludes the truth holds the estimate on the bound."""
    rec = record_of(pitch_run, 0.1, 11)
    off = FlightRecord(t=rec.t, free_dofs=rec.free_dofs, q=rec.q + 0.5 * D, surfaces=rec.surfaces, airspeed=20.0, name="offset")
    names = EST_1DOF[1:]
    start = {n: v * 1.05 for n, v in zip(names, truth(names))}
    fit = sysid.fit(off, P, names, start=start, biases=True)
    assert fit.nuisance["bias.offset.model_pitch"] == pytest.approx(0.5 * D, abs=0.05 * D)
    for n, t in zip(names, truth(names)):
        assert abs(fit.values[n] - t) < 3.0 * fit.std[n]
    bounded = sysid.fit(rec, P, ["hawk_aero.CMq"], bounds={"hawk_aero.CMq": (-4.0, -1.0)}, start={"hawk_aero.CMq": -2.0})
    assert bounded.values["hawk_aero.CMq"] == pytest.approx(-4.0)


def test_a_parameter_the_records_cannot_show_is_refused_by_name(pitch_run):
    """A 1-DOF pitch record says nothing of the rig-roll friction nor of the compensator; the servo delay moves
    in whole physics steps.  Each is refused by name rather than given a meaningless standard error."""
    rec = record_of(pitch_run, 0.1, 0)
    with pytest.raises(ValueError, match=r"friction\.rig_roll\.Fc.*not identifiable"):
        sysid.fit(rec, P, ["hawk_aero.CMq", "friction.rig_roll.Fc"])
    with pytest.raises(ValueError, match=r"servos\.hawk\.delay_s.*whole physics steps"):
        sysid.fit(rec, P, ["servos.hawk.delay_s"])


def test_the_unsteady_models_parameters_are_identified_from_a_stall_record():
    """aero_model="unsteady": the centre-of-pressure travel (docs/MODEL.md 3.1.1), which acts only in the
    unsteady model, comes back from a simulated 1-DOF elevator doublet through the stall's onset (0.05 deg
    pot noise) within two standard errors, from a start at 0; equation error, which has no aerodynamic
    states, refuses the model by name; rig identify takes the option and refuses a bad one."""
    from rig_cli.identify import AERO_MODEL_NAMES
    from rig_env.physics.pipeline import AERO_MODELS

    assert tuple(AERO_MODELS) == AERO_MODEL_NAMES
    truth_p = P.replace(**{"hawk_aero.sep_cp_travel": 0.06})

    def elev(t):
        k = (np.asarray(t) - 0.5) / 0.5
        return -0.8 + 1.2 * np.select([k < 0, k < 1, k < 2, k < 3, k < 4], [0.0, 1.0, -1.0, 1.0, -1.0], 0.0)

    r = simulate(truth_p, [9.35 * D], [0.0], 6.0, free_dofs=("model_pitch",), controls={"hawk_elevator": elev}, airspeed=20.0,
                 aero_model="unsteady")
    assert r.separation[:, 0].min() < 0.2  # the doublet reaches the stall
    rng = np.random.default_rng(0)
    rec = FlightRecord(t=r.t, free_dofs=("model_pitch",), q=r.q + rng.normal(0.0, 0.05 * D, r.q.shape),
                       surfaces={"hawk_elevator": elev(r.t)}, airspeed=20.0, name="stall")
    fit = sysid.fit(rec, P, ["hawk_aero.sep_cp_travel"], aero_model="unsteady")
    assert fit.converged and fit.initial["hawk_aero.sep_cp_travel"] == 0.0
    assert abs(fit.values["hawk_aero.sep_cp_travel"] - 0.06) < 2.0 * fit.std["hawk_aero.sep_cp_travel"] + 1e-4
    assert fit.std["hawk_aero.sep_cp_travel"] < 0.01
    with pytest.raises(ValueError, match="equation error regresses the measured states"):
        sysid.fit(rec, P, ["hawk_aero.sep_cp_travel"], method="equation_error", aero_model="unsteady")
    with pytest.raises(ValueError, match=r"aero_model = 'quasi': allowed values"):
        sysid.fit(rec, P, ["hawk_aero.sep_cp_travel"], aero_model="quasi")


def test_misfit_warnings_need_a_low_r2_and_coloured_residuals(pitch_run, tmp_path):
    """sysid.misfit_warnings flags an output only when all hold: R^2 below 0.9, residuals far from white, and an
    output that moves beyond its noise.  On a good fit's own shape: an output whose residuals are white noise as
    large as its motion (R^2 about 0) is not flagged; a slow structured misfit of the motion's size is; a small
    structured misfit (R^2 0.99) is not; nor an output that hardly moves, whose residuals (noise ten times its motion
    and a slow part as large as the noise) are coloured.  Equation error is never flagged."""
    from dataclasses import replace as dc_replace

    rec = record_of(pitch_run, 0.1, 0)
    good = sysid.fit(rec, P, ["hawk_aero.CMq"], start={"hawk_aero.CMq": truth(["hawk_aero.CMq"])[0]})
    assert good.warnings == () and sysid.misfit_warnings(good) == ()
    n, m = good.residuals[0].shape
    rng = np.random.default_rng(0)
    t = np.arange(n) / 80.0
    motion = np.outer(np.sin(2 * np.pi * 0.5 * t), np.ones(m)) * 1e-3
    noise = rng.standard_normal((n, m)) * 1e-3
    drift = np.outer(np.sin(2 * np.pi * 0.2 * t + 1.0), np.ones(m)) * 1e-3
    assert sysid.misfit_warnings(dc_replace(good, predicted=(motion * 0.0,), residuals=(noise,))) == ()
    flagged = sysid.misfit_warnings(dc_replace(good, predicted=(motion,), residuals=(drift,)))
    assert len(flagged) == m and all(f"{rec.name}: {name} is not followed" in w for name, w in zip(good.outputs[0], flagged))
    assert sysid.misfit_warnings(dc_replace(good, predicted=(motion,), residuals=(0.1 * drift,))) == ()
    still = dc_replace(good, predicted=(0.1 * motion,), residuals=(noise + drift,))
    from rig_env.sysid.diagnostics import whiteness

    assert all(w.p_value < 1e-6 for w in whiteness(still.residuals[0])) and sysid.misfit_warnings(still) == ()
    assert sysid.misfit_warnings(dc_replace(good, method="equation_error", predicted=(motion,), residuals=(drift,))) == ()
    report = sysid.write_report(dc_replace(good, warnings=flagged), tmp_path / "flagged").read_text()  # the report tells them
    assert "**Warnings**" in report and flagged[0] in report
    assert "**Warnings**" not in sysid.write_report(good, tmp_path / "good").read_text()


def test_monte_carlo_counts_flagged_fits_without_warning_each(pitch_run):
    """sysid.monte_carlo keeps each draw's misfit flag in ``flagged`` and issues no FitWarning draw by draw: none on the
    right model, every draw when the fitted rig's CMalpha is held at 30 % of the truth (only CMq estimated)."""
    from rig_env.sysid import monte_carlo

    clean = record_of(pitch_run, 0.0, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", sysid.FitWarning)
        good = monte_carlo(clean, P, ["hawk_aero.CMq"], noise_std_rad=0.1 * D, seeds=[0, 1], fit_kwargs={"max_iter": 8})
        wrong = monte_carlo(clean, P.replace(**{"hawk_aero.CMalpha": 0.3 * P.hawk_aero.CMalpha}), ["hawk_aero.CMq"],
                            noise_std_rad=0.1 * D, seeds=[0, 1], fit_kwargs={"max_iter": 8})
    assert good.flagged.tolist() == [False, False] and wrong.flagged.tolist() == [True, True]
    one = monte_carlo(clean, P, "hawk_aero.CMq", noise_std_rad=0.1 * D, seeds=[0], fit_kwargs={"max_iter": 8})
    assert one.names == ("hawk_aero.CMq",)  # one name, as fit() takes it; it was split into 13 one-letter "names"


def test_fit_from_starts_refuses_bad_starts_by_name(pitch_run):
    """sysid.fit_from_starts: the starts must be a non-empty list of mappings of the estimated names, and the
    start values are given there, not as start=; each refused before any fit runs."""
    rec = record_of(pitch_run, 0.1, 0)
    for starts, words in (([], "non-empty list"), ({"hawk_aero.CMq": -4.0}, "non-empty list"), ([1.0], "mapping"),
                          ([{"hawk_aero.CMalpha": -0.5}], "not among the estimated parameters")):
        with pytest.raises(ValueError, match=words):
            sysid.fit_from_starts(rec, P, ["hawk_aero.CMq"], starts)
    with pytest.raises(ValueError, match="give the start values in starts"):
        sysid.fit_from_starts(rec, P, ["hawk_aero.CMq"], [{"hawk_aero.CMq": -4.0}], start={"hawk_aero.CMq": -3.0})


def test_records_too_short_or_named_alike_are_refused_before_the_fit(pitch_run):
    """A 2-sample record ran the fit and failed in the diagnostics; a 5-sample one returned CMq = -77 +- 112 without a
    word.  Two records of one name gave one nuisance parameter name (x0.<record>.<joint>) and one report figure, and so did
    two names of one file-name form.  Each is refused by the API before the fit, naming the records; rig identify
    refuses short records by the API's own number."""
    import inspect

    import rig_cli.identify as identify

    assert identify.MIN_RECORD_SAMPLES == sysid.MIN_RECORD_SAMPLES == 10
    assert "MIN_RECORD_SAMPLES = " not in inspect.getsource(identify)  # imported, not a second number
    rec = record_of(pitch_run, 0.1, 0)
    for n in (2, 5, 9):
        short = rec.segment(rec.t[0], rec.t[n - 1])
        with pytest.raises(RecordError, match=rf"pitch\[0:[\d.]+\]: {n} sample\(s\); a record to fit needs at least 10"):
            sysid.fit(short, P, ["hawk_aero.CMq"])
        with pytest.raises(RecordError, match=rf"{n} sample\(s\); a record to fit needs at least 10"):
            sysid.fit_from_starts([rec, short], P, ["hawk_aero.CMq"], [{"hawk_aero.CMq": -4.0}])
    with pytest.raises(RecordError, match=r"records\[0\] 'pitch' and records\[1\] 'pitch': the same name, so their estimated initial states "
                                          r"\(x0.pitch.<joint>\), biases and report figures \(history_pitch.png, acf_pitch.png\) would collide; "
                                          r"give each record its own name \(FlightRecord\(name=...\)"):
        sysid.fit([rec, record_of(pitch_run, 0.1, 1)], P, ["hawk_aero.CMq"])
    with pytest.raises(RecordError, match=r"records\[0\] 'run 1' and records\[1\] 'run_1': names of one file-name form 'run_1', so their report "
                                          r"figures \(history_run_1.png, acf_run_1.png\) would collide.*rig identify: the \[\[record\]\] table's name"):
        sysid.fit([record_of(pitch_run, 0.1, 0, "run 1"), record_of(pitch_run, 0.1, 1, "run_1")], P, ["hawk_aero.CMq"], method="equation_error")


def test_fit_arguments_of_the_wrong_type_are_refused_by_name(pitch_run):
    """Each was a raw Python error (or, for progress, one from inside the optimiser); max_iter=True ran as 1 and a
    numpy integer was refused."""
    rec = record_of(pitch_run, 0.1, 0)
    E = ["hawk_aero.CMq"]
    for kw, words in (({"tol": "1e-6"}, r"tol = '1e-6': allowed a number in \(0, 1\)"), ({"tol": None}, r"tol = None: allowed a number"),
                      ({"max_iter": True}, r"max_iter = True: allowed an integer in \[1, 1000\]"), ({"max_iter": 2.0}, r"max_iter = 2.0"),
                      ({"progress": 5}, r"progress = 5: give a function taking one line \(str\) per iteration, or None"),
                      ({"start": {"hawk_aero.CMq": "x"}}, r"start\['hawk_aero.CMq'\] = 'x': must be a number in \[-100.0, 10.0\] 1/rad"),
                      ({"bounds": {"hawk_aero.CMq": (True, 0.0)}}, r"bounds\['hawk_aero.CMq'\] must be a pair \(low, high\) of numbers"),
                      ({"start": 5}, r"start = 5: give a mapping")):
        with pytest.raises(ValueError, match=words):
            sysid.fit(rec, P, E, **kw)
    for records in (None, "pitch", [rec, None]):
        with pytest.raises(RecordError, match=r"records = .*: give one or more FlightRecord objects"):
            sysid.fit(records, P, E)
    with pytest.raises(ParameterError, match=r"estimate = None: give a list of dotted parameter names"):
        sysid.fit(rec, P, None)
    lines = []
    fit = sysid.fit(rec, P, E, max_iter=np.int64(1), tol=np.float32(1e-3), progress=lines.append)
    assert fit.iterations == 1 and lines


def test_fit_from_starts_checks_every_start_and_option_before_the_first_fit(pitch_run):
    """A bad second start failed only after the first start's fit had run; an estimate given as one string was
    refused listing its characters."""
    rec = record_of(pitch_run, 0.1, 0)
    ran = []
    with pytest.raises(ParameterError, match=r"starts\[1\]: start value of hawk_aero.CMq = 500.0 1/rad is outside its bounds"):
        sysid.fit_from_starts(rec, P, ["hawk_aero.CMq"], [{"hawk_aero.CMq": -4.0}, {"hawk_aero.CMq": 500.0}], progress=ran.append)
    with pytest.raises(ParameterError, match=r"starts\[1\]: start\['hawk_aero.CMq'\] = 'x': must be a number"):
        sysid.fit_from_starts(rec, P, ["hawk_aero.CMq"], [{"hawk_aero.CMq": -4.0}, {"hawk_aero.CMq": "x"}], progress=ran.append)
    with pytest.raises(ValueError, match=r"tol = 'x': allowed a number"):
        sysid.fit_from_starts(rec, P, ["hawk_aero.CMq"], [{"hawk_aero.CMq": -4.0}], tol="x", progress=ran.append)
    with pytest.raises(ValueError, match=r"options: got an unexpected keyword argument 'max_iters'"):
        sysid.fit_from_starts(rec, P, ["hawk_aero.CMq"], [{"hawk_aero.CMq": -4.0}], max_iters=3, progress=ran.append)
    assert ran == []  # no fit ran
    with pytest.raises(ValueError, match=r"estimate = 'hawk_aero.CMq': give a list of names \(dotted names of rig_env.PARAM_NAMES\), "
                                         r"e.g. \['hawk_aero.CMq'\]"):
        sysid.fit_from_starts(rec, P, "hawk_aero.CMq", [{"hawk_aero.CMq": -4.0}])
