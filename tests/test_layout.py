"""The package's shape: stage folders in order, one concept per module, no client in the core, no circle."""

from __future__ import annotations

import ast
import graphlib
import re
from pathlib import Path

import pytest

import sogdd

PKG = Path(sogdd.__file__).resolve().parent
REPO = PKG.parents[1]
CORE_EXCLUDED = ("theory", "baselines", "evaluation", "report", "cli", "collection", "calib")


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


#: the core's stages, in the order the grey image goes through them
STAGES = ("image", "measure", "select")
#: the folders whose ``__init__`` says, in a table, what each of their modules is
DOCUMENTED = ("image", "measure", "select", "gpu", "formats", "calib", "calib/targets",
              "calib/targets/chessboard",
              "calib/cameras")


def _stage(name: str) -> int | None:
    parts = name.split(".")
    return STAGES.index(parts[1]) if len(parts) > 1 and parts[1] in STAGES else None


def test_a_stage_imports_no_later_stage():
    """image -> measure -> select: a stage uses what earlier stages made, never what comes after it."""
    modules = _modules()
    bad = [(m, t) for m, p in modules.items() if _stage(m) is not None
           for t in _imports(m, p, modules) if _stage(t) is not None and _stage(t) > _stage(m)]
    assert bad == []


@pytest.mark.parametrize("folder", DOCUMENTED)
def test_each_module_is_one_concept_named_in_its_stage(folder):
    """The folder's table names every module with what it does, and names no module that is not there."""
    doc = ast.get_docstring(ast.parse((PKG / folder / "__init__.py").read_text()))
    listed = set(re.findall(r"^:mod:`\.(\w+)`", doc, flags=re.M))
    present = {p.stem for p in (PKG / folder).glob("*.py") if p.stem != "__init__"}
    present |= {p.parent.name for p in (PKG / folder).glob("*/__init__.py")}
    assert listed == present


@pytest.mark.skipif(not (REPO / "tests").is_dir(), reason="needs the repository checkout")
def test_no_file_over_the_sanity_ceiling():
    """About 800 lines: a file longer than that holds more than one concept (the split is by concept,
    not by a count; this only catches a file that grew out of hand)."""
    long = []
    for folder in ("src", "tests", "benchmarks", "tools", "studies"):
        for p in (REPO / folder).rglob("*.py"):
            n = len(p.read_text().splitlines())
            if n > 800:
                long.append((str(p.relative_to(REPO)), n))
    assert long == []


#: calib's sub-packages: each uses the core and itself, never the calibration around it
CALIB_LEAVES = ("sogdd.calib.targets", "sogdd.calib.cameras")


@pytest.mark.parametrize("leaf", CALIB_LEAVES)
def test_calib_sub_packages_import_nothing_back_up(leaf):
    """A board or a camera model is usable alone: ``targets`` and ``cameras`` import no other part of
    ``sogdd.calib`` (nor each other), and no client of the core."""
    modules = _modules()
    inside = [m for m in modules if m == leaf or m.startswith(leaf + ".")]
    assert len(inside) > 2, inside
    bad = [(m, t) for m in inside for t in _imports(m, modules[m], modules)
           if not (t == leaf or t.startswith(leaf + ".")) and not _is_core(t)]
    assert bad == []


def test_the_evaluations_hold_no_camera_model_of_their_own():
    """One camera model: the renderer and the evaluations use :mod:`sogdd.calib.cameras`, and no module
    outside it defines the distortion polynomial."""
    polynomial = re.compile(r"1 \+ r2 \* \(k1 \+ r2 \* \(k2 \+ r2 \* k3\)\)")
    found = [p.relative_to(PKG).parts for p in PKG.rglob("*.py") if polynomial.search(p.read_text())]
    assert any("cameras" in f for f in found), "the search finds the model where it lives"
    assert [f for f in found if "cameras" not in f] == []


def test_no_private_name_is_imported_from_another_module():
    """A module's private names (``_x``) are its own: what another module needs is public there."""
    found = []
    for p in PKG.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom):
                found += [f"{p.relative_to(PKG)}: {node.module}.{a.name}" for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")]
    assert found == []
