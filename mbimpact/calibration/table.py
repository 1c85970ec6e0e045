"""Impact data tables: an incidence angle and any of the measurable quantities, with gaps.

A table file is CSV: comment lines starting with ``#`` (the source and notes; lines
``# key: value`` become metadata, indented comment lines continue the previous key),
a header row of column names, then one row per incidence angle. A blank cell is a
gap. Columns: ``theta_deg`` (required), ``speed`` (m/s) and any of the quantities of
:mod:`mbimpact.calibration.quantities` (``kappa``, ``mu``, ``et``, ``et_cp``, ``spin``,
``rebound_deg``, ``rebound_cp_deg``); the metadata key ``body`` (``sphere radius=R
mass=m`` or ``point``) names the body of the experiment.

The data shipped with mbimpact are in ``models/data`` (:func:`data_names`, :func:`data_path`).
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..mechanism.robots import models_dir
from .bodies import Body, PointMass, Ball
from ..errors import TableError
from .quantities import QUANTITIES

__all__ = ["ImpactTable", "data_names", "data_path"]

_KEY = re.compile(r"^#\s?([A-Za-z_][\w-]*):\s*(.*)$")


@dataclass(frozen=True, eq=False)
class ImpactTable:
    """Measured (or correlated) impact outcomes against the incidence angle.

    Parameters
    ----------
    theta_deg : array_like, shape (n,)
        Incidence from the normal, degrees in [0, 90).
    columns : mapping of str to array_like, shape (n,) each
        Quantities by name (:data:`mbimpact.calibration.quantities.QUANTITIES`); NaN marks a gap.
    speed : array_like, shape (n,), optional
        Impact speed per row (m/s, > 0).
    meta : mapping of str to str
        Header metadata (``source``, ``body``, ...).
    name : str
        A label (the file's stem).
    """

    theta_deg: NDArray[np.float64]
    columns: Mapping[str, NDArray[np.float64]]
    speed: NDArray[np.float64] | None = None
    meta: Mapping[str, str] = field(default_factory=dict)
    name: str = "table"

    def __post_init__(self) -> None:
        theta = _column("theta_deg", self.theta_deg, None)
        if not len(theta):
            raise TableError("a table needs at least one row")
        if np.isnan(theta).any() or (theta < 0).any() or (theta >= 90).any():
            raise TableError("theta_deg must be given on every row, within [0, 90) degrees from the normal")
        n = len(theta)
        cols = {}
        for key, values in dict(self.columns).items():
            if key not in QUANTITIES:
                raise TableError(f"unknown column {key!r}; valid: theta_deg, speed, " + ", ".join(QUANTITIES))
            cols[key] = _column(key, values, n)
        if not cols or all(np.isnan(v).all() for v in cols.values()):
            raise TableError("a table needs at least one quantity column with data: " + ", ".join(QUANTITIES))
        speed = None
        if self.speed is not None:
            speed = _column("speed", self.speed, n)
            if np.isnan(speed).any() or not (speed > 0).all():
                raise TableError("speed must be given on every row and be > 0 (m/s)")
        object.__setattr__(self, "theta_deg", theta)
        object.__setattr__(self, "columns", MappingProxyType(cols))
        object.__setattr__(self, "speed", speed)
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))

    # ------------------------------------------------------------------ reading
    @classmethod
    def from_csv(cls, path: str | Path) -> ImpactTable:
        """Read a table file (format in the module notes); a shipped name (``"kharaz2001"``) also works.

        Raises
        ------
        TableError
            No such file, no header, an unknown column, a value that is not a number.
        """
        p = Path(path)
        if not p.is_file():
            if not p.suffix and (models_dir() / "data" / f"{p}.csv").is_file():
                p = models_dir() / "data" / f"{p}.csv"
            else:
                raise TableError(f"no data file {str(path)!r}; shipped data sets: {', '.join(data_names())}")
        meta: dict[str, str] = {}
        last: str | None = None
        rows: list[list[str]] = []
        header: list[str] | None = None
        with p.open(newline="", encoding="utf-8") as fh:
            for lineno, line in enumerate(fh, 1):
                stripped = line.strip()
                if not stripped:
                    continue
                if stripped.startswith("#"):
                    match = _KEY.match(stripped)
                    if match:
                        last = match.group(1)
                        meta[last] = match.group(2).strip()
                    elif last is not None:
                        meta[last] += " " + stripped.lstrip("#").strip()
                    continue
                cells = next(csv.reader([stripped]))
                if header is None:
                    header = [c.strip() for c in cells]
                    continue
                if len(cells) != len(header):
                    raise TableError(f"{p.name}, line {lineno}: {len(cells)} cells for {len(header)} columns")
                rows.append([c.strip() for c in cells])
        if header is None:
            raise TableError(f"{p.name}: no header row (column names) found")
        if "theta_deg" not in header:
            raise TableError(f"{p.name}: a table needs a theta_deg column (incidence from the normal, degrees)")
        values: dict[str, list[float]] = {h: [] for h in header}
        for i, row in enumerate(rows):
            for h, cell in zip(header, row):
                try:
                    values[h].append(float(cell) if cell else math.nan)
                except ValueError:
                    raise TableError(f"{p.name}, data row {i + 1}: {h} = {cell!r} is not a number") from None
        columns = {h: np.array(v) for h, v in values.items() if h not in ("theta_deg", "speed")}
        speed = np.array(values["speed"]) if "speed" in values else None
        return cls(np.array(values["theta_deg"]), columns, speed, meta, p.stem)

    # ------------------------------------------------------------------ views
    def __len__(self) -> int:
        return len(self.theta_deg)

    @property
    def quantities(self) -> tuple[str, ...]:
        """The quantity columns that hold data, in the order of :data:`QUANTITIES`."""
        return tuple(q for q in QUANTITIES if q in self.columns and not np.isnan(self.columns[q]).all())

    def values(self, quantity: str) -> NDArray[np.float64]:
        """The column ``quantity`` (n,), NaN at gaps."""
        if quantity not in self.columns:
            raise TableError(f"{self.name} has no column {quantity!r}; it has {', '.join(self.quantities)}")
        return self.columns[quantity]

    def body(self) -> Body | None:
        """The body named by the ``body`` metadata (``sphere radius=R mass=m`` or ``point``), or None."""
        text = self.meta.get("body")
        if not text:
            return None
        words = text.split()
        kind, params = words[0].lower(), {}
        for word in words[1:]:
            if "=" not in word:
                break
            key, _, value = word.partition("=")
            try:
                params[key] = float(value)
            except ValueError:
                raise TableError(f"{self.name}: body parameter {word!r} is not key=number") from None
        if kind == "point":
            return PointMass()
        if kind == "sphere":
            if "radius" not in params or "mass" not in params:
                raise TableError(f"{self.name}: 'body: sphere' needs radius=... and mass=..., got {text!r}")
            return Ball(params["radius"], params["mass"], params.get("inertia"))
        raise TableError(f"{self.name}: unknown body {kind!r}; valid: 'sphere radius=R mass=m', 'point'")

    def source(self) -> str:
        """The ``source`` metadata (the citation), or ''."""
        return self.meta.get("source", "")


def _column(name: str, values: ArrayLike, n: int | None) -> NDArray[np.float64]:
    try:
        a = np.array(values, dtype=float)
    except (TypeError, ValueError):
        raise TableError(f"column {name} must hold numbers (NaN for a gap)") from None
    if a.ndim != 1 or (n is not None and len(a) != n):
        raise TableError(f"column {name} must be 1-D with {n if n is not None else 'one value a row'} entries, "
                         f"got shape {a.shape}")
    if np.isinf(a).any():
        raise TableError(f"column {name} holds an infinite value")
    a.setflags(write=False)
    return a


def data_names() -> list[str]:
    """Names of the data sets shipped in ``models/data`` (for :meth:`ImpactTable.from_csv`)."""
    return sorted(p.stem for p in (models_dir() / "data").glob("*.csv"))


def data_path(name: str) -> Path:
    """Path of a shipped data set, e.g. ``data_path("kharaz2001")``."""
    path = models_dir() / "data" / f"{name}.csv"
    if not path.is_file():
        raise TableError(f"no shipped data set {name!r}; valid: {', '.join(data_names())}")
    return path
