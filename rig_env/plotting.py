"""Pictures of the rig and of simulated trajectories (matplotlib, Agg canvas: no display needed).

The rig is drawn from the model's own kinematics, :func:`rig_env.physics.joint_space.frames`, with
the kernel parameter vector (``RigParams.to_vector()``), so the picture shows exactly the geometry
the equations use: arm rotation A_s, aircraft rotation A_a, model gimbal G = A_s [l_f 0 0]^T, the
bodies' c.g. positions and the compensator reference point.  World axes: x upstream, y starboard,
z down, origin at the pivot.  Two views:

* side view, x-z plane, seen from starboard (y towards the viewer), z axis inverted so up is up;
* view from behind, y-z plane, looking upstream along +x (x away from the viewer), up is up.

The Hawk is a schematic outline (fuselage, wing, tailplane, fin; 1/16 scale proportions), rotated
by A_a about the model gimbal.  The compensator is drawn as the aerodynamic model sees it: four
panels in an X at roll positions 135, 45, -45, -135 deg (flaps 1-4) about the arm axis, spanning
arm_radius to span/2, chord S/span with the quarter chord at the aerodynamic reference point, a 25 %
chord flap deflected by the given angle (positive: trailing edge towards -n, lift towards +n with
n = x_arm x e_r, a positive rolling moment).

Nothing here imports pyplot: figures are ``matplotlib.figure.Figure`` objects on an Agg canvas, so
the module works headless and never changes the user's backend.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Circle, FancyArrowPatch, Polygon

from rig_env.params import JOINTS, SERVOS, RigParams
from rig_env.physics import layout as L
from rig_env.physics.aero import PANEL_GAMMA
from rig_env.physics.joint_space import frames

# ---------------------------------------------------------------------- schematic Hawk (body axes)
# Metres, aircraft axes from the model gimbal: x forward, y starboard, z down.  An outline at 1/16
# scale (span 0.612 m, length about 0.70 m); for the picture only, not used by the physics.
_HAWK_FUSELAGE = [  # side profile, y = 0
    (0.33, 0.000), (0.30, -0.020), (0.20, -0.035), (0.12, -0.060), (0.04, -0.055), (0.00, -0.035),
    (-0.30, -0.025), (-0.37, -0.020), (-0.37, 0.005), (-0.20, 0.025), (0.10, 0.035), (0.28, 0.020),
]
_HAWK_WING = [
    (0.09, -0.03, 0.02), (-0.06, -0.306, 0.012), (-0.13, -0.306, 0.012), (-0.10, -0.03, 0.02),
    (-0.10, 0.03, 0.02), (-0.13, 0.306, 0.012), (-0.06, 0.306, 0.012), (0.09, 0.03, 0.02),
]
_HAWK_TAIL = [
    (-0.26, -0.02, -0.005), (-0.33, -0.13, 0.01), (-0.37, -0.13, 0.01), (-0.35, -0.02, -0.005),
    (-0.35, 0.02, -0.005), (-0.37, 0.13, 0.01), (-0.33, 0.13, 0.01), (-0.26, 0.02, -0.005),
]
_HAWK_FIN = [(-0.22, 0.0, -0.03), (-0.33, 0.0, -0.15), (-0.38, 0.0, -0.15), (-0.37, 0.0, -0.025)]
_HAWK_SECTION = [(0.0, 0.035 * math.cos(t), -0.01 + 0.035 * math.sin(t)) for t in np.linspace(0, 2 * math.pi, 25)]
# fuselage profile, fuselage section, wing, tailplane, fin: RigOutline.hawk order
_HAWK_PARTS = tuple(
    np.array(pts, dtype=np.float64)
    for pts in ([(x, 0.0, z) for x, z in _HAWK_FUSELAGE], _HAWK_SECTION, _HAWK_WING, _HAWK_TAIL, _HAWK_FIN)
)
_GAMMA = np.array(PANEL_GAMMA)

_FLAP_CHORD = 0.25  # flap chord / panel chord (Sec. III: full-length 25 % chord flaps)
# colours of the parts, shared with the environment renderer (rig_env.envs.render)
RIG_COLORS = {"arm": "0.35", "hawk": "#2b6cb0", "comp": "#c05621", "flap": "#e53e3e", "world": "k", "frame_s": "#2f855a", "frame_a": "#6b46c1"}


def _rot(t: Sequence[float]) -> np.ndarray:
    return np.asarray(t, dtype=np.float64).reshape(3, 3)


class _View:
    """One orthographic view: which world axes are horizontal and vertical, and the viewer's side."""

    def __init__(self, ax: Axes, h: int, v: int, towards_viewer: np.ndarray, name: str):
        self.ax, self.h, self.v, self.out, self.name = ax, h, v, towards_viewer, name

    def xy(self, pts: np.ndarray) -> np.ndarray:
        pts = np.atleast_2d(pts)
        return np.stack([pts[:, self.h], pts[:, self.v]], axis=1)

    def poly(self, pts: np.ndarray, **kw) -> None:
        self.ax.add_patch(Polygon(self.xy(pts), closed=True, **kw))

    def line(self, pts: np.ndarray, **kw) -> None:
        p = self.xy(pts)
        self.ax.plot(p[:, 0], p[:, 1], **kw)

    def text(self, pt: np.ndarray, s: str, **kw) -> None:
        p = self.xy(pt)[0]
        self.ax.text(p[0], p[1], s, **kw)

    def arrow(self, a: np.ndarray, b: np.ndarray, color: str, lw: float = 1.5, label: str | None = None, z: int = 6) -> None:
        """A 3-D arrow projected; one pointing (nearly) along the line of sight becomes a dot or cross."""
        d = b - a
        n = np.linalg.norm(d)
        pa, pb = self.xy(a)[0], self.xy(b)[0]
        ax = self.ax
        if np.linalg.norm(pb - pa) < 0.3 * n:
            towards = float(np.dot(d, self.out)) > 0.0
            r = 0.02
            ax.add_patch(Circle(pa, r, fc="white", ec=color, lw=lw, zorder=z + 3))
            if towards:  # point of the arrow coming at the viewer
                ax.plot([pa[0]], [pa[1]], "o", ms=2.5, color=color, zorder=z + 3)
            else:  # tail feathers going away
                k = r * 0.7
                ax.plot([pa[0] - k, pa[0] + k], [pa[1] - k, pa[1] + k], color=color, lw=lw, zorder=z + 3)
                ax.plot([pa[0] - k, pa[0] + k], [pa[1] + k, pa[1] - k], color=color, lw=lw, zorder=z + 3)
            tip = pa + np.array([r * 1.9, -r * 1.9])
        else:
            ax.add_patch(FancyArrowPatch(pa, pb, arrowstyle="-|>", mutation_scale=10, color=color, lw=lw, zorder=z))
            tip = pb + 0.12 * (pb - pa)
        if label:
            ax.text(tip[0], tip[1], label, color=color, fontsize=8, ha="center", va="center", zorder=z)


