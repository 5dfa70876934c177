"""RigVectorEnv's two autoreset modes under Gymnasium's vector wrappers, against SyncVectorEnv over RigEnv."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.wrappers import vector as vw

import rig_env.envs  # registers the ids
from rig_env.envs import RigEnv, RigVectorEnv

# short episodes (40 control steps at 80 Hz) with every random source on: many autoresets in a few hundred steps
SHORT = dict(episode_seconds=0.5, turbulence=0.05, link_delay_steps=2, randomise={"mass.hawk_mass": (0.8, 1.5)})
NEXT = AutoresetMode.NEXT_STEP


def _actions(rng: np.random.Generator, n: int, k: int = 3) -> np.ndarray:
    return rng.uniform(-1.2, 1.2, size=(n, k))


def _full_elevator(rng: np.random.Generator, n: int) -> np.ndarray:
    """Full compensator elevator with a little noise: the departure task's model pitch runs into its stop."""
    return np.array([0.0, 1.0, 0.0]) + rng.uniform(-0.1, 0.1, size=(n, 3))


@pytest.mark.parametrize("task, policy, min_term", [("velocity_vector_roll", _actions, 0), ("bank_to_bank", _actions, 0),
                                                     ("departure_recovery", _full_elevator, 1)])
def test_next_step_equals_sync_vector_env_of_rigenv(task, policy, min_term):
    """Observations, rewards, terminations, truncations and the end-of-episode metrics equal Gymnasium's own
    next-step vectorisation of the scalar environment, step for step, across several autoresets (truncations,
    and terminations at a stop for the departure task)."""
    n, seed, steps = 3, 11, 170
    venv = RigVectorEnv(n, task=task, autoreset_mode=NEXT, **SHORT)
    sync = SyncVectorEnv([lambda: RigEnv(task=task, **SHORT)] * n, autoreset_mode=NEXT)
    assert venv.metadata["autoreset_mode"] is NEXT
    o1, _ = venv.reset(seed=seed)
    o2, _ = sync.reset(seed=seed)
    np.testing.assert_array_equal(o1, o2)
    rng, ends, restarts, terms = np.random.default_rng(1), 0, 0, 0
    done_before = np.zeros(n, dtype=bool)
    for _ in range(steps):
        a = policy(rng, n)
        r1 = venv.step(a)
        r2 = sync.step(a)
        for x, y in zip(r1[:4], r2[:4]):
            np.testing.assert_array_equal(x, y)
        done, terms = r1[2] | r1[3], terms + int(r1[2].sum())
        if done.any():
            ends += int(done.sum())
            for k in ("success", "rms_error", "status"):
                m = r2[4][f"_{k}"]
                np.testing.assert_array_equal(r1[4][f"_{k}"], m)
                np.testing.assert_allclose(r1[4][k][m], r2[4][k][m].astype(float))
        restarts += int(done_before.sum())
        assert np.all(r1[1][done_before] == 0.0) and not (r1[2] | r1[3])[done_before].any()  # the reset step
        done_before = done
    assert ends >= 2 * n and restarts >= n and terms >= min_term  # several autoresets in every environment


def test_next_step_actions_differ_only_where_used():
    """On the step after an end the action of that environment is ignored (its result is the reset)."""
    venv = RigVectorEnv(2, autoreset_mode="NextStep", episode_seconds=0.1)
    venv.reset(seed=3)
    for _ in range(venv.max_steps):
        _, _, _, trunc, _ = venv.step(np.zeros((2, 3)))
    assert trunc.all()
    o_a, *_ = venv.step(np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]))
    venv.reset(seed=3)
    for _ in range(venv.max_steps):
        venv.step(np.zeros((2, 3)))
    o_b, *_ = venv.step(np.zeros((2, 3)))
    np.testing.assert_array_equal(o_a, o_b)


def test_same_step_default_is_unchanged():
    """Same-step (the default and SB3's): reset observation returned, the last one in final_obs, equal to RigEnv."""
    venv = RigVectorEnv(2, **SHORT)
    assert venv.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    env = RigEnv(**SHORT)
    venv.reset(seed=5)
    o, _ = env.reset(seed=5)
    rng = np.random.default_rng(0)
    for _ in range(90):
        a = _actions(rng, 2)
        vo, vr, vte, vtr, info = venv.step(a)
        o, r, te, tr, i1 = env.step(a[0])
        if te or tr:
            np.testing.assert_array_equal(info["final_obs"][0], o)
            assert info["final_info"]["success"][0] == i1["success"]
            o, _ = env.reset()
        np.testing.assert_array_equal(vo[0], o)
        assert (vr[0], vte[0], vtr[0]) == (r, te, tr)


