"""One law-as-data format: every registered law saves to the rig-law artefact and loads back to the same law,
the one checksum catches a flipped byte, an old-format policy file is refused with the conversion command
(and converts exactly), and the law runtimes with a shipped policy import numpy only."""

from __future__ import annotations

import base64
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from controllers import LoopSpec, make_controller
from controllers.laws import LAWS, Controller, register
from controllers.laws import artefact as A
from controllers.laws.rl import POLICY_DIR, PPOPolicy, SACPolicy, policy_path
from rig_env.envs import RigVectorEnv

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
HEAVY = ("torch", "stable_baselines3", "scipy", "control", "numba", "gymnasium", "matplotlib", "rig_env")


def _env(task: str, **opts) -> RigVectorEnv:
    return RigVectorEnv(1, task=task, task_options=opts)


def _sac_law(spec: LoopSpec) -> SACPolicy:
    """A SAC law of random weights (no SAC policy is shipped; SB3's SAC is checked in test_artefact_kinds)."""
    rng = np.random.default_rng(4)
    sizes = [spec.obs_dim, 16, 16, spec.n_actions]
    data = {"activation": "relu", "postprocess": "tanh_unscale", "obs_norm": {"clip_obs": 5.0, "epsilon": 1e-8},
            "obs_mean": rng.normal(size=spec.obs_dim) * 0.1, "obs_var": rng.uniform(0.5, 2.0, spec.obs_dim),
            "action_low": -np.ones(spec.n_actions), "action_high": np.ones(spec.n_actions)}
    for i, (n_in, n_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        data[f"weight_{i}"] = rng.normal(size=(n_out, n_in)).astype(np.float32).astype(np.float64)
        data[f"bias_{i}"] = rng.normal(size=n_out).astype(np.float32).astype(np.float64) * 0.1
    return SACPolicy.from_data(data, spec)


def _linear_law(spec: LoopSpec):
    from controllers.design.linear import roll_tracking

    return roll_tracking(spec, 2.0, 1.0, 1.0)


# artefact kind -> (task, task options, how the test builds the law)
BUILDERS = {
    "linear": ("velocity_vector_roll", {}, _linear_law),
    "pid": ("velocity_vector_roll", {}, lambda spec: make_controller("pid", spec, 1)),
    "lqr": ("bank_to_bank", {}, lambda spec: make_controller("lqr", spec, 1)),
    "pid_heave_sway": ("pull_up_push_over", {}, lambda spec: make_controller("pid", spec, 1)),
    "lqr_heave_sway": ("forced_oscillation", {"axis": "sway_yaw"}, lambda spec: make_controller("lqr", spec, 1)),
    "lqr_emulation": ("free_flight_emulation", {}, lambda spec: make_controller("lqr", spec, 1)),
    "ppo": ("bank_to_bank", {}, lambda spec: make_controller("ppo", spec, 1)),
    "sac": ("velocity_vector_roll", {}, _sac_law),
}


def test_every_registered_law_has_a_round_trip_case():
    assert set(A.artefact_kinds()) == set(BUILDERS)
    assert {c.artefact_kind for c in (PPOPolicy, SACPolicy)} == {"ppo", "sac"}


@pytest.mark.parametrize("kind", sorted(BUILDERS))
def test_round_trip_through_the_one_format_flies_the_same_episode(tmp_path, kind):
    """save -> load -> the law's own class, identical actions (exact) over a closed-loop episode with a mid-episode reset."""
    task, opts, build = BUILDERS[kind]
    env = _env(task, **opts)
    law = build(A_spec := LoopSpec.from_env(env))
    assert law.artefact_kind == kind
    path = tmp_path / f"{kind}.json"
    digest = A.save(A.from_controller(law, A.sensors_of(env.config), source="test"), path)
    art = A.load(path)
    assert art.kind == kind and art.spec == A_spec and art.sha256 == digest
    run = art.controller()
    assert type(run) is type(law)
    obs, _ = env.reset(seed=3)
    law.reset(), run.reset()
    moved = 0.0
    for k in range(300):
        if k == 150:
            law.reset(np.array([True])), run.reset(np.array([True]))
        a, b = law.act(obs), run.act(obs)
        np.testing.assert_array_equal(a, b)
        moved = max(moved, float(np.abs(a).max()))
        obs, _, term, trunc, _ = env.step(a)
        law.reset(term | trunc), run.reset(term | trunc)
    assert moved > 0.01  # the episode exercised the law
    # and the loaded law saves to the same data
    again = A.from_controller(run, art.sensors, art.limits, source="test")
    assert A.canonical({**A._body(again), "provenance": {}}) == A.canonical({**A._body(art), "provenance": {}})


@pytest.mark.parametrize("kind", ["pid", "ppo"])
def test_checksum_catches_a_flipped_byte(tmp_path, kind):
    """One bit of one stored number flipped (the file still parses, every array still decodes): checksum mismatch."""
    task, opts, build = BUILDERS[kind]
    env = _env(task, **opts)
    path = tmp_path / "law.json"
    A.save(A.from_controller(build(LoopSpec.from_env(env)), A.sensors_of(env.config), source="test"), path)
    doc = json.loads(path.read_text())
    name = sorted(doc["arrays"])[0]
    raw = bytearray(base64.b64decode(doc["arrays"][name]["data"]))
    raw[len(raw) // 2] ^= 0x01
    doc["arrays"][name]["data"] = base64.b64encode(bytes(raw)).decode()
    (tmp_path / "flipped.json").write_text(json.dumps(doc))
    with pytest.raises(A.ArtefactError, match="checksum mismatch"):
        A.load(tmp_path / "flipped.json")
    doc = json.loads(path.read_text())
    doc["provenance"]["source"] = "Test"  # one byte of the provenance
    (tmp_path / "prov.json").write_text(json.dumps(doc))
    with pytest.raises(A.ArtefactError, match="checksum mismatch"):
        A.load(tmp_path / "prov.json")


# ---------------------------------------------------------------------- the earlier policy format
def _old_policy_file(path: Path) -> tuple[dict, LoopSpec]:
    """A small policy file of the earlier format (rig_env.rl_policy, version 1), written as rig train wrote it."""
    spec = LoopSpec(task="velocity_vector_roll", free_dofs=("rig_roll",), obs_labels=("a", "b"), action_names=("u",), dt=0.0125,
                    airspeed_range=(18.0, 18.0))
    payload = {
        "format": "rig_env.rl_policy", "format_version": 1, "kind": "ppo",
        "loop_spec": {"task": spec.task, "free_dofs": list(spec.free_dofs), "obs_labels": list(spec.obs_labels),
                      "action_names": list(spec.action_names), "dt": spec.dt, "airspeed_range": list(spec.airspeed_range),
                      "action_scale_deg": spec.action_scale_deg},
        "env_overrides": {"turbulence": 0.02},
        "network": {"activation": "tanh", "layers": [{"weight": [[0.5, -0.25], [0.1, 0.2], [-0.3, 0.7]], "bias": [0.01, -0.02, 0.03]},
                                                    {"weight": [[0.9, -1.1, 0.4]], "bias": [0.05]}]},
        "obs_norm": {"mean": [0.1, -0.2], "var": [1.5, 0.5], "clip_obs": 10.0, "epsilon": 1e-8},
        "action": {"postprocess": "clip", "low": [-1.0], "high": [1.0]},
        "provenance": {"command": "rig train --algo ppo", "final_eval": {"success_rate": 0.5}},
    }
    body = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    payload["sha256"] = hashlib.sha256(body.encode("utf-8")).hexdigest()
    path.write_text(json.dumps(payload))
    return payload, spec


def test_old_format_policy_is_refused_naming_the_file_and_the_conversion(tmp_path):
    old = tmp_path / "old_policy.json"
    _, spec = _old_policy_file(old)
    msg = rf"{old}: an old-format policy file .*rig-deploy convert-policy {old} NEW.json"
    with pytest.raises(A.ArtefactError, match=msg):
        A.load(old)
    with pytest.raises(A.ArtefactError, match=msg):
        make_controller("ppo", spec, 1, path=old)
    from controllers.deploy.cli import main  # the command the message names

    assert main(["verify", "--law", str(old)]) == 2


def test_old_format_policy_converts_exactly(tmp_path):
    """rig-deploy convert-policy: the same numbers (float64 as the JSON reads), the same actions as the earlier
    runtime's formula computed here by hand, the training record kept; a damaged old file is not converted."""
    from controllers.deploy.cli import main

    old, new = tmp_path / "old.json", tmp_path / "new.json"
    payload, spec = _old_policy_file(old)
    assert main(["convert-policy", str(old), str(new)]) == 0
    art = A.load(new)
    assert art.kind == "ppo" and art.spec == spec and art.sensors == A.DEFAULT_SENSORS
    assert art.provenance["converted_from"]["sha256"] == payload["sha256"] and art.provenance["env_overrides"] == {"turbulence": 0.02}
    assert art.provenance["final_eval"] == payload["provenance"]["final_eval"]
    layers = payload["network"]["layers"]
    for i, layer in enumerate(layers):
        assert art.data[f"weight_{i}"].tobytes() == np.array(layer["weight"], dtype=np.float64).tobytes()
    law = make_controller("ppo", spec, 4, path=new)
    obs = np.random.default_rng(1).uniform(-3, 3, (4, 2))
    n = payload["obs_norm"]
    h = np.clip((obs.astype(np.float32) - np.array(n["mean"])) / np.sqrt(np.array(n["var"]) + n["epsilon"]), -10, 10).astype(np.float32).astype(np.float64)
    # each row's product on its own, as the runtime computes it (controllers.laws.rl.rowwise: batch-independent rounding)
    h = np.tanh((h[:, None, :] @ np.array(layers[0]["weight"]).T)[:, 0, :] + np.array(layers[0]["bias"]))
    want = np.clip((h[:, None, :] @ np.array(layers[1]["weight"]).T)[:, 0, :] + np.array(layers[1]["bias"]), -1, 1)
    np.testing.assert_array_equal(law.act(obs), want)
    payload["network"]["layers"][0]["bias"][0] = 0.5  # edited without its checksum
    old.write_text(json.dumps(payload))
    assert main(["convert-policy", str(old), str(tmp_path / "x.json")]) == 2 and not (tmp_path / "x.json").exists()


def test_convert_policy_keeps_an_existing_file_unless_overwrite(tmp_path, capsys):
    """convert-policy replaced an existing NEW (a flight law file, perhaps another's) without a word; now as
    export: refused in one line unless --overwrite."""
    from controllers.deploy.cli import main

    old, new = tmp_path / "old.json", tmp_path / "new.json"
    _old_policy_file(old)
    new.write_text("mine\n")
    assert main(["convert-policy", str(old), str(new)]) == 2
    assert f"NEW {new}: already exists; give --overwrite" in capsys.readouterr().err and new.read_text() == "mine\n"
    assert main(["convert-policy", str(old), str(new), "--overwrite"]) == 0 and A.load(new).kind == "ppo"


# ---------------------------------------------------------------------- registry and numpy-only runtime
def test_a_registered_law_is_an_artefact_kind(tmp_path):
    """register(kind) with an artefact_kind and to_data / from_data is all a law needs; a taken artefact kind is refused."""
    from controllers.laws.linear import LinearLaw

    class Scaled(LinearLaw):
        artefact_kind = "test_scaled_linear"

    spec = LoopSpec.from_env(_env("velocity_vector_roll"))
    register("test_scaled")(Scaled)
    try:
        law = Scaled(spec, 1, K=np.full((spec.n_actions, spec.obs_dim), 0.01))
        A.save(A.from_controller(law, A.DEFAULT_SENSORS, source="test"), tmp_path / "s.json")
        assert type(A.load(tmp_path / "s.json").controller()) is Scaled

        class Clash(Controller):
            artefact_kind = "test_scaled_linear"

            def reset(self, mask=None): ...

            def act(self, obs): ...

        with pytest.raises(ValueError, match="artefact kind 'test_scaled_linear': already that of"):
            register("test_clash")(Clash)
    finally:
        LAWS.pop("test_scaled")
        LAWS.pop("test_clash", None)
    with pytest.raises(A.ArtefactError, match="no law registered"):
        A.load(tmp_path / "s.json")


def test_default_sensors_are_the_environments():
    """The codec's numpy-only copy of the sensor defaults (used by the old-format conversion) is RigEnvConfig's."""
    from rig_env.envs.tasks import TASKS

    for task in TASKS:
        assert A.sensors_of(RigVectorEnv(1, task=task).config) == A.DEFAULT_SENSORS, task


def test_laws_and_a_shipped_policy_import_numpy_only():
    """import controllers.laws, load a shipped PPO artefact, compute an action: no heavy module in sys.modules."""
    path = policy_path("velocity_vector_roll", "ppo")
    code = ("import sys, json, numpy as np\n"
            "import controllers.laws\n"
            "from controllers.laws.artefact import load\n"
            f"art = load({str(path)!r})\n"
            "law = art.controller(2); law.reset()\n"
            "u = law.act(np.zeros((2, art.spec.obs_dim)))\n"
            "assert u.shape == (2, art.spec.n_actions) and np.all(np.isfinite(u))\n"
            f"print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & set({list(HEAVY)!r}))))")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == []


def test_shipped_policies_are_artefacts():
    files = sorted(POLICY_DIR.glob("*.json"))
    assert files
    for f in files:
        art = A.load(f)
        assert art.kind in ("ppo", "sac") and f.name == f"{art.spec.task}_{art.kind}.json"
        assert {"final_eval", "env_overrides", "command", "hyperparameters", "versions"} <= set(art.provenance)


def test_the_laws_know_the_aerodynamic_models_rig_env_flies():
    """controllers.laws imports nothing of rig_env, so it keeps the model names itself: the same as rig_env's."""
    from controllers.laws.base import AERO_MODELS
    from rig_env.physics.pipeline import AERO_MODELS as RIG_MODELS

    assert AERO_MODELS == tuple(RIG_MODELS)


def test_an_artefact_records_the_aerodynamic_model_and_older_ones_read_as_linear(tmp_path):
    """The loop's aero_model round-trips through the one format; an artefact written before the field (no key)
    reads as the linear model; an unknown name is refused naming the field and the allowed values."""
    import dataclasses

    shipped = A.load(ROOT / "controllers" / "policies" / "departure_recovery_ppo.json")
    art = dataclasses.replace(shipped, spec=dataclasses.replace(shipped.spec, aero_model="tables"))
    A.save(art, tmp_path / "tables.json")
    assert A.load(tmp_path / "tables.json").spec.aero_model == "tables"

    def rewritten(name: str, change) -> Path:
        doc = json.loads((tmp_path / "tables.json").read_text())
        change(doc["spec"])
        body = {k: doc[k] for k in A._BODY_KEYS}
        doc["sha256"] = hashlib.sha256(A.canonical(body)).hexdigest()
        out = tmp_path / name
        out.write_text(json.dumps(doc))
        return out

    assert A.load(rewritten("old.json", lambda s: s.pop("aero_model"))).spec.aero_model == "linear"
    with pytest.raises(A.ArtefactError, match=r"spec.aero_model = 'vortex'.*linear.*tables.*unsteady"):
        A.load(rewritten("bad.json", lambda s: s.update(aero_model="vortex")))
