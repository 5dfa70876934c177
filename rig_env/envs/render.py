"""Frames of a rig environment: the rig from the side and from behind, drawn from its state.

Geometry comes from :func:`rig_env.plotting.rig_outline` (the model's own kinematics,
``joint_space.frames``), so a frame shows exactly what the equations integrate: arm and gimbals,
the Hawk's attitude, the compensator turned with the arm and its four flaps deflected by their
servo positions.  Two views side by side (world axes: x upstream, y starboard, z down; up is up):

| view | plane | shows |
|---|---|---|
| side, from starboard | x-z | rig pitch (heave), model pitch, the wind along -x |
| from behind, looking upstream | y-z | rig roll, rig yaw (sway), model yaw, the compensator X with flap numbers 1-4 and a red needle per flap: the trailing edge's direction of motion, 4 mm per deg |

A two-line overlay gives time, airspeed, the task's tracking error (reference - measured, in the
task's display unit: deg for the angle tasks), the integrator status, the joint angles and the flap
positions.

Speed: one ``Figure`` on an Agg canvas, created on the first frame; the static parts (axes, grid,
labels, wind arrows, support) are drawn once and kept as a bitmap; each frame restores that bitmap,
updates the moving artists in place (``set_xy``, ``set_data``) and draws only those (blitting).  Text
that changes every frame is stamped from glyph bitmaps rendered once (matplotlib would lay out and
rasterise ~250 glyphs a frame, 30 ms).  About 5 ms per 1024 x 448 frame on an idle core of this
machine, 10-15 ms while it is shared (tests/test_render.py measures it).

Environments (:class:`EnvViewer`): ``RigEnv.render()`` is the frame of its batch of one;
``RigVectorEnv.render()`` returns :class:`EnvFrames`, a sequence of ``num_envs`` frames drawn only
when indexed (Gymnasium's ``VectorEnv.render`` contract at the cost of the frames actually used).  A
frame after a step shows each environment's state, except that an environment whose episode ended on
that step shows the ended episode's last state (held before the same-step autoreset).

``render_mode="human"`` shows environment 0 in a pyplot window at ``render_fps`` on every step and
reset (:mod:`rig_env.envs.human_window`: real-time pacing, frames dropped when the display is
slower).  Without an interactive backend (headless, ``MPLBACKEND=Agg``) it warns once and shows
nothing; the environment runs on and ``render()`` returns None.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg
from matplotlib.colors import to_rgb, to_rgba
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.patches import Circle, FancyArrowPatch, Polygon

from rig_env.envs.human_window import HumanWindow
from rig_env.params import JOINTS
from rig_env.physics import layout as L
from rig_env.plotting import RIG_COLORS, VIEWS, rig_outline

RENDER_MODES = ("rgb_array", "human")
NEEDLE_M_PER_DEG = 0.004  # length of a flap's deflection needle in the view from behind
_XLIM = {"side": (-0.72, 1.28), "behind": (-0.78, 0.78)}  # m, world x resp. y
_ZLIM = (-0.64, 0.64)  # m, world z (down), shown inverted
_STATUS = {L.S_OK: "ok", L.S_NONFINITE: "FAILED: non-finite state", L.S_RUNAWAY: "FAILED: runaway rate",
           L.S_CONSTRAINT: "FAILED: constraint residual"}
_RGB_OF_RGBA = np.dtype({"names": ["rgb"], "formats": ["V3"], "offsets": [0], "itemsize": 4})
_DPI = 100.0


class RenderedBatch(Protocol):
    """What a frame needs of a batch of environments (:class:`rig_env.envs.vector_env.RigVectorEnv` is one;
    declared here so that this module does not import the environment that imports it).

    X: (num_envs, N_STATE) physics state; P: (num_envs, N_PARAMS) parameter rows; status: (num_envs,)
    integrator status; t: (num_envs,) or scalar time, s; airspeed: (num_envs,) m/s; keys: the episode
    streams, None before the first reset; task: the task (``tracked`` and ``reference`` give the error).
    """

    num_envs: int
    keys: np.ndarray | None
    t: np.ndarray
    airspeed: np.ndarray
    task: Any

    @property
    def X(self) -> np.ndarray: ...

    @property
    def P(self) -> np.ndarray: ...

    @property
    def status(self) -> np.ndarray: ...


def check_render_mode(render_mode: str | None) -> str | None:
    """render_mode itself if allowed (None, "rgb_array", "human"); ValueError otherwise."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode = {render_mode!r}: allowed values are None, {', '.join(repr(m) for m in RENDER_MODES)}")
    return render_mode


