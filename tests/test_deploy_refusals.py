"""``rig-deploy`` refuses bad input before it runs, naming the option or field and the allowed range.

Files a user wrote are never replaced silently (``export --out``, ``sim-rig --record`` / ``--summary``:
``--overwrite``), and their paths are checked before the run; a socket that cannot be bound names
``--bind`` / ``--bind-port`` / ``--host`` / ``--port`` (or ``--rig`` for a host that does not resolve) and
leaves no log behind; seeds share one range; ``verify`` refuses what ``run`` refuses (the environments'
ranges of the law rate, the sensor layout and the airspeed range).  Everything runs on loopback and
each case is bounded in time.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from controllers.deploy import cli
from controllers.deploy import loop as lp
from controllers.deploy import protocol as pr
from controllers.deploy.validate import ENV_RANGES, load_deployable
from controllers.laws import artefact as A
from fake_rig import FakeRig
from rig_env.physics import jit

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
TASK = "velocity_vector_roll"
EXPORT = ["export", "--controller", "linear", "--task", TASK]


@pytest.fixture(scope="module")
def law_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("law") / "law.json"
    r = subprocess.run([sys.executable, "-m", "controllers.deploy.cli", *EXPORT, "--out", str(out)],
                       env=ENV, capture_output=True, text=True, timeout=300, cwd=str(ROOT), check=False)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture
def busy_port():
    """A loopback UDP port held by another socket for the test."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    try:
        yield s.getsockname()[1]
    finally:
        s.close()


def _refused(argv: list[str], capsys) -> str:
    """Run ``main(argv)``: refused with exit 2 (by main or by argparse), one line or argparse's usage, no traceback; stderr."""
    try:
        rc = cli.main(argv)
    except SystemExit as e:
        rc = e.code
    out, err = capsys.readouterr()
    assert rc == cli.EXIT_REFUSED and "Traceback" not in err, (rc, err)
    assert "listening" not in out, out  # refused before the sim rig served anything
    return err


# ---------------------------------------------------------------------- files: never replaced silently, checked first
def test_sim_rig_refuses_its_output_paths_before_the_run(tmp_path, capsys):
    old_rec, old_sum = tmp_path / "old.npz", tmp_path / "old.json"
    old_rec.write_bytes(b"a record")
    old_sum.write_text("a summary")
    cases = [
        (["--record", str(old_rec)], ["--record", "already exists", "--overwrite"]),
        (["--summary", str(old_sum)], ["--summary", "already exists", "--overwrite"]),
        (["--record", str(tmp_path / "no" / "dir" / "r.npz")], ["--record", "does not exist"]),
        (["--summary", str(tmp_path / "no" / "s.json")], ["--summary", "does not exist"]),
        (["--record", str(tmp_path)], ["--record", "is a folder"]),
        (["--summary", str(tmp_path)], ["--summary", "is a folder"]),
        (["--record", str(tmp_path / "rec.csv")], ["--record", ".npz"]),  # np.savez would have written rec.csv.npz
        (["--record", str(tmp_path / "x.npz"), "--summary", str(tmp_path / "x.npz")], ["--record and --summary"]),
    ]
    for extra, expect in cases:
        t0 = time.monotonic()
        err = _refused(["sim-rig", "--port", "0", "--duration", "1", *extra], capsys)
        assert all(e in err for e in expect) and time.monotonic() - t0 < 10.0, (extra, err)
    assert old_rec.read_bytes() == b"a record" and old_sum.read_text() == "a summary"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.json", "old.npz"]  # nothing written, not rec.csv.npz


