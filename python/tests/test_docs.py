"""The worked example of docs/python.md runs as written (matplotlib drawing off screen), prints what the page
says it prints, and finds what the record holds: the simulated N and the vibration added to it."""

import os
import re
import subprocess
import sys

from conftest import ROOT, need


def test_the_worked_example_runs(tmp_path):
    need("matplotlib")
    text = (ROOT / "docs" / "python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1, "docs/python.md has one worked example"
    printed = re.search(r"It prints \(the test checks these lines\):\n\n```text\n(.*?)```", text, re.S).group(1)
    script = tmp_path / "example.py"
    script.write_text(blocks[0])
    env = dict(os.environ, MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "adev.png").stat().st_size > 10_000
    lines = out.stdout
    assert lines == printed, (lines, printed)
    # N of the simulated ADXRS300 (0.046 deg/sqrt(s)) within 10%, and the vibration named.
    n = float(re.search(r"^N = (\S+) deg/sqrt\(s\)", lines, re.M).group(1))
    assert abs(n / 0.046 - 1) < 0.1, lines
    assert re.search(r"effect: .*sinusoid", lines), lines
