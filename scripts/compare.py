"""Compare every control law on every task: ``python scripts/compare.py [--quick] [--out DIR] ...``.

The same as ``rig compare`` (see ``rig compare --help``); runs :func:`rig_env.cli.main`.
"""

import sys

from rig_env.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["compare", *sys.argv[1:]]))
