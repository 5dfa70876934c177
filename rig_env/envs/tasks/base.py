"""``Task``: the base class of every manoeuvre task (reference, observation entries, reward, success).

A task never integrates the rig; the environment (:mod:`rig_env.envs.vector_env`) owns the physics
batch and calls the task with (n, ...) arrays at the control rate, in this order:

| when | hook | purpose |
|---|---|---|
| reset of envs ``idx`` | ``conditions(idx, airspeed, P)`` then ``reset(idx, u)`` | episode airspeed and parameter rows, then the task's draws and initial state |
| start of a control step | ``pilot_inputs(t)`` | Hawk elevator, aileron, rudder disturbances (rad), held over the step |
| after the physics step | ``air(gust)`` | the gust (n, 3), m/s world, that acted over the step (zeros in calm air) |
| after ``air`` | ``advance(t, q, qd)`` | internal states (reference models, captured baselines) |
| after ``advance`` | ``reference(t)``, ``reward``, ``tracked`` | reference signals, reward, metrics' signal |
| episode end of envs ``idx`` | ``episode_metrics(idx)`` | task-specific metrics, added to ``final_info`` |
| time limit | ``success(q, qd, ref, metrics)`` | success flag of the envs that reached it (metrics include the task's) |

Disturbances: a task's pilot inputs on the Hawk surfaces (3-2-1-1s, pulses; :meth:`Task.pilot_inputs`)
and, for every task, the configuration's gusts (``turbulence``, ``turbulence_model``, ``turbulence_tau`` or
``turbulence_scale``, ``turbulence_convected``; off by default).  ``air(gust)`` gets the Hawk's gust; the
compensator meets it convected downstream (:mod:`rig_env.turbulence`).
Every reward has one form (:meth:`Task.shaped_reward`), from the task's tracking cost ``c >= 0`` (squared
errors over their scales, in each task's docstring) and the control cost ``c_u >= 0``:

    r = (0.7 exp(-c) + 0.3 exp(-sqrt(c) / 6)) exp(-c_u)                         in (0, 1]
    c_u = sum_j [0.25 a_j^2 + 0.3 (max(|a_j| - 0.9, 0) / 0.1)^2] + w m            (w: the task's rate_weight, 0.2 by default)
    m' = (sum_j (da_j/dt / 4 s^-1)^2 - m) / 0.25 s                             (command activity, m = 0 at reset)

with ``a`` the normalised actions (+-1 full deflection), ``da/dt`` their change per control period over
dt, and ``m`` advanced once per control step (``m += dt / 0.25 s (... - m)``; a per-episode state of the
task, zeroed in :meth:`Task.conditions`).  Why each part:

- ``0.7 exp(-c)`` is the manoeuvre's precision: near 1 only inside the error scales.  Alone it is flat
  once the errors pass two or three scales, so an untrained policy that has lost the reference sees no
  difference between its actions; ``0.3 exp(-sqrt(c) / 6)`` (errors in units six times wider, decaying
  like ``exp(-|e|)``, not ``exp(-e^2)``) still ranks actions there: halving a 90 deg roll error is worth
  as much as halving a 9 deg one was.
- the rate term charges the command's rate in 1/s (a full-range swing in half a second is one unit), not
  its change per control step, which shrinks with the control period: a 2.5 Hz +-30 deg aileron
  oscillation (8.3 s^-1 RMS) costs 59 % of the reward, a single full-range swing in 0.5 s (one unit of
  rate) up to 16 % of the reward while it lasts, fading over the next quarter second.  It charges the rate's average over the last
  0.25 s, not the step's own: a per-step charge inside ``exp`` can take at most the one step's reward,
  so a bang from stop to stop would cost one step in 80 and bang-bang chatter would be cheaper than a
  smooth oscillation; averaged, one switch costs the reward of tens of steps and a square wave at 2.5 Hz
  nearly all of it.  A policy exploring with white noise at 80 Hz would pay this on its noise (SB3's
  default Gaussian: the reward all but vanishes); ``rig train`` explores with gSDE (state-dependent,
  smooth noise), the RL Zoo's choice for the same reason.  Chatter is never the best way to earn equal tracking (the surfaces are summed:
  chatter on one is not diluted by the others at rest);
- the saturation term charges commands beyond 90 % of full deflection (a surface held at its stop costs
  30 % of the reward), so holding a stop is never free.
- the deflection term ``0.25 a_j^2`` makes a surface the manoeuvre does not need cost something (half
  deflection 6 % of the reward): a flap held over is drag, hinge load and authority lost for the next
  disturbance.  At 0.05 it was too cheap against a squashed (tanh) exploration policy's incentive to
  park its mean where tanh is flat and its own noise is small: PPO policies held the unused elevator and
  rudder at 25-30 deg (RMS command 24-29 deg against the PID's 7-11 deg).

A step that ends the episode by failure (blow-up or a joint beyond its stop margin) earns 0 (the
environment does that).  Episodes
run to their time limit otherwise, so ending early never pays.  Angles in rad and rates in rad/s
inside; the ``*_deg`` names and the metrics' display units are deg.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from rig_env.params import JOINTS, LIMITED_JOINTS
from rig_env.physics import layout as L
from rig_env.physics.jit import kernel

D = math.pi / 180.0
G0 = 9.81  # m/s^2, for load factors in observations and docstrings (the physics uses P's gravity)
STOP_MARGIN = 2.0 * D  # beyond a stop by more than this: terminated
_STOP_COL = {j: getattr(L, f"P_STOPS_{j.upper()}_LOWER_DEG") for j in LIMITED_JOINTS}
_JIT = {"cache": True, "error_model": "numpy", "_nrt": False}  # allocation-free kernels, compiled lazily


@kernel(**_JIT)
def _stop_flags(q, P, joints, cols, margin, on, beyond):
    """Per environment: on a stop (q <= lower or q >= upper) and beyond one by more than margin (rad).

    q (n, 5) rad; P (n, N_PARAMS) with each stop pair (lower, upper) at columns cols[m], cols[m] + 1
    (rad) for joint joints[m]; on, beyond (n,) bool outputs.  NaN angles are on no stop.
    """
    for i in range(q.shape[0]):
        o, b = False, False
        for m in range(joints.shape[0]):
            x, lo, hi = q[i, joints[m]], P[i, cols[m]], P[i, cols[m] + 1]
            o |= (x <= lo) | (x >= hi)
            b |= (x < lo - margin) | (x > hi + margin)
        on[i], beyond[i] = o, b


RATE_SCALE = 4.0
"""1/s: the normalised command rate the control-rate cost counts in units of (a full-range swing, 2, in half a second)."""
RATE_WEIGHT = 0.2
"""Weight of the command activity in the control cost."""
RATE_TAU = 0.25
"""s: time constant of the command-activity average the rate cost charges (a switch is charged for about this long)."""
WIDE = 6.0
"""The wide tracking term's errors count in units WIDE times the fine term's (:meth:`Task.shaped_reward`)."""
FINE_SHARE = 0.7
"""Share of the fine term in the tracking reward; the wide term has the rest."""
SAT_KNEE = 0.9
"""|a| above this (normalised) is charged as saturation."""
EFFORT_WEIGHT = 0.25
"""Weight of the squared deflection sum_j a_j^2 in the control cost."""


@kernel(**_JIT)
def _control_cost_kernel(a, a_prev, rate_step, alpha, knee, w_rate, activity, out):
    """out (n,) = sum_j [EFFORT_WEIGHT a_j^2 + 0.3 (max(|a_j| - knee, 0) / (1 - knee))^2] + w_rate m, where the command
    activity m (n,) (in/out) is first advanced m += alpha (sum_j ((a_j - a_prev_j) / rate_step)^2 - m).

    a, a_prev (n, k) normalised actions; rate_step = RATE_SCALE * dt, the change per control step that counts as
    one unit of rate; alpha = dt / RATE_TAU; knee: SAT_KNEE; w_rate: RATE_WEIGHT.
    """
    k = a.shape[1]
    for i in range(a.shape[0]):
        s, r2 = 0.0, 0.0
        for j in range(k):
            x = a[i, j]
            d = (x - a_prev[i, j]) / rate_step
            ax = x if x >= 0.0 else -x
            sat = (ax - knee) / (1.0 - knee) if ax > knee else 0.0
            s += EFFORT_WEIGHT * x * x + 0.3 * sat * sat
            r2 += d * d
        activity[i] += alpha * (r2 - activity[i])
        out[i] = s + w_rate * activity[i]


class Task:
    """Base class.  Subclasses set the class constants and implement the vectorised hooks.

    | class constant | meaning |
    |---|---|
    | name | key in ``TASKS`` (the ``task`` configuration field) |
    | default_free_dofs, default_airspeed, default_episode_seconds | used when the configuration leaves them ``None`` |
    | default_aero_model | the aerodynamic model ("linear", "tables", "unsteady") when the configuration leaves ``aero_model`` (and ``nonlinear_aero``) ``None`` |
    | required | joints that must be free (a ``ValueError`` otherwise) |
    | ref_labels | names of the observation entries the task appends (bounds ``obs_low``/``obs_high``) |
    | ref_scales | every appended entry by name -> its unit per normalised value (rad, rad/s, m/s^2, Hz, 1), in ``ref_labels`` order: the entry times its scale is the physical quantity the class docstring's table names (laws read them at design time) |
    | n_draws | uniforms consumed per reset |
    | display_label | what :meth:`display` returns, for plots (e.g. "roll angle, deg") |
    | display_joint | index in ``JOINTS`` of the joint :meth:`display` shows (None: a derived quantity) |
    | display_rate | (joint index, reference column) of a commanded rate to plot beside it, or None |
    | rate_weight | weight of the command activity in the control cost (default :data:`RATE_WEIGHT`) |
    | min_airspeed | m/s: the lowest airspeed the comparison and RL training fly the task at (None: no floor; the default rig's reach, :meth:`airspeed_for`) |

    Named constants a control law needs to rebuild a task's reference from its observation are class
    attributes too (e.g. ``ForcedOscillation.T_RAMP``, :data:`G0`); :meth:`driven_joint` names the rig
    joint a heave or sway task drives.

    Options (``task_options`` of the configuration) are checked by :meth:`check_options`; the base
    class accepts none.  Per-episode conditions set by the environment before :meth:`reset`
    (:meth:`conditions`): ``self.V`` (n,) airspeed, m/s; ``self.l`` (n,) arm length (pivot to model
    gimbal), m.  Tasks that need more of the (randomised) parameters override :meth:`conditions`.
    """

    name: ClassVar[str]
    default_free_dofs: ClassVar[tuple[str, ...]]
    default_airspeed: ClassVar[tuple[float, float]]
    default_episode_seconds: ClassVar[float]
    default_aero_model: ClassVar[str] = "linear"
    required: ClassVar[tuple[str, ...]] = ()
    ref_labels: ClassVar[tuple[str, ...]]
    ref_scales: ClassVar[Mapping[str, float]]
    n_draws: ClassVar[int]
    reward_range: ClassVar[tuple[float, float]] = (0.0, 1.0)
    display_label: str = "tracked quantity, deg"
    display_joint: int | None = None
    display_rate: tuple[int, int] | None = None
    min_airspeed: ClassVar[float | None] = None
    """m/s: below it the default rig cannot fly what the task draws (the roll tasks' 90 deg banks); the comparison's
    and RL training's airspeed draw starts here (:meth:`airspeed_for`).  None: no floor."""
    rate_weight: ClassVar[float] = RATE_WEIGHT
    """Weight of the command activity in this task's control cost (default :data:`RATE_WEIGHT`; a task that
    lowers it says why in its docstring)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A task class that sets ``ref_labels`` must declare a scale for every one of them, in that order."""
        super().__init_subclass__(**kwargs)
        labels = cls.__dict__.get("ref_labels")
        if labels is not None and tuple(getattr(cls, "ref_scales", {})) != tuple(labels):
            raise TypeError(f"task class {cls.__name__}: ref_scales must name every entry of ref_labels {list(labels)} "
                            f"in that order, got {list(getattr(cls, 'ref_scales', {}))}")

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float, **options: Any) -> None:
        missing = [j for j in self.required if j not in free_dofs]
        if missing:
            raise ValueError(f"task {self.name!r} needs free joint(s) {missing}; free_dofs = {list(free_dofs)}")
        self.options = self.check_options(options)
        self.n, self.free, self.dt, self.T = n_envs, free_dofs, dt, episode_seconds
        self.free_idx = np.array([JOINTS.index(j) for j in free_dofs])
        self.meas_roll = self.col("rig_roll")  # column of rig_roll in the measured joints (-1: locked)
        self.limited = np.array([JOINTS.index(j) for j in free_dofs if j in LIMITED_JOINTS], dtype=np.int64)
        self._stop_cols = np.array([_STOP_COL[JOINTS[j]] for j in self.limited], dtype=np.int64)
        self.obs_low = -np.full(len(self.ref_labels), 5.0)
        self.obs_high = np.full(len(self.ref_labels), 5.0)
        self.V = np.zeros(n_envs)
        self.l = np.ones(n_envs)
        self.activity = np.zeros(n_envs)  # the control cost's command activity m (module docstring), zeroed per episode
        self._zero_pilot = np.zeros((n_envs, 3))

    # ------------------------------------------------------------------ options and defaults
    @classmethod
    def check_options(cls, options: Mapping[str, Any]) -> dict[str, Any]:
        """Validated task options; the base class takes none (any name is a ValueError)."""
        if options:
            raise ValueError(f"task_options: task {cls.name!r} takes no options, got {sorted(options)}")
        return {}

    @classmethod
    def free_dofs_for(cls, options: Mapping[str, Any]) -> tuple[str, ...]:
        """Default free joints for these options (most tasks: ``default_free_dofs``)."""
        return cls.default_free_dofs

    @classmethod
    def airspeed_for(cls, airspeed: tuple[float, float]) -> tuple[float, float]:
        """The airspeed range (m/s) the comparison and RL training draw this task's episodes from, given theirs:
        its low end raised to :attr:`min_airspeed` (documented, not silent: ``rig compare`` prints it); unchanged
        without a floor or when the range lies wholly below it (a deliberate low-speed study)."""
        lo, hi = float(airspeed[0]), float(airspeed[1])
        if cls.min_airspeed is None or lo >= cls.min_airspeed or hi <= cls.min_airspeed:
            return (lo, hi)
        return (float(cls.min_airspeed), hi)

    @classmethod
    def driven_joint(cls, options: Mapping[str, Any]) -> str | None:
        """The rig joint whose angle the task's reference drives (heave: rig_pitch, sway: rig_yaw) with these
        options, or None when the task drives none (the roll tasks track rig_roll; departure recovery levels the rig)."""
        return None

    # ------------------------------------------------------------------ shared pieces
    def col(self, joint: str) -> int:
        """Column of ``joint`` in the measured (free-joint) arrays, -1 when it is locked."""
        return self.free.index(joint) if joint in self.free else -1

    def conditions(self, idx: np.ndarray, airspeed: np.ndarray, P: np.ndarray) -> None:
        """Episode conditions of envs idx: airspeed (m,) m/s and kernel parameter rows P (m, N_PARAMS)."""
        self.V[idx] = airspeed
        self.l[idx] = P[:, L.P_GEOMETRY_ARM_LENGTH]
        self.activity[idx] = 0.0

    def initial_state(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(m, 5) angles and rates: free joints uniform in +-3 deg, at rest (uses len(free) uniforms)."""
        q = np.zeros((idx.size, 5))
        q[:, self.free_idx] = (2.0 * u[:, : len(self.free_idx)] - 1.0) * 3.0 * D
        return q, np.zeros((idx.size, 5))

    def limits(self, q: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(on a stop, beyond a stop by more than STOP_MARGIN), each (n,) bool, free limited joints.

        q: (n, 5) rad; P: (n, N_PARAMS) kernel parameter rows (stops in rad).
        """
        on = np.empty(q.shape[0], dtype=bool)
        beyond = np.empty(q.shape[0], dtype=bool)
        _stop_flags(q, P, self.limited, self._stop_cols, STOP_MARGIN, on, beyond)
        return on, beyond

    def _control_cost(self, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        """(n,) control cost of normalised actions a, a_prev (n, k) (the module docstring's ``c_u``)."""
        out = np.empty(a.shape[0])
        _control_cost_kernel(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(a_prev, dtype=np.float64),
                             RATE_SCALE * self.dt, self.dt / RATE_TAU, SAT_KNEE, self.rate_weight, self.activity, out)
        return out

    def shaped_reward(self, c: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        """(n,) ``(FINE_SHARE exp(-c) + (1 - FINE_SHARE) exp(-sqrt(c) / WIDE)) exp(-c_u)`` from the task's tracking
        cost c (n,) >= 0 (a sum of squared errors over their scales) and the control cost of a, a_prev (n, k)."""
        track = FINE_SHARE * np.exp(-c) + (1.0 - FINE_SHARE) * np.exp(-np.sqrt(c) / WIDE)
        return track * np.exp(-self._control_cost(a, a_prev))

    # ------------------------------------------------------------------ hooks with defaults
    def pilot_inputs(self, t: np.ndarray) -> np.ndarray:
        """(n, 3) Hawk elevator, aileron, rudder disturbance, rad, at the step's start time t (n,), s.

        The environment writes it to the Hawk surface inputs (``U_HAWK_*``) and holds it over the
        control step; with ``hawk_surfaces=True`` it is added to the action's command.  Default: zeros.
        """
        return self._zero_pilot

    def air(self, gust: np.ndarray) -> None:
        """The gust (n, 3), m/s in world axes (x upstream, z down), held over the step just taken; a reference
        model that flies in the same air as the rig reads it here.  Default: ignored."""

    def advance(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        """Update internal states to time t (n,) s from the true state q, qd (n, 5).  Default: nothing."""

    def episode_metrics(self, idx: np.ndarray) -> dict[str, np.ndarray]:
        """Task-specific metrics of the ending episodes of envs idx ((len(idx),) arrays).  Default: none."""
        return {}

    # ------------------------------------------------------------------ hooks
    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Draw references and initial states of envs idx from uniforms u (m, n_draws); returns (q0, qd0)."""
        raise NotImplementedError

    def reference(self, t: np.ndarray) -> np.ndarray:
        """(n, k) reference signals at times t (n,), s."""
        raise NotImplementedError

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """(n, len(ref_labels)) from the reference and the measured angles/rates of the free joints."""
        raise NotImplementedError

    def reward(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        """(n,) in (0, 1] from the true state (q, qd: (n, 5)) and normalised actions."""
        raise NotImplementedError

    def tracked(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, ...]:
        """(segment id, y, segment target, error in display units, settling band) for the metrics."""
        raise NotImplementedError

    def success(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, metrics: dict[str, np.ndarray]) -> np.ndarray:
        """(m,) bool for envs that reached their time limit (rows of q, qd, ref, metrics)."""
        raise NotImplementedError

    def display(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n,) tracked quantity and (n,) its reference, deg, for plots (:attr:`display_label`).

        From :meth:`tracked`: ``y`` and ``y + error`` (its error is reference minus ``y`` in degrees);
        a task whose tracked ``y`` is not an angle overrides this."""
        _, y, _, err, _ = self.tracked(t, q, qd, ref)
        return y / D, y / D + err


def smooth_ramp(x: np.ndarray) -> np.ndarray:
    """0 for x <= 0, 1 for x >= 1, ``x^2 (3 - 2 x)`` between (zero slope at both ends)."""
    s = np.clip(x, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def sign_of(u: np.ndarray) -> np.ndarray:
    """+1 or -1 from uniforms in [0, 1) (each with probability 1/2)."""
    return np.where(u < 0.5, -1.0, 1.0)
