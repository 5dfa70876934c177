"""Gymnasium / SB3 environments: API conformance, determinism, batch-of-one equality, bounds, errors."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import rig_env
import rig_env.envs  # registers the ids
from rig_env.envs import ENV_IDS, TASKS, RigEnv, RigVectorEnv
from rig_env.envs.metrics import StepMetrics
from rig_env.envs.sensors import Sensors
from rig_env.physics import layout as L

RANDOMISE = {
    "mass.hawk_mass": (0.8, 1.5),
    "geometry.hawk_cg_z": (0.0, 0.02),
    "hawk_aero.CMalpha": (-0.7, -0.4),
    "friction.rig_roll.Fc": (0.04, 0.059),
    "servos.compensator.delay_s": (0.01, 0.02),
}
RICH = dict(randomise=RANDOMISE, turbulence=0.05, link_delay_steps=2, episode_seconds=1.0)
# every task, and the forced oscillation on both axes: (task, task_options)
TASK_CASES = [(t, {}) for t in TASKS] + [("forced_oscillation", {"axis": "sway_yaw"})]
CASE_IDS = [f"{t}-{o.get('axis', '')}".rstrip("-") for t, o in TASK_CASES]


def _actions(rng: np.random.Generator, n: int, k: int = 3) -> np.ndarray:
    return rng.uniform(-1.2, 1.2, size=(n, k))


def _same(a, b) -> bool:
    return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f")


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_check_env_every_registered_id(env_id):
    env = gym.make(env_id)
    assert env.unwrapped.spec is not None and not env.unwrapped.spec.nondeterministic  # determinism is checked
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_make_vec_uses_the_batch():
    venv = gym.make_vec("rig_env/VelocityVectorRoll-v0", num_envs=1024, vectorization_mode="vector_entry_point")
    assert isinstance(venv, RigVectorEnv) and venv.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    obs, _ = venv.reset(seed=0)
    for _ in range(3):
        obs, rew, term, trunc, _ = venv.step(np.zeros((1024, 3)))
    assert obs.shape == (1024, 13) and np.all(np.isfinite(obs)) and not term.any()
    g = gym.make("rig_env/ManoeuvreRig-v0", task="bank_to_bank", free_dofs=("rig_roll", "model_pitch"), airspeed=18.0)
    assert g.observation_space.shape == (13 - 3 + 2,)  # rig_roll, model_pitch + bank task's 2 entries


@pytest.mark.parametrize("task, options", TASK_CASES, ids=CASE_IDS)
def test_same_seed_identical_rollouts_and_other_seed_differs(task, options):
    runs = []
    for seed in (7, 7, 8):
        env = RigVectorEnv(3, task=task, task_options=options, **RICH)
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(0)
        trace = [obs]
        for _ in range(120):  # crosses one autoreset (80 steps per episode)
            obs, rew, term, trunc, _ = env.step(_actions(rng, 3))
            trace += [obs, rew, term, trunc]
        runs.append(trace)
    assert all(_same(a, b) for a, b in zip(runs[0], runs[1]))
    assert not _same(runs[0][0], runs[2][0])


@pytest.mark.parametrize("task, options", TASK_CASES, ids=CASE_IDS)
def test_scalar_env_equals_vector_env_step_by_step(task, options):
    n, seed, check = 33, 100, (0, 17, 32)  # 33 >= PARALLEL_MIN_ENVS: the batch runs the parallel kernel
    venv = RigVectorEnv(n, task=task, task_options=options, **RICH)
    envs = {i: RigEnv(task=task, task_options=options, **RICH) for i in check}
    vobs, _ = venv.reset(seed=seed)
    sobs = {i: envs[i].reset(seed=seed + i)[0] for i in check}
    rng = np.random.default_rng(1)
    ends = 0
    for _ in range(170):  # two autoresets
        a = _actions(rng, n)
        vobs, vr, vt, vtr, vinfo = venv.step(a)
        for i in check:
            o, r, te, tr, info = envs[i].step(a[i])
            assert (te, tr) == (vt[i], vtr[i]) and r == vr[i]
            if te or tr:
                ends += 1
                assert _same(o, vinfo["final_obs"][i])
                for k, v in info.items():
                    assert _same(v, vinfo["final_info"][k][i]), k
                o, _ = envs[i].reset()
            assert _same(o, vobs[i])
    assert ends == 2 * len(check)


@pytest.mark.parametrize("task, options", TASK_CASES, ids=CASE_IDS)
def test_rewards_in_bounds_and_observations_in_space(task, options):
    env = RigVectorEnv(8, task=task, task_options=options, episode_seconds=2.0, turbulence=0.1)
    lo, hi = env.reward_range
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(2)
    for k in range(400):
        a = rng.uniform(-3, 3, size=(8, 3)) if k % 50 < 25 else np.sign(rng.standard_normal((8, 3)))
        obs, rew, term, trunc, info = env.step(a)
        assert obs.dtype == np.float32 and obs in env.observation_space
        assert np.all((lo <= rew) & (rew <= hi))
        if info:
            for i in np.flatnonzero(info["_final_obs"]):
                assert info["final_obs"][i] in env.single_observation_space


def test_out_of_range_actions_are_clipped_and_nonfinite_raise():
    a_env, b_env = RigVectorEnv(2), RigVectorEnv(2)
    a_env.reset(seed=1), b_env.reset(seed=1)
    oa = a_env.step(np.array([[5.0, -7.0, 0.3], [1.0, 2.0, -9.0]]))[0]
    ob = b_env.step(np.array([[1.0, -1.0, 0.3], [1.0, 1.0, -1.0]]))[0]
    assert _same(oa, ob)
    with pytest.raises(ValueError, match="non-finite"):
        a_env.step(np.array([[0.0, np.nan, 0.0], [0.0, 0.0, 0.0]]))
    env = RigEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="non-finite"):
        env.step(np.array([np.inf, 0.0, 0.0]))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(6))


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"colour": "red"}, "unknown configuration name"),
        ({"task": "loop"}, "task"),
        ({"airspeed": 100.0}, "airspeed"),
        ({"airspeed": (20.0, 15.0)}, "airspeed"),
        ({"control_rate": 80.0, "physics_dt": 0.003}, "integer multiple"),
        ({"control_rate": 0.0}, "control_rate"),
        ({"free_dofs": ("rig_roll", "tail")}, "free_dofs"),
        ({"free_dofs": ("model_pitch",)}, "rig_roll"),
        ({"locked_deg": {"rig_roll": 10.0}}, "free"),
        ({"locked_deg": {"rig_pitch": 120.0}}, r"locked_deg.*\[-89"),
        ({"link_delay_steps": -1}, "link_delay_steps"),
        ({"turbulence": 0.5}, "turbulence"),
        ({"randomise": {"mass.tail_mass": (1, 2)}}, "unknown parameter"),
        ({"randomise": {"mass.hawk_mass": (0.01, 1.0)}}, r"mass.hawk_mass.*range"),
        ({"quantise": "yes"}, "quantise"),
        ({"task_options": {"axis": "heave_pitch"}}, "takes no options"),
        ({"task": "forced_oscillation", "task_options": {"axis": "roll"}}, r"axis.*allowed"),
        ({"task": "forced_oscillation", "task_options": {"amplitude": 3}}, "unknown name"),
        ({"task": "forced_oscillation", "task_options": {"axis": ["roll"]}}, r"axis.*allowed"),
        ({"task": "forced_oscillation", "task_options": {"axis": "sway_yaw"}, "free_dofs": ("rig_pitch",)}, "rig_yaw"),
        ({"task": "pull_up_push_over", "free_dofs": ("model_pitch",)}, "rig_pitch"),
        ({"task": "free_flight_emulation", "free_dofs": ("rig_pitch",)}, "model_pitch"),
        ({"task": "departure_recovery", "free_dofs": ("rig_roll",)}, "model_pitch"),
        ({"nonlinear_aero": "on"}, "nonlinear_aero"),
        ({"free_dofs": 5}, r"free_dofs = 5: must be a joint name"),
        ({"locked_deg": None}, r"locked_deg = None: must be a mapping.*\[-89.0, 89.0\] deg"),
        ({"locked_deg": [1, 2]}, r"locked_deg = \[1, 2\]: must be a mapping"),
        ({"task": ["a"]}, r"task = \['a'\]: unknown; valid names"),
        ({"params_file": str(Path(rig_env.__file__).parent)}, r"params_file = .*: a directory"),
        ({"params_file": 5}, r"params_file = 5: must be the path"),
        ({"airspeed": (15, 20, 25)}, r"airspeed = \(15, 20, 25\): must be a number or a \(low, high\) pair, allowed range \[0.0, 40.0\] m/s"),
        ({"airspeed": "20"}, r"airspeed = '20'"),
        ({"randomise": None}, r"randomise = None: must be a mapping"),
        ({"pot_bits": 12.0}, r"pot_bits = 12.0: must be an integer"),
        ({"control_rate": 7.3, "rate_filter_hz": 10.0}, r"rate_filter_hz = 10.0 Hz: allowed range \[0.1, 3.65\] Hz .*control_rate = 7.3 Hz"),
    ],
)
def test_bad_configuration_raises_naming_the_field(fields, match):
    with pytest.raises(ValueError, match=match) as err:
        RigVectorEnv(2, **fields)
    assert "\n" not in str(err.value)


def test_numpy_scalars_are_numbers_and_stored_as_python_numbers():
    """np.float32 / np.int64 wherever a Python number is accepted (they were 'not iterable' or 'must be an integer')."""
    fields = dict(airspeed=np.float32(20), control_rate=np.int64(80), episode_seconds=np.float32(1.0), pot_bits=np.int64(10),
                  encoder_bits=np.int64(12), link_delay_steps=np.int64(2), rate_filter_hz=np.float32(8), turbulence=np.float64(0.01),
                  angle_noise_deg=np.float32(0.1), locked_deg={"rig_pitch": np.int64(3)}, quantise=np.bool_(True))
    env = RigEnv(**fields)
    cfg = env.config
    assert cfg.airspeed == (20.0, 20.0) and RigEnv(airspeed=np.int64(20)).config.airspeed == (20.0, 20.0)
    assert (cfg.pot_bits, cfg.encoder_bits, cfg.link_delay_steps) == (10, 12, 2) and type(cfg.pot_bits) is int
    assert type(cfg.control_rate) is float and type(cfg.rate_filter_hz) is float and cfg.locked_deg == {"rig_pitch": 3.0}
    assert type(cfg.quantise) is bool
    plain = RigEnv(airspeed=20.0, control_rate=80, episode_seconds=1.0, pot_bits=10, encoder_bits=12, link_delay_steps=2, rate_filter_hz=8.0,
                   turbulence=0.01, angle_noise_deg=float(np.float32(0.1)), locked_deg={"rig_pitch": 3.0})
    assert plain.config == cfg
    assert _same(env.reset(seed=3)[0], plain.reset(seed=3)[0]) and _same(env.step(np.zeros(3))[0], plain.step(np.zeros(3))[0])
    from rig_env.envs.render import RigRenderer

    r = RigRenderer(np.int64(640), np.int64(320))  # was 'integers of at least 320 and 160 pixels'
    assert (r.width, r.height) == (640, 320) and type(r.width) is int


@pytest.mark.parametrize("rate", [1.0, 7.3, 19.99])
def test_control_rates_below_20_hz_derive_the_rate_filter(rate):
    """The documented control_rate range [1, 2000] Hz holds: below 20 Hz the rate filter's default corner is the
    Nyquist frequency control_rate / 2 (10 Hz above it), not a refusal blaming rate_filter_hz."""
    env = RigEnv(control_rate=rate, episode_seconds=3.0)
    assert env.config.rate_filter_hz == pytest.approx(rate / 2) and env.config.rate_filter_derived
    env.reset(seed=0)
    for _ in range(3):
        obs, rew, term, trunc, _ = env.step(np.zeros(3))
        assert np.all(np.isfinite(obs)) and 0.0 <= rew <= 1.0 and not term
    assert RigEnv(control_rate=rate, rate_filter_hz=0.4).config.rate_filter_hz == 0.4  # a given corner is kept


def test_rate_filter_default_is_10_hz_from_20_hz_and_follows_the_control_rate():
    from rig_env.envs.config import RigEnvConfig, default_rate_filter_hz

    assert [RigEnvConfig(control_rate=r).rate_filter_hz for r in (20.0, 80.0, 244.0, 2000.0)] == [10.0] * 4
    assert default_rate_filter_hz(7.0) == 3.5 and default_rate_filter_hz(80.0) == 10.0
    slow = RigEnvConfig().with_overrides(control_rate=7.0)  # derived again from the new control rate (was refused)
    assert slow.rate_filter_hz == 3.5 and slow.with_overrides(control_rate=80.0).rate_filter_hz == 10.0
    assert RigEnvConfig(rate_filter_hz=2.0).with_overrides(control_rate=7.0).rate_filter_hz == 2.0  # given: kept
    assert RigVectorEnv(1, RigEnvConfig(), control_rate=7.0).config.rate_filter_hz == 3.5


def test_seeds_beyond_64_bits_are_refused_not_wrapped():
    """2**64 replayed seed 0 (and env 1 of a batch seeded 2**64 - 1 too): refused, naming seed and its range."""
    env = RigEnv()
    with pytest.raises(ValueError, match=r"seed = 18446744073709551616: allowed range \[0, 18446744073709551615\]"):
        env.reset(seed=2**64)
    top = env.reset(seed=2**64 - 1)[0]
    assert not _same(top, env.reset(seed=0)[0])
    vec = RigVectorEnv(2)
    with pytest.raises(ValueError, match=r"seed = 18446744073709551615: allowed range \[0, 18446744073709551614\]"):
        vec.reset(seed=2**64 - 1)
    obs = vec.reset(seed=2**64 - 2)[0]
    assert _same(obs[1], top)  # environment 1 is RigEnv's seed + 1, still below 2**64
    with pytest.raises(gym.error.Error, match="greater or equal to zero"):  # negative: Gymnasium's own refusal
        env.reset(seed=-1)
    with pytest.raises(gym.error.Error, match="greater or equal to zero"):
        vec.reset(seed=-1)


@pytest.mark.parametrize(
    "action, match",
    [
        ("abc", r"action: expected real numbers, shape \(3,\) \(comp_aileron, comp_elevator, comp_rudder\), got str 'abc'"),
        (np.array([0.5 + 1j, 0.0, 0.0]), r"action: .*got complex numbers"),
        ([0.5 + 0j, 0.0, 0.0], r"action: .*got complex numbers"),
        ([None, 0.0, 0.0], r"action: expected real numbers"),
        ([[0.0], 0.0, 0.0], r"action: expected real numbers"),
        (np.zeros(6), r"action: expected real numbers, shape \(3,\).*got shape \(6,\)"),
    ],
)
def test_bad_actions_are_refused_naming_the_action_and_its_shape(action, match):
    env = RigEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=match) as err:
        env.step(action)
    assert "\n" not in str(err.value)
    assert math.isfinite(env.step(np.array([np.float32(0.1), 0, 0.2], dtype=object))[1])  # objects that are numbers step


def test_bad_actions_of_a_batch_and_of_the_sb3_adapter_name_the_expected_shape():
    pytest.importorskip("stable_baselines3")
    from rig_env.envs.sb3 import RigSB3VecEnv

    vec = RigVectorEnv(2)
    vec.reset(seed=0)
    for bad, got in ((np.full((2, 3), "a"), "got ndarray"), (np.zeros((2, 3), dtype=complex), "got complex numbers"), (np.zeros(3), "got shape")):
        with pytest.raises(ValueError, match=rf"actions: expected real numbers, shape \(2, 3\) \(comp_aileron, comp_elevator, comp_rudder\), {got}"):
            vec.step(bad)
    sb3 = RigSB3VecEnv(2)
    sb3.reset()
    with pytest.raises(ValueError, match=r"actions: expected real numbers, shape \(2, 3\) .*got shape \(3,\)"):  # was numpy's reshape error
        sb3.step(np.zeros(3))
    with pytest.raises(ValueError, match=r"actions: .*got complex numbers"):
        sb3.step(np.zeros((2, 3), dtype=complex))
    assert sb3.step(np.zeros(6))[0].shape == (2, 13)  # the flat actions of the batch are reshaped, as before


def test_bad_configuration_through_gymnasium_make():
    with pytest.raises(ValueError, match="unknown configuration name"):
        gym.make("rig_env/BankToBank-v0", max_bank=3)
    with pytest.raises(ValueError, match="num_envs"):
        RigVectorEnv(0)


def test_blown_up_environment_is_terminated_and_reported_rest_carry_on():
    ref, env = RigVectorEnv(4), RigVectorEnv(4)
    ref.reset(seed=5), env.reset(seed=5)
    a = np.full((4, 3), 0.3)
    for _ in range(10):
        ref.step(a), env.step(a)
    env.X[2, L.X_QD + 3] = np.nan  # env 2's state turns non-finite during the next step
    ro, rr, rt, _, _ = ref.step(a)
    eo, er, et, etr, info = env.step(a)
    assert et.tolist() == [False, False, True, False] and not etr.any()
    assert info["_final_info"].tolist() == [False, False, True, False]
    assert info["final_info"]["status"][2] == L.S_NONFINITE and not info["final_info"]["success"][2]
    assert er[2] == 0.0 and np.all(np.isfinite(eo)) and np.all(np.isfinite(info["final_obs"][2]))
    keep = [0, 1, 3]
    assert _same(eo[keep], ro[keep]) and _same(er[keep], rr[keep])
    assert env.status[2] == L.S_OK  # autoreset started a fresh episode
    for _ in range(5):
        ro, rr, *_ = ref.step(a)
        eo, er, *_ = env.step(a)
    assert _same(eo[keep], ro[keep])


def test_parameter_randomisation_rows_equal_param_batch(params):
    env = RigVectorEnv(6, randomise=RANDOMISE)
    env.reset(seed=11)
    cols = {k: rig_env.params.PARAM_INDEX[k] for k in RANDOMISE}
    drawn = {k: env.P[:, c] * (180 / math.pi if k.endswith("_deg") else 1.0) for k, c in cols.items()}
    for k, (lo, hi) in RANDOMISE.items():
        assert np.all((lo <= drawn[k]) & (drawn[k] <= hi)) and np.ptp(drawn[k]) > 0
    np.testing.assert_allclose(env.P, rig_env.param_batch(params, 6, drawn), rtol=0, atol=1e-15)
    expected_delay = np.rint(drawn["servos.compensator.delay_s"] / env.h)
    assert np.array_equal(env.delay_steps[:, 0], expected_delay)


def test_sensors_quantise_delay_and_estimate_rates():
    dt, d = 1 / 80, 3
    s = Sensors(1, ("rig_roll", "model_pitch"), dt, rate_filter_hz=10.0, delay_steps=d, quantise=True)
    rate = np.array([2.0, -0.5])  # rad/s
    s.reset(np.array([0]), np.zeros((1, 2)), np.zeros((1, 4)), np.array([20.0]))
    for k in range(1, 200):
        s.update((rate * k * dt)[None], np.full((1, 4), 0.1), np.array([20.0]))
        if k == d:  # still the held initial sample
            assert np.all(s.angles == 0.0)
    true = rate * (199 - d) * dt
    lsb = np.array([2 * math.pi / 4096, 2 * math.pi / 8192])  # 12-bit potentiometer, 13-bit encoder
    assert np.all(np.abs(s.angles[0] - true) <= lsb / 2 + 1e-15)
    assert np.allclose(np.round(s.angles[0] / lsb) * lsb, s.angles[0], atol=1e-15)
    np.testing.assert_allclose(s.rates[0], rate, rtol=0.02)  # a ramp's filtered difference -> its slope
    assert abs(s.flaps[0, 0] - 0.1) <= math.pi / 8192


def test_step_metrics_of_a_first_order_response_match_theory():
    dt, tau = 0.001, 0.2
    m = StepMetrics(1, dt)
    t, z = 0.0, np.zeros((1, 3))
    for k in range(1, 3001):
        t = k * dt
        y = 1.0 - math.exp(-(t - dt) / tau) if k > 1 else 0.0
        m.update(np.array([t]), np.array([0]), np.array([y]), np.array([1.0]), np.array([1.0 - y]), np.array([0.0]), z, z, np.zeros(1, bool))
    out = m.finish(np.array([0]), np.array([t]))
    assert out["rise_time"][0] == pytest.approx(tau * math.log(9.0), abs=2 * dt)
    assert out["settling_time"][0] == pytest.approx(tau * math.log(20.0), abs=2 * dt)
    assert out["overshoot_pct"][0] == 0.0 and out["segments_settled"][0] == 1


def test_step_metrics_a_segment_that_never_reaches_its_target_is_not_settled():
    dt, z = 0.01, np.zeros((1, 3))
    m = StepMetrics(1, dt)
    for k in range(1, 201):  # segment 0: y stays at 0 while the target is 1; segment 1: target 0, already there
        seg = 0 if k <= 100 else 1
        m.update(np.array([k * dt]), np.array([seg]), np.zeros(1), np.array([1.0 - seg]), np.zeros(1), np.array([0.01]), z, z, np.zeros(1, bool))
    out = m.finish(np.array([0]), np.array([2.0]))
    assert out["segments"][0] == 2 and out["segments_settled"][0] == 1
    assert out["settling_time"][0] == pytest.approx(dt)  # only segment 1's, settled on its first step


def _stop_terminations() -> dict:
    # model-pitch upper stop at 0 deg: envs starting above +2 deg terminate on the first step
    return dict(randomise={"stops.model_pitch.upper_deg": (0.0, 0.0)}, episode_seconds=0.5)


def test_sb3_adapter_reset_semantics_match_dummy_vec_env():
    from stable_baselines3.common.vec_env import DummyVecEnv

    from rig_env.envs.sb3 import RigSB3VecEnv

    n = 4
    ours = RigSB3VecEnv(n, **_stop_terminations())
    ref = DummyVecEnv([lambda: RigEnv(**_stop_terminations()) for _ in range(n)])
    ours.seed(21), ref.seed(21)
    assert _same(ours.reset(), ref.reset())
    rng = np.random.default_rng(4)
    seen = {"terminated": 0, "truncated": 0}
    for _ in range(90):
        a = rng.uniform(-1, 1, size=(n, 3)).astype(np.float32)
        o1, r1, d1, i1 = ours.step(a)
        o2, r2, d2, i2 = ref.step(a)
        assert _same(o1, o2) and _same(r1, r2) and _same(d1, d2)
        for x, y in zip(i1, i2):
            assert set(x) == set(y)
            for k in x:
                assert _same(x[k], y[k]), k
            if "terminal_observation" in x:
                seen["truncated" if x["TimeLimit.truncated"] else "terminated"] += 1
    assert seen["terminated"] > 0 and seen["truncated"] > 0
    assert _same(ours.reset(), ref.reset())  # unseeded reset: next episode of every stream


def test_sb3_ppo_trains_a_few_thousand_steps():
    from stable_baselines3 import PPO

    from rig_env.envs.sb3 import RigSB3VecEnv

    venv = RigSB3VecEnv(8, episode_seconds=2.0)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=128, n_epochs=2, seed=0, device="cpu")
    model.learn(total_timesteps=3072)
    assert model.num_timesteps >= 3072
    obs = venv.reset()
    act, _ = model.predict(obs, deterministic=True)
    assert act.shape == (8, 3) and np.all(np.abs(act) <= 1.0)


def test_velocity_vector_roll_reference_angle_is_the_integral_of_its_rate():
    from rig_env.envs.tasks import VelocityVectorRoll

    n, dt = 5, 1e-4
    task = VelocityVectorRoll(n, ("rig_roll", "model_pitch"), 1 / 80, 8.0)
    task.reset(np.arange(n), np.random.default_rng(0).uniform(size=(n, task.n_draws)))
    ts = np.arange(0.0, 8.0, dt)
    refs = np.stack([task.reference(np.full(n, t)) for t in ts])  # (n_t, n, 2)
    integral = refs[0, :, 0] + np.concatenate([np.zeros((1, n)), np.cumsum(0.5 * (refs[1:, :, 1] + refs[:-1, :, 1]) * dt, axis=0)])
    np.testing.assert_allclose(refs[:, :, 0], integral, atol=1e-6)
    np.testing.assert_allclose(refs[-1, :, 0], task.stop_angle(), atol=1e-12)
    peak = np.degrees(np.abs(refs[:, :, 1]).max(axis=0))
    assert np.all((90.0 <= peak) & (peak <= 360.0)) and np.all(refs[-1, :, 1] == 0.0)


def test_env_seeds_option_equals_scalar_env_seeds():
    """reset(options={"env_seeds": s}) puts environment i on the stream RigEnv.reset(seed=s[i]) uses."""
    seeds = np.array([40, 3, 40])
    venv = RigVectorEnv(3, **RICH)
    vobs, _ = venv.reset(options={"env_seeds": seeds})
    assert _same(vobs[0], vobs[2]) and not _same(vobs[0], vobs[1])
    for i, s in enumerate(seeds):
        env = RigEnv(**RICH)
        o, _ = env.reset(seed=int(s))
        assert _same(o, vobs[i])
    with pytest.raises(ValueError, match="env_seeds"):
        venv.reset(options={"env_seeds": [1, 2]})
    with pytest.raises(ValueError, match="unknown key"):
        venv.reset(options={"seeds": seeds})


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_registered_time_limit_is_the_tasks_own(env_id):
    """spec.max_episode_steps = the task's default_episode_seconds x the default control rate (the longest task's
    for the generic id), and the environment made from the id ends its episodes there itself."""
    from rig_env.envs.config import RigEnvConfig
    from rig_env.envs.registration import MAX_EPISODE_STEPS

    rate = RigEnvConfig().control_rate
    task = ENV_IDS[env_id].get("task")
    seconds = TASKS[task].default_episode_seconds if task else max(t.default_episode_seconds for t in TASKS.values())
    assert gym.spec(env_id).max_episode_steps == MAX_EPISODE_STEPS[env_id] == round(seconds * rate)
    if task:
        assert gym.make(env_id).unwrapped.vec.max_steps == gym.spec(env_id).max_episode_steps


def test_an_episode_through_make_is_truncated_once_at_the_limit_with_its_metrics():
    """gymnasium.make wraps TimeLimit(spec.max_episode_steps); the environment truncates at the same step, so the
    episode ends exactly once, at step 640, with the environment's metrics (not a bare TimeLimit cut)."""
    env = gym.make("rig_env/VelocityVectorRoll-v0")
    assert any(isinstance(w, gym.wrappers.TimeLimit) for w in _wrappers(env))
    env.reset(seed=0)
    ends = []
    for k in range(1, 700):
        _, _, term, trunc, info = env.step(np.zeros(3))
        if term or trunc:
            ends.append((k, term, trunc, "rms_error" in info))
            env.reset()
        if k == 640:
            break
    assert ends == [(640, False, True, True)]


def test_make_vec_caps_the_batch_at_the_spec_and_max_episode_steps_is_checked():
    venv = gym.make_vec("rig_env/ManoeuvreRig-v0", num_envs=2, vectorization_mode="vector_entry_point", task="bank_to_bank")
    assert venv.max_steps == 1360
    assert RigVectorEnv(1, max_episode_steps=5).max_steps == 5 and RigVectorEnv(1, max_episode_steps=-1).max_steps == 640
    with pytest.raises(ValueError, match="max_episode_steps"):
        RigVectorEnv(1, max_episode_steps=0)


def _wrappers(env):
    while isinstance(env, gym.Wrapper):
        yield env
        env = env.env
