"""The laws' design: trim and linearisation of the numba model, python-control, scipy, RL training.

Each law family's design sits beside its runtime by name (``controllers/design/lqr.py`` designs
``controllers/laws/lqr.py``) and returns the tables the runtime executes, as plain data.
:data:`DESIGNS` maps every model-based law class to its design function; :func:`make_controller`
designs and builds in one call.
"""

from __future__ import annotations

import inspect
from typing import Any, Callable

from controllers.design.emulation import design_emulation_lqr
from controllers.design.heave_sway import design_heave_sway_lqr, design_heave_sway_pid
from controllers.design.lqr import design_lqr
from controllers.design.pid import design_pid
from controllers.laws import Controller, LoopSpec, law_for
from controllers.laws.emulation import EmulationLQR
from controllers.laws.heave_sway import HeaveSwayLQR, HeaveSwayPID
from controllers.laws.lqr import LQRLaw
from controllers.laws.pid import PIDLaw

DESIGNS: dict[type[Controller], Callable[..., Any]] = {
    PIDLaw: design_pid,
    LQRLaw: design_lqr,
    HeaveSwayPID: design_heave_sway_pid,
    HeaveSwayLQR: design_heave_sway_lqr,
    EmulationLQR: design_emulation_lqr,
}
"""Design function of each model-based law: ``design(spec, params=None, **options) -> tables``."""


def make_controller(kind: str, spec: LoopSpec, num_envs: int = 1, **options: Any) -> Controller:
    """The law of ``kind`` that takes ``spec`` (:func:`controllers.laws.law_for`), designed and built.

    ``options`` go to the class's design function (``params``, ``link_delay_steps``... see
    :data:`DESIGNS`); ``tables=`` skips the design.  Laws without a design (``"ppo"``, ``"sac"``:
    ``path=``; ``"linear"``: ``K=``...) take ``options`` as constructor arguments.  ValueError for an
    unknown kind or an option the kind's design (or constructor) does not take, before any design work;
    :class:`~controllers.laws.UnsupportedTask` when no law of the kind flies ``spec``.
    """
    cls = law_for(kind, spec)
    design = DESIGNS.get(cls)
    if design is not None and "tables" in options and len(options) > 1:
        raise ValueError(f"tables given: {sorted(set(options) - {'tables'})} belong to the design and must not be passed too")
    takes = cls.__init__ if design is None or "tables" in options else design
    _check_options(kind, takes, options)
    if design is None or "tables" in options:
        return cls(spec, num_envs, **options)
    return cls(spec, num_envs, tables=design(spec, **options))


def _check_options(kind: str, fn: Callable[..., Any], options: dict[str, Any]) -> None:
    """ValueError naming the options ``fn`` (a design function or a law's constructor) does not take: else a TypeError
    ("design_pid() got an unexpected keyword argument") that names neither the kind nor what it takes."""
    params = inspect.signature(fn).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return
    allowed = [n for n, p in params.items() if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and n not in ("self", "spec", "num_envs")]
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ValueError(f"options {unknown}: not options of kind {kind!r} ({getattr(fn, '__qualname__', fn)}); allowed {allowed}")
