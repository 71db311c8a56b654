"""harness.report.compare_metrics: the check that a refactoring leaves every figure's metrics unchanged."""

import json

from harness.report.compare_metrics import compare_trees, differences

BASE = {
    "variants": {"default": {"ate": {"odometry": 0.15, "gtsam": 0.09}, "timing": {"ratslam_s": 1.1}}},
    "claims": [
        {"key": "loop", "measured": "ATE 0.164 m", "held": True},
        {"key": "real_time", "measured": "x582 real time", "held": True},
    ],
    "provenance": {"created_utc": "2026-01-01"},
}


def _changed(**edits):
    doc = json.loads(json.dumps(BASE))
    for path, value in edits.items():
        *keys, last = path.split("/")
        node = doc
        for k in keys:
            node = node[int(k)] if isinstance(node, list) else node[k]
        node[last if not isinstance(node, list) else int(last)] = value
    return doc


def test_wall_times_and_provenance_are_ignored():
    other = _changed(
        **{
            "variants/default/timing/ratslam_s": 9.9,
            "provenance/created_utc": "x",
            "claims/1/measured": "x600 real time",
        }
    )
    assert differences(BASE, other) == []


def test_any_metric_change_is_reported_with_its_path():
    assert differences(BASE, _changed(**{"variants/default/ate/gtsam": 0.0900001})) == [
        "/variants/default/ate/gtsam: 0.09 vs 0.0900001"
    ]
    assert differences(BASE, _changed(**{"claims/0/measured": "ATE 0.165 m"})) == [
        "/claims[0]/measured: 'ATE 0.164 m' vs 'ATE 0.165 m'"
    ]
    assert differences(BASE, _changed(**{"claims/1/held": False})) == ["/claims[1]/held: True vs False"]


def test_missing_keys_and_files_are_reported(tmp_path):
    (tmp_path / "a" / "run").mkdir(parents=True)
    (tmp_path / "b").mkdir()
    (tmp_path / "a" / "run" / "metrics.json").write_text(json.dumps(BASE))
    assert compare_trees(tmp_path / "a", tmp_path / "b") == [f"run/metrics.json: missing in {tmp_path / 'b'}"]
    short = json.loads(json.dumps(BASE))
    del short["variants"]["default"]["ate"]["gtsam"]
    assert differences(BASE, short) == ["/variants/default/ate/gtsam: only in first"]
