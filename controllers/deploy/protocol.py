"""The rig link's binary protocol: sensor frames (rig -> loop) and command frames (loop -> rig), UDP, little-endian.

Version 2 (version 1 had neither ``ack``, ``session`` nor ``mac``; a version-1 frame is refused as
``version`` / ``length``).  Sensor frame, 92 bytes, one per rig tick (80 Hz pilot rig, ~244 Hz later rig):

| offset | type | field | unit / meaning |
|---|---|---|---|
| 0 | 4 bytes | magic | ``b"RIGS"`` |
| 4 | uint16 | version | :data:`VERSION` (2) |
| 6 | uint16 | reserved | 0 (a non-zero value is implausible: :mod:`controllers.deploy.plausibility`) |
| 8 | uint32 | seq | frame counter, +1 per rig tick, wraps at 2**32 |
| 12 | float64 | rig_time | rig clock, s |
| 20 | 5 x float32 | angles | rig_roll, rig_pitch, rig_yaw, model_pitch, model_yaw, rad (locked joints: their lock angle) |
| 40 | 4 x float32 | flaps | compensator flaps 1-4 (encoders), rad |
| 56 | float32 | airspeed | m/s |
| 60 | uint32 | status | bit 0 RIG_FAULT (e-stop / rig-side fault), bit 1 SIMULATED; others 0 (:data:`STATUS_KNOWN`) |
| 64 | uint32 | ack | seq of the newest command the rig applied before this frame (``NO_ECHO``: none yet) |
| 68 | uint32 | session | the session id of the client the rig serves (0: none) |
| 72 | 16 bytes | mac | HMAC-SHA256 of bytes 0-71 with the link key, first 16 bytes; all zero without a key |
| 88 | uint32 | crc32 | zlib CRC-32 of bytes 0-87 |

Command frame, 64 bytes, one per loop tick:

| offset | type | field | unit / meaning |
|---|---|---|---|
| 0 | 4 bytes | magic | ``b"RIGC"`` |
| 4 | uint16 | version | :data:`VERSION` (2) |
| 6 | uint16 | mode | 0 DISARMED (neutral), 1 ACTIVE, 2 SAFE (fault or stale: neutral) |
| 8 | uint32 | seq | command counter, +1 per loop tick |
| 12 | uint32 | echo | seq of the sensor frame this command answers (``NO_ECHO`` = none) |
| 16 | uint32 | session | the loop's session id: random, non-zero, fixed for one run of the loop |
| 20 | 6 x float32 | surfaces | compensator aileron, elevator, rudder, Hawk elevator, aileron, rudder, rad (unused: 0) |
| 44 | 16 bytes | mac | HMAC-SHA256 of bytes 0-43 with the link key, first 16 bytes; all zero without a key |
| 60 | uint32 | crc32 | zlib CRC-32 of bytes 0-59 |

The link key (optional, shared by the loop and the rig, >= 16 bytes: :func:`read_link_key`).  The MAC
field is always present, so the layout does not depend on the key.  With a key, a frame is accepted only
when its MAC equals the HMAC-SHA256 (truncated to 128 bits: forging one takes 2**128 tries) of the
frame before the MAC; without a key, only when the MAC field is all zero (an authenticated frame at a
receiver without a key is refused, so a key on one side only shows at once as refused frames on both).
The CRC is checked first (``crc``: transmission damage), then the MAC (``mac``: not from a key holder).
The MAC covers ``seq`` and ``session``: a receiver that accepts only seqs newer than the last it accepted
(:func:`newer`) and only its own session refuses every replayed frame, from this run or an earlier one.

Sequence numbers compare by serial-number arithmetic (RFC 1982): :func:`newer`.  ``unpack_*`` raise
:class:`FrameError` (a ``ValueError``) with a short ``reason`` (``length``, ``magic``, ``version``, ``crc``,
``mac``, ``nonfinite``, ``mode``) for the counters; ``pack_*_into`` write into a preallocated buffer.
Both ends open their socket with :func:`bind_udp` (a :class:`BindError` says whether the host or the port was refused).
"""

from __future__ import annotations

import errno
import hashlib
import hmac
import math
import os
import socket
import stat
import struct
import zlib
from pathlib import Path
from typing import NamedTuple, Sequence

