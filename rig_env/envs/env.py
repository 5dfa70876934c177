"""``RigEnv``: one rig environment, the batch of one of :class:`RigVectorEnv` (no second copy of anything)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from rig_env.envs.config import RigEnvConfig
from rig_env.envs.render import RENDER_MODES
from rig_env.envs.vector_env import RigVectorEnv, action_array, check_seed


class RigEnv(gym.Env):
    """The Bristol 5-DOF manoeuvre rig in a wind tunnel, seen through its real-time loop.

    ``RigEnv(config=None, **fields)`` with the fields of :class:`rig_env.envs.config.RigEnvConfig`
    (task and task options, free DOFs, airspeed, control rate, sensors, delay, turbulence, randomisation,
    Hawk surfaces).  The task (one of Table 1's manoeuvres, :mod:`rig_env.envs.tasks`) sets the
    reference, reward, pilot-input disturbances (3-2-1-1s, elevator pulses on the Hawk) and success.

    ## Action space

    ``Box(-1, 1, (3,), float32)``; ``(6,)`` with ``hawk_surfaces=True``.  Each entry maps linearly to
    +-40 deg of the surface command, held over the control step (1/80 s by default).

    | index | action | unit after scaling |
    |---|---|---|
    | 0 | compensator aileron (mixed onto the four flaps) | +-40 deg |
    | 1 | compensator elevator | +-40 deg |
    | 2 | compensator rudder | +-40 deg |
    | 3-5 | Hawk elevator, aileron, rudder (``hawk_surfaces`` only; the task's pilot input is added) | +-40 deg |

    Out-of-range values are clipped to [-1, 1]; NaN or inf, a wrong shape, strings or complex numbers raise
    ``ValueError``.  The servos then add
    their delay, lag, rate limit and +-40 deg stop (rig_env.physics.servo).  A ``pilot_inputs`` schedule
    (:class:`rig_env.signals.InputSchedule`) replaces the task's pilot inputs on the Hawk surfaces and is
    added to the compensator commands (:mod:`rig_env.envs.config`).

    ## Observation space

    ``Box(low, high, float32)``, names in ``env.obs_labels``: what the rig's loop measures, quantised,
    noisy and delayed by ``link_delay_steps`` (:mod:`rig_env.envs.sensors`), then the task's entries.

    | entries | observation | normalisation | bounds |
    |---|---|---|---|
    | each free limited joint (rig_pitch, rig_yaw, model_pitch) | potentiometer / encoder angle | / 30 deg | [-3, 3] |
    | each free unlimited joint (rig_roll, model_yaw) | sin, cos of the angle | - | [-1, 1] |
    | each free joint | rate, filtered backward difference (``rate_filter_hz``) | / 12 rad/s (rig_roll, model_yaw), / 5 rad/s | [-5, 5] |
    | 4 | compensator flap positions (encoders) | / 40 deg | [-1.5, 1.5] |
    | 1 | airspeed | / 40 m/s | [0, 1.5] |
    | task | e.g. roll error, reference (see the task's docstring) | task's | [-5, 5] |

    Default ``velocity_vector_roll`` (rig_roll, model_pitch free): 13 entries; ``bank_to_bank`` (4 DOF): 17;
    ``pull_up_push_over`` 13, ``forced_oscillation`` 15 (sway-yaw 16), ``free_flight_emulation`` 15,
    ``departure_recovery`` 19 (tasks: :mod:`rig_env.envs.tasks`).

    ## Rewards

    Per step in [0, 1]: ``exp(-cost)`` of the task (tracking error plus small control and control-rate
    terms); 0 on a failing step.  ``env.reward_range == (0.0, 1.0)``.

    ## Episode end

    Terminated: blow-up of the integration (``info["status"]`` 1 non-finite, 2 runaway rate) or a
    free limited joint more than 2 deg beyond its stop.  Truncated: the task's time limit
    (``episode_seconds`` at the control rate, capped at ``max_episode_steps`` control steps when given;
    the registered ids' ``spec.max_episode_steps`` equal the tasks' limits, so ``gymnasium.make``'s
    ``TimeLimit`` truncates at the same step).  At the end, ``info`` holds the metrics (``success``, ``rms_error``,
    ``rise_time``, ``settling_time``, ``overshoot_pct``, ``control_effort``, ``control_rate``,
    ``constraint_violations``, ``episode_time``, ``segments``, ``segments_settled``, ``status``,
    ``stop_exceeded``).  Step the environment again only after ``reset()``.

    ## Seeding

    ``reset(seed=s)`` runs exactly as environment ``j`` of a ``RigVectorEnv`` reset with seed ``s - j``.
    Seeds are in ``[0, 2**64 - 1]``: a larger one is a ``ValueError`` (it would wrap round to a small seed's
    episodes); negative seeds and non-``int`` types are refused as by Gymnasium.

    ## Rendering

    ``render_mode``: None, ``"rgb_array"`` (``render()`` returns a (448, 1024, 3) uint8 frame: the
    rig from the side and from behind, :mod:`rig_env.envs.render`; after the last step of an episode
    it shows that step's state until ``reset()``) or ``"human"`` (a pyplot window, drawn on every step
    and reset; headless it warns once and shows nothing).  ``metadata["render_fps"]`` is the control
    rate, so ``gymnasium.wrappers.RecordVideo`` plays in real time.
    """

    metadata: dict[str, Any] = {"render_modes": list(RENDER_MODES)}

    def __init__(
        self, config: RigEnvConfig | None = None, render_mode: str | None = None, max_episode_steps: int | None = None, **fields: Any
    ) -> None:
        self.vec = RigVectorEnv(1, config, render_mode=render_mode, max_episode_steps=max_episode_steps, **fields)
        self.render_mode, self.metadata = self.vec.render_mode, {**type(self).metadata, "render_fps": self.vec.metadata["render_fps"]}
        self.config = self.vec.config
        self.observation_space = self.vec.single_observation_space
        self.action_space = self.vec.single_action_space
        self.reward_range = self.vec.reward_range
        self.obs_labels, self.action_names = self.vec.obs_labels, self.vec.action_names
        self._next: tuple[np.ndarray, dict[str, Any]] | None = None  # the autoreset episode, after an end

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        check_seed(seed, 1)
        super().reset(seed=seed)
        if seed is None and options is None and self._next is not None:
            obs, info = self._next  # the batch already started the next episode of this stream
            if self.vec.viewer is not None:
                self.vec.viewer.clear_held()
                if self.render_mode == "human":
                    self.vec.viewer.show(self.vec)
        else:
            obs, info = self.vec.reset(seed=seed, options=options)
            obs = obs[0]
        self._next = None
        return obs, info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._next is not None:
            raise RuntimeError("the episode has ended: call reset() before step()")
        a = action_array(action, (len(self.action_names),), self.action_names, "action")
        obs, rew, term, trunc, infos = self.vec.step(a[None])
        info: dict[str, Any] = {}
        if term[0] or trunc[0]:
            self._next = (obs[0], {})
            obs = infos["final_obs"][0]
            info = {k: v[0].item() for k, v in infos["final_info"].items() if not k.startswith("_")}
        return obs[0] if obs.ndim == 2 else obs, float(rew[0]), bool(term[0]), bool(trunc[0]), info

    def render(self) -> np.ndarray | None:
        """rgb_array: (H, W, 3) uint8 frame; human: show it (also done on every step and reset), None."""
        if self.vec.viewer is None:
            return None
        if self.render_mode == "human":
            self.vec.viewer.show(self.vec)
            return None
        return self.vec.viewer.frame(self.vec, 0)

    def close(self) -> None:
        self.vec.close()

    @property
    def unwrapped_vec(self) -> RigVectorEnv:
        """The underlying batch of one."""
        return self.vec
