"""``rig-deploy`` (= ``python scripts/deploy.py``): export a law, fly it on a rig, or serve a simulated rig.

    rig-deploy export --controller KIND --task NAME --out PATH [--overwrite] [--task-option KEY=VALUE ...] [--rate 80] [--key-file F] [--gains KP KD KFF] [--policy FILE]
    rig-deploy run --law FILE --rig udp://HOST:PORT [--rate 80] [--arm] [--duration S] [--log PATH] [--key-file F] [--link-key-file F] [--stuck-frames 32] [--test-input FILE.json]
    rig-deploy sim-rig --port PORT [--task NAME] [--task-option KEY=VALUE ...] [--rate 80] [--duration S] [--loss P] [--blackout T0 DUR] ... [--record F.npz] [--summary F.json] [--overwrite]
    rig-deploy verify --law FILE [--key-file F]
    rig-deploy convert-policy OLD NEW [--key-file F] [--overwrite]
    rig-deploy log show|plot|export FILE [--out DIR|FILE.csv]

``convert-policy`` rewrites a policy file of the earlier separate format (``rig_env.rl_policy``) as the
rig-law artefact every law now uses (:mod:`controllers.deploy.convert`); loading an old file names
this command.

The ``run`` path imports numpy, the standard library, the deployed runtime and the observation builder
only (:mod:`controllers.deploy.loop`): no gymnasium, numba, llvmlite, matplotlib, scipy, python-control
or torch (``tests/test_deploy_imports.py``); ``export`` and ``sim-rig`` import the environments inside
their functions.

``run --test-input FILE.json`` adds a test input (:class:`rig_env.signals.InputSchedule`, as written by
its ``save``) to the law's command from each arming (:mod:`controllers.deploy.loop`).

``verify`` and ``run`` share one validator (:mod:`controllers.deploy.validate`): what ``verify``
accepts, ``run`` flies.  ``log`` reads a flight's log (:mod:`controllers.deploy.logtool`).

Files written: ``export --out`` and ``sim-rig --record`` (exactly that name, ``.npz``) / ``--summary``
refuse, before any work, a folder, a path whose folder is missing or read-only, and an existing file
unless ``--overwrite`` (``run --log`` is always a new file).  Sockets: a host or port that cannot be used
is refused naming its option and value (``run --rig``, ``--bind``, ``--bind-port``; ``sim-rig --host``,
``--port``), before the log is created.

Exit status (:data:`EXIT_CODES`; ``run --help`` lists them):

| code | meaning |
|---|---|
| 0 | success (``run``: frames received, flown, not in FAULT at the end, log complete) |
| 2 | refused input: arguments, artefact, log path (exists), test input; nothing was flown |
| 3 | the run ended in FAULT (a latched watchdog) |
| 4 | no sensor frame was ever received (the rig did not answer) |
| 5 | the log could not be written (FAULT ``log_write``; the summary names the path) |
| 6 | the command path was lost: ``fault_frames`` (8) or more command sends failed |

When several apply, the first of 5, 4, 6, 3 wins.
``run`` arms on SIGUSR1, disarms on SIGUSR2, stops on SIGINT / SIGTERM.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import socket
import sys
from pathlib import Path
from typing import Any, Callable, Sequence
from urllib.parse import urlparse

from controllers.deploy.framelog import LogWriteError
from controllers.deploy.protocol import BindError
from controllers.laws.artefact import ArtefactError
from rig_env.envs.ranges import CONTROL_RATE_HZ, MAX_SEED

EXIT_OK, EXIT_REFUSED, EXIT_FAULT, EXIT_NO_FRAMES, EXIT_LOG, EXIT_CMD_LOST = 0, 2, 3, 4, 5, 6
EXIT_CODES = {EXIT_OK: "success", EXIT_REFUSED: "refused input (arguments, artefact, log path); nothing flown",
              EXIT_FAULT: "the run ended in FAULT", EXIT_NO_FRAMES: "no sensor frame received",
              EXIT_LOG: "the log could not be written", EXIT_CMD_LOST: "command path lost: sends failed (fault_frames or more) or the rig stopped acknowledging (command_ack)"}
MAX_PORT = 65535
MAX_DURATION_S = 1.0e6  # controllers.deploy.loop.MAX_DURATION_S (a test checks the copy; importing the loop here would load it for every command)


def _integer(hi: int, what: str) -> Callable[[str], int]:
    """argparse type: an integer in [0, hi] (``what``: the error's name of it)."""
    def parse(text: str) -> int:
        shown = text if len(text) <= 24 else text[:20] + "..."
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{shown!r}: not an integer {what}; allowed range [0, {hi}]") from None
        if not 0 <= v <= hi:
            raise argparse.ArgumentTypeError(f"{shown}: allowed range [0, {hi}]")
        return v
    return parse


_port = _integer(MAX_PORT, "port (0: any free port)")
"""argparse type: a UDP port, [0, 65535] (0: any free port)."""
_seed = _integer(MAX_SEED, "seed")
"""argparse type: a seed, an integer in [0, MAX_SEED] (``run --seed``, ``sim-rig --seed``, ``--fault-seed``)."""


def _bounded(lo: float, hi: float, unit: str, integer: bool = False, lo_open: bool = False):
    """argparse type: a finite number in [lo, hi] (``(lo, hi]`` with lo_open), in ``unit``."""
    def parse(text: str) -> float | int:
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: not {'an integer' if integer else 'a number'}") from None
        # an integer is compared exactly (a 400-digit one has no float; math.isfinite would overflow)
        if not ((integer or math.isfinite(v)) and (lo < v if lo_open else lo <= v) and v <= hi):
            shown = text if len(text) <= 24 else text[:20] + "..."
            raise argparse.ArgumentTypeError(f"{shown}: allowed range {'(' if lo_open else '['}{lo:g}, {hi:g}] {unit}")
        return v
    return parse


def _finite(text: str) -> float:
    """argparse type: a finite number."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{text[:24]!r}: not a finite number")
    return v


def check_out_file(option: str, path: str, overwrite: bool = False) -> None:
    """Refuse (ValueError naming ``option`` and ``path``), before any work, a path a command cannot write its
    output to: a folder, a path whose folder is missing or not writable, or an existing file unless
    ``overwrite`` (which replaces a regular file only: never a device, FIFO or socket)."""
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{option} {path}: is a folder; give a file path (e.g. {p / 'NAME'})")
    if os.path.lexists(p):
        if not overwrite:
            raise ValueError(f"{option} {path}: already exists; give --overwrite to replace it, or another {option}")
        if not p.is_file():
            raise ValueError(f"{option} {path}: exists and is not a regular file (a device, FIFO, socket or broken link); give another {option}")
    folder = p.parent
    if not folder.is_dir():
        raise ValueError(f"{option} {path}: its folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {path}: its folder {folder} is not writable")


def _bind_refused(e: BindError, host_option: str, port_option: str) -> ValueError:
    """A socket that could not be bound, as a refusal naming the option at fault (the host's or the port's) and its value."""
    if e.host_refused:
        return ValueError(f"{host_option} {e.host}: cannot bind a UDP socket to this host ({e.strerror}); give a name or address of this machine")
    return ValueError(f"{port_option} {e.port}: cannot bind a UDP socket to this port on {host_option} {e.host} ({e.strerror})")


def _key(path: str | None) -> bytes | None:
    if path is None:
        return None
    try:
        return Path(path).read_bytes().strip()
    except OSError as e:
        raise ArtefactError(f"key file {path}: cannot read ({e.strerror})") from None


def _link_key(path: str | None) -> bytes | None:
    from controllers.deploy.protocol import read_link_key

    return None if path is None else read_link_key(path)


def _rig_address(url: str) -> tuple[str, int]:
    u = urlparse(url)
    try:
        port = u.port
    except ValueError:  # urllib: "Port out of range 0-65535" or not a number
        port = None
    if u.scheme != "udp" or not u.hostname or not port:
        raise ValueError(f"--rig {url!r}: expected udp://HOST:PORT with PORT in 1-{MAX_PORT}")
    return u.hostname, port


def task_options(pairs: Sequence[str] | None) -> dict[str, Any]:
    """``--task-option KEY=VALUE`` arguments as the task's ``task_options`` mapping.

    VALUE is read as JSON when it parses (numbers, true/false, quoted strings) and as a plain string
    otherwise, so ``axis=sway_yaw`` and ``amplitude_deg=5`` both work; the task checks names and values
    (a ValueError naming the option and what it accepts).
    """
    out: dict[str, Any] = {}
    for pair in pairs or ():
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise ValueError(f"--task-option {pair!r}: expected KEY=VALUE")
        if key in out:
            raise ValueError(f"--task-option {key!r}: given twice")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def cmd_export(a: argparse.Namespace) -> int:
    check_out_file("--out", a.out, a.overwrite)  # before building anything
    from controllers import CONTROLLERS, LoopSpec, make_controller
    from controllers.laws import artefact as art
    from controllers.design.linear import roll_tracking
    from rig_env.envs import RigVectorEnv

    env = RigVectorEnv(1, task=a.task, control_rate=a.rate, task_options=task_options(a.task_option))
    spec = LoopSpec.from_env(env)
    sensors = art.sensors_of(env.config)
    kinds = sorted(set(CONTROLLERS) | {"linear"})
    if a.controller == "linear":
        ctrl = roll_tracking(spec, *a.gains)
    elif a.controller in CONTROLLERS:
        if a.policy and a.controller not in ("ppo", "sac"):
            raise ValueError(f"--policy: only for the RL kinds ppo, sac; not {a.controller!r}")
        kwargs: dict[str, Any] = {"path": a.policy} if a.policy else {}  # controllers.laws.rl.MLPPolicy(path=...)
        ctrl = make_controller(a.controller, spec, 1, **kwargs)
    else:
        raise ValueError(f"--controller {a.controller!r}: not available in this installation; available: {kinds}")
    rate_limit = env.params.servos.compensator.rate_limit_deg_s
    artefact = art.from_controller(ctrl, sensors, art.default_limits(spec, rate_limit), source=f"rig-deploy export --controller {a.controller} --task {a.task}" + "".join(f" --task-option {o}" for o in a.task_option or ()), notes=a.notes)
    try:
        digest = art.save(artefact, a.out, _key(a.key_file), overwrite=a.overwrite)
    except OSError as e:  # e.g. the file appeared meanwhile, or the disk is full
        raise ValueError(f"--out {a.out}: not written ({e.strerror or e})") from None
    print(f"wrote {a.out}: kind {artefact.kind}, task {spec.task}, {1 / spec.dt:g} Hz, sha256 {digest}")
    return 0


def cmd_verify(a: argparse.Namespace) -> int:
    from controllers.deploy.validate import load_deployable

    art = load_deployable(a.law, _key(a.key_file), require_signature=a.key_file is not None, rate_hz=a.rate)
    print(json.dumps({"ok": True, "kind": art.kind, "task": art.spec.task, "rate_hz": 1 / art.spec.dt, "sha256": art.sha256, "provenance": art.provenance}, indent=1))
    return 0


def cmd_convert_policy(a: argparse.Namespace) -> int:
    from controllers.deploy.convert import convert_policy_file

    check_out_file("NEW", a.new, a.overwrite)
    digest = convert_policy_file(a.old, a.new, _key(a.key_file), overwrite=a.overwrite)
    print(f"wrote {a.new}: rig-law artefact of {a.old}, sha256 {digest}")
    return 0


def cmd_run(a: argparse.Namespace) -> int:
    from rig_env.physics import jit

    # the sensors' and the task's kernels run as Python: the rig process imports no numba, compiles nothing
    with jit.python_mode():
        return _run(a)


def _run(a: argparse.Namespace) -> int:
    from controllers.deploy.loop import LoopConfig, RigLoop
    from controllers.deploy.validate import load_deployable

    from rig_env.signals import InputSchedule, ScheduleError

    art = load_deployable(a.law, _key(a.key_file), require_signature=a.key_file is not None, rate_hz=a.rate)
    rate = a.rate if a.rate is not None else 1.0 / art.spec.dt
    if a.log is not None:  # refused before flying: never append to, nor overwrite, a file (the loop creates it exclusively)
        for p in (a.log, a.log + ".summary.json"):
            if os.path.lexists(p):
                raise ValueError(f"--log {a.log}: {p} already exists; a log is never appended to nor overwrites a file: give a new path")
    test_input = None
    if a.test_input is not None:
        try:
            test_input = InputSchedule.load(a.test_input)
        except ScheduleError as e:
            raise ValueError(f"--test-input: {e}") from None
    host, port = _rig_address(a.rig)
    try:
        rig = (socket.gethostbyname(host), port)
    except (OSError, UnicodeError) as e:  # socket.gaierror: an unknown name; UnicodeError: a malformed one
        raise ValueError(f"--rig {a.rig}: host {host!r} does not resolve ({getattr(e, 'strerror', None) or e})") from None
    cfg = LoopConfig(rig=rig, rate_hz=rate, bind=(a.bind, a.bind_port), duration=a.duration, arm=a.arm, log_path=a.log,
                     seed=a.seed, stale_frames=a.stale_frames, fault_frames=a.fault_frames, realtime=a.realtime,
                     link_delay_steps=a.link_delay_steps, stuck_frames=a.stuck_frames, stuck_cmd_deg=a.stuck_cmd_deg, test_input=test_input,
                     link_key=_link_key(a.link_key_file), ack_frames=a.ack_frames, allow_unlogged=a.allow_unlogged)
    loop = RigLoop(art, cfg)
    try:
        loop.open()  # before the log is created: a refused address leaves no file behind
    except BindError as e:
        raise _bind_refused(e, "--bind", "--bind-port") from None
    signal.signal(signal.SIGINT, lambda *_: loop.stop())
    signal.signal(signal.SIGTERM, lambda *_: loop.stop())
    if hasattr(signal, "SIGUSR1"):
        signal.signal(signal.SIGUSR1, lambda *_: loop.arm())
        signal.signal(signal.SIGUSR2, lambda *_: loop.disarm())
    summary = loop.run()
    code = run_exit_code(summary, cfg.fault_frames)
    summary["exit"] = {"code": code, "meaning": EXIT_CODES[code]}
    text = json.dumps(summary, indent=1)
    print(text, flush=True)
    if a.log:
        where = a.log + ".summary.json"
        try:
            with open(where, "x") as f:  # written wherever it can be: a failed log does not stop it
                f.write(text + "\n")
        except OSError as e:
            print(f"rig-deploy: {where}: summary not written ({e.strerror or e})", file=sys.stderr)
    if summary["log"]["error"]:
        print(f"rig-deploy: log failed: {summary['log']['error']}", file=sys.stderr)
    if code != EXIT_OK:
        print(f"rig-deploy: run: exit {code}: {EXIT_CODES[code]}", file=sys.stderr)
    return code


def run_exit_code(summary: dict[str, Any], fault_frames: int = 8) -> int:
    """The exit status of a run from its summary (module docstring): 5 log, 4 no frames, 6 command path lost
    (``fault_frames`` or more sends failed, or the rig stopped acknowledging the commands: FAULT ``command_ack``),
    3 FAULT, else 0."""
    counts = summary["counts"]
    if summary["log"]["error"]:
        return EXIT_LOG
    if counts["fresh"] == 0:
        return EXIT_NO_FRAMES
    if counts["tx_error"] >= fault_frames or "command_ack" in summary.get("faults", ()):
        return EXIT_CMD_LOST
    return EXIT_FAULT if summary["final_state"] == "FAULT" else EXIT_OK


def _stuck(values: Sequence[str] | None) -> tuple[str, float, float] | None:
    """``sim-rig --stuck JOINT T0 DUR`` as (joint, t0 s, duration s); ValueError naming ``--stuck`` and the bad part."""
    if not values:
        return None
    from rig_env.params import JOINTS

    joint, t0, dur = values
    given = f"--stuck {' '.join(values)}"
    if joint not in JOINTS:
        raise ValueError(f"{given}: JOINT {joint!r}: one of {list(JOINTS)}")
    out = []
    for name, text, lo_open in (("T0", t0, False), ("DUR", dur, True)):
        try:
            v = float(text)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and (v > 0 if lo_open else v >= 0)):
            raise ValueError(f"{given}: {name} {text[:24]!r}: {'a number > 0' if lo_open else 'a number >= 0'}, s of rig time")
        out.append(v)
    return joint, out[0], out[1]


def cmd_sim_rig(a: argparse.Namespace) -> int:
    # every refusal before the model is built or a socket bound: the output files, the faults, the key
    outputs = [(opt, path) for opt, path in (("--record", a.record), ("--summary", a.summary)) if path]
    for opt, path in outputs:
        check_out_file(opt, path, a.overwrite)
    if a.record and Path(a.record).suffix != ".npz":
        raise ValueError(f"--record {a.record}: the record is a NumPy .npz archive; give a name ending in .npz")
    if len(outputs) == 2 and os.path.abspath(a.record) == os.path.abspath(a.summary):
        raise ValueError(f"--record and --summary: both {a.record}; give two files")
    from controllers.deploy.simrig import Faults, SimRig

    try:
        faults = Faults(loss=a.loss, cmd_loss=a.cmd_loss, delay=a.delay, duplicate=a.duplicate, reorder=a.reorder, corrupt=a.corrupt,
                        blackout=tuple(a.blackout) if a.blackout else None, cmd_blackout=tuple(a.cmd_blackout) if a.cmd_blackout else None,
                        stuck=_stuck(a.stuck), seed=a.fault_seed)
    except ValueError as e:  # Faults names its fields (blackout = ...); the command's options are --blackout, --cmd-blackout
        text = str(e)
        field = text.split(" = ", 1)[0]
        raise ValueError(f"--{field.replace('_', '-')}{text[len(field):]}" if field in ("blackout", "cmd_blackout") else text) from None
    fields: dict[str, Any] = {"task_options": task_options(a.task_option)}
    if a.no_noise:
        fields.update(angle_noise_deg=0.0, flap_noise_deg=0.0, airspeed_noise=0.0)
    key = _link_key(a.link_key_file)
    try:
        rig = SimRig(a.port, a.task, a.rate, a.duration, a.seed, faults, host=a.host, realtime=a.realtime, link_key=key, **fields)
    except BindError as e:
        raise _bind_refused(e, "--host", "--port") from None
    print(json.dumps({"listening": [a.host, rig.port], "task": a.task, "rate_hz": a.rate}), flush=True)
    signal.signal(signal.SIGTERM, lambda *_: rig.stop())
    summary = rig.run()
    text = json.dumps(summary, indent=1)
    print(text, flush=True)  # first: a file that cannot be written does not lose the summary
    written = True
    for opt, path in outputs:
        if opt == "--record" and "error" in summary:
            continue
        try:
            if opt == "--record":
                rig.save_record(path, overwrite=a.overwrite)
            else:
                with open(path, "w" if a.overwrite else "x", encoding="utf-8") as f:
                    f.write(text + "\n")
        except OSError as e:  # the folder went away, the disk is full, or the file appeared during the run
            print(f"rig-deploy: {opt} {path}: not written ({e.strerror or e})", file=sys.stderr)
            written = False
    return 0 if "error" not in summary and written else 1


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rig-deploy", description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    e = sub.add_parser("export", help="write a law to an artefact file")
    e.add_argument("--controller", required=True, help="controller kind (linear; lqr, pid, ppo, sac when installed)")
    e.add_argument("--task", required=True)
    e.add_argument("--task-option", action="append", metavar="KEY=VALUE", help="a task option (repeatable), e.g. axis=sway_yaw for forced_oscillation")
    e.add_argument("--out", required=True, help="the artefact file to write (an existing file is refused unless --overwrite)")
    e.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    e.add_argument("--rate", type=_bounded(*CONTROL_RATE_HZ, "Hz"), default=80.0, help="control rate, Hz")
    e.add_argument("--policy", help="ppo, sac: a policy artefact from rig train (default: the shipped controllers/policies/<task>_<kind>.json)")
    e.add_argument("--gains", type=_finite, nargs=3, default=(2.0, 1.0, 1.0), metavar=("KP", "KD", "KFF"), help="linear: roll-tracking gains")
    e.add_argument("--key-file", help="sign with the HMAC key in this file")
    e.add_argument("--notes", default="")
    e.set_defaults(func=cmd_export)
    v = sub.add_parser("verify", help="validate an artefact file")
    v.add_argument("--law", required=True)
    v.add_argument("--key-file")
    v.add_argument("--rate", type=_bounded(*CONTROL_RATE_HZ, "Hz"), help="also check the law against this loop rate, Hz")
    v.set_defaults(func=cmd_verify)
    c = sub.add_parser("convert-policy", help="convert an old-format policy file (rig_env.rl_policy) to a rig-law artefact")
    c.add_argument("old")
    c.add_argument("new")
    c.add_argument("--key-file", help="sign with the HMAC key in this file")
    c.add_argument("--overwrite", action="store_true", help="replace NEW if it exists (refused otherwise)")
    c.set_defaults(func=cmd_convert_policy)
    r = sub.add_parser("run", help="fly a law on a rig", formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="exit status:\n" + "\n".join(f"  {c}  {m}" for c, m in EXIT_CODES.items())
                       + "\n  (several: 5, then 4, 6, 3)")
    r.add_argument("--law", required=True)
    r.add_argument("--rig", required=True, help="udp://HOST:PORT")
    r.add_argument("--rate", type=_bounded(*CONTROL_RATE_HZ, "Hz"), help="Hz (default: the law's)")
    r.add_argument("--arm", action="store_true", help="arm at the first frame")
    r.add_argument("--duration", type=_bounded(0.0, MAX_DURATION_S, "s", lo_open=True), help=f"s, up to {MAX_DURATION_S:g} (default: until SIGINT)")
    r.add_argument("--log", help="a new file (an existing path is refused, exit 2)")
    r.add_argument("--allow-unlogged", action="store_true", help="keep flying when the log cannot be written (default: FAULT, stop, exit 5)")
    r.add_argument("--seed", type=_seed, default=0, help=f"task reference draw (as RigVectorEnv.reset(seed)), 0-{MAX_SEED}")
    r.add_argument("--bind", default="0.0.0.0")
    r.add_argument("--bind-port", type=_port, default=0)
    r.add_argument("--stale-frames", type=_bounded(1, 1000, "frames", integer=True), default=3)
    r.add_argument("--fault-frames", type=_bounded(1, 1000, "frames", integer=True), default=8)
    r.add_argument("--stuck-frames", type=int, default=32,
                   help="FAULT when a free joint's reading repeats for this many frames while the command moves (0: off)")
    r.add_argument("--stuck-cmd-deg", type=float, default=2.0, help="command movement, deg at 18 m/s (x (18/U)^2 at U), that shows the rig is driven (stuck-sensor watchdog)")
    r.add_argument("--key-file")
    r.add_argument("--link-key-file", metavar="FILE", help="shared link key (hex or raw, >= 16 bytes, mode 600): MAC on every frame; the rig needs the same key")
    r.add_argument("--ack-frames", type=int, default=8, help="FAULT command_ack when the rig acknowledges none of this many commands sent")
    r.add_argument("--realtime", action="store_true", help="SCHED_FIFO scheduling (Linux, privileged)")
    r.add_argument("--link-delay-steps", type=_bounded(0, 50, "steps", integer=True), default=0, help="age of a sensor frame on arrival, control steps (reference lead)")
    r.add_argument("--test-input", metavar="FILE.json", help="a test input schedule (rig_env.signals.InputSchedule.save) added to the law's command from arming")
    r.set_defaults(func=cmd_run)
    s = sub.add_parser("sim-rig", help="serve the simulated rig")
    s.add_argument("--port", type=_port, required=True)
    s.add_argument("--host", default="127.0.0.1")
    s.add_argument("--task", default="velocity_vector_roll")
    s.add_argument("--task-option", action="append", metavar="KEY=VALUE", help="a task option (repeatable), as for export")
    s.add_argument("--rate", type=_bounded(*CONTROL_RATE_HZ, "Hz"), default=80.0)
    s.add_argument("--duration", type=_bounded(0.0, 3600.0, "s", lo_open=True), default=20.0)
    s.add_argument("--seed", type=_seed, default=0, help=f"the model's seed (as RigVectorEnv.reset(seed)), 0-{MAX_SEED}")
    s.add_argument("--loss", type=_bounded(0.0, 1.0, "(probability)"), default=0.0)
    s.add_argument("--cmd-loss", type=_bounded(0.0, 1.0, "(probability)"), default=0.0)
    s.add_argument("--delay", type=_bounded(0.0, 1.0, "s"), default=0.0)
    s.add_argument("--duplicate", type=_bounded(0.0, 1.0, "(probability)"), default=0.0)
    s.add_argument("--reorder", type=_bounded(0.0, 1.0, "(probability)"), default=0.0)
    s.add_argument("--corrupt", type=_bounded(0.0, 1.0, "(probability)"), default=0.0)
    s.add_argument("--blackout", type=float, nargs=2, metavar=("T0", "DUR"))
    s.add_argument("--cmd-blackout", type=float, nargs=2, metavar=("T0", "DUR"), help="drop every command in this span of rig time (no ack)")
    s.add_argument("--link-key-file", metavar="FILE", help="shared link key (as for run): only the loop's authenticated commands fly the rig")
    s.add_argument("--stuck", nargs=3, metavar=("JOINT", "T0", "DUR"), help="freeze that joint's angle in the frames from T0 for DUR s of rig time")
    s.add_argument("--fault-seed", type=_seed, default=0, help=f"seed of the fault draws, 0-{MAX_SEED}")
    s.add_argument("--no-noise", action="store_true", help="no sensor noise (quantisation stays)")
    s.add_argument("--realtime", action="store_true", help="SCHED_FIFO scheduling (Linux, privileged)")
    s.add_argument("--record", metavar="FILE.npz", help="write the state / command record to this new .npz file (exactly this name; "
                   "another suffix is refused)")
    s.add_argument("--summary", metavar="FILE.json", help="write the run's summary (JSON) to this new file")
    s.add_argument("--overwrite", action="store_true", help="replace existing --record / --summary files")
    s.set_defaults(func=cmd_sim_rig)
    from controllers.deploy.logtool import add_parser as add_log_parser

    add_log_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    a = parser().parse_args(argv)
    try:
        return a.func(a)
    except ArtefactError as e:
        print(f"rig-deploy: artefact refused: {e}", file=sys.stderr)
        return EXIT_REFUSED
    except ValueError as e:
        print(f"rig-deploy: {e}", file=sys.stderr)
        return EXIT_REFUSED
    except OSError as e:  # a raised FileNotFoundError(message) has no strerror: print the message
        # only the path the error names: a guessed one (--log, --out, --law) would blame the wrong file
        where = e.filename if e.filename is not None else a.command
        print(f"rig-deploy: {where}: {e.strerror}" if e.strerror else f"rig-deploy: {e}", file=sys.stderr)
        return EXIT_LOG if isinstance(e, LogWriteError) else EXIT_REFUSED


if __name__ == "__main__":
    raise SystemExit(main())
