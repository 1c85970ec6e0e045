"""The package's build backend: setuptools', with the compiled front end (``native.cpp``) added.

``pyproject.toml`` names this module as its PEP 517 backend (``backend-path``). Every hook is
setuptools' own; the only change is that the setup it runs declares the extension
``mbimpact.mechanism.native`` (``native.cpp`` and ``native_contact.cpp``), compiled against the Pinocchio, Boost and Eigen headers that the
build environment's ``pin`` and ``cmeel-eigen`` wheels carry, and linked to their libraries. The
extension is optional: where it cannot be built (no C++ compiler, headers missing), the install
goes on without it and :mod:`mbimpact.mechanism.front` says why it is absent; every result is then
computed by the Python route, the same to rounding.

Not imported by the package at run time.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from setuptools import build_meta

__all__ = ["build_wheel", "build_sdist", "build_editable", "get_requires_for_build_wheel",
           "get_requires_for_build_sdist", "get_requires_for_build_editable", "prepare_metadata_for_build_wheel",
           "prepare_metadata_for_build_editable", "extension"]

# What Pinocchio's CMake targets declare to their users: they fix the joint variant's layout and
# make the headers declare (not instantiate) the algorithms the library compiles
DEFINES = [("PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION", None), ("BOOST_MPL_LIMIT_LIST_SIZE", "30"),
           ("BOOST_MPL_LIMIT_VECTOR_SIZE", "30"), ("BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", None),
           ("BOOST_FUSION_INVOKE_MAX_ARITY", "12")]


def cmeel_prefixes() -> list[Path]:
    """The ``cmeel.prefix`` folders on ``sys.path`` (where cmeel wheels put headers and libraries)."""
    found = []
    for entry in sys.path:
        prefix = Path(entry or ".") / "cmeel.prefix"
        if prefix.is_dir() and prefix not in found:
            found.append(prefix)
    return found


def extension() -> Any:
    """The front end's :class:`setuptools.Extension` (optional: its build may fail without failing the
    install)."""
    from setuptools import Extension

    prefixes = cmeel_prefixes()
    includes = [str(p / "include") for p in prefixes] + [str(p / "include" / "eigen3") for p in prefixes]
    return Extension(
        "mbimpact.mechanism.native",
        sources=["mbimpact/mechanism/native.cpp", "mbimpact/mechanism/native_contact.cpp"],
        include_dirs=includes,
        library_dirs=[str(p / "lib") for p in prefixes],
        libraries=["pinocchio_default", f"boost_python{sys.version_info[0]}{sys.version_info[1]}"],
        define_macros=DEFINES,
        extra_compile_args=["-std=c++17", "-O2", "-fvisibility=hidden"],
        language="c++",
        optional=True,
    )


class _Backend(build_meta._BuildMetaBackend):  # noqa: SLF001 — the class setuptools' own hooks are bound to
    def run_setup(self, setup_script: str = "setup.py") -> None:
        from setuptools import setup

        setup(ext_modules=[extension()])


_BACKEND = _Backend()
get_requires_for_build_wheel = _BACKEND.get_requires_for_build_wheel
get_requires_for_build_sdist = _BACKEND.get_requires_for_build_sdist
get_requires_for_build_editable = _BACKEND.get_requires_for_build_editable
prepare_metadata_for_build_wheel = _BACKEND.prepare_metadata_for_build_wheel
prepare_metadata_for_build_editable = _BACKEND.prepare_metadata_for_build_editable
build_wheel = _BACKEND.build_wheel
build_sdist = _BACKEND.build_sdist
build_editable = _BACKEND.build_editable
