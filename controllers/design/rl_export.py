"""From a trained stable-baselines3 model to the rig-law artefact of a PPO/SAC law, and its evaluation.

``export_sb3`` reads the actor's weights, the VecNormalize statistics and the action space off the
live SB3 objects (it calls their methods; it imports stable-baselines3 only to check classes, and
only when called) and returns the :class:`~controllers.laws.artefact.Artefact` that
:func:`controllers.laws.artefact.save` writes (``rig train`` writes ``policy.json`` this way, then adds
the training record to its provenance).  The data is the runtime's (:mod:`controllers.laws.rl`): the
float32 weights as float64 arrays of the same values.  ``evaluate`` is the recorded evaluation whose
numbers go into a policy's provenance and which ``tests/test_rl.py`` reruns: any :class:`Controller`
on ``law.num_envs`` seeded episodes of a :class:`rig_env.envs.RigVectorEnv`.

Only what the runtime reproduces exactly is exported; anything else is a ValueError naming it:

| model | accepted |
|---|---|
| PPO | ``ActorCriticPolicy``, flat Box observations (FlattenExtractor), DiagGaussian actions (no gSDE, no squash) |
| SAC | ``SACPolicy`` actor, flat Box observations, no gSDE |
| both | hidden layers ``nn.Linear`` + one activation type (``nn.Tanh`` or ``nn.ReLU``), VecNormalize of observations or none |
"""

from __future__ import annotations

from typing import Any

import numpy as np

from controllers.laws.artefact import Artefact, _check_body, _body, default_limits, provenance as file_provenance, sensors_of
from controllers.laws.base import Controller, LoopSpec
from controllers.laws.rl import POSTPROCESS, parse_data


def _sequential_layers(seq: Any, where: str) -> tuple[list[tuple[np.ndarray, np.ndarray]], set[str]]:
    """Linear layers and activation names of an ``nn.Sequential`` of Linear/activation pairs."""
    from torch import nn

    names = {nn.Tanh: "tanh", nn.ReLU: "relu"}
    layers, acts, expect_linear = [], set(), True
    for m in seq:
        if isinstance(m, nn.Linear) and expect_linear:
            layers.append((m.weight.detach().cpu().numpy(), m.bias.detach().cpu().numpy()))
        elif type(m) in names and not expect_linear:
            acts.add(names[type(m)])
        else:
            raise ValueError(f"{where}: module {m!r} is not a Linear/activation(tanh, relu) chain; cannot export")
        expect_linear = not expect_linear
    if not expect_linear and layers:
        raise ValueError(f"{where}: ends in a Linear layer without its activation; cannot export")
    return layers, acts


