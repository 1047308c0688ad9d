#!/usr/bin/env bash
# The bounded-memory floor (issue 4 item 5): 72 h at 2 kS/s = 518.4 million samples, OADEV at octave tau and the
# fit, from a raw binary file and from stdin, with /usr/bin/time -v: wall time and peak RSS.
# Floor: <= 10 s and <= 512 MB. Not part of the test command (writes a 2 GB file, takes a minute).
#
# usage: bench/stream_518m.sh [FORMAT (f32le|f64le|i16le)] [N_SAMPLES]
set -euo pipefail
cd "$(dirname "$0")/.."
FORMAT=${1:-f32le}
N=${2:-518400000}
PY=${OCTAVAR_PYTHON:-.venv-ref/bin/python}
if [ ! -x "$PY" ]; then
    python3 -m venv .venv-ref
    .venv-ref/bin/pip install --quiet allantools==2024.6 numpy
    PY=.venv-ref/bin/python
fi
cargo build --release -q -p octavar-cli
BIN=${CARGO_TARGET_DIR:-target}/release/octavar
WORK=${BENCH_DIR:-$(mktemp -d)}
DATA="$WORK/rate_$N.$FORMAT"
[ -s "$DATA" ] || "$PY" bench/gen_rate.py "$DATA" "$N" --format "$FORMAT" --rate 2000
ls -l "$DATA"
cat "$DATA" > /dev/null  # warm the page cache: the run measures octavar, not the disk

run() {
    local label=$1; shift
    /usr/bin/time -v "$@" > "$WORK/out.txt" 2> "$WORK/time.txt" || { cat "$WORK/time.txt"; exit 1; }
    local wall rss
    wall=$(grep "Elapsed (wall clock)" "$WORK/time.txt" | awk '{print $NF}')
    rss=$(grep "Maximum resident set size" "$WORK/time.txt" | awk '{print $NF}')
    printf '%-8s wall %s  peak RSS %.0f MB  (user %ss, sys %ss)\n' "$label" "$wall" "$(echo "$rss/1024" | bc -l)" \
        "$(grep 'User time' "$WORK/time.txt" | awk '{print $NF}')" "$(grep 'System time' "$WORK/time.txt" | awk '{print $NF}')"
}
run file "$BIN" analyze "$DATA" --format "$FORMAT" --rate 2000 --column gz
sed -n '1,40p' "$WORK/out.txt"
run stdin sh -c "cat '$DATA' | '$BIN' analyze - --format $FORMAT --rate 2000 --column gz"
[ -n "${BENCH_DIR:-}" ] || rm -rf "$WORK"
