"""Per-figure accuracy thresholds: each paper figure is run and each of its claims must hold.

Every figure runs once per session (module fixture) at the paper's duration unless stated in
``DURATIONS``; every claim of the figure registry is one test, named by the figure and claim
(the claim's statement is its docstring in the registry, repeated in the report). The
thresholds inside the claims come from measured runs with a margin; see ``harness/figures/registry.py``.
"""

import json

import numpy as np
import pytest

from harness.figures.registry import FIGURES
from harness.figures.run import run_figure

# Durations used by the suite: the paper's, except where the suite's 10-minute budget does not
# allow it (stated here, and the committed reports under reports/ are at the paper's length).
DURATIONS = {"fig4": 9000.0, "fig11": 3600.0}


def claimed_variants(name: str) -> tuple[str, ...]:
    """The variants the suite runs besides the primary (which always runs): those the figure's
    claims read. The others (fig4's distinct rooms and the paper's re-entries, fig9's and fig10's
    bias in the odometry, the Plaza logs' simulator defaults) are reported under reports/ but carry
    no claim, so the suite skips their runs."""
    fig = FIGURES[name]
    named = {v for claim in fig.claims for v in claim.variants}
    return tuple(v.name for v in fig.variants[1:] if v.name in named)


# Claims that do not hold in the measured runs (reports/<figure>/report.md has the numbers). They
# stay as strict expected failures, so the day one of them holds the suite says so; they are not
# loosened.
KNOWN_FAILURES = {
    ("fig11", "g_h_two_pose_cell_loops"): "full floor: the pose cells relocalise the second lap of the room "
    "onto the first (lap centres 0.03 m apart; 0.30 m even with "
    "view injection off), see the figure's notes",
}


# The same claims judged for RatSLAM as published (RatSLAMConfig.published(), run beside the
# defaults on the same streams): those it fails here, with the measured cause (docs/fidelity.md,
# reports/fidelity: each departure switched on alone over the paper and removed alone from the
# defaults; the mechanisms counted against ground truth). Strict: the day one holds, the suite says so.
_LINKS = (
    "the paper's transitions assume the robot stands at the re-entered experience, and eq 9's sum "
    "re-enters one 20-40 deg away in heading, so links carry that heading (p90 28 deg on fig7)"
)
_FALSE = "eq 9's sum and acting on every tick's view re-enter places on one-tick false positives by heading alone"
_LOOKALIKE = "re-entries wherever the pose cells say: look-alike rooms B and C re-entered 19 m away (669 false)"
_BENT = "false loop closures where the biased pose cells drift onto an aliased scene (31 / 33 / 3 false re-entries)"
PUBLISHED_FAILURES: dict[tuple[str, str], str] = {
    ("fig7", "experience_map_consistent"): f"map 1.05 m: {_LINKS}; {_FALSE}",
    ("fig7", "wheel_errors_map_consistent"): f"map 1.05 m: {_LINKS}; {_FALSE}",
    ("fig7", "wheel_errors_map_beats_odometry"): f"map 1.05 m against odometry 1.23 m: {_LINKS}",
    ("fig8", "experience_map_consistent"): f"map 1.53 m: {_BENT}; {_LINKS}",
    ("fig8", "pose_cells_bent"): "the map (1.53 m) is bent as much as the pose cells' path (1.19 m): " + _BENT,
    ("fig8", "only_orientation_differs"): f"map 1.53 m: {_BENT}",
    ("fig8", "odometric_experience_map"): f"map 1.53 m with the bias in the odometry: {_LINKS}",
    ("fig8", "odometric_ratio_ratslam"): f"map 1.53 m against odometry 3.21 m: {_LINKS}",
    ("fig9", "experience_map_consistent"): f"map 1.62 m: {_BENT}; {_LINKS}",
    ("fig9", "pose_cells_bent"): "the map (1.62 m) is bent as much as the pose cells' path (1.92 m): " + _BENT,
    ("fig9", "only_orientation_differs"): f"map 1.62 m: {_BENT}",
    ("fig10", "experience_map_consistent"): f"map 2.53 m: {_BENT}; {_LINKS}",
    ("fig10", "pose_cells_bent"): "the map (2.53 m) is bent as much as the pose cells' path (2.84 m): " + _BENT,
    ("fig10", "only_orientation_differs"): f"map 2.53 m: {_BENT}",
    ("fig11", "g_h_two_pose_cell_loops"): KNOWN_FAILURES[("fig11", "g_h_two_pose_cell_loops")],
    ("fig11", "g_h_overlap_in_experience_map"): "lap centres 1.68 m apart in the map: " + _LINKS,
    ("fig11", "experience_map_consistent"): f"map 12.98 m: 41 false re-entries (34 on heading alone); {_LINKS}",
    ("fig13", "experience_map_consistent"): f"map 2.54 m: {_LINKS} (p90 38 deg); {_FALSE}",
    ("fig13", "wheel_errors_map_beats_odometry"): f"map 2.54 m against odometry 0.57 m: {_LINKS}",
    ("fig4", "experience_map_consistent"): f"map 6.83 m: {_LOOKALIKE}; {_LINKS}",
    ("plaza1", "experience_map_improves"): f"map 13.2 m against odometry 1.47 m: {_LINKS}; {_FALSE}",
    ("plaza2", "experience_map_improves"): f"map 5.94 m against odometry 15.9 m (needs 5x): {_LINKS}",
}


