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
    # a misspelt task exited 1 only when training began; a thread count beyond the machine's was taken; an --out that
    # is a file (or lies under one) ended in mkdir's traceback
    (["--task", "bank_to_bnk"], "--task 'bank_to_bnk': unknown (did you mean 'bank_to_bank'?)"),
    (["--threads", "100000"], "--threads = 100000: allowed range [1, "),
    (["--out", "AFILE"], "--out AFILE: is a file, not a folder"),
    (["--out", "AFILE/run"], "--out AFILE/run: lies under AFILE, a file, not a folder"),
])
def test_bad_arguments_are_refused(capsys, argv, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "AFILE").write_text("mine")
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


# ---------------------------------------------------------------- settings files (controllers/design/hyperparams/*.toml)
def test_shipped_settings_files_cover_every_task_and_parse():
    """Both shipped files load for every task; PPO has its own table for every task (none falls back to defaults)."""
    import tomllib

    from controllers.design.rl_hyperparams import default_file, settings
    from rig_env.envs.tasks import TASKS

    ppo_tables = tomllib.loads(default_file("ppo").read_text())
    assert set(TASKS) <= set(ppo_tables)
    for task in TASKS:
        for algo in ("ppo", "sac"):
            s = settings(algo, task)
            assert s.num_envs > 0 and s.timesteps > 0 and "learning_rate" in s.algo_kwargs


_GOOD = """
[defaults]
num_envs = 32
timesteps = 1000
eval_every = 500
normalize = true
clip_obs = 5.0
"""


def test_task_table_overrides_defaults_key_by_key(tmp_path):
    from controllers.design.rl_hyperparams import settings

    f = tmp_path / "mine.toml"
    f.write_text(_GOOD + """[defaults.algo]
n_steps = 16
batch_size = 128
[defaults.algo.policy_kwargs]
net_arch = [32, 32]
log_std_init = -1.0
[bank_to_bank]
num_envs = 8
error_reset = { entry = "roll_error", bound = 2.0 }
[bank_to_bank.algo]
n_steps = 8
[bank_to_bank.algo.policy_kwargs]
activation_fn = "relu"
""")
    s = settings("ppo", "bank_to_bank", f)
    assert (s.num_envs, s.timesteps, s.clip_obs, s.error_reset) == (8, 1000, 5.0, ("roll_error", 2.0))
    assert s.algo_kwargs["n_steps"] == 8 and s.algo_kwargs["batch_size"] == 128
    assert s.algo_kwargs["policy_kwargs"] == {"net_arch": [32, 32], "log_std_init": -1.0, "activation_fn": "relu"}
    import torch

    assert s.sb3_kwargs()["policy_kwargs"]["activation_fn"] is torch.nn.ReLU
    other = settings("ppo", "velocity_vector_roll", f)  # no table: the defaults
    assert other.num_envs == 32 and other.error_reset is None




@pytest.mark.parametrize("extra, message", [
    ("[bank_to_bank]\nnum_env = 8\n", "[bank_to_bank].num_env: unknown field; allowed: ["),
    ("[bank_to_bank]\nnum_envs = 0\n", "[bank_to_bank].num_envs = 0: must be a positive integer"),
    ("[bank_to_bank]\nnormalize = 1\n", "[bank_to_bank].normalize = 1: must be true or false"),
    ("[bank_to_bank.algo]\nn_stepz = 8\n", "[bank_to_bank].algo.n_stepz: unknown field; allowed: ["),
    ("[bank_to_bank.algo]\ngamma = 1.5\n", "[bank_to_bank].algo.gamma = 1.5: must be a number in (0, 1]"),
    ("[bank_to_bank.algo]\nbuffer_size = 10\n", "[bank_to_bank].algo.buffer_size: unknown field"),  # a SAC field in a PPO file
    ("[bank_to_bank.algo.policy_kwargs]\nactivation_fn = \"gelu\"\n", "activation_fn = 'gelu': must be one of ['tanh', 'relu']"),
    ("[bank_to_bank.algo.policy_kwargs]\nnet_arch = [64, -1]\n", "net_arch = [64, -1]: must be a list of positive layer widths"),
    ("[bank_to_bank]\nerror_reset = { entry = \"roll_error\" }\n", "error_reset: needs both 'entry' and 'bound'"),
    ("[bank_too_bank]\nnum_envs = 8\n", "table(s) ['bank_too_bank']: not a task"),
    ("[bank_to_bank\n", "not valid TOML"),
    ("[bank_to_bank]\nacting_surfaces = \"yes\"\n", "[bank_to_bank].acting_surfaces = 'yes': must be true or false"),
])
def test_bad_settings_are_refused_by_name(tmp_path, extra, message):
    from controllers.design.rl_hyperparams import HyperparamError, settings

    f = tmp_path / "bad.toml"
    f.write_text(_GOOD + extra)
    with pytest.raises(HyperparamError) as e:
        settings("ppo", "bank_to_bank", f)
    assert message in str(e.value) and str(f) in str(e.value)


