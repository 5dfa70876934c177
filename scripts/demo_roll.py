"""Velocity-vector roll demo: the same as ``rig demo`` (see rig_cli.main.demo_roll).

Usage: python scripts/demo_roll.py [--out DIR] [--t-final S] [--airspeed M/S] [--aileron DEG] [--no-plot] [--quiet] [--overwrite]
"""

from __future__ import annotations

import sys

from rig_cli.main import main

if __name__ == "__main__":
    raise SystemExit(main(["demo", *sys.argv[1:]]))
