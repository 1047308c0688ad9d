#!/usr/bin/env python3
"""Independent writer of TDMS files for octavar's TDMS reader tests: npTDMS, and NI's format written by hand.

Usage: tdms_write.py MODE OUT_DIR
Writes OUT_DIR/file.tdms and, for each channel the test compares, OUT_DIR/<group>_<channel>.f64: the values
octavar must read, as little-endian float64. Every expected file is also checked here against npTDMS's own read
of file.tdms (its scaled read where the channel has NI scaling), so the expectation is npTDMS's reading, not only
this script's.

Modes:
  segments   TdmsWriter, three write_segment calls: imu/gx (f64, with NaN), imu/gy (i16), imu/gz (f32),
             aux/temp (f64), all with wf_increment 1/400 s; odd/short (f64, 10 values, no wf_increment) in the
             first segment only.
  scaled     TdmsWriter, two segments, NI scaling properties: dev/lin (i16, Linear), dev/poly (i32, Polynomial),
             dev/chain (i16, Linear then Polynomial fed by it), dev/already (f64, NI_Scaling_Status "scaled"),
             dev/table (i16, a Table scale octavar does not apply: no expected file); wf_increment 1 ms.
  handbuilt  Bytes written with struct from NI's format description, in cases TdmsWriter does not write:
             metadata carried over (a segment without metadata, raw data indexes "same as previous", an object
             appended to the previous list, an object without data in one segment), interleaved data and
             big-endian segments: g/a (f64) and g/b (i16), wf_increment 0.02 s, and g/c (u8).
"""
import struct
import sys
from pathlib import Path

import numpy as np
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter


def save(out, group, channel, values):
    np.asarray(values, dtype="<f8").tofile(out / f"{group}_{channel}.f64")


def check(path, expected):
    """npTDMS's read of every expected channel must equal the expectation (NaN where it has NaN)."""
    f = TdmsFile.read(path)
    for (group, channel), values in expected.items():
        got = f[group][channel][:].astype(np.float64)
        want = np.asarray(values, dtype=np.float64)
        assert got.shape == want.shape, (group, channel, got.shape, want.shape)
        assert np.array_equal(got, want, equal_nan=True), (group, channel)


def segments(out):
    rng = np.random.default_rng(20240611)
    lengths = [1000, 777, 1]
    inc = 1.0 / 400.0
    props = {"wf_increment": inc, "wf_start_offset": 0.0, "unit_string": "deg/s"}
    expected = {("imu", "gx"): [], ("imu", "gy"): [], ("imu", "gz"): [], ("aux", "temp"): []}
    path = out / "file.tdms"
    with TdmsWriter(str(path)) as w:
        for k, n in enumerate(lengths):
            gx = rng.normal(0.0, 0.05, n)
            if k == 0:
                gx[5] = np.nan
                gx[900] = np.nan
            gy = rng.integers(-32768, 32768, n).astype(np.int16)
            gz = (rng.normal(0.0, 2.0, n)).astype(np.float32)
            temp = 25.0 + rng.normal(0.0, 0.01, n)
            objects = [
                ChannelObject("imu", "gx", gx, properties=props),
                ChannelObject("imu", "gy", gy, properties=props),
                ChannelObject("imu", "gz", gz, properties=props),
                ChannelObject("aux", "temp", temp, properties=props),
            ]
            if k == 0:
                objects = [RootObject(properties={"name": "octavar test", "samples": 1778}),
                           GroupObject("imu", properties={"sensor": "ADXRS"})] + objects
                objects.append(ChannelObject("odd", "short", np.arange(10, dtype=np.float64) * 0.5))
                save(out, "odd", "short", np.arange(10) * 0.5)
            w.write_segment(objects)
            for (key, values) in zip(expected, (gx, gy, gz, temp)):
                expected[key].append(values.astype(np.float64))
    expected = {k: np.concatenate(v) for k, v in expected.items()}
    for (group, channel), values in expected.items():
        save(out, group, channel, values)
    check(path, expected)


