# Types of the compiled front end (native.cpp), built at install where a C++ compiler is at hand.
from typing import Any

import numpy as np
from numpy.typing import NDArray

PINOCCHIO_VERSION: str
DONE: int
CHECKS: int
GENERAL: int

def bind(model: Any, data: Any) -> object: ...
def newton(bound: object, q: object, v: object, fid: int, point: NDArray[np.float64], R: NDArray[np.float64],
           e: float, out: NDArray[np.float64]) -> int: ...
def stage_one(bound: object, q: object, v: object, fid: int, point: NDArray[np.float64], A: NDArray[np.float64],
              J: NDArray[np.float64]) -> int: ...
def stage_rows(bound: object, Q: NDArray[np.float64], fid: int, point: NDArray[np.float64], A: NDArray[np.float64],
               J: NDArray[np.float64], U: NDArray[np.float64] | None, D: NDArray[np.float64] | None) -> int: ...
