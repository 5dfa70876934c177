"""A fake rig for the deployment tests: 80 Hz sensor frames of a slowly rocking rig over loopback UDP.

It serves whoever sent the first datagram, in that sender's session, acknowledging each command it
receives (protocol 2), and records every command as (mode, surfaces rad).
"""

from __future__ import annotations

import math
import socket
import threading
import time

from controllers.deploy import protocol as pr


class FakeRig:
    """Sensor frames at ``rate`` Hz to the first sender; ``commands``: (mode, surfaces) of each command received."""

    def __init__(self, rate: float = 80.0) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.002)
        self.port = self.sock.getsockname()[1]
        self.period = 1.0 / rate
        self.commands: list[tuple[int, tuple[float, ...]]] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    @property
    def modes(self) -> dict[int, int]:
        """Commands received, counted by mode."""
        out: dict[int, int] = {}
        for mode, _ in list(self.commands):
            out[mode] = out.get(mode, 0) + 1
        return out

    def _run(self) -> None:
        buf = bytearray(pr.SENSOR_SIZE)
        peer, seq, t0, nxt, ack, session = None, 0, None, 0.0, pr.NO_ECHO, 0
        deadline = time.monotonic() + 90.0  # never outlives the test
        while not self.stop.is_set() and time.monotonic() < deadline:
            try:
                data, addr = self.sock.recvfrom(256)
                peer = addr
                try:
                    c = pr.unpack_command(data)
                    self.commands.append((c.mode, c.surfaces))
                    ack, session = c.seq, c.session  # serve its session, acknowledge its commands
                except pr.FrameError:
                    pass
            except (TimeoutError, BlockingIOError):
                pass
            now = time.monotonic()
            if peer is not None and now >= nxt:
                t0 = now if t0 is None else t0
                w = math.sin(3.0 * (now - t0))  # every joint moves a little: the stuck-sensor watchdog stays quiet
                angles = (0.01 * w, 0.002 * w, 0.003 * w, 0.02 + 0.004 * w, 0.005 * w)
                pr.pack_sensor_into(buf, seq, now - t0, angles, (0.0,) * 4, 20.0, pr.STATUS_SIMULATED, ack=ack, session=session)
                self.sock.sendto(buf, peer)
                seq += 1
                nxt = now + self.period

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=5)
        self.sock.close()
