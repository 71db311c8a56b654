"""``python -m harness.cli``: the ``ratslam-harness`` command."""

import sys

from . import main

sys.exit(main())
