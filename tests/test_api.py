"""Public API: shapes, names and clear errors for bad input."""

import warnings

import numpy as np
import pytest

import rig_env
from rig_env import JOINTS, ParameterError


def test_public_names():
    assert rig_env.JOINTS == ("rig_roll", "rig_pitch", "rig_yaw", "model_pitch", "model_yaw")
    assert set(rig_env.SURFACES) == {"comp_aileron", "comp_elevator", "comp_rudder", "hawk_elevator", "hawk_aileron", "hawk_rudder"}


def test_result_shapes(params):
    r = rig_env.simulate(params, [0.1, 0.0], [0.0, 0.0], 1.0, free_dofs=["rig_roll", "model_pitch"])
    assert r.t.shape == (81,) and r.t[-1] == pytest.approx(1.0)
    assert r.q.shape == r.qd.shape == (81, 2) and r.energy.shape == (81,) and r.constraint_residual is None
    rb = rig_env.simulate(params, np.zeros((3, 2)), np.zeros((3, 2)), 1.0, free_dofs=["rig_roll", "model_pitch"], control_rate=244.0,
                          physics_dt=1 / 244 / 2)
    assert rb.q.shape == (3, 245, 2) and rb.energy.shape == (3, 245) and rb.status.shape == (3,)


def test_controls_as_functions_and_arrays(params):
    r = rig_env.simulate(params, np.zeros((2, 1)), np.zeros((2, 1)), 2.0, free_dofs=["rig_roll"],
                         controls={"comp_aileron": lambda t: np.array([10.0, -10.0]) * min(t, 1.0)})
    # each environment its own command: the rig banks each way (the roll imbalance holds it near 35 deg at 10 deg
    # of aileron, where 90 deg would need 43 % of the travel at 20 m/s)
    assert r.q[0, -1, 0] > 0.2 and r.q[1, -1, 0] < -0.2


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(q0=[np.nan, 0.0]), "q0: values must be finite"),
        (dict(q0=[0.0, 0.0, 0.0]), r"q0: expected shape \(2,\)"),
        (dict(qd0=[np.inf, 0.0]), "qd0: values must be finite"),
        (dict(free_dofs=["rig_rol"]), r"free_dofs: unknown joint\(s\) \['rig_rol'\]"),
        (dict(free_dofs=[]), "at least one joint must be free"),
        (dict(controls={"aileron": 1.0}), r"controls: unknown surface\(s\) \['aileron'\]"),
        (dict(controls={"comp_aileron": lambda t: np.nan}), "non-finite value"),
        (dict(controls={"comp_aileron": np.ones(3)}), "does not broadcast"),
        (dict(airspeed=-5.0), r"airspeed = -5.*m/s is outside the allowed range \[0, 60\]"),
        (dict(t_final=-1.0), "t_final"),
        # inside t_final's range, but 64 environments over 1e5 s at 80 Hz would be 149 GiB: refused before numpy is asked
        (dict(q0=np.zeros((64, 2)), qd0=np.zeros((64, 2)), t_final=1e5), r"t_final = 100000 s: 64 environment\(s\) sampled at 80 Hz would need 148.8 GiB for the result, more than 4 GiB"),
        (dict(t_final=0.004), r"t_final = 0.004 s is shorter than half a control step \(0.0125 s at 80 Hz\): nothing would be simulated"),
        (dict(formulation="ode"), "formulation"),
        (dict(physics_dt=0.003), "integer multiple"),
        (dict(control_rate=0.0), "control_rate"),
        (dict(gust=[1.0, 2.0]), "gust"),
    ],
)
def test_bad_input_is_a_clear_error(params, kwargs, match):
    args = dict(q0=[0.0, 0.0], qd0=[0.0, 0.0], t_final=0.1, free_dofs=["rig_roll", "model_pitch"])
    args.update(kwargs)
    q0, qd0, t_final = args.pop("q0"), args.pop("qd0"), args.pop("t_final")
    with pytest.raises(ValueError, match=match):
        rig_env.simulate(params, q0, qd0, t_final, **args)


def test_t_final_between_control_steps_ends_at_the_nearest_and_says_so(params):
    """simulate() rounded t_final to a control step without a word (0.03 s at 80 Hz ended at 0.025 s); it still
    does, and warns with the time it ends at; whole steps stay silent."""
    with pytest.warns(UserWarning, match=r"t_final = 0.03 s is not a whole number of control steps \(0.0125 s\): the run ends at the nearest, 0.025 s"):
        r = rig_env.simulate(params, [0.0], [0.0], 0.03, free_dofs=["model_pitch"])
    assert r.t[-1] == pytest.approx(0.025, abs=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert rig_env.simulate(params, [0.0], [0.0], 0.1, free_dofs=["model_pitch"]).t[-1] == pytest.approx(0.1, abs=1e-12)


def test_bad_params_argument(params):
    with pytest.raises(ParameterError, match="RigParams"):
        rig_env.simulate({"mass": 1}, [0.0], [0.0], 0.1, free_dofs=["rig_roll"])
    with pytest.raises(ParameterError, match="outside the allowed range"):
        rig_env.simulate(params, [0.0], [0.0], 0.1, free_dofs=["rig_roll"], overrides={"mass.hawk_mass": 0.0})


def test_locked_rates_must_be_zero(params):
    with pytest.raises(ValueError, match="locked joints must have zero rate"):
        rig_env.simulate(params, np.zeros(5), np.ones(5), 0.1, free_dofs=["rig_roll"])


def test_all_joints_free_accepts_full_vectors(params):
    r = rig_env.simulate(params, np.zeros(5), np.zeros(5), 0.1, free_dofs=JOINTS)
    assert r.q.shape == (9, 5)
