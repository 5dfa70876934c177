"""Flight records: readers and writers, pre-processing, the smoother, the loop's frame log, bad records.

Round trips write the project's layout and read it back (exact: CSV keeps 17 significant digits);
foreign files are written here by hand (numpy, csv, scipy.io) in other units and read through a column
map.  The smoother is checked against theory (a straight line is a local linear fit's fixed point; the
bisquare weights reject an outlier) and against statsmodels' independent LOWESS.  The frame-log test
flies the simulated rig with the real-time loop over loopback UDP (rig and loop in threads of this
process, as tests/test_deploy.py does with the rig in a subprocess) and reads the loop's log.
"""

from __future__ import annotations

import json
import math
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rig_env import SURFACES, simulate
from rig_env.framelog_format import RECORD, header_line
from rig_env.sysid import FlightRecord, RecordError, check_sampling, lowess

FREE = ("rig_roll", "model_pitch")


def _doublet(t: float) -> float:
    """Elevator doublet, deg, switching between control steps (0.503 s, 0.897 s): the record must hold what simulate held."""
    return 3.0 if 0.503 <= t < 0.897 else (-3.0 if 0.897 <= t < 1.3 else 0.5)


def _record(n: int = 161, rate: float = 80.0, airspeed_series: bool = True, qd: bool = True) -> FlightRecord:
    rng = np.random.default_rng(1)
    t = 0.25 + np.arange(n) / rate
    return FlightRecord(
        t=t, free_dofs=FREE, q=rng.normal(0, 0.2, (n, 2)), qd=rng.normal(0, 1.0, (n, 2)) if qd else None,
        surfaces={"hawk_elevator": rng.normal(0, 5, n), "comp_aileron": np.round(rng.normal(0, 10, n), 1)},
        airspeed=18.0 + rng.random(n) if airspeed_series else 17.5, locked={"rig_pitch": 0.05, "rig_yaw": -0.01, "model_yaw": 0.0},
        surface_kind="actual", setup={"mass.hawk_mass": 1.25}, name="doublet run 3",
    )


def _assert_same(a: FlightRecord, b: FlightRecord) -> None:
    assert (a.free_dofs, a.surface_kind, a.name, a.locked, a.setup) == (b.free_dofs, b.surface_kind, b.name, b.locked, b.setup)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.q, b.q)
    assert (a.qd is None) == (b.qd is None)
    if a.qd is not None:
        np.testing.assert_array_equal(a.qd, b.qd)
    assert sorted(a.surfaces) == sorted(b.surfaces)
    for s in a.surfaces:
        np.testing.assert_array_equal(a.surfaces[s], b.surfaces[s])
    assert np.ndim(a.airspeed) == np.ndim(b.airspeed)
    np.testing.assert_array_equal(a.airspeed, b.airspeed)


# ---------------------------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
@pytest.mark.parametrize("series", [True, False], ids=["airspeed_series", "airspeed_constant"])
def test_round_trip_every_format(tmp_path, suffix, series):
    rec = _record(airspeed_series=series, qd=series)
    path = rec.write(tmp_path / f"run{suffix}")
    back = FlightRecord.read(path)
    _assert_same(rec, back)
    renamed = FlightRecord.read(path, name="renamed")  # a keyword replaces the stored configuration
    assert renamed.name == "renamed" and renamed.setup == rec.setup


def test_own_layout_is_documented_columns(tmp_path):
    rec = _record()
    rec.write(tmp_path / "run.csv")
    first, header = (tmp_path / "run.csv").read_text().splitlines()[:2]
    assert first.startswith("# rig-flight-record {")
    assert header.split(",") == ["t_s", "q_rig_roll_rad", "q_model_pitch_rad", "qd_rig_roll_rad_s", "qd_model_pitch_rad_s",
                                 "surface_comp_aileron_deg", "surface_hawk_elevator_deg", "airspeed_m_s"]
    with np.load(rec.write(tmp_path / "run.npz")) as z:
        assert json.loads(str(z["rig_flight_record"]))["free_dofs"] == list(FREE)
        np.testing.assert_array_equal(z["q_model_pitch_rad"], rec.q[:, 1])


def test_write_never_overwrites_silently(tmp_path):
    rec = _record()
    path = rec.write(tmp_path / "run.npz")
    with pytest.raises(RecordError, match="exists; pass overwrite=True"):
        rec.write(path)
    other = rec.segment(0.5, 1.5)
    other.write(path, overwrite=True)
    assert FlightRecord.read(path).n_t == other.n_t
    with pytest.raises(RecordError, match=r"allowed suffixes: \.csv, \.npz, \.mat"):
        rec.write(tmp_path / "run.txt")


