"""Stage 2 of the pipeline: the A-metric at the contact (Delassus matrix W, local frame)."""

from ..common.basis import local_basis
from .delassus import ContactMetric, FactoredMetric, eigen_ratio, spread_bound

__all__ = ["ContactMetric", "FactoredMetric", "local_basis", "spread_bound", "eigen_ratio"]
