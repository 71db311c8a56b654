"""Typed run results: metrics.json round trips through them, claims read them (a mistyped name
fails loudly, a missing quantity is "not measurable"), and figures add their own metrics
through the ``extra_metrics`` hook."""

import dataclasses
import json
import math

import pytest

from harness.figures import registry as F
from harness.figures.registry import Claim, Figure, NotMeasurable, Variant, evaluate_claims
from harness.figures.run import replay, run_figure
from harness.report.results import PerTrajectory, ResultsError, RunResult, Timing, VariantResult


def _assert_round_trip(path):
    """Read back, the typed result writes the very same document: keys, order and values."""
    text = path.read_text()
    run = RunResult.from_json(path)
    assert json.dumps(run.to_json(), indent=2, allow_nan=True) + "\n" == text
    again = path.parent / "again.json"
    run.write(again)
    assert again.read_text() == text
    return run


def test_figure_metrics_round_trip(tmp_path):
    # the defaults alone: a minute of the published RatSLAM leaves NaN metrics, written as null
    # (RunResult.write), which read back as unmeasured and so cannot round-trip to the same text
    out = run_figure("fig8", out=tmp_path / "fig8", duration=60.0, show_progress=False, workers=1, ratslam="defaults")
    run = _assert_round_trip(out / "metrics.json")
    assert list(run.variants) == ["paper", "odometric", "odometric_bias_var"]
    v = run.variant("paper")
    assert v.has_ground_truth and v.ate is not None and v.ate.experience_map is not None
    assert v.config is not None and v.config.pi_bias_deg_s == 1.5
    assert run.claims and run.world is not None and run.world.name == "small_loop"


def test_replay_metrics_round_trip_with_and_without_ground_truth(tmp_path):
    from worlds import simulate

    log = simulate("small_loop", duration=60.0, seed=1)
    log.write_csv(tmp_path / "log.csv")
    run = _assert_round_trip(replay(tmp_path / "log.csv", tmp_path / "replay", show_progress=False) / "metrics.json")
    assert run.figure is None and run.title == "replay of log.csv" and run.primary.derived_scale
    # the same log without its ground-truth columns: sizes and timing only, and still a report
    lines = (tmp_path / "log.csv").read_text().splitlines()
    (tmp_path / "bare.csv").write_text("\n".join(",".join(ln.split(",")[:5]) for ln in lines) + "\n")
    out = replay(tmp_path / "bare.csv", tmp_path / "bare", show_progress=False)
    bare = _assert_round_trip(out / "metrics.json").primary
    assert not bare.has_ground_truth and bare.ate is None and bare.loop_closures_proposed is not None
    assert "multiple_representations" not in json.loads((out / "metrics.json").read_text())["variants"]["replay"]
    assert "No ground truth" in (out / "report.md").read_text()
    # the report is redrawn from maps.npz alone (the trajectories are not needed); a damaged
    # maps.npz makes it a one-line error, not a traceback
    from harness.report.run_report import ReportError, write_report

    (tmp_path / "replay" / "trajectories" / "odometry.tum").write_text("1 2 3\n")
    write_report(tmp_path / "replay")
    (tmp_path / "replay" / "maps.npz").write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(ReportError, match=r"maps\.npz: cannot be read"):
        write_report(tmp_path / "replay")


def test_a_file_that_is_not_a_runs_metrics_is_a_one_line_error(tmp_path):
    (tmp_path / "metrics.json").write_text('{"figure": null}')
    with pytest.raises(ResultsError, match="not a run's metrics") as e:
        RunResult.from_json(tmp_path / "metrics.json")
    assert "\n" not in str(e.value)
    (tmp_path / "metrics.json").write_text("{")
    with pytest.raises(ResultsError, match="cannot be read as JSON"):
        RunResult.from_json(tmp_path / "metrics.json")


# --- claims ----------------------------------------------------------------------------------


def _run(**variant_fields) -> RunResult:
    timing = Timing(1.0, 1.0, 0.0, 900.0, 7000.0, 900.0, 7000.0)
    fields = dict(
        ticks=10,
        simulated_s=1.0,
        snaps=2,
        experiences=3,
        links=2,
        timing=timing,
        ate=PerTrajectory(odometry=1.0, ratslam_online=0.2, pose_cell_path=3.0, experience_map=0.1),
        alignment_yaw_deg=PerTrajectory(odometry=0.0, ratslam_online=0.0, pose_cell_path=0.0, experience_map=5.0),
    )
    fields.update(variant_fields)
    return RunResult(figure=None, variants={"default": VariantResult(**fields)}, duration_s=1.0)


def test_claims_read_the_typed_result():
    fig = F.get_figure("fig4")
    results = {c.key: c for c in evaluate_claims(fig, _run(multiple_representations=1, hash_collisions=0))}
    assert results["snaps"].measured == "snaps = 2 (need >= 1)" and results["snaps"].held
    assert not results["hash_collision"].held
    assert results["experience_map_consistent"].measured == "experience_map ATE 0.100 m (bound 0.5 m)"


