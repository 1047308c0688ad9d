#!/usr/bin/env python3
"""octavar's Python package against allantools 2024.6, in one process, on the same arrays (issue 35's floors).

For each allantools-compatible function: the best of --reps runs of allantools and of octavar on the same float64
array of rate samples (data_type="freq"), the speed ratio, and the largest relative difference of the deviations
(which must stay within 1e-9). The floors: OADEV at octave tau on 1e7 samples at least 30 times faster than
allantools, every other statistic at least 10 times. TOTDEV at octave tau runs on --totdev-n samples and the
"all" taus on --all-n samples, sizes at which allantools finishes in seconds (its "all" costs N per tau).
Exits 1 when a floor is missed. Not part of the test command; run it on a quiet machine.

usage: python_vs_allantools.py [--n N] [--totdev-n N] [--all-n N] [--reps R]
"""
import argparse
import sys

import allantools
import numpy as np

import octavar
from timing import best

p = argparse.ArgumentParser()
p.add_argument("--n", type=int, default=10_000_000)
p.add_argument("--totdev-n", type=int, default=10_000_000)
p.add_argument("--all-n", type=int, default=10_000)
p.add_argument("--reps", type=int, default=3)
a = p.parse_args()

RATE = 2000.0
rng = np.random.default_rng(20240601)


def record(n):
    """White noise, a random walk and an offset: rate samples in deg/s."""
    return 0.5 + rng.standard_normal(n) * 0.05 + np.cumsum(rng.standard_normal(n)) * 1e-5


big = record(a.n)
cases = [(s, "octave", big, 30.0 if s == "oadev" else 10.0) for s in ("oadev", "adev", "mdev", "hdev", "ohdev",
                                                                      "tdev")]
cases.append(("oadev", "decade", big, 10.0))
cases.append(("totdev", "octave", big if a.totdev_n == a.n else record(a.totdev_n), 10.0))
small = record(a.all_n)
cases += [(s, "all", small, 10.0) for s in ("oadev", "adev", "mdev", "hdev", "ohdev", "tdev", "totdev")]

print(f"# best of {a.reps}, one process, the same float64 array; data_type=freq, rate {RATE:g} Hz")
print(f"{'stat':8} {'taus':7} {'N':>10} {'#taus':>6} {'allantools s':>13} {'octavar s':>10} {'ratio':>7} "
      f"{'floor':>6} {'max rel diff':>13}")
failed = False
for stat, taus, y, floor in cases:
    t_at, (at_taus, at_devs, _, _) = best(lambda: getattr(allantools, stat)(y, rate=RATE, data_type="freq",
                                                                            taus=taus), a.reps)
    t_ov, (ov_taus, ov_devs, _, _) = best(lambda: getattr(octavar, stat)(y, rate=RATE, data_type="freq",
                                                                         taus=taus), a.reps)
    assert np.array_equal(at_taus, ov_taus), (stat, taus)
    diff = float(np.max(np.abs(ov_devs / at_devs - 1.0)))
    ratio = t_at / t_ov
    ok = ratio >= floor and diff <= 1e-9
    failed |= not ok
    print(f"{stat:8} {taus:7} {len(y):>10} {len(ov_taus):>6} {t_at:>13.4f} {t_ov:>10.4f} {ratio:>7.1f} "
          f"{floor:>6.0f} {diff:>13.1e}{'' if ok else '  FAIL'}")
sys.exit(1 if failed else 0)
