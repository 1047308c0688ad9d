"""The IEEE 952 fit on records made with numpy, whose N, B and K are known: each truth inside its 95% interval
and near the estimate; the fit of allantools' deviations agrees; the dict has the documented shape."""

import math

import numpy as np
import pytest

import octavar

RATE = 100.0
N_TRUE = 0.01  # deg/sqrt(s)
K_TRUE = 2e-4  # deg/s/sqrt(s)
B_TRUE = 0.004  # deg/s


def white_and_walk(n, seed):
    rng = np.random.default_rng(seed)
    white = rng.standard_normal(n) * N_TRUE * math.sqrt(RATE)
    walk = np.cumsum(rng.standard_normal(n)) * K_TRUE / math.sqrt(RATE)
    return white + walk + 0.5


def flicker(n, b, seed):
    """Flicker rate noise of bias instability b (one-sided PSD b^2 / (pi f): Allan floor 0.6643 b), shaped in the
    frequency domain from white noise."""
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1.0 / RATE)
    psd = np.zeros_like(f)
    psd[1:] = b * b / (math.pi * f[1:])
    scale = np.sqrt(psd * n * RATE / 4.0)
    spectrum = scale * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    return np.fft.irfft(spectrum, n)


def inside(term, truth):
    lo, hi = term["interval"]
    return lo is not None and hi is not None and lo <= truth <= hi


def test_white_noise_and_random_walk_give_n_and_k():
    y = white_and_walk(1 << 21, seed=11)
    f = octavar.fit(y, RATE)
    for name, truth in (("N", N_TRUE), ("K", K_TRUE)):
        t = f[name]
        assert t["identifiable"], (name, t)
        assert inside(t, truth), (name, t, truth)
        assert abs(t["value"] / truth - 1) < 0.1, (name, t["value"], truth)
    assert f["N"]["unit"] == "deg/sqrt(s)" and f["K"]["unit"] == "deg/s/sqrt(s)"
    assert f["N"]["alt"] == {"value": pytest.approx(60 * f["N"]["value"]), "unit": "deg/sqrt(h)"}
    # Neither a ramp nor a quantization term is in this record: nothing claims one.
    for name in ("Q", "R"):
        assert f[name]["value"] is None or not f[name]["identifiable"] or f[name]["value"] < 0.2 * f[name]["interval"][1]
    # The five-term model describes this record: no misfit beyond the model-error floor.
    assert f["chi2_per_dof"] < 3.0, f["chi2_per_dof"]
    assert f["confidence"] == 0.95
    pts = f["points"]
    assert pts["stat"] == "oadev" and list(pts["m"][:3]) == [1, 2, 4]
    assert np.all(pts["lo"] < pts["dev"]) and np.all(pts["dev"] < pts["hi"])


def test_flicker_gives_b():
    n = 1 << 21
    y = flicker(n, B_TRUE, seed=5) + np.random.default_rng(6).standard_normal(n) * N_TRUE * math.sqrt(RATE)
    f = octavar.fit(y, RATE)
    b = f["B"]
    assert b["identifiable"], b
    assert inside(b, B_TRUE), (b, B_TRUE)
    assert abs(b["value"] / B_TRUE - 1) < 0.2, b
    assert b["alt"]["unit"] == "deg/h" and b["alt"]["value"] == pytest.approx(3600 * b["value"])
    # The white noise is still found beside the flicker (its interval, as tight as 0.4% here, leaves no room for
    # how the synthesised flicker departs from the asymptotic floor at the shortest taus).
    assert f["N"]["value"] == pytest.approx(N_TRUE, rel=0.02), f["N"]


def test_the_fit_of_allantools_deviations_finds_the_same_terms(allantools):
    y = white_and_walk(1 << 20, seed=12)
    taus, devs, errs, ns = allantools.oadev(y, rate=RATE, data_type="freq", taus="octave")
    f = octavar.fit_deviations(taus, devs, ns=ns, rate=RATE)
    for name, truth in (("N", N_TRUE), ("K", K_TRUE)):
        assert inside(f[name], truth), (name, f[name], truth)
    # The same points with the EDF the deviation table gives: the same estimate within 5%.
    d = octavar.deviation(y, RATE)
    g = octavar.fit_deviations(d["tau_s"], d["dev"], edf=d["edf"])
    for name in ("N", "K"):
        assert g[name]["value"] == pytest.approx(f[name]["value"], rel=0.05), name
    # Limiting the terms and the tau range is honoured.
    h = octavar.fit_deviations(taus, devs, ns=ns, rate=RATE, terms=["N"], tau_max=1.0)
    assert h["K"]["value"] in (None, 0.0) and h["tau_range_s"][1] <= 1.0
    assert inside(h["N"], N_TRUE)


def test_model_adev_is_the_five_term_formula():
    y = white_and_walk(1 << 18, seed=3)
    f = octavar.fit(y, RATE)
    taus = np.logspace(-2, 3, 20)
    sq = f["squares"]
    want = np.sqrt(3 * sq["Q"] / taus**2 + sq["N"] / taus + 2 * math.log(2) / math.pi * sq["B"]
                   + sq["K"] * taus / 3 + sq["R"] * taus**2 / 2)
    np.testing.assert_allclose(octavar.model_adev(f, taus), want, rtol=1e-12)


def test_accelerometer_units():
    y = white_and_walk(1 << 18, seed=4)
    f = octavar.fit(y, RATE, quantity="accel")
    assert f["N"]["unit"] == "m/s/sqrt(s)" and f["B"]["unit"] == "m/s^2"
