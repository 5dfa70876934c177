"""``python -m rig_cli ...`` = the ``rig`` command."""

from rig_cli.main import main

raise SystemExit(main())
