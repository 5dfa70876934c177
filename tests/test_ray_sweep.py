"""``rig sweep`` and ``rig train --seeds ... --backend ray`` on Ray Tune: every trial seeded, a node lost mid-sweep
and a sweep stopped and resumed lose no trial, the results in one table and the best policy exported.

Trials are tiny (2048 environment steps, 16 environments, checkpoints every 512 steps) on the local multi-node
cluster of tests/conftest.py (``ray_cluster``).
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import pytest

from controllers.design.rl_train import train_trial
from controllers.design.sweep import SweepConfig, parse, run_sweep
from rig_cli.main import main as rig

TINY = """algo = "ppo"
tasks = ["bank_to_bank"]
seeds = [0, 1]
timesteps = 2048
storage = "store"
name = "{name}"
checkpoint_every = 512
eval_every = 1024
eval_episodes = 2
final_episodes = 2
max_failures = 3
[grid]
num_envs = [16]
"algo.batch_size" = [256]
"algo.learning_rate" = [3e-4, 1e-3]
"""


def _config(tmp: Path, name: str) -> tuple[Path, SweepConfig]:
    path = tmp / f"{name}.toml"
    path.write_text(TINY.format(name=name))
    return path, parse(path)


def _results(folder: Path) -> dict[str, list[dict[str, Any]]]:
    """Every trial folder's reported results (result.json lines), by trial folder name."""
    out = {}
    for f in folder.glob("trial_*/result.json"):
        try:
            lines = [json.loads(x) for x in f.read_text().splitlines() if x.strip()]
        except ValueError:  # a line being written
            continue
        if lines:
            out[f.parent.name] = lines
    return out


@pytest.fixture
def no_ray(monkeypatch: pytest.MonkeyPatch) -> None:
    """A test that must not reach Ray: starting a session fails it (quickly: no cluster starts)."""
    from rig_env import distributed

    def session(address: str | None = None, **kw: Any) -> Any:
        raise AssertionError("a Ray session was started")

    monkeypatch.setattr(distributed, "session", session)


class _Tune:
    """Ray Tune without a cluster: the session a no-op, ``Tuner(...).fit()`` calls ``on_fit`` (if set) and returns
    ``grid`` (Tune's results as fold reads them)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        import contextlib

        from ray import tune

        from rig_env import distributed

        self.grid: list[Any] = []
        self.on_fit: Any = None
        self.fits = 0
        fake = self

        class Tuner:
            can_restore = staticmethod(tune.Tuner.can_restore)

            def __init__(self, *a: Any, **kw: Any) -> None:
                pass

            def fit(self) -> list[Any]:
                fake.fits += 1
                if fake.on_fit is not None:
                    fake.on_fit()
                return fake.grid

        monkeypatch.setattr(distributed, "session", lambda address=None, **kw: contextlib.nullcontext())
        monkeypatch.setattr(tune, "Tuner", Tuner)

    def trial(self, folder: Path, name: str, seed: int, done: bool) -> None:
        """A trial of ``folder``'s sweep in the grid: finished (its final result logged) or errored."""
        import types

        (folder / name).mkdir(parents=True)
        lines = [{"timesteps": 512, "final": False, "attempt": 1}] + ([FINAL] if done else [])
        (folder / name / "result.json").write_text("".join(json.dumps(x) + "\n" for x in lines))
        self.grid.append(types.SimpleNamespace(metrics=lines[-1], config={"task": "bank_to_bank", "seed": seed, "hp": {}},
                                               path=str(folder / name), error=None if done else RuntimeError("failed"),
                                               checkpoint=None))


@pytest.fixture
def fake_tune(monkeypatch: pytest.MonkeyPatch) -> _Tune:
    pytest.importorskip("ray.tune")
    return _Tune(monkeypatch)


PLAIN = 'algo = "ppo"\ntasks = ["bank_to_bank"]\ntimesteps = 2048\ncheckpoint_every = 512\nstorage = "st"\nname = "x"\n'


