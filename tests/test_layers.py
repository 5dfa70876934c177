"""Import structure: the import-linter contracts of pyproject.toml hold, and no module imports itself back.

``lint-imports`` checks the layers (rig_cli > controllers > rig_env; inside rig_env and controllers) and
the forbidden imports of the laws' and the deployed runtime's modules.  The cycle check builds the
module graph of the three packages with grimp (type-only imports excluded, as in the contracts) and
asserts every strongly connected component is one module.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rig_env", "controllers", "rig_cli")


def _lint_imports() -> list[str]:
    exe = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    return [exe] if Path(exe).exists() else [sys.executable, "-m", "importlinter.cli"]


def test_import_contracts_hold():
    import importlinter  # noqa: F401  (a test extra: a missing install fails here, never skips)

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([*_lint_imports(), "--no-cache"], cwd=str(ROOT), env=env, capture_output=True, text=True, timeout=300)
    print(r.stdout[-4000:])
    assert r.returncode == 0, r.stdout[-8000:] + r.stderr[-2000:]
    assert "0 broken" in r.stdout


def _components(adj: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in sorted(adj):
        if root in index:
            continue
        work = [(root, iter(sorted(adj[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(adj[w]))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    out.append(sorted(comp))
    return out


def test_components_of_a_known_graph():
    adj = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert sorted(_components(adj)) == [["a", "b", "c"], ["d"], ["e"]]


def test_no_import_cycle_among_the_project_modules():
    grimp = pytest.importorskip("grimp", reason="grimp (import-linter's graph library) is not installed")
    sys.path.insert(0, str(ROOT))
    try:
        graph = grimp.build_graph(*PACKAGES, cache_dir=None, exclude_type_checking_imports=True)
    finally:
        sys.path.remove(str(ROOT))
    mods = {m for m in graph.modules if m.split(".")[0] in PACKAGES}
    adj = {m: {i for i in graph.find_modules_directly_imported_by(m) if i in mods} for m in mods}
    assert not [m for m in mods if m in adj[m]]
    cycles = [c for c in _components(adj) if len(c) > 1]
    detail = []
    for c in cycles:
        members = set(c)
        detail.append(" ; ".join(f"{m} -> {sorted(adj[m] & members)}" for m in c))
    assert not cycles, "import cycles:\n" + "\n".join(detail)
