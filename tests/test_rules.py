"""The tuning rules' index: ``docs/rules.md`` is what ``scripts/rules.py`` writes, every
rule of the per-pixel path says in a ``#:`` comment what it decides, and no threshold
hides in a keyword default."""

import ast
import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("rules", ROOT / "scripts" / "rules.py")
rules = sys.modules["rules"] = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rules)

PATH = [p for _, paths in rules.STAGES for p in paths]


def test_the_index_is_up_to_date():
    assert (ROOT / "docs" / "rules.md").read_text() == rules.render(), (
        "docs/rules.md is out of date: run python scripts/rules.py")


def test_every_module_of_the_path_is_in_one_stage():
    modules = {p.relative_to(rules.SRC).as_posix() for pkg in rules.PACKAGES
               for p in (rules.SRC / pkg).glob("*.py") if p.name != "__init__.py"}
    assert sorted(PATH) == sorted(set(PATH)), "a module in two stages"
    assert modules <= set(PATH), modules - set(PATH)


@pytest.mark.parametrize("path", PATH)
def test_every_rule_says_what_it_decides(path):
    bare = [r.name for r in rules.rules_in(path) if not r.marked]
    assert not bare, f"{path}: give {bare} a #: comment"


#: Keyword defaults that are switches or guards, not tuned thresholds.
NOT_RULES = {("__init__", "ahead"), ("sinusoid_pursuit", "ridge"), ("optical_flow", "polish"),
             ("solve_camera_trajectory", "robust"),
             ("flow_pair", "max_width"), ("phase_correlate", "search"), ("fill_hull", "value"),
             ("splat", "eps"), ("costlier", "margin")}


@pytest.mark.parametrize("path", PATH)
def test_no_threshold_hides_in_a_keyword_default(path):
    tree = ast.parse((rules.SRC / path).read_text())
    hidden = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            a = node.args
            pairs = list(zip(a.args[len(a.args) - len(a.defaults):], a.defaults, strict=True))
            pairs += [(k, d) for k, d in zip(a.kwonlyargs, a.kw_defaults, strict=True)
                      if d is not None]
            hidden += [f"{node.name}({arg.arg}={d.value})" for arg, d in pairs
                       if isinstance(d, ast.Constant) and type(d.value) in (int, float)
                       and (node.name, arg.arg) not in NOT_RULES]
    assert not hidden, f"{path}: name these as constants with a #: comment: {hidden}"


def test_a_rule_comment_is_one_or_two_lines():
    """A ``#:`` comment says what its rule decides; the evidence lives in the docs it names."""
    long = []
    for path in sorted((ROOT / "src" / "unjello").rglob("*.py")):
        run = 0
        for i, line in enumerate(path.read_text().splitlines() + [""], start=1):
            if line.lstrip().startswith("#:"):
                run += 1
                continue
            if run > 2:
                long.append(f"{path.relative_to(ROOT)}:{i - run}")
            run = 0
    assert not long, long