# ---------------------------------------------------------------------------------------------- foreign files
def test_foreign_csv_through_a_column_map_in_deg_and_ms(tmp_path):
    n = 200
    t_ms = 1000.0 + 12.5 * np.arange(n)
    theta, roll, de, v = 10 * np.sin(t_ms / 300), 5 * np.cos(t_ms / 700), np.where(t_ms > 2000, 2.0, -1.0), 20 + 0.01 * np.arange(n)
    lines = ["# exported by a data logger", "time,theta,phi,de_cmd,V,unused"]
    lines += [",".join(repr(float(x)) for x in row) + ",7" for row in zip(t_ms, theta, roll, de, v)]
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    cols = {"t": ("time", "ms"), "q.model_pitch": ("theta", "deg"), "q.rig_roll": ("phi", "deg"),
            "surfaces.hawk_elevator": ("de_cmd", "deg"), "airspeed": ("V", "m/s")}
    rec = FlightRecord.read(tmp_path / "log.csv", cols, surface_kind="commanded", locked={"rig_pitch": 0.1})
    assert rec.free_dofs == FREE and rec.name == "log" and rec.locked == {"rig_pitch": 0.1} and rec.qd is None
    np.testing.assert_allclose(rec.t, t_ms / 1000, rtol=1e-15)
    np.testing.assert_allclose(rec.q, np.radians(np.column_stack([roll, theta])), rtol=1e-15)
    np.testing.assert_array_equal(rec.surfaces["hawk_elevator"], de)
    np.testing.assert_array_equal(rec.airspeed, v)


def test_foreign_npz_and_mat_with_matrix_columns(tmp_path):
    from scipy.io import savemat

    n = 100
    t = np.arange(n) / 50.0
    Y = np.column_stack([np.sin(t), np.cos(t), 0.3 * t])  # deg, deg, deg/s
    cols = {"t": ("time", "s"), "q.rig_roll": ("Y[0]", "deg"), "q.model_pitch": ("Y[1]", "deg"),
            "qd.rig_roll": ("rates[0]", "deg/s"), "qd.model_pitch": ("rates[1]", "deg/s"), "surfaces.comp_aileron": ("da", "rad")}
    arrays = dict(time=t, Y=Y, rates=np.column_stack([Y[:, 2], -Y[:, 2]]), da=0.01 * t)
    np.savez(tmp_path / "run.npz", **arrays)
    savemat(tmp_path / "run.mat", {k: (v[:, None] if v.ndim == 1 else v) for k, v in arrays.items()})  # MATLAB column vectors
    for f in ("run.npz", "run.mat"):
        rec = FlightRecord.read(tmp_path / f, cols, airspeed=0.0, surface_kind="actual")
        np.testing.assert_allclose(rec.q, np.radians(Y[:, :2]), rtol=1e-15)
        np.testing.assert_allclose(rec.qd, np.radians(np.column_stack([Y[:, 2], -Y[:, 2]])), rtol=1e-15)
        np.testing.assert_allclose(rec.surfaces["comp_aileron"], np.degrees(0.01 * t), rtol=1e-15)
        assert rec.airspeed == 0.0


# ---------------------------------------------------------------------------------------------- from simulate()
@pytest.fixture(scope="module")
def sim():
    from rig_env import RigParams

    p = RigParams.default()
    q0 = np.array([0.1, 0.05, 0.0, 0.02, 0.0])  # all five joints: the locked rig_pitch held at 0.05 rad
    controls = {"hawk_elevator": _doublet, "comp_aileron": 2.0}
    res = simulate(p, q0, None, 2.0, free_dofs=FREE, controls=controls, airspeed=18.0)
    return p, q0, controls, res


def test_from_sim_surfaces_redrive_simulate_to_the_same_angles(sim):
    p, q0, controls, res = sim
    rec = FlightRecord.from_sim(res, surfaces=controls, airspeed=18.0, rates=True)
    assert rec.free_dofs == FREE and rec.locked == {"rig_pitch": 0.05, "rig_yaw": 0.0, "model_yaw": 0.0}
    np.testing.assert_array_equal(rec.surfaces["hawk_elevator"], [_doublet(float(t)) for t in res.t])  # sample k = command at t_k
    again = simulate(p, q0, None, rec.duration, free_dofs=rec.free_dofs, controls=rec.surface_schedules(), airspeed=rec.airspeed)
    np.testing.assert_array_equal(again.q, rec.q)  # the same inputs at every step: the same trajectory, bit for bit
    # negative control: the commands one sample late (a misaligned hold) give another trajectory
    late = {s: (lambda t, f=f: f(max(t - res.control_dt, 0.0))) for s, f in rec.surface_schedules().items()}
    shifted = simulate(p, q0, None, rec.duration, free_dofs=rec.free_dofs, controls=late, airspeed=rec.airspeed)
    assert np.abs(shifted.q - rec.q).max() > 1e-5


def test_from_sim_batched_result_needs_env(sim):
    p, q0, _, _ = sim
    res = simulate([p, p], np.stack([q0, 0.5 * q0]), None, 0.5, free_dofs=FREE, controls={"comp_aileron": np.array([1.0, -1.0])},
                   airspeed=lambda t: 15.0 + t)
    with pytest.raises(RecordError, match=r"give env= in \[0, 1\]"):
        FlightRecord.from_sim(res, surfaces={"comp_aileron": np.array([1.0, -1.0])})
    rec = FlightRecord.from_sim(res, surfaces={"comp_aileron": np.array([1.0, -1.0])}, airspeed=lambda t: 15.0 + t, env=1)
    np.testing.assert_array_equal(rec.q, res.q[1])
    assert np.all(rec.surfaces["comp_aileron"] == -1.0)
    np.testing.assert_allclose(rec.airspeed, 15.0 + res.t)
    assert rec.locked["rig_pitch"] == 0.025


