"""System identification: the rig's model fitted to what the rig recorded (the paper's Sections IV-V).

Records (:class:`FlightRecord`), their readers and pre-processing; input design; friction from wind-off
tests; aerodynamic and other parameters by output-error, filter-error and equation-error; the fitted
parameters back into :class:`rig_env.RigParams` and a parameter file.  See README.md, "Identification".
"""

from __future__ import annotations

from rig_env.sysid.inputs import doublet, multisine, peak_factors, three_two_one_one  # scipy only inside multisine()
from rig_env.sysid.records import FlightRecord, RecordError

__all__ = ["FlightRecord", "RecordError", "doublet", "multisine", "peak_factors", "three_two_one_one"]
