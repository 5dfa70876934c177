"""Hardening of the deployment path (issue 24): log failures, exit codes, the log policy and reader, one
validator for hostile artefacts, bounded arguments, and the ``rig-deploy log`` tool.

The flights here run the real :class:`controllers.deploy.loop.RigLoop` (in :func:`rig_env.physics.jit.python_mode`,
as ``rig-deploy run`` does: nothing compiles) against a small fake rig on loopback that sends 80 Hz frames
and records every command it receives; each flight lasts about a second.
"""

from __future__ import annotations

import dataclasses
import errno
import hashlib
import json
import math
import os
import socket
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from controllers.deploy import cli
from controllers.deploy import framelog as fl
from controllers.deploy import loop as lp
from controllers.deploy import protocol as pr
from fake_rig import FakeRig
from controllers.deploy.validate import load_deployable
from controllers.laws import artefact as A
from rig_env.framelog_format import TornLogWarning, read_log
from rig_env.physics import jit

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
TASK = "velocity_vector_roll"


# ---------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def law_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("law") / "law.json"
    r = subprocess.run([sys.executable, "-m", "controllers.deploy.cli", "export", "--controller", "linear", "--task", TASK, "--out", str(out)],
                       env=ENV, capture_output=True, text=True, timeout=300, cwd=str(ROOT), check=False)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="module")
def trim_law(law_file, tmp_path_factory) -> Path:
    """The linear law with K = 0 and a constant output u0 = (0.5, -0.5, 0.25): commands 20, -20, 10 deg once slewed."""
    art = A.load(law_file)
    data = dict(art.data, K=np.zeros_like(art.data["K"]), u0=np.array([0.5, -0.5, 0.25]), rate_limit=np.full(3, 1e3))
    out = tmp_path_factory.mktemp("trim") / "trim.json"
    A.save(dataclasses.replace(art, data=data, sha256=""), out)
    return out


def _fly(law: Path, log: Path | None, duration: float = 1.0, port: int | None = None, **kw) -> tuple[dict, list]:
    """Fly ``law`` with RigLoop against a FakeRig (or a silent ``port``); (summary, commands the rig received)."""
    rig = FakeRig() if port is None else None
    try:
        cfg = lp.LoopConfig(rig=("127.0.0.1", rig.port if rig else port), rate_hz=80.0, bind=("127.0.0.1", 0), duration=duration, arm=True,
                            log_path=None if log is None else str(log), **kw)
        with jit.python_mode():
            summary = lp.RigLoop(A.load(law), cfg).run()
        time.sleep(0.05)  # the last datagrams reach the rig
    finally:
        if rig is not None:
            rig.close()
    return summary, (rig.commands if rig else [])


class FullDisk:
    """A file object whose writes fail with ENOSPC after ``ok`` successful writes (the header)."""

    def __init__(self, f, ok: int = 1) -> None:
        self.f, self.ok = f, ok

    def write(self, b: bytes) -> int:
        if self.ok <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.ok -= 1
        return self.f.write(b)

    def __getattr__(self, name: str):
        return getattr(self.f, name)


@pytest.fixture
def full_disk(monkeypatch):
    """FrameLog's file fails on the first record write (the header goes through), as a disk filling mid-flight."""
    real_open = open

    class FullLog(fl.FrameLog):
        def __init__(self, *a, **k) -> None:
            import builtins

            monkeypatch.setattr(builtins, "open", lambda p, m="r", *aa, **kk: FullDisk(real_open(p, m, *aa, **kk)) if m == "xb" else real_open(p, m, *aa, **kk))
            try:
                super().__init__(*a, **k)
            finally:
                monkeypatch.setattr(builtins, "open", real_open)

    monkeypatch.setattr(lp, "FrameLog", FullLog)


# ---------------------------------------------------------------------- 1. a log failure is a fault
def test_log_writer_failure_is_recorded_and_close_never_raises(tmp_path, full_disk):
    log = lp.FrameLog(tmp_path / "x.log", 80.0, {"run": 1})
    log.next()["tick"] = 1
    log.flush()
    log.close()
    assert log.error is not None and str(tmp_path / "x.log") in log.error and "No space left" in log.error


