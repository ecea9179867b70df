"""Write ``docs/rules.md``: every tuning rule of the per-pixel path, grouped by stage.

A rule is a module-level constant of the path's modules whose value holds a number; its
``#:`` comment (the lines right above it) says what it decides and points to the
measurement that set it. The dense method's settings (:class:`DenseConfig`'s fields) are
listed with their docstring. ``tests/test_rules.py`` fails when the page is out of date
or a rule has no ``#:`` comment: run ``python scripts/rules.py`` after changing one.
"""

from __future__ import annotations

import ast
import re
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "unjello"
OUT = ROOT / "docs" / "rules.md"

#: The per-pixel path's stages in the order a frame meets them, and their modules.
STAGES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("Flow between frames", ("motion/flow/dis.py", "motion/flow/inverse.py",
                             "motion/flow/patches.py", "motion/flow/phase.py")),
    ("Where a clip breaks", ("motion/cuts.py",)),
    ("The camera model: smooth or vibrating", ("motion/dense/vibration.py",
                                               "motion/dense/choice.py")),
    ("The camera trajectory", ("motion/dense/camera.py",)),
    ("The per-pixel residual and field", ("motion/dense/method.py", "motion/dense/field.py",
                                          "motion/dense/config.py")),
    ("Do no harm: folds, objects, spinners", ("motion/dense/safety.py",
                                              "motion/objects/folds.py",
                                              "motion/objects/rigid.py",
                                              "motion/objects/support.py",
                                              "motion/objects/spinners.py")),
    ("The warp", ("warp/warper.py", "warp/maps.py", "warp/bands.py", "warp/scanlines.py",
                  "warp/front_layers.py")),
    ("What the frame did not see", ("warp/fill/planes.py", "warp/fill/neighbours.py",
                                    "warp/fill/uncovered.py", "warp/fill/leaving.py")),
)
#: The packages the path's modules live in: each of their modules is in one stage.
PACKAGES = ("motion/flow", "motion/dense", "motion/objects", "warp", "warp/fill")


@dataclass(frozen=True)
class Rule:
    """One tuning constant: where it is, its value and its ``#:`` comment."""

    name: str
    value: str
    path: str
    line: int
    comment: tuple[str, ...]
    marked: bool  # the comment is a ``#:`` one


def _numeric(node: ast.AST) -> bool:
    return any(isinstance(n, ast.Constant) and isinstance(n.value, (int, float))
               and not isinstance(n.value, bool) for n in ast.walk(node))


def rules_in(path: str) -> list[Rule]:
    """Return the rules of one module (``path`` under ``src/unjello``)."""
    text = (SRC / path).read_text()
    lines = text.splitlines()
    out = []
    for node in ast.parse(text).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target, value = node.targets[0], node.value
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            target, value = node.target, node.value
        else:
            continue
        if isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple):
            pairs = list(zip(target.elts, value.elts, strict=True))
        else:
            pairs = [(target, value)]
        above = []
        k = node.lineno - 2
        while k >= 0 and lines[k].lstrip().startswith("#"):
            above.insert(0, lines[k].strip())
            k -= 1
        marked = bool(above) and all(a.startswith("#:") for a in above)
        comment = tuple(re.sub(r"^#:? ?", "", a) for a in above)
        for t, v in pairs:
            if not (isinstance(t, ast.Name) and t.id.lstrip("_").isupper()
                    and t.id != "__all__" and _numeric(v)):
                continue
            seg = " ".join((ast.get_source_segment(text, v) or "").split())
            out.append(Rule(t.id, seg, path, node.lineno, comment, marked))
    return out


def _first_sentence(comment: tuple[str, ...]) -> str:
    text = re.sub(r"^\.\.\.\s*", "", " ".join(comment))
    m = re.search(r"^(.+?\.)(?=\s+[A-Z(`:]|$)", text)
    first = m.group(1) if m else text
    return first if len(first) <= 240 else first[:237].rsplit(" ", 1)[0] + " ..."


def _evidence(comment: tuple[str, ...]) -> str:
    refs = sorted(set(re.findall(r"(?:docs|benchmarks)/[\w/.-]+?\.(?:md|py)(?:#[\w-]+)?",
                                 " ".join(comment))))
    return ", ".join(f"`{r}`" for r in refs) or "–"


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def settings() -> list[tuple[str, str, str]]:
    """:class:`DenseConfig`'s fields: name, default, the docstring's first sentence."""
    text = (SRC / "motion/dense/config.py").read_text()
    cls = next(n for n in ast.parse(text).body
               if isinstance(n, ast.ClassDef) and n.name == "DenseConfig")
    doc = ast.get_docstring(cls) or ""
    out = []
    for node in cls.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            name = node.target.id
            m = re.search(rf"^{name} :.*\n((?:    .*\n?)+)", doc, re.M)
            what = _first_sentence(tuple(m.group(1).split("\n"))) if m else "–"
            default = ast.get_source_segment(text, node.value) if node.value else ""
            out.append((name, default or "", " ".join(what.split())))
    return out


def render() -> str:
    """Return the page, as ``docs/rules.md`` holds it."""
    out = ["# The tuning rules of the per-pixel path", "",
           "Every constant that decides something on the default (`dense`) path, by stage,",
           "in the order a frame meets them: its value, where it is, what it decides (the",
           "first sentence of its `#:` comment) and what measured it. Generated by",
           "`python scripts/rules.py`; `tests/test_rules.py` fails when this page is out",
           "of date. The stages themselves: [method.md](method.md#the-stages).", ""]
    for title, paths in STAGES:
        out += [f"## {title}", "", "| rule | value | where | what it decides | measured in |",
                "|---|---|---|---|---|"]
        for path in paths:
            for r in rules_in(path):
                where = f"[{r.path}:{r.line}](../src/unjello/{r.path}#L{r.line})"
                out.append(f"| `{r.name}` | `{_cell(r.value)}` | {where} | "
                           f"{_cell(_first_sentence(r.comment))} | {_evidence(r.comment)} |")
        out.append("")
    out += ["## The dense method's settings", "",
            "`DenseConfig`'s fields (`src/unjello/motion/dense/config.py`), each a default the",
            "measurements in [tuning.md](tuning.md) chose; presets and flags change them.", "",
            "| setting | default | what it decides |", "|---|---|---|"]
    out += [f"| `{n}` | `{_cell(d)}` | {_cell(w)} |" for n, d, w in settings()]
    return "\n".join(out) + "\n"


def main() -> int:
    """Write the page."""
    OUT.write_text(render())
    print(f"wrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
