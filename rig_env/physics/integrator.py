"""Fixed-step integration of the joint-space model, batched over environments with numba ``prange``.

One call advances every environment by one control step of ``n_sub`` physics steps of ``h`` seconds.
Per physics step (Strang splitting, second order overall with friction, fourth order without):

    1. bristle states z: exact solution of eq. (19) over h/2 at the current joint rates
    2. classical RK4 over h on (q, qd, servo positions, servo rates) with z frozen
    3. bristle states z: exact solution over h/2 at the new joint rates

The flow-separation states (``F_UNSTEADY``, X_SEP: the Hawk's and the compensator panels') are split the same way, inside the bristles' half
steps: relaxed exactly over h/2 towards its target at the state of the step's start, held through RK4,
relaxed over h/2 at the state of its end (within a control step, the end's half and the next step's
opening half, at the same state and inputs, as one relaxation over h).
    4. servo rate and position limits

Surface demands pass through a per-environment delay line of whole physics steps.  An environment
whose state becomes non-finite or whose joint rates exceed ``RUNAWAY_RATE`` is frozen at its last
finite state and flagged in ``status``; the others carry on.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from rig_env.physics import friction as fr
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.joint_space import accelerations, kinetic_energy, potential_energy, separation_step
from rig_env.physics.llvm_inline import inlined
from rig_env.physics.vec import FASTMATH

_JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)  # allocation-free kernels: no NRT refcounting
# batch drivers keep NRT: numba does not parallelise a prange loop compiled with _nrt=False
_JIT_BATCH = dict(cache=True, error_model="numpy", fastmath=FASTMATH)

N_Y = 24  # RK state: q (5), qd (5), servo positions (7), servo rates (7)
# scratch layout of one environment's work row
W_Y0 = 0
W_K = 24  # four stage derivatives, 4 x 24
W_YT = 120
W_UD = 144  # delayed demands, 7
W_Q = 151  # generalised forces, 5
W_H = 156  # bias, 5
W_JV = 161  # Jacobian columns, 45
W_QDD = 206
W_BACKUP = 211  # state at the start of the control step, N_STATE
W_DECAY = 240  # bristle decay (a, g) over h/2 of each joint at the joint rate of the last update, 5 x 3
N_WORK = 255
RK_C = (0.0, 0.5, 0.5, 1.0)
RK_W = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)


def new_work(n_envs: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-environment scratch: (n_envs, N_WORK) floats and (n_envs, 5, 5) mass matrices."""
    return np.zeros((n_envs, N_WORK)), np.zeros((n_envs, 5, 5))


@inlined(**_JIT)
def rhs(y, z, xs, ud, u, p, flags, free_idx, n_free, tabs, M, w, out):
    """Time derivative of the RK state y (24,) into out (24,); z, xs: bristle and separation states, held."""
    q = y[0:5]
    qd = y[5:10]
    if flags & L.F_SERVO:
        flaps = y[10:17]
    else:
        flaps = ud
    qdd = w[W_QDD : W_QDD + 5]
    accelerations(q, qd, z, xs, flaps, u, p, flags, free_idx, n_free, tabs, M, w[W_H : W_H + 5], w[W_Q : W_Q + 5], w[W_JV : W_JV + 45], qdd)
    for j in range(5):
        out[j] = 0.0
        out[5 + j] = 0.0
    for a in range(n_free):
        j = free_idx[a]
        out[j] = qd[j]
        out[5 + j] = qdd[j]
    sv.derivatives(y, 10, 17, ud, p, flags, out, 10, 17)


@njit(**_JIT)
def half_bristle_step(x, z, p, free_idx, n_free, h, w):
    """Bristle states z of the free joints over h/2 at the joint rates of x (exact, eq. 19).

    The decay factors depend on the joint rate only, and the rate at the end of one physics step is the
    rate at the start of the next: w[W_DECAY:] keeps (rate, a, g) of each joint's last update and they
    are reused when the rate is bit-for-bit the same.  advance_env invalidates them at the start of
    every control step (the caller may have changed states or parameters in between).
    """
    for a in range(n_free):
        j = free_idx[a]
        v = x[L.X_QD + j]
        c = W_DECAY + 3 * j
        if v == w[c]:
            rate = w[c + 1]
            g = w[c + 2]
        else:
            rate, g = fr.bristle_decay(p, j, v, 0.5 * h)
            w[c] = v
            w[c + 1] = rate
            w[c + 2] = g
        z[j] = fr.advance_bristle_decay(v, z[j], rate, g)


