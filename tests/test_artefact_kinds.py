"""Artefact kinds "pid", "lqr", "pid_heave_sway", "lqr_heave_sway" and "ppo"/"sac": the laws as
plain data, run by their numpy runtime.

The runtime is the law's own class built from the designed tables (``PIDLaw.from_data``,
``LQRLaw.from_data``, ``HeaveSwayPID.from_data``, ``HeaveSwayLQR.from_data``), so the round trip must reproduce the in-memory law (the issue's bound 1e-5;
identical here) over a closed-loop episode in ``RigVectorEnv``, internal states included; the
tables must be what the design tools give (python-control's LQR, the loop-shaping tuner), and
loading must refuse a table of the wrong shape and import none of the design's heavy modules.  For the
learned laws the independent reference is stable-baselines3 itself: a model trained in the test,
exported, wrapped as an artefact and loaded must act as ``model.predict(obs, deterministic=True)``.
"""

from __future__ import annotations

import base64
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from controllers import LoopSpec, make_controller
from controllers.laws import artefact as A
from rig_env.envs import RigVectorEnv

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "scripts" / "deploy.py")
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
TASKS = ("velocity_vector_roll", "bank_to_bank")
KINDS = ("pid", "lqr")
RL_KINDS = ("ppo",)  # the kinds with a shipped policy (sac: trained in test_sb3_predict_through_the_artefact)
HEAVY = {"control", "scipy", "numba", "torch", "gymnasium", "stable_baselines3", "rig_env"}


def _sensors(env: RigVectorEnv) -> dict:
    c = env.config
    return {"rate_filter_hz": c.rate_filter_hz, "link_delay_steps": c.link_delay_steps, "quantise": c.quantise,
            "pot_bits": c.pot_bits, "encoder_bits": c.encoder_bits}


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict:
    """(kind, task) -> (in-memory law, artefact path), designed once per module."""
    tmp = tmp_path_factory.mktemp("kinds")
    out = {}
    for task in TASKS:
        env = RigVectorEnv(1, task=task)
        spec = LoopSpec.from_env(env)
        for kind in KINDS + RL_KINDS:
            law = make_controller(kind, spec, 1)
            path = tmp / f"{kind}_{task}.json"
            A.save(A.from_controller(law, _sensors(env), source="test"), path)
            out[kind, task] = (law, path)
    return out


def _state(law) -> dict[str, np.ndarray]:
    """Every internal state of a law: integrators, filters, last outputs, estimator, schedule interpolation."""
    if law.kind in ("ppo", "sac"):
        return {}  # a feed-forward policy has no state
    if getattr(law, "artefact_kind", "") == "lqr_emulation":
        return {"hawk": law.hawk, "pilot": law.pilot, "est": law.est, "fresh": law.fresh, "u_past": law.u_past}
    if getattr(law, "artefact_kind", "").endswith("_heave_sway"):
        r = law.ref
        st = {"ref.clock": r.clock, "ref.w_ref": r.w_ref, "ref.th_ref": r.th_ref, "ref.th_base": r.th_base, "ref.fresh": r.fresh}
        if law.kind == "pid":
            st["pending"] = law._pending
            for name, el in (("outer", law.outer), ("inner", law.inner)):
                for f in ("i", "d", "u", "y_prev"):
                    st[f"{name}.{f}"] = getattr(el, f)
            return st
        return {**st, "z": law.z, "kf.q": law.kf.q, "kf.w": law.kf.w, "kf.q_m": law.kf.q_m, "kf.w_m": law.kf.w_m, "kf.s_prev": law.kf.s_prev}
    if law.kind == "pid":
        st = {"p_ref_prev": law._p_ref_prev, "pending": law._pending}
        for j in law.tables.axes:
            for name, el in (("outer", law.outer[j]), ("inner", law.inner[j])):
                for f in ("i", "d", "u", "y_prev"):
                    st[f"{name}.{j}.{f}"] = getattr(el, f)
        return st
    w = law._weights(law.sig.airspeed, law.kf.q[:, law.roll])
    return {"z": law.z, "p_prev": law._p_prev, "kf.q": law.kf.q, "kf.w": law.kf.w, "kf.q_m": law.kf.q_m, "kf.w_m": law.kf.w_m,
            "kf.s_prev": law.kf.s_prev, "K(V, phi)": law._interp(law.tables.K, w), "u_trim(V, phi)": law._interp(law.tables.u_trim, w)}


