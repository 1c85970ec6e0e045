"""Fixtures of the geometry tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.geometry.helpers import TINY_MJCF


@pytest.fixture(scope="session")
def tiny_mjcf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A free box with a hinged ball and capsule over a floor plane, as an MJCF file."""
    path = tmp_path_factory.mktemp("mjcf") / "tiny.xml"
    path.write_text(TINY_MJCF)
    return path
