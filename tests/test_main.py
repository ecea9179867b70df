"""The command's entry point: BLAS on one thread unless the user chose, NumPy loaded after."""

import os
import subprocess
import sys

PROBE = """
import sys
from unjello.__main__ import run
sys.argv = ["unjello", "--version"]
try:
    run()
except SystemExit:
    pass
from threadpoolctl import threadpool_info
print(sorted({i["num_threads"] for i in threadpool_info() if i["internal_api"] == "openblas"}))
"""


def _blas_threads(env: dict[str, str]) -> str:
    res = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                         env=env, check=True)
    return res.stdout.strip().splitlines()[-1]


def test_the_command_runs_blas_on_one_thread():
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    assert _blas_threads(env) == "[1]"


def test_the_users_own_blas_setting_wins():
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "2"}
    assert _blas_threads(env) == "[2]"