def test_log_failure_mid_flight_faults_to_neutral_stops_and_exits_5(tmp_path, trim_law, full_disk):
    log = tmp_path / "run.log"
    summary, cmds = _fly(trim_law, log, duration=3.0)
    assert summary["final_state"] == "FAULT" and summary["faults"] == ["log_write"]
    assert str(log) in summary["log"]["error"] and "No space left" in summary["log"]["error"]
    assert summary["ticks"] < 0.5 * 3.0 * 80  # stopped at the first flush (0.5 s), not flown on unlogged
    (ev,) = [e for e in summary["events"] if e["event"] == "fault"]
    assert ev["fault"] == "log_write"
    assert cli.run_exit_code(summary) == cli.EXIT_LOG
    assert cmds[-1] == (pr.MODE_DISARMED, (0.0,) * 6) and summary["end"]["state"] == "DISARMED"


def test_allow_unlogged_keeps_flying_but_still_reports_the_log(tmp_path, trim_law, full_disk):
    summary, _ = _fly(trim_law, tmp_path / "run.log", duration=1.5, allow_unlogged=True)
    assert summary["final_state"] == "ACTIVE" and summary["faults"] == [] and summary["ticks"] >= 1.4 * 80
    assert [e["event"] for e in summary["events"]].count("log_lost") == 1
    assert cli.run_exit_code(summary) == cli.EXIT_LOG  # flown as asked, the log is still incomplete


def test_cli_log_failure_prints_and_writes_the_summary_and_names_the_path(tmp_path, trim_law, full_disk, capsys):
    rig = FakeRig()
    log = tmp_path / "cli.log"
    try:
        rc = cli.main(["run", "--law", str(trim_law), "--rig", f"udp://127.0.0.1:{rig.port}", "--arm", "--duration", "2", "--log", str(log),
                       "--bind", "127.0.0.1"])
    finally:
        rig.close()
    out, err = capsys.readouterr()
    assert rc == cli.EXIT_LOG and "Traceback" not in err
    assert f"{log}: log write failed" in err
    printed = json.loads(out[out.index("{"):])
    written = json.loads(Path(str(log) + ".summary.json").read_text())
    assert printed == written and written["faults"] == ["log_write"] and written["exit"]["code"] == cli.EXIT_LOG


# ---------------------------------------------------------------------- 2. exit codes, disarm at the end
def test_no_frames_at_all_exits_4(tmp_path, law_file):
    silent = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    silent.bind(("127.0.0.1", 0))  # a port that takes the hellos and never answers
    try:
        summary, _ = _fly(law_file, None, duration=0.5, port=silent.getsockname()[1], connect_timeout=0.3)
    finally:
        silent.close()
    assert summary["counts"]["fresh"] == 0 and summary["final_state"] == "DISARMED"
    assert cli.run_exit_code(summary) == cli.EXIT_NO_FRAMES


def test_exit_code_precedence_from_the_summary():
    base = {"counts": {"fresh": 10, "tx_error": 0}, "final_state": "ACTIVE", "log": {"error": None}}
    assert cli.run_exit_code(base) == cli.EXIT_OK
    assert cli.run_exit_code(dict(base, final_state="FAULT")) == cli.EXIT_FAULT
    assert cli.run_exit_code(dict(base, final_state="FAULT", counts={"fresh": 10, "tx_error": 8})) == cli.EXIT_CMD_LOST
    assert cli.run_exit_code(dict(base, final_state="FAULT", faults=["command_ack"])) == cli.EXIT_CMD_LOST
    assert cli.run_exit_code(dict(base, final_state="FAULT", faults=["stale"])) == cli.EXIT_FAULT
    assert cli.run_exit_code(dict(base, counts={"fresh": 0, "tx_error": 8})) == cli.EXIT_NO_FRAMES
    assert cli.run_exit_code(dict(base, counts={"fresh": 0, "tx_error": 0}, log={"error": "x: full"})) == cli.EXIT_LOG
    assert len(set(cli.EXIT_CODES)) == 6
    helptext = cli.parser()._subparsers._group_actions[0].choices["run"].format_help()
    assert all(f"{c}  {m}" in helptext for c, m in cli.EXIT_CODES.items())