@pytest.mark.parametrize("text, needle", [
    ('algo = "ppo"\ntasks = ["bank_to_bank"]\nwarp = 9\n', "unknown key(s) ['warp']"),
    ('algo = "ppo"\ntasks = ["nowhere"]\n', "tasks = ['nowhere']: distinct names from"),
    ('algo = "ppo"\ntasks = ["bank_to_bank"]\nseeds = [1, 1]\n', "seeds = [1, 1]: a non-empty list of distinct integers"),
    ('algo = "ppo"\ntasks = ["bank_to_bank"]\n[grid]\n"algo.learning_rate" = [-1.0]\n', "learning_rate = -1.0: must be a positive number"),
    ('algo = "ppo"\ntasks = ["bank_to_bank"]\n[grid]\n"algo.warp" = [1]\n', "algo.warp: unknown field"),
    ('algo = "ppo"\ntasks = ["bank_to_bank"]\nmax_failures = -1\n', "max_failures = -1: must be an integer in [0, 100]"),
    ('algo = "ppo"\ntasks = ["bank_to_bank"]\nmetric = "luck"\n', "metric = 'luck': allowed"),
    # [env] checked when the file is read, as rig train checks --env (not by every trial failing on the cluster)
    (PLAIN + '[env]\nturbulense = 0.02\n', "[env] unknown configuration name(s) ['turbulense']; valid names:"),
    (PLAIN + '[env]\nturbulence = "lots"\n', "[env] turbulence = 'lots' (fraction of airspeed): allowed range"),
    (PLAIN + '[env]\ntask = "bank_to_bank"\n', "[env] task: not an environment setting"),
    (PLAIN + 'target_success = true\n', "target_success = True: must be a number in the range (0, 1]"),
    (PLAIN + '[grid]\n"algo.learning_rate" = [3e-4, 1e-3, 3e-4]\n', "grid.algo.learning_rate = [0.0003, 0.001, 0.0003]: "
                                                                     "the value 0.0003 is listed twice"),
])
def test_bad_sweep_file_is_a_one_line_error(text: str, needle: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            no_ray: None) -> None:
    (tmp_path / "s.toml").write_text(text)
    rc = rig(["sweep", str(tmp_path / "s.toml")])
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "st").exists()


@pytest.mark.parametrize("file, option", [("st", "storage"), ("st/x", "name")])
def test_storage_or_name_that_is_a_file_is_refused_before_ray(file: str, option: str, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str], no_ray: None) -> None:
    (tmp_path / "s.toml").write_text(PLAIN)
    (tmp_path / file).parent.mkdir(parents=True, exist_ok=True)
    (tmp_path / file).write_text("mine")
    rc = rig(["sweep", str(tmp_path / "s.toml")])
    err = capsys.readouterr().err
    assert rc == 2 and f"{option} {tmp_path / file}: is a file, not a folder" in err and "Traceback" not in err, err
    assert (tmp_path / file).read_text() == "mine"


@pytest.mark.parametrize("flags", [[], ["--overwrite"]])
def test_folder_that_is_not_a_sweep_is_refused_and_kept(flags: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        no_ray: None) -> None:
    (tmp_path / "s.toml").write_text(PLAIN)
    (tmp_path / "st" / "x" / "my_results").mkdir(parents=True)
    (tmp_path / "st" / "x" / "notes.txt").write_text("notes")
    (tmp_path / "st" / "x" / "my_results" / "a.csv").write_text("1,2\n")
    rc = rig(["sweep", str(tmp_path / "s.toml"), *flags])
    err = capsys.readouterr().err
    assert rc == 2 and f"{tmp_path / 'st' / 'x'}: not a sweep" in err and "holds a sweep" not in err, err
    assert (tmp_path / "st" / "x" / "notes.txt").read_text() == "notes"
    assert (tmp_path / "st" / "x" / "my_results" / "a.csv").read_text() == "1,2\n"


