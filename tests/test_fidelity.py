"""The fidelity study's configurations are what they claim, and its probe does not change RatSLAM."""

from __future__ import annotations

import numpy as np
import pytest

from harness.figures import fidelity
from ratslam import RatSLAM, RatSLAMConfig
from ratslam.published import departures


@pytest.mark.parametrize("figure", ["fig7", "fig8", "fig4"])
def test_each_configuration_differs_in_exactly_its_switch(figure):
    base = fidelity.figure_base(figure)
    published = RatSLAMConfig.published(base)
    configs = fidelity.configurations(base)
    assert fidelity.differing_fields(configs["published"], published) == set()
    assert fidelity.differing_fields(configs["defaults"], base) == set()
    for s in fidelity.switches():
        fields = set(s.on)
        on_top = configs[f"published{'-' if s.local_view else '+'}{s.name}"]
        removed = configs[f"defaults-{s.name}"]
        assert fidelity.differing_fields(on_top, published) == fields, s.name
        assert fidelity.differing_fields(removed, base) == fields, s.name
        for f in fields:
            section, name = f.split(".")
            if s.local_view:  # switched off in both
                assert getattr(getattr(on_top, section), name) == s.off[f]
            else:  # the departure's value on the preset, the preset's value on the defaults
                assert getattr(getattr(on_top, section), name) == getattr(getattr(base, section), name)
                assert getattr(getattr(removed, section), name) == getattr(getattr(published, section), name)
            assert getattr(getattr(removed, section), name) == s.off[f]
    pair = configs["published+reentry_fusion+gate"]
    assert fidelity.differing_fields(pair, published) == {
        "reentry.position_sigma_m",
        "reentry.heading_sigma_deg",
        "experience_map.odometry_gate_chi2",
    }
    assert configs["published"].pose_cells.path_integration_bias_deg_s == base.pose_cells.path_integration_bias_deg_s


def test_every_departure_is_one_switch():
    paths = {d.split(" = ")[0] for d in departures(RatSLAMConfig())}
    departure_fields = [f for s in fidelity.switches() if not s.local_view for f in s.on]
    assert sorted(departure_fields) == sorted(paths)  # each once, none missing
    assert {s.name for s in fidelity.switches() if s.local_view} == {"fatigue", "min_age"}


def test_scene_run_lengths():
    runs = fidelity.scene_run_lengths(np.array([5, 5, 7, -1, -1, -1, 5]))
    assert runs.tolist() == [2, 2, 1, 3, 3, 3, 1]


def test_probe_is_ratslam_unchanged_and_counts_its_switches():
    log = fidelity.figure_stream("fig7", seed=0, duration=90.0)
    cfg = RatSLAMConfig.published(fidelity.figure_base("fig7"))
    plain, probe = RatSLAM(cfg), fidelity.Probe(cfg)
    for dt, v, w, s in zip(log.dt, log.v_trans, log.v_rot, log.scene_id):
        plain.step(dt, v, w, s)
        probe.step(dt, v, w, s)
    np.testing.assert_array_equal(probe.experience_poses, plain.experience_poses)
    kinds = [e[1] for e in probe.events]
    assert kinds.count(0) == len(probe.experience_poses)  # every experience, the first included
    assert kinds.count(1) > 0  # the published map re-enters within 90 s of the loop
    rows = fidelity.run_configs(log, {"published": cfg}, {"figure": "fig7", "seed": 0, "scenes": "world"})
    assert rows[0]["reentries"] == kinds.count(1)
    assert rows[0]["experiences"] == len(plain.experience_poses)
    assert 0.9 < rows[0]["pc_gain"] < 1.1