def export_sb3(
    model: Any,
    spec: LoopSpec,
    vecnormalize: Any | None = None,
    env_overrides: dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    action_index: tuple[int, ...] | None = None,
) -> Artefact:
    """The policy of a trained SB3 PPO/SAC ``model`` as a rig-law artefact of kind "ppo" / "sac".

    vecnormalize: the training ``VecNormalize`` (its observation statistics are shipped) or None.
    env_overrides: the environment settings it was trained with (recorded in the provenance; the
    sensor layout and output limits are those of ``RigVectorEnv(1, task=spec.task, **env_overrides)``).
    provenance: the training record (merged over the default provenance).
    action_index: the loop's actions the model commands, when it was trained on a subset
    (:class:`controllers.design.rl_callbacks.ActionSubset`); the others get zero rows in the output layer, so
    the artefact commands them at exactly 0 (tanh(0) and clip(0) are 0 on the symmetric +-1 range).
    Write it with :func:`controllers.laws.artefact.save`.
    """
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.distributions import DiagGaussianDistribution, StateDependentNoiseDistribution
    from stable_baselines3.common.torch_layers import FlattenExtractor
    from torch import nn

    if isinstance(model, PPO):
        kind, pol = "ppo", model.policy
        # gSDE (StateDependentNoiseDistribution) explores with state-dependent noise; its deterministic action is
        # the same mean action_net(latent) as the diagonal Gaussian's, so both export alike, unsquashed
        # the same mean action_net(latent) as the diagonal Gaussian's, so both export alike; with squash_output
        # (gSDE only) the deterministic action is tanh(mean) unscaled to the action space, as SAC's is
        if not isinstance(pol.action_dist, (DiagGaussianDistribution, StateDependentNoiseDistribution)):
            raise ValueError("PPO export: only a DiagGaussian or gSDE action distribution")
        post = "tanh_unscale" if pol.squash_output else "clip"
        extractor = pol.pi_features_extractor if not pol.share_features_extractor else pol.features_extractor
        hidden, acts = _sequential_layers(pol.mlp_extractor.policy_net, "PPO policy_net")
        out = pol.action_net
    elif isinstance(model, SAC):
        kind, pol = "sac", model.policy.actor
        if pol.use_sde:
            raise ValueError("SAC export: gSDE actors are not supported")
        extractor = pol.features_extractor
        hidden, acts = _sequential_layers(pol.latent_pi, "SAC latent_pi")
        out = pol.mu
        post = POSTPROCESS[kind]
    else:
        raise ValueError(f"export_sb3: model of type {type(model).__name__}; expected PPO or SAC")
    if not isinstance(extractor, FlattenExtractor):
        raise ValueError(f"{kind} export: features extractor {type(extractor).__name__}; only FlattenExtractor")
    if not isinstance(out, nn.Linear):
        raise ValueError(f"{kind} export: output module {out!r} is not a Linear layer")
    if len(acts) > 1:
        raise ValueError(f"{kind} export: mixed activations {sorted(acts)}")
    W_out, b_out = out.weight.detach().cpu().numpy(), out.bias.detach().cpu().numpy()
    space = model.action_space
    low, high = np.asarray(space.low, dtype=np.float64), np.asarray(space.high, dtype=np.float64)
    if action_index is not None:
        idx = list(action_index)
        if len(idx) != space.shape[0] or len(set(idx)) != len(idx) or min(idx) < 0 or max(idx) >= spec.n_actions:
            raise ValueError(f"{kind} export: action_index {action_index!r}: {space.shape[0]} distinct indices in [0, {spec.n_actions})")
        W = np.zeros((spec.n_actions, W_out.shape[1]), dtype=W_out.dtype)
        b = np.zeros(spec.n_actions, dtype=b_out.dtype)
        W[idx], b[idx] = W_out, b_out
        W_out, b_out = W, b
        low, high = -np.ones(spec.n_actions), np.ones(spec.n_actions)
        low[idx], high[idx] = np.asarray(space.low), np.asarray(space.high)
    layers = hidden + [(W_out, b_out)]
    if W_out.shape[0] != spec.n_actions or tuple(model.observation_space.shape) != (spec.obs_dim,):
        raise ValueError(f"{kind} export: model spaces {model.observation_space.shape} -> {space.shape} do not match the loop spec")

    overrides = dict(env_overrides or {})
    data: dict[str, Any] = {"activation": acts.pop() if acts else "tanh", "postprocess": post, "obs_norm": None,
                            "action_low": _f64(low), "action_high": _f64(high)}
    for i, (W, b) in enumerate(layers):
        data[f"weight_{i}"], data[f"bias_{i}"] = _f64(W), _f64(b)
    if vecnormalize is not None and vecnormalize.norm_obs:
        rms = vecnormalize.obs_rms
        data.update(obs_mean=np.array(rms.mean, dtype=np.float64), obs_var=np.array(rms.var, dtype=np.float64),
                    obs_norm={"clip_obs": float(vecnormalize.clip_obs), "epsilon": float(vecnormalize.epsilon)})
    parse_data(kind, data, spec)  # what the runtime will accept

    from rig_env.envs import RigVectorEnv

    env = RigVectorEnv(1, task=spec.task, **overrides)
    prov = {**file_provenance(f"controllers.design.rl_export.export_sb3 ({kind})"), **dict(provenance or {}), "env_overrides": overrides}
    art = Artefact(kind, spec, sensors_of(env.config), default_limits(spec, env.params.servos.compensator.rate_limit_deg_s), data, prov)
    _check_body(_body(art), "<export>")
    return art


def _f64(a: Any) -> np.ndarray:
    """A float32 array's values as float64 (exact: every float32 is a float64)."""
    return np.asarray(a, dtype=np.float32).astype(np.float64)


def evaluate(law: Controller, env_overrides: dict[str, Any], seed: int) -> dict[str, Any]:
    """One seeded episode per environment of ``law``: success rate, RMS roll error (deg), returns.

    The batch is ``RigVectorEnv(law.num_envs, task=law.spec.task, **env_overrides)`` reset with
    ``seed`` (environment ``i`` runs the episode of seed ``seed + i``); each environment's first
    episode counts.  Deterministic: the same law, overrides and seed give the same numbers.
    """
    from rig_env.envs import RigVectorEnv

    n = law.num_envs
    env = RigVectorEnv(n, task=law.spec.task, **env_overrides)
    obs, _ = env.reset(seed=seed)
    law.reset()
    ret = np.zeros(n)
    done = np.zeros(n, dtype=bool)
    success = np.zeros(n, dtype=bool)
    rms = np.zeros(n)
    while not done.all():
        obs, r, term, trunc, infos = env.step(law.act(obs))
        ret += np.where(done, 0.0, r)
        end = (term | trunc) & ~done
        if end.any():
            fi = infos["final_info"]
            success[end], rms[end] = fi["success"][end], fi["rms_error"][end]
        done |= end
        law.reset(term | trunc)
    return {
        "episodes": n, "seed": int(seed), "success_rate": float(success.mean()),
        "rms_error_deg": float(rms.mean()), "rms_error_deg_max": float(rms.max()),
        "mean_return": float(ret.mean()), "std_return": float(ret.std()),
        "max_return": float(env.max_steps * env.reward_range[1]),
    }

