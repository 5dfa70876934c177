"""Training-side helpers of ``rig train``: success in the infos, evaluation, stopping, progress, the curve.

| piece | what |
|---|---|
| ``SuccessInfo`` | VecEnvWrapper: copies the task's ``success`` into ``is_success`` (what SB3's EvalCallback counts) |
| ``ErrorReset`` | VecEnvWrapper: ends a training episode once the tracking error passes a bound (curriculum) |

The reward is always the task's own (``rig_env.envs.tasks``: its wide term ranks actions at large errors,
its rate terms sit on the success criterion's scale, its control-rate cost makes chatter never optimal);
what used to be training-side shaping here (potential shaping on the errors, a hold-rate penalty) is
part of the tasks' rewards now.
| ``SeededEvalCallback`` | EvalCallback that reseeds its batch before each evaluation and records wall time |
| ``StopAtSuccess`` | after an evaluation: stop once the success rate reaches the target |
| ``EnvTimer`` | VecEnvWrapper: wall time spent in the environment's ``step_wait`` (the native batch and the wrappers under it) |
| ``Progress`` | a tqdm bar (a printed line every 10 s without tqdm): steps/s and the split into environment, policy and learner time |
| ``plot_curve`` | mean return and success rate vs timesteps, PNG |
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import (
    BaseCallback,
    CallbackList,
    CheckpointCallback,
    EvalCallback,
)
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

class SuccessInfo(VecEnvWrapper):
    """Adds ``infos[i]["is_success"] = infos[i]["success"]`` on finishing steps (RigSB3VecEnv's episode metric)."""

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        obs, rew, done, infos = self.venv.step_wait()
        for i in np.flatnonzero(done):
            infos[i]["is_success"] = bool(infos[i].get("success", False))
        return obs, rew, done, infos


class ActionSubset(VecEnvWrapper):
    """The policy commands only the actions ``keep`` (indices); the others are held at 0 (neutral).

    ``rig train`` keeps the compensator surfaces that move a free rig joint
    (:func:`controllers.laws.axes.acting_surfaces`): a surface on a locked axis does nothing for the task,
    and a squashed (tanh) policy left to explore it drifts to a large deflection.  The exported policy
    commands every action, with zero weights for the held ones (:func:`controllers.design.rl_export.export_sb3`).
    """

    def __init__(self, venv: VecEnv, keep: tuple[int, ...]) -> None:
        from gymnasium import spaces

        full = venv.action_space
        if not keep or min(keep) < 0 or max(keep) >= full.shape[0] or len(set(keep)) != len(keep):
            raise ValueError(f"ActionSubset: keep = {keep!r}: distinct indices in [0, {full.shape[0]})")
        self.keep = tuple(int(i) for i in keep)
        self.n_full = int(full.shape[0])
        space = spaces.Box(full.low[list(self.keep)], full.high[list(self.keep)], dtype=full.dtype)
        super().__init__(venv, action_space=space)

    def reset(self) -> Any:
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        a = np.zeros((actions.shape[0], self.n_full), dtype=np.float32)
        a[:, list(self.keep)] = actions
        self.venv.step_async(a)

    def step_wait(self) -> Any:
        return self.venv.step_wait()


class ErrorReset(VecEnvWrapper):
    """Training curriculum: end an episode early once ``|o[label]| > limit`` (a lost track), as a failure.

    Sits directly on a :class:`RigSB3VecEnv` (``base``); the lost environments are reset in place through
    ``base.vec.reset(options={"reset_mask": ...})`` and reported as terminated (``terminal_observation``
    set, not truncated).  The task's reward is nonnegative, so losing the remaining steps is the
    penalty.  ``limit = inf`` is the identity (used on the eval batch).
    """

    def __init__(self, base: Any, label: str | None, limit: float) -> None:
        super().__init__(base)
        self.base = base
        self.col = base.vec.obs_labels.index(label) if label is not None else 0
        self.limit = float(limit)

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        obs, rew, done, infos = self.venv.step_wait()
        lost = (np.abs(obs[:, self.col]) > self.limit) & ~done
        if lost.any():
            for i in np.flatnonzero(lost):
                infos[i]["terminal_observation"] = obs[i].copy()
                infos[i]["TimeLimit.truncated"] = False
            new, _ = self.base.vec.reset(options={"reset_mask": lost})
            obs = np.where(lost[:, None], new, obs)
            done = done | lost
        return obs, rew, done, infos


class SeededEvalCallback(EvalCallback):
    """EvalCallback on the same seeded episodes every time; keeps (timesteps, wall s, return, success) points."""

    def __init__(self, eval_env: VecEnv, eval_seed: int, curve_path: Path | None = None,
                 points: list[dict[str, float]] | None = None, wall_offset: float = 0.0, **kwargs: Any) -> None:
        super().__init__(eval_env, **kwargs)
        self.eval_seed = eval_seed
        self.points: list[dict[str, float]] = list(points or [])  # a resumed run's earlier points
        self.curve_path, self.wall_offset = curve_path, wall_offset
        self.t0 = time.perf_counter()
        self.eval_seconds = 0.0

    def _on_training_start(self) -> None:
        self.t0 = time.perf_counter()

    def _on_step(self) -> bool:
        if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:
            self.eval_env.seed(self.eval_seed)  # consumed by the reset at the start of the evaluation
            t = time.perf_counter()
            out = super()._on_step()
            self.eval_seconds += time.perf_counter() - t
            return out
        return super()._on_step()

    def _on_event(self) -> bool:
        """Right after each evaluation, before ``callback_after_eval``: record the point."""
        succ = float(np.mean(self._is_success_buffer)) if self._is_success_buffer else float("nan")
        self.points.append({
            "timesteps": int(self.num_timesteps), "wall_s": round(self.wall_offset + time.perf_counter() - self.t0, 1),
            "mean_return": round(float(self.last_mean_reward), 2), "success_rate": succ,
        })
        if self.curve_path is not None:  # after every evaluation: a resumed run keeps its curve
            import json

            self.curve_path.write_text(json.dumps(self.points, indent=1) + "\n")
        print(f"  eval at {self.num_timesteps:>9d} steps, {self.points[-1]['wall_s']:7.1f} s: "
              f"return {self.last_mean_reward:7.1f}, success {succ:.2f}", flush=True)
        return super()._on_event()


class StopAtSuccess(BaseCallback):
    """Child of the eval callback: stop training when the last evaluation's success rate >= target."""

    def __init__(self, target: float | None) -> None:
        super().__init__()
        self.target = target
        self.reached: dict[str, float] | None = None

    def _on_step(self) -> bool:
        parent = self.parent
        assert isinstance(parent, SeededEvalCallback)
        if not parent.points or self.reached is not None:
            return True
        if parent.points[-1]["success_rate"] >= self.target_or_never:
            self.reached = dict(parent.points[-1])
            return False
        return True

    @property
    def target_or_never(self) -> float:
        return self.target if self.target is not None else np.inf


class EnvTimer(VecEnvWrapper):
    """Identity wrapper that adds up the wall time of the wrapped batch's ``step_wait`` (``seconds``)."""

    def __init__(self, venv: VecEnv) -> None:
        super().__init__(venv)
        self.seconds = 0.0

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        t = time.perf_counter()
        out = self.venv.step_wait()
        self.seconds += time.perf_counter() - t
        return out


class Progress(BaseCallback):
    """Progress and where the time goes: environment (``EnvTimer``), evaluation, policy (the rest of the
    rollout: forward passes, SB3's buffers and wrappers) and learner (between rollouts: the gradient updates).

    With tqdm: a bar over the budget, its postfix the shares; without: a printed line every ``every_s`` seconds.
    :meth:`split` gives the seconds of each part (recorded in the policy's provenance).
    """

    def __init__(self, total: int, env_timer: EnvTimer, eval_cb: "SeededEvalCallback", every_s: float = 10.0, bar: bool = True) -> None:
        super().__init__()
        self.total, self.timer, self.eval_cb, self.every_s = total, env_timer, eval_cb, every_s
        self.use_bar = bar
        self.bar: Any = None
        self.collect = self.learn = 0.0
        self.t_mark = self.t0 = self.last = time.perf_counter()
        self.start_steps = 0

    def _on_training_start(self) -> None:
        self.t0 = self.last = self.t_mark = time.perf_counter()
        self.start_steps = int(self.num_timesteps)
        self.env0, self.eval0 = self.timer.seconds, self.eval_cb.eval_seconds
        if self.use_bar:
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, initial=self.start_steps, unit="step", unit_scale=True, dynamic_ncols=True, mininterval=1.0)

    def _on_rollout_start(self) -> None:
        now = time.perf_counter()
        if self.t_mark is not None and self.num_timesteps > self.start_steps:
            self.learn += now - self.t_mark
        self.t_mark = now

    def _on_rollout_end(self) -> None:
        now = time.perf_counter()
        self.collect += now - self.t_mark
        self.t_mark = now

    def split(self) -> dict[str, float]:
        """Seconds so far in this session: environment, evaluation, policy (rest of the rollouts), learner."""
        env = self.timer.seconds - self.env0
        ev = self.eval_cb.eval_seconds - self.eval0
        return {"env_s": round(env, 2), "eval_s": round(ev, 2), "policy_s": round(max(self.collect - env - ev, 0.0), 2),
                "learner_s": round(self.learn, 2)}

    def _describe(self) -> str:
        sp = self.split()
        busy = sum(sp.values()) or 1.0
        n = self.num_timesteps - self.start_steps
        el = time.perf_counter() - self.t0
        return (f"{n / max(el, 1e-9):,.0f} steps/s; env {100 * sp['env_s'] / busy:.0f} %, policy {100 * sp['policy_s'] / busy:.0f} %, "
                f"learner {100 * sp['learner_s'] / busy:.0f} %, eval {100 * sp['eval_s'] / busy:.0f} %")

    def _on_step(self) -> bool:
        now = time.perf_counter()
        if self.bar is not None:
            self.bar.update(self.training_env.num_envs)
            if now - self.last >= 2.0:
                self.last = now
                self.bar.set_postfix_str(self._describe(), refresh=False)
        elif now - self.last >= self.every_s:
            self.last = now
            n = self.num_timesteps
            print(f"  {n:>9d} / {self.total} steps ({100.0 * n / self.total:5.1f} %), {self._describe()}", flush=True)
        return True

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()
        print(f"  time: {self._describe()}", flush=True)


