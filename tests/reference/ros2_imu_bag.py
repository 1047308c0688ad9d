"""Write a ROS 2 bag (MCAP) of sensor_msgs/msg/Imu messages with the reference writers (mcap, mcap-ros2-support).

Usage: python ros2_imu_bag.py SPEC.json

SPEC: {"out": PATH, "compression": "zstd" | "lz4" | "none", "chunked": true, "chunk_size": BYTES,
       "topics": [TOPIC, ...], "other_topic": false}
TOPIC: {"name": "/imu/data", "n": 1000, "rate": 200.0, "seed": 1, "t0_ns": 1700000000123456789,
        "drop": [k, ...],        # sample indices never written (k = 0 must stay)
        "jitter": 0.0,           # stamps move by up to this fraction of a period, uniformly
        "zero_stamps": false,    # header.stamp = 0; the log time carries the sample time
        "swap": [i, ...],        # messages i and i+1 (of those written) are logged in the other order
        "duplicate": [i, ...],   # message i is written again right after (same stamp, negated rates)
        "bad_schema": false,     # the schema is named sensor_msgs/msg/Imu but defines only the header
        "frame_id": "imu_link"}

For topic j it also writes PATH.j.f64: one row of float64 [k, wx, wy, wz] (rad/s) per sample written, in
sample order, without the duplicates: the values the reader must find at grid position k.
"""

import json
import sys

import numpy as np
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from mcap.well_known import SchemaEncoding
from mcap_ros2._dynamic import serialize_dynamic
from mcap_ros2.writer import Writer as Ros2Writer

SEP = "=" * 80 + "\n"

# The full definition, as rosbag2 stores it: the message, then each type it uses after a line of '=' and
# 'MSG: pkg/Name'.
IMU_MSGDEF = (
    """# This is a message to hold data from an IMU (Inertial Measurement Unit)
#
# Accelerations should be in m/s^2 (not in g's), and rotational velocity should be in rad/sec

std_msgs/Header header

geometry_msgs/Quaternion orientation
float64[9] orientation_covariance # Row major about x, y, z axes

geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance # Row major about x, y, z axes

geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance # Row major x, y z
"""
    + SEP
    + """MSG: std_msgs/Header
# Standard metadata for higher-level stamped data types.
builtin_interfaces/Time stamp
string frame_id
"""
    + SEP
    + """MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""
    + SEP
    + """MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
"""
    + SEP
    + """MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""
)

# A schema that claims the Imu name but defines only the header: its messages do not decode as Imu.
BAD_IMU_MSGDEF = (
    "std_msgs/Header header\n"
    + SEP
    + "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    + SEP
    + "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
)

STRING_MSGDEF = "string data\n"


def topic_messages(t):
    """The (log_time, message dict) list of one topic in write order, and its truth rows."""
    n, rate = t["n"], t["rate"]
    rng = np.random.default_rng(t.get("seed", 1))
    w = rng.normal(0.0, 0.01, size=(n, 3)) + np.array([0.002, -0.001, 0.0005])
    period = round(1e9 / rate)
    t0 = t.get("t0_ns", 1_700_000_000_123_456_789)
    jitter = t.get("jitter", 0.0)
    offsets = np.zeros(n, dtype=np.int64)
    if jitter > 0:
        offsets = np.round(rng.uniform(-jitter, jitter, size=n) * period).astype(np.int64)
    drop = set(t.get("drop", []))
    kept = [k for k in range(n) if k not in drop]
    stamps = {k: t0 + k * period + int(offsets[k]) for k in kept}
    truth = np.array([[k, *w[k]] for k in kept], dtype=np.float64)

    order = list(kept)
    for i in t.get("swap", []):
        order[i], order[i + 1] = order[i + 1], order[i]
    written = []  # (k, sign)
    dup = set(t.get("duplicate", []))
    for i, k in enumerate(order):
        written.append((k, 1.0))
        if i in dup:
            written.append((k, -1.0))
    # The recorder logs each message a little after its stamp, in write order.
    log_times = sorted(stamps[k] for k, _ in written)

    frame_id = t.get("frame_id", "imu_link")
    out = []
    for (k, sign), log_time in zip(written, log_times):
        stamp = 0 if t.get("zero_stamps") else stamps[k]
        if t.get("zero_stamps"):
            log_time = stamps[k]
        else:
            log_time += 1_000_000
        msg = {
            "header": {"stamp": {"sec": stamp // 1_000_000_000, "nanosec": stamp % 1_000_000_000}, "frame_id": frame_id},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            "orientation_covariance": [0.0] * 9,
            "angular_velocity": {"x": sign * w[k, 0], "y": sign * w[k, 1], "z": sign * w[k, 2]},
            "angular_velocity_covariance": [0.0] * 9,
            "linear_acceleration": {"x": 0.01 * k, "y": -0.02, "z": 9.81},
            "linear_acceleration_covariance": [0.0] * 9,
        }
        out.append((log_time, msg))
    return out, truth


def main():
    with open(sys.argv[1]) as f:
        spec = json.load(f)
    path = spec["out"]
    compression = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[
        spec.get("compression", "zstd")
    ]
    chunk_size = spec.get("chunk_size", 1024 * 1024)

    events = []  # (log_time, order, topic, schema key, message)
    for j, t in enumerate(spec["topics"]):
        msgs, truth = topic_messages(t)
        truth.tofile(f"{path}.{j}.f64")
        key = "bad" if t.get("bad_schema") else "imu"
        for i, (log_time, msg) in enumerate(msgs):
            events.append((log_time, j, i, t["name"], key, msg))
    if spec.get("other_topic"):
        t0 = min((e[0] for e in events), default=1_700_000_000_000_000_000)
        for i in range(10):
            events.append((t0 + i * 100_000_000, 99, i, "/status", "string", {"data": f"status {i}"}))
    events.sort(key=lambda e: (e[0], e[1], e[2]))

    if spec.get("chunked", True):
        writer = Ros2Writer(path, chunk_size=chunk_size, compression=compression)
        schemas = {
            "imu": writer.register_msgdef("sensor_msgs/msg/Imu", IMU_MSGDEF),
            "bad": writer.register_msgdef("sensor_msgs/msg/Imu", BAD_IMU_MSGDEF),
            "string": writer.register_msgdef("std_msgs/msg/String", STRING_MSGDEF),
        }
        for log_time, _, _, topic, key, msg in events:
            writer.write_message(topic, schemas[key], msg, log_time=log_time)
        writer.finish()
    else:
        # Messages outside chunks: the plain mcap writer, with mcap-ros2-support's CDR encoders.
        with open(path, "wb") as stream:
            writer = McapWriter(stream, use_chunking=False)
            writer.start(profile="ros2", library="octavar-tests")
            defs = {"imu": ("sensor_msgs/msg/Imu", IMU_MSGDEF), "bad": ("sensor_msgs/msg/Imu", BAD_IMU_MSGDEF),
                    "string": ("std_msgs/msg/String", STRING_MSGDEF)}
            schema_ids, encoders, channels = {}, {}, {}
            for log_time, _, _, topic, key, msg in events:
                if key not in schema_ids:
                    name, text = defs[key]
                    schema_ids[key] = writer.register_schema(name, SchemaEncoding.ROS2, text.encode())
                    encoders[key] = serialize_dynamic(name, text)[name]
                if topic not in channels:
                    channels[topic] = writer.register_channel(topic, "cdr", schema_ids[key])
                writer.add_message(channels[topic], log_time, encoders[key](msg), log_time)
            writer.finish()


if __name__ == "__main__":
    main()
