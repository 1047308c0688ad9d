"""One 6-axis IMU record with known noise terms, written as CSV and as ROS bags by an independent writer.

Usage: imu_six_axis.py SPEC.json, where SPEC is {"out": DIR, "mode": "record" or "cases", ...}.

mode "record" ({"hours", "rate", "seed", "formats"}): three gyro axes (rad/s) and three accelerometer axes (m/s^2), each the
sum of a constant bias and three independent noises, numpy only (no code shared with octavar):
  - white noise of density N: per-sample standard deviation N * sqrt(rate), Allan variance N^2 / tau;
  - flicker noise of level B: one-sided PSD B^2 / (pi f), made as a sum of first-order Gauss-Markov processes with
    correlation times spaced by a factor r = 2 from 0.05 s to 3e5 s, each of variance B^2 ln(r) / pi (the sum of
    their Lorentzians is B^2 / (pi f) between those corner frequencies, within a few per cent of ripple); its Allan
    deviation is the flat floor sqrt(2 ln 2 / pi) B = 0.6643 B of IEEE 952;
  - a random walk of K: per-sample steps of standard deviation K / sqrt(rate), Allan variance K^2 tau / 3.
The terms put the white-to-floor crossing at tau = 1 s and the floor-to-walk crossing at 1e4 s. The truths are
written to truth.json (gyro terms in deg units: N deg/sqrt(s), B deg/s, K deg/s/sqrt(s); accelerometer terms in
m/s units), the samples to imu.csv (columns t, gx, gy, gz in rad/s, ax, ay, az in m/s^2, shortest round-trip
repr so a reader gets the same doubles), and the same samples as sensor_msgs Imu messages with header.stamp on an
exact grid to those of "formats" (default all): imu_none.bag, imu_bz2.bag, imu_lz4.bag (ROS 1,
rosbags.rosbag1.Writer), imu_db3/ (rosbag2 SQLite storage) and imu_mcap/ (rosbag2 MCAP storage), both through
rosbags.rosbag2.Writer, and those storages with rosbag2's zstd compression of whole files or of each message
(imu_db3_zstd_file/, imu_db3_zstd_message/, imu_mcap_zstd_file/, imu_mcap_zstd_message/).

mode "cases": small bags for the error paths: several.bag (two Imu topics), noimu_db3/ (a bag with only a
String topic), disorder.bag and disorder_db3/ (stamps out of order and repeated: message order 0 1 3 2 4 4 5 ...;
truths in disorder.json), small_bz2.bag (to be damaged by the test).
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.signal import lfilter
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer as Writer2
from rosbags.typesys import Stores, get_typestore

T0_NS = 1_700_000_000_000_000_000
DEG = math.pi / 180.0
IMU = "sensor_msgs/msg/Imu"

# Truths: gyro in deg units (converted to rad for the samples), accelerometer in m/s units.
GYRO_N = 0.005  # deg/sqrt(s)
GYRO_B = GYRO_N / 0.6643  # deg/s: the white noise meets the floor at 1 s
GYRO_K = 0.6643 * GYRO_B * math.sqrt(3.0 / 1e4)  # deg/s/sqrt(s): the walk meets the floor at 1e4 s
ACC_N = 6e-4  # m/s/sqrt(s)
ACC_B = ACC_N / 0.6643  # m/s^2
ACC_K = 0.6643 * ACC_B * math.sqrt(3.0 / 1e4)  # m/s^2/sqrt(s)
BIAS = [0.01, -0.02, 0.005, 0.05, -0.03, 9.81]  # rad/s, m/s^2


def flicker(rng, n, rate, b):
    """Flicker noise of level b: a sum of Gauss-Markov processes with correlation times spaced by 2."""
    r = 2.0
    out = np.zeros(n)
    var = b * b * math.log(r) / math.pi
    t = 0.05
    while t <= 3e5:
        phi = math.exp(-1.0 / (rate * t))
        e = rng.standard_normal(n) * math.sqrt(var * (1.0 - phi * phi))
        start = rng.standard_normal() * math.sqrt(var)
        y, _ = lfilter([1.0], [1.0, -phi], e, zi=[phi * start])
        out += y
        t *= r
    return out


def channel(rng, n, rate, big_n, big_b, big_k):
    white = rng.standard_normal(n) * big_n * math.sqrt(rate)
    walk = np.cumsum(rng.standard_normal(n) * big_k / math.sqrt(rate))
    return white + flicker(rng, n, rate, big_b) + walk


def typestores():
    return get_typestore(Stores.ROS1_NOETIC), get_typestore(Stores.ROS2_HUMBLE)


def imu_msg(ts, stamp_ns, w, a, ros1, seq=0):
    T = ts.types
    sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
    stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
    if ros1:
        header = T["std_msgs/msg/Header"](seq=seq, stamp=stamp, frame_id="imu_link")
    else:
        header = T["std_msgs/msg/Header"](stamp=stamp, frame_id="imu_link")
    v3 = T["geometry_msgs/msg/Vector3"]
    zeros = np.zeros(9)
    return T[IMU](
        header=header,
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.array([-1.0] + [0.0] * 8),
        angular_velocity=v3(x=float(w[0]), y=float(w[1]), z=float(w[2])),
        angular_velocity_covariance=zeros,
        linear_acceleration=v3(x=float(a[0]), y=float(a[1]), z=float(a[2])),
        linear_acceleration_covariance=zeros,
    )


def write_ros1(path, topics, compression=None):
    """topics: {name: [(log_ns, bytes)]} or {name: ("type", [(log_ns, bytes)])}, written in log-time order."""
    ts1, _ = typestores()
    w = Writer1(path)
    if compression:
        w.set_compression(compression)
    w.open()
    items = []
    for name, (kind, msgs) in topics.items():
        conn = w.add_connection(name, kind, typestore=ts1)
        items += [(t, i, conn, data) for i, (t, data) in enumerate(msgs)]
    items.sort(key=lambda x: (x[0], x[1]))
    for t, _, conn, data in items:
        w.write(conn, t, data)
    w.close()


def write_ros2(path, topics, storage, compression=None):
    """compression: None, or rosbag2's zstd compression mode, "file" or "message"."""
    _, ts2 = typestores()
    w = Writer2(path, version=9, storage_plugin=storage)
    if compression:
        mode = {"file": CompressionMode.FILE, "message": CompressionMode.MESSAGE}[compression]
        w.set_compression(mode, CompressionFormat.ZSTD)
    w.open()
    items = []
    for name, (kind, msgs) in topics.items():
        conn = w.add_connection(name, kind, typestore=ts2)
        items += [(t, i, conn, data) for i, (t, data) in enumerate(msgs)]
    items.sort(key=lambda x: (x[0], x[1]))
    for t, _, conn, data in items:
        w.write(conn, t, data)
    w.close()


