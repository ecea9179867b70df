"""Running the command line in tests: in-process through Click's CliRunner, or as a process."""

import subprocess
import sys
from types import SimpleNamespace

from click.testing import CliRunner

from unjello.cli.commands import cli


def run(*args):
    """Run ``unjello ARGS`` in this process (Click's CliRunner); stdout and stderr apart."""
    res = CliRunner().invoke(cli, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    return SimpleNamespace(returncode=res.exit_code, stdout=res.stdout, stderr=res.stderr)


def run_process(*args, cwd=None):
    """Run the real CLI in a subprocess, where the process is the point (exit codes, pools)."""
    return subprocess.run([sys.executable, "-m", "unjello", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


def clean_failure(res):
    """Assert a failure said in exactly one line, without a traceback; return the line."""
    assert res.returncode != 0
    assert "Traceback" not in res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    return lines[0]
