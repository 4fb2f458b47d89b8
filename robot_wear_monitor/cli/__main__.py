"""``python3 -m robot_wear_monitor.cli``: the ``robot-wear-monitor`` command line."""

import sys

from robot_wear_monitor.cli import main

sys.exit(main())
