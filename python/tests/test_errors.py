"""Bad input raises ValueError (or OSError for a file) with a message naming the fault; nothing panics."""

import numpy as np
import pytest

import octavar

Y = np.random.default_rng(5).standard_normal(1000)
FUNCS = [octavar.adev, octavar.oadev, octavar.mdev, octavar.hdev, octavar.ohdev, octavar.tdev, octavar.totdev]


@pytest.mark.parametrize("f", FUNCS)
def test_nan_is_refused_with_its_index_unless_it_marks_gaps(f):
    y = Y.copy()
    y[123] = np.nan
    with pytest.raises(ValueError, match=r"data\[123\] is NaN.*gaps=True"):
        f(y, data_type="freq")
    taus, devs, errs, ns = f(y, data_type="freq", gaps=True)
    assert np.all(np.isfinite(devs)) and len(devs) > 0
    # The terms touching the gap are not averaged: fewer terms than the gap-free record has at the first tau.
    assert ns[0] < f(Y, data_type="freq")[3][0]


@pytest.mark.parametrize(
    "data, message",
    [
        (np.array(["a", "b", "c"]), "dtype <U1 is not a real number type"),
        (np.array([1 + 2j, 3j, 4]), "dtype complex128 is not a real number type"),
        (np.array([True, False, True]), "dtype bool is not a real number type"),
        (np.array([1.0, None, 2.0], dtype=object), "dtype object is not a real number type"),
        (np.zeros((10, 2)), r"must be one-dimensional; its shape is \(10, 2\)"),
        (np.array([]), "data is empty"),
        ([], "data is empty"),
    ],
)
def test_wrong_arrays_are_refused(data, message):
    with pytest.raises(ValueError, match=message):
        octavar.oadev(data)
    with pytest.raises(ValueError, match=message):
        octavar.fit(data, 10.0)


def test_bad_requests_are_refused():
    with pytest.raises(ValueError, match='taus "weekly": use "octave", "decade", "all"' ):
        octavar.oadev(Y, taus="weekly")
    with pytest.raises(ValueError, match=r"taus\[1\] is -2: a tau must be a positive, finite"):
        octavar.oadev(Y, taus=[1.0, -2.0])
    with pytest.raises(ValueError, match=r"taus\[0\] is NaN"):
        octavar.mdev(Y, taus=[np.nan])
    with pytest.raises(ValueError, match="rate must be a positive, finite number"):
        octavar.oadev(Y, rate=0.0)
    with pytest.raises(ValueError, match="rate must be a positive, finite number"):
        octavar.fit(Y, float("inf"))
    with pytest.raises(ValueError, match='data_type "velocity": use "freq"'):
        octavar.oadev(Y, data_type="velocity")
    with pytest.raises(ValueError, match="sample 7 is infinite"):
        octavar.oadev(np.where(np.arange(1000) == 7, np.inf, Y), data_type="freq")
    with pytest.raises(ValueError, match="no tau of this request has two or more terms"):
        octavar.oadev(Y[:5], taus=[100.0])
    with pytest.raises(ValueError, match="too few valid samples"):
        octavar.deviation(Y[:1])
    with pytest.raises(ValueError, match=r"confidence must be in \(0, 1\), got 1.5"):
        octavar.deviation(Y, confidence=1.5)
    with pytest.raises(ValueError, match='unknown statistic "xdev"'):
        octavar.deviation(Y, stat="xdev")
    with pytest.raises(ValueError, match='term "X": the IEEE 952 terms are Q, N, B, K and R' ):
        octavar.fit(Y, 10.0, terms=["N", "X"])
    with pytest.raises(ValueError, match="give edf=, or ns= and rate="):
        octavar.fit_deviations([1.0, 2.0, 4.0], [1.0, 0.7, 0.5])
    with pytest.raises(ValueError, match="taus must increase"):
        octavar.fit_deviations([1.0, 1.0, 4.0], [1.0, 0.7, 0.5], edf=[10.0, 10.0, 10.0])
    with pytest.raises(ValueError, match="holdout fraction 1.5 must be at least 0 and below 1"):
        octavar.gap(Y, 10.0, holdout_fraction=1.5)
    with pytest.raises(ValueError, match="the ensemble needs at least 3 seeds"):
        octavar.gap(np.tile(Y, 4), 10.0, seeds=1)


def test_an_unreadable_file_is_an_oserror_naming_it(tmp_path):
    missing = tmp_path / "nothing_here.csv"
    with pytest.raises(FileNotFoundError, match="nothing_here.csv"):
        octavar.read(missing, "x", rate=10.0)
    with pytest.raises(OSError, match="nothing_here.toml"):
        octavar.simulate(tmp_path / "nothing_here.toml", 10.0)


def test_a_bad_file_is_a_valueerror_with_the_commands_message(tmp_path, cli):
    import subprocess

    p = tmp_path / "rec.csv"
    p.write_text("t,x\n0,1.5\n0.1,oops\n0.2,1.0\n")
    with pytest.raises(ValueError) as e:
        octavar.read(p, "x", rate=10.0)
    out = subprocess.run([cli, "analyze", str(p), "--column", "x", "--rate", "10"], capture_output=True, text=True)
    assert out.returncode == 2
    # The command prints "octavar: MESSAGE"; the exception carries MESSAGE.
    assert out.stderr.strip() == f"octavar: {e.value}", (out.stderr, str(e.value))
    assert 'line 3, column "x": "oops" is not a number' in str(e.value)
    with pytest.raises(ValueError, match='no column "y"'):
        octavar.read(p, "y", rate=10.0)
    with pytest.raises(ValueError, match="column= is required"):
        octavar.read(p)
    with pytest.raises(ValueError, match='unknown unit "furlongs"'):
        octavar.read(p, "x", rate=10.0, unit="furlongs")