# the two views: (horizontal world axis, vertical world axis, unit vector towards the viewer)
VIEWS = {
    "side": (0, 2, np.array([0.0, 1.0, 0.0])),  # x-z plane seen from starboard
    "behind": (1, 2, np.array([-1.0, 0.0, 0.0])),  # y-z plane seen from behind, looking upstream
}


def _side_view(ax: Axes) -> _View:
    return _View(ax, *VIEWS["side"], "side")


def _behind_view(ax: Axes) -> _View:
    return _View(ax, *VIEWS["behind"], "behind")


def _triad(view: _View, origin: np.ndarray, A: np.ndarray, length: float, color: str, sub: str) -> None:
    for k, name in enumerate("xyz"):
        view.arrow(origin, origin + length * A[:, k], color, lw=1.3, label=f"${name}_{{{sub}}}$" if sub else f"${name}$")


def _rotation_mark(view: _View, centre: np.ndarray, axis: np.ndarray, radius: float, label: str, color: str) -> None:
    """Curved arrow for the positive sense of a joint whose axis is (nearly) along the line of sight.

    Positive rotation about an axis coming at the viewer is anticlockwise as seen; the arc is drawn in
    world coordinates, so the axis inversion of the plot is taken care of automatically.
    """
    a = axis / np.linalg.norm(axis)
    if abs(float(np.dot(a, view.out))) < 0.7:
        return
    # two in-plane unit vectors of the view (world), e1 x e2 = a
    e1 = np.zeros(3)
    e1[view.h] = 1.0
    e1 -= np.dot(e1, a) * a
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    angles = np.radians(np.linspace(-150.0, -30.0, 24))
    arc = np.array([centre + radius * (math.cos(t) * e1 + math.sin(t) * e2) for t in angles])
    p = view.xy(arc)
    view.ax.plot(p[:-1, 0], p[:-1, 1], color=color, lw=1.2, zorder=7)
    view.ax.add_patch(FancyArrowPatch(p[-3], p[-1], arrowstyle="-|>", mutation_scale=10, color=color, lw=1.2, zorder=7))
    t0 = math.radians(-165.0)  # label just before the start of the arc
    mid = view.xy(centre + 1.3 * radius * (math.cos(t0) * e1 + math.sin(t0) * e2))[0]
    view.ax.text(mid[0], mid[1], label, color=color, fontsize=8, ha="center", va="center", zorder=7)


