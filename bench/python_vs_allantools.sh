#!/usr/bin/env bash
# octavar's Python package against allantools 2024.6 (issue 35): installs the package into the reference venv
# from this checkout (a release build, as `pip install ./python` makes it) and runs bench/python_vs_allantools.py.
# Not part of the test command (a few minutes). Timings on a loaded machine are noisy: run it quiet.
#
# usage: bench/python_vs_allantools.sh [python_vs_allantools.py options]
set -euo pipefail
cd "$(dirname "$0")/.."
. bench/ref_venv.sh
# The build backend (maturin) is in the venv already: no isolated build environment to fetch.
PATH="$(dirname "$PY"):$PATH" "$PY" -m pip install --quiet --no-build-isolation ./python
cd bench
"$PY" python_vs_allantools.py "$@"
