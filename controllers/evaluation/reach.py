"""Can this rig fly what a task draws?  The tasks' static holds, trimmed on the rig the comparison flies.

The tasks' draws were chosen for the default rig (the pull-up's holds in ``PullUpPushOver.HOLDABLE_DEG``, banks up
to 90 deg from the roll tasks' airspeed floor ``roll.ROLL_MIN_AIRSPEED``, 17 m/s).  An identified rig, or the paper's
model with its 7 deg trim, may reach less; then those episodes fail every law and the comparison reads as the laws'
fault.  :func:`reach` trims a task's extreme static holds (``rig_env.trim``, the holding surface solved for) and
names each that needs more of the compensator's travel than the task allows itself:

| task | hold | allowed share of the travel |
|---|---|---|
| pull_up_push_over | rig pitch at both ends of ``HOLDABLE_DEG``, at both ends of the airspeed range | ``PullUpPushOver.REACH_SHARE`` (85 %) |
| bank_to_bank, velocity_vector_roll | +-90 deg of bank at the lowest airspeed flown (rig roll and model pitch free) | ``roll.ROLL_REACH_SHARE`` (60 %) |

The other tasks hold nothing static to check (an empty list).  ``rig compare --params`` prints the lines before a
task flies and keeps them in ``summary.json``'s ``settings.reach``.  The default rig produces none at the airspeeds the
comparison flies (tested); the paper's model cannot hold the pull-up's -4 deg.
Here and not in the tasks' modules: the deployed rig process imports the tasks, and must not import the trim
solver (scipy, numba's model).
"""

from __future__ import annotations

import math

from rig_env.envs.tasks.longitudinal import PullUpPushOver
from rig_env.envs.tasks.roll import ROLL_REACH_SHARE
from rig_env.linear import trim
from rig_env.params import JOINTS, RigParams

_ROLL_DOING = {"velocity_vector_roll": "accelerates the roll through the worst angle",
               "bank_to_bank": "starts and stops the 30-90 deg steps"}


def hold_share(params: RigParams, free_dofs: tuple[str, ...], joint: str, angle_deg: float, surface: str, airspeed: float) -> float:
    """The share of the compensator's travel (``servos.compensator.limit_deg``) that ``surface`` needs to hold ``joint`` at
    ``angle_deg`` deg at ``airspeed`` m/s with ``free_dofs`` free (``rig_env.trim``; the other joints settle); inf when no
    trim exists."""
    q0 = [0.0] * 5
    q0[JOINTS.index(joint)] = math.radians(angle_deg)
    op = trim(params, free_dofs, q0, airspeed=airspeed, hold={joint: math.radians(angle_deg)}, unknown_inputs=[surface], max_residual=None)
    if not op.residual <= 1e-6:
        return math.inf
    return abs(op.controls_deg[surface]) / params.servos.compensator.limit_deg


def _share(share: float) -> str:
    return f"{100 * share:.0f} %" if math.isfinite(share) else "more than all"


def reach(task: str, params: RigParams, airspeed: tuple[float, float]) -> list[str]:
    """The lines of the module docstring for ``task`` on the rig ``params`` at airspeeds in ``airspeed`` (m/s); empty when
    every checked hold is within the task's share."""
    if task == PullUpPushOver.name:
        out = []
        for V in sorted({float(airspeed[0]), float(airspeed[1])}):
            for th in PullUpPushOver.HOLDABLE_DEG:
                share = hold_share(params, ("rig_pitch", "model_pitch"), "rig_pitch", th, "comp_elevator", V)
                if share > PullUpPushOver.REACH_SHARE:
                    out.append(f"{task}: holding rig pitch at {th:g} deg at {V:g} m/s needs {_share(share)} of the compensator "
                               f"elevator's travel (this task allows {100 * PullUpPushOver.REACH_SHARE:.0f} %; it draws holds in "
                               f"{list(PullUpPushOver.HOLDABLE_DEG)} deg): holds near there are beyond this rig's reach")
        return out
    if task in _ROLL_DOING:
        V = float(min(airspeed))
        share = max(hold_share(params, ("rig_roll", "model_pitch"), "rig_roll", bank, "comp_aileron", V) for bank in (90.0, -90.0))
        if share <= ROLL_REACH_SHARE:
            return []
        return [f"{task}: holding 90 deg of bank at {V:g} m/s needs {_share(share)} of the compensator aileron's travel (the roll "
                f"tasks allow {100 * ROLL_REACH_SHARE:.0f} %: the rest {_ROLL_DOING[task]}): at the low airspeeds this rig's roll "
                "imbalance leaves too little to fly the task"]
    return []


__all__ = ["hold_share", "reach"]
