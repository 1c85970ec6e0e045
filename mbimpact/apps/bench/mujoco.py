"""The shipped scenes MuJoCo can express, simulated by MuJoCo: accuracy of the impact outcome and speed.

Optional: needs the ``mujoco`` package (``pip install mujoco``); without it the part is skipped.
"""

from __future__ import annotations

from ..progress import Progress
from .common import BenchRow

__all__ = ["available", "mujoco_rows"]


def available() -> bool:
    """Whether the ``mujoco`` package can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def mujoco_rows(quick: bool, progress: Progress) -> list[BenchRow]:
    """Rows of part ``"mujoco"`` (see the module docstring)."""
    return []