def _episode(law, run, task: str, steps: int = 700, reset_at: int = 350, opts: dict | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """Fly ``law`` in RigVectorEnv with ``run`` fed the same observations; returns the observations, the law's actions
    and the largest state difference seen.  Both laws are restarted mid-episode (as after an autoreset)."""
    env = RigVectorEnv(1, task=task, task_options=opts or {})
    obs, _ = env.reset(seed=7)
    law.reset(), run.reset()
    worst, O, U = 0.0, [], []
    for k in range(steps):
        if k == reset_at:
            law.reset(np.array([True])), run.reset(np.array([True]))
        a, b = law.act(obs), run.act(obs)
        assert np.max(np.abs(a - b)) <= 1e-5, (k, a, b)
        sa, sb = _state(law), _state(run)
        for key in sa:
            worst = max(worst, float(np.max(np.abs(np.asarray(sa[key], dtype=float) - np.asarray(sb[key], dtype=float)), initial=0.0)))
        O.append(obs.copy()), U.append(a.copy())
        obs, _, term, trunc, _ = env.step(a)
        if term[0] or trunc[0]:
            law.reset(term | trunc), run.reset(term | trunc)
    return np.array(O), np.array(U), worst


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("kind", KINDS)
def test_round_trip_reproduces_the_law_and_its_states(exported, kind, task):
    law, path = exported[kind, task]
    art = A.load(path)
    assert art.kind == kind and art.spec == law.spec
    run = art.controller()
    assert type(run) is type(law)  # one implementation: the artefact builds the law's own class
    _, U, worst = _episode(law, run, task)
    print(f"{kind} {task}: max state difference {worst:.2e}, mean |u| {np.abs(U).mean():.3f}")
    assert worst <= 1e-5
    assert np.abs(U).max() > 0.01  # the episode exercised the law
    design = art.data["design"]  # provenance of the design travels with the law
    assert design["airspeed_range"] == list(law.spec.airspeed_range) and design["link_delay_steps"] == 1
    assert ("tunings" in design and "targets" in design) if kind == "pid" else ("margins" in design and "max_deviation" in design)


@pytest.mark.parametrize("task", TASKS)
def test_lqr_tables_are_python_controls_lqr_and_bilinear(exported, task):
    """Independent: a grid point's gain is control.lqr at that point (design_point); the schedule is bilinear."""
    from controllers.design.lqr import design_point
    from rig_env.params import RigParams

    law, path = exported["lqr", task]
    run = A.load(path).controller()
    t = run.tables
    iv, ip = t.airspeeds.size - 1, 4
    d = design_point(RigParams.default(), law.spec.free_dofs, float(t.airspeeds[iv]), float(t.phis[ip]))
    np.testing.assert_allclose(t.K[iv, ip], d.K, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(t.u_trim[iv, ip], d.u_trim, rtol=1e-9, atol=1e-12)
    V = np.array([0.5 * (t.airspeeds[0] + t.airspeeds[1])])
    phi = np.array([t.phis[ip] + 0.25 * t.phi_step])
    corners = 0.5 * (0.75 * t.K[0, ip] + 0.25 * t.K[0, ip + 1]) + 0.5 * (0.75 * t.K[1, ip] + 0.25 * t.K[1, ip + 1])
    np.testing.assert_allclose(run._interp(t.K, run._weights(V, phi))[0], corners, rtol=1e-12, atol=1e-14)
    wrap = run._interp(t.K, run._weights(V, np.array([t.phis[-1] + 0.5 * t.phi_step])))[0]  # periodic in phi
    np.testing.assert_allclose(wrap, 0.25 * (t.K[0, -1] + t.K[0, 0] + t.K[1, -1] + t.K[1, 0]), rtol=1e-12, atol=1e-14)


def test_pid_gains_are_the_tuners(exported):
    from controllers.design.tuning import tune_axis
    from rig_env.params import RigParams

    law, path = exported["pid", "bank_to_bank"]
    t = A.load(path).controller().tables
    for k, j in enumerate(t.axes):
        ref = tune_axis(RigParams.default(), law.spec.free_dofs, j, t.v_design, law.spec.dt, link_delay_steps=1, rate_filter_hz=10.0)
        assert (t.kp[k], t.ki[k], t.k_angle[k]) == pytest.approx((ref.kp, ref.ki, ref.k_angle), rel=1e-12)
        assert ref.pm_inner >= t.design["targets"]["pm_inner"] and ref.gm_outer >= t.design["targets"]["gm_outer"]


def _rechecksum(doc: dict) -> dict:
    import hashlib

    doc["sha256"] = hashlib.sha256(A.canonical({k: doc[k] for k in A._BODY_KEYS})).hexdigest()
    return doc


@pytest.mark.parametrize("kind, name", [("pid", "kp"), ("lqr", "K")])
def test_wrong_shape_gain_table_refused(exported, tmp_path, kind, name):
    """A consistently re-checksummed file whose gain table has the wrong shape is refused by the kind, naming it."""
    _, path = exported[kind, "bank_to_bank"]
    doc = json.loads(path.read_text())
    arr = A._encode_array(name, np.zeros([*doc["arrays"][name]["shape"][:-1], doc["arrays"][name]["shape"][-1] - 1]))
    doc["arrays"][name] = arr
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_rechecksum(doc)))
    with pytest.raises(A.ArtefactError, match=rf"kind '{kind}' refused its data: {kind}: {name}: expected shape"):
        A.load(bad)


