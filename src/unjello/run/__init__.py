"""Running clips on more than one core or machine, within a memory budget.

* :mod:`~unjello.run.parallel`: a thread pool for one clip's frame-level work;
* :mod:`~unjello.run.heap`: memory the process freed handed back to the system;
* :mod:`~unjello.run.batch`: many clips on local processes, Dask or Ray;
* :mod:`~unjello.run.segments`: one long clip cut at keyframes, corrected on workers,
  joined without re-encoding.
"""
