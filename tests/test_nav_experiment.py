"""The goal-navigation experiment (``ratslam-harness nav``): its run directory, its one-line errors,
its determinism, and the saved post-exploration map planning as the live one."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

import ratslam.navigation as rnav
from harness.navigation.closed_loop import navigation_ratslam_config
from harness.navigation.experiment import run_nav_experiment
from ratslam import RatSLAM
from tests.helpers import cli as run_cli
from worlds import simulate
from worlds.files import read_json

FILES = ("metrics.json", "report.md", "routes.png", "ratslam_map.npz", "recording.rrd")


def test_cli_nav_writes_every_file(tmp_path):
    """A short exploration and two goals, end to end as a user runs it: every file, the claims
    with GTSAM beside RatSLAM, the per-goal table, provenance; the saved map loads and plans."""
    out = tmp_path / "nav"
    r = run_cli("nav", "small_loop", "--exploration", "120", "--goals", "2", "--seed", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "run directory:" in r.stdout and "goals reached" in r.stdout
    for name in FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert not list(tmp_path.glob(".nav.partial-*"))  # staged, then moved into place
    m = read_json(out / "metrics.json")
    assert m["experiment"] == "nav" and m["world"] == "small_loop" and m["seed"] == 1 and m["n_goals"] == 2
    assert {c["id"] for c in m["claims"]} == {"success_rate", "median_time_ratio"}
    for c in m["claims"]:
        assert {"statement", "threshold", "held", "ratslam", "gtsam", "gtsam_meets"} <= set(c)
    for system in ("ratslam", "gtsam"):
        s = m["summary"][system]
        assert s["goals"] == 2 and 0.0 <= s["success_rate"] <= 1.0
        assert {"median_time_ratio", "mean_time_ratio", "replans_total"} <= set(s)
        assert len(m["goals"][system]) == 2
        assert {"status", "time_s", "shortest_time_s", "time_ratio", "replans"} <= set(m["goals"][system][0])
    assert set(m["exploration_map_ate_m"]) == {"ratslam", "gtsam"}
    loc = m["summary"]["ratslam"]["localiser"]  # RatSLAM navigated its fixed map (the default)
    assert set(loc) == {"sightings_matched", "relocalisations", "times_lost", "ways_back_given_up"}
    assert loc["sightings_matched"] > 0 and "localiser" not in m["summary"]["gtsam"]
    assert m["provenance"]["git_commit"] and m["provenance"]["packages"]["numpy"]
    assert m["settings"]["ratslam_config"]["reentry"] and m["settings"]["gtsam_config"]
    report = (out / "report.md").read_text()
    assert "## Claims" in report and "routes.png" in report
    (out / "report.md").unlink()  # `report DIR` rebuilds it from metrics.json, byte for byte
    r = run_cli("report", str(out))
    assert r.returncode == 0, r.stderr
    assert (out / "report.md").read_text() == report
    loaded = RatSLAM.load(out / "ratslam_map.npz")
    goal = m["goals"]["ratslam"][0]["map_goal"]
    assert rnav.plan_route(loaded, goal).found
    rrd = out / "recording.rrd"
    rerun = Path(sys.executable).parent / "rerun"
    res = subprocess.run([str(rerun), "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr[-2000:]
    entities = {c.entity_path for c in RrdReader(rrd).store().stream().to_chunks()}
    for system in ("ratslam", "gtsam"):
        for name in ("goal", "route", "driven"):
            assert f"/world/nav/{system}/{name}" in entities
        assert f"/metrics/nav/{system}/success_rate" in entities
    assert {"/pose_cells/nav/route", "/world/ratslam/experiences", "/world/ground_truth"} <= entities


@pytest.mark.parametrize(
    "args, expected",
    [
        (("no_such_world",), "no such world"),
        (("small_loop", "--goals", "0"), "--goals"),
        (("small_loop", "--exploration", "-5"), "--exploration"),
        (("small_loop", "--exploration", "10", "--goals", "3"), "explore for longer"),
    ],
    ids=["unknown_world", "zero_goals", "negative_exploration", "exploration_too_short"],
)
def test_cli_nav_bad_input_is_one_line(tmp_path, args, expected):
    out = tmp_path / "out"
    r = run_cli("nav", *args, "--no-recording", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ratslam-harness: error:") and expected in lines[0], r.stderr
    assert not out.exists() and not list(tmp_path.glob(".out.partial-*"))  # nothing written


def test_nav_experiment_is_deterministic(tmp_path):
    """Same seed, same metrics (timing and provenance aside)."""
    runs = []
    for name in ("a", "b"):
        out = run_nav_experiment(
            "small_loop", tmp_path / name, seed=3, n_goals=2, exploration_s=90.0, recording=False, show_progress=False
        )
        m = read_json(out / "metrics.json")
        assert m["settings"]["lookalikes"] is True
        runs.append({k: v for k, v in m.items() if k not in ("timing", "provenance")})
    assert runs[0] == runs[1]


def test_saved_map_plans_as_the_live_one(tmp_path):
    """RatSLAM.save after an exploration, RatSLAM.load: the loaded map plans the same routes (same
    nodes, same times, same failures) to goals all over the map, and keeps doing so as both are
    stepped on the same further observations."""
    log = simulate("small_loop", duration=150.0, seed=2)
    live = RatSLAM(navigation_ratslam_config())
    obs = list(zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist()))
    for o in obs[:800]:
        live.step(*o)
    live.save(tmp_path / "map.npz")
    loaded = RatSLAM.load(tmp_path / "map.npz")

    def plans(slam):
        xy = slam.experience_poses[:, :2]
        goals = np.vstack((xy[::3], xy[::7] + 0.3, [[50.0, 50.0]]))  # on nodes, beside them, off the map
        return [rnav.plan_route(slam, g) for g in goals]

    def same(a, b):
        assert len(a) == len(b)
        for ra, rb in zip(a, b):
            assert ra.status == rb.status and ra.nodes.tolist() == rb.nodes.tolist()
            assert ra.time_s == rb.time_s or (math.isinf(ra.time_s) and math.isinf(rb.time_s))
            assert np.array_equal(ra.waypoints, rb.waypoints)

    first = plans(live)
    assert sum(r.found for r in first) > 10 and not first[-1].found
    same(first, plans(loaded))
    for o in obs[800:]:
        live.step(*o)
        loaded.step(*o)
    assert live.pose == loaded.pose
    same(plans(live), plans(loaded))


def test_cli_nav_options():
    from harness.cli import build_parser

    args = build_parser().parse_args(["nav", "office_floor", "--no-lookalikes", "--goals", "5", "--exploration", "60"])
    assert (args.no_lookalikes, args.goals, args.exploration, args.seed) == (True, 5, 60.0, 0)
    assert build_parser().parse_args(["nav", "office_floor"]).no_lookalikes is False


def test_navigating_the_saved_map_in_localisation_mode(tmp_path):
    """Localisation (the default): the explored map, saved, is the one navigated (a copy, never
    stepped), and the run says so; the same exploration and goals as with RatSLAM stepping
    (``--stepping``); the CLI's default and both flags."""
    from harness.cli import build_parser
    from harness.navigation.closed_loop import run_navigation

    loc = run_navigation("small_loop", 120.0, 2, 1, systems=("ratslam",), trace=True)
    slam = run_navigation("small_loop", 120.0, 2, 1, systems=("ratslam",), ratslam_localise=False)
    parse = build_parser().parse_args
    assert not parse(["nav", "x"]).stepping and not parse(["nav", "x", "--localise"]).stepping
    assert parse(["nav", "x", "--stepping"]).stepping
    assert loc.settings["ratslam_navigation"].startswith("localisation")
    assert slam.settings["ratslam_navigation"].startswith("RatSLAM stepping")
    a, b = loc.systems["ratslam"].outcomes, slam.systems["ratslam"].outcomes
    assert [o.true_goal for o in a] == [o.true_goal for o in b]
    # the same map and the same first click (later ones differ: stepping, RatSLAM's map moves)
    assert a[0].map_goal == b[0].map_goal
    assert len(loc.systems["ratslam"].trace["estimate"]) > 0


@pytest.mark.slow
@pytest.mark.xdist_group("nav_office_floor")
def test_ratslam_map_reaches_the_goals_on_office_floor():
    """Issue claim (the paper's future work): navigating RatSLAM's experience map, the robot
    reaches >= 95 % of 50 goals with a median time ratio <= 1.3 — on office_floor as shipped
    (look-alike rooms B and C), seed 0, the committed report's run, RatSLAM's side only (measured:
    50 of 50, median 1.01; seeds 0-7 reach 48-50, README). The map fixed after the exploration and
    localised on (the default)."""
    from harness.navigation.closed_loop import run_navigation

    result = run_navigation("office_floor", 9000.0, 50, 0, systems=("ratslam",))
    nav = result.systems["ratslam"]
    assert nav.success_rate >= 0.95
    assert nav.median_time_ratio <= 1.3
