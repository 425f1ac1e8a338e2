"""The package's layers import in one direction only.

Every import in ``fxdsp`` (module-level, inside functions, under TYPE_CHECKING, and a module named
in a string such as a lazy export table) is read from the source with ``ast``. Each import between
two of the package's parts (a sub-package or a top-level module) must go to a lower tier of
``TIERS``; so there is no cycle between parts, and a part not placed in a tier is refused, which
makes a new sub-package choose its place. The package never imports the test tree, and writes every
import of its own modules in one style (absolute: ``from fxdsp.x import y``), so a module reads the
same wherever it is moved.

The checker is tried on a small package built here with each fault, so that it is known to fail.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest

import fxdsp

PACKAGE = Path(fxdsp.__file__).parent
TESTS = Path(__file__).parent

# lowest first: a part may import only parts of a lower tier
TIERS: list[set[str]] = [
    {"errors", "interrupts", "threads"},
    {"owned", "numeric", "plots"},
    {"units", "ramps", "outputs", "logfile", "fixed", "schemas", "configs"},
    {"api", "config"},
    {"blocks", "netlist", "mechanisms"},
    {"sensors", "causes"},
    {"chains"},
    {"vectors", "float_vs_fixed"},
    {"sim"},
    {"hdl"},
    {"budget", "diagnose"},
    {"repro", "sweep"},
    {"extend"},
    {"commands"},
    {"cli", "__init__"},
]

_DOTTED = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)+$")


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, root: Path):
    """(line, imported module, relative?) of every import in a file, and of every string constant
    that names one of the package's modules (a lazy import table)."""
    name = _module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, False
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            for alias in node.names:   # `from fxdsp import sim` imports the module `sim`, not `fxdsp`
                full = f"{module}.{alias.name}"
                yield node.lineno, full if _is_module(full, root) else module, bool(node.level)
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str) and _DOTTED.match(node.value)
              and node.value.split(".")[0] == root.name):
            yield node.lineno, node.value, False


def _is_module(dotted: str, root: Path) -> bool:
    parts = dotted.split(".")
    if parts[0] != root.name:
        return False
    path = root.parent.joinpath(*parts)
    return path.is_dir() or path.with_suffix(".py").is_file()


def _part(module: str, root: Path) -> str | None:
    """The part of the package a dotted name belongs to (None: not the package, or no such part)."""
    parts = module.split(".")
    if parts[0] != root.name:
        return None
    if len(parts) == 1:
        return "__init__"
    if (root / parts[1]).is_dir() or (root / f"{parts[1]}.py").is_file():
        return parts[1]
    return None


def layer_faults(root: Path, tiers: list[set[str]], test_names: set[str]) -> list[str]:
    """Every import that goes up or sideways between tiers, every part placed in no tier, every
    relative import and every import of a test module, as one line each."""
    tier_of = {part: i for i, tier in enumerate(tiers) for part in tier}
    faults = []
    for path in sorted(root.rglob("*.py")):
        here = _part(_module_name(path, root), root)
        where = path.relative_to(root.parent)
        if here not in tier_of:
            faults.append(f"{where}: part {here!r} is in no tier")
            continue
        for line, module, relative in _imports(path, root):
            if relative:
                faults.append(f"{where}:{line}: relative import of {module} (write it as absolute)")
            top = module.split(".")[0]
            if top in test_names or top == "tests":
                faults.append(f"{where}:{line}: imports the test tree ({module})")
                continue
            there = _part(module, root)
            if there is None or there == here:
                continue
            if there not in tier_of:
                faults.append(f"{where}:{line}: imports {module}, whose part {there!r} is in no tier")
            elif tier_of[there] >= tier_of[here]:
                faults.append(f"{where}:{line}: {here} (tier {tier_of[here]}) imports {module} "
                              f"({there}, tier {tier_of[there]}): not a lower tier")
    for path in sorted(root.rglob("*.py")):
        if re.search(r"sys\.path\.(insert|append)|sys\.path\s*\[", path.read_text(encoding="utf-8")):
            faults.append(f"{path.relative_to(root.parent)}: changes sys.path")
    return sorted(set(faults))


def _test_module_names() -> set[str]:
    """The names a module of the test tree is importable by when the tests put it on sys.path."""
    names = {p.stem for p in TESTS.rglob("*.py")} | {p.name for p in TESTS.rglob("*") if p.is_dir()}
    names -= {"__init__", "__pycache__"}
    return {n for n in names if n not in sys.stdlib_module_names}


def test_the_package_imports_down_its_tiers_only():
    faults = layer_faults(PACKAGE, TIERS, _test_module_names())
    assert not faults, "\n".join(faults)


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for name, text in {"__init__.py": "", **files}.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text, encoding="utf-8")
    return root


@pytest.mark.parametrize("files, expected", [
    # a cycle hidden in a function: the upward half is named
    ({"low/__init__.py": "def f():\n    from pkg.high import g\n", "high/__init__.py": "from pkg.low import f\n"},
     "low (tier 0) imports pkg.high"),
    # a lazy import table naming a higher module in a string
    ({"low/__init__.py": "_EXPORTS = {'g': 'pkg.high.mod'}\n", "high/mod.py": ""}, "imports pkg.high.mod"),
    ({"low/__init__.py": "from pkg.low import x\n", "low/a.py": "from .b import y\n", "low/b.py": ""},
     "relative import of pkg.low.b"),
    ({"low/__init__.py": "", "high/__init__.py": "import hdl_util\n"}, "imports the test tree (hdl_util)"),
    ({"low/__init__.py": "import sys\nsys.path.insert(0, 'tests/hdl')\n"}, "changes sys.path"),
    ({"low/__init__.py": "", "middle.py": ""}, "part 'middle' is in no tier"),
    # two parts of one tier importing each other: a cycle the tiers also refuse
    ({"low/__init__.py": "from pkg.other import z\n", "other.py": "from pkg.low import w\n"},
     "not a lower tier"),
])
def test_the_checker_finds_each_kind_of_fault(tmp_path, files, expected):
    root = _package(tmp_path, files)
    tiers = [{"low", "other", "__init__"}, {"high"}]
    faults = layer_faults(root, tiers, {"hdl_util"})
    assert any(expected in f for f in faults), faults


def test_the_checker_passes_a_package_that_imports_down(tmp_path):
    root = _package(tmp_path, {"low/__init__.py": "X = 1\n",
                               "high/__init__.py": "from pkg.low import X\n\ndef f():\n    import pkg.low\n"})
    assert layer_faults(root, [{"low", "__init__"}, {"high"}], {"hdl_util"}) == []