# ---------------------------------------------------------------------------------------------- resample, segment, noise
def test_resample_interpolates_angles_and_holds_commands():
    n = 81
    t = np.arange(n) / 80.0 + 1e-4 * np.sin(np.arange(n))  # a jittery clock
    q = np.column_stack([2.0 * t - 1.0, -0.5 * t])  # straight lines: linear interpolation is exact
    step = np.where(np.arange(n) >= 40, 4.0, -4.0)  # command changes at sample 40
    rec = FlightRecord(t=t, free_dofs=FREE, q=q, surfaces={"hawk_elevator": step}, airspeed=20.0 + t, surface_kind="commanded")
    r = rec.resample(50.0)
    np.testing.assert_allclose(np.diff(r.t), 0.02, atol=1e-12)
    assert r.t[0] == t[0] and r.t[-1] <= t[-1]
    np.testing.assert_allclose(r.q, np.column_stack([2.0 * r.t - 1.0, -0.5 * r.t]), atol=1e-12)
    np.testing.assert_allclose(r.airspeed, 20.0 + r.t, atol=1e-12)
    np.testing.assert_array_equal(r.surfaces["hawk_elevator"], np.where(r.t >= t[40], 4.0, -4.0))  # held, never blended
    actual = FlightRecord(t=t, free_dofs=FREE, q=q, surfaces={"hawk_elevator": 3.0 * t}, surface_kind="actual").resample(50.0)
    np.testing.assert_allclose(actual.surfaces["hawk_elevator"], 3.0 * actual.t, atol=1e-12)
    assert rec.resample(160.0).n_t == 160  # up to 2x the record's rate; the grid stops inside the record (t[-1] = 0.9999 s)
    with pytest.raises(RecordError, match=r"resample: rate_hz = 200.0; allowed \(0, 16\d\.\d+\] Hz"):
        rec.resample(200.0)
    gappy = FlightRecord(t=np.delete(t, [20, 21]), free_dofs=FREE, q=np.delete(q, [20, 21], axis=0))
    with pytest.raises(RecordError, match=r"gap of 0.037\d* s after t = 0.237\d* s"):  # 3 periods, jittered
        gappy.resample(80.0)
    assert gappy.resample(80.0, allow_gaps=True).n_t == 80  # interpolated across the gap; the grid stops inside t[-1] = 0.9999 s


def test_segment_keeps_absolute_times_and_refuses_bad_windows():
    rec = _record()  # t = 0.25 .. 2.25 s at 80 Hz
    s = rec.segment(1.0, 1.5)
    assert s.t[0] == pytest.approx(1.0) and s.t[-1] == pytest.approx(1.5) and s.n_t == 41 and s.name == "doublet run 3[1:1.5]"
    np.testing.assert_array_equal(s.q, rec.q[60:101])
    np.testing.assert_array_equal(s.airspeed, rec.airspeed[60:101])
    assert rec.segment(1.0, 1.5, rebase=True).t[0] == 0.0
    for a, b, msg in [(2.0, 3.0, "reaches outside"), (0.0, 1.0, "reaches outside"), (1.5, 1.0, "need finite t_start < t_end"),
                      (1.001, 1.002, "holds 0 sample")]:
        with pytest.raises(RecordError, match=msg):
            rec.segment(a, b)


def test_with_noise_is_seeded_and_scaled():
    rec = FlightRecord(t=np.arange(20000) / 80.0, free_dofs=FREE, q=np.zeros((20000, 2)), qd=np.zeros((20000, 2)))
    a, b = rec.with_noise([0.01, 0.002], seed=3), rec.with_noise([0.01, 0.002], seed=3)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_allclose(a.q.std(axis=0), [0.01, 0.002], rtol=0.02)  # 20000 samples: 1 % standard error of a std
    assert np.all(a.qd == 0.0) and rec.with_noise(0.0, seed=1, std_rad_s=0.1).qd.std() == pytest.approx(0.1, rel=0.02)
    with pytest.raises(RecordError, match="one per free joint"):
        rec.with_noise([0.1, 0.1, 0.1], seed=0)


def test_record_smooth_reduces_noise_on_chosen_channels():
    t = np.arange(3200) / 80.0
    truth = np.column_stack([0.3 * np.sin(0.5 * t), 0.1 * np.sin(1.3 * t)])
    rec = FlightRecord(t=t, free_dofs=FREE, q=truth, surfaces={"comp_aileron": np.sign(np.sin(t))}).with_noise(0.01, seed=0)
    sm = rec.smooth()
    rms = np.sqrt(np.mean((sm.q - truth) ** 2))
    assert rms < 0.35 * 0.01  # local linear over 40 samples (tricube-weighted): about sqrt(1/25) of the noise, little bias at these frequencies
    np.testing.assert_array_equal(sm.surfaces["comp_aileron"], rec.surfaces["comp_aileron"])  # not asked for: untouched
    with pytest.raises(RecordError, match="unknown channel"):
        rec.smooth(channels=("q", "flaps"))


