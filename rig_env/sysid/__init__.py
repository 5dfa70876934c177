"""System identification: the rig's model fitted to what the rig recorded (the paper's Sections IV-V).

Records (:class:`FlightRecord`), their readers and pre-processing; input design; friction from wind-off
tests; aerodynamic and other parameters by output error and filter error; the fitted
parameters back into :class:`rig_env.RigParams` and a parameter file.  See README.md, "Identification".

Importing this package is light (numpy and the parameters; scipy when a .mat file is read or written, the
model's kernels when a fit runs).
"""

from __future__ import annotations

from rig_env.sysid.fit import METHODS, fit
from rig_env.sysid.readers import ColumnMap, read_frame_log
from rig_env.sysid.records import (
    GAP_FACTOR,
    MAX_UPSAMPLE,
    FlightRecord,
    RecordError,
    check_sampling,
)
from rig_env.sysid.result import Fit
from rig_env.sysid.smoothing import lowess

__all__ = [
    "GAP_FACTOR", "MAX_UPSAMPLE", "METHODS", "ColumnMap", "Fit", "FlightRecord", "RecordError", "check_sampling", "fit",
    "lowess", "read_frame_log",
]
