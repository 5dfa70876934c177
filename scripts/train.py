"""Train PPO or SAC on a rig task: the same as ``rig train`` (see ``rig train --help``).

Usage: python scripts/train.py --algo ppo|sac --task NAME [...]; runs :func:`controllers.design.rl_train.main`.
"""

import sys

from controllers.design.rl_train import main

if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
