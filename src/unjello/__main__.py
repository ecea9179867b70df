"""``python -m unjello`` and the ``unjello`` command: the command line.

NumPy's BLAS (OpenBLAS) starts a thread per core when NumPy loads, and those threads spin
after every call: the command's algebra is small (a few hundred unknowns) and the encoder
wants the cores, so the command runs BLAS on one thread unless the user set
``OPENBLAS_NUM_THREADS``. On the 1080p speed clip that cost 2 % of the whole run's CPU
(``docs/history/measurements.md``). It is set before anything imports NumPy; the library, imported
on its own, leaves the user's process as it is.
"""

import os


def run() -> None:
    """Run the command line with one BLAS thread (unless the user chose otherwise)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from .cli.commands import main

    main()


if __name__ == "__main__":
    run()
