"""``rig continuation`` (rig_cli.continuation): the branch it writes is rig_env.continuation's, and bad input is
refused in one line naming the option, before anything is written or computed."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

import rig_env
from rig_cli.main import main


def read(path: Path) -> list[list[str]]:
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def test_continuation_command_writes_the_branch_of_rig_env_continuation(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", "4", "-4", "9",
            "--aero-model", "tables", "--set", "hawk_aero.CMq=-20", "--no-orbits", "--out", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "9 equilibria sampled, 9 stable; hawk_elevator in deg" in text and "fold" in text
    assert sorted(p.name for p in out.iterdir()) == ["bifurcation.png", "branch.csv", "orbits.csv", "special_points.csv"]
    p = rig_env.RigParams.default().replace(**{"hawk_aero.CMq": -20.0})
    br = rig_env.continuation(p, free_dofs=("model_pitch",), parameter="hawk_elevator", values=np.linspace(4, -4, 9), aero_model="tables", periodic=False)
    rows = read(out / "branch.csv")
    assert rows[0][:3] == ["hawk_elevator (deg)", "model_pitch (deg)", "model_pitch_rate (deg/s)"]
    assert rows[0][-3:] == ["stable", "leading_real (1/s)", "leading_imag (1/s)"]
    got = np.array([[float(r[0]), float(r[1])] for r in rows[1:]])
    assert np.allclose(got[:, 0], br.values) and np.allclose(got[:, 1], np.degrees(br.states[:, 0]), atol=1e-8)
    assert [r[-3] for r in rows[1:]] == ["1"] * 9  # every sampled point stable
    lead = br.eigenvalues[:, 0]
    assert np.allclose([float(r[-2]) for r in rows[1:]], lead.real, rtol=1e-5)
    sp = read(out / "special_points.csv")
    assert sp[0] == ["kind", "hawk_elevator (deg)", "model_pitch (deg)", "frequency (Hz)"]
    assert [r[0] for r in sp[1:]] == ["fold", "fold"]  # the stall tables' hysteresis window (README: Continuation)
    assert [float(r[1]) for r in sp[1:]] == pytest.approx(list(br.folds), abs=1e-8)
    assert [float(r[2]) for r in sp[1:]] == pytest.approx([math.degrees(x.state[0]) for x in br.points("fold")], abs=1e-5)
    # a second run into the same folder keeps the first's files unless --overwrite
    before = (out / "branch.csv").read_bytes()
    assert main(argv) == 2
    assert "already there; give --overwrite" in capsys.readouterr().err and (out / "branch.csv").read_bytes() == before
    assert main([*argv, "--overwrite"]) == 0


@pytest.mark.parametrize(("rig", "values", "elevators"), [
    ("paper", ["1.5", "0.3"], [1.12, 0.70]),
    # the default rig (README: both examples): the same band 1.46 deg lower in elevator.  Its shooting once threw
    # the period to 1e18 s from the second Hopf point and crashed allocating for it (periodic.Shooting's guard)
    ("default", ["0.0", "-1.2"], [-0.33, -0.76]),
])
def test_continuation_command_reports_hopf_points_and_orbits_of_the_lower_band(tmp_path, capsys, rig, values, elevators):
    """The lower band of Fig. 8 (docs/MODEL.md 7): a lift break and centre-of-pressure travel given on the command line."""
    out = tmp_path / "band"
    rig_file = ["--params", str(rig_env.params.PAPER_FILE)] if rig == "paper" else []
    assert main(["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", *values, "25",
                 "--aero-model", "unsteady", "--set", "hawk_aero.sep_cp_travel=0.2", "--lift-break", "6", "0.05",
                 *rig_file, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "orbit family 0 from the supercritical Hopf point" in text and "all stable" in text
    sp = read(out / "special_points.csv")[1:]
    assert [r[0] for r in sp] == ["hopf", "hopf"]
    assert sorted(float(r[2]) for r in sp) == pytest.approx([4.45, 6.0], abs=0.05)
    assert [float(r[1]) for r in sp] == pytest.approx(elevators, abs=0.01)
    orbits = read(out / "orbits.csv")
    assert orbits[0][-3:] == ["stable", "kind", "multiplier error"]
    amp = max(float(r[3]) for r in orbits[1:])
    # every orbit read as stable (its multipliers clear of the unit circle by more than their error), no fold, doubling or torus
    assert 1.2 < amp < 1.6 and all(r[4] == "1" and r[5] == "orbit" and 0.0 <= float(r[6]) < 0.02 for r in orbits[1:])


@pytest.mark.parametrize(("option", "message"), [
    ({"--free": ["model_roll"]}, "--free: unknown joint(s) ['model_roll']"),
    ({"--set": ["hawk_aero.CMq"]}, "--set 'hawk_aero.CMq': expected NAME=VALUE"),
    ({"--set": ["hawk_aero.CMqq=1"]}, "--set 'hawk_aero.CMqq=1': unknown name 'hawk_aero.CMqq'"),
    ({"--set": ["hawk_aero.CMq=abc"]}, "--set 'hawk_aero.CMq=abc': 'abc' is not a number"),
    ({"--lift-break": ["8", "0.05"]}, "--lift-break: alpha_deg = 8.0: must lie strictly between two breakpoints"),
    ({"--lift-break": ["6", "-0.1"]}, "--lift-break: depth = -0.1"),
    ({"--values": ["1", "1", "5"]}, "--values 1.0 1.0: two different finite ends are needed"),
    ({"--values": ["1", "0", "1"]}, "--values: the number of points must be an integer from 2 to 2001, not 1.0"),
    ({"--values": ["1", "0", "2.5"]}, "the number of points must be an integer"),
    ({"--control": ["hawk_flap=2"]}, "--control 'hawk_flap=2': unknown name 'hawk_flap'"),
    ({"--state": ["rig_roll"]}, "--state 'rig_roll': must be one of the free joints ['model_pitch']"),
    ({"--aero-model": ["stall"]}, "--aero-model = 'stall': allowed values: ['linear', 'tables', 'unsteady']"),
    ({"--parameter": ["hawk_aero.nothing"]}, "--parameter 'hawk_aero.nothing': unknown; valid names: the surfaces"),
    # a misspelt name is refused by its option before anything runs, with the close names (not all 150 listed)
    ({"--parameter": ["hawk_elevater"]}, "--parameter 'hawk_elevater': unknown (did you mean 'hawk_elevator'?)"),
    ({"--sweep": ["airsped", "10", "20", "3"]}, "--sweep 'airsped': unknown (did you mean 'airspeed'?)"),
    ({"--set": ["geometry.hawk_cgx=0.1"]}, "unknown name 'geometry.hawk_cgx' (did you mean 'geometry.hawk_cg_x'"),
    ({"--physics-dt": ["0"]}, "--physics-dt 0.0: the orbits' RK4 step must lie in [0.0001, 0.005] s"),
    ({"--physics-dt": ["nan"]}, "--physics-dt nan: the orbits' RK4 step must lie in [0.0001, 0.005] s"),
    ({"--physics-dt": ["1e-8"]}, "--physics-dt 1e-08: the orbits' RK4 step must lie in [0.0001, 0.005] s"),  # 79 GiB asked
    ({"--physics-dt": ["0.02"]}, "--physics-dt 0.02: the orbits' RK4 step must lie in [0.0001, 0.005] s"),
    ({"--values": ["1", "0", "inf"]}, "--values: the number of points must be an integer from 2 to 2001, not inf"),
    ({"--values": ["1", "0", "nan"]}, "--values: the number of points must be an integer from 2 to 2001, not nan"),
    ({"--sweep": ["airspeed", "10", "20", "inf"]}, "--sweep: the number of points must be an integer from 2 to 2001, not inf"),
])
def test_continuation_command_refuses_bad_input_by_name(tmp_path, capsys, option, message):
    opts = {"--free": ["model_pitch"], "--parameter": ["hawk_elevator"], "--values": ["2", "-2", "5"], **option}
    argv = ["continuation", "--no-orbits", "--out", str(tmp_path / "x")] + [a for k, v in opts.items() for a in (k, *v)]
    assert main(argv) == 2
    cap = capsys.readouterr()
    err = cap.err
    assert err.startswith("rig continuation: error: ") and message in err and len(err.strip().splitlines()) == 1
    assert len(err) < 500 and "continuing" not in cap.out  # one readable line, and nothing printed as if a run had started
    assert not (tmp_path / "x").exists()


def test_continuation_command_passes_q_guess_in_degrees_and_names_it_in_errors(tmp_path, capsys, monkeypatch):
    """--q-guess (deg) reaches rig_env.continuation as q_guess (rad); the library's advice to give "a better
    q_guess" comes out naming the command's option, which the command had not had."""
    seen = {}

    def fake(p, **kw):
        seen.update(kw)
        raise ValueError("q_guess: no equilibrium of ['model_pitch'] found near it at any of the values of hawk_elevator "
                         "(smallest max |qdd| 3 rad/s^2); give a better q_guess")

    monkeypatch.setattr(rig_env, "continuation", fake)
    argv = ["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", "1", "2", "3", "--no-orbits",
            "--q-guess", "0", "10", "0", "5", "0", "--out", str(tmp_path / "x")]
    assert main(argv) == 2
    np.testing.assert_allclose(seen["q_guess"], np.radians([0.0, 10.0, 0.0, 5.0, 0.0]), rtol=0, atol=1e-15)
    err = capsys.readouterr().err
    assert err.startswith("rig continuation: error: --q-guess: no equilibrium of ['model_pitch']") and err.rstrip().endswith(
        "give a better --q-guess (deg)")
    for bad in (["0", "0", "0", "nan", "0"], ["0", "0", "0", "400", "0"]):
        assert main(argv[:-8] + ["--q-guess", *bad, "--out", str(tmp_path / "x")]) == 2
        assert "--q-guess 0 0 0" in capsys.readouterr().err and not (tmp_path / "x").exists()


