"""Input design and the one schedule: shapes against their definitions, orthogonal multisines against
theory (orthogonality over the period, peak factor below Schroeder's), limits, the plain-data round trip,
and the same schedule flown by simulate() and by the environment."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import rig_env
from rig_env.envs import RigVectorEnv
from rig_env.envs.tasks import freeflight
from rig_env.physics import layout as L
from rig_env.signals import (
    Doublet,
    InputSchedule,
    Multisine,
    Sampled,
    ScheduleError,
    Step,
    ThreeTwoOneOne,
    three_two_one_one as wave_3211,
)
from rig_env.simulate import fill_inputs
from rig_env.sysid import doublet, multisine, peak_factors, three_two_one_one
from rig_env.sysid.inputs import harmonics, relative_peak_factor, schroeder_phases

H = 1e-4  # s, the fine grid the step shapes are read on
COMP = ("comp_aileron", "comp_elevator", "comp_rudder")


def _jumps(ts: np.ndarray, u: np.ndarray) -> np.ndarray:
    return ts[1:][np.diff(u) != 0.0]


# ---------------------------------------------------------------------- steps against their definitions
def test_three_two_one_one_timing_levels_and_areas():
    sched = three_two_one_one("hawk_elevator", 2.0)  # the paper's 0.28 s unit, from 0.5 s
    (shape,) = sched.shapes["hawk_elevator"]
    assert shape == ThreeTwoOneOne(2.0, 0.28, 0.5) and sched.duration == pytest.approx(0.5 + 7 * 0.28)
    ts = np.arange(0.0, 3.0, H)
    u = sched(ts)["hawk_elevator"]
    edges = 0.5 + 0.28 * np.array([0.0, 3.0, 5.0, 6.0, 7.0])
    np.testing.assert_allclose(_jumps(ts, u), edges, atol=1.5 * H)
    assert [u[np.searchsorted(ts, e + 0.01)] for e in edges] == [2.0, -2.0, 2.0, -2.0, 0.0]
    assert np.sum(u) * H == pytest.approx(2.0 * 0.28, rel=1e-3)  # (3 - 2 + 1 - 1) units of +A
    assert np.sum(np.abs(u)) * H == pytest.approx(7 * 2.0 * 0.28, rel=1e-3)
    # one copy: the free-flight task's 3-2-1-1 is this one
    assert freeflight.three_two_one_one is wave_3211
    np.testing.assert_array_equal(shape(ts), wave_3211(ts, 0.5, 2.0))


def test_doublet_and_step_timing_levels_and_areas():
    sched = doublet("comp_elevator", 1.5)  # the paper's 1 s compensator doublet, from 0.5 s
    ts = np.arange(0.0, 2.0, H)
    u = sched(ts)["comp_elevator"]
    np.testing.assert_allclose(_jumps(ts, u), [0.5, 1.0, 1.5], atol=1.5 * H)
    assert u[np.searchsorted(ts, 0.75)] == 1.5 and u[np.searchsorted(ts, 1.25)] == -1.5 and u[-1] == 0.0
    assert abs(np.sum(u) * H) < 2 * 1.5 * H and np.sum(np.abs(u)) * H == pytest.approx(1.5, rel=1e-3)
    s = Step(-3.0, duration_s=0.4, start_s=0.2)
    v = s(ts)
    np.testing.assert_allclose(_jumps(ts, v), [0.2, 0.6], atol=1.5 * H)
    assert np.sum(v) * H == pytest.approx(-3.0 * 0.4, rel=1e-3) and s.end_s == pytest.approx(0.6)


def test_sampled_series_is_held_and_replays_sample_k_at_step_k():
    dt, vals = 1 / 80, np.random.default_rng(0).normal(size=500)
    s = Sampled(tuple(vals), dt, start_s=0.25)
    k = np.arange(-20, 540)
    t = 0.25 + k * dt  # the products of rounding that simulate() and the environments evaluate
    expect = np.where((k >= 0) & (k < 500), vals[np.clip(k, 0, 499)], 0.0)
    np.testing.assert_array_equal(s(t), expect)
    np.testing.assert_array_equal(s(t + 0.6 * dt), expect)  # held between samples
    assert s.end_s == pytest.approx(0.25 + 500 * dt)


# ---------------------------------------------------------------------- multisines against theory
def test_orthogonal_multisines_disjoint_orthogonal_and_peak_factor_below_schroeder():
    T = 10.0
    sched = multisine(COMP, T, 0.1, 2.0, 5.0)
    ks = harmonics(T, 0.1, 2.0, 3)
    assert [k.tolist() for k in ks] == [list(range(1, 21))[j::3] for j in range(3)]  # interleaved, every harmonic used once
    n = 4096  # > 2 k_max: on this uniform grid over one period, sines of distinct harmonics sum to zero exactly
    t = 0.5 + T * np.arange(n) / n
    U = sched.sample(t)[:, :3]
    for j, s in enumerate(COMP):
        (m,) = sched.shapes[s]
        np.testing.assert_allclose(np.array(m.frequencies_hz) * T, ks[j], atol=1e-9)
    G = U.T @ U / n  # mean products over the period
    corr = G / np.sqrt(np.outer(np.diag(G), np.diag(G)))
    assert np.max(np.abs(corr - np.eye(3))) < 1e-12, corr
    rpf = peak_factors(sched)
    for j, s in enumerate(COMP):
        (m,) = sched.shapes[s]
        schroeder = Multisine(m.frequencies_hz, m.amplitudes_deg, tuple(schroeder_phases(len(ks[j]))), T, 0.5)
        print(f"{s}: harmonics {ks[j].tolist()}, relative peak factor {rpf[s]:.4f} (Schroeder's {schroeder.relative_peak_factor:.4f})")
        assert rpf[s] < schroeder.relative_peak_factor and rpf[s] < 1.2
        assert rpf[s] == pytest.approx(relative_peak_factor(U[:, j]), rel=2e-3)  # the property is the definition
        assert np.abs(U[:, j]).max() == pytest.approx(5.0, rel=2e-3)  # scaled to its peak amplitude
        assert abs(m(0.5)) < 1e-9 and abs(m(0.5 + T - 1e-9)) < 1e-6  # starts and ends at zero
        assert m(0.5 - 1e-9) == 0.0 and m(0.5 + T) == 0.0  # nothing outside its window
    sched.check(40.0, 350.0, 1 / 80)


def test_multisine_limits_refused_by_name_or_scaled_on_request():
    with pytest.raises(ValueError, match=r"comp_elevator: a 45 deg peak exceeds the position limit.*lower amplitude_deg for comp_elevator"):
        multisine(("comp_elevator",), 8.0, 0.2, 1.0, 45.0)
    with pytest.raises(ValueError, match=r"hawk_rudder.*exceeds the rate limit.*lower amplitude_deg for hawk_rudder to at most"):
        multisine(("hawk_aileron", "hawk_rudder"), 8.0, 2.0, 12.0, {"hawk_aileron": 1.0, "hawk_rudder": 20.0})
    sched = multisine(("hawk_aileron", "hawk_rudder"), 8.0, 2.0, 12.0, [1.0, 20.0], scale_to_limits=True)
    sched.check(40.0, 350.0, 1 / 80)
    t = np.arange(int(8.5 * 80) + 2) / 80
    rate = np.abs(np.diff(sched.sample(t)[:, 5], prepend=0.0)).max() * 80
    assert rate == pytest.approx(350.0, rel=1e-9)  # scaled exactly to the rate limit, not below
    assert np.abs(sched.sample(t)[:, 4]).max() <= 1.0  # the other surface untouched
    with pytest.raises(ValueError, match="harmonic"):
        multisine(COMP, 2.0, 0.5, 1.0, 1.0)  # two harmonics of 0.5 Hz in the band for three surfaces
    with pytest.raises(ValueError, match="half the 80 Hz"):
        multisine(COMP, 10.0, 1.0, 45.0, 1.0)


def test_numpy_numbers_are_numbers_to_the_designs():
    assert three_two_one_one("hawk_elevator", np.int64(2)) == three_two_one_one("hawk_elevator", 2.0)
    assert doublet("comp_elevator", np.float32(1.5), limit_deg=np.int64(40)) == doublet("comp_elevator", 1.5)
    a = multisine("hawk_elevator", np.float32(5.0), np.float64(0.2), 2.0, np.float32(5.0), seed=np.int64(0), restarts=np.int32(1))
    b = multisine("hawk_elevator", 5.0, 0.2, 2.0, 5.0, seed=0, restarts=1)
    assert a == b
    assert multisine(("hawk_elevator", "hawk_rudder"), 5.0, 0.2, 2.0, np.array([5.0, 2.0])).surfaces == ("hawk_elevator", "hawk_rudder")


@pytest.mark.parametrize("call, message", [
    (lambda: three_two_one_one("hawk_elevator", 1.0, limit_deg=-1), r"^limit_deg = -1: the position limit must be a positive finite number of degrees$"),
    (lambda: doublet("hawk_elevator", 1.0, limit_deg=0.0), r"^limit_deg = 0.0: the position limit must be a positive"),
    (lambda: three_two_one_one("hawk_elevator", "2"), r"^amplitude_deg = '2': must be a finite number of degrees$"),
    (lambda: three_two_one_one("hawk_elevator", np.int64(50)), r"^amplitude_deg = np.int64\(50\): must be non-zero and within the position limit \+-40 deg$"),
    (lambda: multisine("hawk_elevator", 5.0, 0.2, 2.0, 5.0, restarts=-1), r"^restarts = -1: must be an integer in \[0, 100\]$"),
    (lambda: multisine("hawk_elevator", 5.0, 0.2, 2.0, 5.0, restarts=2.5), r"^restarts = 2.5: must be an integer in \[0, 100\]$"),
    (lambda: multisine("hawk_elevator", 5.0, 0.2, 2.0, 5.0, seed=-1), r"^seed = -1: must be an integer >= 0$"),
    (lambda: multisine("hawk_elevator", 5.0, 0.2, 2.0, 5.0, seed=True), r"^seed = True: must be an integer >= 0$"),
    (lambda: multisine("hawk_elevator", 5.0, 0.2, 2.0, "5"), r"^amplitude_deg = '5': give one number, one per surface in order, or a mapping"),
    (lambda: multisine("hawk_elevator", np.float32(-5.0), 0.2, 2.0, 5.0), r"^duration_s = np.float32\(-5.0\): must be a positive finite number$"),
    (lambda: multisine("hawk_elevator", 1000.0, 0.1, 10.0, 5.0), r"^multisine: duration_s \* f_max_hz = 1000 s x 10 Hz = 10000, beyond harmonic 4096 "
                                                                   r"of 1/duration_s \(rig_env.sysid.inputs.MAX_HARMONIC"),
    (lambda: multisine("hawk_elevator", 4000.0, 0.01, 1.0, 5.0), r"^multisine: the command held every dt = 0.0125 s over start_s \+ duration_s = 4000.5 s "
                                                                   r"\(320042 steps\) with 3961 harmonics is 1.27e\+09 sine terms"),
    (lambda: multisine("hawk_elevator", 100.0, 0.1, 1.0, 5.0, dt=1e-5), r"^multisine: start_s \+ duration_s = 100.5 s held every dt = 1e-05 s is "
                                                                         r"1.005e\+07 control steps, more than 4194304"),
])
def test_bad_design_arguments_are_refused_by_name(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_phase_search_work_is_bounded(monkeypatch):
    """60 s, 0.1-10 Hz on one surface (595 harmonics): the search runs on 16 samples per period of the highest
    harmonic, with its iterations capped (took > 75 s with an n^3 BFGS on 64 samples per period); the peak
    factor stays near 1 (Schroeder's 1.29)."""
    from rig_env.sysid import inputs

    k = harmonics(60.0, 0.1, 10.0, 1)[0]
    synthesised = []
    synth = inputs._synth
    monkeypatch.setattr(inputs, "_synth", lambda k, a, phi, n: (synthesised.append(n), synth(k, a, phi, n))[1])
    phi = inputs.minimum_peak_phases(k, 60.0, restarts=0)
    assert k.size == 595 and max(synthesised) == 65536 and sorted(set(synthesised)) == [16384, 65536]
    assert sum(synthesised) < 12e6, f"{len(synthesised)} signals, {sum(synthesised):.3g} samples"
    rpf = relative_peak_factor(synth(k, np.ones(k.size), phi, 65536))
    assert rpf < 1.0 < relative_peak_factor(synth(k, np.ones(k.size), schroeder_phases(k.size), 65536)) - 0.25, rpf


def test_check_names_surface_time_and_limit():
    with pytest.raises(ScheduleError, match=r"hawk_rudder: 41 deg at t = 0\.5000 s exceeds the position limit \+-40 deg"):
        InputSchedule({"hawk_rudder": Step(41.0, 1.0, 0.5)}).check()
    # +3 to -3 deg at 0.5 + 3 x 0.28 = 1.34 s, first held at the step of 1.35 s: 6 deg in 1/80 s
    with pytest.raises(ScheduleError, match=r"hawk_elevator: the command changes at 480 deg/s at t = 1\.3500 s .*rate limit 350 deg/s"):
        InputSchedule({"hawk_elevator": ThreeTwoOneOne(3.0, start_s=0.5)}).check(rate_deg_s=350.0)
    InputSchedule({"hawk_elevator": ThreeTwoOneOne(2.0, start_s=0.5)}).check()  # 4 deg in 1/80 s = 320 deg/s: within


def test_check_bounds_its_work_and_reads_a_long_schedule_in_blocks():
    from rig_env.signals import MAX_CHECK_SAMPLES

    with pytest.raises(ScheduleError, match=r"^check: dt = 0.0125 s over the schedule's 1e\+15 s is 8e\+16 samples, more than "
                                            rf"{MAX_CHECK_SAMPLES} \(rig_env.signals.MAX_CHECK_SAMPLES\)"):
        InputSchedule({"hawk_elevator": Step(1.0, 1e15)}).check()
    with pytest.raises(ScheduleError, match=r"^check: dt = 1e-15 s over the schedule's 1 s is 1e\+15 samples"):
        InputSchedule({"hawk_elevator": Step(1.0, 1.0)}).check(dt=1e-15)
    with pytest.raises(ScheduleError, match=r"^check.dt = np.float32\(-1.0\): must be a positive finite number"):
        InputSchedule({"hawk_elevator": Step(1.0, 1.0)}).check(dt=np.float32(-1.0))
    # beyond the first block of samples: found at its time; a position excess is named before an earlier rate excess
    with pytest.raises(ScheduleError, match=r"hawk_rudder: 41 deg at t = 1000\.0000 s exceeds the position limit"):
        InputSchedule({"hawk_rudder": Step(41.0, 1.0, 1000.0)}).check()
    with pytest.raises(ScheduleError, match=r"hawk_rudder: the command changes at 800 deg/s at t = 1000\.0000 s"):
        InputSchedule({"hawk_rudder": Step(10.0, 1.0, 1000.0)}).check()
    with pytest.raises(ScheduleError, match=r"hawk_rudder: 41 deg at t = 1000\.0000 s"):
        InputSchedule({"hawk_rudder": [Step(10.0, 1.0, 0.5), Step(41.0, 1.0, 1000.0)]}).check()
    InputSchedule({"hawk_rudder": Step(4.0, 900.0, 100.0)}).check(dt=np.float64(1 / 80))


def test_multisine_evaluation_and_peak_factor_are_those_of_the_definition():
    """Evaluated in blocks (bounded memory) to the same values; the peak factor of harmonics by FFT equals the direct one's."""
    m = Multisine(tuple(np.arange(1, 301) / 10.0), (1.0,) * 300, tuple(schroeder_phases(300)), 10.0, 0.5)
    t = 0.5 + 10.0 * np.arange(8192) / 8192
    f, a, p = (np.array(v) for v in (m.frequencies_hz, m.amplitudes_deg, m.phases_rad))
    direct = (np.sin(2.0 * math.pi * np.multiply.outer(t - 0.5, f) + p) * a).sum(axis=-1)
    np.testing.assert_array_equal(m(t), direct)
    assert m(t.reshape(64, 128)).shape == (64, 128) and m(0.4) == 0.0
    n = int(64 * 30 * 10)
    assert m.relative_peak_factor == pytest.approx(relative_peak_factor(m(0.5 + 10.0 * np.arange(n) / n)), rel=1e-9)
    off = Multisine((0.25, 0.61), (1.0, 0.5), (0.0, 1.0), 3.0)  # not harmonics of 1 / 3 s: read directly
    n = 4096
    assert off.relative_peak_factor == pytest.approx(relative_peak_factor(off(3.0 * np.arange(n) / n)), rel=1e-12)


# ---------------------------------------------------------------------- plain data
def _every_shape() -> InputSchedule:
    return InputSchedule({
        "comp_aileron": Multisine((0.5, 1.5), (1.0, 0.5), (0.1, -2.0), 4.0, 0.5),
        "comp_rudder": Sampled((0.0, 1.0, -1.0, 0.5), 0.0125, 1.0),
        "hawk_elevator": [ThreeTwoOneOne(2.0, start_s=0.5), Doublet(1.0, 1.0, 3.0), Step(0.5, 2.0, 0.0)],
    })


def test_plain_data_and_file_round_trip(tmp_path):
    sched = _every_shape()
    data = json.loads(json.dumps(sched.to_data(), allow_nan=False))
    again = InputSchedule.from_data(data)
    assert again == sched
    t = np.arange(0.0, 6.0, 1 / 80)
    np.testing.assert_array_equal(again.sample(t), sched.sample(t))
    path = tmp_path / "test.json"
    sched.save(path)
    assert InputSchedule.load(path) == sched
    with pytest.raises(FileExistsError):
        sched.save(path)
    three_two_one_one("hawk_rudder", 1.0).save(path, overwrite=True)
    assert InputSchedule.load(path).surfaces == ("hawk_rudder",)
    u = sched(0.6)
    assert isinstance(u["hawk_elevator"], float) and u["hawk_elevator"] == 2.0 + 0.5
    assert set(sched.controls()) == {"comp_aileron", "comp_rudder", "hawk_elevator"} and sched.controls()["hawk_elevator"](0.6) == 2.5


@pytest.mark.parametrize("change, message", [
    (lambda d: d["surfaces"]["hawk_elevator"][0].update(kind="sawtooth"), "unknown shape kind 'sawtooth'"),
    (lambda d: d["surfaces"].update(hawk_flap=[]), "unknown surface 'hawk_flap'"),
    (lambda d: d["surfaces"]["hawk_elevator"][0].update(amplitude_deg=float("nan")), r"amplitude_deg = nan: must be a finite number"),
    (lambda d: d["surfaces"]["comp_aileron"][0]["phases_rad"].__setitem__(1, float("inf")), r"phases_rad\[1\] = inf"),
    (lambda d: d["surfaces"]["hawk_elevator"][1].pop("amplitude_deg"), r"missing field\(s\) \['amplitude_deg'\]"),
    (lambda d: d["surfaces"]["hawk_elevator"][1].update(gain=2), r"unknown field\(s\) \['gain'\]"),
    (lambda d: d["surfaces"]["comp_rudder"][0].update(dt_s=0.0), "dt_s = 0.0: must be a positive"),
    (lambda d: d.update(format="pickle"), "format 'pickle'"),
])
def test_bad_data_is_refused_with_a_clear_error(change, message, tmp_path):
    data = _every_shape().to_data()
    change(data)
    with pytest.raises(ScheduleError, match=message):
        InputSchedule.from_data(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))  # NaN and Infinity tokens where the data has them
    with pytest.raises(ScheduleError, match=str(path) if "nan" not in message and "inf" not in message else "non-finite number"):
        InputSchedule.load(path)


