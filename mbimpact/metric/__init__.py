"""Stage 2 of the pipeline: the A-metric at the contact (Delassus matrix W, local frame)."""

from .basis import local_basis
from .delassus import ContactMetric, eigen_ratio, spread_bound

__all__ = ["ContactMetric", "local_basis", "spread_bound", "eigen_ratio"]
