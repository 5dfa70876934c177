"""Deploy a law to the rig: the same as the ``rig-deploy`` console command (see controllers.deploy.cli).

Usage: python scripts/deploy.py {export,verify,run,sim-rig} ...
"""

from __future__ import annotations

from controllers.deploy.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