@pytest.mark.parametrize("kind", KINDS)
def test_tampered_and_truncated_refused(exported, tmp_path, kind):
    _, path = exported[kind, "velocity_vector_roll"]
    doc = json.loads(path.read_text())
    doc["params"]["design"]["link_delay_steps"] = 0  # any edit, even to the provenance
    (tmp_path / "t.json").write_text(json.dumps(doc))
    with pytest.raises(A.ArtefactError, match="checksum mismatch"):
        A.load(tmp_path / "t.json")
    raw = path.read_bytes()
    (tmp_path / "c.json").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(A.ArtefactError, match="truncated"):
        A.load(tmp_path / "c.json")


@pytest.mark.parametrize("kind, task, opts", [("pid", "bank_to_bank", {}), ("lqr", "bank_to_bank", {}), ("pid", "pull_up_push_over", {}),
                                             ("lqr", "forced_oscillation", {"axis": "sway_yaw"}), ("lqr", "free_flight_emulation", {}),
                                             ("ppo", "bank_to_bank", {})])
def test_runtime_imports_only_numpy(exported, tmp_path, kind, task, opts):
    """Loading and flying the law in a fresh interpreter imports none of the design's modules and reproduces the actions."""
    if task == "bank_to_bank":
        law, path = exported[kind, task]
    else:  # a heave/sway law: artefact kinds pid_heave_sway, lqr_heave_sway
        env = RigVectorEnv(1, task=task, task_options=opts)
        law, path = make_controller(kind, LoopSpec.from_env(env), 1), tmp_path / "law.json"
        A.save(A.from_controller(law, _sensors(env), source="test"), path)
    O, U, _ = _episode(law, make_controller(kind, law.spec, 1), task, steps=200, reset_at=100, opts=opts)
    np.save(tmp_path / "obs.npy", O), np.save(tmp_path / "act.npy", U)
    code = (f"import sys, json, numpy as np; from controllers.laws.artefact import load\n"
            f"law = load({str(path)!r}).controller(); law.reset()\n"
            f"O, U = np.load({str(tmp_path / 'obs.npy')!r}), np.load({str(tmp_path / 'act.npy')!r})\n"
            "err = 0.0\n"
            "for k in range(len(O)):\n"
            "    err = max(err, float(np.abs(law.act(O[k]) - U[k]).max()))\n"
            "    if k == 99: law.reset(np.array([True]))\n"
            f"print(json.dumps({{'err': err, 'kind': type(law).__name__, 'heavy': sorted({{m.split('.')[0] for m in sys.modules}} & set({sorted(HEAVY)!r}))}}))")
    r = subprocess.run([sys.executable, "-c", code], check=False, env=ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)
    assert res["heavy"] == [], res
    assert res["kind"] == type(law).__name__
    assert res["err"] <= 1e-5, res


