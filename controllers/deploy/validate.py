"""One validator for ``rig-deploy verify`` and ``run``: the artefact's own checks, then its spec against the loop.

:func:`load_deployable` = :func:`controllers.laws.artefact.load` (file, JSON, schema, checksum, signature,
arrays, the kind's ``from_data``) + :func:`check_deployable`, which asks what the loop
(:class:`controllers.deploy.loop.RigLoop`) relies on and the artefact codec cannot know without the
environments' names: the task is known, its options are accepted by the task, the free joints are
``rig_env.JOINTS`` names in that order, the observation labels equal what the loop builds for them,
the actions are the loop's surfaces in order (at most six), the law's rate ``1 / spec.dt``, sensor layout
and airspeed range are within the environments' ranges (:data:`ENV_RANGES`), and the rate matches ``spec.dt``.
``verify`` accepts exactly what ``run`` flies; both refuse with an :class:`ArtefactError` naming the file and
the field (exit 2).  Imports: the observation builder only (numpy; no gymnasium, no numba).

:data:`ENV_RANGES` are :class:`rig_env.envs.config.RigEnvConfig`'s ranges of the same fields, from
:mod:`rig_env.envs.ranges` (a module that imports nothing: the configuration itself loads numba, which the rig
process must not, ``tests/test_deploy_imports.py``).
"""

from __future__ import annotations

import os

import numpy as np

from controllers.laws.artefact import Artefact, ArtefactError, load
from rig_env.envs.observation import labels, task_for_seed
from rig_env.envs.ranges import CONTROL_RATE_HZ, CONVERTER_BITS, LINK_DELAY_STEPS, MAX_AIRSPEED, RATE_FILTER_MIN_HZ
from rig_env.envs.sensors import Sensors
from rig_env.envs.tasks import TASKS
from rig_env.params import JOINTS, SURFACES

__all__ = ["ENV_RANGES", "check_deployable", "load_deployable"]

ENV_RANGES: dict[str, tuple[float, float, str]] = {
    "control_rate": (*CONTROL_RATE_HZ, "Hz"),  # the loop's rate_hz too (controllers.deploy.loop.LoopConfig)
    "pot_bits": (*CONVERTER_BITS, "bits"),
    "encoder_bits": (*CONVERTER_BITS, "bits"),
    "link_delay_steps": (*LINK_DELAY_STEPS, "control steps"),
    "rate_filter_hz": (RATE_FILTER_MIN_HZ, 0.5, "Hz"),  # the upper bound is this fraction of the control rate
    "airspeed": (0.0, MAX_AIRSPEED, "m/s"),
}
"""(low, high, unit) of :class:`rig_env.envs.config.RigEnvConfig`'s field of that name, from :mod:`rig_env.envs.ranges`
(which both use): an artefact's law rate ``1 / spec.dt``, ``sensors.*`` and ``spec.airspeed_range`` must lie in them."""


def _check_ranges(art: Artefact, where: str) -> None:
    """Refuse (ArtefactError naming ``where``, the field and the range) a rate, sensor layout or airspeed range
    outside the environments' configuration ranges (:data:`ENV_RANGES`)."""
    spec, sen = art.spec, art.sensors
    lo, hi, unit = ENV_RANGES["control_rate"]
    rate = 1.0 / spec.dt
    if not lo <= rate <= hi:
        raise ArtefactError(f"{where}: spec.dt = {spec.dt:g} s, a law rate of {rate:g} Hz: allowed range [{lo:g}, {hi:g}] {unit} "
                            f"(spec.dt in [{1.0 / hi:g}, {1.0 / lo:g}] s)")
    for k in ("pot_bits", "encoder_bits", "link_delay_steps", "rate_filter_hz"):
        lo, hi, unit = ENV_RANGES[k]
        if k == "rate_filter_hz":
            hi, unit = hi * rate, f"Hz (up to half the law's {rate:g} Hz)"
        if not lo <= sen[k] <= hi:
            raise ArtefactError(f"{where}: sensors.{k} = {sen[k]!r}: allowed range [{lo:g}, {hi:g}] {unit}")
    lo, hi, unit = ENV_RANGES["airspeed"]
    if not all(lo <= v <= hi for v in spec.airspeed_range):
        raise ArtefactError(f"{where}: spec.airspeed_range = {list(spec.airspeed_range)}: each speed in [{lo:g}, {hi:g}] {unit}")


def check_deployable(art: Artefact, where: str, rate_hz: float | None = None) -> None:
    """Refuse (ArtefactError naming ``where`` and the field) a spec the loop cannot fly; ``rate_hz``: the loop's rate, Hz."""
    spec = art.spec

    def need(cond: bool, what: str) -> None:
        if not cond:
            raise ArtefactError(f"{where}: {what}")

    need(spec.task in TASKS, f"spec.task = {spec.task!r}: unknown; known tasks: {sorted(TASKS)}")
    need(all(j in JOINTS for j in spec.free_dofs), f"spec.free_dofs = {list(spec.free_dofs)}: each must be one of {list(JOINTS)}")
    need(list(spec.free_dofs) == sorted(spec.free_dofs, key=JOINTS.index), f"spec.free_dofs = {list(spec.free_dofs)}: not in the order {list(JOINTS)}")
    need(spec.n_actions <= len(SURFACES) and tuple(spec.action_names) == tuple(SURFACES[: spec.n_actions]),
         f"spec.action_names = {list(spec.action_names)}: the loop commands {list(SURFACES)} in this order (the first 1-{len(SURFACES)})")
    _check_ranges(art, where)
    if rate_hz is not None:
        need(abs(rate_hz * spec.dt - 1.0) <= 1e-6, f"rate {rate_hz:g} Hz: the law was designed for {1.0 / spec.dt:g} Hz (spec.dt = {spec.dt} s)")
    try:
        sensors = Sensors(1, tuple(spec.free_dofs), spec.dt, rate_filter_hz=float(art.sensors["rate_filter_hz"]), delay_steps=0, quantise=False)
        task = task_for_seed(spec.task, tuple(spec.free_dofs), spec.dt, 600.0, 0, airspeed=float(np.mean(spec.airspeed_range)),
                             options=dict(spec.task_options))
    except (TypeError, ValueError, KeyError) as e:  # an unknown option is a TypeError of the task's constructor
        raise ArtefactError(f"{where}: spec.task_options = {dict(spec.task_options)} / free_dofs {list(spec.free_dofs)}: "
                            f"refused by task {spec.task!r}: {e}") from None
    built = labels(sensors, task)
    need(tuple(built) == tuple(spec.obs_labels), f"spec.obs_labels: the law expects {list(spec.obs_labels)}, the loop builds {list(built)}")


def load_deployable(path: str | os.PathLike, key: bytes | None = None, require_signature: bool = False,
                    rate_hz: float | None = None) -> Artefact:
    """:func:`controllers.laws.artefact.load` then :func:`check_deployable`: the artefact ``run`` may fly."""
    art = load(path, key, require_signature=require_signature)
    check_deployable(art, str(path), rate_hz)
    return art