def serialized(stamps, log, gyro, acc):
    """The ROS 1 and CDR bytes of each message: [(log_ns, bytes)] twice."""
    ts1, ts2 = typestores()
    ros1, cdr = [], []
    for k in range(len(stamps)):
        m1 = imu_msg(ts1, stamps[k], gyro[k], acc[k], True, seq=k)
        m2 = imu_msg(ts2, stamps[k], gyro[k], acc[k], False)
        ros1.append((int(log[k]), bytes(ts1.serialize_ros1(m1, IMU))))
        cdr.append((int(log[k]), bytes(ts2.serialize_cdr(m2, IMU))))
    return ros1, cdr


def write_all(out, name, stamps, log, gyro, acc, formats):
    """The messages as NAME_{none,bz2,lz4}.bag, NAME_db3/ and NAME_mcap/, and with rosbag2's zstd compression
    NAME_{db3,mcap}_zstd_{file,message}/: those of `formats`."""
    ros1, cdr = serialized(stamps, log, gyro, acc)
    fmt = {"none": None, "bz2": Writer1.CompressionFormat.BZ2, "lz4": Writer1.CompressionFormat.LZ4}
    for kind in formats:
        if kind in fmt:
            write_ros1(out / f"{name}_{kind}.bag", {"/imu/data": (IMU, ros1)}, fmt[kind])
        elif kind == "db3":
            write_ros2(out / f"{name}_db3", {"/imu/data": (IMU, cdr)}, StoragePlugin.SQLITE3)
        elif kind == "mcap":
            write_ros2(out / f"{name}_mcap", {"/imu/data": (IMU, cdr)}, StoragePlugin.MCAP)
        elif kind.startswith(("db3_zstd_", "mcap_zstd_")):
            storage = StoragePlugin.SQLITE3 if kind.startswith("db3") else StoragePlugin.MCAP
            write_ros2(out / f"{name}_{kind}", {"/imu/data": (IMU, cdr)}, storage, kind.rsplit("_", 1)[1])