def test_continuation_refuses_a_first_equilibrium_outside_its_domain(params):
    """A q_guess that leads to an equilibrium beyond +-170 deg (the continuation's domain) is refused by name; it
    used to leave an empty branch and fail with an IndexError."""
    with pytest.raises(ValueError, match=r"q_guess: the equilibrium found near it .* model_pitch = 17\d\.\d deg, outside the continuation's \+-170 deg"):
        rig_env.continuation(params, free_dofs=("model_pitch",), parameter="hawk_elevator", values=[-1.0, 1.0],
                             q_guess=np.radians([0.0, 0.0, 0.0, 170.0, 0.0]), periodic=False)


@pytest.mark.parametrize("where", ["afile", "afile/sub"])
def test_continuation_command_refuses_an_out_that_is_a_file_before_computing(tmp_path, capsys, monkeypatch, where):
    """--out naming a file (or a folder under one) is refused in one line before any computation (it used to fail
    in mkdir with a traceback after the whole run); the file is left as it was."""
    (tmp_path / "afile").write_text("mine")
    monkeypatch.setattr(rig_env, "continuation", lambda *a, **k: pytest.fail("computed before checking --out"))
    argv = ["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", "1", "2", "5", "--out", str(tmp_path / where)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig continuation: error: --out ") and "not a folder" in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "afile").read_text() == "mine"


@pytest.mark.parametrize(("argv", "message"), [
    (["--q", "nan", "0", "0", "0", "0"], "--q nan 0 0 0 0: joint angles must be finite and within +-360 deg"),
    (["--q", "1e308", "0", "0", "0", "0"], "--q 1e+308 0 0 0 0: joint angles must be finite and within +-360 deg"),
    (["--q", "0", "0", "0", "0", "0", "--flaps", "50", "0", "0", "0"], "--flaps 50 0 0 0: flap deflections must be finite and within +-40 deg"),
    (["--q", "0", "0", "0", "0", "0", "--flaps", "nan", "0", "0", "0"], "--flaps nan 0 0 0: flap deflections must be finite"),
    (["--flaps", "1", "2", "3", "4"], "--flaps: give the pose with --q too"),
    (["--out", "AFILE"], "--out AFILE: is a file, not a folder"),
])
def test_draw_and_demo_refuse_bad_poses_and_an_out_that_is_a_file(tmp_path, capsys, monkeypatch, argv, message):
    """rig draw: angles and flaps checked against the ranges its help gives (a NaN or 1e308 angle used to end in a
    matplotlib traceback; flaps of 50 deg or without --q were drawn or ignored silently); rig demo: --out a file."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "AFILE").write_text("mine")
    assert main(["draw", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig draw: error: ") and message in err and len(err.strip().splitlines()) == 1
    assert main(["demo", "--t-final", "6", "--quiet", "--out", "AFILE"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig demo: error: --out AFILE: is a file, not a folder") and (tmp_path / "AFILE").read_text() == "mine"
    # an aileron past the flaps' travel was reported as held at 90 deg while the flaps flew at 40
    assert main(["demo", "--t-final", "6", "--quiet", "--no-plot", "--aileron", "90"]) == 2
    assert "--aileron 90: comp_aileron 90, comp_elevator 0, comp_rudder 0 deg put flap 1 at 90 deg, beyond" in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "message"), [
    (["--t-final", "3"], "--t-final 3: the simulated time must lie in (5, 3600] s"),
    (["--t-final", "inf"], "--t-final inf: the simulated time must lie in (5, 3600] s"),
    (["--t-final", "1e5"], "--t-final 100000: the simulated time must lie in (5, 3600] s"),  # ran 17 minutes, silent with --quiet
    (["--airspeed", "nan"], "--airspeed nan: the tunnel speed must lie in [0, 60] m/s"),
    (["--airspeed", "100"], "--airspeed 100: the tunnel speed must lie in [0, 60] m/s"),
    (["--aileron", "nan"], "--aileron nan: deflections must be finite (deg)"),
])
def test_demo_refuses_bad_options_by_their_names_before_running(capsys, monkeypatch, argv, message):
    """rig demo's errors name its options (they named run_roll's t_final and aileron_deg), before anything runs."""
    import sys

    monkeypatch.setattr(sys.modules["rig_cli.main"], "run_roll", lambda **kw: pytest.fail("ran before checking the options"))
    assert main(["demo", "--quiet", "--no-plot", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"rig demo: error: {message}") and len(err.strip().splitlines()) == 1


def test_draw_and_demo_keep_an_earlier_picture_unless_overwrite(tmp_path, capsys):
    """rig draw and rig demo replaced their PNG on every run; now, as the other commands, only with --overwrite
    (refused before the run: demo's 6 s flight is not flown for nothing)."""
    mine = tmp_path / "rig_frames.png"
    mine.write_bytes(b"mine")
    (tmp_path / "demo_roll.png").write_bytes(b"mine too")
    assert main(["draw", "--out", str(tmp_path)]) == 2
    assert "--out: " in capsys.readouterr().err and mine.read_bytes() == b"mine"
    assert main(["demo", "--t-final", "6", "--quiet", "--out", str(tmp_path)]) == 2
    assert "demo_roll.png is already there; give --overwrite" in capsys.readouterr().err
    assert (tmp_path / "demo_roll.png").read_bytes() == b"mine too"
    assert main(["draw", "--out", str(tmp_path), "--overwrite"]) == 0
    assert mine.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_continuation_command_sweeps_a_second_parameter(tmp_path, capsys):
    """--sweep: a line per swept value, loci.csv with the sweep's special points and unstable samples (those of
    rig_env.continuation_sweep), sweep.png; a bad --sweep refused by name."""
    out = tmp_path / "sweep"
    argv = ["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", "2", "-3", "101", "--aero-model", "unsteady",
            "--sweep", "hawk_aero.sep_cp_travel", "0.08", "0.12", "3", "--params", str(rig_env.params.PAPER_FILE), "--out", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "sweep 1/3: hawk_aero.sep_cp_travel = 0.08 c: 2 fold, 0 hopf" in text and "sweep 2/3: hawk_aero.sep_cp_travel = 0.1 c: 2 fold, 2 hopf" in text
    assert sorted(p.name for p in out.iterdir()) == ["loci.csv", "sweep.png"]
    rows = read(out / "loci.csv")
    assert rows[0] == ["hawk_aero.sep_cp_travel (c)", "kind", "hawk_elevator (deg)", "model_pitch (deg)", "frequency (Hz)", "note"]
    sw = rig_env.continuation_sweep(rig_env.RigParams.paper(), sweep="hawk_aero.sep_cp_travel", sweep_values=np.linspace(0.08, 0.12, 3),
                                    free_dofs=("model_pitch",), parameter="hawk_elevator", values=np.linspace(2, -3, 101), aero_model="unsteady")
    hopf = np.array([[float(r[0]), float(r[2])] for r in rows[1:] if r[1] == "hopf"])
    assert np.allclose(hopf, sw.locus("hopf"), atol=1e-8)
    assert sum(r[1] == "unstable" for r in rows[1:]) == len(sw.unstable())
    assert main(argv) == 2 and "loci.csv, sweep.png already there" in capsys.readouterr().err
    assert main(["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", "2", "-3", "5",
                 "--sweep", "hawk_aero.sep_cp_travel", "a", "0.1", "3", "--out", str(tmp_path / "bad")]) == 2
    assert "--sweep hawk_aero.sep_cp_travel a 0.1 3: FIRST, LAST and POINTS must be numbers" in capsys.readouterr().err
    assert main(["continuation", "--free", "model_pitch", "--parameter", "hawk_elevator", "--values", "2", "-3", "5",
                 "--sweep", "airspeed", "15", "90", "3", "--out", str(tmp_path / "bad2")]) == 2
    assert "sweep_values: airspeed 15..90 m/s is outside the allowed range" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists() and not (tmp_path / "bad2").exists()
