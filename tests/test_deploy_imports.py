"""The rig process (``rig-deploy run``) imports numpy, the runtime and the observation builder, nothing heavy.

The real ``run`` code path (:func:`controllers.deploy.cli.main`) flies an exported law for a second
against a tiny fake rig in this test (loopback UDP, 80 Hz frames), inside a ``python -c``
subprocess that then writes its ``sys.modules``; and ``import rig_env; import rig_env.envs.observation``
alone, in a fresh interpreter.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from controllers.deploy import protocol as pr
from fake_rig import FakeRig

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
HEAVY = ("gymnasium", "numba", "llvmlite", "matplotlib", "scipy", "control", "torch", "stable_baselines3")
TASK = "velocity_vector_roll"


def _heavy(modules: list[str]) -> list[str]:
    return sorted({m.split(".")[0] for m in modules} & set(HEAVY))


def _modules_after(code: str) -> list[str]:
    r = subprocess.run([sys.executable, "-c", code + "\nimport sys, json; print(json.dumps(sorted(sys.modules)))"], env=ENV,
                       capture_output=True, text=True, timeout=120, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_import_rig_env_and_the_observation_builder_is_light():
    mods = _modules_after("import rig_env; import rig_env.envs.observation; import rig_env.envs.sensors; import rig_env.envs.streams; "
                          "import rig_env.envs.tasks; import rig_env.physics.layout; import rig_env.physics.vmath")
    assert _heavy(mods) == []
    assert "rig_env.simulate" not in mods and "rig_env.envs.vector_env" not in mods


@pytest.fixture(scope="module")
def law_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("law") / "law.json"
    r = subprocess.run([sys.executable, "-m", "controllers.deploy.cli", "export", "--controller", "linear", "--task", TASK, "--out", str(out)],
                       env=ENV, capture_output=True, text=True, timeout=300, cwd=str(ROOT))
    assert r.returncode == 0, r.stderr
    return out


def test_run_path_flies_without_heavy_modules(law_file, tmp_path):
    """... with a test input too (``--test-input``: rig_env.signals, numpy only)."""
    rig = FakeRig()
    out = tmp_path / "modules.json"
    schedule = tmp_path / "input.json"
    schedule.write_text(json.dumps({"format": "rig_env.InputSchedule", "version": 1,
                                    "surfaces": {"hawk_elevator": [{"kind": "doublet", "amplitude_deg": 1.0, "period_s": 0.5, "start_s": 0.2}]}}))
    argv = ["run", "--law", str(law_file), "--rig", f"udp://127.0.0.1:{rig.port}", "--arm", "--duration", "1.0", "--bind", "127.0.0.1",
            "--test-input", str(schedule)]
    code = ("import sys, json\n"
            "from controllers.deploy.cli import main\n"
            f"rc = main({argv!r})\n"
            f"open({str(out)!r}, 'w').write(json.dumps({{'rc': rc, 'modules': sorted(sys.modules)}}))\n")
    try:
        r = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True, timeout=120, cwd=str(ROOT))
    finally:
        rig.close()
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout[r.stdout.index("{"):])
    result = json.loads(out.read_text())
    print("\nheavy modules of the loop process:", _heavy(result["modules"]), f"({len(result['modules'])} modules)")
    print("rig_env modules:", [m for m in result["modules"] if m.startswith("rig_env")])
    print("loop summary:", {k: summary[k] for k in ("final_state", "faults", "counts", "compute")})
    # the law flew (commands in mode ACTIVE); an overrun latch is the shared test machine's scheduling, not the imports
    assert result["rc"] in (0, 3) and set(summary["faults"]) <= {"overrun"}, summary
    assert summary["counts"]["fresh"] > 40 and rig.modes.get(pr.MODE_ACTIVE, 0) >= 10, (summary["counts"], rig.modes)
    assert _heavy(result["modules"]) == []
    assert "rig_env.physics.jit" in result["modules"] and "rig_env.envs.observation" in result["modules"]
    assert "rig_env.signals" in result["modules"]
    if not summary["faults"]:  # the doublet flew to its end (an overrun latch would have stopped it)
        assert any(e["event"] == "test_input_end" for e in summary["events"]), summary["events"]
