"""``RigVectorEnv``: a batch of rig environments over one physics batch (Gymnasium VectorEnv, same- or next-step autoreset).

The physics is a :class:`rig_env.physics.pipeline.PhysicsBatch` (``self.physics``: state ``X``,
parameters ``P``, inputs ``U``, servo delay lines, status; the same pipeline :func:`rig_env.simulate`
runs), advanced with the lane kernel (eight environments per SIMD register; every aerodynamic model,
:func:`rig_env.physics.pipeline.choose_kernel`).  Servos start every episode at rest at zero
deflection (the pipeline's convention with the zero commands of a reset).  The task
(:mod:`rig_env.envs.tasks`) supplies references, rewards, initial states and success; the sensor model
(:mod:`rig_env.envs.sensors`) turns the state into what the real-time loop measures.

Seeding: ``reset(seed=s)`` gives environment ``i`` the stream of seed ``s + i`` (as
``gymnasium.vector.SyncVectorEnv`` seeds its sub-environments); every random number of an episode is a
counter-based function of (stream, episode number, control step) (:mod:`rig_env.envs.streams`).  So
environment ``i`` of a batch reset with seed ``s`` runs exactly as ``RigEnv`` reset with seed
``s + i``, also across automatic resets (each reset advances that environment's episode number;
``reset(seed=None)`` advances every environment's).  ``reset(seed=None)`` before any seeded reset draws
``s`` from the batch generator ``self.np_random``.  Seeds are 64-bit: a batch of ``n`` takes seeds in
``[0, 2**64 - n]`` (so that ``s + n - 1`` is one), a larger seed is a ``ValueError`` (it would wrap round to
replay a small seed's episodes); negative seeds and non-``int`` types are refused as by Gymnasium.

Autoreset (``autoreset_mode``, also ``metadata["autoreset_mode"]``; Gymnasium's two modes):

- ``AutoresetMode.SAME_STEP`` (the default, what SB3 expects): when environment ``i`` terminates or
  truncates, ``step`` returns the first observation of its next episode and puts the last one in
  ``infos["final_obs"][i]`` and the episode's metrics in ``infos["final_info"]`` (arrays over the batch
  with ``_name`` masks, Gymnasium's convention).
- ``AutoresetMode.NEXT_STEP`` (what Gymnasium's vector observation wrappers and CleanRL-style loops
  expect): the ending step returns the last observation itself and the metrics at the top level of
  ``infos`` (``infos["success"]``, ``infos["_success"]``, ...); the next ``step`` ignores that
  environment's action and returns the first observation of its next episode with reward 0, not
  terminated, not truncated.  Step for step equal to ``SyncVectorEnv([lambda: RigEnv(...)] * n,
  autoreset_mode=AutoresetMode.NEXT_STEP)``.

Metric keys: ``success``, ``status`` (0 ok, 1 non-finite state, 2 runaway rate; a blown-up environment
is terminated, the others carry on), ``stop_exceeded``, :data:`rig_env.envs.metrics.METRIC_NAMES` and
the task's own (``Task.episode_metrics``, e.g. ``amplitude_ratio`` of the forced oscillation).

Episode length: ``episode_seconds`` (the task's default when None) at the control rate, capped at
``max_episode_steps`` control steps when that is given (what ``gymnasium.make_vec`` passes from the
registered spec, so the batch ends episodes where ``gymnasium.make``'s ``TimeLimit`` ends them).

Actions are ``(num_envs, 3)`` (``(num_envs, 6)`` with ``hawk_surfaces``): compensator aileron,
elevator, rudder (then Hawk elevator, aileron, rudder), each in [-1, 1] for +-40 deg.  Out-of-range
values are clipped; a non-finite value, a wrong shape or anything but real numbers (strings, complex
numbers) raises ``ValueError``.  The task's pilot inputs
(:meth:`rig_env.envs.tasks.Task.pilot_inputs`: 3-2-1-1s, pulses) are the Hawk surface commands, held
over each control step; with ``hawk_surfaces`` they are added to the action's Hawk commands.  A
configuration's ``pilot_inputs`` schedule (:class:`rig_env.signals.InputSchedule`, evaluated at each
environment's episode time) replaces the task's pilot inputs on the Hawk surfaces and is added to the
action's compensator commands (:mod:`rig_env.envs.config`).
Observations are float32, see :class:`rig_env.envs.env.RigEnv` for the table.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit

from rig_env.envs import streams as rs
from rig_env.envs.config import RigEnvConfig
from rig_env.envs.metrics import StepMetrics
from rig_env.envs.observation import observe
from rig_env.envs.render import RENDER_MODES, EnvFrames, EnvViewer, check_render_mode
from rig_env.envs.sensors import Sensors
from rig_env.envs.tasks import TASKS
from rig_env.params import JOINTS, PARAM_INDEX, RigParams, param_batch
from rig_env.physics import layout as L
from rig_env.physics.pipeline import PhysicsBatch, flags_of, rates, resolve_aero_model
from rig_env.turbulence import MIN_CONVECTION_SPEED, SPECTRAL_MODELS, GustHistory, SpectralGusts, convection_delay

ACTION_SCALE_DEG = 40.0
_RAD_PER_ACTION = math.radians(ACTION_SCALE_DEG)
COMP_ACTIONS = ("comp_aileron", "comp_elevator", "comp_rudder")
HAWK_ACTIONS = ("hawk_elevator", "hawk_aileron", "hawk_rudder")


@njit(cache=True, error_model="numpy", _nrt=False)
def _clip_actions(a, out):
    """out = a clipped to [-1, 1], both (n, k); returns False (out incomplete) at the first non-finite value."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            v = a[i, j]
            if not math.isfinite(v):
                return False
            out[i, j] = max(-1.0, min(v, 1.0))
    return True