def scaled(out):
    rng = np.random.default_rng(7)
    lin = {
        "NI_Scaling_Status": "unscaled",
        "NI_Number_Of_Scales": 1,
        "NI_Scale[0]_Scale_Type": "Linear",
        "NI_Scale[0]_Linear_Slope": 0.00875,
        "NI_Scale[0]_Linear_Y_Intercept": -0.3,
        "NI_Scale[0]_Linear_Input_Source": 0xFFFFFFFF,
        "wf_increment": 0.001,
    }
    poly = {
        "NI_Scaling_Status": "unscaled",
        "NI_Number_Of_Scales": 1,
        "NI_Scale[0]_Scale_Type": "Polynomial",
        "NI_Scale[0]_Polynomial_Coefficients_Size": 3,
        "NI_Scale[0]_Polynomial_Coefficients[0]": 0.5,
        "NI_Scale[0]_Polynomial_Coefficients[1]": 1e-3,
        "NI_Scale[0]_Polynomial_Coefficients[2]": -2e-9,
        "wf_increment": 0.001,
    }
    chain = {
        "NI_Scaling_Status": "unscaled",
        "NI_Number_Of_Scales": 2,
        "NI_Scale[0]_Scale_Type": "Linear",
        "NI_Scale[0]_Linear_Slope": 2.5e-3,
        "NI_Scale[0]_Linear_Y_Intercept": 0.1,
        "NI_Scale[1]_Scale_Type": "Polynomial",
        "NI_Scale[1]_Polynomial_Coefficients_Size": 2,
        "NI_Scale[1]_Polynomial_Coefficients[0]": -1.25,
        "NI_Scale[1]_Polynomial_Coefficients[1]": 3.0,
        "NI_Scale[1]_Polynomial_Input_Source": 0,
        "wf_increment": 0.001,
    }
    already = dict(lin, NI_Scaling_Status="scaled")
    table = {
        "NI_Number_Of_Scales": 1,
        "NI_Scale[0]_Scale_Type": "Table",
        "wf_increment": 0.001,
    }
    raw = {"lin": [], "poly": [], "chain": [], "already": []}
    path = out / "file.tdms"
    with TdmsWriter(str(path)) as w:
        for k, n in enumerate([600, 401]):
            values = {
                "lin": rng.integers(-32768, 32768, n).astype(np.int16),
                "poly": rng.integers(-(2 ** 31), 2 ** 31, n).astype(np.int32),
                "chain": rng.integers(-32768, 32768, n).astype(np.int16),
                "already": rng.normal(0.0, 1.0, n),
            }
            first = k == 0
            objects = [
                ChannelObject("dev", "lin", values["lin"], properties=lin if first else None),
                ChannelObject("dev", "poly", values["poly"], properties=poly if first else None),
                ChannelObject("dev", "chain", values["chain"], properties=chain if first else None),
                ChannelObject("dev", "already", values["already"], properties=already if first else None),
                ChannelObject("dev", "table", values["lin"], properties=table if first else None),
            ]
            w.write_segment(objects)
            for name in raw:
                raw[name].append(values[name])
    raw = {k: np.concatenate(v) for k, v in raw.items()}
    f = TdmsFile.read(path)
    for name in raw:
        save(out, "dev", name, f["dev"][name][:].astype(np.float64))
    # npTDMS's scaled read is the scaling of the raw values (it applied the properties at all).
    assert np.array_equal(f["dev"]["lin"][:], raw["lin"] * 0.00875 - 0.3)
    assert np.array_equal(f["dev"]["already"][:], raw["already"])
    assert not np.array_equal(f["dev"]["chain"][:], raw["chain"])


# The hand-built file's format: NI's "TDMS File Format Internal Structure".
TOC_META, TOC_NEW_OBJ_LIST, TOC_RAW, TOC_INTERLEAVED, TOC_BIG_ENDIAN = 1 << 1, 1 << 2, 1 << 3, 1 << 5, 1 << 6
T_U8, T_I16, T_F64, T_STRING = 5, 2, 10, 0x20
NO_DATA, SAME = 0xFFFFFFFF, 0


def meta(objects, e):
    """objects: (path, index, properties); index is NO_DATA, SAME or (type, count); properties name -> value."""
    out = struct.pack(e + "I", len(objects))
    for path, index, props in objects:
        p = path.encode()
        out += struct.pack(e + "I", len(p)) + p
        if isinstance(index, tuple):
            out += struct.pack(e + "IIIQ", 20, index[0], 1, index[1])
        else:
            out += struct.pack(e + "I", index)
        out += struct.pack(e + "I", len(props))
        for name, value in props.items():
            n = name.encode()
            out += struct.pack(e + "I", len(n)) + n
            if isinstance(value, float):
                out += struct.pack(e + "Id", T_F64, value)
            else:
                v = value.encode()
                out += struct.pack(e + "II", T_STRING, len(v)) + v
    return out


