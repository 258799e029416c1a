"""The package's shape: stage folders, a small root, no client imported by the core, no import circle."""

from __future__ import annotations

import ast
import graphlib
from pathlib import Path

import pytest

import sogdd

PKG = Path(sogdd.__file__).resolve().parent
REPO = PKG.parents[1]
CORE_EXCLUDED = ("theory", "baselines", "evaluation", "report", "cli")


def _modules() -> dict[str, Path]:
    """Dotted name -> file, for every module of the installed package."""
    out = {}
    for p in PKG.rglob("*.py"):
        rel = p.relative_to(PKG).with_suffix("").parts
        name = ".".join(("sogdd",) + (rel[:-1] if rel[-1] == "__init__" else rel))
        out[name] = p
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Every sogdd module ``name`` imports, anywhere in the file (functions and TYPE_CHECKING included)."""
    is_pkg = path.name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("sogdd")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                pkg = base[: len(base) - node.level + 1]
                mod = ".".join(pkg + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("sogdd"):
                continue
            for a in node.names:
                sub = f"{mod}.{a.name}"
                found.add(sub if sub in modules else mod)
    return {m for m in found if m in modules and m != name}


def _is_core(name: str) -> bool:
    if name == "sogdd.__main__":  # ``python -m sogdd``: the command line's entry point, a client
        return False
    parts = name.split(".")
    return len(parts) < 2 or parts[1] not in CORE_EXCLUDED


def test_root_holds_at_most_fifteen_modules():
    root = [p.stem for p in PKG.glob("*.py") if p.stem not in ("__init__", "__main__", "_version")]
    assert len(root) <= 15, sorted(root)
    for stage in ("image", "measure", "select", "gpu", "formats"):
        doc = ast.get_docstring(ast.parse((PKG / stage / "__init__.py").read_text()))
        assert doc and "module" in doc, f"sogdd.{stage} says what each module does"


def test_the_core_never_imports_a_client():
    modules = _modules()
    bad = [(m, t) for m, p in modules.items() if _is_core(m)
           for t in _imports(m, p, modules) if not _is_core(t)]
    assert bad == []


def test_no_import_circle():
    """A module reachable from itself through named imports (TYPE_CHECKING and function imports too)."""
    modules = _modules()
    graph = {m: _imports(m, p, modules) for m, p in modules.items()}
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as exc:
        pytest.fail(f"import circle: {' -> '.join(exc.args[1])}")


@pytest.mark.skipif(not (REPO / "tests").is_dir(), reason="needs the repository checkout")
def test_no_file_over_450_lines():
    long = []
    for folder in ("src", "tests", "benchmarks", "tools", "studies"):
        for p in (REPO / folder).rglob("*.py"):
            n = len(p.read_text().splitlines())
            if n > 450:
                long.append((str(p.relative_to(REPO)), n))
    assert long == []