def test_overwrite_replaces_only_what_the_sweep_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_tune: _Tune) -> None:
    (tmp_path / "s.toml").write_text(PLAIN)
    folder = tmp_path / "st" / "x"
    old_trial = folder / "trial_0a1b2_00000_0_hp=,seed=0,task=bank_to_bank_2026-01-01_00-00-00"
    (old_trial / "checkpoint_000000").mkdir(parents=True)
    (folder / "summary").mkdir()
    theirs = ["sweep.toml.json", "books.json", "tuner.pkl", ".validate_storage_marker", "experiment_state-2026-01-01_00-00-00.json",
              "basic-variant-state-2026-01-01_00-00-00.json", "summary/sweep.csv", "summary/best_policy.json",
              f"{old_trial.name}/result.json"]
    mine = ["notes.txt", "summary/my_plot.png", "trial_notes/a.txt"]
    for f in theirs + mine:
        (folder / f).parent.mkdir(parents=True, exist_ok=True)
        (folder / f).write_text("{}")
    rc = rig(["sweep", str(tmp_path / "s.toml")])  # a sweep: refused without --overwrite
    assert rc == 2 and "holds a sweep; --resume continues it, --overwrite replaces it" in capsys.readouterr().err

    def at_fit() -> None:  # the old sweep gone before Tune runs the new one
        assert not old_trial.exists() and not (folder / "tuner.pkl").exists() and not (folder / "summary" / "sweep.csv").exists()
        fake_tune.trial(folder, "trial_ccccc_00000_0", 0, done=True)

    fake_tune.on_fit = at_fit
    rc = rig(["sweep", str(tmp_path / "s.toml"), "--overwrite"])
    captured = capsys.readouterr()
    assert rc == 0 and fake_tune.fits == 1, captured.err
    assert all((folder / f).read_text() == "{}" for f in mine)  # what the sweep did not write stays
    assert "kept what it did not write: ['notes.txt', 'summary/my_plot.png', 'trial_notes']" in captured.out
    assert json.loads((folder / "sweep.toml.json").read_text())["name"] == "x"
    assert json.loads((folder / "summary" / "sweep.json").read_text())["done"] == 1


@pytest.mark.parametrize("done, rc, needle", [((False,), 1, "no trial finished"), ((True, False), 1, "only 1 of the 2 trials finished"),
                                              ((True, True), 0, None)])
def test_sweep_exits_non_zero_unless_every_trial_finished(done: tuple[bool, ...], rc: int, needle: str | None, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str], fake_tune: _Tune) -> None:
    (tmp_path / "s.toml").write_text(PLAIN.replace('name = "x"', f"name = \"x\"\nseeds = {list(range(len(done)))}"))

    def at_fit() -> None:
        for i, d in enumerate(done):
            fake_tune.trial(tmp_path / "st" / "x", f"trial_{i}", i, d)

    fake_tune.on_fit = at_fit
    assert rig(["sweep", str(tmp_path / "s.toml")]) == rc
    err = capsys.readouterr().err
    if needle is None:
        assert "error" not in err, err
    else:
        assert len(err.strip().splitlines()) == 1 and err.startswith("rig sweep: error: ") and needle in err, err


def test_checkpoint_every_not_below_timesteps_is_warned(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "s.toml").write_text(PLAIN.replace("checkpoint_every = 512", "checkpoint_every = 4096"))
    parse(tmp_path / "s.toml")
    err = capsys.readouterr().err
    assert "warning: checkpoint_every = 4096 >= timesteps = 2048" in err and "lost trial restarts from scratch" in err, err
    (tmp_path / "s.toml").write_text(PLAIN)
    parse(tmp_path / "s.toml")
    assert "warning" not in capsys.readouterr().err


