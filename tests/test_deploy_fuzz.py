"""Property-based fuzzing of the rig link's frames and of `rig-deploy run`'s arguments (issue: every hostile
input refused cleanly).  Frames: any bytes, and any single-bit change of a valid frame, decode to a frame or
raise :class:`FrameError` naming the reason, never anything else; a valid frame survives its round trip.
Arguments: any value of any numeric option is accepted or refused with exit 2 and a message that names the
option, never a traceback (a refused value flies nothing); ``--duration`` is fuzzed in its own test over
values that cannot keep a test waiting (an accepted run lasts its duration)."""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from controllers.deploy import cli  # noqa: E402
from controllers.deploy import protocol as pr  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
KEY = bytes(range(32))
_floats = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6)


@settings(max_examples=300, deadline=None)
@given(data=st.binary(max_size=2 * pr.SENSOR_SIZE), key=st.sampled_from([None, KEY]))
def test_any_bytes_decode_to_a_frame_or_a_named_refusal(data, key):
    for unpack in (pr.unpack_sensor, pr.unpack_command):
        try:
            unpack(data, key)
        except pr.FrameError as e:
            assert e.reason in ("length", "magic", "crc", "version", "mac", "nonfinite", "mode")


def _f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _sensor(seq, t, angles, key):
    buf = bytearray(pr.SENSOR_SIZE)
    pr.pack_sensor_into(buf, seq, t, angles, (0.0, 0.0, 0.0, 0.0), 20.0, key=key)
    return buf


@settings(max_examples=200, deadline=None)
@given(seq=st.integers(0, 2**32 - 1), t=_floats, angles=st.lists(_floats, min_size=5, max_size=5),
       key=st.sampled_from([None, KEY]), bit=st.integers(0, 8 * pr.SENSOR_SIZE - 1))
def test_a_valid_sensor_frame_round_trips_and_any_flipped_bit_is_refused(seq, t, angles, key, bit):
    buf = _sensor(seq, t, angles, key)
    f = pr.unpack_sensor(bytes(buf), key)
    assert f.seq == seq and f.rig_time == t and f.angles == tuple(_f32(a) for a in angles)  # float32 on the wire
    buf[bit // 8] ^= 1 << (bit % 8)
    with pytest.raises(pr.FrameError):
        pr.unpack_sensor(bytes(buf), key)


@settings(max_examples=200, deadline=None)
@given(seq=st.integers(0, 2**32 - 1), surfaces=st.lists(_floats, min_size=6, max_size=6), key=st.sampled_from([None, KEY]),
       bit=st.integers(0, 8 * pr.COMMAND_SIZE - 1))
def test_a_valid_command_frame_round_trips_and_any_flipped_bit_is_refused(seq, surfaces, key, bit):
    buf = bytearray(pr.COMMAND_SIZE)
    pr.pack_command_into(buf, seq, 7, surfaces, pr.MODE_ACTIVE, session=3, key=key)
    f = pr.unpack_command(bytes(buf), key)
    assert f.seq == seq and f.mode == pr.MODE_ACTIVE
    buf[bit // 8] ^= 1 << (bit % 8)
    with pytest.raises(pr.FrameError):
        pr.unpack_command(bytes(buf), key)


@pytest.fixture(scope="module")
def law_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("law") / "law.json"
    r = subprocess.run([sys.executable, "-m", "controllers.deploy.cli", "export", "--controller", "linear", "--task", "velocity_vector_roll",
                        "--out", str(out)], env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True, timeout=300, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr
    return out


_NUMERIC = ("--rate", "--seed", "--bind-port", "--stale-frames", "--fault-frames", "--stuck-frames", "--stuck-cmd-deg",
            "--ack-frames", "--link-delay-steps")
_values = st.one_of(st.integers(-10**400, 10**400).map(str), st.floats().map(repr), st.text(max_size=12),
                    st.sampled_from(["", "-1", "0", "1e309", "nan", "-inf", "0x10", "1_000", "٣", "1e-320"]))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(option=st.sampled_from(_NUMERIC), value=_values)
def test_any_value_of_a_numeric_run_option_is_accepted_or_refused_by_name(law_file, capsys, option, value):
    argv = ["run", "--law", str(law_file), "--rig", "udp://127.0.0.1:9", "--duration", "0.03", "--bind", "127.0.0.1", f"{option}={value}"]
    try:
        rc = cli.main(argv)
    except SystemExit as e:  # argparse's refusal
        rc = e.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if rc == cli.EXIT_REFUSED:
        assert option in err or option.lstrip("-").replace("-", "_") in err, err
    else:  # accepted: the short run ends having received no frame (nothing listens on port 9)
        assert rc == cli.EXIT_NO_FRAMES, (rc, err)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(value=st.one_of(st.floats(max_value=0.05).map(repr), st.integers(-10**400, 0).map(str), st.text(max_size=8).filter(lambda t: not _valid(t)),
                       st.sampled_from(["1e309", "inf", "nan", "-0", "0", "1e400", str(10**400)])))
def test_any_duration_is_accepted_or_refused_by_name(law_file, capsys, value):
    try:
        rc = cli.main(["run", "--law", str(law_file), "--rig", "udp://127.0.0.1:9", "--bind", "127.0.0.1", f"--duration={value}"])
    except SystemExit as e:
        rc = e.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert rc == cli.EXIT_NO_FRAMES if _small_positive(value) else (rc == cli.EXIT_REFUSED and "--duration" in err), (value, rc, err)


def _small_positive(text: str) -> bool:
    return _valid(text) and float(text) <= 0.05


def _valid(text: str) -> bool:
    """A valid duration (0 < v <= MAX_DURATION_S, as float() reads it): random text that is one ("1", "2_0") is a
    run that waits its length for frames, so the text strategy leaves those out (the floats keep the small ones)."""
    try:
        v = float(text)
    except ValueError:
        return False
    return math.isfinite(v) and 0.0 < v <= cli.MAX_DURATION_S
