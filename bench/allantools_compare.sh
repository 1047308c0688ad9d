#!/usr/bin/env bash
# octavar against allantools 2024.6 (issue 4 item 7): the same deterministic 1e7-sample rate file (f64le, 2 kHz),
# OADEV at octave tau; the numbers must agree within 1e-9 relative; prints compute and end-to-end times and their
# ratios. Not part of the test command (about a minute). Timings on a loaded machine are noisy: run it quiet.
#
# usage: bench/allantools_compare.sh [N_SAMPLES]
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-10000000}
# The venv .ci/run makes (allantools==2024.6 + numpy), reused when present.
. bench/ref_venv.sh
cargo build --release -q -p octavar-cli
cargo bench -q -p octavar --bench analyze --no-run 2>/dev/null
TARGET=${CARGO_TARGET_DIR:-$PWD/target}
BENCH=$(ls -t "$TARGET"/release/deps/analyze-* | grep -v '\.d$' | head -1)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$PY" bench/gen_rate.py "$WORK/rate.f64" "$N" --format f64le --rate 2000
"$PY" bench/allantools_compare.py "$WORK/rate.f64" "$TARGET/release/octavar" "$BENCH" --rate 2000