def record(out, spec):
    rate = float(spec["rate"])
    n = int(round(float(spec["hours"]) * 3600 * rate))
    rng = np.random.default_rng(int(spec["seed"]))
    gyro = np.stack([channel(rng, n, rate, GYRO_N * DEG, GYRO_B * DEG, GYRO_K * DEG) + BIAS[i] for i in range(3)], 1)
    acc = np.stack([channel(rng, n, rate, ACC_N, ACC_B, ACC_K) + BIAS[3 + i] for i in range(3)], 1)
    period_ns = int(round(1e9 / rate))
    stamps = T0_NS + np.arange(n, dtype=np.int64) * period_ns
    # The recorder logs each message a little after its stamp.
    log = stamps + 300_000 + (np.arange(n) % 7) * 10_000
    with open(out / "imu.csv", "w") as f:
        f.write("t,gx,gy,gz,ax,ay,az\n")
        # Python floats' repr: the shortest text that reads back as the same double.
        rows = np.column_stack([np.arange(n) / rate, gyro, acc]).tolist()
        f.writelines(",".join(map(repr, r)) + "\n" for r in rows)
    write_all(out, "imu", stamps, log, gyro, acc, spec.get("formats", ["none", "bz2", "lz4", "db3", "mcap"]))
    truth = {
        "gyro": {"N": GYRO_N, "B": GYRO_B, "K": GYRO_K, "units": ["deg/sqrt(s)", "deg/s", "deg/s/sqrt(s)"]},
        "accel": {"N": ACC_N, "B": ACC_B, "K": ACC_K, "units": ["m/s/sqrt(s)", "m/s^2", "m/s^2/sqrt(s)"]},
        "samples": n,
        "rate": rate,
    }
    (out / "truth.json").write_text(json.dumps(truth))


def cases(out):
    ts1, ts2 = typestores()
    rate, n = 100.0, 400
    rng = np.random.default_rng(5)
    gyro, acc = rng.standard_normal((n, 3)) * 0.01, rng.standard_normal((n, 3)) + [0, 0, 9.81]
    stamps = T0_NS + np.arange(n, dtype=np.int64) * 10_000_000
    ros1, cdr = serialized(stamps, stamps + 1000, gyro, acc)
    # Two Imu topics.
    write_ros1(out / "several.bag", {"/imu/a": (IMU, ros1), "/imu/b": (IMU, ros1[:100])})
    # No Imu topic.
    s = ts2.types["std_msgs/msg/String"](data="hello")
    strings = [(int(t), bytes(ts2.serialize_cdr(s, "std_msgs/msg/String"))) for t in stamps[:10]]
    write_ros2(out / "noimu_db3", {"/status": ("std_msgs/msg/String", strings)}, StoragePlugin.SQLITE3)
    # Stamps out of order and repeated: message order 0 1 3 2 4 4 5 6 ... (log times still increasing); the
    # repeated 4 carries other values, which the reader must drop (it keeps the first logged).
    order = [0, 1, 3, 2, 4, 4] + list(range(5, n))
    g = gyro[order].copy()
    g[5] = [9.0, 9.0, 9.0]
    log = T0_NS + np.arange(len(order), dtype=np.int64) * 10_000_000 + 5000
    write_all(out, "disorder", stamps[order], log, g, acc[order], ["lz4", "db3", "mcap"])
    (out / "disorder.json").write_text(json.dumps({"messages": len(order), "out_of_order": 1, "duplicates": 1,
                                                   "samples": n, "gyro_rad_s": gyro.tolist()}))
    # A small bz2 bag, to damage.
    write_ros1(out / "small_bz2.bag", {"/imu/data": (IMU, ros1)}, Writer1.CompressionFormat.BZ2)


def main():
    spec = json.loads(Path(sys.argv[1]).read_text())
    out = Path(spec["out"])
    out.mkdir(parents=True, exist_ok=True)
    if spec["mode"] == "record":
        record(out, spec)
    else:
        cases(out)


if __name__ == "__main__":
    main()
