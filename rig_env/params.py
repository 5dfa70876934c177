"""Rig parameters: frozen dataclasses loaded from a TOML data file with a source tag on every value.

The default rig (``rig_env/data/default_rig.toml``) is the Bristol pilot manoeuvre rig with the 1/16
BAe Hawk (Pattinson, Lowenberg & Goman, AIAA 2009-5727).  Every value in the file carries its origin:
``paper`` (that paper), ``rig-code`` (the later Bristol rig's control code) or ``estimate`` with a
one-line derivation, or ``identified`` (fitted by :mod:`rig_env.sysid`: the entry also carries ``std``,
the Cramer-Rao standard error in the value's unit, ``records``, the names of the records it was fitted
to, and ``method``, one of :data:`rig_env.params_io.IDENTIFICATION_METHODS`, which are ``rig_env.sysid.METHODS``).
Values are validated on load; errors name the file, the field and its allowed range.  An entry's optional ``unit``
must be the field's own: values are never converted.

Units are SI except where the field name says otherwise (``_deg``, ``_deg_s``, ``_hz``).

The numba kernels read a flat float64 vector per environment (``RigParams.to_vector``), laid out by
:data:`PARAM_NAMES`; :func:`param_batch` builds the ``(n_envs, n_params)`` array with per-environment
overrides for domain randomisation.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from rig_env.params_io import (
    IDENTIFICATION_METHODS,
    IDENTIFIED_KEYS,
    ParameterError,
    did_you_mean,
    params_text,
    write_checked,
)

JOINTS: tuple[str, ...] = ("rig_roll", "rig_pitch", "rig_yaw", "model_pitch", "model_yaw")
"""Canonical joint names, in the order of every joint-space array."""

LIMITED_JOINTS: tuple[str, ...] = ("rig_pitch", "rig_yaw", "model_pitch")
"""Joints with gimbal stops; ``rig_roll`` and ``model_yaw`` are unlimited (and unwrapped)."""

SURFACES: tuple[str, ...] = (
    "comp_aileron",
    "comp_elevator",
    "comp_rudder",
    "hawk_elevator",
    "hawk_aileron",
    "hawk_rudder",
)
"""Control inputs in degrees, as a pilot or controller commands them."""

SERVOS: tuple[str, ...] = ("flap1", "flap2", "flap3", "flap4", "hawk_elevator", "hawk_aileron", "hawk_rudder")
"""Physical actuators: four compensator flaps (after mixing) and three Hawk surfaces."""

SOURCES = ("paper", "rig-code", "estimate", "identified")
_META = ("sources", "identified")  # RigParams fields that record provenance, not parameters

NEUTRAL_DEFAULTS: dict[str, tuple[float, str]] = {
    "hawk_aero.alphadot_fraction": (0.0, "not in the file: 0, the combined CMq + CMalphadot (and CLq) acting on q alone, as before issue 21"),
    "hawk_aero.blanking_alpha_deg": (12.0, "not in the file: 12 deg (paper Sec. VII); inactive with blanked_fraction = 1"),
    "hawk_aero.blanking_width_deg": (6.0, "not in the file: 6 deg; inactive with blanked_fraction = 1"),
    "hawk_aero.blanked_fraction": (1.0, "not in the file: 1, no tail blanking, as before issue 21"),
    "hawk_aero.Clbeta_CL": (0.0, "not in the file: 0, Clbeta independent of lift, as before issue 21"),
    "hawk_aero.sep_tau1": (10.0, "not in the file: 10 c/V, typical of wings at low speed (Goman & Khrabrov 1994); used by aero_model='unsteady' only"),
    "hawk_aero.sep_tau2": (3.0, "not in the file: 3 c/V, typical of wings at low speed (Goman & Khrabrov 1994); used by aero_model='unsteady' only"),
    "hawk_aero.wake_factor": (0.0, "not in the file: 0, no wake at the compensator, as before issue 21 item 4; used by aero_model='unsteady' only"),
    "hawk_aero.sep_cp_travel": (0.0, "not in the file: 0, the lift separation takes or gives back at the attached flow's aerodynamic centre, as before; used by aero_model='unsteady' only"),
    "hawk_aero.Cnbeta_body": (0.0, "not in the file: 0, no fuselage part of Cnbeta apart from the fin's, as before"),
    "comp_aero.sep_tau1": (10.0, "not in the file: 10 c/V, typical of wings at low speed (Goman & Khrabrov 1994); used by aero_model='unsteady' only"),
    "comp_aero.sep_tau2": (3.0, "not in the file: 3 c/V, typical of wings at low speed (Goman & Khrabrov 1994); used by aero_model='unsteady' only"),
}
"""Parameters added after the file format was first used: a file without them loads with these values
(source ``estimate``), which switch the added terms off, so that an older file keeps its model exactly."""
DATA_DIR = Path(__file__).parent / "data"
DEFAULT_FILE = DATA_DIR / "default_rig.toml"
"""The default rig, the consistent set (issue 21): CM0 and alpha0 from one table, the compensator on the arm axis
with its force point at its c.g., the later rig's measured roll imbalance, the alpha-dot split, fin blanking and
Clbeta with lift on."""
PAPER_FILE = DATA_DIR / "paper_rig.toml"
"""The paper's model (Figs. 5 and 7): Table 4's alpha0 with Table 3's CM0, the compensator's force point off its
c.g., a 0.185 kg m roll imbalance, the added terms off."""
CONSISTENT_FILE = DEFAULT_FILE
"""The consistent set's file: the default since issue 21 made it so (kept for scripts that name it)."""