def test_sim_rig_overwrite_replaces_exactly_the_named_files_after_the_run(tmp_path, law_file):
    rec, summ = tmp_path / "r.npz", tmp_path / "s.json"
    rec.write_bytes(b"old")
    summ.write_text("old")
    p = subprocess.Popen([sys.executable, "-m", "controllers.deploy.cli", "sim-rig", "--port", "0", "--task", TASK, "--duration", "1",
                          "--record", str(rec), "--summary", str(summ), "--overwrite"],
                         env=ENV, cwd=str(ROOT), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = p.stdout.readline()
        assert line, p.stderr.read()
        port = json.loads(line)["listening"][1]
        cfg = lp.LoopConfig(rig=("127.0.0.1", port), rate_hz=80.0, bind=("127.0.0.1", 0), duration=1.0, arm=True)
        with jit.python_mode():
            lp.RigLoop(A.load(law_file), cfg).run()
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.communicate(timeout=10)
    assert p.returncode == 0, err
    with np.load(rec, allow_pickle=False) as z:
        n = z["t"].size
        assert n > 40 and z["q"].shape == (n, 5)
    assert json.loads(summ.read_text())["frames"] == n
    assert sorted(q.name for q in tmp_path.iterdir()) == ["r.npz", "s.json"]


def test_export_refuses_an_existing_artefact_and_a_folder_unless_overwrite(tmp_path, law_file, capsys):
    out = tmp_path / "a.json"
    out.write_bytes(law_file.read_bytes())
    before = out.read_bytes()
    err = _refused([*EXPORT, "--out", str(out), "--gains", "3", "1", "1"], capsys)
    assert f"--out {out}" in err and "already exists" in err and "--overwrite" in err, err
    assert out.read_bytes() == before
    err = _refused([*EXPORT, "--out", str(tmp_path)], capsys)
    assert f"--out {tmp_path}" in err and "is a folder" in err and ".tmp" not in err, err
    err = _refused([*EXPORT, "--out", str(tmp_path / "none" / "b.json")], capsys)
    assert "--out" in err and "does not exist" in err, err
    assert cli.main([*EXPORT, "--out", str(out), "--gains", "3", "1", "1", "--overwrite"]) == 0
    capsys.readouterr()
    assert out.read_bytes() != before and load_deployable(out).data["K"].max() == 3.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]
    with pytest.raises(FileExistsError, match="already exists"):  # the codec's own no-clobber save
        A.save(A.load(out), out, overwrite=False)
    assert load_deployable(out).data["K"].max() == 3.0


# ---------------------------------------------------------------------- sockets: the option at fault, no log left
def test_run_with_its_port_in_use_names_bind_port_and_leaves_no_log(tmp_path, law_file, busy_port, capsys):
    log = tmp_path / "bindtest.log"
    argv = ["run", "--law", str(law_file), "--rig", "udp://127.0.0.1:9", "--duration", "0.5", "--bind", "127.0.0.1", "--log", str(log)]
    err = _refused([*argv, "--bind-port", str(busy_port)], capsys)
    assert f"--bind-port {busy_port}" in err and "in use" in err and str(law_file) not in err, err
    assert not log.exists() and not Path(str(log) + ".summary.json").exists()
    rig = FakeRig()  # the same --log is taken by the next run
    try:
        argv[argv.index("udp://127.0.0.1:9")] = f"udp://127.0.0.1:{rig.port}"
        assert cli.main(argv) in (cli.EXIT_OK, cli.EXIT_FAULT)  # FAULT: an overrun on a busy machine
    finally:
        rig.close()
    assert json.loads(capsys.readouterr().out)["counts"]["fresh"] > 0 and log.exists()
    cfg = lp.LoopConfig(rig=("127.0.0.1", 9), rate_hz=80.0, bind=("127.0.0.1", busy_port), duration=0.5, log_path=str(tmp_path / "lib.log"))
    with jit.python_mode(), pytest.raises(pr.BindError) as e:
        lp.RigLoop(A.load(law_file), cfg).run()
    assert not e.value.host_refused and not (tmp_path / "lib.log").exists()


