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


_LOCAL = """
import sys
from pathlib import Path
import numpy as np
from controllers.evaluation.compare import compare
out = Path(sys.argv[1])
c = compare(tasks=[{task!r}], kinds={kinds!r}, episodes={episodes}, seed={seed}, modes=["nominal"], out_dir=out,
            progress=False, stream=open(out.parent / "local.log", "w"))
arrays = {{}}
for r in c.results:
    for part in ("metrics", "history"):
        for law, d in getattr(r, part).items():
            for k, v in d.items():
                arrays[f"{{r.task}}|{{r.conditions}}|{{r.n_episodes}}|{{part}}|{{law}}|{{k}}"] = np.asarray(v)
np.savez(out.parent / "local.npz", **arrays)
"""


@pytest.fixture(scope="module")
def local(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, np.ndarray]]:
    """The local backend's run, in a fresh interpreter set up as the Ray workers are (their environment
    variables: one thread, the same numba cache): a user's local run is such a process, while this test
    process has compiled other kernel variants on the way through the suite (README, "Not done yet")."""
    import os
    import subprocess

    from rig_env.distributed import worker_env

    out = tmp_path_factory.mktemp("local") / "cmp"
    code = _LOCAL.format(task=TASK, kinds=KINDS, episodes=EPISODES, seed=SEED)
    r = subprocess.run([sys.executable, "-c", code, str(out)], env={**os.environ, **worker_env()}, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    with np.load(out.parent / "local.npz") as z:
        return out, {k: z[k] for k in z.files}


def _same_metrics(a: dict[str, np.ndarray], b: Any) -> None:
    """Every per-episode metric and recorded history of the local run ``a`` (as saved) equals ``b``'s, bit for bit."""
    got = {}
    for r in b.results:
        for part in ("metrics", "history"):
            for law, d in getattr(r, part).items():
                for k, v in d.items():
                    got[f"{r.task}|{r.conditions}|{r.n_episodes}|{part}|{law}|{k}"] = np.asarray(v)
    assert sorted(got) == sorted(a)
    for k, v in a.items():
        np.testing.assert_array_equal(v, got[k], err_msg=k)


@pytest.mark.parametrize("argv, needle", [
    (["--backend", "spark"], "--backend 'spark': allowed ['local', 'ray']"),
    (["--backend", "ray", "--chunk-size", "0"], "--chunk-size = 0: must be an integer in [1, 100000]"),
    (["--backend", "ray", "--chunk-size", "1"], "--chunk-size = 1: must be an integer in [2, 100000]"),
    (["--chunk-size", "4"], "--chunk-size 4: only with --backend ray"),
    (["--address", "auto"], "--address 'auto': only with --backend ray"),
    (["--backend", "ray", "--address", "bad:99999"], "--address 'bad:99999': give auto, HOST:PORT or ray://HOST:PORT, the port an integer in [1, 65535]"),
    (["--backend", "ray", "--address", "localhost"], "--address 'localhost': give auto, HOST:PORT"),
])
def test_bad_backend_options_are_one_line_errors(argv: list[str], needle: str, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["compare", "--tasks", TASK, "--controllers", "pid", "--episodes", "2", "--out", str(tmp_path / "o"), *argv])
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and "Traceback" not in err


def test_an_address_where_nothing_listens_is_an_error_within_seconds() -> None:
    """rig train / rig compare --backend ray --address HOST:PORT with no Ray head there hung (Ray retries for
    minutes, printing only its own C++ warnings); now a TCP probe answers within CONNECT_TIMEOUT_S."""
    import socket
    import time

    from rig_env import distributed

    with socket.socket() as s:  # a port nothing listens on: bound, never listening, so connections are refused
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        t0 = time.perf_counter()
        with pytest.raises(distributed.BackendError, match=rf"--address '127.0.0.1:{port}': nothing answers at 127.0.0.1:{port} within 5 s"):
            distributed.connect(f"127.0.0.1:{port}")
    assert time.perf_counter() - t0 < 2 * distributed.CONNECT_TIMEOUT_S
    assert distributed.host_port("ray://[::1]:10001") == ("::1", 10001) and distributed.host_port("auto") is None


def test_ray_missing_names_the_extra(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError, as without the extra
    rc = main(["compare", "--tasks", TASK, "--controllers", "pid", "--episodes", "2", "--backend", "ray", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and 'pip install -e ".[ray]"' in err and "Traceback" not in err


def test_ray_summary_equals_local(ray_cluster: Any, local: tuple[Path, Any], tmp_path: Path) -> None:
    t0 = time.perf_counter()
    cmp = _run(tmp_path / "ray", backend="ray", chunk_size=3)  # 10 episodes: chunks 3, 3, 4 (no chunk of one)
    assert time.perf_counter() - t0 < 240
    assert (tmp_path / "ray" / "summary.csv").read_text() == (local[0] / "summary.csv").read_text()
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
    assert (tmp_path / "ray" / "summary.csv").read_text() == (local[0] / "summary.csv").read_text()
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
