"""The identification problem: records, the parameters to estimate, the nuisance parameters, and the
model's outputs and their sensitivities for a full parameter vector, one batch per record.

Full parameter vector ``p`` (file units): the k model parameters (:class:`~rig_env.sysid.parameters.ParameterSet`),
then per record its initial free angles and rates (``x0.<record>.<joint>`` rad, ``x0.<record>.<joint>_rate``
rad/s) when ``initial_state="estimate"``, then per record an output bias (``bias.<record>.<output>``) when
``biases=True``.  Sensitivities are finite differences, for each record one batch of environments: the
nominal, then +step of each parameter that moves the record (``differences="forward"``, ``1 + k + n_x0``
environments) or +step and -step (``"central"``, ``1 + 2 (k + n_x0)``).  Forward is the default: half the
environments (two lane registers instead of four for 14 parameters), and its O(step) error, 1e-3 of a
sensitivity, moves the Cramer-Rao bounds by about 0.1 % and the estimate by about 1e-3 of a standard error.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from rig_env.params import RigParams
from rig_env.sysid.checks import check_record_names
from rig_env.sysid.model import RecordModel, output_names
from rig_env.sysid.parameters import ParameterSet
from rig_env.sysid.records import FlightRecord, RecordError

INITIAL_STATES = ("estimate", "measured")
DIFFERENCES = ("forward", "central")
X0_STEP = 1e-5  # rad or rad/s, central-difference step of the initial state


@dataclass
class Evaluation:
    """Per record: outputs Y (n_t, n_out), sensitivities S (n_t, n_out, n_p) or None, and whether the nominal run is finite."""

    Y: list[np.ndarray]
    S: list[np.ndarray | None]
    ok: bool


class Problem:
    """Records + parameters: ``evaluate(p, sensitivities)`` gives each record's outputs (and dY/dp)."""

    def __init__(
        self,
        records: Sequence[FlightRecord],
        params: RigParams,
        pset: ParameterSet,
        *,
        initial_state: str = "estimate",
        biases: bool = False,
        aero: bool | None = None,
        friction: bool = True,
        stops: bool = True,
        aero_model: str = "linear",
        differences: str = "forward",
    ) -> None:
        if isinstance(records, FlightRecord):
            records = [records]
        records = list(records)
        if not records or not all(isinstance(r, FlightRecord) for r in records):
            raise RecordError("records: give one or more FlightRecord objects")
        if differences not in DIFFERENCES:
            raise ValueError(f"differences = {differences!r}; allowed: {', '.join(DIFFERENCES)}")
        self.central = differences == "central"
        if initial_state not in INITIAL_STATES:
            raise ValueError(f"initial_state = {initial_state!r}; allowed: {', '.join(INITIAL_STATES)}")
        self.records = records
        self.params = params
        self.pset = pset
        self.record_names = [r.name for r in records]
        check_record_names(self.record_names)  # the nuisance parameters' names (x0.<record>.<joint>) are the records'
        self.models = [RecordModel(r, params, aero=aero, friction=friction, stops=stops, aero_model=aero_model) for r in records]
        self.outputs = [output_names(r) for r in records]
        k = pset.k
        names = list(pset.names)
        lower, upper, start = list(pset.lower), list(pset.upper), list(pset.start)
        steps_fixed: list[float] = [np.nan] * k
        self.x0_slices: list[slice | None] = []
        self.x0_fixed: list[np.ndarray] = []
        for m, rn in zip(self.models, self.record_names):
            x0 = m.measured_x0()
            self.x0_fixed.append(x0)
            if initial_state == "estimate":
                a = len(names)
                for j, v in zip([*m.record.free_dofs, *(f"{d}_rate" for d in m.record.free_dofs)], x0):
                    names.append(f"x0.{rn}.{j}")
                    lower.append(-np.inf)
                    upper.append(np.inf)
                    start.append(float(v))
                    steps_fixed.append(X0_STEP)
                self.x0_slices.append(slice(a, len(names)))
            else:
                self.x0_slices.append(None)
        self.bias_slices: list[slice | None] = []
        for m, rn in zip(self.models, self.record_names):
            if biases:
                a = len(names)
                for o in m.outputs:
                    names.append(f"bias.{rn}.{o}")
                    lower.append(-np.inf)
                    upper.append(np.inf)
                    start.append(0.0)
                    steps_fixed.append(np.nan)
                self.bias_slices.append(slice(a, len(names)))
            else:
                self.bias_slices.append(None)
        self.names = tuple(names)
        self.lower = np.array(lower)
        self.upper = np.array(upper)
        self.p0 = np.array(start)
        self._steps_fixed = np.array(steps_fixed)
        self.n_p = len(names)
        self.k = k

    # ------------------------------------------------------------------ helpers
    def clip(self, p: np.ndarray) -> np.ndarray:
        return np.clip(p, self.lower, self.upper)

    def x0_of(self, r: int, p: np.ndarray) -> np.ndarray:
        s = self.x0_slices[r]
        return self.x0_fixed[r] if s is None else p[s]

    def steps(self, p: np.ndarray) -> np.ndarray:
        st = self._steps_fixed.copy()
        st[: self.k] = self.pset.steps(p[: self.k])
        return st

    def check_identifiable(self, ev: "Evaluation") -> None:
        """ValueError naming every parameter whose outputs' sensitivity is zero in every record: the records
        cannot show it (a servo delay moves in whole physics steps, so a small change of it changes nothing)."""
        dead = []
        for i, name in enumerate(self.names):
            if all(S is not None and not np.any(S[:, :, i]) for S in ev.S):
                dead.append(name)
        if dead:
            hint = ("; the servo delays act in whole physics steps (a finite-difference step cannot move them): "
                    "identify a delay by fitting at a few fixed values" if any("delay_s" in d for d in dead) else "")
            raise ValueError(f"{dead}: no effect on the records' outputs, so not identifiable from them "
                             f"(a locked joint's parameter, a surface never moved, a term switched off){hint}")

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, p: np.ndarray, sensitivities: bool) -> Evaluation:
        """Outputs of every record at p, with dY/dp (central differences, one batch per record) if asked."""
        k = self.k
        steps = self.steps(p)
        Ys: list[np.ndarray] = []
        Ss: list[np.ndarray | None] = []
        ok = True
        for r, model in enumerate(self.models):
            x0 = self.x0_of(r, p)
            xs = self.x0_slices[r]
            moved = list(range(k)) + (list(range(xs.start, xs.stop)) if (sensitivities and xs is not None) else [])
            if not sensitivities:
                moved = []
            per = 2 if self.central else 1
            m = 1 + per * len(moved)
            thetas = np.repeat(p[None, :k], m, axis=0)
            X0 = np.repeat(x0[None, :], m, axis=0)
            for c, i in enumerate(moved):
                for sgn, e in (((1.0, 1 + 2 * c), (-1.0, 2 + 2 * c)) if self.central else ((1.0, 1 + c),)):
                    if i < k:
                        thetas[e, i] += sgn * steps[i]
                    else:
                        X0[e, i - xs.start] += sgn * steps[i]  # type: ignore[union-attr]
            rows = self.pset.rows(model.base_row, thetas)
            Y, status = model.run(rows, X0)
            y = Y[0]
            bs = self.bias_slices[r]
            if bs is not None:
                y = y + p[bs]
            if status[0] != 0 or not np.all(np.isfinite(y)):
                ok = False
            Ys.append(y)
            if not sensitivities:
                Ss.append(None)
                continue
            S = np.zeros((model.n_t, model.n_out, self.n_p))
            for c, i in enumerate(moved):
                if not self.central:
                    if status[1 + c] == 0:
                        S[:, :, i] = (Y[1 + c] - Y[0]) / steps[i]
                    else:
                        warnings.warn(f"{self.record_names[r]}: the model blew up when {self.names[i]} was perturbed; "
                                      "its sensitivity is taken as zero", RuntimeWarning, stacklevel=3)
                    continue
                up, dn = 1 + 2 * c, 2 + 2 * c
                good_up, good_dn = status[up] == 0, status[dn] == 0
                if good_up and good_dn:
                    S[:, :, i] = (Y[up] - Y[dn]) / (2.0 * steps[i])
                elif good_up or good_dn:
                    e, sgn = (up, 1.0) if good_up else (dn, -1.0)
                    S[:, :, i] = sgn * (Y[e] - Y[0]) / steps[i]
                else:
                    warnings.warn(f"{self.record_names[r]}: the model blew up both ways when {self.names[i]} was perturbed; "
                                  "its sensitivity is taken as zero", RuntimeWarning, stacklevel=3)
            if bs is not None:
                for j in range(model.n_out):
                    S[:, j, bs.start + j] = 1.0
            Ss.append(S)
        return Evaluation(Ys, Ss, ok)
