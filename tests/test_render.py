"""Rendering of the environments (rig_env.envs.render): frames, their geometry, Gymnasium's checks, video.

Pixel tests locate parts of the rig independently of the renderer's geometry code: from the sign
conventions of docs/MODEL.md (rig roll right-handed about the arm axis, clockwise seen from behind;
panel i at roll position gamma_i; a positive flap moves its trailing edge towards -n, n = x_s x e_r)
and matplotlib's data-to-pixel transform of the view.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import time
import warnings

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")  # headless: also what "human" mode must survive

import gymnasium  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402

from rig_env.envs import RigEnv, RigVectorEnv  # noqa: E402
from rig_env.envs.render import RENDER_MODES, RigRenderer  # noqa: E402
from rig_env.physics import layout as L  # noqa: E402

GAMMA_DEG = (135.0, 45.0, -45.0, -135.0)  # panel roll positions, flaps 1-4 (docs/MODEL.md)


def _set_state(env: RigEnv, q_deg=(0, 0, 0, 0, 0), flaps_deg=(0, 0, 0, 0)) -> None:
    env.vec.X[0, L.X_Q : L.X_Q + 5] = np.radians(q_deg)
    env.vec.X[0, L.X_SERVO : L.X_SERVO + 4] = np.radians(flaps_deg)


def _pixel(renderer: RigRenderer, y: float, z: float) -> tuple[int, int]:
    """(row, column) of world point (y, z) in the view from behind."""
    px, py = renderer.ax_behind.transData.transform((y, z))
    return int(round(renderer.height - py)), int(round(px))


def _reddish(rgb: np.ndarray) -> bool:
    r, g, b = (int(c) for c in rgb)
    return r > 170 and g < 140 and b < 140


@pytest.fixture(scope="module")
def env() -> RigEnv:
    e = RigEnv(render_mode="rgb_array", free_dofs=("rig_roll", "rig_pitch", "rig_yaw", "model_pitch", "model_yaw"))
    e.reset(seed=3)
    return e


def test_frame_shape_dtype_and_content(env: RigEnv) -> None:
    _set_state(env)
    frame = env.render()
    r = env.vec.viewer.renderer
    assert frame.shape == (r.height, r.width, 3) == (448, 1024, 3)
    assert frame.dtype == np.uint8 and frame.flags.c_contiguous
    # against the static background alone (axes, grid, labels): the rig and the overlay are drawn on it
    r.canvas.restore_region(r._background)
    background = np.asarray(r.canvas.buffer_rgba())[:, :, :3].copy()
    drawn = np.any(frame != background, axis=2)
    assert drawn.sum() > 5000, f"only {drawn.sum()} pixels drawn over the background"
    hawk_blue = (frame[:, :, 2].astype(int) - frame[:, :, 0] > 40) & drawn
    flap_red = (frame[:, :, 0].astype(int) - frame[:, :, 2] > 80) & drawn
    assert hawk_blue.sum() > 300 and flap_red.sum() > 100


def test_roll_sign_and_flap_direction_from_behind(env: RigEnv) -> None:
    """All flaps +40 deg: each flap shows from behind as a red band beside its panel, on its -n side.

    At rig roll phi, panel i lies along e_r = (0, cos(gamma_i + phi), sin(gamma_i + phi)) (world,
    zero pitch and yaw).  The band's middle, 0.2 m out, is checked red at +30 deg roll and not red at
    -30 deg (and vice versa), which fixes both the roll sense and the flap sense.
    """
    p = env.vec.P[0]
    chord = p[L.P_COMP_AERO_S] / p[L.P_COMP_AERO_SPAN]
    offset = 0.5 * 0.25 * chord * math.sin(math.radians(40.0))  # half the flap's projected width
    r = env.vec.viewer.renderer
    frames = {}
    for phi in (30.0, -30.0):
        _set_state(env, (phi, 0, 0, 0, 0), (40, 40, 40, 40))
        frames[phi] = env.render()
    for i, gam in enumerate(GAMMA_DEG):
        for phi, other in ((30.0, -30.0), (-30.0, 30.0)):
            g = math.radians(gam + phi)
            er, n = np.array([math.cos(g), math.sin(g)]), np.array([-math.sin(g), math.cos(g)])  # (y, z)
            y, z = 0.2 * er - offset * n
            row, col = _pixel(r, y, z)
            assert _reddish(frames[phi][row, col]), f"flap {i + 1} at roll {phi}: {frames[phi][row, col]} at ({y:.3f}, {z:.3f})"
            assert not _reddish(frames[other][row, col]), f"flap {i + 1}: red at roll {other} where it should be at roll {phi}"


def test_roll_changes_the_view_from_behind(env: RigEnv) -> None:
    _set_state(env, (0, 0, 0, 10, 0))
    a = env.render()
    _set_state(env, (90, 0, 0, 10, 0))
    b = env.render()
    r = env.vec.viewer.renderer
    top, left = _pixel(r, -0.78, -0.64)
    bottom, right = _pixel(r, 0.78, 0.64)
    changed = np.any(a[top:bottom, left:right] != b[top:bottom, left:right], axis=2).sum()
    assert changed > 500


def test_flap_deflection_changes_pixels_around_that_flap_only(env: RigEnv) -> None:
    _set_state(env, (0, 0, 0, 0, 0), (0, 0, 0, 0))
    a = env.render()
    _set_state(env, (0, 0, 0, 0, 0), (0, 0, 30, 0))
    b = env.render()
    r = env.vec.viewer.renderer
    diff = np.any(a != b, axis=2)

    def around(flap: int) -> int:
        g = math.radians(GAMMA_DEG[flap - 1])
        row, col = _pixel(r, 0.2 * math.cos(g), 0.2 * math.sin(g))
        return int(diff[row - 25 : row + 25, col - 25 : col + 25].sum())

    assert around(3) > 60
    assert around(1) == around(2) == around(4) == 0


def test_vector_env_frames_are_per_environment_and_lazy() -> None:
    vec = RigVectorEnv(3, render_mode="rgb_array")
    vec.reset(seed=0)
    vec.X[1, L.X_Q] = math.radians(90.0)
    frames = vec.render()
    assert len(frames) == 3 and frames._cache == {}
    f0, f1 = frames[0], frames[1]
    assert f0.shape == (448, 1024, 3) and f0.dtype == np.uint8
    assert np.any(f0 != f1)
    assert np.array_equal(frames[-3], f0)
    vec.X[0, L.X_Q] = math.radians(45.0)  # frames are a snapshot: later changes do not leak in
    assert np.array_equal(frames[2], vec.render()[2]) and np.array_equal(frames[0], f0)
    assert vec.metadata["render_fps"] == 80 and RigVectorEnv.metadata.get("render_fps") is None
    vec.close()


def test_ended_episode_shows_its_last_state_until_reset() -> None:
    env = RigEnv(render_mode="rgb_array", episode_seconds=0.1)
    env.reset(seed=0)
    trunc = False
    while not trunc:
        _, _, _, trunc, _ = env.step(np.zeros(3))
    held = env.vec.viewer.snapshot(env.vec, np.array([0]))
    assert held.t[0] == pytest.approx(env.vec.max_steps * env.vec.dt)
    env.reset()
    assert env.vec.viewer.snapshot(env.vec, np.array([0])).t[0] == 0.0


def test_render_fps_is_the_control_rate() -> None:
    assert RigEnv(render_mode="rgb_array").metadata["render_fps"] == 80
    e = RigEnv(render_mode="rgb_array", control_rate=244.0)
    assert e.metadata["render_fps"] == 244 and RigEnv.metadata.get("render_fps") is None


def test_check_env_with_render_check() -> None:
    env = gymnasium.make("rig_env/ManoeuvreRig-v0", render_mode="rgb_array").unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the "human" pass warns headless, by design
        check_env(env, skip_render_check=False)


def test_bad_render_mode_raises() -> None:
    for make in (lambda: RigEnv(render_mode="rgb"), lambda: RigVectorEnv(2, render_mode="ansi"),
                 lambda: gymnasium.make("rig_env/BankToBank-v0", render_mode="video")):
        with pytest.raises(ValueError, match="allowed values are None, 'rgb_array', 'human'"), warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # gymnasium.make's own notice of the unknown mode
            make()
    assert RENDER_MODES == ("rgb_array", "human")


def test_human_mode_headless_warns_once_and_runs() -> None:
    env = RigEnv(render_mode="human")
    with pytest.warns(UserWarning, match="interactive matplotlib backend") as rec:
        env.reset(seed=0)
        for _ in range(3):
            env.step(np.zeros(3))
        assert env.render() is None
    assert sum("interactive matplotlib backend" in str(w.message) for w in rec) == 1
    env.close()


def test_record_video_writes_a_playable_mp4(tmp_path) -> None:
    pytest.importorskip("moviepy")
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(RigEnv(render_mode="rgb_array", episode_seconds=0.25), str(tmp_path / "v"), episode_trigger=lambda e: e == 0,
                      disable_logger=True)
    env.reset(seed=1)
    steps, done = 0, False
    while not done:
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        steps, done = steps + 1, term or trunc
    env.close()
    videos = list((tmp_path / "v").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
    iio = pytest.importorskip("imageio.v3")
    frames = iio.imread(videos[0])
    assert frames.shape[1:] == (448, 1024, 3)
    assert frames.shape[0] == steps + 1  # the reset frame and one per step
    meta = iio.immeta(videos[0])
    assert meta["fps"] == pytest.approx(80.0)


@pytest.mark.filterwarnings("ignore:.*same-step")  # gymnasium's notice; here a frame after an end shows the last state
def test_vector_record_video_of_the_first_environment(tmp_path) -> None:
    """gymnasium.wrappers.vector.RecordVideo over the native vector env: one frame per step drawn."""
    pytest.importorskip("moviepy")
    from gymnasium.wrappers.vector import RecordVideo

    vec = RigVectorEnv(64, render_mode="rgb_array")
    env = RecordVideo(vec, str(tmp_path / "v"), step_trigger=lambda s: s == 0, video_length=12, record_first_only=True,
                      disable_logger=True)
    env.reset(seed=0)
    for _ in range(14):
        env.step(np.zeros((64, 3)))
    env.close()
    videos = list((tmp_path / "v").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
    iio = pytest.importorskip("imageio.v3")
    # the wrapper starts at step 0 and stops once it holds more than video_length frames
    assert iio.imread(videos[0]).shape == (12 + 1, 448, 1024, 3)


HUMAN_SCRIPT = """
import time, numpy as np
from rig_env.envs import RigEnv
env = RigEnv(render_mode="human", control_rate=20.0)
env.reset(seed=0)
t0 = time.perf_counter()
for _ in range(40):
    env.step(np.zeros(3))
w = env.vec.viewer._window
print(time.perf_counter() - t0, w.shown, w.dropped)
env.close()
"""


@pytest.fixture
def display():
    """A display for an interactive backend: $DISPLAY, or a private Xvfb started here (CI installs xvfb)."""
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("needs a display: set DISPLAY or install Xvfb (Debian package xvfb)")
    disp = f":{90 + os.getpid() % 400}"
    proc = subprocess.Popen([xvfb, disp, "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        time.sleep(1.0)
        if proc.poll() is not None:
            pytest.skip("Xvfb did not start")
        yield disp
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_human_mode_window_runs_in_real_time(display) -> None:
    """TkAgg in a subprocess: 40 steps at 20 Hz are paced to real time (about 2 s, not free-running); every
    frame is shown or counted as dropped."""
    pytest.importorskip("tkinter")
    env = dict(os.environ, MPLBACKEND="TkAgg", DISPLAY=display, PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run([sys.executable, "-c", HUMAN_SCRIPT], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    elapsed, shown, dropped = out.stdout.split()[-3:]
    assert 1.9 < float(elapsed) < 6.0  # paced by the window clock; the upper bound only catches a stall
    assert int(shown) + int(dropped) == 41 and int(shown) >= 10  # the reset frame and one per step
