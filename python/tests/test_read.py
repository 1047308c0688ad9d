"""`read` in every format `octavar analyze` reads, each file written by an independent writer (numpy, gzip, npTDMS,
rosbags): the samples in deg/s (m/s^2 for an accelerometer) and the rate, as written."""

import gzip
import math

import numpy as np
import pytest

import octavar
from conftest import need

RATE = 50.0
DEG = 180.0 / math.pi


def series(n=1000, seed=9):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((n, 3)) * 0.1 + np.array([0.5, -0.2, 0.1])


def test_csv_columns_units_time_and_filters(tmp_path):
    v = series()
    t = np.arange(len(v)) / RATE
    p = tmp_path / "imu.csv"
    np.savetxt(p, np.column_stack([t, v, np.arange(len(v)) % 2]), delimiter=",", header="t,wx,wy,wz,period",
               comments="", fmt="%.17g")
    y, rate = octavar.read(p, "wz", rate=RATE)
    assert rate == RATE and y.dtype == np.float64
    np.testing.assert_array_equal(y, v[:, 2])
    y, rate = octavar.read(p, ["wx", "wy"], time_column="t", unit="rad/s")
    assert rate == pytest.approx(RATE) and y.shape == (len(v), 2)
    np.testing.assert_allclose(y, v[:, :2] * DEG, rtol=1e-15)
    y, _ = octavar.read(p, "wx", rate=RATE, where=["period=1"])
    np.testing.assert_array_equal(y, v[1::2, 0])
    y, _, temp = octavar.read(p, "wx", rate=RATE, temp_column="wy")
    np.testing.assert_array_equal(temp, v[:, 1])


def test_gzip_semicolons_decimal_commas_and_gaps(tmp_path):
    v = series()[:, 0]
    lines = ["x"] + [f"{x:.17g}".replace(".", ",") for x in v]
    lines[9] = "NaN"  # a gap (sample 8)
    p = tmp_path / "rec.csv.gz"
    with gzip.open(p, "wt") as f:
        f.write("\n".join(lines) + "\n")
    y, rate = octavar.read(p, "x", rate=RATE, delimiter=";", decimal_comma=True)
    assert np.isnan(y[8]) and np.count_nonzero(np.isnan(y)) == 1
    np.testing.assert_array_equal(np.delete(y, 8), np.delete(v, 8))
    # NaN is a gap only where asked for.
    with pytest.raises(ValueError, match=r"data\[8\] is NaN"):
        octavar.oadev(y, rate, "freq")
    assert len(octavar.oadev(y, rate, "freq", gaps=True)[0]) > 3


def test_raw_little_endian_samples(tmp_path):
    v = series()[:, :2]
    p = tmp_path / "rate.bin"
    v.astype("<f8").tofile(p)
    y, rate = octavar.read(p, ["a", "b"], format="f64le", rate=RATE, channels=2)
    assert rate == RATE
    np.testing.assert_array_equal(y, v)
    codes = (np.arange(100) % 7).astype("<i2")
    codes.tofile(p)
    y, _ = octavar.read(p, "c", format="i16le", rate=RATE)
    np.testing.assert_array_equal(y, codes.astype(np.float64))


def test_tdms(tmp_path):
    nptdms = need("nptdms")
    v = series()[:, 0]
    p = tmp_path / "run.tdms"
    with nptdms.TdmsWriter(p) as w:
        w.write_segment([nptdms.ChannelObject("imu", "gz", v, properties={"wf_increment": 1.0 / RATE})])
    y, rate = octavar.read(p, "imu/gz")
    assert rate == pytest.approx(RATE)
    np.testing.assert_array_equal(y, v)


def imu_messages(typestore, ros1, gyro, acc):
    T = typestore.types
    v3 = T["geometry_msgs/msg/Vector3"]
    out = []
    for k in range(len(gyro)):
        stamp_ns = 1_700_000_000_000_000_000 + round(k * 1e9 / RATE)
        sec, nsec = divmod(stamp_ns, 1_000_000_000)
        stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
        header = (T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="imu") if ros1
                  else T["std_msgs/msg/Header"](stamp=stamp, frame_id="imu"))
        msg = T["sensor_msgs/msg/Imu"](
            header=header,
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.zeros(9),
            angular_velocity=v3(x=float(gyro[k, 0]), y=float(gyro[k, 1]), z=float(gyro[k, 2])),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=v3(x=float(acc[k, 0]), y=float(acc[k, 1]), z=float(acc[k, 2])),
            linear_acceleration_covariance=np.zeros(9),
        )
        data = typestore.serialize_ros1(msg, "sensor_msgs/msg/Imu") if ros1 else \
            typestore.serialize_cdr(msg, "sensor_msgs/msg/Imu")
        out.append((stamp_ns, bytes(data)))
    return out


@pytest.mark.parametrize("kind", ["bag", "mcap", "db3"])
def test_ros_bags(tmp_path, kind):
    need("rosbags")
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin, Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    gyro, acc = series(400, seed=1), series(400, seed=2) + np.array([0.0, 0.0, 9.8])
    if kind == "bag":
        ts = get_typestore(Stores.ROS1_NOETIC)
        path = tmp_path / "imu.bag"
        w = Writer1(path)
    else:
        ts = get_typestore(Stores.ROS2_HUMBLE)
        path = tmp_path / "imu"
        storage = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        w = Writer2(path, version=9, storage_plugin=storage)
    w.open()
    conn = w.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=ts)
    for t, data in imu_messages(ts, kind == "bag", gyro, acc):
        w.write(conn, t, data)
    w.close()
    if kind == "mcap":
        path = next(path.glob("*.mcap"))
    y, rate = octavar.read(path)
    assert rate == pytest.approx(RATE)
    assert y.shape == (400, 6)
    np.testing.assert_allclose(y[:, :3], gyro * DEG, rtol=1e-15)
    np.testing.assert_allclose(y[:, 3:], acc, rtol=1e-15)
    z, _ = octavar.read(path, "z", topic="/imu/data")
    np.testing.assert_array_equal(z, y[:, 2])
