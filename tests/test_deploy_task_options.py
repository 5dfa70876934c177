"""``rig-deploy export|sim-rig --task-option KEY=VALUE``: the task's options reach the artefact and the
simulated rig, and bad ones are refused with a message naming them."""

from __future__ import annotations

import json

import pytest

from controllers.deploy import cli
from controllers.laws.artefact import load


def test_task_option_values_are_json_or_plain_strings():
    assert cli.task_options(["axis=sway_yaw", "amplitude_deg=5", "flag=true"]) == {"axis": "sway_yaw", "amplitude_deg": 5, "flag": True}
    assert cli.task_options(None) == {}
    for bad in (["axis"], ["=x"]):
        with pytest.raises(ValueError, match="KEY=VALUE"):
            cli.task_options(bad)
    with pytest.raises(ValueError, match="given twice"):
        cli.task_options(["axis=a", "axis=b"])


def test_export_carries_the_task_options_into_the_artefact(tmp_path):
    out = tmp_path / "osc.json"
    assert cli.main(["export", "--controller", "pid", "--task", "forced_oscillation", "--task-option", "axis=sway_yaw", "--out", str(out)]) == 0
    art = load(out)
    assert dict(art.spec.task_options) == {"axis": "sway_yaw"}
    assert "rig_yaw" in art.spec.free_dofs and "rig_pitch" not in art.spec.free_dofs  # the sway-yaw configuration
    assert "--task-option axis=sway_yaw" in json.loads(out.read_text())["provenance"]["source"]


def test_export_refuses_an_unknown_option_or_value(tmp_path, capsys):
    out = tmp_path / "x.json"
    assert cli.main(["export", "--controller", "pid", "--task", "forced_oscillation", "--task-option", "axis=roll_yaw", "--out", str(out)]) == cli.EXIT_REFUSED
    assert "axis" in capsys.readouterr().err
    assert cli.main(["export", "--controller", "pid", "--task", "velocity_vector_roll", "--task-option", "speed=3", "--out", str(out)]) == cli.EXIT_REFUSED
    assert "speed" in capsys.readouterr().err
    assert not out.exists()


def test_sim_rig_flies_the_configuration_of_its_task_options():
    from controllers.deploy.simrig import SimRig

    a = cli.parser().parse_args(["sim-rig", "--port", "0", "--task", "forced_oscillation", "--task-option", "axis=sway_yaw"])
    rig = SimRig(a.port, a.task, duration=1.0, task_options=cli.task_options(a.task_option))
    try:
        assert "rig_yaw" in rig.env.free_dofs and "rig_pitch" not in rig.env.free_dofs
    finally:
        rig.sock.close()
