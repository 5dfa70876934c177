"""The task's reward along the path a = k a_LQR: does the reward's optimum sit where the criterion's does?

    python scripts/reward_along_lqr.py                       # free-flight emulation, k = 0 .. 1.25, 64 episodes
    python scripts/reward_along_lqr.py --k 0.5 1 --episodes 32 --seed 30000
    python scripts/reward_along_lqr.py --k 1 --dither 0.1 5 --rate-weights 0.2 0.02   # chatter on top: what it costs

The designed LQR of the task (``make_controller("lqr", ...)``) with its gains scaled by k (the law's estimator
predicts with the command it sends, so the loop stays consistent) flies ``--episodes`` seeded episodes under
the comparison's nominal conditions.  Per k: the mean return (of the task's maximum), the mean tracking and
control parts of the reward from the input's start (the reward is ``track * exp(-c_u)``: the control part is
``exp(-c_u)``), the median episode metric the criterion reads (``emulation_error`` for free-flight emulation,
else the RMS error) and the success share.  A reward that trains as the task defines it peaks near k = 1
(or wherever the criterion's metric is best), not at a weaker law.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np


def sweep(task: str, ks: list[float], episodes: int, seed: int, rate_weights: Sequence[float] = (),
          dither: tuple[float, float] | None = None) -> list[dict[str, Any]]:
    """One row per gain scale k: mean return, mean tracking and control factors of the reward over the scored
    steps (after the free-flight input's start; all steps for other tasks), median metric, success share; and per
    weight w of ``rate_weights`` the mean return the same flights would earn with the command-rate weight w
    (``return_w<w>``; the tracking factor does not depend on it).  ``dither`` (amplitude, Hz): a square wave of that
    amplitude (normalised command) and frequency added to the law's command, a chatter the reward must not pay for."""
    from controllers import LoopSpec, make_controller
    from controllers.design.conditions import MODES
    from rig_env.envs import RigVectorEnv
    from rig_env.envs.tasks import base as tb

    overrides = MODES["nominal"].env_fields()
    env = RigVectorEnv(episodes, task=task, **overrides)
    spec = LoopSpec.from_env(env)
    base = make_controller("lqr", spec, episodes)
    metric = "emulation_error" if task == "free_flight_emulation" else "rms_error"
    rows = []
    for k in ks:
        law = make_controller("lqr", spec, episodes, tables=dataclasses.replace(base.tables, K=k * base.tables.K))
        obs, _ = env.reset(seed=seed)
        law.reset()
        ret, track, ctrl, n_on = (np.zeros(episodes) for _ in range(4))
        a_prev, activity, c_0 = np.zeros((episodes, len(spec.action_names))), np.zeros(episodes), np.zeros(episodes)
        w_task = getattr(env.task, "rate_weight", tb.RATE_WEIGHT)
        ret_w = np.zeros((len(rate_weights), episodes))
        done = np.zeros(episodes, dtype=bool)
        value, success = np.zeros(episodes), np.zeros(episodes, dtype=bool)
        active = spec.obs_labels.index("input_active") if "input_active" in spec.obs_labels else None
        while not done.all():
            on = np.ones(episodes, dtype=bool) if active is None else obs[:, active] > 0.5
            a = law.act(obs)
            if dither is not None:
                t = env.steps * env.dt
                a = np.clip(a + dither[0] * np.sign(np.sin(2.0 * np.pi * dither[1] * t))[:, None] * (a != 0.0), -1.0, 1.0)
            obs, r, term, trunc, infos = env.step(a)
            # the reward's control factor exp(-c_u), recomputed with the task's own kernel and weights
            # (c_0: the deflection and saturation part, activity: the command activity m; c_u = c_0 + w m)
            tb._control_cost_kernel(a, a_prev, tb.RATE_SCALE * env.dt, env.dt / tb.RATE_TAU, tb.SAT_KNEE, 0.0, activity, c_0)
            c_u = c_0 + w_task * activity
            a_prev = a
            live = ~done
            ret += np.where(live, r, 0.0)
            for j, w in enumerate(rate_weights):
                ret_w[j] += np.where(live, r * np.exp(c_u - c_0 - w * activity), 0.0)
            cnt = live & on
            ctrl += np.where(cnt, np.exp(-c_u), 0.0)
            track += np.where(cnt, r * np.exp(c_u), 0.0)
            n_on += cnt
            end = (term | trunc) & live
            if end.any():
                fi = infos["final_info"]
                value[end], success[end] = fi[metric][end], fi["success"][end]
            done |= end
            law.reset(term | trunc)
        row = {"k": k, "return": float(ret.mean()), "max_return": float(env.max_steps), f"median_{metric}": float(np.median(value)),
               "success": float(success.mean())}
        row["track_factor"] = float((track / np.maximum(n_on, 1)).mean())
        row["control_factor"] = float((ctrl / np.maximum(n_on, 1)).mean())
        for j, w in enumerate(rate_weights):
            row[f"return_w{w:g}"] = float(ret_w[j].mean())
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--task", default="free_flight_emulation")
    p.add_argument("--k", type=float, nargs="+", default=[0.0, 0.25, 0.5, 0.75, 1.0, 1.25])
    p.add_argument("--episodes", type=int, default=64)
    p.add_argument("--seed", type=int, default=30_000, help="first episode's seed (default 30000: not the comparison's 0-63)")
    p.add_argument("--rate-weights", type=float, nargs="*", default=[],
                   help="also the return these flights would earn with these command-rate weights (the task's: rate_weight)")
    p.add_argument("--dither", type=float, nargs=2, default=None, metavar=("AMP", "HZ"),
                   help="add a square-wave chatter of AMP (normalised command) at HZ to the law's command")
    a = p.parse_args(argv)
    rows = sweep(a.task, a.k, a.episodes, a.seed, a.rate_weights, None if a.dither is None else tuple(a.dither))
    keys = list(rows[0])
    print(" | ".join(keys))
    for row in rows:
        print(" | ".join(f"{row[c]:.3f}" if isinstance(row[c], float) else str(row[c]) for c in keys))
    return 0


if __name__ == "__main__":
    sys.exit(main())