# ---------------------------------------------------------------------------------------------- the smoother
@pytest.mark.parametrize("robust", [False, True])
def test_lowess_reproduces_a_straight_line(robust):
    x = np.cumsum(np.random.default_rng(0).uniform(0.5, 1.5, 500))  # irregular abscissae
    y = 3.0 - 0.2 * x
    np.testing.assert_allclose(lowess(y, x, 40, robust=robust), y, rtol=0, atol=1e-12)


def test_lowess_robust_ignores_an_outlier_and_plain_does_not():
    t = np.arange(400) / 80.0
    clean = np.sin(2 * t) + 0.01 * np.random.default_rng(2).standard_normal(400)
    y = clean.copy()
    y[200] += 5.0
    plain = np.abs(lowess(y, t, 40, robust=False) - lowess(clean, t, 40, robust=False))
    robust = np.abs(lowess(y, t, 40, robust=True) - lowess(clean, t, 40, robust=True))
    print(f"outlier's effect: plain {plain.max():.4f}, robust {robust.max():.4f}")
    assert plain.max() > 0.1  # tricube weight near 1 at the centre: about 5 / (sum of weights ~ 20) leaks in
    assert robust.max() < 0.01  # bisquare weight 0 beyond 6 median |residual|: the outlier (and the neighbours it pulled) drop out


@pytest.mark.parametrize("robust", [False, True])
def test_lowess_matches_statsmodels(robust):
    sm = pytest.importorskip("statsmodels.nonparametric.smoothers_lowess")
    rng = np.random.default_rng(5)
    n = 700
    x = np.cumsum(rng.uniform(0.2, 1.8, n))
    Y = np.column_stack([np.sin(x / 20) + 0.1 * rng.standard_normal(n), rng.standard_t(2, n)])  # heavy tails in the second channel
    ours = lowess(Y, x, 40, robust=robust, iterations=3)
    for k in range(2):
        ref = sm.lowess(Y[:, k], x, frac=40 / n, it=3 if robust else 0, delta=0.0, return_sorted=False)
        np.testing.assert_allclose(ours[:, k], ref, rtol=0, atol=1e-10)


def test_lowess_smooths_a_40s_80hz_record_quickly():
    Y = np.random.default_rng(0).standard_normal((3200, 6))
    best = min(_timed(lambda: lowess(Y, np.arange(3200) / 80.0, 40)) for _ in range(3))
    print(f"lowess, 3200 samples x 6 channels, span 40, 3 robustness passes: {best * 1e3:.1f} ms")
    assert best < 0.5


def _timed(f) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


# ---------------------------------------------------------------------------------------------- frame logs
def _synthetic_log(path: Path, header: dict, ticks: list[tuple[int, int, float]]) -> np.ndarray:
    """A log of (fresh, seq, rig_time) ticks, angles = (seq, 0.1, 0.2, 0.3 seq, 0.4) mrad, command = seq mrad."""
    recs = np.zeros(len(ticks), dtype=RECORD)
    for r, (fresh, seq, t) in zip(recs, ticks):
        r["fresh"], r["seq"], r["rig_time"], r["airspeed"] = fresh, seq, t, 18.0
        r["angles"] = 1e-3 * np.array([seq, 0.1, 0.2, 0.3 * seq, 0.4])
        r["command"] = 1e-3 * seq
    path.write_bytes(header_line(header) + recs.tobytes() + b"\x00" * 7)  # and a torn last record
    return recs


@pytest.mark.filterwarnings("ignore:.*the last record is torn:rig_env.framelog_format.TornLogWarning")  # the synthetic logs end torn on purpose
def test_frame_log_fresh_frames_once_and_free_dofs_from_header_or_keyword(tmp_path):
    ticks = [(0, -1, 0.0), (1, 0, 0.0), (0, 0, 0.0), (1, 1, 0.0125), (1, 1, 0.0125), (1, 2, 0.025), (1, 3, 0.0375)]
    _synthetic_log(tmp_path / "old.log", {"task": "t", "rate_hz": 80.0}, ticks)
    with pytest.raises(RecordError, match="does not name the free joints.*give free_dofs="):
        FlightRecord.read(tmp_path / "old.log")
    rec = FlightRecord.read(tmp_path / "old.log", free_dofs=["model_pitch", "rig_roll"])
    np.testing.assert_array_equal(rec.t, [0.0, 0.0125, 0.025, 0.0375])
    np.testing.assert_allclose(rec.q, 1e-3 * np.column_stack([np.arange(4), 0.3 * np.arange(4)]))
    np.testing.assert_allclose(rec.surfaces["hawk_rudder"], np.degrees(1e-3 * np.arange(4)))
    assert rec.surface_kind == "commanded" and rec.locked == pytest.approx({"rig_pitch": 1e-4, "rig_yaw": 2e-4, "model_yaw": 4e-4})
    _synthetic_log(tmp_path / "new.log", {"task": "t", "rate_hz": 80.0, "free_dofs": ["rig_roll"]}, ticks)
    assert FlightRecord.read(tmp_path / "new.log").free_dofs == ("rig_roll",)
    with pytest.raises(RecordError, match=r"but the log's header says \['rig_roll'\]"):
        FlightRecord.read(tmp_path / "new.log", free_dofs=FREE)
    lost = [(1, k, k / 80.0) for k in range(10) if k != 6]
    _synthetic_log(tmp_path / "lost.log", {"free_dofs": ["rig_roll"]}, lost)
    with pytest.raises(RecordError, match=r"lost.log: rig_time of the fresh frames: t: gap of 0.025 s after t = 0.0625 s"):
        FlightRecord.read(tmp_path / "lost.log")
    assert FlightRecord.read(tmp_path / "lost.log", allow_gaps=True).resample(80.0, allow_gaps=True).n_t == 10


