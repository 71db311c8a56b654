"""Test-session settings.

The suite runs on two xdist workers on a 2-core machine. The pose-cell and pose-graph matrices are
small, so OpenBLAS's own threads only contend with the other worker (measured: the small-loop and
GTSAM accuracy modules take 71 s with them, 45 s without). Set before any test module imports numpy.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest


def pytest_configure(config):
    """Compile RatSLAM's numba kernels into numba's disk cache once, before the xdist workers
    start (on a fresh clone they would each compile them, and so would every command a test
    starts before the cache is written); the workers load them from the cache."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return
    from harness.run.workers import warm_kernels

    warm_kernels()


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """Keep each ``xdist_group`` on one worker under pytest 9.

    pytest-xdist's ``--dist loadgroup`` tags a grouped test by appending ``@group`` to
    ``item._nodeid`` on the worker; pytest 9 keeps the node id in ``item._id`` instead, so the tag
    is lost and every figure would run once per worker. Apply the same tag to ``_id``.
    """
    if not (os.environ.get("PYTEST_XDIST_WORKER") and config.getvalue("loadgroup")):
        return
    from _pytest.nodeid import coerce_node_id

    for item in items:
        names = sorted(
            {str(m.args[0] if m.args else m.kwargs.get("name", "default")) for m in item.iter_markers("xdist_group")}
        )
        if names and "@" not in item.nodeid and hasattr(item, "_id"):
            item._id = coerce_node_id(f"{item.nodeid}@{'_'.join(names)}")
