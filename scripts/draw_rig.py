"""Draw the default rig (zero position and a posed example) to docs/rig_frames.png.

The same as ``rig draw --out docs --overwrite`` (it redraws the documentation's picture); extra arguments are
passed on (``--q``, ``--flaps``, ``--out``).
"""

from __future__ import annotations

import sys
from pathlib import Path

from rig_cli.main import main

DOCS = Path(__file__).resolve().parents[1] / "docs"

if __name__ == "__main__":
    raise SystemExit(main(["draw", "--out", str(DOCS), "--overwrite", *sys.argv[1:]]))