def _flap_list(flaps_deg: Sequence[float] | None) -> np.ndarray:
    if flaps_deg is None:
        return np.zeros(4)
    f = np.asarray(flaps_deg, dtype=np.float64).ravel()
    if f.shape[0] not in (4, len(SERVOS)):
        raise ValueError(f"flaps_deg: expected 4 compensator flaps or {len(SERVOS)} servos (rig_env.SERVOS order), got {f.shape[0]}")
    return f[:4]


class RigOutline(NamedTuple):
    """World-frame points of the rig's drawing (m, from the pivot; x upstream, y starboard, z down).

    | field | shape | what |
    |---|---|---|
    | As, Aa | (3, 3) | arm and aircraft rotations, body to world (``joint_space.frames``) |
    | axes | (5, 3) | joint axes, world, rig_env.JOINTS order |
    | G, rho, r_s, r_r, r_ref | (3,) | model gimbal; gimbal to Hawk c.g.; arm c.g.; compensator c.g.; compensator aero point |
    | arm | (2, 3) | arm centre line, from behind the compensator to the model gimbal |
    | hawk | 5 x (k, 3) | Hawk outline: fuselage profile, fuselage section, wing, tailplane, fin |
    | panels, flaps | (4, 4, 3) | compensator panels 1-4 (fixed part) and their flaps (deflected), quadrilaterals |
    | tips | (4, 3) | just beyond each panel tip (where its number goes) |
    | normals, flap_mid | (4, 3) | panel normal n (world) and the flap's mid-span hinge point, for deflection marks |
    """

    As: np.ndarray
    Aa: np.ndarray
    axes: np.ndarray
    G: np.ndarray
    rho: np.ndarray
    r_s: np.ndarray
    r_r: np.ndarray
    r_ref: np.ndarray
    arm: np.ndarray
    hawk: tuple[np.ndarray, ...]
    panels: np.ndarray
    flaps: np.ndarray
    tips: np.ndarray
    normals: np.ndarray
    flap_mid: np.ndarray


