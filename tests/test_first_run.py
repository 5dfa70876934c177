"""A fresh installation's first run: kernels compiled side by side, never silently, once for both installs.

Checked: two installations of the same sources (different directories) share numba's disk cache (the
second compiles nothing); :func:`rig_env.compile_watch.compile_watch` reports a compile while it runs
and says nothing for a cached kernel; :func:`rig_env.precompile.precompile` groups the tasks by physics
kernel, runs its children, records its work so the next run starts none, and reports a failed child
without recording anything.  The cold-start time itself is a benchmark (``benchmarks/bench_cold_start.py``).
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

import rig_env
from rig_env import precompile as pre
from rig_env.compile_watch import compile_watch

_PROBE = """
import json, sys
# this installation, not the one the test runs from (an editable install's import hook would win over PYTHONPATH)
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
sys.path.insert(0, sys.argv[1])
from rig_env.physics import jit
jit.setup_numba()
import numpy as np
from rig_env.physics import layout as L
from rig_env.physics.friction import stribeck
stribeck(np.zeros(L.N_PARAMS), 0, 0.1)
print(json.dumps({"file": jit.__file__, "hits": len(stribeck.stats.cache_hits), "misses": len(stribeck.stats.cache_misses)}))
"""


def test_two_installations_of_the_same_sources_share_one_cache(tmp_path: Path) -> None:
    src = Path(rig_env.__file__).parent
    for name in ("site", "checkout"):  # as `pip install .` and `pip install -e .` would place them
        shutil.copytree(src, tmp_path / name / "rig_env", ignore=shutil.ignore_patterns("__pycache__"))
    runs = []
    for name in ("site", "checkout"):
        env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
        r = subprocess.run([sys.executable, "-c", _PROBE, str(tmp_path / name)], env=env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        runs.append(json.loads(r.stdout.strip().splitlines()[-1]))
    assert runs[0]["file"] != runs[1]["file"] and str(tmp_path / "checkout") in runs[1]["file"]
    assert (runs[0]["misses"], runs[0]["hits"]) == (1, 0)  # the first installation compiles
    assert (runs[1]["misses"], runs[1]["hits"]) == (0, 1)  # the second loads what the first compiled
    assert [p.name for p in (tmp_path / "cache").iterdir()] == ["rig_env_physics"]


def _fresh_function(k: int):  # a new function each call: numba has compiled nothing of it
    import numba

    ns: dict = {}
    body = " + ".join(f"math.sin(x * {i + 1}.0 + {k}.0)" for i in range(200))
    exec(f"import math\ndef f(x):\n    return {body}\n", ns)
    return numba.njit(cache=False)(ns["f"])


def test_compile_watch_speaks_while_numba_compiles_and_not_when_nothing_compiles() -> None:
    f = _fresh_function(int(time.time() * 1000) % 100000)
    out = io.StringIO()
    with compile_watch(out, interval=0.05) as log:
        f(0.5)
    assert log.functions >= 1 and log.seconds > 0
    assert "compiled" in out.getvalue() and "numba functions" in out.getvalue()
    quiet = io.StringIO()
    with compile_watch(quiet, interval=0.05) as log2:
        f(0.25)  # compiled above: nothing to say
    assert log2.functions == 0 and quiet.getvalue() == ""


def test_compile_watch_inside_another_reports_once() -> None:
    f = _fresh_function(int(time.time() * 1000) % 100000 + 7)
    outer, inner = io.StringIO(), io.StringIO()
    with compile_watch(outer, interval=0.05) as a:
        with compile_watch(inner, interval=0.05) as b:
            f(0.5)
    assert a.functions >= 1 and b.functions == 0 and inner.getvalue() == ""


def test_precompile_groups_tasks_by_physics_kernel() -> None:
    """One job per kernel and aerodynamic model (the linear and the tables lane kernels are separate functions,
    compiled side by side), the design folded into the cheaper: the linear group (40 + 2 s) before the
    tables' (55 s)."""
    tasks = ["velocity_vector_roll", "bank_to_bank", "departure_recovery"]
    jobs = pre._jobs(tasks, {}, True, 2)
    assert len(jobs) == 2
    lanes = next(j for j in jobs if "velocity_vector_roll" in j["tasks"])
    assert lanes["tasks"] == ["velocity_vector_roll", "bank_to_bank"] and lanes["design"]
    tables = next(j for j in jobs if j is not lanes)
    assert tables["tasks"] == ["departure_recovery"] and not tables["design"]
    three = pre._jobs(tasks, {}, True, 3)
    assert len(three) == 3 and [j for j in three if j["design"]] == [{"tasks": [], "design": True}]
    one = pre._jobs(tasks, {}, True, 1)
    assert len(one) == 1 and sorted(one[0]["tasks"]) == sorted(tasks) and one[0]["design"]


def test_precompile_records_its_work_and_reports_a_failed_child(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    marker = tmp_path / "precompiled.json"
    monkeypatch.setattr(pre, "_marker", lambda spec: marker)
    out = io.StringIO()
    rep = pre.precompile(["velocity_vector_roll"], {}, design=False, processes=2, stream=out)
    assert not rep.skipped and not rep.failed and len(rep.jobs) == 1
    assert json.loads(marker.read_text())["tasks"] == ["velocity_vector_roll"]
    assert "compiled (velocity_vector_roll)" in out.getvalue()
    again = pre.precompile(["velocity_vector_roll"], {}, design=False, processes=2, stream=io.StringIO())
    assert again.skipped == "compiled by an earlier run" and not again.jobs
    marker.unlink()
    monkeypatch.setattr(pre.sys, "executable", shutil.which("false") or "/bin/false")
    out = io.StringIO()
    bad = pre.precompile(["velocity_vector_roll"], {}, design=False, processes=2, stream=out)
    assert len(bad.failed) == 1 and "compile when first used" in out.getvalue()
    assert not marker.exists()  # nothing recorded: the next run tries again


def test_precompile_refuses_bad_arguments_by_name() -> None:
    with pytest.raises(ValueError, match="tasks: unknown"):
        pre.precompile(["no_such_task"])
    with pytest.raises(ValueError, match="processes"):
        pre.precompile(["velocity_vector_roll"], processes=0)
    with pytest.raises(ValueError, match="airspeed"):
        pre.precompile(["velocity_vector_roll"], {"airspeed": -5.0}, processes=2)
