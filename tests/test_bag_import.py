"""ROS bags as observation logs (your own robot's data, no ROS install): a ROS 2 bag written with
rosbags' own writer is imported, matches the run it was written from, replays end to end through
the CLI, and a bag without the topic or with a topic of the wrong type fails in one line."""

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag2 import Writer
from rosbags.typesys import Stores, get_typestore

from harness.run.runner import dead_reckon
from tests.helpers import cli
from worlds import simulate
from worlds.bag_import import BagImportError, import_bag

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types


def _header(t):
    sec = int(np.floor(t))
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9))), frame_id="odom"
    )


def _odometry(t, x, y, th, v, w):
    P, Q = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    pose = T["geometry_msgs/msg/PoseWithCovariance"](
        pose=T["geometry_msgs/msg/Pose"](
            position=P(x=x, y=y, z=0.0), orientation=Q(x=0.0, y=0.0, z=np.sin(th / 2), w=np.cos(th / 2))
        ),
        covariance=np.zeros(36),
    )
    V = T["geometry_msgs/msg/Vector3"]
    twist = T["geometry_msgs/msg/TwistWithCovariance"](
        twist=T["geometry_msgs/msg/Twist"](linear=V(x=v, y=0.0, z=0.0), angular=V(x=0.0, y=0.0, z=w)),
        covariance=np.zeros(36),
    )
    return T["nav_msgs/msg/Odometry"](header=_header(t), child_frame_id="base_link", pose=pose, twist=twist)


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    """A 60 s simulated run written as a ROS 2 bag: /odom, /ground_truth, /place (Int32)."""
    path = tmp_path_factory.mktemp("bag") / "run"
    log = simulate("small_loop", duration=60.0, seed=4)
    odo = np.vstack([[0.0, 0.0, 0.0], dead_reckon(log)])
    t = np.concatenate(([0.0], log.t)) + 100.0
    gt = np.vstack([log.ground_truth()[:1], log.ground_truth()])
    v = np.concatenate(([0.0], log.v_trans))
    w = np.concatenate(([0.0], log.v_rot))
    with Writer(path, version=8) as writer:
        odom = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=TS)
        truth = writer.add_connection("/ground_truth", "nav_msgs/msg/Odometry", typestore=TS)
        place = writer.add_connection("/place", "std_msgs/msg/Int32", typestore=TS)
        for k in range(len(t)):
            ns = int(round(t[k] * 1e9))
            writer.write(odom, ns, TS.serialize_cdr(_odometry(t[k], *odo[k], v[k], w[k]), "nav_msgs/msg/Odometry"))
            writer.write(truth, ns, TS.serialize_cdr(_odometry(t[k], *gt[k], 0.0, 0.0), "nav_msgs/msg/Odometry"))
            if k:
                writer.write(
                    place,
                    ns,
                    TS.serialize_cdr(T["std_msgs/msg/Int32"](data=int(log.scene_id[k - 1])), "std_msgs/msg/Int32"),
                )
    return path, log


def test_bag_odometry_ground_truth_and_labels(bag):
    path, log = bag
    for twist in (False, True):
        got = import_bag(path, "/odom", ground_truth_topic="/ground_truth", label_topic="/place", twist=twist)
        assert len(got) == len(log)
        np.testing.assert_allclose(got.t - 100.0, log.t, atol=1e-6)
        np.testing.assert_allclose(got.v_trans, log.v_trans, atol=1e-6)
        np.testing.assert_allclose(got.v_rot, log.v_rot, atol=1e-6)
        np.testing.assert_array_equal(got.scene_id, log.scene_id)
        np.testing.assert_allclose(got.ground_truth()[:, :2], log.ground_truth()[:, :2], atol=1e-6)


@pytest.mark.parametrize(
    "args, expected",
    [
        (("--odom", "/wheel_odom", "--labels", "/place"), "topic /wheel_odom (odometry): not in the bag (topics: "),
        (
            ("--odom", "/place", "--labels", "/place"),
            "topic /place (odometry): type std_msgs/msg/Int32, expected nav_msgs/msg/Odometry",
        ),
        (("--odom", "/odom", "--labels", "/odom"), "topic /odom (place labels): type nav_msgs/msg/Odometry"),
    ],
)
def test_bad_topics_are_one_line_and_write_nothing(bag, tmp_path, args, expected):
    path, _ = bag
    out = tmp_path / "log.csv"
    r = cli("import", "rosbag", str(path), *args, "--out", str(out))
    assert r.returncode == 2 and expected in r.stderr and str(path) in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_not_a_bag(tmp_path):
    with pytest.raises(BagImportError, match="no such bag"):
        import_bag(tmp_path / "missing", "/odom", label_topic="/place")


def test_bag_imported_and_replayed_through_thecli(bag, tmp_path):
    path, _ = bag
    out = tmp_path / "log.csv"
    r = cli(
        "import",
        "rosbag",
        str(path),
        "--odom",
        "/odom",
        "--gt",
        "/ground_truth",
        "--labels",
        "/place",
        "--out",
        str(out),
    )
    assert r.returncode == 0, r.stderr
    r = cli("replay", str(out), "--out", str(tmp_path / "run"), "--quiet", "--no-recording")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "run" / "metrics.json").is_file()
