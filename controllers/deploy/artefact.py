"""The artefact codec under its earlier name: everything is :mod:`controllers.laws.artefact` (the one file format of every law)."""

from controllers.laws.artefact import *  # noqa: F401, F403
from controllers.laws.artefact import (  # noqa: F401  (names the tests and tools use beyond __all__)
    _BODY_KEYS, _body, _check_body, _encode_array, Artefact, ArtefactError, artefact_class, artefact_kinds, canonical,
    default_limits, from_controller, load, provenance, save, sensors_of,
)
