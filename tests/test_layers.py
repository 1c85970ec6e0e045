"""The package's shape: stages import only the stages before them, no module imports another's private
names, and modules hold one idea (a size limit)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mbimpact"

# The pipeline's order (the package docstring): a subpackage may import those of a lower or equal rank.
RANK = {
    "errors": 0, "common": 0, "results": 0,
    "mechanism": 1, "geometry": 1,
    "metric": 2,
    "quadrature": 3, "roughness": 3,
    "facets": 4,
    "averaging": 5,
    "laws": 6,
    "pipeline": 7,
    "compliant": 8, "calibration": 8,
    "simulation": 9,
    "theory": 10, "apps": 10, "__main__": 10, "__init__": 10,
}
MAX_LINES = 500


def _modules() -> list[tuple[Path, str]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        out.append((path, ".".join(parts[:-1] if parts[-1] == "__init__" else parts)))
    return out


def _imports(path: Path, module: str) -> list[tuple[int, str, list[str]]]:
    """(line, imported module, names) of every ``from … import`` of the package in a file, lazy ones and
    those under ``TYPE_CHECKING`` included."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.split(".")[0] == "mbimpact":
                target = node.module
            else:
                continue
            found.append((node.lineno, target, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name, []) for a in node.names if a.name.split(".")[0] == "mbimpact"]
    return found


def _stage(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_subpackage_has_a_rank():
    stages = {_stage(m) for _, m in _modules()}
    assert stages <= set(RANK), f"give {sorted(stages - set(RANK))} a rank in the pipeline's order"


def test_a_stage_imports_only_the_stages_before_it():
    wrong = [f"{path.relative_to(PACKAGE.parent)}:{line} ({_stage(module)}) imports {target} ({_stage(target)})"
             for path, module in _modules() for line, target, _ in _imports(path, module)
             if RANK[_stage(target)] > RANK[_stage(module)]]
    assert not wrong, "\n".join(wrong)


def test_no_module_imports_another_modules_private_names():
    wrong = [f"{path.relative_to(PACKAGE.parent)}:{line} imports {name} from {target}"
             for path, module in _modules() for line, target, names in _imports(path, module)
             for name in names if name.startswith("_") and not name.startswith("__")]
    wrong += [f"{path.relative_to(PACKAGE.parent)}:{line} imports {target}"
              for path, module in _modules() for line, target, _ in _imports(path, module)
              if any(p.startswith("_") and not p.startswith("__") for p in target.split("."))]
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("path", [p for p, _ in _modules()], ids=lambda p: str(p.relative_to(PACKAGE)))
def test_a_module_holds_one_idea(path):
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{path.name}: {lines} lines; split it by idea"


def test_the_check_sees_a_wrong_import(tmp_path):
    """The import check itself: a metric module importing the laws is found, with its line."""
    module = tmp_path / "bad.py"
    module.write_text("import numpy\n\nfrom ..laws.rough import RoughLaw\nfrom .kernels import _private\n")
    found = _imports(module, "mbimpact.metric.bad")
    assert found == [(3, "mbimpact.laws.rough", ["RoughLaw"]), (4, "mbimpact.metric.kernels", ["_private"])]
    assert RANK[_stage(found[0][1])] > RANK["metric"]
