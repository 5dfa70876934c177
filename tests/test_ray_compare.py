"""``rig compare --backend ray``: the same numbers as the local backend, a node lost mid-run costs nothing.

On a local multi-node cluster (tests/conftest.py ``ray_cluster``: a head without CPUs, two one-CPU worker
nodes on loopback).  Options are refused in one line (exit 2) without a cluster.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from controllers.evaluation.compare import compare
from rig_cli.main import main

TASK, KINDS, EPISODES, SEED = "bank_to_bank", ["pid", "lqr", "ppo"], 10, 5  # ppo: the law whose batch product rounds by shape


def _run(out: Path, **kw: Any) -> Any:
    return compare(tasks=[TASK], kinds=KINDS, episodes=EPISODES, seed=SEED, modes=["nominal"], out_dir=out,
                   progress=False, stream=open(out.parent / f"{out.name}.log", "w"), **kw)


@pytest.fixture(scope="module")
def local(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    out = tmp_path_factory.mktemp("local") / "cmp"
    return out, _run(out)


# Equal to the last bit when the driver and the workers run kernels compiled alike; a process whose kernels
# were compiled in another order (the full test suite compiles variants on the way) can differ in the last
# bits of a float (README, "Not done yet"), so floats are compared to 1e-9 relative, everything else exactly.
def _close(a: Any, b: Any, what: str) -> None:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f" or b.dtype.kind == "f":
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12, equal_nan=True, err_msg=what)
    else:
        np.testing.assert_array_equal(a, b, err_msg=what)


def _same_csv(a: str, b: str) -> None:
    import csv
    import io
    import math

    ra, rb = list(csv.reader(io.StringIO(a))), list(csv.reader(io.StringIO(b)))
    assert ra[0] == rb[0] and len(ra) == len(rb)
    for row_a, row_b in zip(ra, rb):
        for x, y in zip(row_a, row_b, strict=True):
            try:
                fx, fy = float(x), float(y)
            except ValueError:
                assert x == y
                continue
            assert (math.isnan(fx) and math.isnan(fy)) or math.isclose(fx, fy, rel_tol=1e-9, abs_tol=1e-12), (x, y)


def _same_metrics(a: Any, b: Any) -> None:
    assert [(r.task, r.conditions, r.n_episodes) for r in a.results] == [(r.task, r.conditions, r.n_episodes) for r in b.results]
    for ra, rb in zip(a.results, b.results):
        for law in ra.metrics:
            for k, v in ra.metrics[law].items():
                _close(v, rb.metrics[law][k], f"{law} {k}")
        for law in ra.history:
            for k, v in ra.history[law].items():
                _close(v, rb.history[law][k], f"history {law} {k}")


@pytest.mark.parametrize("argv, needle", [
    (["--backend", "spark"], "--backend 'spark': allowed ['local', 'ray']"),
    (["--backend", "ray", "--chunk-size", "0"], "--chunk-size = 0: must be an integer in [1, 100000]"),
    (["--backend", "ray", "--chunk-size", "1"], "--chunk-size = 1: must be an integer in [2, 100000]"),
    (["--chunk-size", "4"], "--chunk-size 4: only with --backend ray"),
    (["--address", "auto"], "--address 'auto': only with --backend ray"),
])
def test_bad_backend_options_are_one_line_errors(argv: list[str], needle: str, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["compare", "--tasks", TASK, "--controllers", "pid", "--episodes", "2", "--out", str(tmp_path / "o"), *argv])
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and "Traceback" not in err


def test_ray_missing_names_the_extra(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError, as without the extra
    rc = main(["compare", "--tasks", TASK, "--controllers", "pid", "--episodes", "2", "--backend", "ray", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and 'pip install -e ".[ray]"' in err and "Traceback" not in err


def test_ray_summary_equals_local(ray_cluster: Any, local: tuple[Path, Any], tmp_path: Path) -> None:
    t0 = time.perf_counter()
    cmp = _run(tmp_path / "ray", backend="ray", chunk_size=3)  # 10 episodes: chunks 3, 3, 4 (no chunk of one)
    assert time.perf_counter() - t0 < 240
    _same_csv((tmp_path / "ray" / "summary.csv").read_text(), (local[0] / "summary.csv").read_text())
    _same_metrics(local[1], cmp)
    (batch,) = cmp.backend["batches"]
    assert [(c["first"], c["episodes"]) for c in batch["chunks"]] == [(0, 3), (3, 3), (6, 4)]
    assert all(c["cache_dir"] for c in batch["chunks"])  # every task set its node's numba cache before the kernels


@pytest.mark.slow
def test_node_lost_mid_comparison_every_episode_accounted(ray_cluster: Any, local: tuple[Path, Any], tmp_path: Path) -> None:
    import ray

    victim = next(iter(ray_cluster.worker_nodes))
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["cmp"] = _run(tmp_path / "ray", backend="ray", chunk_size=2)
        except BaseException as exc:  # noqa: BLE001  (reported by the main thread)
            box["error"] = exc

    th = threading.Thread(target=run, daemon=True)
    th.start()
    removed, t0 = False, time.perf_counter()
    while not removed and th.is_alive() and time.perf_counter() - t0 < 180:
        try:
            snap = ray.get(ray.get_actor(f"rig-ledger-{TASK}-nominal").snapshot.remote(), timeout=10)
        except (ValueError, ray.exceptions.RayError):
            time.sleep(0.2)
            continue
        busy = [k for k, starts in snap["attempts"].items() if starts[-1]["node"] == victim.node_id]
        if busy and snap["done"] < snap["total"]:
            time.sleep(0.5)  # mid-chunk
            ray_cluster.remove_node(victim, allow_graceful=False)
            removed = True
        time.sleep(0.1)
    th.join(timeout=300)
    ray_cluster.add_node(num_cpus=1, node_ip_address="127.0.0.1")  # the next test's cluster again
    assert removed, "no chunk ran on the node to remove"
    assert not th.is_alive() and "error" not in box, box.get("error")
    cmp = box["cmp"]
    assert cmp.backend["retries"] >= 1
    (batch,) = cmp.backend["batches"]
    retried = [c for c in batch["chunks"] if len(c["attempts"]) > 1]
    assert retried and all(c["attempts"][0]["node"] == victim.node_id for c in retried)
    assert all(c["finished_on"]["node"] != victim.node_id for c in retried)
    assert sorted(c["first"] for c in batch["chunks"]) == list(range(0, EPISODES, 2))  # every episode, once
    _same_csv((tmp_path / "ray" / "summary.csv").read_text(), (local[0] / "summary.csv").read_text())
    _same_metrics(local[1], cmp)
    assert f"{cmp.backend['retries']} retried" in (tmp_path / "ray.log").read_text()  # the retries reported


@pytest.mark.parametrize("text, needle", [
    ('backend = "spark"\n', "backend = 'spark': allowed ['local', 'ray']"),
    ("chunk_size = 0\n", "chunk_size = 0: must be an integer in [1, 100000] episodes"),
    ('address = ""\n', "address = '': must be a Ray address"),
])
def test_config_file_backend_keys_are_checked(text: str, needle: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "c.toml").write_text(text)
    rc = main(["compare", "--config", str(tmp_path / "c.toml"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and needle in err, err


def test_kernels_warm_once_per_process(ray_cluster: Any, tmp_path: Path) -> None:
    """Every chunk sets its node's numba cache; a worker process warms a batch's kernels once, not once per task."""
    cmp = compare(tasks=[TASK], kinds=["pid"], episodes=12, seed=1, modes=["nominal"], out_dir=None, progress=False,
                  stream=open(tmp_path / "log", "w"), backend="ray", chunk_size=2)
    chunks = cmp.backend["batches"][0]["chunks"]
    by_pid: dict[int, list[float]] = {}
    for c in sorted(chunks, key=lambda c: c["first"]):
        by_pid.setdefault(c["finished_on"]["pid"], []).append(c["warm_s"])
    assert sum(len(v) for v in by_pid.values()) == 6
    for warms in by_pid.values():
        assert sum(w > 0 for w in warms) <= 1  # the process's first chunk warmed (or an earlier run did), no later one
