"""A record's simulation by the rig's own model, for many parameter sets at once.

:class:`RecordModel` flies one :class:`~rig_env.sysid.records.FlightRecord`'s inputs (surface commands or
deflections, tunnel speed) through :class:`rig_env.physics.pipeline.PhysicsBatch`, the batch the
environments step, with one environment per parameter set: the nominal set and its perturbations run in
one call of the lane kernel, which is how the identification gets its sensitivities.

Timing (the environments' convention): the record's sample k is the state at ``t_k``; the inputs of
sample k are held over ``[t_k, t_k+1)``; the control step is the record's sample interval (records must
be uniformly sampled: resample first).  Outputs: the free joints' angles (rad), then their rates (rad/s)
when the record measured them.  Surfaces of kind "commanded" pass through the model's servos (delay,
rate limit, second-order lag); of kind "actual" they are the deflections themselves (servo dynamics off,
no transport delay).  The record's ``setup`` overrides its parameter rows (a friction test's fixture).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rig_env.params import JOINTS, SURFACES, RigParams
from rig_env.physics import layout as L
from rig_env.physics.pipeline import DELAY_COLUMNS, PhysicsBatch, flags_of, rates
from rig_env.sysid.records import FlightRecord, RecordError

UNIFORM_TOL = 1e-6  # relative spread of the sample interval a record may have


def output_names(record: FlightRecord) -> tuple[str, ...]:
    """The outputs of a record: its free joints' angles (rad), then their rates (``<joint>_rate``, rad/s) if measured."""
    names = tuple(record.free_dofs)
    if record.qd is not None:
        names += tuple(f"{j}_rate" for j in record.free_dofs)
    return names


def measured_outputs(record: FlightRecord) -> np.ndarray:
    """(n_t, n_out) the record's measured outputs in :func:`output_names` order (rad, rad/s)."""
    return record.q if record.qd is None else np.concatenate([record.q, record.qd], axis=1)


