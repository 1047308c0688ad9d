#!/usr/bin/env python3
"""Independent reference for octavar's accumulator tests: allantools' adev and oadev at octave tau.

Usage: allantools_octaves.py CODES_FILE RATE_HZ
CODES_FILE holds one integer code per line. Prints JSON:
{"adev": [[m, n, dev], ...], "oadev": [[m, n, dev], ...]} with m = tau * rate, for every octave allantools returns.
"""
import json
import sys

import allantools
import numpy as np


def main():
    path, rate = sys.argv[1], float(sys.argv[2])
    y = np.loadtxt(path, dtype=np.float64, ndmin=1)
    tau0 = 1.0 / rate
    taus = [2.0 ** k * tau0 for k in range(0, 40) if 2 ** (k + 1) <= len(y)]
    out = {}
    for name, fn in (("adev", allantools.adev), ("oadev", allantools.oadev)):
        t, d, e, n = fn(y, rate=rate, data_type="freq", taus=taus)
        out[name] = [[int(round(ti * rate)), int(ni), float(di)] for ti, di, ni in zip(t, d, n)]
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