def test_bad_autoreset_mode_is_named():
    with pytest.raises(ValueError, match="autoreset_mode"):
        RigVectorEnv(1, autoreset_mode=AutoresetMode.DISABLED)
    with pytest.raises(ValueError, match="autoreset_mode"):
        RigVectorEnv(1, autoreset_mode="sometimes")


def test_make_vec_passes_autoreset_mode():
    venv = gym.make_vec("rig_env/BankToBank-v0", num_envs=2, vectorization_mode="vector_entry_point", autoreset_mode=NEXT)
    assert isinstance(venv, RigVectorEnv) and venv.metadata["autoreset_mode"] is NEXT


def _next(n: int = 4) -> RigVectorEnv:
    return RigVectorEnv(n, autoreset_mode=NEXT, episode_seconds=0.25)


def test_normalize_observation_runs_and_normalises():
    env = vw.NormalizeObservation(_next())
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    obs = [env.step(_actions(rng, 4))[0] for _ in range(60)]
    late = np.concatenate(obs[30:])
    assert np.all(np.isfinite(late)) and np.all(np.abs(late.mean(axis=0)) < 3.0)
    assert env.obs_rms.count > 60 * 4


def test_transform_flatten_and_dtype_observation():
    base = _next()
    low = base.single_observation_space.low
    single = gym.spaces.Box(2.0 * low, 2.0 * base.single_observation_space.high, dtype=np.float32)
    tr = vw.TransformObservation(base, lambda o: 2.0 * o, single_observation_space=single)
    o_t, _ = tr.reset(seed=0)
    o_b, _ = RigVectorEnv(4, autoreset_mode=NEXT, episode_seconds=0.25).reset(seed=0)
    np.testing.assert_array_equal(o_t, 2.0 * o_b)
    fl = vw.FlattenObservation(_next())
    assert fl.reset(seed=0)[0].shape == (4, low.size)
    dt = vw.DtypeObservation(_next(), np.float64)
    o, _ = dt.reset(seed=0)
    assert o.dtype == np.float64
    for _ in range(25):  # across an autoreset (20 steps per episode)
        o, *_ = dt.step(np.zeros((4, 3)))
        o2, *_ = fl.step(np.zeros((4, 3)))
    assert o.dtype == np.float64 and o2.shape == (4, low.size)


def test_wrappers_refuse_same_step_as_gymnasium_says():
    """The reason for next-step mode: NormalizeObservation refuses the default same-step batch."""
    with pytest.raises(ValueError, match="NEXT_STEP"):
        vw.NormalizeObservation(RigVectorEnv(2))


def test_cleanrl_style_rollout_loop():
    """The CleanRL PPO collection loop: RecordEpisodeStatistics + NormalizeObservation over make_vec, next-step mode,
    a buffer of (obs, action, reward, done) with ``next_done`` carried; episodes are counted once each."""
    n, T = 4, 50
    envs = gym.make_vec("rig_env/VelocityVectorRoll-v0", num_envs=n, vectorization_mode="vector_entry_point",
                        autoreset_mode=NEXT, episode_seconds=0.25)
    envs = vw.RecordEpisodeStatistics(envs)
    envs = vw.ClipAction(envs)
    envs = vw.NormalizeObservation(envs)
    envs = vw.TransformObservation(envs, lambda o: np.clip(o, -10, 10))
    next_obs, _ = envs.reset(seed=1)
    next_done = np.zeros(n, dtype=bool)
    obs_buf = np.zeros((T, n) + envs.single_observation_space.shape, dtype=np.float32)
    rew_buf, done_buf = np.zeros((T, n)), np.zeros((T, n), dtype=bool)
    rng, episodes = np.random.default_rng(0), []
    for t in range(T):
        obs_buf[t], done_buf[t] = next_obs, next_done
        action = rng.normal(size=(n, 3))  # the policy stands in; ClipAction bounds it
        next_obs, reward, term, trunc, info = envs.step(action)
        rew_buf[t], next_done = reward, term | trunc
        if "episode" in info:
            episodes += list(info["episode"]["l"][info["_episode"]])
    assert np.all(np.isfinite(obs_buf)) and np.all((rew_buf >= 0) & (rew_buf <= 1))
    assert episodes and all(length == 20 for length in episodes)  # 0.25 s at 80 Hz, counted once each
    assert len(episodes) == n * 2  # steps 20 and 41 end episodes (step 21 is the reset): two per environment in 50