@dataclass(frozen=True)
class Snapshot:
    """What a frame shows of m environments (row-wise copies, so later steps do not change it).

    p: (m, N_PARAMS) kernel parameters; q: (m, 5) joint angles, rad; servo: (m, 7) servo positions,
    rad (rig_env.SERVOS order); t, airspeed, err: (m,) s, m/s, task tracking error (display unit,
    NaN before the first reset); status: (m,) integrator status.
    """

    p: np.ndarray
    q: np.ndarray
    servo: np.ndarray
    t: np.ndarray
    airspeed: np.ndarray
    err: np.ndarray
    status: np.ndarray

    @classmethod
    def of(cls, vec: RenderedBatch, rows: np.ndarray) -> Snapshot:
        X = vec.X
        if vec.keys is None:  # never reset: no task state yet
            err = np.full(rows.size, np.nan)
        else:
            q, qd = X[:, L.X_Q : L.X_Q + 5], X[:, L.X_QD : L.X_QD + 5]
            err = np.asarray(vec.task.tracked(vec.t, q, qd, vec.task.reference(vec.t))[3], dtype=np.float64)[rows]
        return cls(vec.P[rows].copy(), X[rows, L.X_Q : L.X_Q + 5].copy(), X[rows, L.X_SERVO : L.X_SERVO + 7].copy(),
                   np.broadcast_to(vec.t, (vec.num_envs,))[rows].copy(), vec.airspeed[rows].copy(), err, vec.status[rows].copy())

    def replace_rows(self, rows: np.ndarray, other: Snapshot) -> None:
        """Overwrite rows (indices into this snapshot) with other's rows, in place."""
        for name in ("p", "q", "servo", "t", "airspeed", "err", "status"):
            getattr(self, name)[rows] = getattr(other, name)


class _Glyphs:
    """Printable ASCII of a monospace font, drawn once by Agg into pixel cells; text is then stamped
    into frames with numpy (matplotlib lays out and rasterises every glyph of a Text on every draw,
    about 60 us a glyph: 15-30 ms for the overlay).

    cells: (95, h, w) float32 coverage in [0, 1] of characters 32-126; w is the font's advance
    rounded up, so a string is the concatenation of its cells.
    """

    def __init__(self, size_pt: float, dpi: float, weight: str = "normal") -> None:
        prop = FontProperties(family="DejaVu Sans Mono", size=size_pt, weight=weight)
        probe = RendererAgg(100, 100, dpi)
        adv = probe.get_text_width_height_descent("M" * 20, prop, ismath=False)[0]
        _, height, descent = probe.get_text_width_height_descent("M|gj_()", prop, ismath=False)
        w, h = int(np.ceil(adv / 20.0)), int(np.ceil(height)) + 3
        n = 95
        fig = Figure(figsize=(n * w / dpi, h / dpi), dpi=dpi, facecolor="white")
        canvas = FigureCanvasAgg(fig)
        for k in range(n):
            fig.text(k * w / (n * w), (np.ceil(descent) + 1.5) / h, chr(32 + k), fontproperties=prop, color="black", va="baseline", ha="left")
        canvas.draw()
        grey = np.asarray(canvas.buffer_rgba())[:, :, 0].astype(np.float32)
        self.cells = np.ascontiguousarray((1.0 - grey / 255.0).reshape(h, n, w).transpose(1, 0, 2))
        self.w, self.h = w, h

    def stamp(self, img: np.ndarray, text: str, x: float, y: float, color: tuple[int, int, int], anchor: str = "topleft") -> None:
        """Write text into img (H, W, 3) uint8 in place, top-left corner (or centre: anchor="center") at pixel (x, y)."""
        codes = np.frombuffer(text.encode("ascii", "replace"), dtype=np.uint8).astype(np.int64) - 32
        a = self.cells[np.clip(codes, 0, 94)].transpose(1, 0, 2).reshape(self.h, -1)
        if anchor == "center":
            x, y = x - a.shape[1] / 2.0, y - self.h / 2.0
        x0, y0 = int(round(x)), int(round(y))
        H, W = img.shape[:2]
        xs, ys = max(0, -x0), max(0, -y0)
        xe, ye = min(a.shape[1], W - x0), min(self.h, H - y0)
        if xe <= xs or ye <= ys:
            return
        a = a[ys:ye, xs:xe, None]
        region = img[y0 + ys : y0 + ye, x0 + xs : x0 + xe].astype(np.float32)
        region += (np.asarray(color, dtype=np.float32) - region) * a
        img[y0 + ys : y0 + ye, x0 + xs : x0 + xe] = region.astype(np.uint8)