def rig_outline(p: np.ndarray, q: Sequence[float] | None, flaps_deg: Sequence[float] | None = None) -> RigOutline:
    """Every point of the rig picture at joint angles q, from the model's kinematics (``joint_space.frames``).

    p: (N_PARAMS,) kernel parameter vector (``RigParams.to_vector()``, or a row of an environment's
    parameter batch); q: (5,) joint angles, rad, rig_env.JOINTS order (None: all zero); flaps_deg:
    the four compensator flap deflections, deg (or the 7 servo positions in rig_env.SERVOS order).
    The one geometry routine of both :func:`draw_rig` and the environment renderer
    (:mod:`rig_env.envs.render`).
    """
    qv = np.zeros(5) if q is None else np.asarray(q, dtype=np.float64).ravel()
    if qv.shape != (5,):
        raise ValueError(f"q: expected 5 joint angles (rad, {list(JOINTS)}), got shape {np.shape(q)}")
    flaps = _flap_list(flaps_deg)
    As_t, Aa_t, axes_t, G_t, rho_t, r_s_t, r_r_t, r_ref_t = frames(qv, p)
    As, Aa = _rot(As_t), _rot(Aa_t)
    G = np.asarray(G_t)
    chord = p[L.P_COMP_AERO_S] / p[L.P_COMP_AERO_SPAN]
    x_aero, r0, r1 = p[L.P_GEOMETRY_COMP_AERO_X], p[L.P_GEOMETRY_ARM_RADIUS], p[L.P_COMP_AERO_SPAN] / 2

    # compensator panels in arm axes: span direction e_r, normal n = x_s x e_r; a positive flap moves
    # its trailing edge towards -n (docs/MODEL.md, "Compensator panels and mixing")
    er = np.stack([np.zeros(4), np.cos(_GAMMA), np.sin(_GAMMA)], axis=1)  # (4, 3)
    n = np.stack([np.zeros(4), -er[:, 2], er[:, 1]], axis=1)
    x_le = x_aero + 0.25 * chord
    x_hinge = x_aero - (0.75 - _FLAP_CHORD) * chord
    c_f = _FLAP_CHORD * chord
    d = np.radians(flaps)[:, None]
    ex = np.array([1.0, 0.0, 0.0])
    te = (x_hinge - c_f * np.cos(d)) * ex - c_f * np.sin(d) * n  # (4, 3) trailing edge offset
    hinge = x_hinge * ex
    panels = np.stack([x_le * ex + r0 * er, x_le * ex + r1 * er, hinge + r1 * er, hinge + r0 * er], axis=1)
    flap_q = np.stack([hinge + r0 * er, hinge + r1 * er, te + r1 * er, te + r0 * er], axis=1)
    tips = x_aero * ex + (r1 + 0.035) * er
    flap_mid = (r0 + r1) / 2 * er + (x_hinge - c_f) * ex

    def hawk(pts: np.ndarray) -> np.ndarray:  # aircraft axes at the model gimbal -> world
        return G + pts @ Aa.T

    arm_back = As @ np.array([x_aero - 0.75 * chord - 0.06, 0.0, 0.0])
    return RigOutline(
        As=As, Aa=Aa, axes=np.asarray(axes_t), G=G, rho=np.asarray(rho_t), r_s=np.asarray(r_s_t),
        r_r=np.asarray(r_r_t), r_ref=np.asarray(r_ref_t), arm=np.stack([arm_back, G]),
        hawk=tuple(hawk(h) for h in _HAWK_PARTS),
        panels=panels @ As.T, flaps=flap_q @ As.T, tips=tips @ As.T, normals=n @ As.T, flap_mid=flap_mid @ As.T,
    )


