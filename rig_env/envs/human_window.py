"""``HumanWindow``: rendered frames shown live in a pyplot window, in real time (render_mode="human").

The only module of the environments that imports pyplot, and only when the first frame is shown.

Pacing: frame k is due at ``t0 + k / fps`` (absolute deadlines, no drift); the window waits for the
deadline while running the GUI event loop.  A frame more than one period late is dropped (not drawn),
so a display slower than ``fps`` shows fewer frames of a simulation that still runs in real time; a
caller that stalls for more than 0.25 s (a pause, a training update) restarts the clock.

Display: the frame is written 1:1 (centred; cropped or framed in white if the window has another
size) straight into the window canvas's Agg buffer and blitted (TkAgg, QtAgg, GTK*Agg, WXAgg,
macosx: all Agg canvases), about 10-20 ms a frame on a software X server; a full redraw of the
window (expose, resize) pastes the last frame again.  Other canvases go through ``imshow`` and a
redraw (slow).

Headless (a non-interactive backend such as ``MPLBACKEND=Agg``, or no display): ``show`` warns once
and does nothing; the environment runs on.
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg

STALL_S = 0.25  # a caller slower than this between frames restarts the clock


def interactive_backend() -> str | None:
    """The current matplotlib backend's name if it can open windows, else None."""
    from matplotlib.backends import BackendFilter, backend_registry

    name = matplotlib.get_backend().lower()
    return None if name in backend_registry.list_builtin(BackendFilter.NON_INTERACTIVE) else name


class HumanWindow:
    """A pyplot figure showing (H, W, 3) uint8 frames at ``fps`` frames per second (see the module doc)."""

    def __init__(self, fps: float, title: str = "rig_env") -> None:
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"fps = {fps!r}: must be a positive number")
        self.period, self.title = 1.0 / float(fps), title
        self._fig: Any = None
        self._image: Any = None  # imshow fallback for canvases that are not Agg
        self._last: np.ndarray | None = None
        self._due = 0.0
        self._warned = False
        self.shown = 0  # frames drawn
        self.dropped = 0  # frames dropped to keep real time

    def due(self) -> bool:
        """Advance the clock by one frame; False if this frame is to be dropped (or nothing can be shown)."""
        if interactive_backend() is None:
            if not self._warned:
                warnings.warn(f"render_mode='human' needs an interactive matplotlib backend, the current one is "
                              f"{matplotlib.get_backend()!r} (no display?): nothing is shown.  Use render_mode='rgb_array' "
                              "to get frames.", stacklevel=4)
                self._warned = True
            return False
        now = time.perf_counter()
        if self._fig is None or now - self._due > STALL_S:
            self._due = now
        else:
            self._due += self.period
        if now - self._due > self.period:
            self.dropped += 1
            return False
        return True

    def show(self, img: np.ndarray) -> None:
        """Display img now and wait until its deadline (call only after ``due()`` returned True)."""
        import matplotlib.pyplot as plt

        if self._fig is None or not plt.fignum_exists(self._fig.number):
            self._open(img.shape[0], img.shape[1])
        canvas = self._fig.canvas
        self._last = img
        if isinstance(canvas, FigureCanvasAgg):
            self._paste(canvas)
            canvas.blit(self._fig.bbox)
        else:
            if self._image is None:
                ax = self._fig.add_axes((0.0, 0.0, 1.0, 1.0))
                ax.set_axis_off()
                self._image = ax.imshow(img, interpolation="nearest", resample=False)
            self._image.set_data(img)
            canvas.draw_idle()
        self.shown += 1
        wait = self._due - time.perf_counter()
        if wait > 0.0:
            canvas.start_event_loop(wait)
        else:
            canvas.flush_events()

    def _open(self, h: int, w: int) -> None:
        import matplotlib.pyplot as plt

        self._fig = plt.figure(self.title, figsize=(w / 100.0, h / 100.0), dpi=100, facecolor="white")
        self._image = None
        # the backend may scale dpi by the screen's pixel ratio: size the canvas in physical pixels
        self._fig.set_size_inches(w / self._fig.dpi, h / self._fig.dpi, forward=True)
        if isinstance(self._fig.canvas, FigureCanvasAgg):  # a full redraw (expose, resize) shows the last frame
            self._fig.canvas.mpl_connect("draw_event", lambda event: self._paste(event.canvas))
        plt.show(block=False)
        self._fig.canvas.draw()

    def _paste(self, canvas: FigureCanvasAgg) -> None:
        """Write the last frame, centred at 1:1 (cropped or framed in white), into the canvas's Agg buffer."""
        if self._last is None:
            return
        buf = np.asarray(canvas.get_renderer().buffer_rgba())
        H, W = buf.shape[:2]
        h, w = self._last.shape[:2]
        hh, ww = min(h, H), min(w, W)
        y0, x0, sy, sx = (H - hh) // 2, (W - ww) // 2, (h - hh) // 2, (w - ww) // 2
        buf[y0 : y0 + hh, x0 : x0 + ww, :3] = self._last[sy : sy + hh, sx : sx + ww]
        buf[y0 : y0 + hh, x0 : x0 + ww, 3] = 255

    def close(self) -> None:
        if self._fig is not None:
            import matplotlib.pyplot as plt

            plt.close(self._fig)
            self._fig = self._image = None
