"""Test-session settings.

The suite runs on two xdist workers on a 2-core machine. The pose-cell and pose-graph matrices are
small, so OpenBLAS's own threads only contend with the other worker (measured: the small-loop and
GTSAM accuracy modules take 71 s with them, 45 s without). Set before any test module imports numpy.
"""

import os
from collections import Counter

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest


def pytest_configure(config):
    """Compile RatSLAM's numba kernels into numba's disk cache once, before the xdist workers
    start (on a fresh clone they would each compile them, and so would every command a test
    starts before the cache is written); the workers load them from the cache."""
    if os.environ.get("PYTEST_XDIST_WORKER") or config.option.collectonly:
        return
    from harness.run.workers import warm_kernels

    warm_kernels()


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """Keep each ``xdist_group`` on one worker under pytest 9, a module's other tests together, and
    hand the workers the explicit groups first.

    pytest-xdist's ``--dist loadgroup`` tags a grouped test by appending ``@group`` to
    ``item._nodeid`` on the worker; pytest 9 keeps the node id in ``item._id`` instead, so the tag
    is lost and every figure would run once per worker. Apply the same tag to ``_id``. A test in no
    group is tagged with its module: the runs a module computes once and shares among its tests
    (module fixtures and caches) are then computed on one worker, not once on each. The workers
    take the groups in the order of the items (``--no-loadscope-reorder``): the explicit groups
    (a figure's long run, the 2.5-hour navigation) first, as collected, then the modules with slow
    tests, then the others, those with the most tests first: no worker is left with a long group
    at the end.
    """
    if not (os.environ.get("PYTEST_XDIST_WORKER") and config.getvalue("loadgroup")):
        return
    from _pytest.nodeid import coerce_node_id

    groups = {}
    for item in items:
        names = sorted(
            {str(m.args[0] if m.args else m.kwargs.get("name", "default")) for m in item.iter_markers("xdist_group")}
        )
        groups[item] = ("_".join(names), True) if names else (item.path.stem, False)
        if "@" not in item.nodeid and hasattr(item, "_id"):
            item._id = coerce_node_id(f"{item.nodeid}@{groups[item][0]}")
    size = Counter(name for name, _ in groups.values())
    slow = {groups[item][0] for item in items if item.get_closest_marker("slow")}
    first = {}
    for i, item in enumerate(items):
        first.setdefault(groups[item][0], i)

    def order(item):
        name, explicit = groups[item]
        return (0, False, 0, first[name]) if explicit else (1, name not in slow, -size[name], first[name])

    items.sort(key=order)
