#!/usr/bin/env bash
# Reading a CSV, octavar against pandas (issue 19 item 6): one run writes a deterministic 1e7-row, one-column CSV
# (`%.9e`, and a gzipped copy), times pandas.read_csv alone, pandas.read_csv + allantools OADEV, and
# `octavar analyze FILE --stats oadev` end to end on the CSV and on the .gz, checks that the OADEVs agree within
# 1e-9 relative, and prints the times, the ratios and octavar's peak memory. Not part of the test command (about
# a minute); run it on a quiet machine.
#
# usage: bench/ingest_compare.sh [N_ROWS]
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-10000000}
# The reference venv .ci/run makes (allantools, pandas).
. bench/ref_venv.sh
cargo build --release -q -p octavar-cli
TARGET=${CARGO_TARGET_DIR:-$PWD/target}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$PY" bench/gen_rate.py "$WORK/rate.csv" "$N" --format csv --rate 1000
gzip -k -6 "$WORK/rate.csv"
"$PY" bench/ingest_compare.py "$WORK/rate.csv" "$TARGET/release/octavar" --rate 1000
