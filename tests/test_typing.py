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