VERSION = 2
SENSOR_MAGIC, COMMAND_MAGIC = b"RIGS", b"RIGC"
N_JOINTS, N_FLAPS, N_SURFACES = 5, 4, 6
NO_ECHO = 0xFFFFFFFF
STATUS_RIG_FAULT, STATUS_SIMULATED = 1, 2
STATUS_KNOWN = STATUS_RIG_FAULT | STATUS_SIMULATED
MODE_DISARMED, MODE_ACTIVE, MODE_SAFE = 0, 1, 2
MAC_SIZE = 16
KEY_MIN_BYTES = 16

_SENSOR = struct.Struct("<4sHHId5f4ffIII")
_COMMAND = struct.Struct("<4sHHIII6f")
_CRC = struct.Struct("<I")
SENSOR_SIZE = _SENSOR.size + MAC_SIZE + 4  # 92
COMMAND_SIZE = _COMMAND.size + MAC_SIZE + 4  # 64
_ZERO_MAC = bytes(MAC_SIZE)


class FrameError(ValueError):
    """A frame was refused; ``reason`` is one of length, magic, version, crc, mac, nonfinite, mode."""

    def __init__(self, reason: str, msg: str) -> None:
        super().__init__(f"{reason}: {msg}")
        self.reason = reason


class SensorFrame(NamedTuple):
    """A decoded sensor frame (units as in the module table)."""

    seq: int
    rig_time: float  # s
    angles: tuple[float, ...]  # (5,) rad
    flaps: tuple[float, ...]  # (4,) rad
    airspeed: float  # m/s
    status: int
    ack: int
    session: int
    reserved: int


class CommandFrame(NamedTuple):
    """A decoded command frame (units as in the module table)."""

    seq: int
    echo: int
    surfaces: tuple[float, ...]  # (6,) rad
    mode: int
    session: int


def newer(a: int, b: int) -> bool:
    """True when sequence number ``a`` is after ``b`` (mod 2**32, RFC 1982)."""
    d = (a - b) & 0xFFFFFFFF
    return 0 < d < 0x80000000


class BindError(OSError):
    """A UDP socket could not be bound to (``host``, ``port``): errno and message of the cause.

    ``host_refused``: the host is at fault (not a name or address that resolves: ``socket.gaierror``; not an
    address of this machine: EADDRNOTAVAIL); otherwise the port (in use, privileged, ...)."""

    def __init__(self, cause: OSError, host: str, port: int) -> None:
        super().__init__(cause.errno, cause.strerror or str(cause))
        self.host, self.port = host, port
        self.host_refused = isinstance(cause, socket.gaierror) or cause.errno == errno.EADDRNOTAVAIL


