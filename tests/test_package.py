"""The package namespace: every public name resolves, and `import mbimpact` leaves the heavy parts unloaded."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import mbimpact as mbi


def test_every_public_name_resolves():
    assert not [name for name in mbi.__all__ if not hasattr(mbi, name)]
    assert set(mbi.__all__) <= set(dir(mbi))


def test_names_loaded_on_use_match_the_static_imports():
    """mbimpact._ON_USE lists what the TYPE_CHECKING block imports (mypy reads one, Python the other)."""
    tree = ast.parse(Path(mbi.__file__).read_text())
    static: dict[str, set[str]] = {}
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for imp in node.body:
                assert isinstance(imp, ast.ImportFrom)
                static["." + (imp.module or "")] = {alias.name for alias in imp.names}
    assert static == {module: set(names) for module, names in mbi._ON_USE.items()}


def test_import_leaves_the_scenes_the_apps_and_scipy_unloaded():
    """`import mbimpact` loads numpy, Pinocchio and the impact pipeline; the rest loads on use."""
    code = ("import sys, numpy, pinocchio; before = set(sys.modules); import mbimpact; "
            "print(' '.join(m for m in ('mbimpact.simulation', 'mbimpact.compliant', 'mbimpact.calibration', "
            "'mbimpact.geometry', 'mbimpact.apps', 'scipy', 'matplotlib', 'jsonschema', 'importlib.metadata') "
            "if m in sys.modules and m not in before))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_every_subpackage_is_installed_by_a_non_editable_install():
    """pyproject lists the packages explicitly: a subpackage missing there is missing from the wheel
    (``mbimpact.apps.bench`` once was), which an editable install hides."""
    import tomllib
    from pathlib import Path

    source = Path(__file__).resolve().parents[1]  # the checkout, whatever copy is installed
    root = source / "mbimpact"
    found = {"mbimpact"} | {"mbimpact." + ".".join(p.parent.relative_to(root).parts)
                            for p in root.rglob("__init__.py") if p.parent != root}
    listed = set(tomllib.loads((source / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    assert listed - {"mbimpact.models"} == found


def test_documented_subpackages_are_attributes_loaded_on_use():
    """``mbi.simulation.section4.stability(...)`` works after ``import mbimpact as mbi`` alone, and `import
    mbimpact` still leaves the scenes unloaded until then."""
    code = ("import sys, mbimpact as mbi; loaded = 'mbimpact.simulation' in sys.modules; "
            "s = mbi.simulation.section4.stability(mbi.Cone(0.2), 0.5, 1); "
            "print(loaded, 0 < s.lam < 1, mbi.calibration.__name__, mbi.averaging.__name__, mbi.theory.__name__, "
            "mbi.compliant.__name__, mbi.geometry.__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True", "mbimpact.calibration", "mbimpact.averaging", "mbimpact.theory",
                                  "mbimpact.compliant", "mbimpact.geometry"]
