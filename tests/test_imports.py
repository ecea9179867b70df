"""The architecture's import rules, checked on the source (DESIGN.md, import contracts).

* only ``unjello.io`` imports ``av`` (I/O at the edges);
* ``unjello.motion`` imports none of ``io``, ``warp``, ``pipeline``, ``config``, ``cli``,
  ``exports``, ``run`` (methods take arrays and return a Trajectory's frames);
* ``unjello.warp`` imports nothing from ``motion`` (the warp reads a FrameMotion);
* ``unjello._kernels`` imports nothing of the package but itself (compiled loops only);
* ``unjello.io`` imports nothing from ``motion`` (the readers make data: a gyro log is
  :mod:`unjello.gyrolog`'s, not the gyro method's);
* nothing imports ``unjello.cli`` (but ``__main__``);
* ``unjello.config`` is the settings schema: it reads no file (none of ``io``'s readers;
  ``io.video`` only for the encoder's settings); ``unjello.clip`` reads a clip's files;
* no two modules import each other, directly or through others (no cycles).

Imports inside functions count: a lazy import is still a dependency.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "unjello"


def _module_name(path: Path) -> str:
    parts = ["unjello", *path.relative_to(SRC).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Modules a file imports, absolute (``from . import x`` resolved to ``pkg.x`` if a module)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out.add(target)
            for alias in node.names:  # `from . import sub` imports the submodule
                if _exists(f"{target}.{alias.name}"):
                    out.add(f"{target}.{alias.name}")
    return out


def _exists(module: str) -> bool:
    rel = Path(*module.split(".")[1:])
    return (SRC / rel).with_suffix(".py").is_file() or (SRC / rel / "__init__.py").is_file()


GRAPH = {_module_name(p): _imports(p) for p in sorted(SRC.rglob("*.py"))}


def _ours(graph_imports: set[str]) -> set[str]:
    return {m for m in graph_imports if m == "unjello" or m.startswith("unjello.")}


def _under(module: str, *packages: str) -> bool:
    """Whether ``module`` is one of ``packages`` or inside one."""
    return any(module == p or module.startswith(p + ".") for p in packages)


def test_the_graph_is_the_package():
    assert {"unjello.pipeline", "unjello.config", "unjello.motion.dense.method",
            "unjello.io.source"} <= set(GRAPH)
    assert "unjello.io.frames" in GRAPH["unjello.io.source"]


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_only_io_imports_av(module):
    if not module.startswith("unjello.io"):
        assert not {m for m in GRAPH[module] if m == "av" or m.startswith("av.")}, module


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if m.startswith("unjello.motion")))
def test_motion_imports_no_files_warp_pipeline_or_cli(module):
    banned = ("unjello.io", "unjello.warp", "unjello.pipeline", "unjello.config", "unjello.cli",
              "unjello.exports", "unjello.run")
    bad = {m for m in GRAPH[module] if _under(m, *banned)}
    assert not bad, f"{module} imports {bad}"


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if _under(m, "unjello.warp")))
def test_warp_imports_nothing_from_motion(module):
    bad = {m for m in GRAPH[module] if _under(m, "unjello.motion")}
    assert not bad, f"{module} imports {bad}"


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if _under(m, "unjello._kernels")))
def test_the_kernels_import_nothing_of_the_package(module):
    bad = {m for m in _ours(GRAPH[module]) if not _under(m, "unjello._kernels")}
    assert not bad, f"{module} imports {bad}"


def test_the_settings_read_no_file():
    io = {m for m in GRAPH["unjello.config"] if m.startswith("unjello.io")}
    assert io <= {"unjello.io.video"}, io  # EncodeOptions, the encoder's settings
    tree = ast.parse((SRC / "config.py").read_text())
    names = {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
             and (n.module or "").startswith("io") for a in n.names}
    assert names <= {"EncodeOptions"}, names


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if m.startswith("unjello.io")))
def test_io_imports_nothing_from_motion(module):
    bad = {m for m in GRAPH[module] if m.startswith("unjello.motion")}
    assert not bad, f"{module} imports {bad}"


def test_nothing_imports_the_cli():
    users = {m for m, deps in GRAPH.items()
             if any(_under(d, "unjello.cli") for d in deps) and not _under(m, "unjello.cli")}
    assert users <= {"unjello.__main__"}, users


def test_no_import_cycles():
    # Packages' __init__ files gather the public names; the rules are about modules.
    graph = {m: {d for d in _ours(deps) if d in GRAPH and d != m and d != "unjello"}
             for m, deps in GRAPH.items() if m != "unjello"}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not cycles, cycles


def test_a_cycle_would_be_found(monkeypatch):
    """The checker itself: a made-up mutual import is reported."""
    monkeypatch.setitem(GRAPH, "unjello.timing", GRAPH["unjello.timing"] | {"unjello.warp.warper"})
    with pytest.raises(AssertionError, match="unjello.timing"):
        test_no_import_cycles()


#: Lines each package may hold (its own files, not its subpackages'): past it, a package
#: holds more than one job and splits into subpackages, as ``motion`` did.
BUDGET = {"unjello": 4500, "unjello._kernels": 1000, "unjello.cli": 1000,
          "unjello.exports": 1000, "unjello.io": 2600, "unjello.motion": 400,
          "unjello.motion.dense": 2500, "unjello.motion.flow": 1200,
          "unjello.motion.gyro": 750, "unjello.motion.objects": 1750,
          "unjello.motion.paper": 1500, "unjello.preview": 600, "unjello.readout": 1800,
          "unjello.run": 900, "unjello.simulate": 1700, "unjello.warp": 1000,
          "unjello.warp.fill": 1500}


def test_packages_stay_within_their_budget():
    """Each package within its line budget; the top holds at most 15 modules; no module
    past 600 lines (two jobs); the streaming module stays a driver."""
    sizes: dict[str, int] = {}
    for p in SRC.rglob("*.py"):
        package = ".".join(["unjello", *p.relative_to(SRC).parent.parts])
        sizes[package] = sizes.get(package, 0) + len(p.read_text().splitlines())
    assert set(sizes) == set(BUDGET), set(sizes) ^ set(BUDGET)
    assert not {k: (v, BUDGET[k]) for k, v in sizes.items() if v > BUDGET[k]}
    assert len(list(SRC.glob("*.py"))) <= 15
    files = {p.relative_to(SRC).as_posix(): len(p.read_text().splitlines())
             for p in SRC.rglob("*.py")}
    assert files["pipeline.py"] <= 500
    assert not {k: v for k, v in files.items() if v > 600}


def test_importing_the_package_loads_what_it_uses():
    # Public names are imported on first use: the command line sets up NumPy's threads
    # before NumPy loads (unjello.__main__), and every public name still resolves.
    code = ("import sys, unjello\nassert 'numpy' not in sys.modules\n"
            "for name in unjello.__all__:\n    getattr(unjello, name)\n"
            "assert sorted(dir(unjello)) == sorted(unjello.__all__)\n"
            "print('ok')")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.stdout.strip() == "ok", res.stderr


def test_the_type_checkers_imports_name_where_each_public_name_lives():
    """``unjello/__init__.py``'s imports for type checkers (never run) name real modules."""
    import importlib

    tree = ast.parse((SRC / "__init__.py").read_text())
    block = next(n for n in tree.body if isinstance(n, ast.If))
    for node in block.body:
        assert isinstance(node, ast.ImportFrom) and node.level == 1
        module = importlib.import_module(f"unjello.{node.module}")
        for alias in node.names:
            assert hasattr(module, alias.name), (node.module, alias.name)
