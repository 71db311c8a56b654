"""RatSLAMs sharing one front end (ratslam/front_end.py): stepped through one stream, systems
configured alike in the search, view cells and pose cells compute them once, and each run is the
run it makes alone, bit for bit, through an adopted yaw-rate bias (rebuilt or corrected in place)."""

import numpy as np
import pytest

from harness.run.stream import step_stream
from ratslam import PAPER_REENTRIES, RatSLAM, RatSLAMConfig
from ratslam.front_end import front_end_key, shared_front_ends
from worlds import load_world, simulate

IN_PLACE = RatSLAMConfig().replace(yaw_bias={"rebuild": False})
CONFIGS = {  # two front ends, each shared by two systems whose maps differ
    "defaults": RatSLAMConfig(),
    "paper_reentries": RatSLAMConfig().replace(**PAPER_REENTRIES),
    "in_place": IN_PLACE,
    "in_place_sum": IN_PLACE.replace(experience_map={"energy": "sum", "view_confirm_ticks": 1}),
}


@pytest.fixture(scope="module")
def biased_loop():
    """150 s of the small loop with 1.5 deg/s of yaw-rate bias: the search adopts a bias at tick 658."""
    return simulate(load_world("small_loop"), duration=150.0, seed=0, bias_deg_s=1.5)


def _same_run(a, b) -> None:
    for field in ("pose", "peak_cells", "snapped", "anchor_node", "anchor_offset"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    x, y = a.system, b.system
    assert np.array_equal(x.experience_poses, y.experience_poses)
    assert np.array_equal(x.links, y.links) and np.array_equal(x.link_phi, y.link_phi)
    assert np.array_equal(x.pose_cell_activity, y.pose_cell_activity)
    assert (x.yaw_bias, x.rebuilds) == (y.yaw_bias, y.rebuilds)
    if x.final_anchors is not None:
        assert all(np.array_equal(p, q) for p, q in zip(x.final_anchors, y.final_anchors))


def test_systems_sharing_a_front_end_run_as_each_alone(biased_loop):
    assert len({front_end_key(c) for c in CONFIGS.values()}) == 2
    alone = {name: step_stream(biased_loop, {name: RatSLAM(cfg)})[0][name] for name, cfg in CONFIGS.items()}
    assert alone["defaults"].system.rebuilds == 1 and alone["in_place"].system.yaw_bias != 0.0
    assert not np.array_equal(alone["defaults"].system.links, alone["paper_reentries"].system.links)

    shared = []

    def watch(k, systems):
        if k == 0:
            s = systems
            shared.append(s["paper_reentries"].front_end is s["defaults"].front_end)
            shared.append(s["in_place_sum"].front_end is s["in_place"].front_end)
            shared.append(s["in_place"].front_end is s["defaults"].front_end)

    systems = {name: RatSLAM(cfg) for name, cfg in CONFIGS.items()}
    together, _ = step_stream(biased_loop, systems, on_tick=watch)
    assert shared == [True, True, False]
    for name in CONFIGS:
        _same_run(together[name], alone[name])
    # afterwards each holds a front end of its own: stepped on alone, it goes on as the other would
    assert systems["paper_reentries"].front_end is not systems["defaults"].front_end
    tick = (0.1, 0.3, 0.05, 7)
    systems["paper_reentries"].step(*tick)
    lone = alone["paper_reentries"].system
    lone.step(*tick)
    assert np.array_equal(systems["paper_reentries"].pose_cell_activity, lone.pose_cell_activity)
    assert systems["paper_reentries"].pose == lone.pose


def test_systems_sharing_a_front_end_must_take_the_same_ticks():
    a, b = RatSLAM(), RatSLAM(RatSLAMConfig().replace(**PAPER_REENTRIES))
    with shared_front_ends([a, b]) as followers:
        assert followers == [b]
        a.step(0.1, 0.2, 0.0, 1)
        with pytest.raises(RuntimeError, match="with other inputs"):
            b.step(0.1, 0.3, 0.0, 1)
        b.step(0.1, 0.2, 0.0, 1)
        a.step(0.1, 0.2, 0.0, 1)
        a.step(0.1, 0.2, 0.0, 1)
        with pytest.raises(RuntimeError, match="must take the same ticks"):
            b.step(0.1, 0.2, 0.0, 1)
    c = RatSLAM()
    c.step(0.1, 0.2, 0.0, 1)
    with shared_front_ends([c, RatSLAM()]) as followers:
        assert followers == []  # a system that has stepped shares with none
    d, e = RatSLAM(), RatSLAM()
    e.pose_cells.inject([np.array([3, 4, 5])], 1.0)  # set apart before stepping
    with shared_front_ends([d, e]) as followers:
        assert followers == []


def test_a_system_sharing_a_front_end_is_timed_as_if_alone(biased_loop):
    """The system reading another's front end is charged its time too: the two RatSLAMs' times
    are close (their maps differ), not one of them the map's alone."""
    systems = {name: RatSLAM(CONFIGS[name]) for name in ("defaults", "paper_reentries")}
    traces, _ = step_stream(biased_loop, systems)
    first, second = traces["defaults"].wall_s, traces["paper_reentries"].wall_s
    assert 0.5 * first < second < 2.0 * first, (first, second)