class _Tracker:
    def __init__(self, ev: SeededEvalCallback, stop: StopAtSuccess) -> None:
        self.ev, self.stop = ev, stop

    @property
    def reached(self) -> dict[str, float] | None:
        return self.stop.reached

    def curve(self) -> list[dict[str, float]]:
        return list(self.ev.points)


def build_callbacks(
    eval_env: VecEnv, out: Path, *, eval_seed: int, eval_freq: int, n_eval: int, checkpoint_freq: int,
    target: float | None, total: int, env_timer: EnvTimer, bar: bool, save_replay_buffer: bool = False,
    points: list[dict[str, float]] | None = None, wall_offset: float = 0.0,
) -> tuple[CallbackList, _Tracker, Progress]:
    """Eval (+ stop at target; its points also in ``out/curve.json``), checkpoints (+ VecNormalize statistics,
    + the replay buffer when asked), progress; frequencies in vec-env steps.  ``points``, ``wall_offset``: a
    resumed run's curve so far and its wall time."""
    stop = StopAtSuccess(target)
    ev = SeededEvalCallback(
        eval_env, eval_seed, curve_path=out / "curve.json", points=points, wall_offset=wall_offset,
        n_eval_episodes=n_eval, eval_freq=eval_freq, log_path=str(out),
        best_model_save_path=str(out), deterministic=True, callback_after_eval=stop, verbose=0,
    )
    ckpt = CheckpointCallback(checkpoint_freq, str(out / "checkpoints"), save_vecnormalize=True, save_replay_buffer=save_replay_buffer)
    progress = Progress(total, env_timer, ev, bar=bar)
    return CallbackList([ev, ckpt, progress]), _Tracker(ev, stop), progress


def plot_curve(curve: list[dict[str, float]], path: Path, title: str, target: float) -> None:
    """Mean eval return (left axis) and success rate (right axis) vs timesteps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=100)
    if curve:
        x = np.array([p["timesteps"] for p in curve])
        ax.plot(x, [p["mean_return"] for p in curve], "o-", color="C0", label="mean eval return")
        ax2 = ax.twinx()
        ax2.plot(x, [p["success_rate"] for p in curve], "s--", color="C1", label="success rate")
        ax2.axhline(target, color="C1", lw=0.8, ls=":")
        ax2.set_ylim(-0.02, 1.02)
        ax2.set_ylabel("success rate", color="C1")
    ax.set_xlabel("timesteps")
    ax.set_ylabel("mean eval return", color="C0")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