def draw_rig(
    params: RigParams,
    q: Sequence[float] | None,
    ax_side: Axes,
    ax_behind: Axes,
    flaps_deg: Sequence[float] | None = None,
    *,
    labels: bool = True,
) -> None:
    """Draw the rig at joint angles q on a side view and a view from behind.

    params: the rig; q: (5,) joint angles, rad, rig_env.JOINTS order (None: all zero); ax_side,
    ax_behind: matplotlib axes for the x-z and y-z views; flaps_deg: the four compensator flap
    deflections (deg, flaps 1-4, or the 7 servo positions in rig_env.SERVOS order); labels: joint,
    frame and part names.
    """
    flaps = _flap_list(flaps_deg)
    o = rig_outline(params.to_vector(), q, flaps)
    As, Aa, G, rho, r_s, r_r, r_ref = o.As, o.Aa, o.G, o.rho, o.r_s, o.r_r, o.r_ref
    axes = list(o.axes)
    fus, sec, wing, tail, fin = o.hawk
    views = [_side_view(ax_side), _behind_view(ax_behind)]

    for v in views:
        ax = v.ax
        behind = v.name == "behind"
        # depth order: in the view from behind the compensator is nearest the viewer
        z_hawk, z_comp = (3, 5) if behind else (4, 3)
        v.line(o.arm, color=RIG_COLORS["arm"], lw=4, solid_capstyle="round", zorder=4)
        for pts in (fus, wing, tail, fin):
            v.poly(pts, fc=to_rgba(RIG_COLORS["hawk"], 0.3), ec=RIG_COLORS["hawk"], lw=0.8, zorder=z_hawk)
        if behind:
            v.poly(sec, fc=to_rgba(RIG_COLORS["hawk"], 0.3), ec=RIG_COLORS["hawk"], lw=0.8, zorder=z_hawk)
        for i in range(4):
            v.poly(o.panels[i], fc=to_rgba(RIG_COLORS["comp"], 0.4), ec=RIG_COLORS["comp"], lw=0.8, zorder=z_comp)
            v.poly(o.flaps[i], fc=to_rgba(RIG_COLORS["flap"], 0.55), ec=RIG_COLORS["flap"], lw=0.8, zorder=z_comp)
        # gimbals and c.g. markers
        for centre, r in ((np.zeros(3), 0.034), (G, 0.03)):
            ax.add_patch(Circle(v.xy(centre)[0], r, fc="white", ec="k", lw=2.0, zorder=8))
        for pt, col in ((G + rho, RIG_COLORS["hawk"]), (r_s, RIG_COLORS["arm"]), (r_r, RIG_COLORS["comp"])):
            c = v.xy(pt)[0]
            ax.plot([c[0]], [c[1]], marker="o", ms=6, mfc="white", mec=col, mew=1.5, zorder=9)
            ax.plot([c[0]], [c[1]], marker="o", ms=2, color=col, zorder=10)
        # frames: arm triad at the pivot, aircraft triad at the model gimbal
        _triad(v, np.zeros(3), As, 0.16, RIG_COLORS["frame_s"], "s")
        if np.linalg.norm(v.xy(G)[0]) > 0.08:  # seen along the arm, frame a would hide frame s
            _triad(v, G, Aa, 0.14, RIG_COLORS["frame_a"], "a")
        if labels:
            # flap numbers and deflection marks: the trailing edge moves towards -n for a positive flap
            for i in range(4):
                tip = o.tips[i] + (np.array([0.035 * np.sign(o.tips[i][1]), 0, 0]) if not behind else 0.0)
                v.text(tip, str(i + 1), color=RIG_COLORS["comp"], fontsize=9, fontweight="bold", ha="center", va="center", zorder=9)
                if behind and abs(flaps[i]) > 0.05:
                    n_w, base = o.normals[i], o.flap_mid[i]
                    end = base - 0.004 * flaps[i] * n_w
                    pa, pb = v.xy(base)[0], v.xy(end)[0]
                    ax.add_patch(FancyArrowPatch(pa, pb, arrowstyle="-|>", mutation_scale=8, color=RIG_COLORS["flap"], lw=1.5, zorder=9))
                    ax.text(pb[0], pb[1], f"{flaps[i]:+.0f}°", color=RIG_COLORS["flap"], fontsize=7, ha="center", va="center", zorder=9,
                            bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7))
            _rotation_mark(v, np.zeros(3), axes[L.J_RIG_PITCH], 0.09, r"$\theta$", "k")
            _rotation_mark(v, np.zeros(3), axes[L.J_RIG_ROLL], 0.09, r"$\phi$", "k")
            _rotation_mark(v, G, axes[L.J_MODEL_PITCH], 0.085, r"$\theta_a$", "k")
    if labels:
        vs, vb = views
        s = vs.xy(np.zeros(3))[0]
        vs.ax.annotate("pivot, 3-DOF gimbal\nrig yaw $\\psi$ ($z$), pitch $\\theta$, roll $\\phi$", s, xytext=(s[0] - 0.05, s[1] + 0.36),
                       fontsize=8, ha="center", arrowprops=dict(arrowstyle="-", color="0.4", lw=0.8), zorder=10)
        gg = vs.xy(G)[0]
        vs.ax.annotate("model gimbal, 2-DOF\nmodel yaw $\\psi_a$ ($z_s$), pitch $\\theta_a$ ($y_a$)", gg, xytext=(gg[0] - 0.05, gg[1] + 0.36),
                       fontsize=8, ha="center", arrowprops=dict(arrowstyle="-", color="0.4", lw=0.8), zorder=10)
        cc = vs.xy(r_ref)[0]
        vs.ax.annotate("compensator\n(4 flapped panels)", cc, xytext=(cc[0] - 0.22, cc[1] - 0.42), fontsize=8, ha="center",
                       arrowprops=dict(arrowstyle="-", color="0.4", lw=0.8), zorder=10)
        vs.ax.annotate("Hawk", vs.xy(G + Aa @ np.array([-0.3, 0, -0.1]))[0], xytext=(gg[0] - 0.3, gg[1] - 0.3), fontsize=8,
                       ha="center", arrowprops=dict(arrowstyle="-", color="0.4", lw=0.8), zorder=10)
        ma = vs.xy(0.45 * G)[0]
        vs.ax.text(ma[0], ma[1] - 0.025, "arm", fontsize=8, color=RIG_COLORS["arm"], ha="center", va="bottom", zorder=10)