@njit(cache=True, error_model="numpy", _nrt=False)
def _command_inputs(a, pilot, scale, U):
    """Surface commands of the control step into U (n, N_INPUTS), rad, in place.

    a (n, k) clipped actions (k = 3 compensator, or 6 with the Hawk's surfaces); pilot (n, 3) the task's
    Hawk elevator, aileron, rudder, rad; scale rad per unit action.  U[:, :k] = scale a, then the Hawk
    columns U_HAWK_ELEVATOR.. = pilot (+ scale a[:, 3:] when k = 6).
    """
    k = a.shape[1]
    for i in range(a.shape[0]):
        for j in range(k):
            U[i, j] = scale * a[i, j]
        for j in range(3):
            U[i, L.U_HAWK_ELEVATOR + j] = pilot[i, j] + (U[i, L.U_HAWK_ELEVATOR + j] if k > 3 else 0.0)


@njit(cache=True, error_model="numpy", _nrt=False)
def _episode_ends(status, beyond, steps, max_steps, reward, terminated, truncated, reward_out):
    """terminated = blown up (status != S_OK) or beyond a stop; truncated = at the time limit and not terminated.

    All (n,); reward_out = reward, 0 where terminated.  Returns whether any environment's episode ended.
    """
    any_done = False
    for i in range(status.shape[0]):
        te = status[i] != L.S_OK or beyond[i]
        tr = steps[i] >= max_steps and not te
        terminated[i], truncated[i] = te, tr
        reward_out[i] = 0.0 if te else reward[i]
        any_done |= te or tr
    return any_done


SEED_LIMIT = 2**64
"""Seeds are below this (64-bit stream keys): environment ``i`` of a batch takes ``seed + i``."""


def check_seed(seed: Any, num_envs: int) -> None:
    """ValueError naming ``seed`` and its range ``[0, 2**64 - num_envs]`` for an ``int`` seed beyond it (it would
    wrap round to replay a small seed's episodes); None, negative seeds and other types are left to Gymnasium."""
    if isinstance(seed, int) and not isinstance(seed, bool) and seed > SEED_LIMIT - num_envs:
        envs = f"; environment i of the batch of {num_envs} takes seed + i" if num_envs > 1 else ""
        raise ValueError(f"seed = {seed}: allowed range [0, {SEED_LIMIT - num_envs}] (2**64 - {num_envs}{envs}; "
                         "a larger seed would wrap round to a small one's episodes)")