def bind_udp(host: str, port: int) -> socket.socket:
    """A non-blocking IPv4 UDP socket bound to (``host``, ``port``; 0: any free port); :class:`BindError` when it cannot be."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except (OSError, OverflowError) as e:  # OverflowError: a port beyond 65535
        sock.close()
        raise BindError(e if isinstance(e, OSError) else OSError(errno.EINVAL, str(e)), host, port) from None
    sock.setblocking(False)
    return sock


def read_link_key(path: str | os.PathLike[str]) -> bytes:
    """The link key in ``path``: hex text (whitespace ignored) or raw bytes, at least 16 bytes; ValueError naming the file otherwise.

    Refused: a missing or unreadable file, a key shorter than :data:`KEY_MIN_BYTES`, a file that group or
    others may read (POSIX; ``chmod 600 FILE``), since whoever reads the key can fly the rig.
    """
    p = Path(path)
    try:
        st = p.stat()
        raw = p.read_bytes()
    except OSError as e:
        raise ValueError(f"link key file {path}: cannot read ({e.strerror})") from None
    if os.name == "posix" and st.st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ValueError(f"link key file {path}: readable by group or others (mode {stat.S_IMODE(st.st_mode):03o}); chmod 600 it")
    text = b"".join(raw.split())
    try:
        key = bytes.fromhex(text.decode("ascii")) if text else b""
    except (UnicodeDecodeError, ValueError):
        key = raw  # not hex: the raw bytes are the key
    if len(key) < KEY_MIN_BYTES:
        raise ValueError(f"link key file {path}: {len(key)} bytes of key, need at least {KEY_MIN_BYTES} (e.g. 32 random bytes as hex)")
    return key


def _mac(key: bytes, body: memoryview) -> bytes:
    return hmac.new(key, body, hashlib.sha256).digest()[:MAC_SIZE]


def _seal(buf: bytearray, n: int, key: bytes | None) -> None:
    """Write the MAC (or zeros) after the ``n`` body bytes, then the CRC over body and MAC."""
    mv = memoryview(buf)
    mv[n : n + MAC_SIZE] = _mac(key, mv[:n]) if key else _ZERO_MAC
    _CRC.pack_into(buf, n + MAC_SIZE, zlib.crc32(mv[: n + MAC_SIZE]))


def pack_sensor_into(buf: bytearray, seq: int, rig_time: float, angles: Sequence[float], flaps: Sequence[float], airspeed: float, status: int = 0,
                     ack: int = NO_ECHO, session: int = 0, key: bytes | None = None, reserved: int = 0) -> None:
    """Write a sensor frame into ``buf`` (>= SENSOR_SIZE bytes). rig_time s; angles: 5 rad; flaps: 4 rad; airspeed m/s."""
    _SENSOR.pack_into(buf, 0, SENSOR_MAGIC, VERSION, reserved, seq & 0xFFFFFFFF, rig_time, *angles, *flaps, airspeed, status,
                      ack & 0xFFFFFFFF, session & 0xFFFFFFFF)
    _seal(buf, _SENSOR.size, key)


def pack_command_into(buf: bytearray, seq: int, echo: int, surfaces: Sequence[float], mode: int, session: int = 0, key: bytes | None = None) -> None:
    """Write a command frame into ``buf`` (>= COMMAND_SIZE bytes). surfaces: up to 6 values, rad."""
    s = list(surfaces) + [0.0] * (N_SURFACES - len(surfaces))
    _COMMAND.pack_into(buf, 0, COMMAND_MAGIC, VERSION, mode, seq & 0xFFFFFFFF, echo & 0xFFFFFFFF, session & 0xFFFFFFFF, *s)
    _seal(buf, _COMMAND.size, key)


def _check(data: bytes | bytearray | memoryview, n: int, st: struct.Struct, magic: bytes, key: bytes | None) -> tuple:
    if len(data) != n:
        raise FrameError("length", f"{len(data)} bytes, expected {n}")
    if bytes(data[:4]) != magic:
        raise FrameError("magic", f"{bytes(data[:4])!r}, expected {magic!r}")
    mv = memoryview(data)
    (crc,) = _CRC.unpack_from(data, st.size + MAC_SIZE)
    if zlib.crc32(mv[: st.size + MAC_SIZE]) != crc:
        raise FrameError("crc", "checksum mismatch (corrupted frame)")
    f = st.unpack_from(data, 0)
    if f[1] != VERSION:
        raise FrameError("version", f"{f[1]}, this loop speaks version {VERSION}")
    got = bytes(mv[st.size : st.size + MAC_SIZE])
    if key:
        if not hmac.compare_digest(got, _mac(key, mv[: st.size])):
            raise FrameError("mac", "wrong or missing MAC (not from a holder of the link key)")
    elif got != _ZERO_MAC:
        raise FrameError("mac", "authenticated frame, but no link key is configured here")
    return f


def unpack_sensor(data: bytes | bytearray | memoryview, key: bytes | None = None) -> SensorFrame:
    """The :class:`SensorFrame` of a valid frame (MAC checked with ``key``; without a key the MAC must be zero)."""
    f = _check(data, SENSOR_SIZE, _SENSOR, SENSOR_MAGIC, key)
    if not all(math.isfinite(v) for v in f[4:15]):
        raise FrameError("nonfinite", "non-finite time or sensor value")
    return SensorFrame(f[3], f[4], f[5:10], f[10:14], f[14], f[15], f[16], f[17], f[2])


def unpack_command(data: bytes | bytearray | memoryview, key: bytes | None = None) -> CommandFrame:
    """The :class:`CommandFrame` of a valid frame (MAC checked with ``key``; without a key the MAC must be zero)."""
    f = _check(data, COMMAND_SIZE, _COMMAND, COMMAND_MAGIC, key)
    if f[2] not in (MODE_DISARMED, MODE_ACTIVE, MODE_SAFE):
        raise FrameError("mode", f"mode {f[2]} unknown")
    if not all(math.isfinite(v) for v in f[6:12]):
        raise FrameError("nonfinite", "non-finite surface command")
    return CommandFrame(f[3], f[4], f[6:12], f[2], f[5])
