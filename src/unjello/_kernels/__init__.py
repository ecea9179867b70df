"""Compiled per-pixel loops (Numba), each with a NumPy reference in the tests.

Nothing here imports the rest of the package (``tests/test_imports.py``).

* :mod:`~unjello._kernels.jit`: the compiler, cached where it can be;
* :mod:`~unjello._kernels.pixelwise`: the dense method's checks, residuals, Jacobian and
  the per-scanline row shift;
* :mod:`~unjello._kernels.field`: the field helpers' fill, snap and maps;
* :mod:`~unjello._kernels.drift`: the scoring of an object's drift.
"""
