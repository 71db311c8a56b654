"""Robot recordings written from a simulated run, as a robot's software would write them: ROS 1
and ROS 2 bags (rosbags' own writers: odometry, ground truth, camera images raw or compressed,
camera info), videos (PyAV) and TUM trajectories. Used by the image-import tests and
``bench/bench_image_import.py``."""

from __future__ import annotations

import io
import math

import numpy as np
from PIL import Image
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from harness.run.runner import dead_reckon
from worlds import simulate
from worlds.camera import Camera, to_uint8

STORES = {1: get_typestore(Stores.ROS1_NOETIC), 2: get_typestore(Stores.ROS2_HUMBLE)}
T0 = 1000.0  # bag clock at the simulated run's start
FX = 32.0 / math.tan(math.radians(25.0))  # a 64-column image with the forward camera's 50 degrees


class Bag:
    """A bag written with rosbags' own writers (ROS 1 file or ROS 2 directory)."""

    def __init__(self, path, ros: int):
        self.ros, self.ts = ros, STORES[ros]
        self.writer = (Writer1(path) if ros == 1 else Writer2(path, version=8)).__enter__()
        self.connections: dict[str, object] = {}

    def header(self, t: float):
        sec = int(math.floor(t))
        stamp = self.ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))
        extra = {"seq": 0} if self.ros == 1 else {}
        return self.ts.types["std_msgs/msg/Header"](stamp=stamp, frame_id="camera", **extra)

    def write(self, topic: str, msgtype: str, t: float, **fields):
        T = self.ts.types
        if topic not in self.connections:
            self.connections[topic] = self.writer.add_connection(topic, msgtype, typestore=self.ts)
        msg = T[msgtype](header=self.header(t), **fields)
        raw = self.ts.serialize_ros1(msg, msgtype) if self.ros == 1 else self.ts.serialize_cdr(msg, msgtype)
        self.writer.write(self.connections[topic], int(round(t * 1e9)), raw)

    def topic(self, topic: str, msgtype: str):
        """A connection without messages."""
        self.connections[topic] = self.writer.add_connection(topic, msgtype, typestore=self.ts)

    def pose(self, topic: str, t: float, x: float, y: float, th: float):
        T = self.ts.types
        pose = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
        )
        if topic == "/ground_truth":
            self.write(topic, "geometry_msgs/msg/PoseStamped", t, pose=pose)
            return
        V = T["geometry_msgs/msg/Vector3"]
        zero = T["geometry_msgs/msg/Twist"](linear=V(x=0.0, y=0.0, z=0.0), angular=V(x=0.0, y=0.0, z=0.0))
        self.write(
            topic,
            "nav_msgs/msg/Odometry",
            t,
            child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=zero, covariance=np.zeros(36)),
        )

    def raw_image(self, topic, t, pixels: np.ndarray, encoding="mono8", step=None, big=0):
        height, width = pixels.shape[:2]
        data = pixels.reshape(height, -1)
        if step is not None:  # rows padded to step bytes
            data = np.hstack([data, np.zeros((height, step - data.shape[1]), np.uint8)])
        self.write(
            topic,
            "sensor_msgs/msg/Image",
            t,
            height=height,
            width=width,
            encoding=encoding,
            is_bigendian=big,
            step=data.shape[1],
            data=np.ascontiguousarray(data).ravel(),
        )

    def compressed(self, topic, t, data: bytes, fmt="png"):
        self.write(topic, "sensor_msgs/msg/CompressedImage", t, format=fmt, data=np.frombuffer(data, np.uint8))

    def camera_info(self, topic, t, fx, width, height):
        k = np.array([fx, 0, width / 2, 0, fx, height / 2, 0, 0, 1], dtype=np.float64)
        T = self.ts.types
        names = ("D", "K", "R", "P") if self.ros == 1 else ("d", "k", "r", "p")
        arrays = (np.zeros(5), k, np.eye(3).ravel(), np.zeros(12))
        roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        self.write(
            topic,
            "sensor_msgs/msg/CameraInfo",
            t,
            height=height,
            width=width,
            distortion_model="plumb_bob",
            binning_x=0,
            binning_y=0,
            roi=roi,
            **dict(zip(names, arrays)),
        )

    def close(self):
        self.writer.__exit__(None, None, None)


def png(grey: np.ndarray) -> bytes:
    """A grey image as PNG bytes."""
    buf = io.BytesIO()
    Image.fromarray(grey, mode="L").save(buf, format="PNG")
    return buf.getvalue()


def simulated_run(world: str, duration: float, seed: int):
    """A simulated run as a robot records it: the log, its rendered forward-camera frames (uint8),
    the dead-reckoned odometry poses and the true poses (one more than ticks: the start first),
    and their times on a bag clock starting at :data:`T0`."""
    log = simulate(world, duration=duration, seed=seed)
    frames = to_uint8(Camera(world, "forward", seed=seed).render_poses(log.ground_truth(), log.t))
    odo = np.vstack([[0.0, 0.0, 0.0], dead_reckon(log)])
    gt = np.vstack([log.ground_truth()[:1], log.ground_truth()])
    t = np.concatenate(([log.t[0] - log.dt[0]], log.t)) + T0
    return log, frames, odo, gt, t


def write_run_bag(path, run, ros: int, compressed: bool, camera_info: bool = True, image_from: int = 0):
    """The run as a bag: /odom, /ground_truth, /camera/image_raw(/compressed) at the tick times
    (from tick ``image_from`` on), /camera/camera_info."""
    _, frames, odo, gt, t = run
    bag = Bag(path, ros)
    for k in range(len(t)):
        bag.pose("/odom", t[k], *odo[k])
        bag.pose("/ground_truth", t[k], *gt[k])
        if k >= 1 + image_from:
            if compressed:
                bag.compressed("/camera/image_raw/compressed", t[k], png(frames[k - 1]))
            else:
                bag.raw_image("/camera/image_raw", t[k], frames[k - 1])
    if camera_info:
        bag.camera_info("/camera/camera_info", t[0], FX, 64, 16)
    bag.close()
    return path


def write_video(path, frames: np.ndarray, codec: str, fps: int = 7):
    """Grey frames (n, rows, columns) as a video: ``ffv1`` (lossless) or ``libx264`` (H.264)."""
    import av

    with av.open(str(path), "w") as container:
        stream = container.add_stream(codec, rate=fps)
        stream.width, stream.height = frames.shape[2], frames.shape[1]
        stream.pix_fmt = "gray" if codec == "ffv1" else "yuv420p"
        for grey in frames:
            container.mux(stream.encode(av.VideoFrame.from_ndarray(grey, format="gray")))
        container.mux(stream.encode())
    return path


def write_tum(path, t, poses):
    """Poses (n, 3) at times ``t`` as a TUM trajectory."""
    rows = [
        f"{float(tk)!r} {float(x)!r} {float(y)!r} 0 0 0 {math.sin(th / 2)!r} {math.cos(th / 2)!r}"
        for tk, (x, y, th) in zip(t, poses)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path