def _rgb_copy(buf: np.ndarray) -> np.ndarray:
    """(H, W, 3) contiguous copy of an (H, W, 4) RGBA buffer (a 3-byte field copy: ~2x a strided slice copy)."""
    rgb = buf.view(_RGB_OF_RGBA)[..., 0]["rgb"]
    return np.ascontiguousarray(rgb).view(np.uint8).reshape(buf.shape[0], buf.shape[1], 3)


class RigRenderer:
    """Draws (H, W, 3) uint8 frames of the rig; one figure, blitted.

    ``RigRenderer(width=1024, height=448, task="")``: pixel size (each at least 320 x 160; multiples
    of 16 keep video encoders from rescaling) and the task name for the overlay.
    ``draw(p, q, servo, t, airspeed, err, status)`` returns a new array for one environment's state
    (units as :class:`Snapshot`, one row).
    """

    def __init__(self, width: int = 1024, height: int = 448, task: str = "") -> None:
        ints = all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in (width, height))  # numpy's too
        if not (ints and width >= 320 and height >= 160):
            raise ValueError(f"width, height = {width!r}, {height!r}: integers of at least 320 and 160 pixels")
        width, height = int(width), int(height)
        self.task, self.width, self.height = task, width, height
        self.fig = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI, facecolor="white")
        self.canvas = FigureCanvasAgg(self.fig)
        self._text = _Glyphs(8.0, _DPI)
        self._small = _Glyphs(6.0, _DPI)
        self._bold = _Glyphs(8.0, _DPI, weight="bold")
        self._layout()
        self._static()
        self._moving()
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)

    # ------------------------------------------------------------------ figure, built once
    def _layout(self) -> None:
        """Two equal-scale axes side by side, sized in pixels (left/gap/right margins, header strip)."""
        W, H = self.width, self.height
        left, gap, right, top, bottom = 52.0, 58.0, 12.0, 66.0, 30.0
        wx = [_XLIM["side"][1] - _XLIM["side"][0], _XLIM["behind"][1] - _XLIM["behind"][0]]
        hz = _ZLIM[1] - _ZLIM[0]
        s = min((W - left - gap - right) / sum(wx), (H - top - bottom) / hz)  # pixels per metre
        x0 = (W - s * sum(wx) - gap - left - right) / 2 + left
        self.ax_side = self.fig.add_axes((x0 / W, bottom / H, s * wx[0] / W, s * hz / H))
        self.ax_behind = self.fig.add_axes(((x0 + s * wx[0] + gap) / W, bottom / H, s * wx[1] / W, s * hz / H))

    def _static(self) -> None:
        for ax, name in ((self.ax_side, "side"), (self.ax_behind, "behind")):
            ax.set_xlim(*_XLIM[name])
            ax.set_ylim(_ZLIM[1], _ZLIM[0])
            ax.set_aspect("equal", adjustable="datalim")
            ax.grid(True, lw=0.4, alpha=0.35)
            ax.tick_params(labelsize=6.5, pad=1.5)
            ax.set_ylabel("z (down), m", fontsize=7, labelpad=1)
            # support below the pivot (schematic)
            ax.plot([0.0, 0.0], [0.05, _ZLIM[1]], color="0.75", lw=5, solid_capstyle="butt", zorder=1)
            ax.text(0.03, _ZLIM[1] - 0.04, "support", fontsize=6.5, color="0.45", va="bottom")
        a, b = self.ax_side, self.ax_behind
        a.set_xlabel("x (upstream), m", fontsize=7, labelpad=1)
        b.set_xlabel("y (starboard), m", fontsize=7, labelpad=1)
        a.set_title("side view, from starboard: rig pitch (heave), model pitch", fontsize=8, pad=3)
        b.set_title("from behind, looking upstream: rig roll, rig yaw (sway)", fontsize=8, pad=3)
        flow = "#3182ce"
        x1, x2, z = _XLIM["side"][1] - 0.04, _XLIM["side"][1] - 0.42, _ZLIM[0] + 0.07
        a.add_patch(FancyArrowPatch((x1, z), (x2, z), arrowstyle="-|>", mutation_scale=12, color=flow, lw=2))
        a.text((x1 + x2) / 2, z + 0.05, "wind V", color=flow, fontsize=7, ha="center", va="top")
        c = (_XLIM["behind"][1] - 0.07, _ZLIM[0] + 0.08)
        b.add_patch(Circle(c, 0.03, fill=False, ec=flow, lw=1.5))
        b.plot([c[0]], [c[1]], "o", ms=3, color=flow)
        b.text(c[0] - 0.05, c[1], "wind V\ntowards you", color=flow, fontsize=6.5, ha="right", va="center")
        self.fig.text(6.0 / self.width, 1.0 - 37.0 / self.height, "blue: Hawk model   orange: compensator panels 1-4   "
                      "red: flaps, needle = trailing-edge motion (4 mm/deg)   o: pivot and model gimbal",
                      fontsize=7, ha="left", va="top", color="0.35")

    def _moving(self) -> None:
        """The artists updated every frame, per view: polygons (depth-sorted), arm, gimbals, needles."""
        hawk = dict(fc=to_rgba(RIG_COLORS["hawk"], 0.35), ec=RIG_COLORS["hawk"], lw=0.8)
        comp = dict(fc=to_rgba(RIG_COLORS["comp"], 0.45), ec=RIG_COLORS["comp"], lw=0.8)
        flap = dict(fc=to_rgba(RIG_COLORS["flap"], 0.9), ec="#9b2c2c", lw=0.9)
        self.views = []
        for ax, (h, v, out) in ((self.ax_side, VIEWS["side"]), (self.ax_behind, VIEWS["behind"])):
            polys = [Polygon(np.zeros((3, 2)), closed=True, **hawk) for _ in range(5)]
            polys += [Polygon(np.zeros((4, 2)), closed=True, **comp) for _ in range(4)]
            polys += [Polygon(np.zeros((4, 2)), closed=True, **flap) for _ in range(4)]
            (arm,) = ax.plot([], [], color=RIG_COLORS["arm"], lw=4, solid_capstyle="round")
            # seen from behind the pivot is nearer than the Hawk: a ring, so the model shows through
            pivot_fc = "none" if ax is self.ax_behind else "white"
            gimbals = [Circle((0.0, 0.0), 0.032, fc=pivot_fc, ec="k", lw=2.0), Circle((0.0, 0.0), 0.028, fc="white", ec="k", lw=2.0)]
            needles = [FancyArrowPatch((0, 0), (0, 0), arrowstyle="-|>", mutation_scale=8, color="#c53030", lw=1.6)
                       for _ in range(4)] if ax is self.ax_behind else []
            for pa in polys + gimbals + needles:
                ax.add_patch(pa)
            for a in polys + gimbals + needles + [arm]:
                a.set_animated(True)
            self.views.append({"ax": ax, "h": h, "v": v, "out": out, "polys": polys, "arm": arm, "gimbals": gimbals, "needles": needles})

    # ------------------------------------------------------------------ one frame
    def draw(self, p: np.ndarray, q: np.ndarray, servo: np.ndarray, t: float, airspeed: float, err: float, status: int) -> np.ndarray:
        """(height, width, 3) uint8 frame of one environment's state (units as :class:`Snapshot`)."""
        flaps_deg = np.degrees(servo[:4])
        o = rig_outline(p, q, flaps_deg)
        parts = [*o.hawk, *o.panels, *o.flaps]
        centroids = np.array([pts.mean(axis=0) for pts in parts] + [o.arm.mean(axis=0)])
        self.canvas.restore_region(self._background)
        for vw in self.views:
            ax, h, v = vw["ax"], vw["h"], vw["v"]
            for pa, pts in zip(vw["polys"], parts):
                pa.set_xy(pts[:, (h, v)])
            vw["arm"].set_data(o.arm[:, h], o.arm[:, v])
            vw["gimbals"][1].set_center((o.G[h], o.G[v]))
            items = vw["polys"] + [vw["arm"]]
            for k in np.argsort(centroids @ vw["out"], kind="stable"):  # painter's order: farthest first
                ax.draw_artist(items[k])
            for g in vw["gimbals"]:
                ax.draw_artist(g)
            for nd, f, base, n in zip(vw["needles"], flaps_deg, o.flap_mid, o.normals):
                if abs(f) > 0.25:
                    end = base - NEEDLE_M_PER_DEG * f * n
                    nd.set_positions((base[h], base[v]), (end[h], end[v]))
                    ax.draw_artist(nd)
        img = _rgb_copy(np.asarray(self.canvas.buffer_rgba()))
        self._labels(img, o)
        self._overlay(img, q, flaps_deg, t, airspeed, err, status)
        return img

    def _pixel(self, ax: Any, xy: tuple[float, float]) -> tuple[float, float]:
        """Data coordinates of ax -> (column, row) of the frame."""
        x, y = ax.transData.transform(xy)
        return float(x), float(self.height - y)

    def _labels(self, img: np.ndarray, o: Any) -> None:
        comp = tuple(int(255 * c) for c in to_rgb(RIG_COLORS["comp"]))
        vb = self.views[1]
        for i in range(4):
            x, y = self._pixel(self.ax_behind, (o.tips[i, vb["h"]], o.tips[i, vb["v"]]))
            self._bold.stamp(img, str(i + 1), x, y, comp, anchor="center")
        for vw, (dx, dy) in zip(self.views, ((0.0, -20.0), (48.0, -16.0))):
            x, y = self._pixel(vw["ax"], (o.G[vw["h"]], o.G[vw["v"]]))
            self._small.stamp(img, "model gimbal", x + dx, y + dy, (77, 77, 77), anchor="center")

    def _overlay(self, img: np.ndarray, q: np.ndarray, flaps_deg: np.ndarray, t: float, airspeed: float, err: float, status: int) -> None:
        e = "   -  " if not np.isfinite(err) else f"{err:+6.1f}"
        st = _STATUS.get(int(status), f"FAILED ({int(status)})")
        a = np.degrees(q)
        joints = "  ".join(f"{j} {a[k]:+6.1f}" for k, j in enumerate(JOINTS))
        fl = " ".join(f"{f:+5.1f}" for f in flaps_deg)
        self._text.stamp(img, f"t = {t:6.2f} s   V = {airspeed:4.1f} m/s   task {self.task}: ref - meas = {e} deg   status {st}",
                         6.0, 3.0, (0, 0, 0))
        self._text.stamp(img, f"{joints} deg   flaps 1-4 {fl} deg", 6.0, 4.0 + self._text.h, (0, 0, 0))