def action_array(actions: Any, shape: tuple[int, ...], names: tuple[str, ...], what: str = "actions", exact: bool = True) -> np.ndarray:
    """``actions`` as a float64 array of ``shape``; ValueError naming ``what``, the expected shape and the
    entries (``names``) for anything but real numbers (strings, complex numbers, None...) or, with ``exact``,
    another shape.  ``exact=False``: any shape of ``shape``'s size, reshaped to it (SB3's flat actions)."""
    expected = f"expected real numbers, shape {shape} ({', '.join(names)})"
    try:
        a = np.asarray(actions)
    except (TypeError, ValueError):  # ragged nesting
        raise ValueError(f"{what}: {expected}, got {_describe(actions)}") from None
    if a.dtype.kind == "O" and all(isinstance(x, numbers.Real) for x in a.flat):
        a = a.astype(np.float64)  # a sequence of numbers of several types (not None: astype makes it NaN)
    if a.dtype.kind not in "biuf":
        got = "complex numbers" if a.dtype.kind == "c" else _describe(actions)
        raise ValueError(f"{what}: {expected}, got {got}")
    if a.shape != shape and (exact or a.size != math.prod(shape)):
        raise ValueError(f"{what}: {expected}, got shape {a.shape}")
    return a.astype(np.float64, copy=False).reshape(shape)


def _describe(x: Any) -> str:
    """A short description of a bad action for an error message."""
    r = repr(x)
    return f"{type(x).__name__} {r[:60] + '...' if len(r) > 60 else r}"


def _autoreset_mode(mode: AutoresetMode | str) -> AutoresetMode:
    """SAME_STEP or NEXT_STEP from an ``AutoresetMode`` or its value; anything else is a ValueError."""
    try:
        m = AutoresetMode(mode)
    except ValueError:
        m = None
    if m not in (AutoresetMode.SAME_STEP, AutoresetMode.NEXT_STEP):
        raise ValueError(f"autoreset_mode = {mode!r}: must be AutoresetMode.SAME_STEP or AutoresetMode.NEXT_STEP ('SameStep', 'NextStep')")
    return m


