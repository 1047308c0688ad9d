# Sourced by the bench scripts: the reference venv that .ci/run makes (allantools==2024.6 + numpy), made here when
# it is missing; sets PY to its python.
if [ ! -x .venv-ref/bin/python ]; then
    python3 -m venv .venv-ref
    .venv-ref/bin/pip install --quiet allantools==2024.6 numpy
fi
PY=$PWD/.venv-ref/bin/python
