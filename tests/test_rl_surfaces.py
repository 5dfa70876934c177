"""The RL laws fly the compensator surfaces that move a free rig joint (``acting_surfaces`` in the training
settings): the geometry against the physics, and the exported artefact commanding the others at exactly 0."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import rig_env
from controllers import LoopSpec, make_controller
from controllers.laws.artefact import load, save
from controllers.laws.axes import SURFACES, acting_surfaces
from rig_env.envs.tasks import TASKS

D = np.pi / 180.0


def test_acting_surfaces_by_hand():
    assert acting_surfaces(("rig_roll", "model_pitch")) == (0,)
    assert acting_surfaces(("rig_pitch", "model_pitch")) == (1,)
    assert acting_surfaces(("rig_yaw",)) == (2,)
    assert acting_surfaces(("rig_roll", "rig_yaw")) == (0, 1, 2)  # rolled, the elevator sways the rig too
    assert acting_surfaces(("rig_pitch", "rig_yaw")) == (1, 2)
    assert acting_surfaces(("model_pitch", "model_yaw")) == ()


@pytest.mark.parametrize("task", sorted(TASKS))
def test_the_surfaces_left_out_barely_move_the_free_joints(task):
    """Against the multibody model: from the task's free joints at rest (rig pitch 7 deg, rig roll 20 deg when
    free), 10 deg on each acting surface moves a free joint by more than 0.5 deg in 0.5 s (0.87-0.93 deg the least,
    bank-to-bank and departure recovery with rig roll and yaw free: the default rig's 0.398 kg m roll imbalance
    resists the aileron at 20 deg of bank); on each surface
    left out, by less than 1 % of the smallest acting surface's effect (what remains is the flap's drag
    and the compensator's offsets, not its lift)."""
    p = rig_env.RigParams.default()
    free = TASKS[task].default_free_dofs
    q0 = np.zeros(5)
    q0[1] = 7.0 * D
    if "rig_roll" in free:
        q0[0] = 20.0 * D
    rest = rig_env.simulate(p, q0, np.zeros(5), 0.5, free_dofs=free, airspeed=20.0)
    effect = []
    for s in SURFACES:
        r = rig_env.simulate(p, q0, np.zeros(5), 0.5, free_dofs=free, airspeed=20.0, controls={s: 10.0})
        effect.append(np.abs(r.q - rest.q).max())
    keep = acting_surfaces(free)
    assert keep, task
    smallest = min(effect[i] for i in keep)
    assert smallest > 0.5 * D
    for i in set(range(3)) - set(keep):
        assert effect[i] < 0.01 * smallest, (task, SURFACES[i], effect)


def test_a_policy_trained_on_a_subset_exports_zero_commands_for_the_rest(tmp_path):
    """A tiny PPO on velocity-vector roll's acting surface (the aileron): the exported artefact's runtime
    gives SB3's deterministic action on the aileron and exactly 0 on the elevator and rudder."""
    import torch
    from stable_baselines3 import PPO

    from controllers.design.rl_callbacks import ActionSubset
    from controllers.design.rl_export import export_sb3
    from rig_env.envs.sb3 import RigSB3VecEnv

    torch.set_num_threads(1)
    base = RigSB3VecEnv(4, task="velocity_vector_roll")
    base.seed(1)
    keep = acting_surfaces(base.vec.free_dofs)
    env = ActionSubset(base, keep)
    assert env.action_space.shape == (1,)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=64, n_epochs=1, seed=1, device="cpu", use_sde=True,
                policy_kwargs=dict(net_arch=[16, 16], squash_output=True, log_std_init=-1.0))
    model.learn(128)
    spec = LoopSpec.from_env(base)
    path = tmp_path / "policy.json"
    save(export_sb3(model, spec, None, action_index=keep), path)
    law = make_controller("ppo", spec, 64, path=path)
    obs = np.random.default_rng(0).uniform(-1, 1, (64, spec.obs_dim)).astype(np.float32)
    got = law.act(obs)
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(got[:, 0], expected[:, 0], atol=1e-5)
    assert np.ptp(got[:, 0]) > 1e-4
    assert np.all(got[:, 1:] == 0.0)
    with pytest.raises(ValueError, match="action_index"):
        export_sb3(model, spec, None, action_index=(0, 1))
    with pytest.raises(ValueError, match="keep"):
        ActionSubset(base, (3,))
    assert load(path).data["weight_2"][1:].sum() == 0.0