class EnvFrames(Sequence):
    """The frames of every environment of a batch at one instant, drawn only when indexed.

    ``len()`` is ``num_envs`` (Gymnasium's ``VectorEnv.render`` contract); ``frames[i]`` draws
    environment i from the snapshot taken at ``render()`` (about 5-10 ms each) and caches it.  So
    ``gymnasium.wrappers.vector.RecordVideo(..., record_first_only=True)`` costs one frame per step;
    ``np.array(frames)`` draws them all.
    """

    def __init__(self, renderer: RigRenderer, snap: Snapshot) -> None:
        self._r, self._s, self._cache = renderer, snap, {}

    def __len__(self) -> int:
        return self._s.q.shape[0]

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        k = int(i) + (len(self) if int(i) < 0 else 0)
        if not 0 <= k < len(self):
            raise IndexError(f"environment {i} out of range [0, {len(self)})")
        if k not in self._cache:
            s = self._s
            self._cache[k] = self._r.draw(s.p[k], s.q[k], s.servo[k], float(s.t[k]), float(s.airspeed[k]), float(s.err[k]), int(s.status[k]))
        return self._cache[k]


class EnvViewer:
    """Rendering of a batch of environments (:class:`RenderedBatch`, e.g. a ``RigVectorEnv``): frames, the
    episode's last state, the human window.

    A frame taken after a step shows each environment's current state, except that an environment
    whose episode ended on that step shows the ended episode's last state (held before the same-step
    autoreset; the next episode appears from the next step or reset on).
    """

    def __init__(self, render_mode: str, fps: float, task: str) -> None:
        self.mode, self.fps, self.task = check_render_mode(render_mode), float(fps), task
        self._renderer: RigRenderer | None = None
        self._held: tuple[np.ndarray, Snapshot] | None = None
        self._window: HumanWindow | None = None

    @property
    def renderer(self) -> RigRenderer:
        if self._renderer is None:
            self._renderer = RigRenderer(task=self.task)
        return self._renderer

    def clear_held(self) -> None:
        self._held = None

    def hold(self, vec: RenderedBatch, idx: np.ndarray) -> None:
        """Keep the last state of environments idx, whose episodes end now (before their reset)."""
        self._held = (np.asarray(idx).copy(), Snapshot.of(vec, np.asarray(idx)))

    def snapshot(self, vec: RenderedBatch, rows: np.ndarray) -> Snapshot:
        snap = Snapshot.of(vec, rows)
        if self._held is not None:
            idx, held = self._held
            where = {int(e): k for k, e in enumerate(idx)}
            mine = [(r, where[int(e)]) for r, e in enumerate(rows) if int(e) in where]
            if mine:
                r, k = np.array(mine).T
                snap.replace_rows(r, Snapshot(*(getattr(held, f)[k] for f in ("p", "q", "servo", "t", "airspeed", "err", "status"))))
        return snap

    def frame(self, vec: RenderedBatch, i: int = 0) -> np.ndarray:
        """(H, W, 3) uint8 frame of environment i."""
        return EnvFrames(self.renderer, self.snapshot(vec, np.array([i])))[0]

    def frames(self, vec: RenderedBatch) -> EnvFrames:
        return EnvFrames(self.renderer, self.snapshot(vec, np.arange(vec.num_envs)))

    def show(self, vec: RenderedBatch, i: int = 0) -> None:
        """Human mode: environment i in a pyplot window at ``fps`` (:mod:`rig_env.envs.human_window`)."""
        if self._window is None:
            self._window = HumanWindow(self.fps)
        if self._window.due():
            self._window.show(self.frame(vec, i))

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