def _f(lo: float, hi: float, unit: str) -> Any:
    return field(metadata={"range": (lo, hi), "unit": unit})


@dataclass(frozen=True)
class Environment:
    gravity: float = _f(0.0, 20.0, "m/s^2")
    air_density: float = _f(0.5, 1.5, "kg/m^3")


@dataclass(frozen=True)
class Geometry:
    """Lengths of eqs. (15)-(17); arm axes x towards the model, y starboard, z down."""

    arm_length: float = _f(0.2, 3.0, "m")  # l_f, pivot to model gimbal
    hawk_cg_x: float = _f(-0.1, 0.1, "m")  # l_cga x, aircraft axes, from the model gimbal
    hawk_cg_z: float = _f(-0.1, 0.1, "m")  # l_cga z (positive: c.g. below the gimbal)
    arm_cg_x: float = _f(-2.0, 2.0, "m")  # l_cgs x
    arm_cg_y: float = _f(-0.2, 0.2, "m")
    arm_cg_z: float = _f(-0.2, 0.2, "m")  # l_cgs z (roll imbalance)
    comp_cg_x: float = _f(-3.0, -0.05, "m")  # -l_r
    comp_cg_y: float = _f(-0.2, 0.2, "m")
    comp_cg_z: float = _f(-0.2, 0.2, "m")
    comp_aero_x: float = _f(-3.0, -0.05, "m")  # compensator aerodynamic reference point
    arm_radius: float = _f(0.0, 0.1, "m")  # root of the compensator panels


@dataclass(frozen=True)
class MassProperties:
    """Masses (kg) and principal inertias about each body's own c.g. (kg m^2, body axes)."""

    hawk_mass: float = _f(0.1, 10.0, "kg")
    hawk_Ixx: float = _f(1e-5, 1.0, "kg m^2")
    hawk_Iyy: float = _f(1e-5, 1.0, "kg m^2")
    hawk_Izz: float = _f(1e-5, 1.0, "kg m^2")
    hawk_Ixz: float = _f(-0.1, 0.1, "kg m^2")
    arm_mass: float = _f(0.1, 50.0, "kg")
    arm_Ixx: float = _f(1e-6, 10.0, "kg m^2")
    arm_Iyy: float = _f(1e-6, 10.0, "kg m^2")
    arm_Izz: float = _f(1e-6, 10.0, "kg m^2")
    comp_mass: float = _f(0.1, 50.0, "kg")
    comp_Ixx: float = _f(1e-6, 10.0, "kg m^2")
    comp_Iyy: float = _f(1e-6, 10.0, "kg m^2")
    comp_Izz: float = _f(1e-6, 10.0, "kg m^2")


@dataclass(frozen=True)
class HawkAero:
    """Eq. (23) derivatives (per rad) plus lateral-directional derivatives, body axes at the c.g."""

    S: float = _f(0.005, 1.0, "m^2")
    c: float = _f(0.01, 1.0, "m")
    b: float = _f(0.05, 3.0, "m")
    e_oswald: float = _f(0.3, 1.0, "-")
    CL0: float = _f(-1.0, 1.5, "-")
    CLalpha: float = _f(0.0, 10.0, "1/rad")
    CLq: float = _f(-50.0, 100.0, "1/rad")
    CLde: float = _f(-5.0, 5.0, "1/rad")
    alpha0: float = _f(-0.3, 0.3, "rad")
    CD0: float = _f(0.0, 1.0, "-")
    CM0: float = _f(-0.5, 0.5, "-")
    CMalpha: float = _f(-5.0, 1.0, "1/rad")
    CMq: float = _f(-100.0, 10.0, "1/rad")  # CMq + CMalphadot
    CMde: float = _f(-10.0, 10.0, "1/rad")
    CYbeta: float = _f(-5.0, 1.0, "1/rad")
    CYdr: float = _f(-2.0, 2.0, "1/rad")
    Clbeta: float = _f(-2.0, 1.0, "1/rad")
    Clp: float = _f(-5.0, 0.5, "1/rad")
    Clr: float = _f(-2.0, 2.0, "1/rad")
    Clda: float = _f(-2.0, 2.0, "1/rad")
    Cldr: float = _f(-2.0, 2.0, "1/rad")
    Cnbeta: float = _f(-2.0, 2.0, "1/rad")
    Cnp: float = _f(-2.0, 2.0, "1/rad")
    Cnr: float = _f(-5.0, 0.5, "1/rad")
    Cnda: float = _f(-2.0, 2.0, "1/rad")
    Cndr: float = _f(-2.0, 2.0, "1/rad")
    # issue 21 (docs/MODEL.md 3.1): the share of the combined q derivatives that is alpha-dot, tail blanking
    # of the fin's derivatives above a break angle of attack, and the swept wing's dihedral effect with lift
    alphadot_fraction: float = _f(0.0, 0.9, "-")  # CMalphadot / (CMq + CMalphadot), likewise for CL
    blanking_alpha_deg: float = _f(0.0, 45.0, "deg")  # onset of fin blanking
    blanking_width_deg: float = _f(0.1, 45.0, "deg")  # blanking complete this far above the onset
    blanked_fraction: float = _f(0.0, 1.0, "-")  # fin derivatives' share left when fully blanked
    Clbeta_CL: float = _f(-1.0, 1.0, "1/rad")  # d(Clbeta)/d(CL), the swept wing's share
    # issue 21 item 1 (docs/MODEL.md 3.1.1): the flow-separation state's time constants (Goman & Khrabrov 1994),
    # in chord lengths of travel c/V; used by aero_model="unsteady" only
    sep_tau1: float = _f(0.5, 100.0, "c/V")  # relaxation time of the separation point
    sep_tau2: float = _f(0.0, 50.0, "c/V")  # delay of the static separation point behind alpha
    # issue 21 item 4 (docs/MODEL.md 3.1.2): the Hawk's wake at the compensator, a multiplier of the derived
    # downwash and sidewash (1 the model as derived, 0 none); used by aero_model="unsteady" only
    wake_factor: float = _f(0.0, 2.0, "-")
    # the travel of the normal force's centre of pressure with flow separation, aft from attached to fully separated
    # (docs/MODEL.md 3.1.1); used by aero_model="unsteady" only (the tables hold its static part)
    sep_cp_travel: float = _f(-0.5, 0.5, "c")
    # the fuselage's share of Cnbeta, which the fin's blanking leaves (docs/MODEL.md 3.1: Cnbeta is the fin's)
    Cnbeta_body: float = _f(-1.0, 0.5, "1/rad")