def _decorate(ax: Axes, name: str, lim: tuple[float, float, float, float], flow: str) -> None:
    ax.set_xlim(lim[0], lim[1])
    ax.set_ylim(lim[3], lim[2])  # inverted: world z down, so up is up
    ax.set_aspect("equal")
    ax.grid(True, lw=0.4, alpha=0.4)
    ax.tick_params(labelsize=7)
    if name == "side":
        ax.set_xlabel("world $x$ (upstream), m", fontsize=8)
        ax.set_ylabel("world $z$ (down), m", fontsize=8)
        x0, x1, z0 = lim[1] - 0.05, lim[1] - 0.45, lim[2] + 0.08
        ax.add_patch(FancyArrowPatch((x0, z0), (x1, z0), arrowstyle="-|>", mutation_scale=14, color="#3182ce", lw=2))
        ax.text(0.5 * (x0 + x1), z0 + 0.05, "tunnel flow $V$", color="#3182ce", fontsize=8, ha="center")
    else:
        ax.set_xlabel("world $y$ (starboard), m", fontsize=8)
        ax.set_ylabel("world $z$ (down), m", fontsize=8)
        c = (lim[1] - 0.08, lim[2] + 0.08)
        ax.add_patch(Circle(c, 0.025, fill=False, ec="#3182ce", lw=1.5))
        ax.plot([c[0]], [c[1]], "o", ms=3, color="#3182ce")
        ax.text(c[0] - 0.05, c[1], "flow $V$\n(towards\nviewer)", color="#3182ce", fontsize=7, ha="right", va="center")
    ax.set_title(flow, fontsize=9)


def _world_triad(ax: Axes, name: str, origin: tuple[float, float]) -> None:
    v = _side_view(ax) if name == "side" else _behind_view(ax)
    o = np.zeros(3)
    o[v.h], o[v.v] = origin
    _triad(v, o, np.eye(3), 0.12, RIG_COLORS["world"], "")
    v.text(o + np.array([0.0, 0.0, -0.04]), "world", fontsize=7, ha="left", va="bottom")