def _marks(figure: str, claim: str, failures: dict[tuple[str, str], str] = KNOWN_FAILURES) -> list:
    # one xdist group per figure: its claims share one run on one worker
    marks = [pytest.mark.xdist_group(figure), pytest.mark.slow]
    if (figure, claim) in failures:
        marks.append(pytest.mark.xfail(strict=True, reason=failures[(figure, claim)]))
    return marks


CASES = [
    pytest.param(fig.name, claim.key, id=f"{fig.name}-{claim.key}", marks=_marks(fig.name, claim.key))
    for fig in FIGURES.values()
    for claim in fig.claims
]
PUBLISHED_CASES = [
    pytest.param(
        fig.name,
        claim.key,
        id=f"{fig.name}-published-{claim.key}",
        marks=_marks(fig.name, claim.key, PUBLISHED_FAILURES),
    )
    for fig in FIGURES.values()
    for claim in fig.claims
]


@pytest.fixture(scope="module")
def figure_runs(tmp_path_factory):
    cache = {}

    def get(name):
        if name not in cache:
            out = tmp_path_factory.mktemp(name) / "run"
            variants = claimed_variants(name)
            run_figure(name, out=out, duration=DURATIONS.get(name), show_progress=False, variants=variants)
            cache[name] = json.loads((out / "metrics.json").read_text()), out
        return cache[name]

    return get


@pytest.mark.parametrize("figure, claim", CASES)
def test_paper_claim_holds(figure_runs, figure, claim):
    """The paper's claim ``claim`` for ``figure`` holds on the measured run."""
    metrics, _ = figure_runs(figure)
    result = {c["key"]: c for c in metrics["claims"]}[claim]
    assert result["held"], f"{figure}: {result['statement']} -- measured {result['measured']}"


@pytest.mark.parametrize("figure, claim", PUBLISHED_CASES)
def test_paper_claim_holds_as_published(figure_runs, figure, claim):
    """The paper's claim ``claim`` for ``figure`` holds for RatSLAM as published on the same run's streams."""
    metrics, _ = figure_runs(figure)
    result = {c["key"]: c for c in metrics["published"]["claims"]}[claim]
    assert result["held"], f"{figure} as published: {result['statement']} -- measured {result['measured']}"


