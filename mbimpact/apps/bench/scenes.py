"""Bench of the simulator: every shipped scene, simulated seconds and impacts per wall second.

Each row is one full :func:`mbimpact.simulate` of a shipped scene (its own duration); ``error``
is the deepest penetration found (0 when every gap stayed above −tolerance) and the status is in
``method``. The comparison with MuJoCo on the scenes it can express is in
:mod:`~mbimpact.apps.bench.mujoco` (optional: ``pip install mujoco``).
"""

from __future__ import annotations

from ...simulation import load_scene, scene_names, simulate
from ..progress import Progress
from .common import BenchRow

__all__ = ["scene_throughput", "QUICK_SCENES"]

#: The scenes of ``mbimpact bench --quick``.
QUICK_SCENES = ("ball_drop", "box_landing", "sphere_spin_rough_plane", "ur5_forearm_box")


def scene_throughput(names: tuple[str, ...] | None, progress: Progress) -> list[BenchRow]:
    """One row per scene: ``param`` impacts, ``seconds`` wall time, ``ratio`` simulated s per wall s."""
    rows = []
    for name in names if names is not None else tuple(scene_names()):
        scene = load_scene(name)
        tr = simulate(scene)
        impacts = sum(1 for e in tr.events if e.kind == "impact")
        simulated = float(tr.t[-1])
        rows.append(BenchRow("scenes", name, f"mbimpact ({tr.status})", impacts, max(0.0, -tr.min_gap),
                             tr.wall_time, simulated / tr.wall_time))
        progress.step(name)
    return rows