def rig_figure(params: RigParams, q: Sequence[float] | None = None, path: str | Path | None = None,
               flaps_deg: Sequence[float] | None = None) -> Figure:
    """The rig picture: side view and view from behind, at joint angles q (rad, JOINTS order).

    q None draws two rows: every joint at zero (the reference position of the equations) and an
    example pose with every joint angle positive (rig roll 30, rig pitch 12, rig yaw 10, model pitch
    15, model yaw 10 deg) and the compensator aileron at +20 deg, to show the sign conventions.
    path: also save it there (PNG, 150 dpi).  Returns the Figure (Agg canvas).
    """
    if q is None:
        rows = [
            (np.zeros(5), np.zeros(4), "all joints at zero"),
            (np.radians([30.0, 12.0, 10.0, 15.0, 10.0]), np.full(4, 20.0),
             "positive angles: rig roll 30, pitch 12, yaw 10; model pitch 15, yaw 10 deg; comp. aileron +20 deg"),
        ]
    else:
        qv = np.asarray(q, dtype=np.float64).ravel()
        desc = ", ".join(f"{j} {math.degrees(a):.0f}" for j, a in zip(JOINTS, qv))
        rows = [(qv, _flap_list(flaps_deg), f"q (deg): {desc}")]
    fig = Figure(figsize=(13.0, 5.6 * len(rows)), layout="constrained")
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(len(rows), 2, width_ratios=[2.1, 1.0])
    for r, (qv, fl, desc) in enumerate(rows):
        a_side = fig.add_subplot(gs[r, 0])
        a_back = fig.add_subplot(gs[r, 1])
        draw_rig(params, qv, a_side, a_back, fl)
        _decorate(a_side, "side", (-0.75, 1.35, -0.6, 0.6), f"side view from starboard ($y$ towards the viewer)\n{desc}")
        _decorate(a_back, "behind", (-0.55, 0.55, -0.6, 0.6), "from behind, looking upstream\n($x$ into the page)")
        _world_triad(a_side, "side", (-0.6, 0.42))
        _world_triad(a_back, "behind", (-0.42, 0.42))
    fig.suptitle("Bristol 5-DOF manoeuvre rig as modelled: bodies, joints and frames "
                 "(green: arm frame $s$ at the pivot; purple: aircraft frame $a$ at the model gimbal; o: c.g.)", fontsize=10)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=150)
    return fig


def plot_trajectory(result, path: str | Path | None, title: str = "", *, env: int = 0) -> Figure:
    """Joint angles (deg) and rates (deg/s) of the free joints, surface positions and energy.

    result: a rig_env.SimResult (a batched one plots environment ``env``); path: PNG to write (None:
    only return the figure); title: figure title.
    """
    q, qd, fl, en = result.q, result.qd, result.flaps, result.energy
    if np.ndim(q) == 3:
        q, qd, fl, en = q[env], qd[env], fl[env], en[env]
    t = result.t
    names = result.free_dofs
    n = len(names)
    fig = Figure(figsize=(11.0, 2.3 * (n + 1) + 0.6), layout="constrained")
    FigureCanvasAgg(fig)
    axs = fig.subplots(n + 1, 2, sharex=True, squeeze=False)
    for k, name in enumerate(names):
        axs[k, 0].plot(t, np.degrees(q[:, k]), color="C0", lw=1.0)
        axs[k, 0].set_ylabel(f"{name}\nangle, deg", fontsize=8)
        axs[k, 1].plot(t, np.degrees(qd[:, k]), color="C1", lw=1.0)
        axs[k, 1].set_ylabel(f"{name}\nrate, deg/s", fontsize=8)
    a_fl, a_en = axs[n, 0], axs[n, 1]
    for k, s in enumerate(SERVOS):
        if k < 4 or np.any(np.abs(fl[:, k]) > 1e-9):
            a_fl.plot(t, fl[:, k], lw=1.0, ls="-" if k < 4 else "--", label=s)
    a_fl.set_ylabel("surface position, deg", fontsize=8)
    a_fl.legend(fontsize=7, ncol=4, loc="lower right")
    a_en.plot(t, en, color="C2", lw=1.0)
    a_en.set_ylabel("kinetic + gravitational\nenergy, J", fontsize=8)
    for ax in axs.ravel():
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.tick_params(labelsize=7)
    for ax in axs[n]:
        ax.set_xlabel("time, s", fontsize=8)
    status = ", ".join(result.status_text())
    fig.suptitle(f"{title}  [{result.formulation}, physics {1e3 * result.physics_dt:.2f} ms, control "
                 f"{1 / result.control_dt:.0f} Hz, status: {status}]", fontsize=10)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
    return fig