def test_completed_run_winds_down_to_neutral_at_the_rate_limit_and_disarms(tmp_path, trim_law):
    summary, cmds = _fly(trim_law, tmp_path / "w.log", duration=1.0)
    assert summary["final_state"] == "ACTIVE" and summary["end"]["state"] == "DISARMED"
    modes = [m for m, _ in cmds]
    last_active = max(i for i, m in enumerate(modes) if m == pr.MODE_ACTIVE)
    tail = np.array([s for _, s in cmds[last_active:]])
    np.testing.assert_allclose(tail[0, :3], np.radians([20.0, -20.0, 10.0]), atol=1e-6)  # the law's steady command (float32 on the wire)
    step = np.radians(350.0) / 80.0  # the artefact's default rate limit per tick
    assert np.all(np.abs(np.diff(tail, axis=0)) <= step + 1e-6)  # never faster than the servos' slew
    assert summary["end"]["wind_down_ticks"] == math.ceil(20.0 / (350.0 / 80.0))  # 5 ticks to neutral from 20 deg
    assert modes[last_active + 1 : last_active + 1 + 5] == [pr.MODE_SAFE] * 5 and modes[-3:] == [pr.MODE_DISARMED] * 3
    assert np.all(tail[-4:] == 0.0)


# ---------------------------------------------------------------------- 5. log policy and reader
def test_existing_log_paths_are_refused_before_flying(tmp_path, law_file, capsys):
    before = law_file.read_bytes()
    for existing in (str(law_file), "/dev/full"):
        t0 = time.monotonic()
        rc = cli.main(["run", "--law", str(law_file), "--rig", "udp://127.0.0.1:9", "--arm", "--duration", "5", "--log", existing])
        err = capsys.readouterr().err
        assert rc == cli.EXIT_REFUSED and existing in err and "already exists" in err and time.monotonic() - t0 < 5.0, err
    assert law_file.read_bytes() == before
    with pytest.raises(fl.LogPathError, match="already exists"):
        fl.FrameLog(law_file, 80.0, {})
    assert law_file.read_bytes() == before


def _small_log(path: Path, n: int = 7) -> bytes:
    log = fl.FrameLog(path, 80.0, {"rate_hz": 80.0, "free_dofs": ["rig_roll"]})
    for k in range(n):
        r = log.next()
        r["tick"], r["seq"], r["fresh"], r["rig_time"] = k, k, 1, k / 80.0
    log.close()
    return path.read_bytes()