@pytest.mark.parametrize("extra, expect", [
    (["--rig", "udp://nonexistent.invalid:4000"], "--rig udp://nonexistent.invalid:4000"),
    (["--rig", "udp://127.0.0.1:9", "--bind", "999.1.1.1"], "--bind 999.1.1.1"),
])
def test_run_names_the_address_option_it_cannot_use(tmp_path, law_file, capsys, extra, expect):
    log = tmp_path / "r.log"
    err = _refused(["run", "--law", str(law_file), "--duration", "0.5", "--log", str(log), *extra], capsys)
    assert expect in err and str(law_file) not in err and str(log) not in err, err
    assert not log.exists()


def test_sim_rig_with_its_port_in_use_or_a_bad_host_names_the_option(busy_port, capsys):
    err = _refused(["sim-rig", "--port", str(busy_port), "--host", "127.0.0.1", "--duration", "1"], capsys)
    assert f"--port {busy_port}" in err and "in use" in err and "(no path)" not in err, err
    err = _refused(["sim-rig", "--port", "0", "--host", "nonexistent.invalid", "--duration", "1"], capsys)
    assert "--host nonexistent.invalid" in err and "(no path)" not in err, err


# ---------------------------------------------------------------------- seeds and other options
@pytest.mark.parametrize("argv", [
    ["sim-rig", "--port", "0", "--seed", "-1"], ["sim-rig", "--port", "0", "--seed", str(2**32)],
    ["sim-rig", "--port", "0", "--fault-seed", "-1"], ["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--seed", "-1"],
    ["run", "--law", "L", "--rig", "udp://127.0.0.1:9", "--seed", str(2**32)],
])
def test_seeds_share_one_range_on_run_and_sim_rig(argv, capsys):
    option = next(a for a in argv if a.endswith("seed"))
    err = _refused(argv, capsys)
    assert option in err and f"[0, {cli.MAX_SEED}]" in err, err


def test_seed_range_is_the_loops_and_the_sim_rigs():
    from controllers.deploy.simrig import Faults, SimRig

    from controllers.evaluation import evaluate
    from rig_env.envs import ranges

    assert cli.MAX_SEED is lp.MAX_SEED is evaluate.MAX_SEED is ranges.MAX_SEED and ranges.MAX_SEED == 2**32 - 1  # one range
    for bad in (-1, 2**32, True, 1.5):
        with pytest.raises(ValueError, match="seed"):
            lp.LoopConfig(rig=("127.0.0.1", 9), rate_hz=80.0, seed=bad)
        with pytest.raises(ValueError, match="seed"):
            SimRig(0, TASK, seed=bad)  # before binding or building anything
        with pytest.raises(ValueError, match="fault seed"):
            Faults(seed=bad)


@pytest.mark.parametrize("argv, option, not_said", [
    (["sim-rig", "--port", "0", "--stuck", "rig_roll", "abc", "1"], "--stuck", "could not convert"),
    (["sim-rig", "--port", "0", "--stuck", "rig_roll", "1", "-2"], "--stuck", "stuck ="),
    (["sim-rig", "--port", "0", "--stuck", "tail_wag", "1", "1"], "--stuck", "stuck joint"),
    (["sim-rig", "--port", "0", "--loss", "2"], "--loss", "loss = "),
    (["sim-rig", "--port", "0", "--blackout", "nan", "1"], "--blackout", "rig-deploy: blackout ="),
    (["sim-rig", "--port", "0", "--cmd-blackout", "1", "-2"], "--cmd-blackout", "rig-deploy: cmd_blackout ="),
    ([*EXPORT, "--out", "x.json", "--gains", "nan", "1", "1"], "--gains", "K:"),
    ([*EXPORT, "--out", "x.json", "--gains", "1", "inf", "1"], "--gains", "K:"),
])
def test_bad_option_values_name_the_option(argv, option, not_said, capsys):
    err = _refused(argv, capsys)
    assert option in err and not_said not in err, err


