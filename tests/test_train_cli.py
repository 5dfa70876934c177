"""rig train's training conditions (--conditions, --env) and seed sweeps (--seeds, controllers/design/rl_seeds.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from controllers.evaluation.evaluate import MODES
from controllers.laws.artefact import load
from controllers.design.rl_train import main, parse_args

TINY = ["--timesteps", "1", "--eval-every", "100000", "--eval-episodes", "4", "--final-episodes", "8"]


@pytest.mark.parametrize("argv, message", [
    (["--env", "turbulence"], "expected KEY=VALUE"),
    (["--seeds", "1", "1"], "repeated seed"),
    (["--seeds", "1", "2", "--ship"], "--ship takes one --seed"),
    (["--seed", "1", "--seeds", "2"], "not allowed with argument"),
    (["--seeds", "-1"], "must be >= 0"),
])
def test_bad_arguments_are_refused(capsys, argv, message):
    with pytest.raises(SystemExit) as e:
        parse_args(["--algo", "ppo", "--task", "bank_to_bank", *argv])
    assert e.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("env, message", [
    (["--env", "turbulance=0.01"], "unknown configuration name(s) ['turbulance']"),
    (["--env", "turbulence=0.5"], "turbulence = 0.5 (fraction of airspeed): allowed range [0.0, 0.3]"),
    (["--env", "task=bank_to_bank"], "the task is --task"),
])
def test_bad_environment_settings_name_the_field(tmp_path, env, message):
    with pytest.raises(SystemExit) as e:
        main(["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--out", str(tmp_path), *env])
    assert message in str(e.value.code)


def test_two_seeds_under_the_comparison_conditions(tmp_path):
    """Each seed trains its own run under the table's settings, then --conditions, then --env (last wins); the
    policies record those settings; seeds.json's statistics are those of the runs' own final evaluations."""
    code = main(["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--seeds", "3", "5", "--conditions", "nominal",
                 "--env", "turbulence=0.02", "--env", "airspeed=[16, 24]", "--out", str(tmp_path)])
    assert code == 0
    summary = json.loads((tmp_path / "seeds.json").read_text())
    assert summary["seeds"] == [3, 5] and (tmp_path / "seeds.png").is_file()
    expected = json.loads(json.dumps(MODES["nominal"].env_fields()))
    expected.update(turbulence=0.02, airspeed=[16, 24])
    finals = []
    for seed in (3, 5):
        prov = load(tmp_path / f"s{seed}" / "policy.json").provenance  # the policy is a rig-law artefact, the training record its provenance
        assert prov["seed"] == seed
        assert prov["env_overrides"] == expected
        assert prov["final_eval"]["seed"] == seed + 20_000
        finals.append(prov["final_eval"])
    for m in ("success_rate", "rms_error_deg", "mean_return"):
        v = np.array([f[m] for f in finals])
        assert summary["final_eval"][m]["mean"] == pytest.approx(v.mean(), rel=1e-12)
        assert summary["final_eval"][m]["std"] == pytest.approx(v.std(ddof=1), rel=1e-12, abs=1e-12)
    assert finals[0]["rms_error_deg"] != finals[1]["rms_error_deg"]  # different seeds, different runs


def test_summary_refuses_runs_of_different_settings(tmp_path):
    from controllers.design.rl_seeds import summarise

    for name, extra in (("a", []), ("b", ["--env", "turbulence=0.02"])):
        assert main(["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--seed", "1", "--out", str(tmp_path / name), *extra]) == 0
    with pytest.raises(ValueError, match="differ from the first run's"):
        summarise([tmp_path / "a" / "policy.json", tmp_path / "b" / "policy.json"], tmp_path / "s", "x", 0.95)
