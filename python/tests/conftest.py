"""What the tests share: the independent references (allantools, the writers of TDMS files and ROS bags, the
`octavar` command for the gap report's keys), each skipped with a printed reason where it is missing, and a
failure instead under CI (the CI variable set), where .ci/run installs them all."""

import importlib
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def missing(what):
    """Skip (fail under CI) because ``what`` is not installed."""
    if os.environ.get("CI"):
        pytest.fail(f"CI must run this test: {what} is missing (.ci/run installs it)")
    print(f"skipped: {what} is missing")
    pytest.skip(f"{what} is missing")


def need(module):
    """The module, or a skip (a failure under CI)."""
    try:
        return importlib.import_module(module)
    except ImportError:
        missing(f"the Python module {module}")


@pytest.fixture(scope="session")
def allantools():
    return need("allantools")


@pytest.fixture(scope="session")
def cli():
    """The ``octavar`` command: OCTAVAR_BIN, or a build in the repository's target directory."""
    env = os.environ.get("OCTAVAR_BIN")
    if env:
        return env
    for profile in ("ci", "release", "debug"):
        p = ROOT / "target" / profile / "octavar"
        if p.exists():
            return str(p)
    found = shutil.which("octavar")
    if found:
        return found
    missing("the octavar command (OCTAVAR_BIN, or cargo build)")


def white(n, sigma=1.0, seed=1):
    return np.random.default_rng(seed).standard_normal(n) * sigma


def signals(n, seed=7):
    """Test records of several noise types: white, random walk, flicker-like (a sum of Gauss-Markov processes),
    with an offset so that the phase integration has work to do."""
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n)
    walk = np.cumsum(rng.standard_normal(n)) * 0.05
    fl = np.zeros(n)
    for t in (4.0, 32.0, 256.0):
        phi = np.exp(-1.0 / t)
        e = rng.standard_normal(n) * np.sqrt(1 - phi * phi)
        y = np.empty(n)
        acc = 0.0
        for i in range(n):  # small n only
            acc = phi * acc + e[i]
            y[i] = acc
        fl += y
    return {"white": 3.0 + w, "walk": w + walk, "flicker": 0.3 * w + fl}
