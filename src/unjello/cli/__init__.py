"""The command line: the only place that prints, draws progress and exits.

* :mod:`~unjello.cli.commands`: the ``unjello`` group and ``correct``, ``batch``,
  ``preview``, ``simulate``, ``evaluate``, ``plot``, ``probe``; library errors as one line;
* :mod:`~unjello.cli.readout`: ``readout``, ``estimate-readout``, ``cameras``;
* :mod:`~unjello.cli.gyroflow`: ``export-gyroflow``;
* :mod:`~unjello.cli.demo`: ``demo``, the built-in example.
"""