@pytest.mark.parametrize("kind, task, art_kind", [("pid", "velocity_vector_roll", "pid"), ("lqr", "velocity_vector_roll", "lqr"),
                                                  ("lqr", "pull_up_push_over", "lqr_heave_sway"), ("lqr", "free_flight_emulation", "lqr_emulation"),
                                                  ("ppo", "velocity_vector_roll", "ppo")])
def test_cli_export_and_verify(tmp_path, kind, task, art_kind):
    out = tmp_path / f"{kind}.json"
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", kind, "--task", task, "--out", str(out)],
                       check=False, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert f"kind {art_kind}," in r.stdout
    r = subprocess.run([sys.executable, SCRIPT, "verify", "--law", str(out)], check=False, env=ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)
    assert v["ok"] and v["kind"] == art_kind and v["task"] == task and v["rate_hz"] == 80.0


TIMING_FAULTS = {"overrun", "stale"}
"""Faults a stall of this shared 2-core VM can cause (a 31 ms pause of the law's thread was seen once in CI)."""


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_hil_flight_with_a_designed_law(tmp_path, kind):
    """The exported law flies the simulated rig through the real-time loop for 20 s; the task succeeds and the
    flight matches the offline closed loop (same tolerances as the demo law's HIL test in test_deploy.py)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_deploy as td  # (its loopback harness: sim rig subprocess + loop thread)

    law_file = tmp_path / f"{kind}.json"
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", kind, "--task", td.TASK, "--out", str(law_file)],
                       check=False, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    for attempt in range(2):  # a timing fault or a burst of missed deadlines (a stall of the shared VM: the loop latches
        # the safe state, as it must, or just runs late) gets one more flight; the second is held to every assertion below
        (tmp_path / f"try{attempt}").mkdir()
        loop, rig, rec, _ = td.fly(tmp_path / f"try{attempt}", law_file, 20.0)
        stalled = loop["deadline_miss_fraction"] >= 0.01
        if not ((loop["faults"] and set(loop["faults"]) <= TIMING_FAULTS) or (stalled and not loop["faults"])):
            break
        print(f"HIL {kind}: attempt {attempt} latched {loop['faults']}, deadline misses {loop['deadline_misses']}/{loop['ticks']} "
              f"(law compute max {loop['compute']['max_ms']:.1f} ms); flying again")
    off = td.fly_offline(A.load(law_file), td.TASK, 80.0, 20.0, seed=0)
    roll, worst = td._compare(rec, off)
    fr, fo = rig["final_info"], off["final_info"]
    print(f"HIL {kind} 20 s: max |roll - offline| {roll:.4f} deg, any joint {worst:.4f} deg; rms error {fr['rms_error']:.3f} vs "
          f"{fo['rms_error']:.3f} deg; deadline misses {loop['deadline_misses']}/{loop['ticks']}")
    assert loop["final_state"] == "ACTIVE" and not loop["faults"]
    assert fr["success"] == fo["success"] == 1.0
    assert roll < 1.5 and abs(fr["rms_error"] - fo["rms_error"]) < 0.25
    assert loop["deadline_miss_fraction"] < 0.01
    assert math.isfinite(worst)


HEAVE_SWAY = [("pull_up_push_over", {}), ("forced_oscillation", {"axis": "heave_pitch"}), ("forced_oscillation", {"axis": "sway_yaw"}),
              ("free_flight_emulation", {})]


@pytest.mark.parametrize("task, opts", [*HEAVE_SWAY, ("departure_recovery", {})])
@pytest.mark.parametrize("kind", KINDS)
def test_round_trip_on_every_other_task_the_law_flies(tmp_path, kind, task, opts):
    """The remaining tasks: where the law can be built (else UnsupportedTask, skipped), the file reproduces it."""
    from controllers import UnsupportedTask

    env = RigVectorEnv(1, task=task, task_options=opts)
    spec = LoopSpec.from_env(env)
    try:
        law = make_controller(kind, spec, 1)
    except UnsupportedTask as e:
        pytest.skip(f"{kind} cannot fly {task}: {e}")
    A.save(A.from_controller(law, _sensors(env), source="test"), tmp_path / "law.json")
    art = A.load(tmp_path / "law.json")
    assert art.kind == law.artefact_kind and art.spec == law.spec
    run = art.controller()
    assert type(run) is type(law)
    _, U, worst = _episode(law, run, task, steps=300, reset_at=150, opts=opts)
    print(f"{kind} {task} {opts}: artefact kind {art.kind}, max state difference {worst:.2e}, mean |u| {np.abs(U).mean():.3f}")
    assert worst <= 1e-5 and np.all(np.isfinite(U))
    assert np.abs(U).max() > 0.01  # the episode exercised the law


@pytest.mark.parametrize("task, opts", HEAVE_SWAY)
@pytest.mark.parametrize("kind", KINDS)
def test_heave_sway_tables_are_the_design_tools(kind, task, opts):
    """Independent of the runtime: the stored model rows are rig_env.linearize's at the zero-input trim
    (axis_point), the static curve is rig_env.trim's (static_table), the reference constants are the task's
    and the arm's; PID gains are tune_driven's, LQR gains control.lqr's (lqr_point with the chosen weights).
    (Free-flight emulation's registered LQR is the model-following one, tests/test_laws_emulation.py; the
    heave/sway LQR, which can still fly it when built directly, is checked here.)"""
    from controllers.design.heave_sway import axis_point, design_heave_sway_lqr, lqr_point, static_table, tune_driven
    from controllers.laws.heave_sway import HeaveSwayLQR
    from rig_env.envs.sensors import RATE_SCALE
    from rig_env.envs.tasks.base import G0
    from rig_env.envs.tasks.oscillation import ForcedOscillation
    from rig_env.params import RigParams

    spec = LoopSpec.from_env(RigVectorEnv(1, task=task, task_options=opts))
    law = HeaveSwayLQR(spec, 1, tables=design_heave_sway_lqr(spec)) if kind == "lqr" else make_controller(kind, spec, 1)
    t, p = law.tables, RigParams.default()
    j, fd = t.reference.joint, spec.free_dofs
    assert (t.reference.arm_length, t.reference.g0, t.reference.t_ramp) == (p.geometry.arm_length, G0, ForcedOscillation.T_RAMP)
    assert t.reference.rate_scale == RATE_SCALE[j]
    i = t.airspeeds.size - 1
    q, sys = axis_point(p, fd, float(t.airspeeds[i]))
    nq, k = len(fd), fd.index(j)
    np.testing.assert_allclose(t.A_row[i], np.asarray(sys.A)[nq + k], rtol=1e-12)
    th, u = static_table(p, fd, j, float(t.airspeeds[i]))
    n = int(t.static_n[i])
    np.testing.assert_allclose(t.static_theta[i, :n], th, rtol=1e-12), np.testing.assert_allclose(t.static_u[i, :n], u, rtol=1e-12)
    if kind == "pid":
        i_mid = int(np.argmin(np.abs(t.airspeeds - law.v_design)))
        how = None if task == "free_flight_emulation" else "passive"  # emulation's cascade is shaped on the plain plant
        ref = tune_driven(p, axis_point(p, fd, float(t.airspeeds[i_mid]))[1], j, law.v_design, spec.dt, decouple=how)
        assert (t.law["kp"], t.law["ki"], t.law["k_angle"]) == pytest.approx((ref.kp, ref.ki, ref.k_angle), rel=1e-12)
    else:
        d = lqr_point(q, sys, fd, float(t.airspeeds[i]), law.max_deviation)
        K = d.K[{"rig_pitch": 1, "rig_yaw": 2}[j]].copy()
        if task == "free_flight_emulation":  # the model is left free: only the driven joint's gains
            K[[c for c in range(2 * nq) if c % nq != k]] = 0.0
        np.testing.assert_allclose(t.law["K"][i], K, rtol=1e-9, atol=1e-12)


def test_smooth_ramp_copy_is_the_tasks():
    """The reference parser's envelope (its runtime cannot import rig_env) is the tasks' ramp at unit ramp time."""
    from controllers.laws.references import ramp_envelope
    from rig_env.envs.tasks.base import smooth_ramp as task_ramp

    def smooth_ramp(x: np.ndarray) -> np.ndarray:
        return ramp_envelope(x, 1.0)[0]

    x = np.linspace(-0.5, 1.5, 201)
    np.testing.assert_array_equal(smooth_ramp(x), task_ramp(x))


def test_heave_sway_wrong_shape_refused(tmp_path):
    spec = LoopSpec.from_env(RigVectorEnv(1, task="pull_up_push_over"))
    path = tmp_path / "hs.json"
    A.save(A.from_controller(make_controller("lqr", spec, 1), _sensors(RigVectorEnv(1, task="pull_up_push_over")), source="test"), path)
    doc = json.loads(path.read_text())
    shp = doc["arrays"]["K"]["shape"]
    doc["arrays"]["K"] = A._encode_array("K", np.zeros([shp[0], shp[1] - 1]))
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_rechecksum(doc)))
    with pytest.raises(A.ArtefactError, match=r"kind 'lqr_heave_sway' refused its data: lqr_heave_sway: K: expected shape"):
        A.load(bad)


# ---------------------------------------------------------------------- the learned laws (ppo, sac)
@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("kind", RL_KINDS)
def test_policy_round_trip_reproduces_the_shipped_policy(exported, kind, task):
    """The exported artefact holds the shipped file's numbers (read here straight from its JSON: base64 of the
    float64 bytes) and, as derived_from, its sha256 and provenance, and flies the same episode as the law built
    from the file."""
    from controllers.laws.rl import policy_path

    law, path = exported[kind, task]
    art = A.load(path)
    run = art.controller()
    assert art.kind == kind and art.spec == law.spec and type(run) is type(law)
    shipped = json.loads(policy_path(task, kind).read_text())
    raw = lambda name: np.frombuffer(base64.b64decode(shipped["arrays"][name]["data"]), dtype="<f8").reshape(shipped["arrays"][name]["shape"])  # noqa: E731
    layers = sorted(k for k in shipped["arrays"] if k.startswith("weight_"))
    for i in range(len(layers)):
        assert np.array_equal(art.data[f"weight_{i}"], raw(f"weight_{i}")) and np.array_equal(art.data[f"bias_{i}"], raw(f"bias_{i}"))
    assert np.array_equal(art.data["obs_mean"], raw("obs_mean")) and np.array_equal(art.data["obs_var"], raw("obs_var"))
    assert np.array_equal(art.data["action_low"], raw("action_low")) and np.array_equal(art.data["action_high"], raw("action_high"))
    header = art.provenance["derived_from"]
    assert header["sha256"] == shipped["sha256"] and header["provenance"] == shipped["provenance"]
    assert art.data["obs_norm"]["clip_obs"] == shipped["params"]["obs_norm"]["clip_obs"] and art.data["activation"] == shipped["params"]["activation"]
    _, U, _ = _episode(law, run, task)
    assert np.abs(U).max() > 0.05 and np.ptp(U, axis=0).max() > 0.05  # the policy moved the flaps
    # re-exporting the loaded law (no policy file at hand) gives the same content
    again = A.from_controller(run, art.sensors, art.limits, source="test")
    assert A.canonical({**A._body(again), "provenance": {}}) == A.canonical({**A._body(art), "provenance": {}})


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_sb3_predict_through_the_artefact(tmp_path, algo):
    """SB3 -> policy file -> artefact -> numpy runtime equals SB3's deterministic predict to 1e-5 (the issue's bound);
    a non-shipped policy file exports through the CLI's --policy."""
    sys.path.insert(0, str(ROOT / "tests"))
    from test_rl import _random_obs, _tiny_model

    from controllers.design.rl_export import export_sb3

    model, vn, spec = _tiny_model(algo, normalize=True)  # a few hundred steps, VecNormalize on
    policy = tmp_path / "policy.json"
    A.save(export_sb3(model, spec, vn), policy)
    law = make_controller(algo, spec, 1, path=policy)
    env = RigVectorEnv(1, task=spec.task)
    A.save(A.from_controller(law, _sensors(env), source="test"), tmp_path / "law.json")
    run = A.load(tmp_path / "law.json").controller()
    obs = _random_obs(spec, 256, seed=5)
    want, _ = model.predict(vn.normalize_obs(obs), deterministic=True)
    got = np.concatenate([run.act(o[None]) for o in obs])
    err = float(np.abs(got - want).max())
    print(f"{algo}: artefact runtime vs SB3 predict over {len(obs)} observations: max |diff| {err:.2e}")
    assert err <= 1e-5 and np.ptp(want, axis=0).max() > 1e-3

    out = tmp_path / "cli.json"
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", algo, "--task", spec.task, "--policy", str(policy), "--out", str(out)],
                       check=False, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert A.load(out).provenance["derived_from"]["sha256"] == json.loads(policy.read_text())["sha256"]


