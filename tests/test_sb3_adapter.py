"""RigSB3VecEnv beyond stepping: frames for SB3's VecVideoRecorder, each environment's spec, the pointer to the adapter."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.wrappers import vector as vw

pytest.importorskip("stable_baselines3")
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import VecVideoRecorder  # noqa: E402

import rig_env.envs  # noqa: E402,F401  registers the ids
from rig_env.envs import RigEnv, RigVectorEnv  # noqa: E402
from rig_env.envs.sb3 import RigSB3VecEnv, as_sb3_vec_env  # noqa: E402


def test_get_images_are_the_batch_frames_and_render_tiles_them():
    env = RigSB3VecEnv(2, render_mode="rgb_array", episode_seconds=0.1)
    env.seed(0)
    env.reset()
    images = env.get_images()
    assert len(images) == 2 and all(im.shape == (448, 1024, 3) and im.dtype == np.uint8 for im in images)
    np.testing.assert_array_equal(images[1], env.vec.render()[1])
    big = env.render()
    assert big.shape[2] == 3 and big.shape[0] * big.shape[1] >= 2 * 448 * 1024
    assert env.metadata["render_fps"] == 80 and RigSB3VecEnv(1).get_images() == [None]


def test_vec_video_recorder_writes_a_video(tmp_path):
    """SB3's recorder over the adapter: a short mp4 (moviepy) of the first frames, at the control rate."""
    pytest.importorskip("moviepy")
    env = VecVideoRecorder(RigSB3VecEnv(1, render_mode="rgb_array", episode_seconds=0.05), str(tmp_path),
                           record_video_trigger=lambda step: step == 0, video_length=5, name_prefix="rig")
    env.seed(0)
    env.reset()
    for _ in range(7):  # 4 steps per episode: the video crosses an autoreset
        env.step_async(np.zeros((1, 3)))
        env.step_wait()
    env.close()
    videos = list(tmp_path.glob("rig*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
    assert env.frames_per_sec == 80


def test_human_render_shows_environment_zero_headless():
    """render('human') shows the batch's window (SB3's base class would call env_method, which the adapter has not)."""
    env = RigSB3VecEnv(1, render_mode="human", episode_seconds=0.05)
    with pytest.warns(UserWarning, match="nothing is shown"):  # headless: the window warns once, on the first show
        env.reset()
    assert env.render() is None and env.render("human") is None


def test_get_attr_spec_rebuilds_the_environment():
    env = RigSB3VecEnv(2, task="bank_to_bank", episode_seconds=2.0, airspeed=(15.0, 20.0))
    specs = env.get_attr("spec")
    assert len(specs) == 2 and specs[0].id == "rig_env/BankToBank-v0"
    assert specs[0].max_episode_steps == 160 and specs[0].kwargs == {"task": "bank_to_bank", "episode_seconds": 2.0, "airspeed": (15.0, 20.0)}
    one = gym.make(specs[0])  # the spec makes one environment of the batch
    assert one.observation_space == env.observation_space and one.unwrapped.vec.max_steps == 160
    other = RigSB3VecEnv(1, task="forced_oscillation", task_options={"axis": "sway_yaw"}).get_attr("spec")[0]
    assert other.id == "rig_env/ForcedOscillation-v0" and other.kwargs == {"task": "forced_oscillation", "task_options": {"axis": "sway_yaw"}}


def test_a_gymnasium_vector_env_is_pointed_at_the_adapter():
    vec = RigVectorEnv(2)
    assert isinstance(as_sb3_vec_env(vec), RigSB3VecEnv) and as_sb3_vec_env(vec).vec is vec
    single = RigEnv()
    assert as_sb3_vec_env(single) is single
    for bad in (vw.NormalizeObservation(RigVectorEnv(2, autoreset_mode=AutoresetMode.NEXT_STEP)),
                SyncVectorEnv([RigEnv, RigEnv])):
        with pytest.raises(TypeError, match="RigSB3VecEnv"):
            as_sb3_vec_env(bad)
    with pytest.raises(ValueError, match="same-step"):
        RigSB3VecEnv.wrap(RigVectorEnv(1, autoreset_mode=AutoresetMode.NEXT_STEP))
    model = PPO("MlpPolicy", as_sb3_vec_env(vec), n_steps=8, batch_size=8, device="cpu")
    assert model.get_env().num_envs == 2


@pytest.mark.parametrize("mode", ["NextStep", AutoresetMode.NEXT_STEP])
def test_next_step_autoreset_is_refused_on_the_keyword_path_too(mode):
    """RigSB3VecEnv(n, autoreset_mode=NEXT_STEP) built and then failed with KeyError 'final_info' at the first
    episode end: refused at construction, as RigSB3VecEnv.wrap refuses a next-step batch."""
    with pytest.raises(ValueError, match="same-step autoreset"):
        RigSB3VecEnv(1, autoreset_mode=mode, episode_seconds=0.05)
    with pytest.raises(ValueError, match="autoreset_mode = 'Bogus'"):
        RigSB3VecEnv(1, autoreset_mode="Bogus")
    env = RigSB3VecEnv(1, autoreset_mode="SameStep", episode_seconds=0.05)  # same-step by name is SB3's protocol
    env.reset()
    dones = [env.step(np.zeros((1, 3)))[2][0] for _ in range(5)]
    assert dones == [False, False, False, True, False]


def test_spec_of_a_slow_batch_derives_its_rate_filter_again():
    """A rate filter derived from the control rate is not recorded as an override: the spec's environment
    derives it the same way (and a changed control_rate in the spec derives it anew)."""
    env = RigSB3VecEnv(1, control_rate=7.0)
    spec = env.get_attr("spec")[0]
    assert spec.kwargs == {"task": "velocity_vector_roll", "control_rate": 7.0}
    assert gym.make(spec).unwrapped.config.rate_filter_hz == 3.5 == env.vec.config.rate_filter_hz
    given = RigSB3VecEnv(1, control_rate=7.0, rate_filter_hz=2.0).get_attr("spec")[0]
    assert given.kwargs["rate_filter_hz"] == 2.0
