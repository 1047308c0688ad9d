#!/usr/bin/env python3
"""Write a deterministic gyro-like rate record (deg/s) as raw little-endian samples or a one-column CSV.

White rate noise (N), a slow random walk of the bias (K) and a constant bias: what a MEMS gyro at rest gives.
Written in pieces, so any length fits in little memory.

usage: gen_rate.py OUT N_SAMPLES [--format f64le|f32le|i16le|csv] [--rate HZ] [--seed S]
"""
import argparse
import sys

import numpy as np

p = argparse.ArgumentParser()
p.add_argument("out")
p.add_argument("n", type=float)
p.add_argument("--format", default="f64le", choices=["f64le", "f32le", "i16le", "csv"])
p.add_argument("--rate", type=float, default=2000.0)
p.add_argument("--seed", type=int, default=1)
a = p.parse_args()

n = int(a.n)
rng = np.random.default_rng(a.seed)
n_dps, k_dps = 0.01, 1e-4  # deg/sqrt(s), deg/s/sqrt(s)
sig_w = n_dps * np.sqrt(a.rate)
sig_k = k_dps / np.sqrt(a.rate)
bias = 0.0 if a.format == "f64le" else 0.25  # zero-mean f64 keeps allantools' plain cumsum exact to 1e-13
walk = 0.0
piece = 1 << 22
with open(a.out, "wb") as f:
    if a.format == "csv":
        f.write(b"gz\n")
    done = 0
    while done < n:
        k = min(piece, n - done)
        w = np.cumsum(rng.standard_normal(k)) * sig_k + walk
        walk = w[-1]
        y = rng.standard_normal(k) * sig_w + w + bias
        if a.format == "f64le":
            y.astype("<f8").tofile(f)
        elif a.format == "f32le":
            y.astype("<f4").tofile(f)
        elif a.format == "i16le":
            np.clip(np.round(y * 1000.0), -32768, 32767).astype("<i2").tofile(f)
        else:
            np.savetxt(f, y, fmt="%.9e")
        done += k
print(f"{a.out}: {n} samples, {a.format}, {a.rate} Hz", file=sys.stderr)