@njit(**_JIT)
def separation_relaxation(x, u, p, tabs, dt):
    """The aerodynamic states x[X_SEP:X_SEP + N_AERO] (flow separation, the wake at the compensator) over dt at
    the joint and servo state of x (exact for their targets held, :func:`rig_env.physics.joint_space.separation_step`;
    the Hawk's surfaces at their servo positions); dt = h/2 on either side of the RK4 step is second order
    overall, as the bristles' split.  Two half steps at the same state with the same inputs (the end of one
    physics step and the start of the next, within a control step) have the same target, so
    :func:`physics_step` makes them one relaxation over h."""
    s = L.X_SEP
    f = L.X_SERVO + 4
    xs = separation_step(x[0:5], x[5:10], u, p, (x[s], x[s + 1], x[s + 2], x[s + 3], x[s + 4], x[s + 5], x[s + 6]),
                         (x[f], x[f + 1], x[f + 2]), dt, tabs)  # fmt: skip
    for k in range(L.N_AERO):
        x[s + k] = xs[k]


@njit(**_JIT)
def physics_step(x, ud, u, p, flags, free_idx, n_free, tabs, h, M, w, sep_open, sep_close):
    """Advance one environment's state x (N_STATE,) by one physics step h (in place).  With F_UNSTEADY the
    separation states relax over h/2 before the RK4 step if ``sep_open`` and over ``sep_close`` seconds after
    it (h/2 at the end of a control step, else h: the next step's opening half merged in)."""
    z = x[L.X_Z : L.X_Z + 5]
    if flags & L.F_FRICTION:
        half_bristle_step(x, z, p, free_idx, n_free, h, w)
    if flags & L.F_UNSTEADY and sep_open:
        separation_relaxation(x, u, p, tabs, 0.5 * h)
    s_ = L.X_SEP
    xs = (x[s_], x[s_ + 1], x[s_ + 2], x[s_ + 3], x[s_ + 4], x[s_ + 5], x[s_ + 6])
    y0 = w[W_Y0 : W_Y0 + N_Y]
    yt = w[W_YT : W_YT + N_Y]
    for i in range(10):
        y0[i] = x[i]
    for i in range(14):
        y0[10 + i] = x[L.X_SERVO + i]
    for s in range(4):
        k = w[W_K + s * N_Y : W_K + (s + 1) * N_Y]
        if s == 0:
            for i in range(N_Y):
                yt[i] = y0[i]
        else:
            kp = w[W_K + (s - 1) * N_Y : W_K + s * N_Y]
            c = RK_C[s] * h
            for i in range(N_Y):
                yt[i] = y0[i] + c * kp[i]
        rhs(yt, z, xs, ud, u, p, flags, free_idx, n_free, tabs, M, w, k)  # one call site: rhs is inlined
    for i in range(N_Y):
        acc = 0.0
        for s in range(4):
            acc += RK_W[s] * w[W_K + s * N_Y + i]
        y0[i] += h * acc
    for i in range(10):
        x[i] = y0[i]
    for i in range(14):
        x[L.X_SERVO + i] = y0[10 + i]
    for k in range(7):
        if flags & L.F_SERVO:
            xs, vs = sv.project(p, k, x[L.X_SERVO + k], x[L.X_SERVO_RATE + k])
            x[L.X_SERVO + k] = xs
            x[L.X_SERVO_RATE + k] = vs
        else:
            x[L.X_SERVO + k] = ud[k]
            x[L.X_SERVO_RATE + k] = 0.0
    if flags & L.F_UNSTEADY:  # after the servos' limits: the wake's target takes the Hawk's surfaces where they end
        separation_relaxation(x, u, p, tabs, sep_close)
    if flags & L.F_FRICTION:
        half_bristle_step(x, z, p, free_idx, n_free, h, w)


@njit(**_JIT)
def limited_demands(u, p):
    """The seven actuators' demands (rad) from the surface commands u, within their position limits (a 7-tuple)."""
    return (
        sv.limited(p, 0, sv.demand(u, 0)), sv.limited(p, 1, sv.demand(u, 1)), sv.limited(p, 2, sv.demand(u, 2)),
        sv.limited(p, 3, sv.demand(u, 3)), sv.limited(p, 4, sv.demand(u, 4)), sv.limited(p, 5, sv.demand(u, 5)),
        sv.limited(p, 6, sv.demand(u, 6)),
    )  # fmt: skip