@pytest.mark.parametrize(
    "make",
    [
        lambda: F.ate_at_most("default", "experiance_map", 0.3, "typo", "k"),
        lambda: F.ratio_at_least("default", "odometry", "gtsam_onlin", 5.0, "typo", "k"),
        lambda: F.count_at_least("default", "snap", 1, "typo", "k"),
        lambda: F._register(
            Figure("x", "x", "small_loop", 60.0, claims=(F.ate_at_most("paper", "gtsam", 0.3, "typo", "k"),))
        ),
    ],
    ids=["trajectory", "ratio_trajectory", "count", "variant"],
)
def test_a_mistyped_name_fails_at_definition(make):
    with pytest.raises(ValueError, match="unknown"):
        make()
    assert "x" not in F.FIGURES


def test_a_mistyped_attribute_raises_on_first_use():
    """A claim reading a name the typed result does not have is a bug: it raises, it is not
    reported as a claim that did not hold."""
    fig = Figure(
        "x",
        "x",
        "small_loop",
        60.0,
        claims=(Claim("k", "typo", lambda run: ("", run.primary.ate.experiance_map <= 0.3)),),
    )
    with pytest.raises(AttributeError, match="experiance_map"):
        evaluate_claims(fig, _run())
    with pytest.raises(KeyError, match="no variant 'paper'"):
        evaluate_claims(
            Figure("x", "x", None, None, claims=(Claim("k", "s", lambda r: ("", r.variant("paper").snaps > 0)),)),
            _run(),
        )


@pytest.mark.parametrize(
    "run, reason",
    [
        (_run(ate=PerTrajectory(odometry=1.0, ratslam_online=0.2, pose_cell_path=3.0)), "no experience_map ATE"),
        (
            _run(ate=PerTrajectory(odometry=1.0, ratslam_online=0.2, pose_cell_path=3.0, experience_map=math.nan)),
            "experience_map ATE is NaN",
        ),
        (_run(ate=None, alignment_yaw_deg=None), "no ground truth"),
    ],
    ids=["no_experiences", "nan", "no_ground_truth"],
)
def test_a_missing_quantity_is_not_measurable(run, reason):
    fig = Figure("x", "x", "small_loop", 60.0, claims=(F.ate_at_most("default", "experience_map", 0.3, "s", "k"),))
    (result,) = evaluate_claims(fig, run)
    assert result.measured == f"not measurable ({reason})" and not result.held


def test_a_claim_on_a_variant_not_run_is_not_measurable():
    fig = Figure("x", "x", "small_loop", 60.0, claims=(F.count_at_least("paper", "snaps", 1, "s", "k"),))
    (result,) = evaluate_claims(fig, _run())
    assert result.measured == "not measurable (variant paper not run)" and not result.held


def test_not_measurable_is_the_only_exception_a_claim_may_raise():
    def check(run):
        raise NotMeasurable("laps not found")

    (result,) = evaluate_claims(Figure("x", "x", None, None, claims=(Claim("k", "s", check),)), _run())
    assert result.measured == "not measurable (laps not found)"
    with pytest.raises(ZeroDivisionError):
        evaluate_claims(Figure("x", "x", None, None, claims=(Claim("k", "s", lambda r: ("", 1 / 0 > 0)),)), _run())


# --- the extra-metrics hook ------------------------------------------------------------------


def test_extra_metrics_hook(tmp_path, monkeypatch):
    """A figure's own metrics come from its ``extra_metrics`` hook: per variant, and the primary's
    at the top level, where its claims read them."""
    from ratslam import RatSLAMConfig
    from worlds import ObservationLog

    seen = []

    def hook(res, log, config):
        assert isinstance(log, ObservationLog) and isinstance(config, RatSLAMConfig)
        seen.append(len(res.snapped))
        return {"laps": {"count": 2, "ticks": len(log)}}

    claim = Claim(
        "laps", "Two laps.", lambda run: (f"{run.extras['laps']['count']} laps", run.extras["laps"]["count"] == 2)
    )
    fig = dataclasses.replace(
        F.get_figure("fig7"),
        name="fig7_hook",
        variants=(
            Variant("default", "no bias"),
            Variant("biased", "1.5 deg/s", ratslam={"pose_cells": {"path_integration_bias_deg_s": 1.5}}),
        ),
        claims=(claim,),
        extra_metrics=hook,
    )
    monkeypatch.setitem(F.FIGURES, fig.name, fig)
    out = run_figure(fig.name, out=tmp_path / "run", duration=30.0, show_progress=False, workers=1)
    doc = json.loads((out / "metrics.json").read_text())
    assert seen == [210] * 4  # each variant's stream, RatSLAM's defaults and the published preset
    assert doc["laps"] == {"count": 2, "ticks": 210} == doc["variants"]["biased"]["laps"]
    assert doc["published"]["laps"] == doc["laps"] and doc["published"]["claims"][0]["held"]
    assert list(doc).index("laps") == list(doc).index("variants") + 1
    assert doc["claims"][0]["measured"] == "2 laps" and doc["claims"][0]["held"]
    assert RunResult.from_json(out / "metrics.json").variant("biased").extras == {"laps": doc["laps"]}


def test_fig11_room_laps_come_from_its_hook():
    assert F.get_figure("fig11").extra_metrics is not None
    assert all(F.get_figure(n).extra_metrics is None for n in F.FIGURES if n != "fig11")


def test_extras_cannot_overwrite_standard_metrics():
    with pytest.raises(ValueError, match="overwrite"):
        _run(extras={"snaps": 3}).to_json()
