"""Sweep bases beyond a simulated world: a real odometry log with place-label axes, and a world
seen through the simulated camera with vision axes."""

import math

import numpy as np
import pytest

from harness.sweeps.run import run_tasks
from harness.sweeps.spec import SweepSpecError, read_sweep_spec
from harness.sweeps.task import condition_log, run_one, system_configs
from worlds import simulate

LOG_SPEC = """
[base]
log = "{log}"
duration = 40.0
[axes]
cell_size = [1.5, 4.0]
fp_rate = [0.02]
[seeds]
count = 1
[systems.ratslam]
system = "ratslam"
[systems.gtsam]
system = "gtsam"
closures.max_candidates = 2
"""


def _write(tmp_path, text, name="spec.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_real_log_base_relabels_its_odometry_per_condition(tmp_path):
    """Plaza 2's first 40 s: the odometry is the recorded one in every condition, the labels
    follow the cell size and false-positive rate, the configurations are derived from the
    labelled log (the spec's fields on top), and a run completes."""
    spec = read_sweep_spec(_write(tmp_path, LOG_SPEC.format(log="plaza2")))
    tasks = run_tasks(spec, "code")
    assert len(tasks) == 3 and tasks[0]["condition"] == {
        "cell_size": 1.5,
        "fp_rate": 0.002,
        "alias_rate": 0.1,
        "blank_rate": 0.1,
        "pi_bias": 0.0,
    }
    logs = [condition_log(t) for t in tasks]
    assert all(np.array_equal(log.v_rot, logs[0].v_rot) for log in logs)
    fine, coarse, noisy = logs
    places = lambda log: len(np.unique(log.scene_id[log.scene_id >= 0]))  # noqa: E731
    assert places(fine) > 1.5 * places(coarse)  # 1.5 m cells: more places than 4 m cells
    assert noisy.false_positive.sum() > fine.false_positive.sum()
    systems = [system_configs(t, log)["gtsam"].config for t, log in zip(tasks[:2], logs[:2])]
    assert systems[0].closures.sigma_xy_m < systems[1].closures.sigma_xy_m  # derived from the labels
    assert all(c.closures.max_candidates == 2 for c in systems)
    result = run_one(tasks[0])
    assert result["error"] is None, result["error"]
    assert all(math.isfinite(r["ate_map"]) for r in result["systems"].values())


def test_a_users_observation_log_is_a_base(tmp_path):
    log = simulate("small_loop", duration=20.0, seed=1)
    log.write_csv(tmp_path / "mine.csv")
    spec = read_sweep_spec(_write(tmp_path, LOG_SPEC.format(log="mine.csv").replace("40.0", "10.0")))
    task = run_tasks(spec, "code")[1]
    relabelled = condition_log(task)
    assert len(relabelled) == 70 and np.array_equal(relabelled.v_trans, log.v_trans[:70])


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda s: s.replace('"plaza2"', '"nowhere.csv"'), "[base] log: "),
        (
            lambda s: s.replace("cell_size = [1.5, 4.0]", "cell_size = [0.0]"),
            "[axes] cell_size: value 0.0 out of range",
        ),
        (
            lambda s: s.replace("fp_rate = [0.02]", "odometric_bias = [1.0]"),
            "[axes] odometric_bias: not an axis of a real log",
        ),
        (
            lambda s: s.replace("duration = 40.0", 'camera = "forward"'),
            "[base] camera: a real log has no simulated world",
        ),
    ],
)
def test_bad_real_log_specs_are_one_line_naming_file_and_field(tmp_path, edit, message):
    path = _write(tmp_path, edit(LOG_SPEC.format(log="plaza2")))
    with pytest.raises(SweepSpecError) as e:
        read_sweep_spec(path)
    text = str(e.value)
    assert "\n" not in text and str(path) in text and message in text
    if "nowhere" in text:
        assert "nowhere.csv" in text


def test_a_log_without_ground_truth_is_refused_naming_its_columns(tmp_path):
    (tmp_path / "nogt.csv").write_text("t,dt,v_trans,v_rot,scene_id\n0.1,0.1,0.3,0.0,1\n0.2,0.1,0.3,0.0,1\n")
    path = _write(tmp_path, LOG_SPEC.format(log="nogt.csv"))
    with pytest.raises(SweepSpecError) as e:
        read_sweep_spec(path)
    assert "\n" not in str(e.value) and "nogt.csv" in str(e.value) and "gt_x" in str(e.value)


CAMERA_SPEC = """
[base]
world = "small_loop"
camera = "forward"
duration = 8.0
[axes]
image_noise = [0.0, 0.2]
lookalikes = [{lookalikes}]
[seeds]
count = 1
[systems.ratslam]
system = "ratslam"
[systems.gtsam]
system = "gtsam"
"""


def test_a_camera_axis_changes_the_rendered_stream(tmp_path):
    """Image noise reaches the camera's images: the matched template numbers change; the run
    steps both systems on the templates."""
    spec = read_sweep_spec(_write(tmp_path, CAMERA_SPEC.format(lookalikes="0, 1")))
    tasks = run_tasks(spec, "code")
    assert [t["condition"]["image_noise"] for t in tasks] == [0.0, 0.2, 0.0, 0.0]
    clean, noisy = condition_log(tasks[0]), condition_log(tasks[1])
    assert clean.view_rotation is not None and not np.array_equal(clean.scene_id, noisy.scene_id)
    result = run_one(tasks[1])
    assert result["error"] is None, result["error"]
    assert result["ticks"] == len(noisy) and result["systems"]["gtsam"]["nodes"] > 0


def test_bad_camera_specs_are_one_line(tmp_path):
    for text, message in (
        (CAMERA_SPEC.format(lookalikes="0.5"), "[axes] lookalikes: value 0.5: expected 0 or 1"),
        (CAMERA_SPEC.format(lookalikes="1").replace('"forward"', '"fisheye"'), "[base] camera: expected one of"),
        (
            CAMERA_SPEC.format(lookalikes="1").replace("image_noise", "fp_rate"),
            "[axes] fp_rate: not an axis of a camera",
        ),
    ):
        path = _write(tmp_path, text)
        with pytest.raises(SweepSpecError) as e:
            read_sweep_spec(path)
        assert "\n" not in str(e.value) and str(path) in str(e.value) and message in str(e.value)
