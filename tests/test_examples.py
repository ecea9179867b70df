"""The runnable examples run, and say what they promise."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["correct_simulated_clip.py", "correct_with_gyro.py"])
def test_example_corrects_its_clip(name):
    res = subprocess.run([sys.executable, str(EXAMPLES / name)], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    before, after = (float(v) for v in re.search(
        r"([\d.]+) px before, ([\d.]+) px after", res.stdout).groups())
    assert after < 0.1 * before


def test_the_speed_profile_finds_every_stage_it_times():
    """benchmarks/speed.py --profile wraps functions by module and name: each must exist
    (a function moved to another module would break the profile, not a test)."""
    from benchmarks.speed import STAGES, _resolve

    for _, targets in STAGES:
        for where, name in targets:
            assert callable(_resolve(where).__dict__.get(name)), (where, name)
