"""The virtual bench through Python: the same seed gives the same samples, and the simulated N is recovered by
allantools (an independent estimator)."""

import math

import numpy as np
import pytest

import octavar


def test_white_noise_of_the_asked_n(allantools):
    y = octavar.simulate({"n": 0.02, "rate": 100.0}, 2000, seed=3, analog=True)
    assert y.shape == (200_000,) and y.dtype == np.float64
    taus, devs, _, _ = allantools.oadev(y, rate=100.0, data_type="freq", taus=np.array([1.0, 10.0]))
    # White rate noise: ADEV(tau) = N / sqrt(tau).
    np.testing.assert_allclose(devs, 0.02 / np.sqrt(taus), rtol=0.05)


def test_seeds_durations_and_the_adc():
    a = octavar.simulate({"n": 0.01, "b": 0.005, "rate": 50.0}, "10m", seed=1)
    b = octavar.simulate({"n": 0.01, "b": 0.005, "rate": 50.0}, 600.0, seed=1)
    c = octavar.simulate({"n": 0.01, "b": 0.005, "rate": 50.0}, 600.0, seed=2)
    assert a.shape == (30_000,)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    # Through the ADC the rates fall on its code steps; the analog rate does not.
    steps = np.unique(np.round(np.diff(np.unique(a)), 12))
    assert steps.size < 5, steps[:10]
    analog = octavar.simulate({"n": 0.01, "rate": 50.0}, 600.0, seed=1, analog=True)
    assert np.unique(analog).size == analog.size


def test_a_model_file_gives_the_commands_samples(tmp_path, cli):
    """A model.toml with a temperature-coupled channel: the samples and the temperature octavar simulate
    writes for the same seed."""
    import subprocess

    model = tmp_path / "model.toml"
    out = tmp_path / "sim.csv"
    subprocess.run([cli, "simulate", "--sensor", "adxrs300", "--n", "0.05", "--b", "0.02", "--rate", "20",
                    "--duration", "5m", "--seed", "4", "--write-model", str(model), "-o", str(out)], check=True,
                   capture_output=True)
    text = model.read_text()
    # A bench temperature that swings 25 .. 35 degC over 10 minutes, so the CSV has a temperature column.
    assert "max_c = 25.0" in text and "period_s = 86400.0" in text, text
    model.write_text(text.replace("max_c = 25.0", "max_c = 35.0").replace("period_s = 86400.0", "period_s = 600.0"))
    subprocess.run([cli, "simulate", "--model", str(model), "--duration", "5m", "--seed", "4", "-o", str(out)],
                   check=True, capture_output=True)
    table = np.genfromtxt(out, delimiter=",", names=True)
    y, temp = octavar.simulate(model, "5m", seed=4, with_temperature=True)
    np.testing.assert_array_equal(y, table["adxrs300_dps"])
    np.testing.assert_allclose(temp, table["temp_c"], rtol=0, atol=0)
    assert temp.max() - temp.min() > 5.0
    assert y.shape == (6000,)


def test_bad_models():
    with pytest.raises(ValueError, match='model key "sigma"' ):
        octavar.simulate({"sigma": 1.0}, 10.0)
    with pytest.raises(ValueError, match='model\\["sensor"\\] "gyro9000": use generic'):
        octavar.simulate({"sensor": "gyro9000"}, 10.0)
    with pytest.raises(ValueError, match="is not a positive time"):
        octavar.simulate({"n": 0.01}, "soon")


def test_a_model_that_is_not_toml(tmp_path):
    model = tmp_path / "model.toml"
    model.write_text("this is not toml = [")
    with pytest.raises(ValueError, match="model .*model.toml"):
        octavar.simulate(model, 10.0)
