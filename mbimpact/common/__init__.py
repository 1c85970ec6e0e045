"""Helpers shared by the stages of the pipeline: input validation and contact geometry.

Everything here is public so that no module needs another's private names.
"""

from .geometry import (
    DEGENERATE,
    EPS,
    facing_half_width,
    facing_half_width_scalar,
    incidence_split,
    offset_point_jacobian,
    ring_quadratic_form,
    scaled_norm,
)
from .threads import (
    BLOCK_ROWS,
    ROWS_PER_THREAD,
    SINGLE_THREAD_ROWS,
    kernel_threads,
    over_rows,
    set_kernel_threads,
    single_blas_thread,
)
from .validation import as_array, as_count, as_scalar, as_vector

__all__ = [
    "DEGENERATE",
    "EPS",
    "facing_half_width",
    "facing_half_width_scalar",
    "incidence_split",
    "offset_point_jacobian",
    "ring_quadratic_form",
    "scaled_norm",
    "SINGLE_THREAD_ROWS",
    "single_blas_thread",
    "BLOCK_ROWS",
    "ROWS_PER_THREAD",
    "kernel_threads",
    "over_rows",
    "set_kernel_threads",
    "as_array",
    "as_count",
    "as_scalar",
    "as_vector",
]
