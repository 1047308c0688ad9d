"""The gap diagnosis through Python: the dict has exactly the keys of the JSON `octavar gap --json` writes for the
same record, at every level, and the same diagnosis."""

import json
import subprocess

import numpy as np
import pytest

import octavar

RATE = 10.0


def record(n=24_000, seed=2):
    """White noise with a slow sinusoid that the fitted five-term model cannot explain."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    return rng.standard_normal(n) * 0.05 + 0.02 * np.sin(2 * np.pi * t / 300.0)


def keys(v, path="$"):
    """Every key path of a JSON value; a list contributes the keys of all its elements under `path[]`."""
    out = set()
    if isinstance(v, dict):
        for k, item in v.items():
            out.add(f"{path}.{k}")
            out |= keys(item, f"{path}.{k}")
    elif isinstance(v, list):
        for item in v:
            out |= keys(item, f"{path}[]")
    return out


def test_the_dict_has_the_commands_json_keys(tmp_path, cli):
    y = record()
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, y, header="x", comments="", fmt="%.17g")
    out = tmp_path / "gap.json"
    subprocess.run([cli, "gap", str(csv), "--column", "x", "--rate", str(RATE), "--seeds", "5", "--json", str(out)],
                   check=True, capture_output=True)
    want = json.loads(out.read_text())
    got = octavar.gap(y, RATE, seeds=5)
    assert isinstance(got, dict)
    assert keys(got) == keys(want), sorted(keys(got) ^ keys(want))[:20]
    # The same record and seeds: the same diagnosis, number for number.
    assert got == want


def test_a_separate_holdout_and_a_temperature():
    y = record(30_000, seed=4)
    temp = 24.0 + np.sin(np.arange(30_000) / 3000.0)
    r = octavar.gap(y[:15_000], RATE, temperature=temp[:15_000], holdout=y[15_000:],
                    holdout_temperature=temp[15_000:], seeds=4)
    assert r["n_train"] == 15_000 and r["n_holdout"] == 15_000
    with pytest.raises(ValueError, match="temperature column has 10 values for 15000 rate samples"):
        octavar.gap(y[:15_000], RATE, temperature=temp[:10], seeds=4)