@pytest.mark.xdist_group("fig8")
def test_run_directory_contract(figure_runs):
    """The run-directory contract: metrics with provenance, TUM files, report, panels."""
    metrics, out = figure_runs("fig8")
    for name in ("ground_truth", "odometry", "ratslam", "gtsam"):
        lines = [ln for ln in (out / "trajectories" / f"{name}.tum").read_text().splitlines() if not ln.startswith("#")]
        assert len(lines) == metrics["variants"]["paper"]["ticks"]
        assert len(lines[0].split()) == 8
    prov = metrics["provenance"]
    assert prov["git_commit"] and prov["packages"]["gtsam"] and prov["seed"] == 0
    assert metrics["variants"]["paper"]["config"]["ratslam"]["pose_cells"]["path_integration_bias_deg_s"] == 1.5
    report = (out / "report.md").read_text()
    assert "| claim | project defaults | held | as published | held |" in report
    for png in ("a_world.png", "b_pose_cells.png", "c_experience_map.png", "d_gtsam.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"
    for png in ("b_pose_cells_published.png", "c_experience_map_published.png"):
        assert (out / "variants" / "odometric" / png).read_bytes()[:4] == b"\x89PNG"
    assert (out / "variants" / "odometric" / "trajectories" / "ratslam.tum").exists()
    assert (out / "variants" / "odometric" / "trajectories" / "ratslam_published.tum").exists()


def _umeyama_se2_ate(est, gt):
    """An independent evo-style ATE: Umeyama (no scale) on positions, RMSE after alignment."""
    mu_e, mu_g = est.mean(0), gt.mean(0)
    cov = (gt - mu_g).T @ (est - mu_e) / len(est)
    u, _, vt = np.linalg.svd(cov)
    s = np.eye(2)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[1, 1] = -1
    r = u @ s @ vt
    t = mu_g - r @ mu_e
    return float(np.sqrt(np.mean(np.sum((est @ r.T + t - gt) ** 2, axis=1))))


@pytest.mark.xdist_group("fig8")
def test_tum_files_reproduce_metrics_json_ate(figure_runs):
    """ATE recomputed evo-style from the TUM files equals the ATE in metrics.json."""
    metrics, out = figure_runs("fig8")
    traj = out / "trajectories"
    gt = np.loadtxt(traj / "ground_truth.tum")
    for tum, key in (("odometry", "odometry"), ("ratslam", "ratslam_online"), ("gtsam", "gtsam_online")):
        est = np.loadtxt(traj / f"{tum}.tum")
        assert np.array_equal(est[:, 0], gt[:, 0])
        ate = _umeyama_se2_ate(est[:, 1:3], gt[:, 1:3])
        assert ate == pytest.approx(metrics["variants"]["paper"]["ate"][key], rel=1e-6, abs=1e-6)


def test_same_seed_same_metrics(tmp_path):
    """Determinism: a seed fixes a run; same seed, same accuracy metrics bit for bit."""
    runs = []
    for i in range(2):
        out = run_figure("fig7", out=tmp_path / f"r{i}", duration=240.0, show_progress=False)
        m = json.loads((out / "metrics.json").read_text())["variants"]["default"]
        m.pop("timing")
        runs.append(m)
    assert runs[0] == runs[1]


def test_parallel_variants_match_a_sequential_run(tmp_path):
    """Determinism whatever the number of processes: a figure's variants run in parallel
    processes give the same metrics and trajectories, bit for bit, as run one after another."""
    outs = [run_figure("fig8", out=tmp_path / f"w{w}", duration=120.0, show_progress=False, workers=w) for w in (1, 3)]
    runs = []
    for out in outs:
        m = json.loads((out / "metrics.json").read_text())
        for v in [*m["variants"].values(), *m["published"]["variants"].values()]:
            v.pop("timing")
        m.pop("provenance")
        runs.append(m)
    assert runs[0] == runs[1]
    for tum in sorted((outs[0] / "variants" / "odometric" / "trajectories").glob("*.tum")):
        other = outs[1] / "variants" / "odometric" / "trajectories" / tum.name
        assert tum.read_bytes() == other.read_bytes(), tum.name


@pytest.mark.xdist_group("plaza2")
def test_real_log_run_directory(figure_runs):
    """A real data set runs like a figure: its duration is the log's own (its clock starts at
    3152 s), closures are judged at the scale of its 2 m scene cells, the derived configuration is
    recorded, and the panels are drawn without a world, framed on the ground truth."""
    metrics, out = figure_runs("plaza2")
    assert metrics["real_log"] == "plaza2" and "world" not in metrics
    assert 400.0 < metrics["duration_s"] < 420.0
    v = metrics["variants"]["derived"]
    assert v["loop_closure"]["true_distance_m"] == 3.0
    assert "m per tick" in v["derived_scale"] and "Measured from the log" in (out / "config.toml").read_text()
    t = v["timing"]  # real-time factors against the log's duration, not its clock
    assert t["ratslam_realtime_factor"] * t["ratslam_s"] == pytest.approx(metrics["duration_s"], rel=1e-3)
    for png in ("a_world.png", "b_pose_cells.png", "c_experience_map.png", "d_gtsam.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"
    assert "Real data set `plaza2`" in (out / "report.md").read_text()
