"""A user's script built from the README's examples passes ``mypy --strict`` against the package's types.

Every Python block of README.md becomes a module of one folder, checked with ``--strict``.  rig_env,
controllers and rig_cli are read as an installed, typed package is (``follow_imports = silent``: their
types are used, errors inside them are theirs, not the script's), which is what a user's mypy sees
with the README's install commands.  The package ships ``py.typed``.  A lazily imported public name
(``rig_env.trim``, ``rig_env.sysid.fit``...) must show its real signature, not ``object``.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
CONFIG = """[mypy]
strict = True
[mypy-rig_env.*,controllers.*,rig_cli.*]
follow_imports = silent
"""


def test_the_packages_are_marked_typed() -> None:
    for pkg in ("rig_env", "controllers"):
        assert (ROOT / pkg / "py.typed").is_file(), pkg
    data = (ROOT / "pyproject.toml").read_text()
    assert '"py.typed"' in data


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("mypy") is None, reason="mypy is in the test extras")
def test_mypy_strict_passes_on_the_readme_examples(tmp_path: Path) -> None:
    for i, block in enumerate(BLOCKS):
        (tmp_path / f"readme_block_{i:02d}.py").write_text(block)
    (tmp_path / "mypy.ini").write_text(CONFIG)
    env = dict(os.environ, MYPYPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "mypy", "--config-file", "mypy.ini", "--no-incremental", "--cache-dir", str(tmp_path / ".mypy_cache"),
                        *sorted(p.name for p in tmp_path.glob("readme_block_*.py"))],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    probe = tmp_path / "probe.py"  # the lazy names' revealed types are their signatures
    probe.write_text("import rig_env\nfrom rig_env import sysid\nreveal_type(rig_env.trim)\nreveal_type(sysid.write_report)\nreveal_type(rig_env.continuation)\n")
    r = subprocess.run([sys.executable, "-m", "mypy", "--config-file", "mypy.ini", "--no-incremental", "--cache-dir", str(tmp_path / ".mypy_cache"), "probe.py"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    notes = [line for line in r.stdout.splitlines() if "Revealed type" in line]
    assert len(notes) == 3 and all('"def (' in n for n in notes), r.stdout


def _defined_functions(obj: object, module: str) -> list[tuple[str, object]]:
    """(name, function) of the public functions of a module or the public methods of a class (classmethods,
    staticmethods and properties unwrapped, ``__init__`` included), defined in ``module`` (not inherited)."""
    import inspect

    out = []
    for name, a in vars(obj).items():
        if name.startswith("_") and name != "__init__":
            continue
        if isinstance(a, (classmethod, staticmethod)):
            a = a.__func__
        elif isinstance(a, property):
            a = a.fget
        a = getattr(a, "py_func", a)  # a numba kernel: its Python function
        if inspect.isfunction(a) and a.__module__ == module:
            out.append((name, a))
    return out


def _unannotated(f: object) -> list[str]:
    import inspect

    sig = inspect.signature(f)  # type: ignore[arg-type]
    params = list(sig.parameters.values())
    bad = [p.name for i, p in enumerate(params) if p.annotation is inspect.Parameter.empty and not (i == 0 and p.name in ("self", "cls"))]
    return bad + (["return"] if sig.return_annotation is inspect.Signature.empty else [])


def test_public_functions_and_methods_of_the_environments_are_annotated() -> None:
    """Every public function and public method of a public class in rig_env.envs (tasks included) has a
    type for each parameter and its return: a user's mypy sees real signatures, not Any."""
    import importlib
    import inspect
    import pkgutil

    import rig_env.envs

    names = ["rig_env.envs"] + [m.name for m in pkgutil.walk_packages(rig_env.envs.__path__, "rig_env.envs.")]
    assert "rig_env.envs.tasks.roll" in names
    if importlib.util.find_spec("stable_baselines3") is None:
        names.remove("rig_env.envs.sb3")
    missing = []
    checked = 0
    for mod_name in names:
        mod = importlib.import_module(mod_name)
        for name, obj in vars(mod).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != mod_name:
                continue
            found = _defined_functions(obj, mod_name) if inspect.isclass(obj) else _defined_functions(mod, mod_name)
            for fname, f in found:
                if inspect.isclass(obj) or fname == name:
                    checked += 1
                    if _unannotated(f):
                        missing.append(f"{mod_name}.{name}{'.' + fname if inspect.isclass(obj) else ''}: {_unannotated(f)}")
    assert checked > 150 and not missing, "\n".join(missing)


def test_task_overrides_have_the_base_task_signatures() -> None:
    """A task's override of a public ``Task`` method (reward, tracked, success, display, ...) declares the base
    method's signature: the same parameters and annotations, the same return (or one member of the base's
    union: ``driven_joint`` -> ``str`` of ``str | None``)."""
    import inspect

    from rig_env.envs.tasks import TASKS, Task

    base = dict(_defined_functions(Task, Task.__module__))
    differ = []
    overrides = 0
    for cls in TASKS.values():
        for name, f in _defined_functions(cls, cls.__module__):
            if name in base and name != "__init__":
                overrides += 1
                sig, ref = inspect.signature(f), inspect.signature(base[name])  # type: ignore[arg-type]
                ret = sig.return_annotation == ref.return_annotation or sig.return_annotation in str(ref.return_annotation).split(" | ")
                if sig.parameters != ref.parameters or not ret:
                    differ.append(f"{cls.__name__}.{name}{inspect.signature(f)} != Task.{name}{inspect.signature(base[name])}")  # type: ignore[arg-type]
            elif not name.startswith("_") and _unannotated(f):
                differ.append(f"{cls.__name__}.{name}: no annotation for {_unannotated(f)}")
    assert overrides >= 21 and not differ, "\n".join(differ)