@pytest.mark.parametrize("values, message", [
    ([[1.0, 2.0]], r"Sampled.values_deg\[0\] = \[1.0, 2.0\]: must be a number \(values_deg is a flat sequence, not nested\)"),
    (np.zeros((1, 2)), r"Sampled.values_deg: must be a flat sequence of numbers, got an array of shape \(1, 2\)"),
])
def test_nested_sequences_are_refused_not_flattened(values, message):
    with pytest.raises(ScheduleError, match=message):
        Sampled(values, 0.0125)
    data = {"format": "rig_env.InputSchedule", "version": 1, "surfaces": {"hawk_rudder": [{"kind": "sampled", "values_deg": [[1, 2]], "dt_s": 0.1}]}}
    with pytest.raises(ScheduleError, match=r"surfaces\['hawk_rudder'\]\[0\]: Sampled.values_deg\[0\] = \[1, 2\]: must be a number"):
        InputSchedule.from_data(data)


def test_load_refuses_a_missing_folder_or_binary_file_naming_it(tmp_path):
    with pytest.raises(ScheduleError, match=rf"^{tmp_path / 'none.json'}: input schedule file not found \(No such file or directory\)$"):
        InputSchedule.load(tmp_path / "none.json")
    with pytest.raises(ScheduleError, match=rf"^{tmp_path}: is a folder, not an input schedule file$"):
        InputSchedule.load(tmp_path)
    binary = tmp_path / "test.json"
    binary.write_bytes(b'{"format": "\xe9"}')
    with pytest.raises(ScheduleError, match=rf"^{binary}: not an input schedule \(not UTF-8 text: byte 12 is b'\\xe9'\)$"):
        InputSchedule.load(binary)


