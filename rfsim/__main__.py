"""``python -m rfsim`` = the ``rfsim`` command."""

import sys

from rfsim.cli import main

sys.exit(main())
