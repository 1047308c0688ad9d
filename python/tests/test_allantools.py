"""Every allantools-compatible function against allantools itself: the same taus and term counts exactly, the
deviations and errors within 1e-9 relative, for octave, decade and all taus (and explicit ones), phase and
frequency data, at two sample rates."""

import numpy as np
import pytest

import octavar
from conftest import signals

STATS = ["adev", "oadev", "mdev", "hdev", "ohdev", "tdev", "totdev"]
RTOL = 1e-9


def check(got, want, what):
    g_taus, g_devs, g_errs, g_ns = got
    w_taus, w_devs, w_errs, w_ns = (np.asarray(v, dtype=np.float64) for v in want)
    assert len(g_taus) > 0, what
    np.testing.assert_array_equal(g_taus, w_taus, err_msg=f"{what}: taus")
    np.testing.assert_array_equal(g_ns, w_ns, err_msg=f"{what}: ns")
    np.testing.assert_allclose(g_devs, w_devs, rtol=RTOL, atol=0, err_msg=f"{what}: devs")
    np.testing.assert_allclose(g_errs, w_errs, rtol=RTOL, atol=0, err_msg=f"{what}: errs")
    for a in got:
        assert isinstance(a, np.ndarray) and a.dtype == np.float64, what


@pytest.fixture(scope="module")
def records():
    # 4000 points for the generated lists; "all" is quadratic in allantools, so 700 there.
    return {n: signals(n) for n in (4000, 700)}


@pytest.mark.parametrize("stat", STATS)
@pytest.mark.parametrize("taus", ["octave", "decade", "all"])
@pytest.mark.parametrize("data_type", ["phase", "freq"])
def test_matches_allantools(allantools, records, stat, taus, data_type):
    n = 700 if taus == "all" else 4000
    for name, y in records[n].items():
        for rate in (1.0, 250.0):
            data = y * 1e-3 if data_type == "phase" else y
            what = f"{stat} {taus} {data_type} {name} rate {rate}"
            want = getattr(allantools, stat)(data, rate=rate, data_type=data_type, taus=taus)
            got = getattr(octavar, stat)(data, rate=rate, data_type=data_type, taus=taus)
            check(got, want, what)


@pytest.mark.parametrize("stat", STATS)
def test_default_arguments_and_explicit_taus_match_allantools(allantools, records, stat):
    y = records[4000]["walk"]
    check(getattr(octavar, stat)(y), getattr(allantools, stat)(y), f"{stat} defaults")
    # Unsorted, repeated, between two m (rounded as numpy rounds, half to even), beyond the record, a list.
    taus = [0.1, 0.5, 0.05, 2.5, 0.3, 0.3, 0.125, 7.99, 1e6]
    want = getattr(allantools, stat)(y, rate=20.0, data_type="freq", taus=np.array(taus))
    check(getattr(octavar, stat)(y, rate=20.0, data_type="freq", taus=taus), want, f"{stat} explicit")


def test_log10_taus_match_allantools(allantools, records):
    y = records[4000]["white"]
    for stat in ("oadev", "mdev"):
        want = getattr(allantools, stat)(y, rate=2.0, data_type="freq", taus="log10")
        check(getattr(octavar, stat)(y, rate=2.0, data_type="freq", taus="log10"), want, f"{stat} log10")


def test_other_input_types_match_allantools(allantools, records):
    """Integer codes, float32, a strided view and a plain list give allantools' result on the same values."""
    y = records[4000]["white"]
    codes = np.round(y * 100).astype(np.int16)
    for data in (codes, y.astype(np.float32), y[::2], list(y[:500])):
        want = allantools.oadev(np.asarray(data, dtype=np.float64), rate=10.0, data_type="freq")
        check(octavar.oadev(data, rate=10.0, data_type="freq"), want, f"oadev of {type(data).__name__}")


def test_a_long_record_takes_the_fast_octave_path_and_still_matches(allantools):
    """2^21 samples: OADEV at octave tau runs without the phase array (the library's long-record path)."""
    y = np.random.default_rng(3).standard_normal(1 << 21) + 1e3
    check(octavar.oadev(y, rate=100.0, data_type="freq"), allantools.oadev(y, rate=100.0, data_type="freq"),
          "oadev 2^21")