class RecordModel:
    """The model of one record: ``run(rows, x0)`` simulates it for each parameter row and initial state.

    params: the rig; aero, friction, stops, aero_model: the model's terms (servo dynamics on for commanded
    surfaces); aero None: on, except for a wind-off record (airspeed 0 throughout), whose motion through
    still air the quasi-steady tunnel-flow aerodynamics does not describe (a body swinging at rest air
    would see 90 deg of incidence).  The record must be uniformly sampled (RecordError otherwise).
    """

    def __init__(self, record: FlightRecord, params: RigParams, *, aero: bool | None = None, friction: bool = True,
                 stops: bool = True, aero_model: str = "linear") -> None:
        dts = np.diff(record.t)
        dt = float(np.mean(dts))
        if np.max(np.abs(dts - dt)) > UNIFORM_TOL * dt:
            raise RecordError(f"{record.name}: sample intervals vary from {dts.min():.6g} to {dts.max():.6g} s; "
                              "the model steps at one rate: resample the record first (FlightRecord.resample)")
        self.record = record
        self.name = record.name
        self.rate = 1.0 / dt
        self.control_dt, self.h, self.n_sub = rates(self.rate, None)
        self.free_idx = np.array([JOINTS.index(j) for j in record.free_dofs], dtype=np.int64)
        self.n_free = self.free_idx.size
        self.outputs = output_names(record)
        self.n_out = len(self.outputs)
        self.z = measured_outputs(record)
        self.n_t = record.n_t
        actual = record.surface_kind == "actual"
        if aero is None:
            aero = bool(np.any(record.airspeed_series() > 0.0))
        self.aero = aero
        self.flags = flags_of(aero, friction, stops, not actual, aero_model)
        base = params.replace(**record.setup) if record.setup else params
        self.base_row = base.to_vector()
        if actual:
            self.base_row[list(DELAY_COLUMNS)] = 0.0
        self.tabs = base.tables()
        self.locked = record.locked_angles()
        U = np.zeros((self.n_t, L.N_INPUTS))
        U[:, 0 : len(SURFACES)] = np.radians(record.surface_array(SURFACES))
        U[:, L.U_AIRSPEED] = record.airspeed_series()
        self.U = U
        self._actual = actual

    # ------------------------------------------------------------------ rows and states
    def row_with(self, rows: np.ndarray) -> np.ndarray:
        """Kernel rows with this record's fixed adjustments (its actual surfaces bypass the servo delays)."""
        rows = np.array(rows, dtype=np.float64, copy=True)
        if self._actual:
            rows[:, list(DELAY_COLUMNS)] = 0.0
        return rows

    def initial_state(self, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q5, qd5) (m, 5) of initial states x0 (m, 2 n_free): free angles then free rates; locked joints at their angles."""
        m = x0.shape[0]
        q5 = np.repeat(self.locked[None, :], m, axis=0)
        qd5 = np.zeros((m, 5))
        q5[:, self.free_idx] = x0[:, : self.n_free]
        qd5[:, self.free_idx] = x0[:, self.n_free :]
        return q5, qd5

    def measured_x0(self, rate_samples: int = 5) -> np.ndarray:
        """(2 n_free,) a start for the initial state: the first sample's angles and rates (measured, or the
        slope of a line through the first ``rate_samples`` angles)."""
        q0 = self.record.q[0]
        if self.record.qd is not None:
            qd0 = self.record.qd[0]
        else:
            k = min(rate_samples, self.n_t)
            t = self.record.t[:k] - self.record.t[0]
            qd0 = np.polyfit(t, self.record.q[:k], 1)[0] if k >= 2 else np.zeros(self.n_free)
        return np.concatenate([q0, np.atleast_1d(qd0)])

    # ------------------------------------------------------------------ simulation
    def batch(self, rows: np.ndarray, x0: np.ndarray, flags: int | None = None) -> PhysicsBatch:
        """A :class:`PhysicsBatch` of len(rows) environments at the record's first sample (inputs of sample 0 set)."""
        rows = self.row_with(rows)
        # the serial lane kernel whatever the batch size: a fit steps it thousands of times, and the parallel
        # kernel's threads wait for each other at every step (1.7x faster at 29 environments on 2 idle cores,
        # 30x slower when the cores are shared with other processes: a 4 s fit took 120-190 s)
        b = PhysicsBatch(rows, self.tabs, self.free_idx, self.flags if flags is None else flags, self.h, self.n_sub, kind="lanes",
                         parallel=False)
        b.U[:] = self.U[0]
        q5, qd5 = self.initial_state(np.broadcast_to(x0, (rows.shape[0], 2 * self.n_free)))
        b.reset(np.arange(rows.shape[0]), q5, qd5)
        return b

    def outputs_of(self, b: PhysicsBatch, out: np.ndarray) -> None:
        """The outputs (m, n_out) of every environment of batch b, in place."""
        out[:, : self.n_free] = b.X[:, self.free_idx]
        if self.n_out > self.n_free:
            out[:, self.n_free :] = b.X[:, L.X_QD + self.free_idx]

    def run(self, rows: np.ndarray, x0: np.ndarray,
            correct: Callable[[int, PhysicsBatch, np.ndarray], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Simulate the record for each row: (Y (m, n_t, n_out) outputs, status (m,) int8, 0 = ok).

        rows: (m, N_PARAMS) kernel rows; x0: (2 n_free,) or (m, 2 n_free) initial free angles and rates.
        correct(k, batch, y): called after sample k's outputs y (m, n_out) are taken, may change the
        batch's state (the filter-error method's Kalman correction).
        """
        rows = np.atleast_2d(rows)
        m = rows.shape[0]
        b = self.batch(rows, x0)
        Y = np.empty((m, self.n_t, self.n_out))
        y = np.empty((m, self.n_out))
        for k in range(self.n_t):
            if k:
                b.U[:] = self.U[k - 1]
                b.step()
            self.outputs_of(b, y)
            if correct is not None:
                correct(k, b, y)
            Y[:, k] = y
        return Y, b.status.copy()

    def servo_positions(self, row: np.ndarray) -> np.ndarray:
        """(n_t, 7) the servo positions (rad, rig_env.SERVOS order) the record's inputs produce with one
        parameter row; they do not depend on the joints' motion."""
        b = self.batch(np.atleast_2d(row), self.measured_x0())
        out = np.empty((self.n_t, 7))
        for k in range(self.n_t):
            if k:
                b.U[:] = self.U[k - 1]
                b.step()
            out[k] = b.X[0, L.X_SERVO : L.X_SERVO + 7]
        return out


__all__ = ["RecordModel", "output_names", "measured_outputs"]