class RigVectorEnv(VectorEnv):
    """``num_envs`` rig environments stepped together; configuration as :class:`RigEnvConfig` fields.

    ``RigVectorEnv(num_envs, config=None, render_mode=None, autoreset_mode=AutoresetMode.SAME_STEP,
    max_episode_steps=None, **fields)``: ``fields`` override ``config`` (an unknown name or out-of-range
    value is a ``ValueError``); ``render_mode`` None, "rgb_array" or "human" (:mod:`rig_env.envs.render`;
    ``metadata["render_fps"]`` is the control rate); ``autoreset_mode`` SAME_STEP or NEXT_STEP (an
    ``AutoresetMode`` or its value, "SameStep" / "NextStep"); ``max_episode_steps`` caps the episode
    at that many control steps (None or -1: no cap beyond ``episode_seconds``).  See the module
    docstring for seeding, autoreset and infos, and :class:`rig_env.envs.env.RigEnv` for the
    observation and action tables.
    """

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": list(RENDER_MODES)}
    action_scale_deg: float = ACTION_SCALE_DEG
    """Compensator deflection, deg, of a normalised action of 1 (every action entry)."""

    def __init__(
        self,
        num_envs: int = 1,
        config: RigEnvConfig | None = None,
        render_mode: str | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.SAME_STEP,
        max_episode_steps: int | None = None,
        **fields: Any,
    ) -> None:
        if not isinstance(num_envs, (int, np.integer)) or isinstance(num_envs, bool) or not 1 <= num_envs <= 1_000_000:
            raise ValueError(f"num_envs = {num_envs!r}: must be an integer in [1, 1000000]")
        mode = _autoreset_mode(autoreset_mode)
        if max_episode_steps is not None and (
            not isinstance(max_episode_steps, (int, np.integer)) or isinstance(max_episode_steps, bool)
            or not (max_episode_steps >= 1 or max_episode_steps == -1)
        ):
            raise ValueError(f"max_episode_steps = {max_episode_steps!r}: must be a positive integer, -1 or None (no cap)")
        cfg = (config or RigEnvConfig()).with_overrides(**fields)
        self.config, self.num_envs, self.render_mode = cfg, int(num_envs), check_render_mode(render_mode)
        n = self.num_envs
        task_cls = TASKS[cfg.task]
        self.free_dofs: tuple[str, ...] = cfg.free_dofs or task_cls.free_dofs_for(cfg.task_options)
        self.airspeed_range: tuple[float, float] = cfg.airspeed or task_cls.default_airspeed
        self.episode_seconds = float(cfg.episode_seconds or task_cls.default_episode_seconds)
        self.dt, self.h, self.n_sub = rates(cfg.control_rate, cfg.physics_dt)
        self.max_steps = max(1, int(round(self.episode_seconds / self.dt)))
        """Control steps of an episode at the time limit (truncation)."""
        if max_episode_steps is not None and max_episode_steps != -1:
            self.max_steps = min(self.max_steps, int(max_episode_steps))
        fps = float(cfg.control_rate)  # one frame per control step; metadata is per instance (rates differ)
        self.metadata = {**type(self).metadata, "render_fps": int(fps) if fps.is_integer() else fps, "autoreset_mode": mode}
        self._next_step = mode is AutoresetMode.NEXT_STEP
        self._pending: np.ndarray | None = None  # next-step mode: environments that ended on the last step
        self.viewer = EnvViewer(self.render_mode, fps, cfg.task) if self.render_mode is not None else None
        bad = [j for j in cfg.locked_deg if j in self.free_dofs]
        if bad:
            raise ValueError(f"locked_deg: joint(s) {bad} are free; lock them by leaving them out of free_dofs")
        self.q_locked = np.zeros(5)
        for j, a in cfg.locked_deg.items():
            self.q_locked[JOINTS.index(j)] = np.radians(a)
        self.locked = np.array([k for k, j in enumerate(JOINTS) if j not in self.free_dofs], dtype=np.int64)
        self.free_idx = np.array([JOINTS.index(j) for j in self.free_dofs], dtype=np.int64)

        # parameters: base row, randomised columns in kernel units, corners validated once
        self.params = RigParams.from_toml(cfg.params_file) if cfg.params_file else RigParams.default()
        self.base_row = param_batch(self.params, 1)[0]
        names = list(cfg.randomise)
        self._rand_cols = np.array([PARAM_INDEX[k] for k in names], dtype=np.int64)
        unit = np.array([np.pi / 180.0 if k.endswith(("_deg", "_deg_s")) else 1.0 for k in names])
        self._rand_lo = np.array([cfg.randomise[k][0] for k in names]) * unit
        self._rand_hi = np.array([cfg.randomise[k][1] for k in names]) * unit
        if names:  # raises ParameterError (a ValueError) naming the parameter and its range
            corners = param_batch(self.params, 2, {k: [cfg.randomise[k][0], cfg.randomise[k][1]] for k in names})
        else:
            corners = self.base_row[None]
        self.aero_model = resolve_aero_model(cfg.aero_model, cfg.nonlinear_aero, task_cls.default_aero_model)
        self.nonlinear_aero = self.aero_model != "linear"  # the tables, static or through the separation state
        # the physics: eight environments per SIMD register (rig_env.physics.lanes), whatever the model and
        # the batch size, so a RigEnv (the batch of one) steps exactly as environment i of a batch.  The
        # delay lines hold the longest servo delay of the randomisation range (its corners).
        self.physics = PhysicsBatch(
            np.repeat(self.base_row[None], n, axis=0), self.params.tables(), self.free_idx,
            flags_of(True, True, True, True, self.aero_model), self.h, self.n_sub, kind="lanes", delay_rows=corners,
        )

        self.task = task_cls(n, self.free_dofs, self.dt, self.episode_seconds, **cfg.task_options)
        self.sensors = Sensors(
            n, self.free_dofs, self.dt, rate_filter_hz=cfg.rate_filter_hz,
            delay_steps=cfg.link_delay_steps,
            angle_noise=np.radians(cfg.angle_noise_deg), flap_noise=np.radians(cfg.flap_noise_deg),
            airspeed_noise=cfg.airspeed_noise, quantise=cfg.quantise, pot_bits=cfg.pot_bits, encoder_bits=cfg.encoder_bits,
        )
        self._noisy = bool(np.any(self.sensors.sigma > 0))
        self.metrics = StepMetrics(n, self.dt)
        self.action_names = COMP_ACTIONS + (HAWK_ACTIONS if cfg.hawk_surfaces else ())
        self.obs_labels = tuple(self.sensors.labels()) + tuple(task_cls.ref_labels)
        low = np.concatenate([self.sensors.low, self.task.obs_low]).astype(np.float32)
        high = np.concatenate([self.sensors.high, self.task.obs_high]).astype(np.float32)
        self.single_observation_space = spaces.Box(low, high, dtype=np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, (len(self.action_names),), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self.reward_range = task_cls.reward_range

        self.keys: np.ndarray | None = None
        self.episode = np.zeros(n, dtype=np.uint64)
        self.steps = np.zeros(n, dtype=np.int64)
        self.t = np.zeros(n)
        self.airspeed = np.zeros(n)
        self.gust = np.zeros((n, 3))
        self.prev_action = np.zeros((n, len(self.action_names)))
        self._phi = float(np.exp(-self.dt / cfg.turbulence_tau))
        gusty = cfg.turbulence > 0.0
        spectral = gusty and cfg.turbulence_model in SPECTRAL_MODELS
        self._spectral = SpectralGusts(n, self.dt, cfg.turbulence_scale, cfg.turbulence_model) if spectral else None
        self._history = GustHistory(n, self.dt, self._longest_delay()) if gusty and cfg.gusts_convected else None
        self._schedule = cfg.pilot_inputs
        self._pilot = np.zeros((n, 3))  # the schedule's Hawk elevator, aileron, rudder, rad

    def _longest_delay(self) -> float:
        """s: the longest convection delay (:func:`rig_env.turbulence.convection_delay`) of the configuration:
        the largest arm length and Hawk c.g. x and the smallest compensator reference x of the randomisation
        ranges, at the lowest airspeed of the range (at least MIN_CONVECTION_SPEED)."""
        row = self.base_row.copy()
        for name, col, hi in (("geometry.arm_length", L.P_GEOMETRY_ARM_LENGTH, True), ("geometry.hawk_cg_x", L.P_GEOMETRY_HAWK_CG_X, True),
                              ("geometry.comp_aero_x", L.P_GEOMETRY_COMP_AERO_X, False)):
            if name in self.config.randomise:
                row[col] = self.config.randomise[name][1 if hi else 0]
        return float(convection_delay(row, max(self.airspeed_range[0], MIN_CONVECTION_SPEED))[0])

    # ------------------------------------------------------------------ reset
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every environment (or those of ``options["reset_mask"]``); see the module doc for seeds.

        ``options["env_seeds"]``: (num_envs,) non-negative ints; environment ``i`` restarts at episode 0
        of the stream of seed ``env_seeds[i]`` (as ``RigEnv.reset(seed=env_seeds[i])``), so several
        blocks of a batch can fly identical episodes (paired comparisons of control laws).
        """
        check_seed(seed, self.num_envs)
        super().reset(seed=seed)
        if seed is not None:
            self.keys, self.episode[:] = rs.env_keys(seed, self.num_envs), 0
        elif self.keys is None:
            self.keys, self.episode[:] = rs.env_keys(int(self.np_random.integers(2**62)), self.num_envs), 0
        else:
            self.episode += np.uint64(1)
        if options and "env_seeds" in options:  # explicit per-environment seeds (paired comparisons)
            seeds = np.asarray(options["env_seeds"])
            if seeds.shape != (self.num_envs,):
                raise ValueError(f"options['env_seeds']: expected shape ({self.num_envs},), got {seeds.shape}")
            self.keys, self.episode[:] = rs.keys_of(seeds), 0
        unknown = sorted(set(options or {}) - {"reset_mask", "env_seeds"})
        if unknown:
            raise ValueError(f"options: unknown key(s) {unknown}; valid keys: ['env_seeds', 'reset_mask']")
        mask = np.ones(self.num_envs, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (self.num_envs,):
                raise ValueError(f"options['reset_mask']: expected shape ({self.num_envs},), got {mask.shape}")
        self._reset_envs(np.flatnonzero(mask))
        if self._pending is not None:  # next-step mode: a reset environment has nothing left to autoreset
            left = self._pending[~mask[self._pending]]
            self._pending = left if left.size else None
        if self.viewer is not None:
            self.viewer.clear_held()
            if self.render_mode == "human":
                self.viewer.show(self)
        return self._observe(), {}

    def _reset_envs(self, idx: np.ndarray) -> None:
        if idx.size == 0:
            return
        keys, ep = self.keys[idx], self.episode[idx]
        if self._rand_cols.size:
            u = rs.uniform(keys, ep, 0, rs.S_PARAMS, self._rand_cols.size)
            rows = np.repeat(self.base_row[None], idx.size, axis=0)
            rows[:, self._rand_cols] = self._rand_lo + (self._rand_hi - self._rand_lo) * u
            self.physics.set_params(idx, rows)
        u = rs.uniform(keys, ep, 0, rs.S_INITIAL, 1)
        lo, hi = self.airspeed_range
        self.airspeed[idx] = lo + (hi - lo) * u[:, 0]
        self.task.conditions(idx, self.airspeed[idx], self.P[idx])
        q0, qd0 = self.task.reset(idx, rs.uniform(keys, ep, 0, rs.S_REFERENCE, self.task.n_draws))
        q0[:, self.locked] = self.q_locked[self.locked]
        qd0[:, self.locked] = 0.0
        if self._spectral is None:
            self.gust[idx] = self.config.turbulence * self.airspeed[idx, None] * rs.normal(keys, ep, 0, rs.S_TURBULENCE, 3)
        else:  # started in the stationary distribution of the episode's airspeed
            sigma = self.config.turbulence * self.airspeed[idx]
            self._spectral.reset(idx, self.airspeed[idx], sigma, rs.normal(keys, ep, 0, rs.S_TURBULENCE, self._spectral.n_normals))
            self.gust[idx] = self._spectral.gust()[idx]
        if self._history is not None:  # the compensator's gust: the Hawk's, convection_delay later
            self._history.reset(idx, self.gust[idx], convection_delay(self.P[idx], self.airspeed[idx]))
        self.U[idx] = 0.0  # zero surface commands: the reset below starts the servos at rest at 0
        self.U[idx, L.U_GUST : L.U_GUST + 3] = self.gust[idx]
        self.U[idx, L.U_GUST_COMP : L.U_GUST_COMP + 3] = self.gust[idx]
        self.U[idx, L.U_AIRSPEED] = self.airspeed[idx]
        self.physics.reset(idx, q0, qd0)  # bristles zero, servos at rest at 0, delay lines zero, status ok
        self.steps[idx], self.t[idx], self.prev_action[idx] = 0, 0.0, 0.0
        noise = rs.normal(keys, ep, 0, rs.S_SENSOR, self.sensors.n_channels) if self._noisy else None
        x = self.X[idx]
        self.sensors.reset(idx, x[:, self.free_idx], x[:, L.X_SERVO : L.X_SERVO + 4], self.airspeed[idx], noise)
        self.metrics.reset(idx)

    # ------------------------------------------------------------------ the physics batch's arrays and settings
    @property
    def X(self) -> np.ndarray:
        """(num_envs, N_STATE) physics state (``layout.X_*``): the batch's own array, changed in place."""
        return self.physics.X

    @property
    def P(self) -> np.ndarray:
        """(num_envs, N_PARAMS) parameter rows, SI units and rad: the batch's own array."""
        return self.physics.P

    @property
    def U(self) -> np.ndarray:
        """(num_envs, N_INPUTS) inputs of the next control step (``layout.U_*``): the batch's own array."""
        return self.physics.U

    @property
    def status(self) -> np.ndarray:
        """(num_envs,) int8 integrator status (0 ok, ``layout.S_*``): the batch's own array."""
        return self.physics.status

    @property
    def dbuf(self) -> np.ndarray:
        """(num_envs, n_buf, 7) servo delay lines of limited demands, rad."""
        return self.physics.dbuf

    @property
    def delay_steps(self) -> np.ndarray:
        """(num_envs, 2) int64 compensator and Hawk servo delays, physics steps."""
        return self.physics.delay_steps

    @property
    def tabs(self) -> tuple[np.ndarray, ...]:
        """The aerodynamic tables of the model (``RigParams.tables()``)."""
        return self.physics.tabs

    @property
    def flags(self) -> int:
        """The physics feature flags (``layout.F_*`` bits)."""
        return self.physics.flags

    # ------------------------------------------------------------------ read-only views for analysis and plots
    @property
    def joint_angles(self) -> np.ndarray:
        """(num_envs, 5) true joint angles, rad, JOINTS order (a copy; locked joints at their angle)."""
        return self.X[:, L.X_Q : L.X_Q + 5].copy()

    @property
    def joint_rates(self) -> np.ndarray:
        """(num_envs, 5) true joint rates, rad/s, JOINTS order (a copy)."""
        return self.X[:, L.X_QD : L.X_QD + 5].copy()

    def reference(self) -> np.ndarray:
        """(num_envs, k) the task's reference signals at the current time (see the task's docstring)."""
        return self.task.reference(self.t)

    # ------------------------------------------------------------------ step
    def _observe(self, ref: np.ndarray | None = None) -> np.ndarray:
        """(num_envs, obs_dim) float32 observation; ref: the task's reference at self.t if already computed."""
        return observe(self.sensors, self.task, self.t, ref)

    def check_actions(self, actions: Any) -> np.ndarray:
        """(num_envs, n_actions) float64 clipped to [-1, 1]; ValueError on a wrong shape, non-finite values or
        anything but real numbers (strings, complex numbers: :func:`action_array`)."""
        shape = (self.num_envs, len(self.action_names))
        a = action_array(actions, shape, self.action_names)
        out = np.empty(shape)
        if not _clip_actions(a, out):
            bad = ~np.all(np.isfinite(a), axis=1)
            raise ValueError(f"actions: non-finite value(s) in environment(s) {np.flatnonzero(bad)[:10].tolist()}; actions must be finite numbers in [-1, 1]")
        return out

    def advance_physics(self) -> None:
        """Advance the physics batch by one control step with the inputs in ``U`` (no task, sensors or
        bookkeeping: the environment's own step calls this; benchmarks time it alone)."""
        self.physics.step()

    def _scheduled_inputs(self, a: np.ndarray) -> None:
        """Surface commands of the step with the configuration's ``pilot_inputs`` schedule at the episode times:
        its Hawk surfaces as the pilot inputs, its compensator surfaces added to the action's commands (rad)."""
        sched = self._schedule
        for j, s in enumerate(HAWK_ACTIONS):
            self._pilot[:, j] = np.radians(sched.value(s, self.t)) if s in sched.shapes else 0.0
        _command_inputs(a, self._pilot, _RAD_PER_ACTION, self.U)
        for j, s in enumerate(COMP_ACTIONS):
            if s in sched.shapes:
                self.U[:, L.U_COMP_AILERON + j] += np.radians(sched.value(s, self.t))

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self.keys is None:
            raise RuntimeError("call reset() before step()")
        a = self.check_actions(actions)
        if self.viewer is not None:
            self.viewer.clear_held()
        pending, self._pending = self._pending, None
        if pending is not None:  # next-step mode: the environments that ended on the last step start their next
            self.episode[pending] += np.uint64(1)  # episode: stepped from its reset state (a blown-up state may
            self._reset_envs(pending)  # be non-finite), then reset again below, so the step is discarded
        # the task's pilot inputs (Hawk elevator, aileron, rudder, rad): the Hawk surface commands, or
        # added to the action's Hawk commands with hawk_surfaces (the servo limits clip the sum)
        if self._schedule is None:
            _command_inputs(a, self.task.pilot_inputs(self.t), _RAD_PER_ACTION, self.U)
        else:
            self._scheduled_inputs(a)
        if self.config.turbulence > 0.0:
            if self._spectral is None:  # gauss_markov
                nz = rs.normal(self.keys, self.episode, self.steps + 1, rs.S_TURBULENCE, 3)
                sig = self.config.turbulence * self.airspeed[:, None]
                self.gust = self._phi * self.gust + np.sqrt(1.0 - self._phi**2) * sig * nz
            else:
                self.gust = self._spectral.step(rs.normal(self.keys, self.episode, self.steps + 1, rs.S_TURBULENCE, self._spectral.n_normals))
            self.U[:, L.U_GUST : L.U_GUST + 3] = self.gust
            self.U[:, L.U_GUST_COMP : L.U_GUST_COMP + 3] = self.gust if self._history is None else self._history.push(self.gust)
        self.advance_physics()
        self.steps += 1
        self.t = self.steps * self.dt
        q, qd = self.X[:, L.X_Q : L.X_Q + 5], self.X[:, L.X_QD : L.X_QD + 5]
        self.task.air(self.U[:, L.U_GUST : L.U_GUST + 3])
        self.task.advance(self.t, q, qd)
        noise = rs.normal(self.keys, self.episode, self.steps, rs.S_SENSOR, self.sensors.n_channels) if self._noisy else None
        self.sensors.update(q[:, self.free_idx], self.X[:, L.X_SERVO : L.X_SERVO + 4], self.airspeed, noise)
        ref = self.task.reference(self.t)
        reward = self.task.reward(q, qd, ref, a, self.prev_action)
        on_stop, beyond = self.task.limits(q, self.P)
        n = self.num_envs
        terminated, truncated, reward_out = np.empty(n, dtype=bool), np.empty(n, dtype=bool), np.empty(n)
        any_done = _episode_ends(self.status, beyond, self.steps, self.max_steps, reward, terminated, truncated, reward_out)
        reward = reward_out
        if pending is not None:
            terminated[pending], truncated[pending], reward[pending] = False, False, 0.0
            any_done = bool(terminated.any() or truncated.any())
        seg, y, r, err, band = self.task.tracked(self.t, q, qd, ref)
        self.metrics.update(self.t, seg, y, r, err, band, a, self.prev_action, on_stop)
        self.prev_action = a
        obs = self._observe(ref)
        infos: dict[str, Any] = {}
        if any_done:
            idx = np.flatnonzero(terminated | truncated)
            if self._next_step:  # the last observation now, the reset on the next step
                infos = self._episode_info(idx, q, qd, ref, truncated, beyond)
                self._pending = idx
            else:
                infos = self._final_infos(idx, obs, q, qd, ref, truncated, beyond)
                if self.viewer is not None:
                    self.viewer.hold(self, idx)  # frames show an ended episode's last state until the next step
                self.episode[idx] += np.uint64(1)
                self._reset_envs(idx)
                obs[idx] = self._observe()[idx]
        if pending is not None:  # the same reset state again: the first observation of the next episode
            self._reset_envs(pending)
            obs[pending] = self._observe()[pending]
        if self.render_mode == "human":
            self.viewer.show(self)
        return obs, reward, terminated, truncated, infos

    def _final_infos(self, idx, obs, q, qd, ref, truncated, beyond) -> dict[str, Any]:
        """Same-step infos of the environments ``idx`` that ended: ``final_obs``, ``final_info`` and masks."""
        fi = self._episode_info(idx, q, qd, ref, truncated, beyond)
        mask = fi["_success"]
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in idx:
            final_obs[i] = obs[i].copy()
        return {"final_obs": final_obs, "_final_obs": mask, "final_info": fi, "_final_info": mask}

    def _episode_info(self, idx, q, qd, ref, truncated, beyond) -> dict[str, Any]:
        """The episode metrics of the environments ``idx`` that ended: (num_envs,) arrays with ``_name`` masks."""
        n = self.num_envs
        mask = np.zeros(n, dtype=bool)
        mask[idx] = True
        m = self.metrics.finish(idx, self.t)
        m.update(self.task.episode_metrics(idx))
        m["success"] = truncated[idx] & self.task.success(q[idx], qd[idx], ref[idx], m)
        m["status"] = self.status[idx].copy()
        m["stop_exceeded"] = beyond[idx].copy()
        fi: dict[str, Any] = {}
        for k, v in m.items():
            full = np.zeros(n, dtype=v.dtype)
            full[idx] = v
            fi[k], fi[f"_{k}"] = full, mask
        return fi

    def render(self) -> EnvFrames | None:
        """rgb_array: the frames of every environment, drawn lazily when indexed (``frames[0]``: the
        first; :class:`rig_env.envs.render.EnvFrames`).  human: shows environment 0 (also done on every
        step and reset), returns None.  None without a render_mode.  See :mod:`rig_env.envs.render`."""
        if self.viewer is None:
            return None
        if self.render_mode == "human":
            self.viewer.show(self)
            return None
        return self.viewer.frames(self)

    def close_extras(self, **kwargs: Any) -> None:
        if self.viewer is not None:
            self.viewer.close()