def test_environment_refuses_a_pilot_inputs_that_is_not_a_schedule():
    with pytest.raises(ValueError, match="pilot_inputs"):
        rig_env.envs.RigEnvConfig(pilot_inputs={"hawk_elevator": 1.0})


# ---------------------------------------------------------------------- one schedule: simulate() and the environment
def test_schedule_flies_the_same_in_simulate_and_in_the_environment(params):
    """Hawk elevator 3-2-1-1 (replacing the task's pilot input) and a compensator doublet (added to zero actions):
    the environment's surface commands equal simulate()'s every step, and so does the trajectory, bit for bit
    on the same kernel."""
    sched = InputSchedule({"hawk_elevator": ThreeTwoOneOne(2.0, start_s=0.5), "comp_elevator": Doublet(1.0, 1.0, 1.0)})
    env = RigVectorEnv(1, task="free_flight_emulation", airspeed=20.0, pilot_inputs=sched)
    env.physics.select_kernel("joint")  # simulate()'s kernel: equality to the last bit
    env.reset(seed=3)
    q0, qd0 = env.X[0, L.X_Q : L.X_Q + 5].copy(), env.X[0, L.X_QD : L.X_QD + 5].copy()
    n = 200  # 2.5 s: both inputs complete
    U_env, X_env = np.zeros((n, 6)), np.zeros((n, L.N_STATE))
    for i in range(n):
        _, _, term, trunc, _ = env.step(np.zeros((1, 3)))
        assert not (term[0] or trunc[0])
        U_env[i], X_env[i] = env.U[0, :6], env.X[0]
    controls = sched.controls()
    U_sim = np.zeros((1, L.N_INPUTS))
    for i in range(n):  # simulate()'s own input step at each control step's start
        fill_inputs(U_sim, i * env.dt, controls, 20.0, None)
        np.testing.assert_array_equal(U_env[i], U_sim[0, :6])
    assert np.ptp(U_env[:, L.U_HAWK_ELEVATOR]) == pytest.approx(np.radians(4.0)) and np.ptp(U_env[:, L.U_COMP_ELEVATOR]) == pytest.approx(np.radians(2.0))
    r = rig_env.simulate(params, q0, qd0, n * env.dt, free_dofs=env.free_dofs, controls=controls, airspeed=20.0)
    np.testing.assert_array_equal(r.q_all[1:], X_env[:, L.X_Q : L.X_Q + 5])
    np.testing.assert_array_equal(r.flaps[1:], np.degrees(X_env[:, L.X_SERVO : L.X_SERVO + 7]))
    assert np.degrees(np.ptp(r.q_all[:, 3])) > 1.0  # the inputs did move the model