def fly_sim_rig(tmp_path: Path, duration: float, task: str = "velocity_vector_roll", rate: float = 80.0):
    """The loop flying the simulated rig over loopback UDP (both in this process, as threads) with the linear
    roll-tracking law: (log path, the sim rig, the law's spec)."""
    from controllers import LoopSpec
    from controllers.deploy.loop import LoopConfig, RigLoop
    from controllers.deploy.simrig import SimRig
    from controllers.design.linear import roll_tracking
    from controllers.laws import artefact as A
    from rig_env.envs import RigVectorEnv

    env = RigVectorEnv(1, task=task)
    spec = LoopSpec.from_env(env)
    art_path = tmp_path / "law.json"
    A.save(A.from_controller(roll_tracking(spec), A.sensors_of(env.config), A.default_limits(spec), source="test"), art_path)
    rig = SimRig(0, task, rate, duration)
    rig_out: dict = {}
    rig_thread = threading.Thread(target=lambda: rig_out.update(rig.run()), daemon=True)
    rig_thread.start()
    log = tmp_path / "loop.log"
    loop = RigLoop(A.load(art_path), LoopConfig(rig=("127.0.0.1", rig.port), rate_hz=rate, bind=("127.0.0.1", 0), duration=duration,
                                                arm=True, log_path=str(log)))
    summary = loop.run()
    rig_thread.join(timeout=30)
    assert not rig_thread.is_alive() and "error" not in rig_out, rig_out
    print(f"loop: {summary['counts']}; rig: {rig_out['counts']}")
    return log, rig, spec


def test_frame_log_of_the_loop_flying_the_simulated_rig(tmp_path):
    from controllers.deploy.framelog import read_log

    rate, duration = 80.0, 3.0
    log, rig, spec = fly_sim_rig(tmp_path, duration, rate=rate)
    rec = FlightRecord.read(log, allow_gaps=True)  # a frame lost on this shared machine is a gap, not a failure
    header, ticks = read_log(log)
    assert rec.free_dofs == spec.free_dofs == tuple(header["free_dofs"]) and rec.surface_kind == "commanded"
    seen: set[int] = set()
    frames = []
    for r in ticks:  # fresh frames, each seq once, in the order the loop used them
        if r["fresh"] and r["seq"] >= 0 and int(r["seq"]) not in seen:
            seen.add(int(r["seq"]))
            frames.append(r)
    assert rec.n_t == len(frames) >= 0.9 * duration * rate
    free = [list(r["angles"]) for r in frames]
    idx = [("rig_roll", "rig_pitch", "rig_yaw", "model_pitch", "model_yaw").index(j) for j in rec.free_dofs]
    np.testing.assert_array_equal(rec.t, [r["rig_time"] for r in frames])
    np.testing.assert_array_equal(rec.q, np.array(free)[:, idx])
    np.testing.assert_array_equal(rec.surface_array(SURFACES), np.degrees([r["command"] for r in frames]))
    assert np.ptp(rec.surfaces["comp_aileron"]) > 1.0  # the law flew: the commands moved
    # the command logged with frame k is the one the rig applied over its step k -> k+1 (the record's zero-order hold)
    seq = np.array([int(r["seq"]) for r in frames])
    applied = np.degrees(rig.rec["cmd"][np.minimum(seq, len(rig.rec["cmd"]) - 1)])
    sent = rec.surface_array(SURFACES)
    match = np.all(np.abs(applied - sent) < 1e-4, axis=1)[:-1]  # float32 on the wire; the last command may arrive after the rig stopped
    late = np.all(np.abs(np.degrees(rig.rec["cmd"][np.maximum(seq - 1, 0)]) - sent) < 1e-4, axis=1)[1:-1]
    print(f"commands applied by the rig on the record's step: {match.mean():.3f}; on the step before: {late.mean():.3f}")
    assert match.mean() > 0.9 and late.mean() < 0.5


