"""``Fit``: the result of an identification, whatever the method.

Names are the dotted parameter names of :data:`rig_env.PARAM_NAMES` (``hawk_aero.CMalpha``,
``friction.rig_roll.Fc``), in the order given to :func:`rig_env.sysid.fit` as ``estimate``.  Values are in
the parameter file's units.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from rig_env.params import RigParams
from rig_env.sysid.records import FlightRecord


@dataclass(frozen=True, eq=False)
class Fit:
    """An identification result.

    | field | meaning |
    |---|---|
    | method | ``"output_error"``, ``"filter_error"`` or ``"equation_error"`` |
    | estimate | the estimated parameters' names, in the caller's order |
    | values, initial | {name: value}: the estimates and the start values |
    | std | {name: Cramer-Rao standard error}, corrected for coloured residuals |
    | std_white | {name: Cramer-Rao standard error} assuming white residuals (the uncorrected bound) |
    | covariance, correlation | (k, k) in the order of ``estimate`` (covariance: the corrected one) |
    | params | the rig's parameters with the estimates in (a :class:`RigParams`) |
    | records | the records fitted |
    | outputs | per record, the names of the output columns (``model_pitch``: angle, rad; ``model_pitch_rate``: rad/s) |
    | predicted, residuals | per record, (n_t, n_outputs): the model's outputs and measured minus predicted (equation error: accelerations, rad/s^2, at ``times``) |
    | times | per record, the sample times (s) of predicted and residuals when they are not the record's own (equation error drops the differentiator's edges); empty otherwise |
    | noise_cov | (n_outputs, n_outputs) measurement-noise covariance estimate (of the first record's outputs when all share them) |
    | nuisance | {name: value}: estimated initial conditions and biases (``x0.<record>.<joint>``, ``bias.<record>.<output>``) |
    | process_noise | {name: value}: filter error's process-noise standard deviations (empty otherwise) |
    | cost_history | the cost per iteration |
    | iterations, converged, message | how the optimisation ended |
    | warnings | what the fit's own residuals flag (:func:`rig_env.sysid.fit.misfit_warnings`): an output the model does not follow, a sign of a local minimum or a model error; empty when none |
    """

    method: str
    estimate: tuple[str, ...]
    values: Mapping[str, float]
    initial: Mapping[str, float]
    std: Mapping[str, float]
    std_white: Mapping[str, float]
    covariance: np.ndarray
    correlation: np.ndarray
    params: RigParams
    records: tuple[FlightRecord, ...]
    outputs: tuple[tuple[str, ...], ...]
    predicted: tuple[np.ndarray, ...]
    residuals: tuple[np.ndarray, ...]
    noise_cov: np.ndarray
    nuisance: Mapping[str, float] = field(default_factory=dict)
    times: tuple[np.ndarray, ...] = ()
    process_noise: Mapping[str, float] = field(default_factory=dict)
    cost_history: tuple[float, ...] = ()
    iterations: int = 0
    converged: bool = True
    message: str = ""
    warnings: tuple[str, ...] = ()