def test_reader_detects_second_header_cut_header_and_torn_record(tmp_path):
    raw = _small_log(tmp_path / "a.log")
    header, recs = read_log(tmp_path / "a.log")
    assert recs.size == 7 and header["torn_bytes"] == 0 and list(recs["tick"]) == list(range(7))
    (tmp_path / "twice.log").write_bytes(raw + raw)  # what appending a second run produced
    with pytest.raises(ValueError, match="second log header"):
        read_log(tmp_path / "twice.log")
    nl = raw.index(b"\n")
    for cut in (raw[: nl // 2], raw[:nl] + b"x"):  # cut before the newline (crash while writing the header)
        (tmp_path / "cut.log").write_bytes(cut)
        with pytest.raises(ValueError, match="cut or damaged"):
            read_log(tmp_path / "cut.log")
    (tmp_path / "cut.log").write_bytes(raw[: nl - 3] + b"\n" + raw[nl + 1 :])  # header damaged, newline kept
    with pytest.raises(ValueError, match="cut or damaged"):
        read_log(tmp_path / "cut.log")
    (tmp_path / "torn.log").write_bytes(raw[:-5])
    with pytest.warns(TornLogWarning, match="torn"):
        header, recs = read_log(tmp_path / "torn.log")
    assert recs.size == 6 and header["torn_bytes"] == fl.RECORD.itemsize - 5


# ---------------------------------------------------------------------- 6. one validator, hostile files
def _rewrite(law_file: Path, tmp: Path, name: str, edit, rechecksum: bool = True) -> Path:
    doc = json.loads(law_file.read_text())
    edit(doc)
    if rechecksum:
        body = {k: doc[k] for k in A._BODY_KEYS}
        doc["sha256"] = hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode()).hexdigest()
    p = tmp / f"{name}.json"
    p.write_text(json.dumps(doc))
    return p


def _hostile(law_file: Path, tmp: Path) -> dict[str, tuple[Path, str]]:
    """name -> (file, what the refusal must say)."""
    out: dict[str, tuple[Path, str]] = {}

    def spec(key, value):
        return lambda d: d["spec"].__setitem__(key, value)

    for name, edit, expect in [
        ("unknown_task", spec("task", "loop_the_loop"), "spec.task"),
        ("bogus_free_joint", spec("free_dofs", ["rig_roll", "tail_wag"]), "spec.free_dofs"),
        ("joints_out_of_order", spec("free_dofs", ["model_pitch", "rig_roll"]), "spec.free_dofs"),
        ("garbage_labels", lambda d: d["spec"].__setitem__("obs_labels", [f"x{i}" for i in range(len(d["spec"]["obs_labels"]))]), "spec.obs_labels"),
        ("seven_actions", lambda d: d["spec"].__setitem__("action_names", d["spec"]["action_names"] + ["a", "b", "c", "d"]), "limits"),
        ("unknown_task_option", spec("task_options", {"speed": 3}), "spec.task_options"),
        ("reversed_airspeed", spec("airspeed_range", [25.0, 12.0]), "airspeed_range"),
        ("one_airspeed", spec("airspeed_range", [12.0]), "airspeed_range"),
        ("bool_version", lambda d: d.__setitem__("format_version", True), "format_version"),
        ("list_dtype", lambda d: d["arrays"]["K"].__setitem__("dtype", ["<f8"]), "arrays.K.dtype"),
        ("dict_shape", lambda d: d["arrays"]["K"].__setitem__("shape", {"a": 1}), "arrays.K.shape"),
        ("huge_int", lambda d: d["params"].__setitem__("n", 10**400), "digits"),
        ("non_ascii_checksum", lambda d: None, "sha256"),
    ]:
        p = _rewrite(law_file, tmp, name, edit)
        if name == "non_ascii_checksum":
            doc = json.loads(p.read_text())
            doc["sha256"] = "\u00e9" * 64
            p.write_text(json.dumps(doc))  # ASCII on disk (escaped), non-ASCII once parsed
        out[name] = (p, expect)
    text = law_file.read_text()
    (tmp / "duplicate_key.json").write_text(text.replace('"kind":', '"kind": "pid", "kind":', 1))
    out["duplicate_key"] = (tmp / "duplicate_key.json", "duplicate key 'kind'")
    (tmp / "deep.json").write_text("[" * 100000 + "]" * 100000)
    out["deep_nesting"] = (tmp / "deep.json", "nested deeper")
    (tmp / "nan_airspeed.json").write_text(text.replace('"airspeed_range": [', '"airspeed_range": [NaN, ', 1))
    out["nan_airspeed"] = (tmp / "nan_airspeed.json", "non-finite constant NaN")
    (tmp / "inf_number.json").write_text(text.replace('"airspeed_range": [', '"airspeed_range": [1e400, ', 1))
    out["huge_float"] = (tmp / "inf_number.json", "overflows")
    (tmp / "latin1.json").write_bytes(text.encode("ascii") + "\u00e9".encode("latin-1"))
    out["not_ascii"] = (tmp / "latin1.json", "not a valid JSON")
    fifo = tmp / "fifo.json"
    os.mkfifo(fifo)
    out["fifo"] = (fifo, "not a regular file")
    (tmp / "dir.json").mkdir()
    out["directory"] = (tmp / "dir.json", "not a regular file")
    return out


def test_hostile_artefacts_refused_by_load_verify_and_run_without_traceback_or_hang(law_file, tmp_path, capsys):
    for name, (p, expect) in _hostile(law_file, tmp_path).items():
        t0 = time.monotonic()
        with pytest.raises(A.ArtefactError) as e:
            load_deployable(p)
        assert str(p) in str(e.value) and expect in str(e.value), (name, str(e.value))
        for argv in (["verify", "--law", str(p)], ["run", "--law", str(p), "--rig", "udp://127.0.0.1:9", "--duration", "1"]):
            assert cli.main(argv) == cli.EXIT_REFUSED, (name, argv)
            err = capsys.readouterr().err
            assert str(p) in err and "Traceback" not in err, (name, err)
        assert time.monotonic() - t0 < 20.0, name  # the FIFO never blocks
    assert cli.main(["verify", "--law", str(law_file)]) == 0  # the untouched file still passes
    capsys.readouterr()
    assert cli.main(["verify", "--law", str(law_file), "--rate", "100"]) == cli.EXIT_REFUSED
    assert "80 Hz" in capsys.readouterr().err


def test_random_corruptions_never_escape_as_anything_but_artefact_error(law_file, tmp_path):
    """A small fuzz: random byte flips, cuts and splices of a valid file are refused (or, rarely, still valid), never a traceback."""
    raw = law_file.read_bytes()
    rng = np.random.default_rng(24)
    p = tmp_path / "fuzz.json"
    for i in range(150):
        b = bytearray(raw)
        kind = i % 3
        if kind == 0:
            for j in rng.integers(0, len(b), 3):
                b[j] = int(rng.integers(0, 256))
        elif kind == 1:
            b = b[: int(rng.integers(0, len(b)))]
        else:
            a, c = sorted(rng.integers(0, len(b), 2))
            b = b[:a] + b"[{" * int(rng.integers(1, 50)) + b[c:]
        p.write_bytes(bytes(b))
        try:
            load_deployable(p)
        except A.ArtefactError as e:
            assert str(p) in str(e)


# ---------------------------------------------------------------------- 8. arguments and resources
@pytest.mark.parametrize("argv, field", [
    (["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--bind-port", "70000"], "--bind-port"),
    (["sim-rig", "--port", "-1"], "--port"),
    (["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--duration", "1e9"], "--duration"),
    (["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--duration", "nan"], "--duration"),
    (["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--rate", "0"], "--rate"),
    (["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--fault-frames", "1.5"], "--fault-frames"),
])
def test_arguments_out_of_range_are_refused_naming_field_and_range(argv, field, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and field in err and ("range" in err or "not" in err), err


def test_rig_port_out_of_range_and_duration_bound(law_file, capsys):
    assert cli.main(["run", "--law", str(law_file), "--rig", "udp://127.0.0.1:70000", "--duration", "1"]) == cli.EXIT_REFUSED
    assert "1-65535" in capsys.readouterr().err
    assert cli.MAX_DURATION_S == lp.MAX_DURATION_S
    with pytest.raises(ValueError, match="duration"):
        lp.LoopConfig(rig=("127.0.0.1", 9), rate_hz=80.0, duration=1e9)


def test_timing_statistics_are_a_bounded_ring(tmp_path, law_file):
    """The per-tick statistics never preallocate beyond STATS_CAP, whatever the duration (1e6 s at 80 Hz would be 1.9 GB)."""
    assert lp.STATS_CAP * 8 * 3 <= 8 * 2**20
    rig = FakeRig()
    try:
        cfg = lp.LoopConfig(rig=("127.0.0.1", rig.port), rate_hz=80.0, bind=("127.0.0.1", 0), duration=lp.MAX_DURATION_S, arm=True)
        with jit.python_mode():
            loop = lp.RigLoop(A.load(law_file), cfg)
            threading.Timer(0.5, loop.stop).start()
            summary = loop.run()
    finally:
        rig.close()
    assert loop.lat.size == lp.STATS_CAP and summary["ticks"] < 200


def test_failed_export_leaves_no_temporary_file(law_file, tmp_path, monkeypatch):
    art = A.load(law_file)

    def refuse(*_a):
        raise OSError(errno.EXDEV, "rename refused")

    monkeypatch.setattr(A.os, "replace", refuse)
    with pytest.raises(OSError):
        A.save(art, tmp_path / "out.json")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- 10. rig-deploy log show|plot|export
def test_log_show_plot_export_of_a_flight(tmp_path, law_file, capsys):
    from rig_env.sysid import FlightRecord

    log = tmp_path / "f.log"
    summary, _ = _fly(law_file, log, duration=1.0)
    assert cli.main(["log", "show", str(log)]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["ticks"] == summary["ticks"] and shown["records"] == summary["ticks"] - summary["counts"]["skipped"]
    assert shown["frames"]["fresh"] == summary["counts"]["fresh"] and shown["frames"]["missed"] == summary["counts"]["missed"]
    assert sum(s["ticks"] for s in shown["states"].values()) == shown["records"] and shown["states"]["ACTIVE"]["ticks"] > 0
    assert shown["header"]["task"] == TASK and shown["faults"] == [] and shown["latency"]["p50_ms"] > 0
    link = shown["header"]["link"]  # the log says how the link was flown
    assert link["keyed"] is False and link["protocol_version"] == 2 and link["session"] > 0 and link["ack_frames"] == 8
    out = tmp_path / "plots"
    assert cli.main(["log", "plot", str(log), "--out", str(out)]) == 0
    pngs = sorted(p.name for p in out.iterdir())
    assert pngs == sorted(["commands.png", "joints.png", "states.png", "timing.png"])
    assert all((out / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)
    capsys.readouterr()
    assert cli.main(["log", "plot", str(log), "--out", str(out)]) == cli.EXIT_REFUSED
    assert "commands.png" in capsys.readouterr().err
    csv = tmp_path / "f.csv"
    assert cli.main(["log", "export", str(log), "--out", str(csv)]) == 0
    lines = csv.read_text().splitlines()
    assert len(lines) == shown["records"] + 1 and "angles_rig_roll" in lines[0] and "command_comp_aileron" in lines[0]
    assert cli.main(["log", "export", str(log), "--out", str(csv)]) == cli.EXIT_REFUSED
    assert not list(tmp_path.glob("*.tmp"))
    rec = FlightRecord.read(log, allow_gaps=True)  # the identification still reads the loop's log
    assert rec.n_t >= 0.8 * summary["counts"]["fresh"] - 1


def test_log_tool_refuses_damaged_logs_naming_them(tmp_path, capsys):
    raw = _small_log(tmp_path / "a.log")
    (tmp_path / "twice.log").write_bytes(raw + raw)
    assert cli.main(["log", "show", str(tmp_path / "twice.log")]) == cli.EXIT_REFUSED
    err = capsys.readouterr().err
    assert "twice.log" in err and "second log header" in err
    (tmp_path / "torn.log").write_bytes(raw[:-3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the tool reports it in the summary, it does not warn
        assert cli.main(["log", "show", str(tmp_path / "torn.log")]) == 0
    assert json.loads(capsys.readouterr().out)["torn_bytes"] == fl.RECORD.itemsize - 3


def test_a_log_header_that_cannot_be_written_exits_5_before_flying(tmp_path, law_file, monkeypatch, capsys):
    real_open = open

    def failing_open(p, m="r", *a, **k):
        return FullDisk(real_open(p, m, *a, **k), ok=0) if m == "xb" else real_open(p, m, *a, **k)

    monkeypatch.setattr(fl, "open", failing_open, raising=False)  # the module's open: only FrameLog's file fails
    log = tmp_path / "h.log"
    rc = cli.main(["run", "--law", str(law_file), "--rig", "udp://127.0.0.1:9", "--arm", "--duration", "1", "--log", str(log)])
    err = capsys.readouterr().err
    assert rc == cli.EXIT_LOG and str(log) in err and "log header" in err and "Traceback" not in err, err


# ---------------------------------------------------------------------- property-based fuzzing (hypothesis)
hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_json = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=8),
                     lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=6), kids, max_size=4), max_leaves=12)
_FIELDS = ("task", "free_dofs", "obs_labels", "action_names", "dt", "airspeed_range", "action_scale_deg", "task_options")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(field=st.sampled_from(_FIELDS + ("format_version", "sha256", "limits", "sensors", "arrays")), value=_json)
def test_any_json_in_any_field_is_accepted_or_refused_never_a_traceback(law_file, tmp_path, field, value):
    """Re-checksummed files with an arbitrary JSON value in a field: load_deployable returns or raises ArtefactError, nothing else."""
    def edit(d):
        if field in _FIELDS:
            d["spec"][field] = value
        else:
            d[field] = value
    p = _rewrite(law_file, tmp_path, "prop", edit, rechecksum=field != "sha256")
    try:
        load_deployable(p)
    except A.ArtefactError as e:
        assert str(p) in str(e)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(body=st.binary(max_size=3 * 255 + 40))
def test_read_log_of_any_body_returns_whole_records_or_says_why(tmp_path, body):
    path = tmp_path / "p.log"
    path.write_bytes(fl.header_line({"rate_hz": 80.0}) + body)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        try:
            header, recs = read_log(path)
        except ValueError as e:
            assert str(path) in str(e) and b"rig-loop-log" in body  # only a second header refuses a body
            return
    assert recs.size == len(body) // fl.RECORD.itemsize and header["torn_bytes"] == len(body) % fl.RECORD.itemsize
    assert bool(w) == bool(header["torn_bytes"])
