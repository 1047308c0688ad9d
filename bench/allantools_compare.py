#!/usr/bin/env python3
"""Side by side with allantools (issue 4 item 7): the same 1e7-sample rate file, OADEV at octave tau.

Runs allantools.oadev(y, rate, data_type="freq", taus="octave") in this process (compute time: from the array in
memory to the deviations; end-to-end: from the file), runs `octavar analyze FILE --format f64le --json` as a
subprocess (end-to-end) and octavar's own compute timing (the `analyze` bench: `stats::analyze` from the array in
memory to OADEV at octave tau, deviations and counts, and again with noise identification, EDF and intervals), and
checks that every common tau agrees within 1e-9 relative.

usage: allantools_compare.py RATE_FILE.f64 OCTAVAR_BIN BENCH_BIN [--rate HZ] [--reps N]
"""
import argparse
import json
import subprocess
import sys
import tempfile

import allantools
import numpy as np

from timing import best

p = argparse.ArgumentParser()
p.add_argument("data")
p.add_argument("octavar")
p.add_argument("bench")
p.add_argument("--rate", type=float, default=2000.0)
p.add_argument("--reps", type=int, default=5)
a = p.parse_args()

# allantools, end to end: read the file, compute.
t_at_e2e, _ = best(lambda: allantools.oadev(np.fromfile(a.data, dtype="<f8"), rate=a.rate, data_type="freq",
                                           taus="octave"), 2)
y = np.fromfile(a.data, dtype="<f8")
t_at, (taus, devs, errs, ns) = best(lambda: allantools.oadev(y, rate=a.rate, data_type="freq", taus="octave"), a.reps)

# octavar, end to end: the command on the file, JSON out.
with tempfile.TemporaryDirectory() as d:
    js = f"{d}/o.json"
    cmd = [a.octavar, "analyze", a.data, "--format", "f64le", "--rate", str(a.rate), "--column", "gz", "--json", js]
    def run():
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t_ov_e2e, _ = best(run, 3)
    doc = json.load(open(js))
# Its in-memory path (the same numbers at m <= stride; the command streams, so above the stride its terms are
# strided): the bench prints the compute time and the fully overlapping deviations of every octave.
out = subprocess.run([a.bench, a.data, str(a.rate), str(a.reps)], check=True, capture_output=True, text=True).stdout
bench = json.loads(out.strip().splitlines()[-1])
t_ov = bench["compute_s"]
ov = {int(m): dev for m, dev in bench["oadev"]}

worst, common = 0.0, 0
for tau, dev, n in zip(taus, devs, ns):
    m = int(round(tau * a.rate))
    if m in ov:
        worst = max(worst, abs(ov[m] / dev - 1.0))
        common += 1
stream = {p["m"]: p["dev"] for p in doc["channels"][0]["stats"]["oadev"]}
stride = bench.get("stride", 1024)
worst_stream = max(abs(stream[m] / ov[m] - 1.0) for m in stream if m <= stride and m in ov)

print(f"samples            {len(y)}")
print(f"taus compared      {common} (allantools {len(taus)}, octavar {len(ov)})")
print(f"max rel. diff      {worst:.2e} (octavar in-memory vs allantools; must be < 1e-9)")
print(f"                   {worst_stream:.2e} (octavar analyze command vs in-memory, m <= stride {stride})")
t_plain = bench.get("compute_plain_s", t_ov)
print(f"compute            allantools {t_at * 1e3:8.1f} ms   octavar {t_plain * 1e3:7.1f} ms   ratio {t_at / t_plain:6.1f}x"
      "   (like for like: deviations, counts)")
print(f"  with intervals   allantools {t_at * 1e3:8.1f} ms   octavar {t_ov * 1e3:7.1f} ms   ratio {t_at / t_ov:6.1f}x"
      "   (octavar adds noise ID, Greenhall EDF, chi-square bounds)")
print(f"end to end         allantools {t_at_e2e * 1e3:8.1f} ms   octavar {t_ov_e2e * 1e3:7.1f} ms   ratio {t_at_e2e / t_ov_e2e:6.1f}x")
print("  (allantools end to end: np.fromfile + oadev in a running interpreter, import excluded;"
      " octavar: the whole `octavar analyze` process, fit and JSON included)")
ok = worst < 1e-9 and worst_stream < 1e-9
sys.exit(0 if ok else 1)