def test_rig_train_backend_ray_without_ray_names_the_extra(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    from controllers.design.rl_train import main

    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(SystemExit) as ex:
        main(["--algo", "ppo", "--task", "bank_to_bank", "--seeds", "0", "1", "--backend", "ray", "--out", str(tmp_path / "r")])
    assert ex.value.code == 2 and 'pip install -e ".[ray]"' in capsys.readouterr().err


FINAL = {"success_rate": 0.5, "rms_error_deg": 3.0, "mean_return": 10.0, "timesteps": 1024, "wall_time_s": 1.0,
         "trial_seconds": 1.0, "final": True, "attempt": 1, "resumed_from": None, "node": "n", "pid": 1}


def _trial_folder(root: Path, *, final_line: bool, final_checkpoint: str | None) -> Path:
    """A trial's folder as a stop can leave it: checkpoint_000000 at 512 steps; the final checkpoint_000001 whole
    (``"whole"``), cut short (``"short"``: no policy.json) or absent; result.json with or without the final line."""
    folder = root / "trial_x"
    (folder / "checkpoint_000000").mkdir(parents=True)
    (folder / "checkpoint_000000" / "trial.json").write_text(json.dumps({"attempt": 1, "timesteps": 512}))
    lines = [{"timesteps": 512, "final": False, "attempt": 1, "checkpoint_dir_name": "checkpoint_000000"}]
    if final_checkpoint is not None:
        (folder / "checkpoint_000001").mkdir()
        (folder / "checkpoint_000001" / "trial.json").write_text(json.dumps({"attempt": 1, "timesteps": 1024, "final": True,
                                                                             "metrics": FINAL}))
        if final_checkpoint == "whole":
            (folder / "checkpoint_000001" / "policy.json").write_text('{"kind": "ppo"}')
    if final_line:
        lines.append({**FINAL, "checkpoint_dir_name": "checkpoint_000001"})
    (folder / "result.json").write_text("".join(json.dumps(x) + "\n" for x in lines))
    return folder


@pytest.mark.parametrize("restored, final_line, final_checkpoint, trains, reports", [
    ("checkpoint_000001", True, "whole", False, False),  # restored from its final checkpoint (Tune took it in)
    ("checkpoint_000000", True, "whole", False, False),  # the stop window: final result logged, earlier checkpoint saved
    ("checkpoint_000000", False, "whole", False, True),  # final checkpoint stored, its result never reached Tune
    ("checkpoint_000000", False, "short", True, True),   # final checkpoint cut short: train on from the earlier one
])
def test_restarted_trial_trains_only_if_it_has_no_final_result(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, restored: str,
                                                               final_line: bool, final_checkpoint: str, trains: bool,
                                                               reports: bool) -> None:
    """trial() as Tune restarts it, without a cluster: Tune's checkpoint and the trial's folder as a stop leaves them."""
    tune = pytest.importorskip("ray.tune")
    import types

    import torch

    from controllers.design import sweep
    from rig_env import distributed

    cfg = SweepConfig(algo="ppo", tasks=["bank_to_bank"], storage=str(tmp_path / "store"), name="s")
    folder = _trial_folder(cfg.folder, final_line=final_line, final_checkpoint=final_checkpoint)
    before = (folder / "result.json").read_text()
    trained: list[Path | None] = []
    reported: list[tuple[dict[str, Any], dict[str, Any]]] = []

    def train(argv: list[str], hp: dict[str, Any], resume: Path | None, extra: Any) -> None:
        trained.append(resume)
        out = Path(argv[argv.index("--out") + 1])
        (out / "policy.json").write_text(json.dumps({"provenance": {
            "final_eval": {"success_rate": 0.25, "rms_error_deg": 9.0, "mean_return": 1.0}, "timesteps": 1024, "wall_time_s": 2.0}}))

    def report(metrics: dict[str, Any], checkpoint: Any = None) -> None:
        reported.append((metrics, {f.name: f.read_text() for f in Path(checkpoint.path).iterdir()}))

    monkeypatch.setattr(distributed, "node_setup", lambda: {"node": "n", "host": "h", "pid": 1, "cache_dir": ""})
    monkeypatch.setattr(torch, "set_num_threads", lambda n: None)
    monkeypatch.setattr(tune, "get_checkpoint", lambda: tune.Checkpoint.from_directory(str(folder / restored)))
    monkeypatch.setattr(tune, "get_context", lambda: types.SimpleNamespace(get_trial_dir=lambda: f"/elsewhere/working_dirs/{folder.name}"))
    monkeypatch.setattr(tune, "report", report)
    sweep.trial({"task": "bank_to_bank", "seed": 0, "hp": {}}, asdict(cfg), train)

    assert (folder / "result.json").read_text() == before
    assert len(trained) == int(trains) and len(reported) == int(reports)
    if trains:  # from the earlier checkpoint, and the final checkpoint carries its result
        assert trained[0] is not None and reported[0][0]["attempt"] == 2 and reported[0][0]["resumed_from"] == 512
        assert json.loads(reported[0][1]["trial.json"])["metrics"] == reported[0][0] and "policy.json" in reported[0][1]
    elif reports:  # the stored final result, with its checkpoint
        assert reported[0][0] == FINAL and reported[0][1]["policy.json"] == '{"kind": "ppo"}'


def test_fold_takes_the_first_final_result_and_its_checkpoint(tmp_path: Path) -> None:
    """Tune's books after a restore from an earlier checkpoint (its last result and checkpoint the earlier one's) and a
    second final line (a trial trained again): the row is the first final result, the policy its checkpoint's."""
    import io
    import types

    from controllers.design.sweep import fold

    cfg = SweepConfig(algo="ppo", tasks=["bank_to_bank"], grid={"algo.learning_rate": [1e-3]}, storage=str(tmp_path / "store"),
                      name="s")
    folder = _trial_folder(cfg.folder, final_line=True, final_checkpoint="whole")
    again = {**FINAL, "success_rate": 0.25, "attempt": 2, "checkpoint_dir_name": "checkpoint_000002"}
    with open(folder / "result.json", "a") as f:
        f.write(json.dumps(again) + "\n")
    (folder / "checkpoint_000002").mkdir()
    (folder / "checkpoint_000002" / "policy.json").write_text('{"kind": "again"}')
    stopped = cfg.folder / "trial_y"
    stopped.mkdir()
    (stopped / "result.json").write_text(json.dumps({"timesteps": 512, "final": False, "attempt": 1}) + "\n")
    hp = {"algo.learning_rate": 1e-3}
    grid = [types.SimpleNamespace(metrics={"timesteps": 512, "final": False, "attempt": 1}, config={"task": "bank_to_bank", "seed": s, "hp": hp},
                                  path=str(p), error=None, checkpoint=None) for s, p in ((0, folder), (1, stopped))]
    res = fold(cfg, grid, [], io.StringIO())
    rows = {r["trial"]: r for r in res["rows"]}
    assert (rows["trial_x"]["status"], rows["trial_x"]["success_rate"], rows["trial_x"]["attempt"]) == ("done", 0.5, 1)
    assert (rows["trial_y"]["status"], rows["trial_y"]["success_rate"]) == ("stopped", None)
    assert res["done"] == 1 and res["best"]["trial"] == "trial_x"
    assert Path(res["best"]["policy"]).read_text() == '{"kind": "ppo"}'


@pytest.mark.slow
def test_node_lost_mid_sweep_every_trial_done_and_retries_reported(ray_cluster: Any, tmp_path: Path) -> None:
    _, cfg = _config(tmp_path, "lost")
    victim = next(iter(ray_cluster.worker_nodes))
    box: dict[str, Any] = {}
    log = open(tmp_path / "sweep.log", "w")

    def run() -> None:
        try:
            box["result"] = run_sweep(cfg, train=train_trial, stream=log)
        except BaseException as exc:  # noqa: BLE001
            box["error"] = exc

    th = threading.Thread(target=run, daemon=True)
    th.start()
    removed, t0 = False, time.perf_counter()
    while not removed and th.is_alive() and time.perf_counter() - t0 < 240:
        for name, lines in _results(cfg.folder).items():
            last = lines[-1]
            if last.get("node") == victim.node_id and not last.get("final") and last["timesteps"] < 2048:
                ray_cluster.remove_node(victim, allow_graceful=False)  # mid-trial: after a checkpoint, before the end
                removed = True
                box["victim_trial"] = name
                break
        time.sleep(0.2)
    th.join(timeout=400)
    ray_cluster.add_node(num_cpus=1, node_ip_address="127.0.0.1")
    assert removed, "no trial ran on the node to remove"
    assert not th.is_alive() and "error" not in box, box.get("error")
    res = box["result"]
    assert res["trials"] == 4 and res["done"] == 4  # every trial accounted for
    assert len(res["retries"]) >= 1  # and the retries reported
    rows = {r["trial"]: r for r in res["rows"]}
    victim_row = rows[box["victim_trial"]]
    assert victim_row["attempt"] >= 2  # restarted ...
    resumed = [x for x in _results(cfg.folder)[box["victim_trial"]] if x.get("attempt", 1) >= 2]
    assert resumed and resumed[0]["resumed_from"] is not None and resumed[0]["resumed_from"] >= 512  # ... from its checkpoint
    assert {(r["seed"], r["algo.learning_rate"]) for r in res["rows"]} == {(s, lr) for s in (0, 1) for lr in (3e-4, 1e-3)}
    assert "retried" in (tmp_path / "sweep.log").read_text()
    table = list(csv.DictReader(open(cfg.folder / "summary" / "sweep.csv")))
    assert len(table) == 4 and {"success_rate", "rms_error_deg", "wall_time_s"} <= set(table[0])
    assert (cfg.folder / "summary" / "sweep.png").stat().st_size > 1000


@pytest.mark.slow
def test_trial_finished_in_the_stop_window_is_not_trained_again(ray_cluster: Any, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """The race behind the flaky stop-and-resume test, hit every time: Tune logs a trial's final result (result.json,
    its last result) at once but registers the result's checkpoint only when a later save call returns, so a stop
    in between saves the trial as running with its previous checkpoint.  The driver stops itself from inside that
    window (SIGINT from the callback that sees the first final result, the way Ctrl-C stops a sweep); the resumed
    sweep must neither train that trial again nor append to its results, and its row is that final result."""
    from ray.tune import ExperimentAnalysis

    from controllers.design.sweep import make_books

    path = tmp_path / "window.toml"
    path.write_text(TINY.format(name="window").replace("seeds = [0, 1]", "seeds = [0]"))
    cfg = parse(path)
    fired: list[str] = []

    def stop_at_first_final(self: Any, iteration: int, trials: list[Any], trial: Any, result: dict[str, Any], **info: Any) -> None:
        if result.get("final") and not fired:
            fired.append(trial.trial_id)
            os.kill(os.getpid(), signal.SIGINT)  # Tune's handler: finish this step, save the state, stop

    monkeypatch.setattr(type(make_books(1, tmp_path / "scratch", quiet=True)), "on_trial_result", stop_at_first_final,
                        raising=False)
    with open(tmp_path / "first.log", "w") as log:
        run_sweep(cfg, train=train_trial, stream=log, progress=False)
    assert fired, "no trial finished before the stop"
    name, lines = next((k, v) for k, v in _results(cfg.folder).items() if v[0]["trial_id"] == fired[0])
    final = [x for x in lines if x.get("final")]
    assert len(final) == 1
    saved = {t.trial_id: t for t in ExperimentAnalysis(str(cfg.folder)).trials}[fired[0]]
    assert saved.checkpoint is not None
    assert saved.status != "TERMINATED" and Path(saved.checkpoint.path).name != final[0]["checkpoint_dir_name"], \
        "the stop missed the window: Tune saved the trial with its final checkpoint"

    with open(tmp_path / "second.log", "w") as log:
        res = run_sweep(cfg, train=train_trial, resume=True, stream=log, progress=False)
    assert res["trials"] == 2 and res["done"] == 2
    assert _results(cfg.folder)[name] == lines  # not trained again: nothing appended
    row = next(r for r in res["rows"] if r["trial"] == name)
    assert (row["status"], row["attempt"]) == ("done", final[0]["attempt"])
    assert (row["success_rate"], row["rms_error_deg"], row["mean_return"]) == \
        (final[0]["success_rate"], final[0]["rms_error_deg"], final[0]["mean_return"])
    if res["best"]["trial"] == name:  # the exported policy is the final checkpoint's
        assert Path(res["best"]["policy"]).read_bytes() == (cfg.folder / name / final[0]["checkpoint_dir_name"] / "policy.json").read_bytes()


@pytest.mark.slow
def test_sweep_stopped_and_resumed_loses_no_finished_trial(ray_cluster: Any, tmp_path: Path) -> None:
    path, cfg = _config(tmp_path, "stopped")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "rig_cli", "sweep", str(path), "--address", ray_cluster.address],
                            cwd=tmp_path, env=env, stdout=open(tmp_path / "first.log", "w"), stderr=subprocess.STDOUT,
                            start_new_session=True)
    finished_before: dict[str, list[dict[str, Any]]] = {}
    try:
        t0 = time.perf_counter()
        while proc.poll() is None and time.perf_counter() - t0 < 240:
            res = _results(cfg.folder)
            done = {k: v for k, v in res.items() if v and v[-1].get("final")}
            if done and len(done) < 4:
                proc.send_signal(signal.SIGINT)  # Ctrl-C: Tune saves its state and stops
                break
            time.sleep(0.2)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    time.sleep(1.0)
    finished_before = {k: v for k, v in _results(cfg.folder).items() if v and v[-1].get("final")}
    assert 0 < len(finished_before) < 4, (tmp_path / "first.log").read_text()[-3000:]
    res = run_sweep(cfg, train=train_trial, resume=True, stream=open(tmp_path / "second.log", "w"))
    assert res["trials"] == 4 and res["done"] == 4
    after = _results(cfg.folder)
    for name, lines in finished_before.items():
        assert after[name] == lines  # a finished trial is kept as it was: not run again, nothing appended
    rows = {r["trial"]: r for r in res["rows"]}
    assert all(rows[name]["success_rate"] == lines[-1]["success_rate"] for name, lines in finished_before.items())
    best = Path(res["best"]["policy"])
    from controllers.laws.artefact import load

    art = load(best)
    assert art.kind == "ppo" and art.spec.task == "bank_to_bank"
    # the best policy flies in rig compare --policy (a contender named after its file)
    from controllers.evaluation.compare import compare

    cmp = compare(tasks=["bank_to_bank"], kinds=[], policies=[best], episodes=2, modes=["nominal"], out_dir=None,
                  progress=False, stream=open(tmp_path / "cmp.log", "w"))
    assert {r["law"] for r in cmp.rows} == {"best_policy"}


@pytest.mark.slow
def test_rig_train_seeds_on_ray_writes_each_seed_and_their_spread(ray_cluster: Any, tmp_path: Path) -> None:
    from controllers.design.rl_train import main

    out = tmp_path / "seeds"
    rc = main(["--algo", "ppo", "--task", "bank_to_bank", "--seeds", "3", "4", "--backend", "ray", "--out", str(out),
               "--timesteps", "1024", "--num-envs", "16", "--checkpoint-every", "512", "--eval-every", "1024",
               "--eval-episodes", "2", "--final-episodes", "2", "--no-progress"])
    assert rc == 0
    seeds = json.loads((out / "seeds.json").read_text())
    assert sorted(r["seed"] for r in seeds["runs"]) == [3, 4]
    for s in (3, 4):
        prov = json.loads((out / f"s{s}" / "policy.json").read_text())["provenance"]
        assert prov["seed"] == s and prov["timesteps"] >= 1024  # every trial seeded by its own seed