def segment(toc, objects, data):
    e = ">" if toc & TOC_BIG_ENDIAN else "<"
    m = b"" if objects is None else meta(objects, e)
    toc |= (TOC_META if objects is not None else 0) | (TOC_RAW if data else 0)
    return b"TDSm" + struct.pack("<I", toc) + struct.pack(e + "IQQ", 4713, len(m) + len(data), len(m)) + m + data


def handbuilt(out):
    rng = np.random.default_rng(99)
    a_all, b_all, c_all = [], [], []

    def take(n, e):
        a = rng.normal(0.0, 1.0, n)
        b = rng.integers(-32768, 32768, n).astype(np.int16)
        a_all.append(a)
        b_all.append(b)
        return a.astype(e + "f8").tobytes(), b.astype(e + "i2").tobytes(), a, b

    def c_bytes(n):
        c = rng.integers(0, 256, n).astype(np.uint8)
        c_all.append(c)
        return c.tobytes()

    def rows(a, b, e):
        rec = np.empty(len(a), dtype=[("a", e + "f8"), ("b", e + "i2")])
        rec["a"], rec["b"] = a, b
        return rec.tobytes()

    inc = {"wf_increment": 0.02}
    ga, gb, gc = "/'g'/'a'", "/'g'/'b'", "/'g'/'c'"
    f = b""
    # 1: a new list, contiguous, little-endian.
    a, b, _, _ = take(5, "<")
    f += segment(TOC_NEW_OBJ_LIST, [("/", NO_DATA, {"title": "hand-built"}), ("/'g'", NO_DATA, {}),
                                     (ga, (T_F64, 5), inc), (gb, (T_I16, 5), inc)], a + b)
    # 2: no metadata, three chunks.
    data = b""
    for _ in range(3):
        a, b, _, _ = take(5, "<")
        data += a + b
    f += segment(0, None, data)
    # 3: the previous list, a "same as previous", c appended (b keeps its data).
    a, b, _, _ = take(5, "<")
    f += segment(0, [(ga, SAME, {}), (gc, (T_U8, 4), {})], a + b + c_bytes(4))
    # 4: interleaved, a new list, two chunks of 3 rows.
    _, _, a, b = take(6, "<")
    f += segment(TOC_NEW_OBJ_LIST | TOC_INTERLEAVED, [(ga, (T_F64, 3), inc), (gb, (T_I16, 3), inc)], rows(a, b, "<"))
    # 5: big-endian, contiguous, the list of 4 carried over with c's data and a property updated.
    a, b, _, _ = take(3, ">")
    f += segment(TOC_BIG_ENDIAN, [(gc, (T_U8, 2), {}), (ga, SAME, {"note": "big-endian"})], a + b + c_bytes(2))
    # 6: metadata only, big-endian: c's index becomes 3 values, the row count of a and b.
    f += segment(TOC_BIG_ENDIAN, [(gc, (T_U8, 3), {})], b"")
    # 7: big-endian and interleaved, without metadata: the list is a, b, c, so the rows are a, b, c.
    _, _, a, b = take(3, ">")
    c = rng.integers(0, 256, 3).astype(np.uint8)
    c_all.append(c)
    rec = np.empty(3, dtype=[("a", ">f8"), ("b", ">i2"), ("c", "u1")])
    rec["a"], rec["b"], rec["c"] = a, b, c
    f += segment(TOC_BIG_ENDIAN | TOC_INTERLEAVED, None, rec.tobytes())
    path = out / "file.tdms"
    path.write_bytes(f)
    expected = {
        ("g", "a"): np.concatenate(a_all).astype(np.float64),
        ("g", "b"): np.concatenate(b_all).astype(np.float64),
        ("g", "c"): np.concatenate(c_all).astype(np.float64),
    }
    check(path, expected)
    for (group, channel), values in expected.items():
        save(out, group, channel, values)


def main():
    mode, out = sys.argv[1], Path(sys.argv[2])
    {"segments": segments, "scaled": scaled, "handbuilt": handbuilt}[mode](out)


if __name__ == "__main__":
    main()
