"""From a trained stable-baselines3 model to the plain-data policy of :mod:`controllers.laws.rl`, and its evaluation.

``export_sb3`` reads the actor's weights, the VecNormalize statistics and the action space off the
live SB3 objects (it calls their methods; it imports stable-baselines3 only to check classes, and
only when called).  ``evaluate`` is the recorded evaluation whose numbers go into a policy's
provenance and which ``tests/test_rl.py`` reruns: any :class:`Controller` on ``law.num_envs`` seeded
episodes of a :class:`rig_env.envs.RigVectorEnv`.

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

from controllers.laws.base import Controller, LoopSpec
from controllers.laws.rl import FORMAT, FORMAT_VERSION, POSTPROCESS


def encode(a: Any) -> list:
    """Float32 array as nested lists of the shortest decimals that read back to the same float32 values.

    JSON carries float64; each value is written as the shortest float32 decimal when that parses back
    to the identical float32, else as the exact float64 of the float32 value (always exact).
    """
    a32 = np.asarray(a, dtype=np.float32)
    short = np.array([float(str(v)) for v in a32.ravel()], dtype=np.float64)
    exact = a32.ravel().astype(np.float64)
    same = short.astype(np.float32) == a32.ravel()
    return np.where(same, short, exact).reshape(a32.shape).tolist()


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
) -> dict[str, Any]:
    """The policy of a trained SB3 PPO/SAC ``model`` as a policy-file payload (see ``controllers.laws.rl``).

    vecnormalize: the training ``VecNormalize`` (its observation statistics are shipped) or None.
    Pass the payload to :func:`controllers.laws.rl.save_policy`.
    """
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.distributions import DiagGaussianDistribution
    from stable_baselines3.common.torch_layers import FlattenExtractor
    from torch import nn

    if isinstance(model, PPO):
        kind, pol = "ppo", model.policy
        if not isinstance(pol.action_dist, DiagGaussianDistribution) or pol.squash_output:
            raise ValueError("PPO export: only a DiagGaussian action distribution without squashing (no gSDE)")
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
    else:
        raise ValueError(f"export_sb3: model of type {type(model).__name__}; expected PPO or SAC")
    if not isinstance(extractor, FlattenExtractor):
        raise ValueError(f"{kind} export: features extractor {type(extractor).__name__}; only FlattenExtractor")
    if not isinstance(out, nn.Linear):
        raise ValueError(f"{kind} export: output module {out!r} is not a Linear layer")
    if len(acts) > 1:
        raise ValueError(f"{kind} export: mixed activations {sorted(acts)}")
    layers = hidden + [(out.weight.detach().cpu().numpy(), out.bias.detach().cpu().numpy())]
    space = model.action_space
    if tuple(space.shape) != (spec.n_actions,) or tuple(model.observation_space.shape) != (spec.obs_dim,):
        raise ValueError(f"{kind} export: model spaces {model.observation_space.shape} -> {space.shape} do not match the loop spec")

    obs_norm = None
    if vecnormalize is not None and vecnormalize.norm_obs:
        rms = vecnormalize.obs_rms
        obs_norm = {"mean": np.asarray(rms.mean, dtype=np.float64).tolist(), "var": np.asarray(rms.var, dtype=np.float64).tolist(),
                    "clip_obs": float(vecnormalize.clip_obs), "epsilon": float(vecnormalize.epsilon)}
    payload = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": kind,
        "loop_spec": {
            "task": spec.task, "free_dofs": list(spec.free_dofs), "obs_labels": list(spec.obs_labels),
            "action_names": list(spec.action_names), "dt": spec.dt, "airspeed_range": list(spec.airspeed_range),
            "action_scale_deg": spec.action_scale_deg,
        },
        "env_overrides": dict(env_overrides or {}),
        "network": {
            "activation": acts.pop() if acts else "tanh",
            "layers": [{"weight": encode(W), "bias": encode(b)} for W, b in layers],
        },
        "obs_norm": obs_norm,
        "action": {"postprocess": POSTPROCESS[kind], "low": encode(space.low), "high": encode(space.high)},
        "provenance": dict(provenance or {}),
    }
    return payload


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

