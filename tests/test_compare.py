"""The comparison: paired conditions, reproducible numbers, files written, skipped laws, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from controllers.laws.base import CONTROLLERS, Controller, register
from controllers.evaluation.compare import compare
from controllers.evaluation.evaluate import NOMINAL, ROBUST, evaluate
from rig_cli.main import main


def test_paired_blocks_see_identical_episodes():
    """The same law twice in one batch: identical metrics, so the blocks ran on identical conditions."""
    res = evaluate({"a": "pid", "b": "pid"}, "velocity_vector_roll", n_episodes=3, seed=5, conditions=NOMINAL)
    assert res.paired
    for key in ("rms_error", "control_effort", "success"):
        np.testing.assert_array_equal(res.metrics["a"][key], res.metrics["b"][key])
    assert np.ptp(res.metrics["a"]["rms_error"]) > 0  # and the episodes differ from one another


def test_robust_mode_spreads_aero_and_friction():
    r = ROBUST.randomise
    lo, hi = r["comp_aero.CLde"]
    assert lo == pytest.approx(0.8 * 1.694) and hi == pytest.approx(1.2 * 1.694)
    lo, hi = r["hawk_aero.CMalpha"]  # negative derivative: ordered bounds
    assert lo == pytest.approx(1.2 * -0.52) and hi == pytest.approx(0.8 * -0.52)
    assert "friction.rig_roll.Fc" in r and "comp_aero.CL0" not in r  # zero values are not spread


@pytest.mark.slow
def test_compare_is_reproducible_and_writes_its_files(tmp_path, capsys):
    kw = dict(tasks=["velocity_vector_roll"], kinds=["pid", "lqr"], episodes=3, seed=2, modes=["nominal", "robust"], progress=False)
    a = compare(out_dir=tmp_path / "a", **kw)
    b = compare(out_dir=None, **{**kw, "modes": ["nominal"]})
    assert [r for r in a.rows if r["mode"] == "nominal"] == b.rows  # same seed, same numbers
    out = capsys.readouterr().out
    assert "success" in out and "RMS err" in out and "robust" in out
    for name in ("summary.json", "summary.csv", "report.md", "metrics.png", "history_velocity_vector_roll.png"):
        assert (tmp_path / "a" / name).stat().st_size > 0, name
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    res = summary["results"]["velocity_vector_roll"]
    assert set(res) == {"nominal", "robust"} and all(set(res[m]["laws"]) == {"pid", "lqr"} for m in res)
    assert summary["settings"]["seed"] == 2 and summary["schema_version"] == 1
    assert set(summary["margins"]["velocity_vector_roll"]) == {"pid", "lqr"}
    assert len((tmp_path / "a" / "summary.csv").read_text().strip().splitlines()) == 5


def test_a_law_without_a_policy_is_skipped_with_a_note(capsys):
    @register("_no_policy")
    class NoPolicy(Controller):
        def __init__(self, spec, num_envs=1):
            raise FileNotFoundError(f"no shipped policy for {spec.task}")

        def reset(self, mask=None): ...

        def act(self, obs): ...

    try:
        cmp = compare(tasks=["velocity_vector_roll"], kinds=["pid", "_no_policy"], episodes=2, modes=["nominal"], out_dir=None, progress=False)
    finally:
        CONTROLLERS.pop("_no_policy")
    assert [r["law"] for r in cmp.rows] == ["pid"]
    assert cmp.skipped and "no shipped policy" in cmp.skipped[0]["reason"]
    assert "_no_policy skipped" in capsys.readouterr().out


def test_cli_compare_errors_are_one_line(capsys):
    assert main(["compare", "--controllers", "nope", "--out", "unused"]) == 2
    err = capsys.readouterr().err
    assert "unknown" in err and "nope" in err and "Traceback" not in err
    with pytest.raises(SystemExit):
        main(["compare", "--help"])


def test_cli_version_and_help_list_choices_and_units(capsys):
    """rig --version prints the installed distribution's version (rig_env.__version__ when not installed)."""
    from importlib.metadata import PackageNotFoundError, version

    import rig_env

    with pytest.raises(SystemExit) as ex:
        main(["--version"])
    assert ex.value.code == 0
    try:
        want = version("rig_env")
    except PackageNotFoundError:
        want = rig_env.__version__
    assert capsys.readouterr().out.strip() == f"rig {want}"
    with pytest.raises(SystemExit):
        main(["compare", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "velocity_vector_roll" in text and "pid" in text and "nominal" in text
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "m/s" in text and "deg" in text and ", s" in text