@njit(**_JIT)
def push_demands(dbuf, slot, u, p):
    """Write the limited actuator demands of inputs u into delay-line slot (per environment)."""
    d = limited_demands(u, p)
    for k in range(7):
        dbuf[slot, k] = d[k]


@njit(**_JIT)
def check(x):
    """Flag a non-finite or runaway state; returns True when the environment is healthy."""
    for i in range(L.N_STATE):
        if not np.isfinite(x[i]):
            return L.S_NONFINITE
    for j in range(5):
        if abs(x[L.X_QD + j]) > L.RUNAWAY_RATE:
            return L.S_RUNAWAY
    return L.S_OK


@njit(**_JIT)
def advance_env(x, w, M, p, u, db, d_comp, d_hawk, k0, flags, free_idx, n_free, tabs, h, n_sub):
    """One environment over one control step; returns its status (x restored on failure)."""
    n_buf = db.shape[0]
    ud = w[W_UD : W_UD + 7]
    backup = w[W_BACKUP : W_BACKUP + L.N_STATE]
    for a in range(L.N_STATE):
        backup[a] = x[a]
    for j in range(5):
        w[W_DECAY + 3 * j] = np.nan  # no cached bristle decay matches (NaN equals nothing)
    for s in range(n_sub):
        k = k0 + s
        push_demands(db, k % n_buf, u, p)
        for a in range(7):
            d = d_comp if a < 4 else d_hawk
            ud[a] = db[(k - d) % n_buf, a]
        physics_step(x, ud, u, p, flags, free_idx, n_free, tabs, h, M, w, s == 0, 0.5 * h if s == n_sub - 1 else h)
    st = check(x)
    if st != L.S_OK:
        for a in range(L.N_STATE):
            x[a] = backup[a]
    return st


@njit(**_JIT)
def advance_slot(i, X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W, MW):
    """Environment i of the batch over one control step: skipped when flagged, flagged when it fails."""
    if status[i] == L.S_OK:
        st = advance_env(
            X[i], W[i], MW[i], P[i], U[i], dbuf[i], delay_steps[i, 0], delay_steps[i, 1],
            k0, flags, free_idx, n_free, tabs, h, n_sub,
        )  # fmt: skip
        if st != L.S_OK:
            status[i] = st


# The serial twins below are separate functions rather than njit applied twice to one function: numba's
# on-disk cache names an entry after the function's name and line only, so twins made from one function
# share it, and whichever was compiled first then runs for both (a "parallel" kernel running serially).


@njit(parallel=True, **_JIT_BATCH)
def step_batch(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W, MW):
    """Advance all environments by one control step of n_sub physics steps, in parallel.

    X: (n, N_STATE) states, in place; dbuf: (n, n_buf, 7) delay lines; k0: physics-step counter at the
    start of this control step; delay_steps: (n, 2) int delays of compensator and Hawk servos, in
    physics steps; P: (n, N_PARAMS); U: (n, N_INPUTS) inputs held over the control step; status: (n,)
    int8, environments with a non-zero status are skipped; W, MW: scratch from ``new_work``.
    """
    for i in prange(X.shape[0]):
        advance_slot(i, X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W, MW)


@njit(**_JIT_BATCH)
def step_serial(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W, MW):
    """Serial twin of step_batch for small batches, where a parallel launch costs more than it saves."""
    for i in range(X.shape[0]):
        advance_slot(i, X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W, MW)


@njit(**_JIT)
def energy_slot(i, X, P, out, W, MW):
    """Kinetic + potential energy (J; gravity and a test fixture's spring and weight) of environment i into out[i]."""
    x = X[i]
    w = W[i]
    q = x[0:5]
    qd = x[5:10]
    out[i] = kinetic_energy(q, qd, P[i], MW[i], w[W_H : W_H + 5], w[W_JV : W_JV + 45]) + potential_energy(q, P[i])


@njit(parallel=True, **_JIT_BATCH)
def energy_batch(X, P, out, W, MW):
    """Kinetic + potential energy (J) of every environment into out (n,), in parallel (see :func:`energy_slot`)."""
    for i in prange(X.shape[0]):
        energy_slot(i, X, P, out, W, MW)


@njit(**_JIT_BATCH)
def energy_serial(X, P, out, W, MW):
    """Serial twin of energy_batch."""
    for i in range(X.shape[0]):
        energy_slot(i, X, P, out, W, MW)


PARALLEL_MIN_ENVS = 32
"""Below this batch size the serial kernels are faster than a parallel launch."""
