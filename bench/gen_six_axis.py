#!/usr/bin/env python3
"""Write a deterministic 6-axis IMU record as CSV: gx, gy, gz (deg/s) and ax, ay, az (m/s^2, gravity on z).

White noise and a slow bias random walk on every axis, as a MEMS IMU at rest gives; written in pieces, so any
length fits in little memory.

usage: gen_six_axis.py OUT N_ROWS [--rate HZ] [--seed S]
"""
import argparse
import sys

import numpy as np

p = argparse.ArgumentParser()
p.add_argument("out")
p.add_argument("n", type=float)
p.add_argument("--rate", type=float, default=1000.0)
p.add_argument("--seed", type=int, default=1)
a = p.parse_args()

n = int(a.n)
rng = np.random.default_rng(a.seed)
# (white density, random walk, mean) per axis: gyro in deg/s, accelerometer in m/s^2.
axes = [(0.01, 1e-4, 0.0)] * 3 + [(0.002, 4e-5, 0.0), (0.002, 4e-5, 0.0), (0.002, 4e-5, 9.80665)]
walk = np.zeros(6)
piece = 1 << 20
with open(a.out, "wb") as f:
    f.write(b"gx,gy,gz,ax,ay,az\n")
    done = 0
    while done < n:
        k = min(piece, n - done)
        cols = []
        for j, (nd, kd, mean) in enumerate(axes):
            w = np.cumsum(rng.standard_normal(k)) * kd / np.sqrt(a.rate) + walk[j]
            walk[j] = w[-1]
            cols.append(rng.standard_normal(k) * nd * np.sqrt(a.rate) + w + mean)
        np.savetxt(f, np.column_stack(cols), fmt="%.9e", delimiter=",")
        done += k
print(f"{a.out}: {n} rows, 6 axes, {a.rate} Hz", file=sys.stderr)