@dataclass(frozen=True)
class CompensatorAero:
    """Table 4 derivatives of the compensator on its reference area, span and chord S/span."""

    S: float = _f(0.005, 2.0, "m^2")
    span: float = _f(0.05, 3.0, "m")
    e_oswald: float = _f(0.3, 1.0, "-")
    CL0: float = _f(-1.0, 1.0, "-")
    CLalpha: float = _f(0.0, 10.0, "1/rad")
    CLq: float = _f(-50.0, 200.0, "1/rad")
    CLde: float = _f(-5.0, 5.0, "1/rad")
    alpha0: float = _f(-0.3, 0.3, "rad")
    CD0: float = _f(0.0, 1.0, "-")
    CM0: float = _f(-0.5, 0.5, "-")
    CMalpha: float = _f(-10.0, 2.0, "1/rad")
    CMq: float = _f(-200.0, 10.0, "1/rad")
    CMde: float = _f(-10.0, 10.0, "1/rad")
    # the panels' flow-separation time constants (docs/MODEL.md 3.1.1), in their chord S / span over V;
    # used by aero_model="unsteady" only
    sep_tau1: float = _f(0.5, 100.0, "c/V")
    sep_tau2: float = _f(0.0, 50.0, "c/V")


@dataclass(frozen=True)
class LuGre:
    """LuGre friction of one joint, eqs. (19)-(21); N m, rad, s."""

    Fs: float = _f(0.0, 10.0, "N m")
    # Fc > 0: eq. (19) divides by S(v) >= Fc, and S(v) -> Fc at speed (with Fc = 0 the bristle state is
    # not finite from the first sliding step); a joint without friction is friction=False, not Fc = 0
    Fc: float = _f(1e-6, 10.0, "N m")
    alpha_f: float = _f(0.0, 1e4, "s/rad")
    v_d: float = _f(1e-4, 100.0, "rad/s")
    sigma0: float = _f(1e-3, 1e7, "N m/rad")
    sigma1: float = _f(0.0, 100.0, "N m s/rad")
    sigma2: float = _f(0.0, 100.0, "N m s/rad")


@dataclass(frozen=True)
class Friction:
    rig_roll: LuGre
    rig_pitch: LuGre
    rig_yaw: LuGre
    model_pitch: LuGre
    model_yaw: LuGre


@dataclass(frozen=True)
class Stop:
    """A gimbal stop: angle limits and a stiff spring-damper beyond them."""

    lower_deg: float = _f(-89.0, 0.0, "deg")
    upper_deg: float = _f(0.0, 89.0, "deg")
    stiffness: float = _f(0.0, 1e7, "N m/rad")
    damping: float = _f(0.0, 1e5, "N m s/rad")


@dataclass(frozen=True)
class Stops:
    rig_pitch: Stop
    rig_yaw: Stop
    model_pitch: Stop


@dataclass(frozen=True)
class Servo:
    """Surface actuator: transport delay, then position limit, second-order lag with a rate limit."""

    delay_s: float = _f(0.0, 0.2, "s")
    rate_limit_deg_s: float = _f(1.0, 5000.0, "deg/s")
    limit_deg: float = _f(1.0, 45.0, "deg")
    natural_freq_hz: float = _f(0.5, 100.0, "Hz")
    damping: float = _f(0.1, 2.0, "-")


@dataclass(frozen=True)
class Servos:
    compensator: Servo
    hawk: Servo


@dataclass(frozen=True)
class Fixture:
    """A wind-off test fixture on one joint (the paper's Sec. IV, Fig. 4(a)): springs and masses.

    Generalised force on the joint ``-stiffness (q - neutral) + torque`` and ``inertia`` added to the
    joint's diagonal of the joint-space mass matrix.  All zero: no fixture (the rig in flight).

    The inertia is an idealised flywheel on the joint's axis, turning at the joint's rate: it enters
    M_jj only (no coupling to other joints, no gyroscopic terms), which is exact when this joint is the
    only free one (a friction test: the parent body is held, the masses turn with the child about a
    fixed axis) and an idealisation otherwise.  The spring acts on the unwrapped angle (a torsion spring
    winds up over turns of rig roll or model yaw).
    """

    stiffness: float = _f(0.0, 1e3, "N m/rad")  # torsional spring k r^2 of the springs at lever r
    neutral: float = _f(-math.pi, math.pi, "rad")  # joint angle at which the spring is relaxed
    inertia: float = _f(0.0, 10.0, "kg m^2")  # masses m r^2 turning with the joint
    torque: float = _f(-10.0, 10.0, "N m")  # constant torque, e.g. a hanging weight's m g r


@dataclass(frozen=True)
class Fixtures:
    rig_roll: Fixture
    rig_pitch: Fixture
    rig_yaw: Fixture
    model_pitch: Fixture
    model_yaw: Fixture