def _rewrite(path: Path, out: Path, edit) -> Path:
    doc = json.loads(path.read_text())
    edit(doc)
    out.write_text(json.dumps(_rechecksum(doc)))
    return out


def test_policy_weights_tampered_or_misshapen_refused(exported, tmp_path):
    """Consistently re-checksummed artefacts whose weights were edited, reshaped or dropped are refused, naming why."""
    _, path = exported["ppo", "velocity_vector_roll"]
    doc = json.loads(path.read_text())
    w1 = A.load(path).data["weight_1"]

    bad = lambda d: d["arrays"].__setitem__("weight_1", A._encode_array("weight_1", w1[:, :-1]))  # noqa: E731
    with pytest.raises(A.ArtefactError, match=r"ppo: weight_1 has shape \(64, 63\), expected \(None, 64\)"):
        A.load(_rewrite(path, tmp_path / "shape.json", bad))
    with pytest.raises(A.ArtefactError, match=r"ppo: arrays .* expected .*bias_2"):
        A.load(_rewrite(path, tmp_path / "missing.json", lambda d: d["arrays"].pop("bias_2")))
    with pytest.raises(A.ArtefactError, match=r"ppo: activation = 'sigmoid'"):
        A.load(_rewrite(path, tmp_path / "act.json", lambda d: d["params"].__setitem__("activation", "sigmoid")))
    doc["arrays"]["bias_0"] = A._encode_array("bias_0", np.zeros(64))  # not re-checksummed
    (tmp_path / "t.json").write_text(json.dumps(doc))
    with pytest.raises(A.ArtefactError, match="checksum mismatch"):
        A.load(tmp_path / "t.json")


