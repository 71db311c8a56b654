"""The re-entry policy (ratslam/reentry_policy.py; not in the paper): each rule alone on top of
the paper's re-entries, and the paper's policy (every switch off) accepting what the rule refuses
or holds, at the pose the pose cells give."""

import math

import numpy as np
import pytest

from ratslam import PAPER_REENTRIES, RatSLAMConfig
from ratslam.entry_offset import ON_THE_EXPERIENCE
from ratslam.experience_map import ExperienceMap
from ratslam.reentry_policy import PathBound, Verdict

PAPER = RatSLAMConfig().replace(**PAPER_REENTRIES)
FUSION = RatSLAMConfig().reentry  # the default sigmas: the fusion on


def only(experience_map=None, reentry=None) -> RatSLAMConfig:
    """The paper's re-entries with one rule switched on."""
    return PAPER.replace(experience_map=experience_map or {}, reentry=reentry or PAPER.reentry)


def _started(cfg: RatSLAMConfig, places) -> ExperienceMap:
    """Experience 0 (view 0) created at the origin by eqs 10-11 and current; ``places`` are (x, y,
    view) of experiences 1, 2, ... added at their poses, none linked."""
    em = ExperienceMap(cfg)
    assert em.update(0, np.array([10.0, 10.0, 0.0]), 0) == "create"
    for k, (x, y, view) in enumerate(places, start=1):
        em.add_experience((x, y, 0.0), (10.0 + 4 * x, 10.0 + 4 * y, 0.0), view, k)
    return em


def _drive(em: ExperienceMap, metres: float, ticks: int = 10) -> None:
    for _ in range(ticks):
        em.integrate(1.0, metres / ticks, 0.0)


# --------------------------------------------------------------------------- path bound
def test_path_bound_refuses_a_place_further_than_the_path_driven_plus_the_slack():
    """1 m driven, slack 4 cells of 0.25 m: 2 m is the bound, measured from the prediction."""
    bound = PathBound(PAPER)
    bound.integrate(1.0, 1.0)
    assert bound.slack_m == 1.0 and bound.path_m == 1.0
    assert bound.refuses((0.0, 0.0, 0.0), (1.5, 1.5, 0.0))  # 2.12 m
    assert not bound.refuses((0.0, 0.0, 0.0), (1.9, 0.0, 3.0))  # heading plays no part
    assert not bound.refuses((5.0, 5.0, 0.0), (6.0, 6.0, 0.0))


def test_path_bound_in_the_map_refuses_a_look_alike_the_papers_policy_takes():
    """1 m after the latest re-entry a view of a place 5 m from the prediction: refused with the
    bound, accepted by the paper's policy; a place 1.5 m off is within the bound."""
    bounded = only(experience_map={"relocalise_path_bound": True})
    for cfg, far, near in ((bounded, Verdict.REFUSE, Verdict.ACCEPT), (PAPER, Verdict.ACCEPT, Verdict.ACCEPT)):
        em = _started(cfg, [(6.0, 0.0, 9), (2.5, 0.0, 8)])
        _drive(em, 1.0)
        assert em.reentry.judge(1, ON_THE_EXPERIENCE, 9) is far
        assert em.reentry.judge(2, ON_THE_EXPERIENCE, 8) is near


def test_a_reentry_starts_the_bounds_path_afresh():
    em = _started(only(experience_map={"relocalise_path_bound": True}), [(1.0, 0.0, 9)])
    _drive(em, 1.0)
    assert em.reentry.path_bound.path_m == pytest.approx(1.0)
    assert em.update(1, em.cells[1].copy(), 9) == "switch"
    assert em.reentry.path_bound.path_m == 0.0


# --------------------------------------------------------------------------- loop-closure sequence
SEQUENCE = only(experience_map={"loop_closure_sequence": True})


def test_sequence_holds_one_view_of_an_unlinked_place_the_papers_policy_takes_it():
    for cfg, expected in ((SEQUENCE, Verdict.HOLD), (PAPER, Verdict.ACCEPT)):
        em = _started(cfg, [(4.0, 0.0, 7)])
        _drive(em, 4.0)
        assert em.reentry.judge(1, ON_THE_EXPERIENCE, 7) is expected


def test_sequence_accepts_once_the_next_scene_agrees_with_the_held_candidate():
    """Held at experience 1 (4 m on); 1 m further the next scene's experience 2 lies where 1 and
    the odometry put the robot: accepted. One 2.5 m to the side (beyond the 1 m slack) is held."""
    for side, expected in ((0.0, Verdict.ACCEPT), (2.5, Verdict.HOLD)):
        em = _started(SEQUENCE, [(4.0, 0.0, 7), (5.0, side, 8)])
        _drive(em, 4.0)
        assert em.reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.HOLD
        em.reentry.declined(7)
        cand = em.reentry.sequence.candidate
        assert cand is not None and (cand.experience, cand.view) == (1, 7)
        _drive(em, 1.0)
        assert em.reentry.judge(2, ON_THE_EXPERIENCE, 8) is expected


