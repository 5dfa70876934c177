"""Behaviour-cloning warm start of a PPO policy from a designed law (``rig train --warm-start lqr``).

The designed law (:func:`controllers.make_controller`, e.g. the task's LQR) flies the training batch for
``samples`` environment steps; the policy's deterministic action (the actor's mean, through tanh when the
policy squashes) is regressed on the law's command at the observations the policy sees (normalised with the
statistics the rollout leaves in ``VecNormalize``), and the value function on the law's discounted returns
(cut at episode ends), so that PPO's first advantages are not those of a random critic.  Then PPO trains on
as usual.  What is cloned is the law's command at the states the law visits (no DAgger: the designed laws'
estimators predict with their own command, so they cannot label states another policy flew).

The shipped artefact is unchanged by this: the same MLP, exported as plain data (:mod:`controllers.design.rl_export`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

WARM_START_LAWS = ("lqr", "pid")
"""Designed law kinds ``--warm-start`` accepts."""


def collect(env: Any, law: Any, keep: tuple[int, ...] | None, samples: int, gamma: float) -> dict[str, np.ndarray]:
    """Roll ``law`` out on the training stack ``env`` (an SB3 VecEnv, possibly ``VecNormalize``) for at least
    ``samples`` steps; returns the raw observations ``obs`` (m, n_obs), the law's commands of the policy's
    actions ``act`` (m, k) (columns ``keep`` of the law's, all if None) and the discounted returns ``ret`` (m,),
    each episode's return cut at its end and at the rollout's (the last steps' returns are short by the rest).

    The law acts on the raw observation (``VecNormalize.get_original_obs``), is reset where an episode ends,
    and its command is what the batch flies; ``VecNormalize`` (in training mode) updates its statistics meanwhile.
    """
    n = env.num_envs
    steps = max(math.ceil(samples / n), 1)
    raw = env.reset()
    raw = env.get_original_obs() if hasattr(env, "get_original_obs") else raw
    law.reset()
    obs, act, rew, done = [], [], np.zeros((steps, n)), np.zeros((steps, n), dtype=bool)
    for k in range(steps):
        a = np.asarray(law.act(raw), dtype=np.float64)
        a = a if keep is None else a[:, list(keep)]
        obs.append(np.array(raw, dtype=np.float64))
        act.append(a)
        nxt, r, d, _ = env.step(a.astype(np.float32))
        rew[k], done[k] = r, d
        law.reset(np.asarray(d, dtype=bool))
        raw = env.get_original_obs() if hasattr(env, "get_original_obs") else nxt
    ret = np.zeros((steps, n))
    g = np.zeros(n)
    for k in range(steps - 1, -1, -1):
        g = rew[k] + gamma * np.where(done[k], 0.0, g)
        ret[k] = g
    return {"obs": np.concatenate(obs), "act": np.concatenate(act), "ret": ret.reshape(-1)}


def clone(model: Any, obs: np.ndarray, act: np.ndarray, ret: np.ndarray, epochs: int = 30, batch_size: int = 4096,
          learning_rate: float = 1e-3, seed: int = 0) -> dict[str, float]:
    """Regress the PPO ``model``'s deterministic action on ``act`` (m, k) and its value on ``ret`` (m,) at the
    policy's observations ``obs`` (m, n_obs), already normalised as the policy sees them; Adam, ``epochs`` passes
    in minibatches.  Targets are clipped to +-0.97 where the policy squashes (tanh cannot reach +-1).  Returns the
    mean squared action error before and after (normalised command units) and the value's after."""
    import torch

    pol = model.policy
    gen = torch.Generator().manual_seed(seed)
    x = torch.as_tensor(obs, dtype=torch.float32)
    lim = 0.97 if pol.squash_output else 1.0
    y = torch.as_tensor(np.clip(act, -lim, lim), dtype=torch.float32)
    v = torch.as_tensor(ret, dtype=torch.float32)
    opt = torch.optim.Adam(pol.parameters(), lr=learning_rate)

    def heads(xb: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        f = pol.extract_features(xb)  # as ActorCriticPolicy.forward: one tensor if shared, else (pi, vf)
        f_pi, f_vf = f if isinstance(f, tuple) else (f, f)
        latent_pi, latent_vf = pol.mlp_extractor.forward_actor(f_pi), pol.mlp_extractor.forward_critic(f_vf)
        mean = pol.action_net(latent_pi)
        return (torch.tanh(mean) if pol.squash_output else mean), pol.value_net(latent_vf).squeeze(-1)

    def errors() -> tuple[float, float]:
        with torch.no_grad():
            a, val = heads(x)
            return float(((a - y) ** 2).mean()), float(((val - v) ** 2).mean())

    before, _ = errors()
    pol.set_training_mode(True)
    for _ in range(epochs):
        perm = torch.randperm(x.shape[0], generator=gen)
        for i in range(0, x.shape[0], batch_size):
            idx = perm[i : i + batch_size]
            a, val = heads(x[idx])
            loss = ((a - y[idx]) ** 2).mean() + 0.5 * ((val - v[idx]) ** 2).mean() / max(float(v.var()), 1e-8)
            opt.zero_grad()
            loss.backward()
            opt.step()
    pol.set_training_mode(False)
    after, value_mse = errors()
    return {"action_mse_before": before, "action_mse_after": after, "value_mse_after": value_mse, "return_var": float(v.var())}


def warm_start(model: Any, env: Any, law: Any, keep: tuple[int, ...] | None, samples: int, epochs: int = 30,
               seed: int = 0) -> dict[str, Any]:
    """Behaviour-clone ``law`` into the PPO ``model`` on its training stack ``env`` (module docstring): roll out
    ``samples`` steps, normalise the observations with the statistics ``env`` then holds (if it normalises),
    regress (:func:`clone`).  Returns the record the policy's provenance keeps."""
    data = collect(env, law, keep, samples, float(model.gamma))
    obs = data["obs"]
    if hasattr(env, "normalize_obs"):
        obs = env.normalize_obs(obs)
    fit = clone(model, obs, data["act"], data["ret"], epochs=epochs, seed=seed)
    return {"law": type(law).__name__, "samples": int(obs.shape[0]), "epochs": epochs,
            "law_mean_return_per_step": float(np.mean(data["ret"]) * (1.0 - float(model.gamma))), **fit}
