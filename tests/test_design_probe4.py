"""The design API and the laws refuse bad arguments in one line naming the argument (probe 4).

Each test failed before its fix: a scipy / python-control / numpy error, a ZeroDivisionError, an AttributeError, or
a silent coercion (link_delay_steps = 1.5 stored as 1, feedforward = "no" as True, a complex gain's imaginary part
dropped, a mask of indices cast to flags), or an artefact written that load() then refused.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from controllers import LoopSpec
from controllers.design.estimator import kalman_gain
from controllers.design.heave_sway import design_heave_sway_lqr, design_heave_sway_pid
from controllers.design.linear import roll_tracking
from controllers.design.lqr import design_lqr
from controllers.design.model import loop_elements, operating_point
from controllers.design.pid import design_pid
from controllers.design.tuning import margins, tune_axis
from controllers.laws import artefact as A
from controllers.laws.estimator import DelayedKalman
from controllers.laws.linear import LinearLaw
from controllers.laws.signals import table_array
from rig_env import RigParams
from rig_env.envs import RigVectorEnv


@pytest.fixture(scope="module")
def env() -> RigVectorEnv:
    return RigVectorEnv(1, task="velocity_vector_roll")


@pytest.fixture(scope="module")
def spec(env: RigVectorEnv) -> LoopSpec:
    return LoopSpec.from_env(env)


@pytest.fixture(scope="module")
def heave_spec() -> LoopSpec:
    return LoopSpec.from_env(RigVectorEnv(1, task="pull_up_push_over"))


# ------------------------------------------------------------------------------------------- design
@pytest.mark.parametrize("args, name", [((math.inf, 1.0, 1.0), "dt"), ((0.0125, math.inf, 1.0), "sigma_a"),
                                        (("a", 1.0, 1.0), "dt"), ((True, 1.0, 1.0), "dt"), ((0.0125, 1.0, -1.0), "sigma_z")])
def test_kalman_gain_names_the_bad_argument(args, name):
    with pytest.raises(ValueError, match=rf"^{name} = .*allowed > 0"):
        kalman_gain(*args)


@pytest.mark.parametrize("kw, name", [({"dt": 0.0}, "dt"), ({"dt": math.nan}, "dt"), ({"link_delay_steps": -5}, "link_delay_steps"),
                                      ({"link_delay_steps": 1.5}, "link_delay_steps"), ({"rate_filter_hz": 0.0}, "rate_filter_hz"),
                                      ({"rate_filter_hz": math.nan}, "rate_filter_hz"), ({"pade_order": 0}, "pade_order"),
                                      ({"pade_order": 2.5}, "pade_order")])
def test_loop_elements_refuses_bad_loop_settings(kw, name):
    args = {"dt": 0.0125, **kw}
    with pytest.raises(ValueError, match=rf"^{name} = .*allowed"):
        loop_elements(RigParams.default(), **args)


def test_tune_axis_refuses_a_joint_that_is_not_free_and_a_nan_target():
    p = RigParams.default()
    with pytest.raises(ValueError, match=r"joint = 'rig_pitch': not among free_dofs"):
        tune_axis(p, ("rig_roll",), "rig_pitch", 20.0, 0.0125)
    with pytest.raises(ValueError, match=r"^pm_inner = nan: .*allowed \[0, 180\)"):
        tune_axis(p, ("rig_roll", "model_pitch"), "rig_roll", 20.0, 0.0125, pm_inner=math.nan)
    with pytest.raises(ValueError, match=r"^dt = 0.0"):
        tune_axis(p, ("rig_roll", "model_pitch"), "rig_roll", 20.0, 0.0)


def test_operating_point_refuses_a_non_finite_roll_angle():
    with pytest.raises(ValueError, match=r"^phi = inf"):
        operating_point(RigParams.default(), ("rig_roll", "model_pitch"), 20.0, math.inf)


def test_margins_of_a_non_finite_loop_is_a_value_error():
    import control

    with pytest.raises(ValueError, match=r"^L: non-finite"):
        margins(control.tf([math.nan], [1.0, 1.0]))


@pytest.mark.parametrize("kw, name", [({"link_delay_steps": 1.5}, "link_delay_steps"), ({"link_delay_steps": -1}, "link_delay_steps"),
                                      ({"rate_filter_hz": 0.0}, "rate_filter_hz"), ({"feedforward": "no"}, "feedforward"),
                                      ({"params": {"a": 1}}, "params")])
def test_design_pid_refuses_bad_options(spec, kw, name):
    with pytest.raises(ValueError, match=rf"^{name} = "):
        design_pid(spec, **kw)


@pytest.mark.parametrize("kw, name", [({"link_delay_steps": 1.5}, "link_delay_steps"), ({"estimator": "no"}, "estimator"),
                                      ({"link_delay_steps": 101}, "link_delay_steps")])
def test_design_lqr_refuses_bad_options(spec, kw, name):
    with pytest.raises(ValueError, match=rf"^{name} = "):
        design_lqr(spec, **kw)


def test_heave_sway_designs_refuse_bad_options(heave_spec):
    with pytest.raises(ValueError, match=r"^targets: unknown key\(s\) \['pm'\]"):
        design_heave_sway_pid(heave_spec, targets={"pm": 3.0})
    with pytest.raises(ValueError, match=r"^decouple = 'yes'"):
        design_heave_sway_pid(heave_spec, decouple="yes")
    with pytest.raises(ValueError, match=r"^link_delay_steps = 1.5"):
        design_heave_sway_lqr(heave_spec, link_delay_steps=1.5)
    with pytest.raises(ValueError, match=r"^max_deviation: unknown key\(s\) \['x'\]"):
        design_heave_sway_lqr(heave_spec, max_deviation={"x": 1.0})
    with pytest.raises(ValueError, match=r"^max_deviation\['rig_pitch'\] = -1.0"):
        design_heave_sway_lqr(heave_spec, max_deviation={"rig_pitch": -1.0})


def test_roll_tracking_refuses_a_gain_that_is_not_a_number(spec):
    with pytest.raises(ValueError, match=r"^kp = '2': must be a finite number"):
        roll_tracking(spec, "2")


# ---------------------------------------------------------------------------------------------- laws
@pytest.mark.parametrize("K", ["abc", [[1.0, 2.0], [3.0]], "complex"])
def test_linear_law_refuses_gains_that_are_not_real_numbers(spec, K):
    if K == "complex":
        K = np.full((spec.n_actions, spec.obs_dim), 1.0 + 1.0j)
    with pytest.raises(ValueError, match=r"^K = .*must be real numbers"):
        LinearLaw(spec, 1, K=K)


def test_table_array_refuses_complex_tables():
    with pytest.raises(ValueError, match=r"^lqr: K = ndarray of dtype complex128: must be real numbers"):
        table_array({"K": np.ones(3, dtype=complex)}, "K", (3,), "lqr")


def test_reset_mask_must_be_flags_not_indices(spec):
    law = LinearLaw(spec, 4, K=np.zeros((spec.n_actions, spec.obs_dim)))
    with pytest.raises(ValueError, match=r"^mask = \[0, 3, 2, 1\]: one flag per environment"):
        law.reset(np.array([0, 3, 2, 1]))
    with pytest.raises(ValueError, match=r"^mask = "):
        law.reset(np.array([0.5, 0.0, 0.0, 0.0]))
    law.reset(np.array([True, False, True, False]))
    law.reset(np.array([1, 0, 0, 1]))  # 0 / 1 flags stay accepted


def test_act_refuses_an_observation_of_strings(spec):
    law = LinearLaw(spec, 1, K=np.zeros((spec.n_actions, spec.obs_dim)))
    with pytest.raises(ValueError, match=r"^obs: dtype"):
        law.act(np.full((1, spec.obs_dim), "x"))


def test_delayed_kalman_checks_its_gain_table():
    with pytest.raises(ValueError, match=r"^gains: shape \(2,\); allowed .*\(3, 2\)"):
        DelayedKalman(1, 0.0125, np.zeros(3, dtype=bool), np.ones(2), 1)


# ----------------------------------------------------------------------------------------- artefact
def test_a_law_of_the_wrong_shape_never_reaches_a_file(env, spec, tmp_path):
    sensors = A.sensors_of(env.config)
    law = roll_tracking(spec)
    law.K = np.zeros((2, 5))  # a gain matrix of another loop
    with pytest.raises(A.ArtefactError, match=r"kind 'linear' refused its data: K: expected shape"):
        A.from_controller(law, sensors)
    good = A.from_controller(roll_tracking(spec), sensors)
    bad = replace(good, data={**good.data, "K": np.zeros((3, 4))})
    out = tmp_path / "law.json"
    with pytest.raises(A.ArtefactError, match=r"law.json: kind 'linear' refused its data"):
        A.save(bad, out)
    assert not out.exists()
    A.save(good, out)
    assert A.load(out).controller().K.shape == (spec.n_actions, spec.obs_dim)


def test_save_names_the_path_it_cannot_write(env, spec, tmp_path):
    art = A.from_controller(roll_tracking(spec), A.sensors_of(env.config))
    with pytest.raises(IsADirectoryError, match="is a directory"):
        A.save(art, tmp_path)
    with pytest.raises(FileNotFoundError, match=r"no such directory.*nodir"):
        A.save(art, tmp_path / "nodir" / "law.json")
    assert list(tmp_path.iterdir()) == []


def test_from_controller_and_default_limits_refuse_bad_arguments(env, spec):
    with pytest.raises(A.ArtefactError, match=r"^ctrl = str: must be a law"):
        A.from_controller("pid", A.sensors_of(env.config))
    with pytest.raises(A.ArtefactError, match=r"^rate_deg_s = 0.0: allowed range \(0, 5000\]"):
        A.default_limits(spec, 0.0)


def test_make_controller_names_an_option_the_kind_does_not_take(spec):
    from controllers import make_controller

    with pytest.raises(ValueError, match=r"^options \['rate_filter_hz'\]: not options of kind 'lqr' \(design_lqr\); allowed \['params', "):
        make_controller("lqr", spec, 1, rate_filter_hz=5.0)
    with pytest.raises(ValueError, match=r"^options \['k'\]: not options of kind 'linear'.*allowed \['K', 'obs0', 'u0', 'rate_limit'\]"):
        make_controller("linear", spec, 1, k=np.zeros((spec.n_actions, spec.obs_dim)))
    assert make_controller("linear", spec, 2, K=np.zeros((spec.n_actions, spec.obs_dim))).num_envs == 2


@pytest.mark.parametrize("kw, name", [({"airspeed_range": (22.0, 18.0)}, "airspeed_range"), ({"airspeed_range": (18.0, math.nan)}, "airspeed_range"),
                                      ({"airspeed_range": (18.0,)}, "airspeed_range"), ({"action_scale_deg": 0.0}, "action_scale_deg"),
                                      ({"dt": 0.0}, "dt"), ({"aero_model": "vortex"}, "aero_model")])
def test_loop_spec_refuses_numbers_a_design_cannot_use(spec, kw, name):
    """A reversed or NaN airspeed range was designed silently at one airspeed; action_scale_deg = 0 divided by zero."""
    with pytest.raises(ValueError, match=rf"^{name} = "):
        replace(spec, **kw)


def test_emulation_design_names_a_bad_maximum_and_takes_numpy_integers():
    from controllers.design.emulation import design_emulation_lqr, zoh_with_delay

    spec = LoopSpec.from_env(RigVectorEnv(1, task="free_flight_emulation"))
    with pytest.raises(ValueError, match=r"^max_input = 'x': every maximum must be finite and > 0"):
        design_emulation_lqr(spec, max_input="x")
    with pytest.raises(ValueError, match=r"^max_deviation\['alpha_error'\] = 'x'"):
        design_emulation_lqr(spec, max_deviation={"alpha_error": "x"})
    with pytest.raises(ValueError, match=r"^max_input = True"):
        design_emulation_lqr(spec, max_input=True)
    with pytest.raises(ValueError, match=r"^params = dict"):
        design_emulation_lqr(spec, params={})
    with pytest.raises(ValueError, match=r"^tau = inf"):
        zoh_with_delay(np.eye(2), np.ones(2), 0.01, math.inf)
    with pytest.raises(ValueError, match=r"^A, b: shapes \(3, 3\), \(2,\)"):
        zoh_with_delay(np.eye(3), np.ones(2), 0.01, 0.0)
    t = design_emulation_lqr(spec, link_delay_steps=np.int64(1))  # a numpy integer (from a config array) was refused
    assert t.design["link_delay_steps"] == 1


@pytest.mark.parametrize("kw, match", [
    ({"tol": 0.0}, r"^tol = 0\.0: the solver's relative tolerance; allowed range \(0, 0\.01\]$"),
    ({"tol": -1.0}, r"^tol = -1\.0: "),
    ({"tol": float("nan")}, r"^tol = nan: "),
    ({"max_residual": 0.0}, r"^max_residual = 0\.0: .*or None; allowed range \(0, 1000\]$"),
])
def test_trim_refuses_a_bad_tolerance_by_name(kw, match):
    """rig_env.trim(tol=-1) failed in scipy's least_squares with its own message; a NaN tolerance or a zero
    max_residual were taken as given."""
    import rig_env

    with pytest.raises(ValueError, match=match):
        rig_env.trim(RigParams.default(), ("model_pitch",), **kw)


@pytest.mark.parametrize("eps", [0.0, -1e-6, float("nan"), 1.0, "1e-6", True])
def test_linearize_refuses_a_bad_step_by_name(eps):
    """rig_env.linearize(eps=0) returned NaN matrices with only a RuntimeWarning."""
    import rig_env

    p = RigParams.default()
    op = rig_env.trim(p, ("model_pitch",))
    with pytest.raises(ValueError, match=r"^eps = .*: the finite-difference step .*allowed range \(0, 0\.01\]$"):
        rig_env.linearize(p, op, eps=eps)
    assert np.all(np.isfinite(rig_env.linearize(p, op).A))  # the default step still linearises


def test_an_old_policy_whose_loop_spec_is_refused_names_the_file(tmp_path):
    """convert-policy of an old-format file whose loop_spec LoopSpec refuses (a reversed airspeed range): an
    ArtefactError naming the file and the field, as every other malformed old file gets, not a bare ValueError."""
    import hashlib
    import json

    from controllers.deploy.convert import old_policy_to_artefact

    payload = {
        "format": "rig_env.rl_policy", "format_version": 1, "kind": "ppo",
        "loop_spec": {"task": "velocity_vector_roll", "free_dofs": ["rig_roll"], "obs_labels": ["a"], "action_names": ["u"],
                      "dt": 0.0125, "airspeed_range": [25.0, 15.0], "action_scale_deg": 40.0},
        "network": {"activation": "tanh", "layers": [{"weight": [[0.5]], "bias": [0.0]}]},
        "action": {"postprocess": "clip", "low": [-1.0], "high": [1.0]},
    }
    body = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    payload["sha256"] = hashlib.sha256(body.encode("utf-8")).hexdigest()
    with pytest.raises(A.ArtefactError, match=r"^old\.json: loop_spec: airspeed_range = \(25\.0, 15\.0\): "):
        old_policy_to_artefact(payload, "old.json")
