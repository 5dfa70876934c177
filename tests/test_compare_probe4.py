"""rig compare's user-facing surface, probed: names given twice or not at all, the API's conditions and record, the
tables' headings under [conditions], an interrupted run's folder, an empty --out, evaluate's task and counts."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

import controllers.evaluation.compare as cmp_mod
from controllers.evaluation.compare import check_out_dir, compare, write_files
from controllers.evaluation.config import parse
from controllers.evaluation.evaluate import evaluate
from rig_cli.main import main

TASK = "velocity_vector_roll"
SMALL = dict(tasks=[TASK], kinds=["pid"], episodes=2, modes=["nominal"], progress=False)




def _cli(args: list[str], capsys) -> tuple[int, str]:
    rc = main(["compare", *args])
    return rc, capsys.readouterr().err


@pytest.mark.parametrize("option, names", [
    ("--tasks", [TASK, TASK]),
    ("--controllers", ["pid", "pid"]),
    ("--modes", ["nominal", "nominal"]),
])
def test_a_name_given_twice_is_refused_naming_the_option(tmp_path, capsys, nothing_runs, option, names):
    base = {"--tasks": [TASK], "--controllers": ["pid"], "--modes": ["nominal"]}
    base[option] = names
    args = [a for k, v in base.items() for a in (k, *v)] + ["--episodes", "1", "--out", str(tmp_path / "o")]
    rc, err = _cli(args, capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert option in err and "more than once" in err and names[0] in err
    assert not (tmp_path / "o").exists()


def test_a_name_given_twice_in_the_config_file_is_refused_naming_the_key(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text(f'tasks = ["{TASK}", "{TASK}"]\n')
    with pytest.raises(ValueError, match=r"c\.toml: tasks = .*given more than once"):
        parse(f, [TASK], ["pid"], ["nominal"])


@pytest.mark.parametrize("kw, message", [
    ({"tasks": []}, r"--tasks: an empty list"),
    ({"modes": []}, r"--modes: an empty list"),
    ({"tasks": TASK}, r"--tasks 'velocity_vector_roll': must be a list"),
    ({"kinds": "pid"}, r"--controllers 'pid': must be a list"),
    ({"conditions": {"turbulance": 0.1}}, r"conditions: unknown key\(s\) \['turbulance'\]; allowed: \['airspeed'"),
    ({"conditions": {"airspeed": (25.0, 15.0)}}, r"conditions\.airspeed = \[25\.0, 15\.0\]: low must not exceed high"),
    ({"record": -1}, r"record = -1: must be an integer >= 0"),
    ({"record": 0}, r"record = 0: the history figures need at least one recorded episode"),
    ({"out_dir": ""}, r"--out '': an empty folder name"),
])
def test_bad_api_arguments_are_one_line_value_errors_before_anything_runs(tmp_path, nothing_runs, kw, message):
    args = {**SMALL, "out_dir": tmp_path / "o", "stream": io.StringIO(), **kw}
    with pytest.raises(ValueError, match=message):
        compare(**args)
    assert not (tmp_path / "o").exists()


def test_evaluate_refuses_an_unknown_task_a_bool_count_and_a_negative_record():
    with pytest.raises(ValueError, match=r"task = 'nope': unknown; valid names: \["):
        evaluate({"pid": "pid"}, "nope", n_episodes=2)
    with pytest.raises(ValueError, match=r"n_episodes = True: must be a positive integer"):
        evaluate({"pid": "pid"}, TASK, n_episodes=True)
    with pytest.raises(ValueError, match=r"record = -1: must be an integer >= 0"):
        evaluate({"pid": "pid"}, TASK, n_episodes=2, record=-1)


def test_chunk_size_help_states_the_range_the_command_accepts(capsys):
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "episodes per Ray task, 2..100000" in text  # --chunk-size 1 is refused (tests/test_ray_compare.py)


# ---------------------------------------------------------------------- one small run: headings and an interrupted write
@pytest.fixture(scope="module")
def flown():
    """One law, one task, two episodes at 19-21 m/s in 5 % gusts (the [conditions] overrides), no files."""
    log = io.StringIO()
    cmp = compare(**SMALL, out_dir=None, stream=log, conditions={"airspeed": (19.0, 21.0), "turbulence": 0.05})
    return cmp, log.getvalue()


def test_the_table_heading_states_the_conditions_flown_not_the_defaults(flown):
    _, log = flown
    heading = next(line for line in log.splitlines() if line.startswith("nominal: 2 episodes"))
    assert "airspeed 19-21 m/s, 5 % gusts" in heading, heading
    assert "15-25" not in heading and "1 % gusts" not in heading, heading


def test_the_default_heading_is_unchanged():
    assert cmp_mod._mode_note("nominal", cmp_mod.MODES["nominal"]) == "airspeed 15-25 m/s, 1 % gusts, sensor noise, parameter spread"


def test_a_run_stopped_while_drawing_does_not_block_the_next_one(flown, tmp_path, monkeypatch):
    cmp, _ = flown
    out = tmp_path / "o"

    def stopped(*a, **k):
        raise KeyboardInterrupt  # the user's Ctrl-C while the figures are drawn

    monkeypatch.setattr(cmp_mod.report.figures, "plot_distributions", stopped)
    with pytest.raises(KeyboardInterrupt):
        write_files(cmp, out, io.StringIO())
    assert (out / f"history_{TASK}.png").is_file()  # drawn before the stop
    monkeypatch.undo()
    note = io.StringIO()
    ours = check_out_dir(out, False, note, [TASK])  # no "not written by an earlier rig compare" refusal
    assert f"history_{TASK}.png" in ours and "summary.json" in ours
    write_files(cmp, out, note, ours)
    files = json.loads((out / "summary.json").read_text())["settings"]["files"]
    assert sorted(files) == sorted(p.name for p in out.iterdir())


def test_the_incomplete_success_caveat_is_a_whole_sentence(flown):
    cmp, _ = flown
    caveats = [c for rec in cmp.recommendations[TASK].values() for c in rec["caveats"]]
    short = [c for c in caveats if "does not exclude a rate below" in c]
    assert short and all(c.endswith("more episodes would narrow the interval") for c in short), short


# ---------------------------------------------------------------------- the API's other arguments
@pytest.mark.parametrize("kw, message", [
    ({"rule": {"min_sucess": 0.9}}, r"score: unknown key\(s\) \['min_sucess'\]; allowed: \['min_success'"),
    ({"rule": {"min_success": 1.5}}, r"score\.min_success = 1\.5: must be a number in \[0, 1\]"),
    ({"rule": 0.9}, r"rule = 0\.9: must be a ScoreRule or a mapping"),
    ({"policies": "runs/a/bank_to_bank_ppo.json"}, r"--policy 'runs/a/bank_to_bank_ppo\.json': must be a list of law files"),
])
def test_a_bad_rule_or_a_bare_policy_path_is_refused_before_anything_runs(tmp_path, nothing_runs, kw, message):
    with pytest.raises(ValueError, match=message):
        compare(**{**SMALL, "out_dir": tmp_path / "o", "stream": io.StringIO(), **kw})
    assert not (tmp_path / "o").exists()


def test_a_rule_as_a_mapping_is_read_as_the_config_file_s_score_table(flown):
    from controllers.evaluation.score import ScoreRule

    assert cmp_mod.check_rule({"min_success": 0.9}) == ScoreRule(min_success=0.9)


def test_evaluate_refuses_a_list_of_laws_and_unknown_conditions_and_takes_a_mode_name():
    with pytest.raises(ValueError, match=r"laws = \['pid'\]: must be a mapping name -> kind"):
        evaluate(["pid"], TASK, n_episodes=2)
    with pytest.raises(ValueError, match=r"conditions = 'stormy': must be a Conditions or a mode name from \['gusty'"):
        evaluate({"pid": "pid"}, TASK, n_episodes=2, conditions="stormy")
    res = evaluate({"pid": "pid"}, TASK, n_episodes=1, conditions="robust", record=1)
    assert res.conditions == "robust"


def test_help_names_every_config_key_and_how_a_law_with_gains_joins(capsys):
    from dataclasses import fields

    from controllers.evaluation.config import CompareConfig

    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    config_help = text[text.index("--config FILE.toml the comparison"):text.index("--overwrite replace")]
    for f in fields(CompareConfig):
        assert f.name in config_help, f.name  # a key the help leaves out is one a user cannot find
    assert "linear takes its gains" in text and "--policy" in text


def test_the_report_states_the_conditions_flown(flown, tmp_path):
    cmp, _ = flown
    write_files(cmp, tmp_path, io.StringIO())
    text = (tmp_path / "report.md").read_text()
    assert "As flown: nominal airspeed 19-21 m/s, 5 % gusts" in text


def test_a_comparison_in_which_no_law_flies_is_one_error_and_writes_nothing(tmp_path, monkeypatch):
    def none_flies(kinds, task, n, fields, out, params=None):
        return {}, [{"task": task, "controller": k, "reason": "cannot"} for k in kinds]

    monkeypatch.setattr(cmp_mod, "_build", none_flies)  # as sac without a shipped policy: skipped with a note
    monkeypatch.setattr(cmp_mod, "precompile", lambda *a, **k: None)
    with pytest.raises(ValueError, match=r"--controllers pid: no law could fly velocity_vector_roll .*nothing written"):
        compare(**{**SMALL, "out_dir": tmp_path / "o", "stream": io.StringIO()})
    assert not (tmp_path / "o").exists()


def test_an_out_folder_that_cannot_be_created_is_refused_before_anything_runs(tmp_path, nothing_runs):
    with pytest.raises(ValueError, match=r"--out /proc/rig_compare_probe4/o: cannot be created"):
        compare(**{**SMALL, "out_dir": "/proc/rig_compare_probe4/o", "stream": io.StringIO()})
    fresh = tmp_path / "a" / "b"  # a folder that can be made is checked and not left behind by a refusal after it
    with pytest.raises(ValueError, match=r"--policy"):
        compare(**{**SMALL, "out_dir": fresh, "stream": io.StringIO(), "policies": [str(tmp_path / "missing.json")]})
    assert not (tmp_path / "a").exists()


@pytest.mark.parametrize("option, text, needle", [
    ("--policy", None, "--policy {path}: cannot read"),
    ("--policy", "{}", "--policy {path}: missing key(s)"),
    ("--params", None, "--params {path}: "),
    ("--params", "x = 1\n", "--params {path}: unknown field(s) ['x']"),
])
def test_a_bad_law_or_parameter_file_is_refused_naming_the_option(tmp_path, capsys, nothing_runs, option, text, needle):
    path = tmp_path / ("f.json" if option == "--policy" else "f.toml")
    if text is not None:
        path.write_text(text)
    rc, err = _cli(["--tasks", TASK, "--controllers", "pid", "--modes", "nominal", "--episodes", "1", option, str(path),
                    "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert needle.format(path=path) in err, err


@pytest.mark.parametrize("option, value, needle", [
    ("--tasks", "bank_to_bnk", "--tasks bank_to_bnk: unknown (did you mean 'bank_to_bank'?); allowed: bank_to_bank,"),
    ("--controllers", "lqg", "--controllers lqg: unknown (did you mean 'lqr'?); allowed: linear, lqr, pid"),
])
def test_a_misspelt_task_or_law_is_refused_naming_the_option_and_the_closest_name(tmp_path, capsys, nothing_runs, option, value, needle):
    base = {"--tasks": TASK, "--controllers": "pid"}
    base[option] = value
    rc, err = _cli([a for k, v in base.items() for a in (k, v)] + ["--modes", "nominal", "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and needle in err, err


def test_backend_local_on_the_command_line_sets_aside_the_file_s_ray_settings(tmp_path, capsys, monkeypatch):
    f = tmp_path / "c.toml"
    f.write_text('backend = "ray"\nchunk_size = 8\naddress = "auto"\n')
    seen = {}
    monkeypatch.setattr(cmp_mod, "compare", lambda **kw: seen.update(kw))
    rc, err = _cli(["--config", str(f), "--backend", "local", "--tasks", TASK, "--out", str(tmp_path / "o")], capsys)
    assert rc == 0, err
    assert seen["backend"] == "local" and seen["address"] is None and seen["chunk_size"] is None
    f.write_text('chunk_size = 8\n')  # a file's own inconsistency is still refused (the file says no backend = "ray")
    monkeypatch.undo()
    rc, err = _cli(["--config", str(f), "--tasks", TASK, "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "--chunk-size 8: only with --backend ray" in err, err


def test_the_recorded_command_of_an_api_run_names_its_conditions(flown):
    cmp, _ = flown
    cmd = cmp.settings["command"]
    assert cmd.startswith("rig compare --episodes 2 --seed 0 --tasks velocity_vector_roll --controllers pid --modes nominal")
    assert "[conditions] airspeed = [19.0, 21.0], turbulence = 0.05" in cmd, cmd  # without it the line flies 15-25 m/s, 1 %
