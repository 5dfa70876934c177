"""Continuation and bifurcation analysis: equilibrium branches over a parameter, their stability, folds and
Hopf points, and the periodic orbits born at the Hopf points.

Manual.  :func:`continuation` (also ``rig_env.continuation``) runs it on the rig::

    br = rig_env.continuation(p, free_dofs=("rig_pitch", "model_pitch"), parameter="comp_aero.CLq",
                              values=np.linspace(40, 0, 41), airspeed=20.0, aero_model="tables")
    br.values, br.states, br.stable      # the sampled branch: (m,), (m, n) named by br.state_names, (m,)
    br.hopf, br.folds                    # parameter values of the Hopf and fold points
    br.hopf_points()[0].frequency_hz     # the Hopf frequency
    br.orbits[0].amplitudes              # the periodic orbits of the first Hopf point: (k, n) half peak-to-peak
    plot_branch(br, "diagram.png", state="rig_pitch")   # from rig_env.bifurcation.plot (matplotlib)

How.  Equilibria: pseudo-arclength continuation (the curve is followed through its folds) with a Newton
corrector on f(x, p) = 0, Jacobians by central differences (:mod:`.core`, :mod:`.equilibria`);
stability from the eigenvalues of the full Jacobian; folds, branch points and Hopf points located on the
arclength by regula falsi.  Periodic orbits: single shooting on a flow map, for the rig the environments'
lane kernel (the same model as :func:`rig_env.simulate`'s per-environment kernel, to 1e-10), continued by pseudo-arclength from a small orbit along the Hopf point's
critical eigenvector; Floquet multipliers from the monodromy matrix, the Hopf point's criticality (super- or
subcritical) and the family's own folds of cycles, period doublings and tori (:mod:`.periodic`).  The rig as a
vector field, its parameters (any surface, ``"airspeed"``, any :data:`rig_env.PARAM_NAMES` entry) and
what continuation does with friction and the stops: :mod:`.rig`.  The core takes any vector field
``f(x, p)`` (:func:`equilibria`, :func:`orbits`), so it is tested on closed forms.

Two parameters: :func:`continuation_sweep` (``sweep``: the loci of the folds and Hopf points over a second
parameter, by a branch at each of its sampled values; ``plot.plot_sweep``).

Modules: ``core`` (the curve solver), ``equilibria``, ``periodic``, ``rig``, ``sweep``, ``result`` (:class:`Branch`,
:class:`OrbitBranch`, :class:`SpecialPoint`, :class:`CyclePoint`), ``plot`` (the bifurcation diagram).
"""

from rig_env.bifurcation.core import Settings
from rig_env.bifurcation.equilibria import equilibria
from rig_env.bifurcation.periodic import orbits, rk4_flow
from rig_env.bifurcation.result import Branch, CyclePoint, OrbitBranch, SpecialPoint
from rig_env.bifurcation.rig import AERO_MODELS, continuation
from rig_env.bifurcation.sweep import Sweep, continuation_sweep

__all__ = ["AERO_MODELS", "Branch", "CyclePoint", "OrbitBranch", "Settings", "SpecialPoint", "Sweep", "continuation", "continuation_sweep", "equilibria", "orbits", "rk4_flow"]
