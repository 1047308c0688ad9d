#!/usr/bin/env python3
"""Reading a CSV, side by side (issue 19 item 6): pandas.read_csv (+ allantools OADEV) and `octavar analyze`.

Times, best of a few runs (octavar's include starting /usr/bin/time, which reports its peak memory): pandas.read_csv of the one-column file alone; that plus allantools.oadev(taus="octave");
`octavar analyze FILE --column gz --rate HZ --stats oadev --json` end to end, on the CSV and on FILE.gz. Checks
every common octave's OADEV within 1e-9 relative, and prints octavar's peak resident memory.

usage: ingest_compare.py RATE.csv OCTAVAR_BIN [--rate HZ] [--reps N]
"""
import argparse
import json
import subprocess
import sys
import tempfile

import allantools
import pandas as pd

from timing import best

p = argparse.ArgumentParser()
p.add_argument("csv")
p.add_argument("octavar")
p.add_argument("--rate", type=float, default=1000.0)
p.add_argument("--reps", type=int, default=3)
a = p.parse_args()



t_pd, frame = best(lambda: pd.read_csv(a.csv), a.reps)
y = frame["gz"].to_numpy()
t_at, (taus, devs, errs, ns) = best(lambda: allantools.oadev(y, rate=a.rate, data_type="freq", taus="octave"), 2)


peak_kb = [0]


def octavar(path, js):
    # /usr/bin/time reports the command's own peak (a child's rusage would count the pages it forked from Python).
    cmd = ["/usr/bin/time", "-f", "%M", a.octavar, "analyze", path, "--column", "gz", "--rate", str(a.rate),
           "--stats", "oadev", "--json", js]
    r = subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    peak_kb[0] = max(peak_kb[0], int(r.stderr.strip().splitlines()[-1]))


with tempfile.TemporaryDirectory() as d:
    js = f"{d}/o.json"
    t_ov, _ = best(lambda: octavar(a.csv, js), a.reps)
    doc = json.load(open(js))
    t_gz, _ = best(lambda: octavar(a.csv + ".gz", f"{d}/gz.json"), a.reps)
    gz_doc = json.load(open(f"{d}/gz.json"))
peak_mb = peak_kb[0] / 1024.0

ov = {round(pt["tau_s"] * a.rate): pt["dev"] for pt in doc["channels"][0]["stats"]["oadev"]}
ov_gz = {round(pt["tau_s"] * a.rate): pt["dev"] for pt in gz_doc["channels"][0]["stats"]["oadev"]}
worst, common = 0.0, 0
for tau, dev in zip(taus, devs):
    m = round(tau * a.rate)
    if m in ov:
        common += 1
        worst = max(worst, abs(ov[m] / dev - 1.0), abs(ov_gz[m] / dev - 1.0))
if common == 0 or worst > 1e-9:
    sys.exit(f"FAIL: {common} common octaves, worst relative difference {worst:.2e} (limit 1e-9)")

print(f"rows: {len(y)}; {common} octaves agree within {worst:.1e} relative (limit 1e-9)")
print(f"pandas.read_csv alone:              {t_pd:7.3f} s")
print(f"pandas.read_csv + allantools OADEV: {t_pd + t_at:7.3f} s")
print(f"octavar analyze, CSV end to end:    {t_ov:7.3f} s  ({t_pd / t_ov:.1f}x pandas.read_csv alone, "
      f"{(t_pd + t_at) / t_ov:.1f}x pandas + allantools)")
print(f"octavar analyze, CSV.gz end to end: {t_gz:7.3f} s")
print(f"octavar peak resident memory:       {peak_mb:7.1f} MB")
