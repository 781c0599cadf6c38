"""The reproduction example runs and the exact filter beats the raw sensor (a short run)."""

import os
import re
import subprocess
import sys

HERE = os.path.dirname(__file__)


def test_fuel_filter_example(tmp_path):
    script = os.path.join(HERE, "..", "examples", "fuel_filter.py")
    proc = subprocess.run(
        [sys.executable, script, "--steps", "600", "--plot", str(tmp_path / "f.png")],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    err = dict(re.findall(r"^\s+(raw sensor|filter with S \(exact\))\s+(\S+)$", proc.stdout, re.M))
    # The filter with the exact model must beat the raw sensor on data from that model;
    # with 500 steps after the transient the RMS estimates are within ~10 % of their limits,
    # far from the factor of ~2.7 between them seen on longer runs.
    assert float(err["filter with S (exact)"]) < float(err["raw sensor"])
