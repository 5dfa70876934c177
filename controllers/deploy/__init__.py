"""Deployment of a control law to the rig's real-time loop.

| module | one idea |
|---|---|
| :mod:`controllers.laws.artefact` | a law as one file of plain data (JSON + base64 arrays), one checksum, optional HMAC; every law's kind (``artefact_kind``) |
| :mod:`~controllers.deploy.convert` | ``rig-deploy convert-policy``: an old-format policy file (``rig_env.rl_policy``) to an artefact |
| :mod:`~controllers.deploy.protocol` | the binary UDP frames (sensor, command), CRC-32 |
| :mod:`~controllers.deploy.loop` | ``RigLoop``: fixed-rate loop, lifecycle, watchdogs, output limits |
| :mod:`~controllers.deploy.framelog` | the loop's binary log, always a new file; a write failure is reported, never raised |
| :mod:`~controllers.deploy.validate` | the one validator of ``verify`` and ``run``: the artefact's checks and its spec against the loop |
| :mod:`~controllers.deploy.logtool` | ``rig-deploy log show|plot|export``: a flight's log as a summary, PNGs or CSV |
| :mod:`~controllers.deploy.simrig` | ``SimRig``: the numba model in real time behind the protocol, fault injection |
| :mod:`~controllers.deploy.cli` | ``rig-deploy`` / ``scripts/deploy.py``: export, verify, run, sim-rig, convert-policy |

Every law serialises itself (``law.to_data()``, ``cls.from_data(data, spec, num_envs)``) and is
found by its ``artefact_kind`` among the registered laws (:data:`controllers.laws.LAWS`): the
model-based laws' designed tables and the trained policies (which ``rig train`` writes as artefacts
directly) travel in the same file format.

Why here, under ``controllers``: imports flow one way (``rig_env.physics`` <- ``rig_env.envs`` <-
``controllers`` <- ``controllers.deploy``); ``rig_env`` never imports a controller.  The rig-side
runtime (artefact, protocol, loop, laws) needs numpy and the standard library only, plus
``rig_env.envs`` for the one observation builder; torch and stable-baselines3 are never imported.
"""

from controllers.laws.artefact import Artefact, ArtefactError, artefact_class, artefact_kinds, load, save

__all__ = ["Artefact", "ArtefactError", "artefact_class", "artefact_kinds", "load", "save"]