TABLE_ALPHA_RANGE_DEG: tuple[float, float] = (-180.0, 180.0)
"""Allowed breakpoints of the high-incidence tables' grids (``alpha_deg``, ``comp_alpha_deg``), deg: every angle of attack."""
TABLE_COEFFICIENT_LIMIT = 5.0
"""Allowed magnitude of a high-incidence table's coefficient (``hawk_CL``, ``hawk_CM``, ``comp_CN``): a sanity bound,
not a physical claim.  No wing or body at any incidence comes near it (a flat plate broadside has CN about 2,
a wing's CLmax is below 2 without high-lift devices and the default tables stay within 1.2); a value beyond it is
a typing or unit error."""


@dataclass(frozen=True)
class HighIncidence:
    """Static coefficient tables over angle of attack (deg) for the optional nonlinear model.

    ``hawk_CL``/``hawk_CM`` replace ``CL0 + CLalpha (alpha - alpha0)`` and ``CM0 + CMalpha (alpha -
    alpha0)``; ``comp_CN`` replaces the compensator panels' ``CLalpha (alpha - alpha0)``.  Outside the
    table the end values are held.  These are not per-environment parameters.

    Each field is a tuple of floats; a grid (``alpha_deg``, ``comp_alpha_deg``) has at least 2 strictly
    increasing breakpoints within :data:`TABLE_ALPHA_RANGE_DEG`, a coefficient one value per breakpoint of
    its grid, each within +-:data:`TABLE_COEFFICIENT_LIMIT`.
    """

    alpha_deg: tuple[float, ...]
    hawk_CL: tuple[float, ...]
    hawk_CM: tuple[float, ...]
    comp_alpha_deg: tuple[float, ...]
    comp_CN: tuple[float, ...]


