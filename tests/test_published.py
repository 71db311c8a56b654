"""RatSLAM as published: the preset's table covers every field, the docs show it, and the preset
reaches a run through the API, a configuration file, a sweep spec and the CLI."""

import json
from pathlib import Path

import pytest

from harness.figures.stream_run import ratslam_settings
from harness.run.config_file import ConfigFileError, read_config_file
from harness.sweeps.spec import SweepSpecError, read_sweep_spec
from ratslam import PAPER_REENTRIES, PoseCellConfig, RatSLAMConfig
from ratslam.published import PUBLISHED, SCALE, departures, field_paths, markdown_table

DOCS = Path(__file__).resolve().parent.parent / "docs" / "configuration.md"


def test_every_field_has_a_published_reading():
    """Each RatSLAMConfig field has the preset's value and its source; a new field without one fails."""
    assert list(PUBLISHED) == field_paths(RatSLAMConfig)
    for path, reading in PUBLISHED.items():
        assert reading.source and reading.note, path


def test_docs_list_every_field_with_its_published_value():
    """docs/configuration.md holds the preset's table as the code has it (every field, value, source)."""
    text = DOCS.read_text()
    assert markdown_table() in text
    for path in field_paths(RatSLAMConfig):
        assert f"| `{path}` |" in text, path


def test_published_preset_is_the_paper_and_keeps_the_scale():
    base = RatSLAMConfig(pose_cells=PoseCellConfig(nx=40, ny=40, cell_size_m=0.5, path_integration_bias_deg_s=3.0))
    pub = RatSLAMConfig.published(base)
    assert departures(pub) == []
    assert (pub.pose_cells.nx, pub.pose_cells.cell_size_m, pub.pose_cells.path_integration_bias_deg_s) == (40, 0.5, 3.0)
    assert pub.experience_map.energy == "sum" and pub.pose_cells.trans_gain == 1.0
    assert not pub.yaw_bias.search and not pub.reentry.enabled
    # the defaults depart in exactly the fields the paper does not have
    assert {d.split(" ")[0] for d in departures(RatSLAMConfig())} == {
        "pose_cells.trans_gain",
        "experience_map.view_confirm_ticks",
        "experience_map.snap_settle_ticks",
        "experience_map.offset_transitions",
        "experience_map.energy",
        "experience_map.relocalise_path_bound",
        "experience_map.loop_closure_sequence",
        "experience_map.odometry_gate_chi2",
        "reentry.position_sigma_m",
        "reentry.heading_sigma_deg",
        "yaw_bias.search",
    }
    assert all(PUBLISHED[f"{s}.{k}"].source != SCALE for s, d in PAPER_REENTRIES.items() for k in d)


def test_a_preset_never_overwrites_a_derived_value_silently():
    """Values derived from a log (or given) that the preset replaces are named in the run's note."""
    derived = RatSLAMConfig().replace(pose_cells={"trans_gain": 1.02, "cell_size_m": 0.4})
    cfg, alternatives, notes = ratslam_settings(derived, "published", "Derived: ...")
    assert cfg.pose_cells.trans_gain == 1.0 and cfg.pose_cells.cell_size_m == 0.4
    assert alternatives == {} and "pose_cells.trans_gain = 1.02 (published: 1.0)" in notes[""]
    cfg, alternatives, notes = ratslam_settings(derived, "both", "Derived: ...")
    assert cfg == derived and alternatives["published"].pose_cells.trans_gain == 1.0
    assert notes[""] == "Derived: ..." and "trans_gain = 1.02" in notes["published"]
    assert ratslam_settings(derived, "defaults", "x") == (derived, {}, {"": "x"})


