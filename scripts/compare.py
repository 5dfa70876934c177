"""Compare every control law on every task: ``python scripts/compare.py [--quick] [--out DIR] ...``.

The same as ``rig compare`` (see ``rig compare --help``); runs :func:`rig_cli.main.main`.
"""

import sys

from rig_cli.main import main

if __name__ == "__main__":
    raise SystemExit(main(["compare", *sys.argv[1:]]))