def test_sequence_accepts_at_once_where_the_links_lead():
    em = _started(SEQUENCE, [(1.0, 0.0, 7)])
    em.add_transition(0, 1, 1.0, 0.0, 0.0, 1.0)
    _drive(em, 1.0)
    assert em.reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.ACCEPT


# --------------------------------------------------------------------------- odometry gate
GATE = only(reentry=FUSION)  # the fusion on, its gate at the default chi2 = 100


def _back_at_the_start(cfg: RatSLAMConfig, place) -> ExperienceMap:
    """80 m driven out and back along x, at the start again; the odometry's model puts the robot
    within 0.7 m; three re-entries showed the odometry keeping to its model."""
    em = _started(cfg, [(*place, 7)])
    for v in [1.0] * 400 + [-1.0] * 400:
        em.integrate(0.1, v, 0.0)
    for _ in range(3):
        em.reentry.fusion.innovations.add(np.array([0.05, 0.05, 0.01]), np.diag([0.01, 0.01, 1e-4]), np.eye(3))
    return em


def test_gate_refuses_a_place_the_odometrys_model_rules_out():
    """8 m to the side after 80 m of odometry good to 0.7 m: d^2 about 130 > 100, refused; 0.3 m
    to the side accepted; without the gate (chi2 inf) or in the paper's policy, accepted."""
    assert _back_at_the_start(GATE, (0.0, 8.0)).reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.REFUSE
    assert _back_at_the_start(GATE, (0.0, 0.3)).reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.ACCEPT
    no_gate = GATE.replace(experience_map={"odometry_gate_chi2": math.inf})
    for cfg in (no_gate, PAPER):
        assert _back_at_the_start(cfg, (0.0, 8.0)).reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.ACCEPT


def test_gate_acts_only_after_three_reentries_and_records_a_refused_scene_once():
    """With ten well-modelled re-entries in the gate's window, the scene refused twice enters its
    scale once; without three re-entries taken the gate does not act."""
    em = _back_at_the_start(GATE, (0.0, 8.0))
    gate = em.reentry.gate
    for _ in range(10):
        gate.scale.add(np.array([0.05, 0.05, 0.01]), np.diag([0.01, 0.01, 1e-4]), np.eye(3))
    assert gate.acts()
    for _ in range(2):
        assert em.reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.REFUSE
    assert gate.scale.count == 11 and gate.view == 7
    em.reentry.fusion.innovations = type(em.reentry.fusion.innovations)(15)
    assert not gate.acts()
    assert em.reentry.judge(1, ON_THE_EXPERIENCE, 7) is Verdict.ACCEPT


# --------------------------------------------------------------------------- fusion
def _fused_offset(cfg: RatSLAMConfig, offset):
    """Experience 0 at the origin, experience 1 a metre on; the robot entered 1 and drove back a
    metre: the map and odometry put it on experience 0; the pose cells at ``offset``."""
    em = _started(cfg, [(1.0, 0.0, 6)])
    _drive(em, 1.0)
    assert em.update(1, em.cells[1].copy(), 6) == "switch"
    _drive(em, -1.0)
    return em.reentry.accept(0, offset)


def test_fusion_keeps_the_odometry_where_it_is_certain_the_papers_policy_the_pose_cells():
    """Two metres of odometry since experience 0 (20 ticks: heading variance 0.002 rad^2, a few
    mm^2 in position) against the view's (5 deg)^2 and (0.25 m)^2: the fused pose lies between
    the two, nearer the odometry's (on experience 0); the paper's policy takes the pose cells'
    offset as it is."""
    offset = (0.25, 0.0, math.radians(10.0))
    fused = _fused_offset(only(reentry=FUSION).replace(experience_map={"odometry_gate_chi2": math.inf}), offset)
    assert 0.0 < fused[0] < 0.1 * offset[0] and 0.0 < fused[2] < 0.3 * offset[2]
    assert _fused_offset(PAPER, offset) == offset


def test_an_accepted_reentry_clears_the_held_candidate():
    em = _started(SEQUENCE, [(4.0, 0.0, 7)])
    _drive(em, 4.0)
    em.reentry.judge(1, ON_THE_EXPERIENCE, 7)
    em.reentry.declined(7)
    assert em.reentry.sequence.candidate is not None
    em.reentry.accept(1, ON_THE_EXPERIENCE)
    assert em.reentry.sequence.candidate is None


def test_policy_state_round_trips():
    """Candidate, paths, gate scale and the visits' noise sums come back from the state."""
    em = _back_at_the_start(GATE.replace(experience_map={"loop_closure_sequence": True}), (0.0, 8.0))
    em.reentry.judge(1, ON_THE_EXPERIENCE, 7)
    em.reentry.declined(7)
    restored = ExperienceMap(em.config)
    restored.set_state(em.get_state())
    a, b = em.reentry, restored.reentry
    assert a.sequence.candidate == b.sequence.candidate
    assert (a.path_bound.path_m, a.sequence.path_m) == (b.path_bound.path_m, b.sequence.path_m)
    assert a.gate.scale.scale == b.gate.scale.scale and a.gate.view == b.gate.view
    np.testing.assert_array_equal(a.visits.view("noise"), b.visits.view("noise"))