# ---------------------------------------------------------------------------------------------- bad records
def _csv(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


MAP = {"t": ("time", "s"), "q.rig_roll": ("phi", "deg")}


@pytest.mark.parametrize("body, columns, kwargs, message", [
    ("time,phi\n0,1\n0.1,nan\n0.2,3\n", MAP, {"airspeed": 20}, r"column 'phi' \(q.rig_roll\): 1 non-finite or empty value\(s\), the first at row 1 \(t = 0.1 s\)"),
    ("time,phi\n0,1\n0.1,\n0.2,3\n", MAP, {"airspeed": 20}, r"column 'phi' \(q.rig_roll\): 1 non-finite or empty"),
    ("time,phi\n0,1\n0.1,abc\n", MAP, {"airspeed": 20}, r"column 'phi', line 3: 'abc' is not a number"),
    ("time,phi\n0,1\n0.1,2,3\n", MAP, {"airspeed": 20}, r"line 3 has 3 fields; the header row has 2 columns"),
    ("time,phi\n0,1\n0.2,2\n0.1,3\n", MAP, {"airspeed": 20}, r"time column 'time' must be strictly increasing; row 2 \(0.1 s\) follows row 1 \(0.2 s\)"),
    ("time,phi\n" + "".join(f"{k / 10 + (0.3 if k > 5 else 0)},0\n" for k in range(10)), MAP, {"airspeed": 20}, r"bad.csv: time column 'time': t: gap of 0.4 s after t = 0.5 s"),
    ("time,phi\n0,1\n0.1,2\n", {"t": ("time", "s"), "q.rig_roll": ("roll", "deg")}, {"airspeed": 20},
     r"column 'roll' \(for q.rig_roll\) is not in the file; columns present: \['phi', 'time'\]"),
    ("time,phi\n0,1\n0.1,2\n", {"t": ("time", "s"), "q.wing": ("phi", "deg")}, {"airspeed": 20}, r"unknown field 'q.wing'.*rig_roll"),
    ("time,phi\n0,1\n0.1,2\n", {"t": ("time", "s"), "q.rig_roll": ("phi", "degrees")}, {"airspeed": 20},
     r"unit 'degrees' is not allowed for angles; allowed: rad, deg"),
    ("time,phi\n0,1\n0.1,2\n", {"t": ("time", "min"), "q.rig_roll": ("phi", "deg")}, {"airspeed": 20}, r"unit 'min' is not allowed for time; allowed: s, ms"),
    ("time,phi,V\n0,1,3\n0.1,2,3\n", dict(MAP, airspeed=("V", "km/h")), {}, r"unit 'km/h' is not allowed for airspeed; allowed: m/s"),
    ("time,phi\n0,1\n0.1,2\n", MAP, {}, r"no airspeed column mapped; give the tunnel speed as airspeed="),
    ("time,phi,de\n0,1,0\n0.1,2,0\n", dict(MAP, **{"surfaces.hawk_elevator": ("de", "deg")}), {"airspeed": 20}, r"surface_kind='commanded'"),
    ("time,phi\n0,1\n0.1,2\n", None, {}, r"no rig-flight-record metadata.*columns present: \['phi', 'time'\]"),
    ("time,phi\n0,1\n0.1,2\n", MAP, {"airspeed": 80}, r"airspeed = 80.0 m/s is outside the allowed range \[0.0, 60.0\]"),
    ("time,phi\n0,1\n0.1,2\n", MAP, {"airspeed": 20, "free_dofs": ["model_pitch"]}, r"free_dofs = \['model_pitch'\] but the angle columns are for \['rig_roll'\]"),
])
def test_bad_csv_records_name_the_problem(tmp_path, body, columns, kwargs, message):
    with pytest.raises(RecordError, match=message):
        FlightRecord.read(_csv(tmp_path / "bad.csv", body), columns, **kwargs)


def test_bad_files_name_the_problem(tmp_path):
    with pytest.raises(RecordError, match="no such file"):
        FlightRecord.read(tmp_path / "missing.csv")
    with pytest.raises(RecordError, match="not a file"):
        FlightRecord.read(tmp_path)
    (tmp_path / "junk.npz").write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(RecordError, match="cannot read as .npz"):
        FlightRecord.read(tmp_path / "junk.npz", MAP, airspeed=20)
    (tmp_path / "junk.mat").write_bytes(b"MATLAB 5.0 MAT-file" + b"\x00" * 20)
    with pytest.raises(RecordError, match="cannot read as MATLAB v5 .mat"):
        FlightRecord.read(tmp_path / "junk.mat", MAP, airspeed=20)
    (tmp_path / "v73.mat").write_bytes(b"MATLAB 7.3 MAT-file, HDF5" + b"\x00" * 100)
    with pytest.raises(RecordError, match=r"v7.3 \(HDF5\).*-v7"):
        FlightRecord.read(tmp_path / "v73.mat")
    (tmp_path / "bin.csv").write_bytes(bytes(range(256)))
    with pytest.raises(RecordError, match="cannot read as UTF-8 CSV"):
        FlightRecord.read(tmp_path / "bin.csv", MAP, airspeed=20)
    (tmp_path / "text.npz").write_text("time,phi\n")
    with pytest.raises(RecordError, match="cannot read as .npz"):
        FlightRecord.read(tmp_path / "text.npz", MAP, airspeed=20)
    (tmp_path / "data.xyz").write_text("1,2\n")
    with pytest.raises(RecordError, match=r"unknown format; readable: CSV \(.csv\), NumPy .npz, MATLAB v5 .mat"):
        FlightRecord.read(tmp_path / "data.xyz")
    np.savez(tmp_path / "short.npz", time=np.arange(5) / 10, phi=np.zeros(4))
    with pytest.raises(RecordError, match=r"column 'phi' \(q.rig_roll\) has 4 samples; the time column 'time' has 5"):
        FlightRecord.read(tmp_path / "short.npz", MAP, airspeed=20)
    np.savez(tmp_path / "mat.npz", time=np.arange(5) / 10, phi=np.zeros((5, 2)))
    with pytest.raises(RecordError, match=r"column 'phi' \(for q.rig_roll\) has shape \(5, 2\); expected a vector"):
        FlightRecord.read(tmp_path / "mat.npz", MAP, airspeed=20)
    (tmp_path / "empty.log").write_bytes(b'{"format": "rig-loop-log", "dtype": []}\n')
    with pytest.raises(RecordError, match="cannot read as a frame log: .*the header's dtype has no fields"):
        FlightRecord.read(tmp_path / "empty.log", free_dofs=["rig_roll"])
    (tmp_path / "other.log").write_bytes(b'{"format": "rig-loop-log", "dtype": [["tick", "<u4"]]}\n' + bytes(8))
    with pytest.raises(RecordError, match=r"frame log without field\(s\) \['fresh', 'seq', 'rig_time', 'angles', 'airspeed', 'command'\]"):
        FlightRecord.read(tmp_path / "other.log", free_dofs=["rig_roll"])


def test_check_sampling_rule():
    t = np.arange(10) * 0.1
    check_sampling(t)
    check_sampling(np.r_[t, 0.9 + 0.14])  # 1.4 x the median: jitter, not a gap
    with pytest.raises(RecordError, match=r"rec: t: gap of 0.16 s after t = 0.9 s"):
        check_sampling(np.r_[t, 0.9 + 0.16], "rec")
    check_sampling(np.r_[t, 5.0], allow_gaps=True)
    rec = FlightRecord(t=np.r_[t, 5.0], free_dofs="rig_roll", q=np.zeros(11))  # built by hand: irregular times are legitimate
    assert rec.n_t == 11 and math.isclose(rec.duration, 5.0)


# ---------------------------------------------------------------------------------------------- fields of the wrong type
N_SHORT = 20
SHORT = dict(t=np.arange(N_SHORT) / 80.0, free_dofs=("model_pitch",), q=np.zeros((N_SHORT, 1)), airspeed=20.0, name="short")


@pytest.mark.parametrize("change, message", [
    ({"locked": {"rig_pitch": "abc"}}, r"short: locked\['rig_pitch'\] = 'abc': a locked angle must be a finite number within \+-2 pi rad"),
    ({"locked": {"rig_pitch": True}}, r"short: locked\['rig_pitch'\] = True: a locked angle must be a finite number"),
    ({"locked": {"rig_pitch": 1e6}}, r"short: locked\['rig_pitch'\] = 1000000.0: a locked angle must be a finite number within \+-2 pi rad "
                                     r"\(\+-360 deg\); the angles are in rad"),
    ({"locked": [0.1]}, r"short: locked: must be a mapping \{name: value\}, got list"),
    ({"setup": {"mass.hawk_mass": "x"}}, r"short: setup\['mass.hawk_mass'\] = 'x': must be a finite number"),
    ({"setup": {"fixture.model_pitch.inertia": -5}}, r"short: setup: fixture.model_pitch.inertia = -5.0 kg m\^2 is outside the allowed range "
                                                     r"\[0.0, 10.0\] kg m\^2"),
    ({"setup": {"mass.hawk_mas": 1.0}}, r"short: setup: unknown parameter 'mass.hawk_mas' \(did you mean 'mass.hawk_mass'"),
    ({"airspeed": "fast"}, r"short: airspeed = 'fast': give the tunnel speed, m/s, as a number in \[0.0, 60.0\] or a series of n_t = 20"),
    ({"airspeed": None}, r"short: airspeed = None: give the tunnel speed"),
    ({"airspeed": True}, r"short: airspeed = True: give the tunnel speed"),
    ({"free_dofs": None}, r"short: free_dofs = None: give one or more distinct joints of \['rig_roll'"),
    ({"free_dofs": [5]}, r"short: free_dofs = \[5\]: give one or more distinct joints"),
    ({"q": np.zeros(10)}, r"short: q has 10 samples; t has 20 \(a 1-D q is one free joint's series\)"),
    ({"q": np.ones((N_SHORT, 1), dtype=bool)}, r"short: q: must be real numbers, got ndarray of bool"),
    ({"q": np.ones((N_SHORT, 1)) * 1j}, r"short: q: must be real numbers, got ndarray of complex128"),
    ({"surfaces": 5}, r"short: surfaces: must be a mapping"),
    ({"name": None}, r"name = None: must be a string"),
])
def test_fields_of_the_wrong_type_or_range_are_refused_by_field(change, message):
    """Each was a bare float()/reshape/iteration error naming no field, or (a locked angle of 1e6 rad, a negative
    fixture inertia) accepted; now a RecordError naming the record and the field.  The setup's ranges are the
    parameter file's own (RigParams.replace)."""
    with pytest.raises(RecordError, match=message):
        FlightRecord(**{**SHORT, **change})


def test_numpy_numbers_are_numbers_in_every_field():
    rec = FlightRecord(**{**SHORT, "airspeed": np.float32(12.5), "locked": {"rig_pitch": np.float64(0.25), "rig_roll": np.int64(0)},
                          "setup": {"mass.hawk_mass": np.float32(1.25)}, "q": np.zeros(N_SHORT)})
    assert rec.airspeed == 12.5 and rec.locked == {"rig_pitch": 0.25, "rig_roll": 0.0} and rec.setup == {"mass.hawk_mass": 1.25}
    assert rec.q.shape == (N_SHORT, 1)
    assert rec.resample(np.float64(40.0)).n_t == 10 and rec.segment(np.float32(0.0), np.float64(0.1)).n_t == 9


def test_pre_processing_refuses_arguments_that_are_not_numbers():
    rec = FlightRecord(**SHORT)
    with pytest.raises(RecordError, match=r"short: resample: rate_hz = abc; allowed \(0, 160\] Hz"):
        rec.resample("abc")
    with pytest.raises(RecordError, match=r"short: resample: rate_hz = True"):
        rec.resample(True)
    with pytest.raises(RecordError, match=r"short: segment: window \[None, 1\] s; need finite t_start < t_end"):
        rec.segment(None, 1)
    with pytest.raises(RecordError, match=r"short: with_noise: std_rad = 'a'"):
        rec.with_noise("a", seed=0)


def test_a_csv_with_a_utf8_byte_order_mark_is_read(tmp_path):
    """Excel's "CSV UTF-8" starts the file with a byte-order mark, which was read as part of the first column's name."""
    (tmp_path / "excel.csv").write_bytes("time,theta\n0,1\n0.1,2\n0.2,3\n".encode("utf-8-sig"))
    rec = FlightRecord.read(tmp_path / "excel.csv", {"t": ("time", "s"), "q.model_pitch": ("theta", "deg")}, airspeed=0.0)
    np.testing.assert_allclose(rec.t, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(rec.q[:, 0], np.radians([1.0, 2.0, 3.0]))


@pytest.mark.parametrize("key, value, message", [
    ("columns", [["t_s", "s"]], r"metadata: columns = \[\[\"t_s\", \"s\"\]\]: must be an object \{field: \[column, unit\]\}"),
    ("columns", {"t": ["t_s", "s"], "q.model_pitch": ["q_model_pitch_rad", 5]}, r"metadata: columns\['q.model_pitch'\] = \('q_model_pitch_rad', 5\)"),
    ("locked", [0.1], r"metadata: locked = \[0.1\]: must be an object \{joint: rad\} or null"),
    ("airspeed", "fast", r"metadata: airspeed = \"fast\": must be a number \(m/s\) or null"),
    ("name", 5, r"metadata: name = 5: must be a string"),
    ("setup", {"mass.hawk_mass": "x"}, r"setup\['mass.hawk_mass'\] = 'x': must be a finite number"),
])
def test_hand_edited_metadata_is_refused_by_key(tmp_path, key, value, message):
    """The metadata line of the project's CSV, edited by hand: a list for the column map was an AttributeError."""
    FlightRecord(**SHORT).write(tmp_path / "own.csv")
    first, *rest = (tmp_path / "own.csv").read_text().splitlines()
    meta = json.loads(first[len("# rig-flight-record "):])
    meta[key] = value
    (tmp_path / "edited.csv").write_text("\n".join([f"# rig-flight-record {json.dumps(meta)}", *rest]) + "\n")
    with pytest.raises(RecordError, match=message):
        FlightRecord.read(tmp_path / "edited.csv")


def test_complex_columns_are_refused(tmp_path):
    """A complex .npz column was cast to its real part with only numpy's ComplexWarning."""
    np.savez(tmp_path / "c.npz", time=np.arange(5) / 10, phi=np.zeros(5) + 0.5j)
    with pytest.raises(RecordError, match=r"column 'phi' \(for q.rig_roll\) holds complex \(complex128\) values; a record's columns are real"):
        FlightRecord.read(tmp_path / "c.npz", MAP, airspeed=20)


@pytest.mark.filterwarnings("ignore:.*the last record is torn:rig_env.framelog_format.TornLogWarning")
def test_frame_log_header_and_keyword_free_dofs_of_the_wrong_type(tmp_path):
    ticks = [(1, k, k / 80.0) for k in range(5)]
    _synthetic_log(tmp_path / "five.log", {"task": "t", "rate_hz": 80.0, "free_dofs": 5}, ticks)
    with pytest.raises(RecordError, match=r"five.log: the log's header has free_dofs = 5; expected a list of joint names"):
        FlightRecord.read(tmp_path / "five.log")
    _synthetic_log(tmp_path / "ok.log", {"task": "t", "rate_hz": 80.0}, ticks)
    with pytest.raises(RecordError, match=r"ok.log: free_dofs = 5: give a list of joint names"):
        FlightRecord.read(tmp_path / "ok.log", free_dofs=5)
