"""The compensator's virtual axes (roll, heave, sway) and their map onto its surfaces (numpy only).

The compensator rolls with the rig, so its elevator and rudder act on rig_pitch and rig_yaw through
the roll angle ``phi``.  The laws command *heave* ``h`` and *sway* ``s`` in the unrolled frame
(derivation in :mod:`controllers.design.model`, checked in ``tests/test_controllers.py``):

    aileron = roll,    de = cos(phi) h + sin(phi) s,    dr = -sin(phi) h + cos(phi) s

This module holds only that geometry, so the runtime laws (what a deployed artefact executes) need
numpy alone; the design side (:mod:`controllers.design.model`, python-control, the numba model) re-exports it.
"""

from __future__ import annotations

import math

import numpy as np

AXES = ("roll", "heave", "sway")
"""Virtual inputs of the designs: aileron, heave and sway (normalised; see :func:`resolve`)."""
AXIS_OF = {"rig_roll": 0, "rig_pitch": 1, "rig_yaw": 2}
"""Virtual input that moves each rig joint."""


def axes_of(free_dofs: tuple[str, ...]) -> list[str]:
    """The rig joints of ``free_dofs`` that a compensator axis holds, in :data:`AXES` order."""
    return [j for j in sorted(AXIS_OF, key=AXIS_OF.get) if j in free_dofs]


SURFACES = ("comp_aileron", "comp_elevator", "comp_rudder")
"""The compensator's surfaces, in the order of the environments' first three actions."""


def acting_surfaces(free_dofs: tuple[str, ...]) -> tuple[int, ...]:
    """Indices (into :data:`SURFACES`) of the compensator surfaces that move a free rig joint.

    The ailerons roll the rig (rig_roll); heave and sway come from the elevator and rudder through the
    roll angle (:func:`resolve`): with rig_roll locked at 0 the elevator moves rig_pitch only and the rudder
    rig_yaw only; with rig_roll free, either moves either joint once the rig has rolled.  A surface that
    moves no free joint only costs drag and hinge load.
    """
    roll, heave, sway = ("rig_roll" in free_dofs), ("rig_pitch" in free_dofs), ("rig_yaw" in free_dofs)
    use = (roll, heave or (roll and sway), sway or (roll and heave))
    return tuple(i for i, u in enumerate(use) if u)


def resolve(phi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(n, 3) compensator (aileron, elevator, rudder) from virtual (roll, heave, sway) v (n, 3) at roll phi (n,), rad."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([v[:, 0], c * v[:, 1] + s * v[:, 2], -s * v[:, 1] + c * v[:, 2]], axis=1)


def unresolve(phi: np.ndarray, surfaces: np.ndarray) -> np.ndarray:
    """(n, 3) virtual (roll, heave, sway) from surfaces (n, 3) at roll phi (n,): the inverse of :func:`resolve`."""
    c, s = np.cos(phi), np.sin(phi)
    a, de, dr = surfaces[:, 0], surfaces[:, 1], surfaces[:, 2]
    return np.stack([a, c * de - s * dr, s * de + c * dr], axis=1)


def rotation(phi: float) -> np.ndarray:
    """(3, 3) matrix R with surfaces = R @ virtual inputs (the linear form of :func:`resolve`)."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
