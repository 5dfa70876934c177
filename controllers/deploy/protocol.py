"""The rig link's binary protocol: sensor frames (rig -> loop) and command frames (loop -> rig), UDP, little-endian.

Sensor frame, 68 bytes, one per rig tick (80 Hz pilot rig, ~244 Hz later rig):

| offset | type | field | unit / meaning |
|---|---|---|---|
| 0 | 4 bytes | magic | ``b"RIGS"`` |
| 4 | uint16 | version | :data:`VERSION` (1) |
| 6 | uint16 | reserved | 0 |
| 8 | uint32 | seq | frame counter, +1 per rig tick, wraps at 2**32 |
| 12 | float64 | rig_time | rig clock, s |
| 20 | 5 x float32 | angles | rig_roll, rig_pitch, rig_yaw, model_pitch, model_yaw, rad (locked joints: their lock angle) |
| 40 | 4 x float32 | flaps | compensator flaps 1-4 (encoders), rad |
| 56 | float32 | airspeed | m/s |
| 60 | uint32 | status | bit 0 RIG_FAULT (e-stop / rig-side fault), bit 1 SIMULATED; others 0 |
| 64 | uint32 | crc32 | zlib CRC-32 of bytes 0-63 |

Command frame, 44 bytes, one per loop tick:

| offset | type | field | unit / meaning |
|---|---|---|---|
| 0 | 4 bytes | magic | ``b"RIGC"`` |
| 4 | uint16 | version | :data:`VERSION` (1) |
| 6 | uint16 | mode | 0 DISARMED (neutral), 1 ACTIVE, 2 SAFE (fault or stale: neutral) |
| 8 | uint32 | seq | command counter, +1 per loop tick |
| 12 | uint32 | echo | seq of the sensor frame this command answers (``NO_ECHO`` = none) |
| 16 | 6 x float32 | surfaces | compensator aileron, elevator, rudder, Hawk elevator, aileron, rudder, rad (unused: 0) |
| 40 | uint32 | crc32 | zlib CRC-32 of bytes 0-39 |

Sequence numbers compare by serial-number arithmetic (RFC 1982): :func:`newer`.  ``unpack_*`` raise
:class:`FrameError` (a ``ValueError``) with a short ``reason`` (``length``, ``magic``, ``version``, ``crc``,
``nonfinite``) for the loop's counters; ``pack_*_into`` write into a preallocated buffer.
"""

from __future__ import annotations

import math
import struct
import zlib
from typing import Sequence

VERSION = 1
SENSOR_MAGIC, COMMAND_MAGIC = b"RIGS", b"RIGC"
N_JOINTS, N_FLAPS, N_SURFACES = 5, 4, 6
NO_ECHO = 0xFFFFFFFF
STATUS_RIG_FAULT, STATUS_SIMULATED = 1, 2
MODE_DISARMED, MODE_ACTIVE, MODE_SAFE = 0, 1, 2

_SENSOR = struct.Struct("<4sHHId5f4ffI")
_COMMAND = struct.Struct("<4sHHII6f")
_CRC = struct.Struct("<I")
SENSOR_SIZE = _SENSOR.size + 4  # 68
COMMAND_SIZE = _COMMAND.size + 4  # 44


class FrameError(ValueError):
    """A frame was refused; ``reason`` is one of length, magic, version, crc, nonfinite, mode."""

    def __init__(self, reason: str, msg: str) -> None:
        super().__init__(f"{reason}: {msg}")
        self.reason = reason


def newer(a: int, b: int) -> bool:
    """True when sequence number ``a`` is after ``b`` (mod 2**32, RFC 1982)."""
    d = (a - b) & 0xFFFFFFFF
    return 0 < d < 0x80000000


def pack_sensor_into(buf: bytearray, seq: int, rig_time: float, angles: Sequence[float], flaps: Sequence[float], airspeed: float, status: int = 0) -> None:
    """Write a sensor frame into ``buf`` (>= SENSOR_SIZE bytes). angles: 5 rad; flaps: 4 rad."""
    _SENSOR.pack_into(buf, 0, SENSOR_MAGIC, VERSION, 0, seq & 0xFFFFFFFF, rig_time, *angles, *flaps, airspeed, status)
    _CRC.pack_into(buf, _SENSOR.size, zlib.crc32(memoryview(buf)[: _SENSOR.size]))


def pack_command_into(buf: bytearray, seq: int, echo: int, surfaces: Sequence[float], mode: int) -> None:
    """Write a command frame into ``buf`` (>= COMMAND_SIZE bytes). surfaces: up to 6 values, rad."""
    s = list(surfaces) + [0.0] * (N_SURFACES - len(surfaces))
    _COMMAND.pack_into(buf, 0, COMMAND_MAGIC, VERSION, mode, seq & 0xFFFFFFFF, echo & 0xFFFFFFFF, *s)
    _CRC.pack_into(buf, _COMMAND.size, zlib.crc32(memoryview(buf)[: _COMMAND.size]))


def _check(data: bytes | bytearray | memoryview, n: int, st: struct.Struct, magic: bytes) -> tuple:
    if len(data) != n:
        raise FrameError("length", f"{len(data)} bytes, expected {n}")
    if bytes(data[:4]) != magic:
        raise FrameError("magic", f"{bytes(data[:4])!r}, expected {magic!r}")
    (crc,) = _CRC.unpack_from(data, st.size)
    if zlib.crc32(memoryview(data)[: st.size]) != crc:
        raise FrameError("crc", "checksum mismatch (corrupted frame)")
    f = st.unpack_from(data, 0)
    if f[1] != VERSION:
        raise FrameError("version", f"{f[1]}, this loop speaks version {VERSION}")
    return f


def unpack_sensor(data: bytes | bytearray | memoryview) -> tuple[int, float, tuple[float, ...], tuple[float, ...], float, int]:
    """(seq, rig_time s, angles (5,) rad, flaps (4,) rad, airspeed m/s, status) of a valid frame."""
    f = _check(data, SENSOR_SIZE, _SENSOR, SENSOR_MAGIC)
    vals = f[4:15]
    if not all(math.isfinite(v) for v in vals):
        raise FrameError("nonfinite", "non-finite time or sensor value")
    return f[3], f[4], f[5:10], f[10:14], f[14], f[15]


def unpack_command(data: bytes | bytearray | memoryview) -> tuple[int, int, tuple[float, ...], int]:
    """(seq, echo, surfaces (6,) rad, mode) of a valid frame."""
    f = _check(data, COMMAND_SIZE, _COMMAND, COMMAND_MAGIC)
    if f[2] not in (MODE_DISARMED, MODE_ACTIVE, MODE_SAFE):
        raise FrameError("mode", f"mode {f[2]} unknown")
    if not all(math.isfinite(v) for v in f[5:11]):
        raise FrameError("nonfinite", "non-finite surface command")
    return f[3], f[4], f[5:11], f[2]
