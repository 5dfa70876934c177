"""RL training speed: where a PPO iteration's time goes, and time to success against a peer.

    python benchmarks/bench_train.py profile [--repeats 3]      # env vs policy vs learner, per batch geometry
    python benchmarks/bench_train.py race [--seeds 0 1 2]        # velocity-vector roll to 95 % vs PPO on Pendulum-v1

One thread for torch and numba (``--threads``, default 1: the machines are shared; the numbers are per core).

``profile``: PPO on velocity_vector_roll under the comparison's nominal conditions, one ``RigSB3VecEnv`` wrapped as
``rig train`` wraps it (VecMonitor, VecNormalize of observations), one warm-up iteration, then ``--iters``
timed iterations per configuration, the configurations taking turns ``--repeats`` times (the shared machine's
slow spells fall on all alike); the table gives each configuration's median.  "env" is the wall time inside the
batch's ``step_wait``, "policy" the rest of the rollout (forward passes, SB3's buffer and wrappers), "learner"
the time between rollouts (``PPO.train``: the gradient updates).  The first row is the settings before issue 22
(64 environments x 128 steps, 2048-sample minibatches, 5 epochs, 2x64 tanh), the others what was tried.

``race``: in one run, (1) stable-baselines3 PPO on Gymnasium's Pendulum-v1 for 100k steps with the RL Zoo's
hyperparameters (hyperparams/ppo.yml: 4 environments, n_steps 1024, gae_lambda 0.95, gamma 0.9, 10 epochs,
ent_coef 0, learning rate 1e-3, clip 0.2, gSDE with sde_sample_freq 4; batch_size SB3's default 64), its
wall time and final mean return over 10 episodes; (2) ``rig train --algo ppo --task velocity_vector_roll``
(the shipped settings file, nominal randomised conditions, a fresh seed) until its evaluation success
reaches 95 %: the wall time at which it did (the evaluation callback's clock, evaluations included).
Prints both and their ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

CONFIGS: list[dict[str, Any]] = [
    dict(name="before: 64 x 128, mb 2048", n_envs=64, n_steps=128, batch_size=2048, act="tanh", sde=False),
    dict(name="256 x 64, mb 4096", n_envs=256, n_steps=64, batch_size=4096, act="tanh", sde=False),
    dict(name="256 x 64, mb 4096, gSDE (shipped)", n_envs=256, n_steps=64, batch_size=4096, act="tanh", sde=True),
    dict(name="256 x 64, mb 8192", n_envs=256, n_steps=64, batch_size=8192, act="tanh", sde=False),
    dict(name="256 x 64, mb 4096, relu", n_envs=256, n_steps=64, batch_size=4096, act="relu", sde=False),
    dict(name="1024 x 32, mb 8192", n_envs=1024, n_steps=32, batch_size=8192, act="tanh", sde=False),
]
"""5 epochs, 2x64 MLP (tanh unless it says relu), gamma 0.98; gSDE: use_sde, squash_output, log_std_init -2."""


def _threads(n: int) -> None:
    os.environ.setdefault("NUMBA_NUM_THREADS", str(n))
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, str(n))
    import numba
    import torch

    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    torch.set_num_threads(n)


def _machine() -> str:
    import platform

    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}"


class _Setup:
    """One configuration's model and timers, built once and iterated in turns."""

    def __init__(self, cfg: dict[str, Any]) -> None:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

        from controllers.design.conditions import MODES
        from controllers.design.rl_callbacks import EnvTimer
        from rig_env.envs.sb3 import RigSB3VecEnv

        base = RigSB3VecEnv(cfg["n_envs"], task="velocity_vector_roll", **MODES["nominal"].env_fields())
        base.seed(0)
        self.timer = EnvTimer(VecMonitor(base))
        env = VecNormalize(self.timer, norm_obs=True, norm_reward=False, clip_obs=10.0)
        act = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[cfg["act"]]
        sde = dict(use_sde=True, sde_sample_freq=-1) if cfg["sde"] else {}
        pk = dict(net_arch=[64, 64], activation_fn=act, log_std_init=-2.0 if cfg["sde"] else -0.5, squash_output=cfg["sde"])
        self.model = PPO("MlpPolicy", env, n_steps=cfg["n_steps"], batch_size=cfg["batch_size"], n_epochs=5, gamma=0.98,
                         device="cpu", seed=0, policy_kwargs=pk, **sde)
        self.cfg, self.per_iter = cfg, cfg["n_envs"] * cfg["n_steps"]
        outer = self

        class Split(BaseCallback):
            def _on_rollout_start(self) -> None:
                outer.t_start = time.perf_counter()

            def _on_rollout_end(self) -> None:
                outer.collect += time.perf_counter() - outer.t_start

            def _on_step(self) -> bool:
                return True

        self.cb = Split()
        self.collect, self.t_start = 0.0, time.perf_counter()
        self.model.learn(self.per_iter, callback=self.cb)  # warm-up: compile, first buffers
        self.rows: list[tuple[float, float, float, float]] = []

    def run(self, iters: int) -> None:
        self.collect, env0 = 0.0, self.timer.seconds
        t0 = time.perf_counter()
        self.model.learn(self.per_iter * iters, callback=self.cb, reset_num_timesteps=False)
        wall = time.perf_counter() - t0
        env = self.timer.seconds - env0
        n = self.per_iter * iters
        self.rows.append((n / wall, n / env, n / max(self.collect - env, 1e-9), n / max(wall - self.collect, 1e-9)))


