"""Every script in ``scripts/`` imports (its work runs under ``__main__`` only), so a
module it uses that moved or went breaks a test, not the next person who runs it. The
examples run in ``tests/test_examples.py``; ``scripts/rules.py`` runs in
``tests/test_rules.py``."""

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPTS = sorted((Path(__file__).resolve().parents[1] / "scripts").glob("*.py"))


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.name for p in SCRIPTS])
def test_the_script_imports(path, monkeypatch):
    name = f"script_{path.stem}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, name, module)
    spec.loader.exec_module(module)
    assert callable(getattr(module, "main", None)), f"{path.name} has no main()"