def test_config_file_preset_then_its_fields(tmp_path):
    """``preset = "published"`` in a file: the paper's algorithm, the file's fields on top."""
    f = tmp_path / "c.toml"
    f.write_text('[ratslam]\npreset = "published"\n[ratslam.experience_map]\nenergy = "product"\n')
    rs, _ = read_config_file(f).apply(RatSLAMConfig(), __import__("baselines").PoseGraphConfig())
    assert [d.split(" ")[0] for d in departures(rs)] == ["experience_map.energy"]
    f.write_text('[ratslam]\npreset = "paper"\n')
    with pytest.raises(ConfigFileError, match=r"c\.toml: \[ratslam\] preset: expected one of 'published'"):
        read_config_file(f)


def test_sweep_system_preset(tmp_path):
    spec = tmp_path / "s.toml"
    body = '[base]\nworld = "small_loop"\nduration = 30.0\n[axes]\nfp_rate = [0.0]\n[seeds]\ncount = 1\n'
    spec.write_text(body + '[systems.paper]\nsystem = "ratslam"\npreset = "published"\n')
    (system,) = read_sweep_spec(spec).systems
    assert departures(system.config) == []
    spec.write_text(body + '[systems.g]\nsystem = "gtsam"\npreset = "published"\n')
    with pytest.raises(SweepSpecError, match=r"\[systems\.g\] preset"):
        read_sweep_spec(spec)


@pytest.mark.slow
def test_run_both_ways_from_the_cli(tmp_path):
    """``run FIG`` runs the published RatSLAM beside the defaults on each variant's stream (GTSAM
    once: the same pose-graph metrics) and judges every claim for both; ``--ratslam published``
    runs the paper's algorithm alone."""
    from harness.cli import main

    out = tmp_path / "both"
    assert main(["run", "fig8", "--out", str(out), "--duration", "60", "--quiet", "--no-recording"]) in (0, None)
    doc = json.loads((out / "metrics.json").read_text())
    pub = doc["published"]
    assert set(pub["variants"]) == set(doc["variants"])
    for name, v in doc["variants"].items():
        p = pub["variants"][name]
        assert p["ate"]["gtsam"] == v["ate"]["gtsam"] and p["ate"]["odometry"] == v["ate"]["odometry"]
        assert departures(RatSLAMConfig.published()) == []
        assert p["config"]["ratslam"]["experience_map"]["energy"] == "sum"
    assert [c["key"] for c in pub["claims"]] == [c["key"] for c in doc["claims"]]
    assert "| claim | project defaults | held | as published | held |" in (out / "report.md").read_text()
    assert (out / "variants" / "odometric" / "c_experience_map_published.png").exists()

    alone = tmp_path / "alone"
    main(
        ["run", "fig8", "--out", str(alone), "--duration", "60", "--quiet", "--no-recording", "--ratslam", "published"]
    )
    doc_alone = json.loads((alone / "metrics.json").read_text())
    assert "published" not in doc_alone
    assert doc_alone["variants"]["paper"]["ate"] == pub["variants"]["paper"]["ate"]


def test_a_report_redraws_from_what_is_committed(tmp_path):
    """What reports/ keeps (metrics.json, report.md, panels, maps.npz, config) is enough for
    ``report DIR`` to redraw every panel; the trajectories are regenerated by the figure's command,
    their checksums in metrics.json."""
    import hashlib
    import shutil

    from harness.cli import main
    from harness.figures.run import run_figure

    out = run_figure("fig7", out=tmp_path / "run", duration=40.0, show_progress=False, workers=1)
    doc = json.loads((out / "metrics.json").read_text())
    sums = doc["trajectory_sha256"]
    assert "trajectories/ratslam_published.tum" in sums and "variants/wheel_errors/trajectories/gtsam.tum" in sums
    for rel, digest in sums.items():
        assert hashlib.sha256((out / rel).read_bytes()).hexdigest() == digest
    for d in out.rglob("trajectories"):
        shutil.rmtree(d)
    pngs = sorted(p.relative_to(out) for p in out.rglob("*.png"))
    for p in pngs:
        (out / p).unlink()
    assert main(["report", str(out)]) in (0, None)
    assert sorted(p.relative_to(out) for p in out.rglob("*.png")) == pngs
    assert len(pngs) == 12  # two variants x (world, pose cells and map for both RatSLAMs, pose graph)