@pytest.mark.parametrize(("write", "message"), [
    (lambda f: f.write_bytes(bytes(range(256))), "not a text file (TOML is UTF-8 text)"),  # was a UnicodeDecodeError traceback
    (lambda f: f.mkdir(), "a folder, not a settings file"),
])
def test_a_settings_file_that_is_no_text_file_is_refused_by_name(tmp_path, write, message):
    from controllers.design.rl_hyperparams import HyperparamError, settings

    f = tmp_path / "bad.toml"
    write(f)
    with pytest.raises(HyperparamError) as e:
        settings("ppo", "bank_to_bank", f)
    assert str(e.value) == f"{f}: {message}"


def test_rig_train_refuses_a_bad_settings_file_naming_the_field(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text(_GOOD + "[bank_to_bank.algo]\nlearning_rate = -1\n")
    with pytest.raises(SystemExit) as e:
        main(["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--hyperparams", str(f), "--out", str(tmp_path / "r")])
    assert "[bank_to_bank].algo.learning_rate = -1: must be a positive number" in str(e.value.code)


def test_default_conditions_are_the_comparisons_nominal_ones(tmp_path):
    """Without --conditions a run trains (and is evaluated) under the nominal randomised conditions, the task's
    airspeed floor applied as the comparison applies it (bank-to-bank from 17 m/s); --conditions none keeps the task's
    own defaults."""
    assert main(["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--out", str(tmp_path / "a")]) == 0
    assert main(["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--conditions", "none", "--out", str(tmp_path / "b")]) == 0
    nominal = json.loads(json.dumps(MODES["nominal"].env_fields("bank_to_bank")))
    assert nominal["airspeed"] == [17.0, 25.0] and MODES["nominal"].airspeed == (15.0, 25.0)
    assert load(tmp_path / "a" / "policy.json").provenance["env_overrides"] == nominal
    assert load(tmp_path / "b" / "policy.json").provenance["env_overrides"] == {}


def test_an_existing_run_is_never_overwritten_silently(tmp_path):
    argv = ["--algo", "ppo", "--task", "bank_to_bank", *TINY, "--out", str(tmp_path)]
    assert main(argv) == 0
    before = (tmp_path / "policy.json").read_bytes()
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert "already holds a run" in str(e.value.code) and "--resume" in str(e.value.code)
    assert (tmp_path / "policy.json").read_bytes() == before
    assert main([*argv, "--overwrite"]) == 0


def test_resume_continues_the_timestep_count_and_reloads_the_normalisation(tmp_path, capsys):
    """A run cut at its budget and resumed with a larger one starts from the last checkpoint: the model's
    timestep count goes on from it (not from 0) and the observation statistics are the checkpoint's, not fresh."""
    import pickle

    from stable_baselines3.common.vec_env import VecNormalize

    from controllers.design import rl_train

    run = tmp_path / "run"
    argv = ["--algo", "ppo", "--task", "bank_to_bank", "--num-envs", "8", "--timesteps", "1024", "--checkpoint-every", "512",
            "--eval-every", "512", "--eval-episodes", "2", "--final-episodes", "2", "--no-stop", "--out", str(run)]
    assert main(argv) == 0
    ckpt, vn, _, n = rl_train.last_checkpoint(run)
    assert n == 1024 and vn is not None
    with open(vn, "rb") as f:
        saved = pickle.load(f)
    assert saved.obs_rms.count > 1000  # statistics of 1024 steps, not a fresh VecNormalize's 1e-4

    seen = {}
    real_load = VecNormalize.load

    def spy(path, venv):
        v = real_load(path, venv)
        seen["count"], seen["mean"] = v.obs_rms.count, v.obs_rms.mean.copy()
        return v

    VecNormalize.load = staticmethod(spy)
    try:
        with pytest.raises(SystemExit):
            main(["--resume", str(run), "--out", str(tmp_path / "x")])
        assert "no --seeds or --out" in capsys.readouterr().err
        assert main(["--resume", str(run), "--timesteps", "2048"]) == 0
    finally:
        VecNormalize.load = staticmethod(real_load)
    assert seen["count"] == saved.obs_rms.count
    np.testing.assert_array_equal(seen["mean"], saved.obs_rms.mean)
    prov = load(run / "policy.json").provenance
    assert prov["resumed_from"]["timesteps"] == 1024
    assert prov["timesteps"] == 2048  # 1024 done + 1024 more, not 2048 more
    assert [p["timesteps"] for p in prov["eval_during_training"]["curve"]] == [512, 1024, 1536, 2048]
    assert rl_train.last_checkpoint(run)[3] == 2048


def test_resume_needs_a_run_folder(tmp_path):
    with pytest.raises(SystemExit, match="no run.json there"):
        main(["--resume", str(tmp_path)])


def test_warm_start_is_ppo_only(capsys):
    for argv in (["--algo", "sac", "--task", "free_flight_emulation", "--warm-start", "lqr"],
                 ["--resume", "runs/x", "--warm-start", "lqr"],
                 ["--algo", "ppo", "--task", "free_flight_emulation", "--warm-start", "lqr", "--backend", "ray"]):
        with pytest.raises(SystemExit) as e:
            parse_args(argv)
        assert e.value.code == 2 and "--warm-start" in capsys.readouterr().err


def test_warm_start_from_the_lqr_flies_free_flight_emulation(tmp_path):
    """--warm-start lqr clones the task's designed LQR into the policy before PPO (one update here): the exported
    policy earns clearly more of the task's reward and succeeds more often than the same run started cold, whose
    untrained policy nearly holds still (zero action: about 160 of 480, no success; the LQR about 250, 60 %:
    scripts/reward_along_lqr.py), and the provenance records the fit."""
    common = ["--algo", "ppo", "--task", "free_flight_emulation", "--timesteps", "1", "--num-envs", "32", "--eval-every",
              "100000", "--eval-episodes", "4", "--final-episodes", "32", "--no-progress"]
    assert main([*common, "--out", str(tmp_path / "cold")]) == 0
    assert main([*common, "--warm-start", "lqr", "--warm-start-samples", "20000", "--out", str(tmp_path / "warm")]) == 0
    cold = load(tmp_path / "cold" / "policy.json").provenance
    warm = load(tmp_path / "warm" / "policy.json").provenance
    assert cold["warm_start"] is None and warm["warm_start"]["kind"] == "lqr"
    fit = warm["warm_start"]
    assert fit["samples"] >= 20000 and fit["action_mse_after"] < 0.2 * fit["action_mse_before"]
    assert fit["clone_eval"]["episodes"] == 4 and (tmp_path / "warm" / "warm_start.json").is_file()  # the clone before PPO
    c, w = cold["final_eval"], warm["final_eval"]
    assert w["mean_return"] > c["mean_return"] + 0.1 * w["max_return"], (c, w)
    assert w["success_rate"] >= c["success_rate"] + 0.25, (c, w)


def test_rig_train_refusals_exit_2_in_one_line(tmp_path, capsys):
    """`rig train`'s refusals raised inside the trainer (SystemExit with the message) exited 1, the others 2; through
    the `rig` command every refusal is now one line on stderr and exit 2."""
    from rig_cli.main import main as rig

    assert rig(["train", "--algo", "ppo", "--task", "bank_to_bank", *TINY, "--out", str(tmp_path / "r"), "--env", "turbulance=0.01"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig train: environment settings") and "unknown configuration name(s) ['turbulance']" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "r" / "policy.json").exists()
