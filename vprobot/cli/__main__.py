"""`python -m vprobot.cli`: the `vprobot` command."""

import sys

from vprobot.cli import main

sys.exit(main())