@dataclass(frozen=True)
class RigParams:
    """All parameters of one rig.  Frozen: derive variants with :meth:`replace`."""

    environment: Environment
    geometry: Geometry
    mass: MassProperties
    hawk_aero: HawkAero
    comp_aero: CompensatorAero
    friction: Friction
    stops: Stops
    servos: Servos
    fixture: Fixtures
    high_incidence: HighIncidence
    sources: Mapping[str, tuple[str, str]] = field(default_factory=dict, compare=False, repr=False)
    identified: Mapping[str, Mapping[str, Any]] = field(default_factory=dict, compare=False, repr=False)

    # ------------------------------------------------------------------ construction
    @classmethod
    def default(cls) -> "RigParams":
        """The default rig, from ``rig_env/data/default_rig.toml``."""
        return cls.from_toml(DEFAULT_FILE)

    @classmethod
    def consistent(cls) -> RigParams:
        """The consistent set, which is the default rig (:meth:`default`): CM0 and alpha0 from Table 3, the
        compensator on the arm axis, the measured 0.398 kg m roll imbalance, and the alpha-dot split, fin blanking
        and Clbeta with lift switched on.  Kept for scripts written before it became the default."""
        return cls.from_toml(DEFAULT_FILE)

    @classmethod
    def paper(cls) -> RigParams:
        """The paper's model, from ``rig_env/data/paper_rig.toml`` (:data:`PAPER_FILE`): Table 4's alpha0 with Table
        3's CM0 (trim 7.7 deg), the compensator's force point 2 cm from its c.g., a 0.185 kg m roll imbalance, no
        alpha-dot split, fin blanking or Clbeta with lift.  The set Figs. 5 and 7 are reproduced with
        (``rig_env.reference``)."""
        return cls.from_toml(PAPER_FILE)

    @classmethod
    def from_toml(cls, path: str | Path) -> "RigParams":
        """Load and validate a parameter file (see the default file for its layout)."""
        path = Path(path)
        try:
            with path.open("rb") as fh:
                raw = tomllib.load(fh)
        except FileNotFoundError:
            raise ParameterError(f"parameter file not found: {path}") from None
        except IsADirectoryError:
            raise ParameterError(f"{path}: is a folder, not a parameter file") from None
        except OSError as exc:
            raise ParameterError(f"{path}: cannot be read ({exc.strerror or exc})") from None
        except UnicodeDecodeError as exc:
            raise ParameterError(f"{path}: not a parameter file (not UTF-8 text: byte {exc.start} is {exc.object[exc.start:exc.start + 1]!r})") from None
        except tomllib.TOMLDecodeError as exc:
            raise ParameterError(f"{path}: not valid TOML: {exc}") from None
        sources: dict[str, tuple[str, str]] = {}
        identified: dict[str, dict[str, Any]] = {}
        params = _build(cls, raw, "", sources, str(path), identified)
        params = dataclasses.replace(params, sources=sources, identified=identified)
        try:
            params.validate()
        except ParameterError as exc:
            raise ParameterError(f"{path}: {exc}") from None
        return params

    def replace(self, **overrides: Any) -> "RigParams":
        """A copy with dotted-name overrides, e.g. ``p.replace(**{"mass.hawk_mass": 1.2})``.

        Names are those of :data:`PARAM_NAMES` (``group.field``, ``friction.<joint>.<field>`` or
        ``fixture.<joint>.<field>``), each a number (Python or numpy), or a table ``high_incidence.<field>``, a
        sequence of numbers (list, tuple or 1-D array; stored as a tuple of floats).  The copy is validated.
        """
        tree = dataclasses.asdict(self)
        for meta in _META:
            tree.pop(meta)
        for name, value in overrides.items():
            parts = name.split(".")
            node: Any = tree
            for part in parts[:-1]:
                if not isinstance(node, dict) or part not in node:
                    raise ParameterError(f"unknown parameter {name!r}{did_you_mean(name, PARAM_NAMES)}; valid names: see rig_env.PARAM_NAMES")
                node = node[part]
            if not isinstance(node, dict) or parts[-1] not in node or isinstance(node[parts[-1]], dict):
                raise ParameterError(f"unknown parameter {name!r}{did_you_mean(name, PARAM_NAMES)}; valid names: see rig_env.PARAM_NAMES")
            if parts[0] == "high_incidence":
                node[parts[-1]] = _table_values(name, value)
            else:
                number = _real(value)
                node[parts[-1]] = value if number is None else number  # not a number: validate() names it
        new = _from_plain(RigParams, tree)
        srcs = dict(self.sources)
        for name in overrides:
            srcs[name] = ("override", "set by RigParams.replace")
        ident = {k: v for k, v in self.identified.items() if k not in overrides}
        new = dataclasses.replace(new, sources=srcs, identified=ident)
        new.validate()
        return new

    def with_lift_break(self, alpha_deg: float, depth: float) -> "RigParams":
        """A copy whose Hawk tables lose ``depth`` of lift at ``alpha_deg`` (a new breakpoint between two of the
        tables' own, the values at those two unchanged): a local break of the lift curve such as a laminar
        separation bubble gives a wing at the rig's Reynolds number (about 1.6e5 at 20 m/s), which static
        tests at that Reynolds number would show and the default tables (linear to 8 deg) do not hold.

        The lost lift acts at the attached flow's aerodynamic centre, the separation model's own assumption
        (docs/MODEL.md 3.1.1): CM changes by (CMalpha / CLalpha) times the lift's change, so the static pitching
        moment about the c.g. follows the lift.  With ``aero_model="unsteady"`` the static separation state
        x0 falls below 1 between the neighbouring breakpoints, which is what the flow-separation model acts on
        (docs/MODEL.md 7: what Fig. 8's lower limit cycle takes).

        alpha_deg: strictly between two breakpoints of ``high_incidence.alpha_deg`` (deg); depth: 0 <= depth <
        the table's CL there.  ParameterError naming the field and its allowed range otherwise.
        """
        hi = self.high_incidence
        a = [float(v) for v in hi.alpha_deg]
        a_num, d_num = _real(alpha_deg), _real(depth)  # numpy numbers as Python's
        alpha_deg = alpha_deg if a_num is None else a_num
        depth = depth if d_num is None else d_num
        if not isinstance(alpha_deg, (int, float)) or isinstance(alpha_deg, bool) or not math.isfinite(alpha_deg):
            raise ParameterError(f"alpha_deg: a finite angle of attack in deg, not {alpha_deg!r}")
        if not a[0] < alpha_deg < a[-1] or alpha_deg in a:
            raise ParameterError(f"alpha_deg = {alpha_deg}: must lie strictly between two breakpoints of high_incidence.alpha_deg "
                                 f"({a[0]} to {a[-1]} deg, not on one of {a})")
        cl_there = float(np.interp(alpha_deg, a, hi.hawk_CL))
        if not isinstance(depth, (int, float)) or isinstance(depth, bool) or not 0.0 <= depth < abs(cl_there):
            raise ParameterError(f"depth = {depth!r}: the lift lost at {alpha_deg} deg must be in [0, {abs(cl_there):.4g}) "
                                 f"(the table's CL there)")
        ratio = self.hawk_aero.CMalpha / self.hawk_aero.CLalpha
        k = int(np.searchsorted(a, alpha_deg))
        lift = -math.copysign(float(depth), cl_there)  # a loss of lift's magnitude
        cl = list(hi.hawk_CL)
        cm = list(hi.hawk_CM)
        cm_there = float(np.interp(alpha_deg, a, hi.hawk_CM))
        a.insert(k, float(alpha_deg))
        cl.insert(k, cl_there + lift)
        cm.insert(k, cm_there + ratio * lift)
        new = self.replace(**{"high_incidence.alpha_deg": tuple(a), "high_incidence.hawk_CL": tuple(cl),
                              "high_incidence.hawk_CM": tuple(cm)})
        note = f"a lift break of {depth} at {alpha_deg} deg added (RigParams.with_lift_break)"
        srcs = dict(new.sources)
        for name in ("high_incidence.alpha_deg", "high_incidence.hawk_CL", "high_incidence.hawk_CM"):
            srcs[name] = ("override", note)
        return dataclasses.replace(new, sources=srcs)

    # ------------------------------------------------------------------ validation
    def validate(self) -> None:
        """Check every field against its range and the cross-field rules; raise ParameterError."""
        for name, value, (lo, hi), unit in _iter_leaves(self):
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise ParameterError(f"{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ParameterError(f"{name} must be finite, got {value!r}")
            if not lo <= value <= hi:
                raise ParameterError(f"{name} = {value} {unit} is outside the allowed range [{lo}, {hi}] {unit}")
        m = self.mass
        for body in ("hawk", "arm", "comp"):
            ixx, iyy, izz = (getattr(m, f"{body}_I{a}") for a in ("xx", "yy", "zz"))
            for a, b_, c_, n in ((ixx, iyy, izz, "Ixx"), (iyy, izz, ixx, "Iyy"), (izz, ixx, iyy, "Izz")):
                if a > b_ + c_ + 1e-12:
                    raise ParameterError(
                        f"mass.{body}_{n} = {a} violates the rigid-body triangle inequality "
                        f"(must be <= the sum of the other two principal inertias, {b_ + c_})"
                    )
        if m.hawk_Ixz**2 >= m.hawk_Ixx * m.hawk_Izz:
            raise ParameterError("mass.hawk_Ixz: the Hawk inertia tensor must be positive definite (Ixz^2 < Ixx Izz)")
        for j in JOINTS:
            fr: LuGre = getattr(self.friction, j)
            if fr.Fs < fr.Fc:
                raise ParameterError(f"friction.{j}.Fs = {fr.Fs} must be >= friction.{j}.Fc = {fr.Fc}")
        for j in LIMITED_JOINTS:
            st: Stop = getattr(self.stops, j)
            if st.lower_deg >= st.upper_deg:
                raise ParameterError(f"stops.{j}: lower_deg {st.lower_deg} must be < upper_deg {st.upper_deg}")
        g = self.geometry
        if g.arm_radius >= self.comp_aero.span / 2:
            raise ParameterError("geometry.arm_radius must be smaller than comp_aero.span / 2")
        hi = self.high_incidence
        lim = TABLE_COEFFICIENT_LIMIT
        for grid, coefficients in (("alpha_deg", ("hawk_CL", "hawk_CM")), ("comp_alpha_deg", ("comp_CN",))):
            gname = f"high_incidence.{grid}"
            xs = _check_table(gname, getattr(hi, grid), TABLE_ALPHA_RANGE_DEG, " deg")
            if len(xs) < 2:
                raise ParameterError(f"{gname}: needs at least 2 breakpoints, got {len(xs)}")
            for i in range(len(xs) - 1):
                if not xs[i] < xs[i + 1]:
                    raise ParameterError(f"{gname} must be strictly increasing: [{i}] = {xs[i]} deg, then [{i + 1}] = {xs[i + 1]} deg")
            for c in coefficients:
                cname = f"high_incidence.{c}"
                ys = _check_table(cname, getattr(hi, c), (-lim, lim), "", f" (|CL|, |CM|, |CN| <= {lim:g}: no wing or body comes near it)")
                if len(ys) != len(xs):
                    raise ParameterError(f"{cname}: needs one value per breakpoint of {gname} ({len(xs)}), got {len(ys)}")

    # ------------------------------------------------------------------ flat layout for kernels
    def to_vector(self) -> np.ndarray:
        """The flat float64 vector the kernels read, laid out by :data:`PARAM_NAMES` (SI, rad)."""
        vals = dict((name, value) for name, value, _, _ in _iter_leaves(self))
        out = np.empty(len(PARAM_NAMES))
        for i, name in enumerate(PARAM_NAMES):
            v = float(vals[name])
            out[i] = math.radians(v) if name.endswith(("_deg", "_deg_s")) else v
        return out

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """High-incidence tables as float64 arrays in rad: (alpha, hawk_CL, hawk_CM, comp_alpha, comp_CN)."""
        hi = self.high_incidence
        return (
            np.radians(np.asarray(hi.alpha_deg, dtype=np.float64)),
            np.asarray(hi.hawk_CL, dtype=np.float64),
            np.asarray(hi.hawk_CM, dtype=np.float64),
            np.radians(np.asarray(hi.comp_alpha_deg, dtype=np.float64)),
            np.asarray(hi.comp_CN, dtype=np.float64),
        )

    def to_toml(self, path: str | Path, overwrite: bool = False, *, base_file: str | Path | None = None) -> Path:
        """Write a complete parameter file at ``path`` (every group and value, laid out as the default file)
        that :meth:`from_toml` reads back to the same values and sources; returns the path.

        Each value keeps its recorded source and note (and, if identified, ``std``, ``records``, ``method``);
        a value without one (set by :meth:`replace`) takes the source of ``base_file`` (default: the default
        rig) if it is that file's value, else a ParameterError names it.  FileExistsError if ``path``
        exists and not ``overwrite``.
        """
        base = RigParams.from_toml(DEFAULT_FILE if base_file is None else base_file)
        text = params_text(self, lambda name: self.file_provenance(name, base), HEADER)
        return write_checked(text, path, RigParams.from_toml, self, overwrite)

    def file_provenance(self, name: str, base: "RigParams") -> dict[str, Any]:
        """The provenance a parameter file records for ``name``: its own (:meth:`provenance`), else ``base``'s
        if the value is ``base``'s; ParameterError otherwise (a value set by :meth:`replace` and never sourced)."""
        if self.sources.get(name, ("",))[0] in SOURCES:
            return self.provenance(name)
        if name == "high_incidence":
            same = base.high_incidence == self.high_incidence
        else:
            same = _leaf(base, name) == _leaf(self, name)
        if name in base.sources and same:
            return base.provenance(name)
        raise ParameterError(f"{name} has no recorded source (set by RigParams.replace?) and differs from the base file; "
                             f"give it in identified, or write it into a base file with its source")

    def source(self, name: str) -> tuple[str, str]:
        """(source tag, note) of a dotted parameter name as recorded in its data file."""
        if name not in self.sources:
            raise ParameterError(f"no source recorded for {name!r}")
        return self.sources[name]

    def provenance(self, name: str) -> dict[str, Any]:
        """Everything the data file says of a dotted name's origin: ``source`` and ``note``, and for an
        ``identified`` value also ``std`` (Cramer-Rao standard error, the value's unit), ``records``
        (list of record names) and ``method``.  ``"high_incidence"`` names the tables."""
        src, note = self.source(name)
        return {"source": src, "note": note, **{k: (list(v) if k == "records" else v) for k, v in self.identified.get(name, {}).items()}}


# ---------------------------------------------------------------------- helpers
HEADER = """# Rig parameters (written by rig_env: RigParams.to_toml or rig_env.sysid.paramfile).
# Every value: source = paper | rig-code | estimate | identified; identified values carry std (Cramer-Rao
# standard error, the value's unit), the records they were fitted to and the method.
# Units SI unless the field name says _deg, _deg_s or _hz. Axes: x towards the model (upstream), y starboard, z down.
"""


def _real(v: Any) -> int | float | None:
    """``v`` as a Python int or float if it is a real number (Python's or numpy's, a 0-d array too; not a bool), else None."""
    if isinstance(v, (bool, np.bool_)):
        return None
    if isinstance(v, (int, float)):
        return v
    if isinstance(v, (np.integer, np.floating)) or (isinstance(v, np.ndarray) and v.ndim == 0 and v.dtype.kind in "iuf"):
        return v.item()
    return None


def _table_values(name: str, v: Any) -> tuple[float, ...]:
    """A high-incidence table's values as the dataclass holds them, a tuple of floats; ParameterError naming ``name``
    if ``v`` is not a flat sequence (list, tuple, 1-D array) of numbers.  Ranges: :meth:`RigParams.validate`."""
    if isinstance(v, np.ndarray) and v.ndim != 1:
        raise ParameterError(f"{name} must be a flat list of numbers, got an array of shape {v.shape}")
    if not isinstance(v, (list, tuple, np.ndarray)):
        raise ParameterError(f"{name} must be a list of numbers (one per breakpoint), got {type(v).__name__} {v!r}")
    out = []
    for i, x in enumerate(v):
        number = _real(x)
        if number is None:
            what = "a nested list" if isinstance(x, (list, tuple, np.ndarray)) else repr(x)
            raise ParameterError(f"{name}[{i}] must be a number, got {what}")
        out.append(float(number))
    return tuple(out)


def _check_table(name: str, values: Any, bounds: tuple[float, float], unit: str, why: str = "") -> tuple[float, ...]:
    lo, hi = bounds
    if not isinstance(values, tuple):
        raise ParameterError(f"{name} must be a tuple of floats (RigParams.replace and from_toml convert), got {type(values).__name__}")
    for i, v in enumerate(values):
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            raise ParameterError(f"{name}[{i}] must be a number, got {v!r}")
        if not math.isfinite(v):
            raise ParameterError(f"{name}[{i}] must be finite, got {v!r}")
        if not lo <= v <= hi:
            raise ParameterError(f"{name}[{i}] = {v}{unit} is outside the allowed range [{lo}, {hi}]{unit}{why}")
    return values


def _leaf(params: Any, name: str) -> Any:
    obj = params
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _iter_leaves(obj: Any, prefix: str = ""):
    for f in fields(obj):
        if f.name in _META or f.name == "high_incidence":
            continue
        value = getattr(obj, f.name)
        name = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(value):
            yield from _iter_leaves(value, name + ".")
        else:
            yield name, value, f.metadata["range"], f.metadata["unit"]


def _build(cls: type, raw: Mapping[str, Any], prefix: str, sources: dict, path: str, identified: dict | None = None) -> Any:
    if not isinstance(raw, Mapping):
        raise ParameterError(f"{path}: [{prefix.rstrip('.')}] must be a table")
    identified = {} if identified is None else identified
    known = {f.name for f in fields(cls) if f.name not in _META}
    unknown = set(raw) - known
    if unknown:
        raise ParameterError(f"{path}: unknown field(s) {sorted(prefix + u for u in unknown)}; allowed: {sorted(known)}")
    kwargs = {}
    for f in fields(cls):
        if f.name in _META:
            continue
        name = prefix + f.name
        if f.name not in raw and name in NEUTRAL_DEFAULTS:
            kwargs[f.name], note = NEUTRAL_DEFAULTS[name]
            sources[name] = ("estimate", note)
            continue
        if f.name not in raw:
            raise ParameterError(f"{path}: missing field {name}")
        entry = raw[f.name]
        ftype = _resolve(cls, f.name)
        if dataclasses.is_dataclass(ftype) and ftype is not HighIncidence:
            kwargs[f.name] = _build(ftype, entry, name + ".", sources, path, identified)
        elif ftype is HighIncidence:
            table = _table_entry(entry, name, path)
            try:
                kwargs[f.name] = HighIncidence(**{k: _table_values(f"{name}.{k}", v) for k, v in table.items()})
            except ParameterError as exc:
                raise ParameterError(f"{path}: {exc}") from None
            sources[name] = (entry["source"], str(entry.get("note", "")))
        else:
            if not isinstance(entry, Mapping) or "value" not in entry or "source" not in entry:
                raise ParameterError(f"{path}: {name} must be a table {{ value = ..., source = ... }}")
            src = entry["source"]
            if src not in SOURCES:
                raise ParameterError(f"{path}: {name}.source = {src!r}; allowed: {', '.join(SOURCES)}")
            note = str(entry.get("note", ""))
            if src == "estimate" and not note:
                raise ParameterError(f"{path}: {name} is an estimate and needs a 'note' with its derivation")
            extra = set(entry) - {"value", "source", "note", "unit", *IDENTIFIED_KEYS}
            if extra:
                raise ParameterError(f"{path}: {name} has unknown key(s) {sorted(extra)}")
            unit = f.metadata["unit"]
            if "unit" in entry and entry["unit"] != unit:  # a label, never a conversion: a value in another unit is refused
                raise ParameterError(f"{path}: {name}.unit = {entry['unit']!r}, but {name} is in {unit!r}; give the value in "
                                     f"{unit!r} (unit = {unit!r}, or no unit key): units are not converted")
            if src == "identified":
                identified[name] = _identified_entry(entry, name, path)
            elif set(entry) & set(IDENTIFIED_KEYS):
                raise ParameterError(f"{path}: {name}: {sorted(set(entry) & set(IDENTIFIED_KEYS))} belong to source = \"identified\" only")
            kwargs[f.name] = entry["value"]
            sources[name] = (src, note)
    return cls(**kwargs)


def _identified_entry(entry: Mapping[str, Any], name: str, path: str) -> dict[str, Any]:
    missing = [k for k in IDENTIFIED_KEYS if k not in entry]
    if missing:
        raise ParameterError(f"{path}: {name} is identified and needs {missing} (std: Cramer-Rao standard error >= 0 in the "
                             f"value's unit; records: list of record names; method: the identification method)")
    std = entry["std"]
    if isinstance(std, bool) or not isinstance(std, (int, float)) or not math.isfinite(std) or std < 0:
        raise ParameterError(f"{path}: {name}.std = {std!r}: must be a finite number >= 0 (the value's unit)")
    recs = entry["records"]
    if not isinstance(recs, list) or not recs or not all(isinstance(r, str) and r for r in recs):
        raise ParameterError(f"{path}: {name}.records = {recs!r}: must be a non-empty list of record names (strings)")
    method = entry["method"]
    if not isinstance(method, str) or not method:
        raise ParameterError(f"{path}: {name}.method = {method!r}: must be a non-empty string")
    if method not in IDENTIFICATION_METHODS:
        raise ParameterError(f"{path}: {name}.method = {method!r}; allowed: {', '.join(IDENTIFICATION_METHODS)}")
    return {"std": float(std), "records": tuple(recs), "method": method}


def _table_entry(entry: Any, name: str, path: str) -> dict:
    if not isinstance(entry, Mapping) or entry.get("source") not in SOURCES:
        raise ParameterError(f"{path}: [{name}] must have a source tag ({', '.join(SOURCES)})")
    if entry["source"] == "estimate" and not entry.get("note"):
        raise ParameterError(f"{path}: [{name}] is an estimate and needs a 'note'")
    keys = {f.name for f in fields(HighIncidence)}
    out = {k: v for k, v in entry.items() if k not in ("source", "note")}
    if set(out) != keys:
        raise ParameterError(f"{path}: [{name}] needs exactly the keys {sorted(keys)}, got {sorted(out)}")
    return out


def _resolve(cls: type, name: str) -> Any:
    return _type_hints(cls)[name]


@functools.cache
def _type_hints(cls: type) -> dict[str, Any]:
    """``typing.get_type_hints(cls)``, once per class: the annotations are strings (``from __future__ import
    annotations``) that it evaluates with ``compile`` on every call, and building parameters resolves every
    field (about 3 s of a quick comparison before this cache)."""
    import typing

    return typing.get_type_hints(cls)


def _from_plain(cls: type, tree: Mapping[str, Any]) -> Any:
    kwargs = {}
    hints = {f.name: _resolve(cls, f.name) for f in fields(cls) if f.name not in _META}
    for name, ftype in hints.items():
        v = tree[name]
        if dataclasses.is_dataclass(ftype):
            kwargs[name] = _from_plain(ftype, v) if ftype is not HighIncidence else HighIncidence(**v)
        else:
            kwargs[name] = v
    return cls(**kwargs)


def _param_names() -> tuple[str, ...]:
    def walk(cls: type, prefix: str):
        for f in fields(cls):
            if f.name in (*_META, "high_incidence"):
                continue
            t = _resolve(cls, f.name)
            if dataclasses.is_dataclass(t):
                yield from walk(t, prefix + f.name + ".")
            else:
                yield prefix + f.name

    return tuple(walk(RigParams, ""))


PARAM_NAMES: tuple[str, ...] = _param_names()
"""Dotted names of the flat parameter vector, in kernel order."""

PARAM_INDEX: dict[str, int] = {n: i for i, n in enumerate(PARAM_NAMES)}


def param_batch(
    params: RigParams | list[RigParams] | tuple[RigParams, ...],
    n_envs: int,
    overrides: Mapping[str, Any] | None = None,
) -> np.ndarray:
    """``(n_envs, n_params)`` kernel parameters with per-environment overrides.

    ``params`` is one RigParams (broadcast) or a sequence of ``n_envs``.  ``overrides`` maps dotted
    names to a scalar or an array of ``n_envs`` values in the file's units (degrees where the name
    says so); every resulting environment is validated.
    """
    if isinstance(params, RigParams):
        base = [params] * n_envs
    else:
        base = list(params)
        if len(base) != n_envs:
            raise ParameterError(f"params: got {len(base)} RigParams for n_envs = {n_envs}")
    overrides = dict(overrides or {})
    for name, v in overrides.items():
        if name not in PARAM_INDEX:
            raise ParameterError(f"unknown parameter {name!r} in overrides{did_you_mean(name, PARAM_NAMES)}; valid names: see rig_env.PARAM_NAMES")
        if np.ndim(v) > 1 or (np.ndim(v) == 1 and len(v) != n_envs):
            raise ParameterError(f"override {name!r} must be a scalar or have n_envs = {n_envs} values, got shape {np.shape(v)}")
        overrides[name] = np.broadcast_to(np.asarray(v, dtype=np.float64), (n_envs,))
    if not overrides:
        cache: dict[int, np.ndarray] = {}
        rows = [cache.setdefault(id(p), p.to_vector()) for p in base]
        return np.ascontiguousarray(np.stack(rows))
    rows = []
    for i, p in enumerate(base):
        rows.append(p.replace(**{k: float(a[i]) for k, a in overrides.items()}).to_vector())
    return np.ascontiguousarray(np.stack(rows))