def test_cli_refuses_tampered_policy_artefact_and_wrong_task_policy(exported, tmp_path):
    """Exit status 2 and a message naming what failed: a tampered file on verify, another task's policy on export."""
    from controllers.laws.rl import policy_path

    _, path = exported["ppo", "velocity_vector_roll"]
    raw = path.read_text()
    assert '"activation": "tanh"' in raw
    (tmp_path / "t.json").write_text(raw.replace('"activation": "tanh"', '"activation": "relu"', 1))
    r = subprocess.run([sys.executable, SCRIPT, "verify", "--law", str(tmp_path / "t.json")], check=False, env=ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "checksum mismatch" in r.stderr, (r.returncode, r.stderr)
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", "ppo", "--task", "velocity_vector_roll", "--out", str(tmp_path / "x.json"),
                        "--policy", str(policy_path("bank_to_bank", "ppo"))], check=False, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "trained for task = 'bank_to_bank'" in r.stderr, (r.returncode, r.stderr)
    assert not (tmp_path / "x.json").exists()
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", "sac", "--task", "velocity_vector_roll", "--out", str(tmp_path / "x.json")],
                       check=False, env=ENV, capture_output=True, text=True, timeout=300)  # no shipped SAC policy
    assert r.returncode == 2 and "sac policy for task 'velocity_vector_roll': no file" in r.stderr, (r.returncode, r.stderr)
