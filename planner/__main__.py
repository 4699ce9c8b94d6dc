"""Run the planner from the command line: ``python -m planner --help``."""

import sys

from planner.cli import main

sys.exit(main())
