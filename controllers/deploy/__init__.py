"""Deployment of a control law to the rig's real-time loop (issue 5).

| module | one idea |
|---|---|
| :mod:`~controllers.deploy.artefact` | a law as one file of plain data (JSON + base64 arrays), checksum, optional HMAC, the kind registry |
| :mod:`~controllers.laws.linear` | ``LinearLaw``: kind "linear" (static state feedback + limits) |
| :mod:`~controllers.deploy.laws` | kinds "pid" and "lqr": the model-based laws' designed tables |
| :mod:`~controllers.deploy.policy_kinds` | kinds "ppo" and "sac": a policy file carried whole, run by :mod:`controllers.laws.rl` |
| :mod:`~controllers.deploy.protocol` | the binary UDP frames (sensor, command), CRC-32 |
| :mod:`~controllers.deploy.loop` | ``RigLoop``: fixed-rate loop, lifecycle, watchdogs, output limits |
| :mod:`~controllers.deploy.framelog` | the loop's append-only binary log |
| :mod:`~controllers.deploy.simrig` | ``SimRig``: the numba model in real time behind the protocol, fault injection |
| :mod:`~controllers.deploy.cli` | ``rig-deploy`` / ``scripts/deploy.py``: export, run, sim-rig |

Why here, under ``controllers``: imports flow one way (``rig_env.physics`` <- ``rig_env.envs`` <-
``controllers`` <- ``controllers.deploy``); ``rig_env`` never imports a controller.  The rig-side
runtime (artefact, protocol, loop, laws) needs numpy and the standard library only, plus
``rig_env.envs`` for the one observation builder; torch and stable-baselines3 are never imported.
Importing this package registers the artefact kinds "linear", "pid", "lqr", "ppo" and "sac".
"""

from controllers.deploy import laws  # noqa: F401  (registers the artefact kinds of every law)
from controllers.deploy.artefact import ARTEFACT_KINDS, Artefact, ArtefactError, load, register_kind, save

__all__ = ["ARTEFACT_KINDS", "Artefact", "ArtefactError", "load", "register_kind", "save"]
