"""System identification: the rig's model fitted to what the rig recorded (the paper's Sections IV-V).

Records (:class:`FlightRecord`), their readers and pre-processing; input design; friction from wind-off
tests; aerodynamic and other parameters by output-error, filter-error and equation-error; the fitted
parameters back into :class:`rig_env.RigParams` and a parameter file.  See README.md, "Identification".

Importing this package is light (numpy and the parameters; scipy only when a .mat file is read or written).
"""

from __future__ import annotations

from rig_env.sysid.readers import ColumnMap, read_frame_log
from rig_env.sysid.records import (
    GAP_FACTOR,
    MAX_UPSAMPLE,
    FlightRecord,
    RecordError,
    check_sampling,
)
from rig_env.sysid.smoothing import lowess

__all__ = ["GAP_FACTOR", "MAX_UPSAMPLE", "ColumnMap", "FlightRecord", "RecordError", "check_sampling", "lowess", "read_frame_log"]
