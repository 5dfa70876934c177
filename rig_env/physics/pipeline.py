"""One physics pipeline: the batch arrays of the rig model, the choice of kernel, and the one call that advances them.

Both :func:`rig_env.simulate` and :class:`rig_env.envs.RigVectorEnv` hold a :class:`PhysicsBatch` and
advance it with :meth:`PhysicsBatch.step`; the feature flags (:func:`flags_of`), the control and physics
rates (:func:`rates`), the servo delay lines (:func:`delay_line`) and the kernel (:func:`choose_kernel`)
are decided here and nowhere else.

Kernels (all advance every environment by one control step of ``n_sub`` physics steps of ``h`` seconds):

    ======  =================================================  ==========================================
    kind    kernel                                             state it integrates
    ======  =================================================  ==========================================
    lanes   :func:`rig_env.physics.lanes.step_lanes`           joint space, eight environments per SIMD
                                                               register (every aerodynamic model; the
                                                               tables as tuples, ``lanes.lane_tables``)
    joint   :func:`rig_env.physics.integrator.step_batch`      joint space, one environment at a time
    dae     :func:`rig_env.physics.dae.step_batch_dae`         the paper's body-coordinate DAE; ``X`` is
                                                               its joint-space image after every step
                                                               (no test fixture: a non-zero ``fixture.*``
                                                               is an error, :func:`check_no_fixture`)
    ======  =================================================  ==========================================

each as its serial twin below :data:`rig_env.physics.integrator.PARALLEL_MIN_ENVS` environments (a
parallel launch costs more than it saves there).  The lane kernel's results equal the per-environment
kernel's to rounding, not bit for bit; a batch of one on a given kernel equals environment i of a
larger batch on the same kernel bit for bit.

Initial servo state (one convention for every caller, :meth:`PhysicsBatch.reset`): a (re)started
environment is in servo equilibrium with the surface commands it holds in ``U`` at the reset, as if
they had been held since forever: each servo at rest at its limited demand, every slot of its delay
line holding that demand.  The environments reset with zero commands, so their servos start at rest at
zero deflection (neutral); :func:`rig_env.simulate` resets with the commands of t = 0, so a constant
command holds from the start (a trim stays a trim) and a later change reaches the servos after their
transport delay.  The LuGre bristle states start at zero.

Hot path: :meth:`PhysicsBatch.step` is one kernel call on arrays allocated once (no per-environment
Python loop, no copy; the DAE adds one conversion kernel to joint space).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit

from rig_env.params import PARAM_NAMES
from rig_env.physics import integrator as integ
from rig_env.physics import lanes
from rig_env.physics import layout as L
from rig_env.physics.joint_space import ATTACHED, separation_steady

KINDS = ("lanes", "joint", "dae")
"""Kernel kinds :func:`choose_kernel` knows (see the module docstring)."""

DELAY_COLUMNS = (L.P_SERVOS_COMPENSATOR_DELAY_S, L.P_SERVOS_HAWK_DELAY_S)
"""Parameter columns of the compensator's and the Hawk's servo transport delays, s."""


FIXTURE_COLUMNS = tuple(range(L.P_FIXTURE_RIG_ROLL_STIFFNESS, L.P_FIXTURE_MODEL_YAW_TORQUE + 1))
"""Parameter columns of the wind-off test fixtures (``fixture.<joint>.*``), which only the joint-space kernels model."""


def check_no_fixture(P: np.ndarray) -> None:
    """ValueError naming the first non-zero ``fixture.*`` parameter of the rows P (n, N_PARAMS), for the DAE.

    The DAE is the paper's formulation of the rig in flight (bodies and constraints); a test fixture's
    spring, added inertia and weight are joint-space terms (M_jj and Q_j of one joint) that it does not
    model.  A friction test runs on the joint-space kernels ("lanes" or "joint")."""
    F = np.asarray(P)[:, FIXTURE_COLUMNS]
    if np.any(F != 0.0):
        env, col = (int(a[0]) for a in np.nonzero(F != 0.0))
        name = PARAM_NAMES[FIXTURE_COLUMNS[col]]
        raise ValueError(
            f"{name} = {F[env, col]:g} (environment {env}): the DAE formulation has no test fixture; "
            "simulate a fixture (a wind-off friction set-up) with formulation='joint'"
        )


AERO_MODELS: dict[str, int] = {"linear": 0, "tables": L.F_NONLINEAR, "unsteady": L.F_NONLINEAR | L.F_UNSTEADY}
"""The aerodynamic models and their flags: ``"linear"`` the stability derivatives (eq. 23), ``"tables"`` the
static high-incidence tables (formerly ``nonlinear_aero=True``), ``"unsteady"`` the tables through the Hawk's
flow-separation state (Goman-Khrabrov; docs/MODEL.md 3.1.1)."""


def check_aero_model(aero_model: object, field: str = "aero_model") -> str:
    """``aero_model`` if it names one of :data:`AERO_MODELS`; ValueError naming ``field`` and the allowed values otherwise."""
    if not isinstance(aero_model, str) or aero_model not in AERO_MODELS:
        raise ValueError(f"{field} = {aero_model!r}: allowed values: {list(AERO_MODELS)}")
    return aero_model


def resolve_aero_model(aero_model: str | None, nonlinear_aero: bool | None, default: str = "linear") -> str:
    """One aero model from the option and its older alias: ``nonlinear_aero=True`` is ``aero_model="tables"``
    (False: "linear"); both given and different is a ValueError; neither: ``default``."""
    if nonlinear_aero is not None and not isinstance(nonlinear_aero, bool):
        raise ValueError(f"nonlinear_aero = {nonlinear_aero!r}: must be True or False (or use aero_model)")
    alias = None if nonlinear_aero is None else ("tables" if nonlinear_aero else "linear")
    if aero_model is None:
        return alias if alias is not None else check_aero_model(default)
    model = check_aero_model(aero_model)
    if alias is not None and alias != model:
        raise ValueError(f"nonlinear_aero = {nonlinear_aero} (aero_model {alias!r}) contradicts aero_model = {model!r}: give one")
    return model


def flags_of(aero: bool, friction: bool, stops: bool, servo: bool, aero_model: str | bool = "linear", *,
             nonlinear_aero: bool | None = None) -> int:
    """The kernels' feature flags (``layout.F_*`` bits) of the model's terms: aerodynamics, LuGre friction,
    joint stops, servo dynamics (off: the surfaces sit at the delayed, limited command) and the
    aerodynamic model (:data:`AERO_MODELS`; True and False stand for "tables" and "linear", as does the
    older keyword ``nonlinear_aero``)."""
    if nonlinear_aero is not None:
        aero_model = resolve_aero_model(None if aero_model == "linear" else aero_model, nonlinear_aero)
    elif isinstance(aero_model, bool):
        aero_model = "tables" if aero_model else "linear"
    return (
        (L.F_AERO if aero else 0)
        | (L.F_FRICTION if friction else 0)
        | (L.F_STOPS if stops else 0)
        | (L.F_SERVO if servo else 0)
        | AERO_MODELS[check_aero_model(aero_model)]
    )


def rates(control_rate: float, physics_dt: float | None) -> tuple[float, float, int]:
    """(control_dt s, physics_dt s, n_sub): the control step and the physics step it is divided into.

    control_rate: Hz, in [1, 2000].  physics_dt: s, in [1e-6, 0.05], an integer fraction of the control
    step (ValueError otherwise); None: the largest step <= 2.5 ms that divides the control step.
    """
    if not (math.isfinite(control_rate) and 1.0 <= control_rate <= 2000.0):
        raise ValueError(f"control_rate = {control_rate} Hz is outside the allowed range [1, 2000] Hz")
    control_dt = 1.0 / control_rate
    if physics_dt is None:
        n_sub = max(1, int(math.ceil(control_dt / 0.0025 - 1e-9)))
        return control_dt, control_dt / n_sub, n_sub
    if not (math.isfinite(physics_dt) and 1e-6 <= physics_dt <= 0.05):
        raise ValueError(f"physics_dt = {physics_dt} s is outside the allowed range [1e-6, 0.05] s")
    ratio = control_dt / physics_dt
    n_sub = int(round(ratio))
    if n_sub < 1 or abs(ratio - n_sub) > 1e-9 * ratio:
        raise ValueError(
            f"the control step 1/{control_rate} s must be an integer multiple of physics_dt = {physics_dt} s (ratio {ratio:.6g})"
        )
    return control_dt, physics_dt, n_sub


def delay_steps_of(P: np.ndarray, physics_dt: float) -> np.ndarray:
    """(n, 2) int64, C order: each row's compensator and Hawk servo delays in whole physics steps (nearest).

    P: (n, N_PARAMS) parameter rows; physics_dt: s."""
    return np.ascontiguousarray(np.rint(P[:, DELAY_COLUMNS] / physics_dt).astype(np.int64))


def delay_line(P: np.ndarray, physics_dt: float) -> tuple[np.ndarray, int]:
    """(delay_steps, n_buf): the (n, 2) per-row servo delays in physics steps (:func:`delay_steps_of`) and
    the delay-line length that holds the longest of them (its maximum + 1).  P: (n, N_PARAMS); physics_dt: s."""
    steps = delay_steps_of(P, physics_dt)
    return steps, int(steps.max()) + 1


@njit(cache=True, error_model="numpy", _nrt=False)
def hold_demands(idx, U, P, X, dbuf):
    """Servo equilibrium of environments idx (m,) int64 with the surface commands of U (n, N_INPUTS), rad:
    servo positions in X (n, N_STATE) at the limited demands (rad), servo rates 0, and every slot of the
    delay lines dbuf (n, n_buf, 7) holding those demands; P (n, N_PARAMS).  In place."""
    for i in idx:
        d = integ.limited_demands(U[i], P[i])
        for a in range(7):
            v = d[a] + 0.0  # a zero demand as +0.0
            X[i, L.X_SERVO + a] = v
            X[i, L.X_SERVO_RATE + a] = 0.0
            for s in range(dbuf.shape[1]):
                dbuf[i, s, a] = v


@njit(cache=True, error_model="numpy", _nrt=False)
def hold_separation(idx, U, P, X, tabs):
    """The unsteady model's aerodynamic states X[i, X_SEP:X_SEP + N_AERO] (flow separation, the wake at the
    compensator) of environments idx (m,) in steady flow at their joint and servo state and the inputs of U
    (:func:`rig_env.physics.joint_space.separation_steady`).  In place.  Without that model they are the
    constant ATTACHED, which :meth:`PhysicsBatch.reset` writes without compiling this."""
    for i in idx:
        x = X[i]
        f = L.X_SERVO + 4
        xs = separation_steady(x[0:5], x[5:10], U[i], P[i], (x[f], x[f + 1], x[f + 2]), tabs)
        for k in range(L.N_AERO):
            X[i, L.X_SEP + k] = xs[k]


@dataclass(frozen=True)
class Kernel:
    """A chosen physics kernel: ``kind`` (one of :data:`KINDS`), whether it is the ``parallel`` version,
    and ``step``, the numba function (arguments as :func:`rig_env.physics.integrator.step_batch`, then
    its scratch; the lane kernel takes the flag ``pack_params`` and :func:`rig_env.physics.lanes.literal_args` last)."""

    kind: str
    parallel: bool
    step: Callable[..., None]


def choose_kernel(kind: str, flags: int, n_envs: int, parallel: bool | None = None) -> Kernel:
    """The kernel of ``kind`` ("lanes", "joint" or "dae") for a model with ``flags`` and ``n_envs`` environments.

    Every kind runs every model (the lane kernel: one function per model, :func:`rig_env.physics.lanes.kernel`,
    compiled for the tables' lengths and the compensator table's form, which :class:`PhysicsBatch` gives it: :func:`rig_env.physics.lanes.literal_args`).  parallel: the ``prange`` version; None chooses it from
    :data:`rig_env.physics.integrator.PARALLEL_MIN_ENVS` environments on.
    """
    if kind not in KINDS:
        raise ValueError(f"kernel kind = {kind!r}; allowed: {', '.join(repr(k) for k in KINDS)}")
    par = n_envs >= integ.PARALLEL_MIN_ENVS if parallel is None else bool(parallel)
    if kind == "lanes":
        step = lanes.kernel(flags, par)
    elif kind == "joint":
        step = integ.step_batch if par else integ.step_serial
    else:
        from rig_env.physics import dae

        step = dae.step_batch_dae if par else dae.step_serial_dae
    return Kernel(kind, par, step)


class PhysicsBatch:
    """The state of ``n`` rig environments and the kernel that advances them, one control step per :meth:`step`.

    Arrays (owned here, changed in place only, so callers may keep references to them):

    ===========  ==================  ==============================================================
    X            (n, N_STATE)        joint angles (rad), rates (rad/s), bristles (rad), servo
                                     positions (rad) and rates (rad/s); ``layout.X_*``
    P            (n, N_PARAMS)       parameter rows, SI units and rad (``layout.P_*``)
    U            (n, N_INPUTS)       inputs held over the next control step: surface commands (rad),
                                     the Hawk's gust (m/s, world), airspeed (m/s), the
                                     compensator's gust (m/s, world) (``layout.U_*``)
    dbuf         (n, n_buf, 7)       servo delay lines of limited demands, rad
    delay_steps  (n, 2) int64        compensator and Hawk servo delays, physics steps
    status       (n,) int8           0 ok, else the blow-up code (``layout.S_*``); a flagged
                                     environment is frozen at its last good state
    Y            (n, N_DAE) or None  the DAE's state (kind "dae" only; ``rig_env.physics.dae_layout``)
    ===========  ==================  ==============================================================

    P: (n, N_PARAMS) parameter rows (used without a copy when C-ordered float64); tabs: the
    aerodynamic tables (``RigParams.tables()``); free_idx: indices of the free joints (JOINTS order);
    flags: :func:`flags_of`; physics_dt: s; n_sub: physics steps per control step; kind: the kernel
    (:func:`choose_kernel`); delay_rows: further (k, N_PARAMS) rows whose servo delays the delay lines
    must also hold (e.g. the corners of a randomisation range, for rows :meth:`set_params` writes later);
    parallel: the kernel's ``prange`` version (:func:`choose_kernel`; None: from the batch size).

    Every environment starts at rest at zero angles with zero inputs; :meth:`reset` sets initial states
    (servos in equilibrium with the commands in U, see the module docstring).
    """

    def __init__(
        self,
        P: np.ndarray,
        tabs: tuple[np.ndarray, ...],
        free_idx: np.ndarray,
        flags: int,
        physics_dt: float,
        n_sub: int,
        *,
        kind: str = "lanes",
        delay_rows: np.ndarray | None = None,
        parallel: bool | None = None,
    ) -> None:
        self.P = np.ascontiguousarray(P, dtype=np.float64)
        n = self.P.shape[0]
        self.n_envs = n
        self.tabs = tabs
        self.free_idx = np.ascontiguousarray(free_idx, dtype=np.int64)
        self.n_free = int(self.free_idx.size)
        self.flags = int(flags)
        self.h = float(physics_dt)
        self.n_sub = int(n_sub)
        self.delay_steps = delay_steps_of(self.P, self.h)
        rows = self.P if delay_rows is None else np.concatenate([self.P, np.atleast_2d(delay_rows)])
        n_buf = int(delay_steps_of(rows, self.h).max()) + 1
        self.X = np.zeros((n, L.N_STATE))
        self.U = np.zeros((n, L.N_INPUTS))
        self.dbuf = np.zeros((n, n_buf, L.N_SERVOS))
        self.status = np.zeros(n, dtype=np.int8)
        self.Y: np.ndarray | None = None
        self.k0 = 0
        """Physics steps taken (the delay lines' write position)."""
        self._energy_work: tuple[np.ndarray, np.ndarray] | None = None
        self.select_kernel(kind, parallel)

    # ------------------------------------------------------------------ kernel
    def select_kernel(self, kind: str, parallel: bool | None = None) -> None:
        """Use the kernel of ``kind`` from the next :meth:`step` on (:func:`choose_kernel`), with fresh scratch.

        A switch between the DAE and the joint-space kernels converts the state (X to Y; Y to X after every step)."""
        self.kernel = choose_kernel(kind, self.flags, self.n_envs, parallel)
        kind = self.kernel.kind
        self._params_changed = True  # the lane kernel keeps P packed in its scratch: pack on the next step
        if kind == "lanes":
            self._work: tuple[np.ndarray, ...] = (lanes.new_work(self.n_envs, self.n_sub),)
            self._state = self.X
            self._lane_literals = lanes.literal_args(self.tabs, self.flags)  # the tables' lengths and form, constants of the kernel
        elif kind == "joint":
            self._work = integ.new_work(self.n_envs)
            self._state = self.X
        else:
            from rig_env.physics import dae

            check_no_fixture(self.P)
            self._work = dae.new_work_dae(self.n_envs)
            self.Y = np.zeros((self.n_envs, dae.N_DAE))
            dae.from_joint_state(self.X, self.P, self.Y)
            self._state = self.Y
        self._lanes = kind == "lanes"
        self._dae = kind == "dae"
        self._entry: Callable[..., None] | None = None  # the lane kernel's compiled entry point (lanes.entry_point)

    # ------------------------------------------------------------------ rows
    def set_params(self, idx: np.ndarray, rows: np.ndarray) -> None:
        """Parameter rows (m, N_PARAMS) for environments idx (m,), with their servo delays; call before
        :meth:`reset` of those environments.  ValueError if a delay exceeds the delay lines (see delay_rows)."""
        if self._dae:
            check_no_fixture(np.atleast_2d(rows))
        steps = delay_steps_of(rows, self.h)
        if steps.size and int(steps.max()) >= self.dbuf.shape[1]:
            raise ValueError(f"servo delay of {int(steps.max())} physics steps exceeds the delay lines ({self.dbuf.shape[1] - 1} steps)")
        self.P[idx] = rows
        self.delay_steps[idx] = steps
        self._params_changed = True

    def reset(self, idx: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        """Restart environments idx (m,) at joint angles q (m, 5), rad, and rates qd (m, 5), rad/s (JOINTS
        order; locked joints: their angle, rate 0), with bristles at zero and status ok.  The servos start
        in equilibrium with the surface commands in U[idx] (set them first): at rest at the limited
        demands, which fill the delay lines (:func:`hold_demands`; zero commands: servos at zero); the
        aerodynamic states in steady flow at that state (:func:`hold_separation`; the unsteady model only)."""
        idx = np.atleast_1d(np.arange(self.n_envs)[idx])
        self.X[idx] = 0.0
        self.X[idx, L.X_Q : L.X_Q + 5] = q
        self.X[idx, L.X_QD : L.X_QD + 5] = qd
        hold_demands(idx, self.U, self.P, self.X, self.dbuf)
        if self.flags & L.F_UNSTEADY:
            hold_separation(idx, self.U, self.P, self.X, self.tabs)
        else:  # constant without the unsteady model (compiling hold_separation for it cost seconds of a cold run)
            self.X[idx, L.X_SEP : L.X_SEP + L.N_AERO] = ATTACHED
        self.status[idx] = L.S_OK
        if self._dae:
            from rig_env.physics import dae

            Yi = np.zeros((idx.size, dae.N_DAE))
            dae.from_joint_state(np.ascontiguousarray(self.X[idx]), np.ascontiguousarray(self.P[idx]), Yi)
            self.Y[idx] = Yi

    # ------------------------------------------------------------------ step
    def step(self) -> None:
        """Advance every environment by one control step (n_sub physics steps) with the inputs in U, in place;
        environments already flagged in ``status`` stay frozen, environments that blow up are flagged."""
        tail = (self._params_changed, *self._lane_literals) if self._lanes else ()
        step = self._entry or self.kernel.step
        step(self._state, self.dbuf, self.k0, self.delay_steps, self.P, self.U, self.flags, self.free_idx,
             self.n_free, self.tabs, self.h, self.n_sub, self.status, *self._work, *tail)
        if self._lanes and self._entry is None:  # compiled now: call its machine code directly from here on
            self._entry = lanes.entry_point(self.kernel.step, *self._lane_literals)
        self._params_changed = False
        if self._dae:
            from rig_env.physics import dae

            dae.to_joint_state(self.Y, self.P, self.X)
        self.k0 += self.n_sub

    # ------------------------------------------------------------------ diagnostics
    def energy(self, out: np.ndarray) -> None:
        """Kinetic + potential energy (J; gravity and a test fixture's spring and weight) of every environment's
        joint state X into out (n,)."""
        if self._energy_work is None:
            self._energy_work = integ.new_work(self.n_envs)
        W, MW = self._energy_work
        (integ.energy_batch if self.kernel.parallel else integ.energy_serial)(self.X, self.P, out, W, MW)

    def constraint_residual(self, out: np.ndarray) -> None:
        """Max-abs constraint residual of every environment's DAE state into out (n,) (kind "dae" only)."""
        if not self._dae:
            raise ValueError("constraint_residual: only the DAE kernel has constraints")
        from rig_env.physics import dae

        dae.constraint_residual_batch(self.Y, self.P, self.free_idx, self.n_free, out)