def profile(args: argparse.Namespace) -> None:
    _threads(args.threads)
    setups = [_Setup(c) for c in CONFIGS]
    for _ in range(args.repeats):
        for s in setups:
            s.run(args.iters)
    print(f"PPO on velocity_vector_roll (nominal conditions), {args.threads} thread(s), {args.iters} iterations x "
          f"{args.repeats} turns, medians; {_machine()}")
    print("| configuration | steps/s | env steps/s | policy steps/s | learner samples/s | env : policy : learner |")
    print("|---|---|---|---|---|---|")
    for s in setups:
        med = [statistics.median(r[k] for r in s.rows) for k in range(4)]
        inv = [1.0 / med[k] for k in (1, 2, 3)]
        share = " : ".join(f"{100 * x / sum(inv):.0f} %" for x in inv)
        print(f"| {s.cfg['name']} | {med[0]:,.0f} | {med[1]:,.0f} | {med[2]:,.0f} | {med[3]:,.0f} | {share} |")


def pendulum(threads: int, seed: int) -> dict[str, float]:
    """SB3 PPO on Pendulum-v1, 100k steps, the RL Zoo's hyperparameters: wall time s and final mean return."""
    _threads(threads)
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.evaluation import evaluate_policy

    env = make_vec_env("Pendulum-v1", n_envs=4, seed=seed)
    model = PPO("MlpPolicy", env, n_steps=1024, gae_lambda=0.95, gamma=0.9, n_epochs=10, ent_coef=0.0, learning_rate=1e-3,
                clip_range=0.2, use_sde=True, sde_sample_freq=4, seed=seed, device="cpu", verbose=0)
    t0 = time.perf_counter()
    model.learn(100_000)
    wall = time.perf_counter() - t0
    ret, _ = evaluate_policy(model, make_vec_env("Pendulum-v1", n_envs=1, seed=seed + 1000), n_eval_episodes=10)
    return {"wall_s": wall, "mean_return": float(ret)}


def race(args: argparse.Namespace) -> None:
    from controllers.design.rl_train import main as train
    from controllers.laws.artefact import load

    print(f"race, {args.threads} thread(s); {_machine()}", flush=True)
    pend = pendulum(args.threads, args.seeds[0])
    print(f"SB3 PPO, Pendulum-v1, 100k steps (RL Zoo hyperparameters): {pend['wall_s']:.1f} s, final mean return "
          f"{pend['mean_return']:.0f} (10 episodes)", flush=True)
    rows = []
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "vvr"
            train(["--algo", "ppo", "--task", "velocity_vector_roll", "--seed", str(seed), "--threads", str(args.threads),
                   "--no-progress", "--out", str(out)])
            rows.append((seed, load(out / "policy.json").provenance))
    print(f"machine at the end: {_machine()}")
    print("| run | wall s | steps | result | ratio to Pendulum |")
    print("|---|---|---|---|---|")
    print(f"| SB3 PPO, Pendulum-v1 (RL Zoo), 100k steps | {pend['wall_s']:.1f} | 100,000 | mean return {pend['mean_return']:.0f} | 1 |")
    for seed, prov in rows:
        reached, fin = prov["target_reached_at"], prov["final_eval"]["success_rate"]
        if reached is None:
            print(f"| rig train velocity_vector_roll, seed {seed}: not reached | {prov['wall_time_s']:.0f} | {prov['timesteps']:,} | "
                  f"final check {fin:.2f} | - |")
        else:
            print(f"| rig train velocity_vector_roll, seed {seed}, to 95 % eval success | {reached['wall_s']:.1f} | "
                  f"{reached['timesteps']:,} | final check {fin:.2f} (100 episodes) | {reached['wall_s'] / pend['wall_s']:.2f} |")
        print(f"  seed {seed}: time split (s) {prov['time_split_s']}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("what", choices=["profile", "race"])
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--iters", type=int, default=3)
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="race: velocity-vector-roll seeds (Pendulum uses the first)")
    a = p.parse_args(argv)
    {"profile": profile, "race": race}[a.what](a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
