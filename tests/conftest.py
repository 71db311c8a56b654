"""Test-session settings.

The suite runs on two xdist workers on a 2-core machine. The pose-cell and pose-graph matrices are
small, so OpenBLAS's own threads only contend with the other worker (measured: the small-loop and
GTSAM accuracy modules take 71 s with them, 45 s without). Set before any test module imports numpy.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
