"""The view gate (ratslam/view_gate.py; not in the paper): view confirmation and snap settling,
each alone, and the paper's (both off) passing every scene at once."""

from ratslam import RatSLAMConfig
from ratslam.view_gate import ViewGate


def gate(confirm: int, settle: int) -> ViewGate:
    return ViewGate(
        RatSLAMConfig().replace(experience_map={"view_confirm_ticks": confirm, "snap_settle_ticks": settle})
    )


def test_a_scene_reaches_the_map_from_its_confirming_tick_on():
    g = gate(confirm=3, settle=0)
    assert [g.confirmed(k, 5, False) for k in range(5)] == [-1, -1, 5, 5, 5]
    assert g.confirmed(5, 6, False) == -1  # a new scene starts its run afresh


def test_a_one_tick_flicker_never_reaches_the_map_the_papers_gate_passes_it():
    for confirm, expected in ((2, [-1, -1, -1, 5]), (1, [5, 9, 5, 5])):
        g = gate(confirm=confirm, settle=0)
        assert [g.confirmed(k, s, False) for k, s in enumerate((5, 9, 5, 5))] == expected


def test_no_scene_reaches_the_map_while_the_peak_settles_after_a_snap():
    """A snap at step 10 with 50 settle ticks: steps 10-59 pass nothing, step 60 the scene; with
    0 settle ticks (the paper) the snap's own tick passes it."""
    g = gate(confirm=1, settle=50)
    passed = [g.confirmed(k, 5, k == 10) for k in range(70)]
    assert passed[:10] == [5] * 10 and passed[10:60] == [-1] * 50 and passed[60:] == [5] * 10
    assert gate(confirm=1, settle=0).confirmed(10, 5, True) == 5


def test_the_gates_state_round_trips():
    g = gate(confirm=2, settle=50)
    g.confirmed(0, 5, True)
    other = gate(confirm=2, settle=50)
    other.set_state(g.get_state())
    assert other.get_state() == (5, 1, 0)
    assert [other.confirmed(k, 5, False) for k in (1, 50)] == [-1, 5]
