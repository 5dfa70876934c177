"""System identification: the rig's model fitted to what the rig recorded (the paper's Sections IV-V).

Records (:class:`FlightRecord`), their readers and pre-processing; input design; friction from wind-off
tests; aerodynamic and other parameters by output error and filter error; the fitted
parameters back into :class:`rig_env.RigParams` and a parameter file.  See README.md, "Identification".

Importing this package is light (numpy and the parameters; scipy when a .mat file is read or written, the
model's kernels when a fit runs).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rig_env.importhook import lazy_attributes
from rig_env.sysid.fit import METHODS, FitWarning, fit, fit_from_starts, misfit_warnings
from rig_env.sysid.inputs import doublet, multisine, peak_factors, three_two_one_one
from rig_env.sysid.readers import ColumnMap
from rig_env.sysid.records import (
    GAP_FACTOR,
    MAX_UPSAMPLE,
    MIN_RECORD_SAMPLES,
    FlightRecord,
    RecordError,
    check_sampling,
    read_frame_log,
)
from rig_env.sysid.result import Fit
from rig_env.sysid.smoothing import lowess

if TYPE_CHECKING:  # what a type checker sees of the lazy names below (their real signatures)
    from rig_env.sysid.friction import fig4_setup, free_decay_estimates, friction_first_estimates, simulate_friction_test
    from rig_env.sysid.montecarlo import MonteCarlo, monte_carlo
    from rig_env.sysid.paramfile import save_fit_params, write_params
    from rig_env.sysid.report import write_report

_LAZY = {  # imported at first use (matplotlib, scipy, the model's kernels)
    "fig4_setup": "rig_env.sysid.friction",
    "simulate_friction_test": "rig_env.sysid.friction",
    "friction_first_estimates": "rig_env.sysid.friction",
    "free_decay_estimates": "rig_env.sysid.friction",
    "save_fit_params": "rig_env.sysid.paramfile",
    "write_params": "rig_env.sysid.paramfile",
    "write_report": "rig_env.sysid.report",
    "monte_carlo": "rig_env.sysid.montecarlo",  # many noisy fits, locally or on Ray
    "MonteCarlo": "rig_env.sysid.montecarlo",
}
__getattr__, __dir__ = lazy_attributes("rig_env.sysid", _LAZY, globals())

__all__ = [
    "GAP_FACTOR", "MAX_UPSAMPLE", "METHODS", "MIN_RECORD_SAMPLES", "ColumnMap", "Fit", "FitWarning", "FlightRecord", "MonteCarlo", "RecordError", "check_sampling", "doublet",
    "fig4_setup", "fit", "fit_from_starts", "misfit_warnings", "monte_carlo", "free_decay_estimates", "friction_first_estimates", "lowess", "simulate_friction_test", "multisine", "peak_factors", "read_frame_log", "save_fit_params", "three_two_one_one", "write_params",
    "write_report",
]