# ---------------------------------------------------------------------- verify refuses what run refuses
def _edited(law_file: Path, tmp: Path, section: str, key: str, value) -> Path:
    doc = json.loads(law_file.read_text())
    doc[section][key] = value
    doc["sha256"] = hashlib.sha256(A.canonical({k: doc[k] for k in A._BODY_KEYS})).hexdigest()
    p = tmp / f"{section}_{key}.json"
    p.write_text(json.dumps(doc))
    return p


@pytest.mark.parametrize("section, key, value, expect", [
    ("spec", "dt", 1e-300, "allowed range [1, 2000] Hz"),
    ("spec", "dt", 1.0 / 4000.0, "allowed range [1, 2000] Hz"),
    ("sensors", "pot_bits", 1000, "sensors.pot_bits = 1000: allowed range [6, 24]"),
    ("sensors", "encoder_bits", 3, "sensors.encoder_bits = 3: allowed range [6, 24]"),
    ("sensors", "link_delay_steps", -5, "sensors.link_delay_steps = -5: allowed range [0, 50]"),
    ("sensors", "rate_filter_hz", 0.01, "sensors.rate_filter_hz = 0.01: allowed range [0.1, 40]"),
    ("spec", "airspeed_range", [0.0, 1e9], "spec.airspeed_range = [0.0, 1000000000.0]: each speed in [0, 40] m/s"),
])
def test_verify_and_run_refuse_the_same_hand_edited_artefact(law_file, tmp_path, capsys, section, key, value, expect):
    p = _edited(law_file, tmp_path, section, key, value)
    with pytest.raises(A.ArtefactError) as e:
        load_deployable(p)
    assert str(e.value).startswith(f"{p}: ") and expect in str(e.value), str(e.value)
    for argv in (["verify", "--law", str(p)], ["run", "--law", str(p), "--rig", "udp://127.0.0.1:9", "--duration", "0.5"]):
        err = _refused(argv, capsys)
        assert err.strip() == f"rig-deploy: artefact refused: {e.value}", err


def test_env_ranges_are_the_environment_configurations():
    """The validator's ranges (rig_env.envs.ranges, which RigEnvConfig checks its fields against) are RigEnvConfig's, at both ends."""
    from rig_env.envs.config import MAX_AIRSPEED, RigEnvConfig

    def accepts(**kw) -> bool:
        try:
            RigEnvConfig(**kw)
        except ValueError:
            return False
        return True

    lo, hi, _ = ENV_RANGES["control_rate"]
    assert accepts(control_rate=lo, rate_filter_hz=lo / 2) and accepts(control_rate=hi)
    assert not accepts(control_rate=lo * 0.999, rate_filter_hz=0.1) and not accepts(control_rate=hi * 1.001)
    assert (lo, hi) == (1.0, 2000.0) and lp.LoopConfig(rig=("h", 1), rate_hz=hi) and lp.LoopConfig(rig=("h", 1), rate_hz=lo)
    for k in ("pot_bits", "encoder_bits", "link_delay_steps"):
        lo, hi, _ = ENV_RANGES[k]
        assert accepts(**{k: lo}) and accepts(**{k: hi}) and not accepts(**{k: lo - 1}) and not accepts(**{k: hi + 1}), k
    lo, frac, _ = ENV_RANGES["rate_filter_hz"]
    assert accepts(control_rate=80.0, rate_filter_hz=lo) and accepts(control_rate=80.0, rate_filter_hz=frac * 80.0)
    assert not accepts(control_rate=80.0, rate_filter_hz=lo * 0.99) and not accepts(control_rate=80.0, rate_filter_hz=frac * 80.0 * 1.001)
    lo, hi, _ = ENV_RANGES["airspeed"]
    assert hi == MAX_AIRSPEED and accepts(airspeed=(lo, hi)) and not accepts(airspeed=(lo, hi * 1.001)) and not accepts(airspeed=(lo - 0.1, hi))
