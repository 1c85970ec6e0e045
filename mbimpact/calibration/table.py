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
import os
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
        # checked before dict(): None, a list, a string or a number fail there with a bare TypeError/ValueError
        if not isinstance(self.columns, Mapping):
            raise TableError("columns must be a mapping of quantity name to values, e.g. {'kappa': [0.8, 0.7]}; "
                             f"got {type(self.columns).__name__}; valid names: " + ", ".join(QUANTITIES))
        if not isinstance(self.meta, Mapping) or not all(isinstance(k, str) and isinstance(v, str)
                                                         for k, v in self.meta.items()):
            raise TableError(f"meta must be a mapping of str to str (e.g. {{'body': 'point'}}), got {self.meta!r}")
        if not isinstance(self.name, str):
            raise TableError(f"name must be a str (a label), got {type(self.name).__name__}")
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
            No such file, an unreadable one (not UTF-8 text, no permission), no header, a repeated or
            unknown column, a value that is not a number.
        """
        if not isinstance(path, (str, os.PathLike)):  # Path(None) would raise a bare TypeError
            raise TableError(f"path must be a file path (str or Path) or a shipped name ({', '.join(data_names())}), "
                             f"got {type(path).__name__}")
        try:
            p = Path(path)
        except TypeError:  # a PathLike whose __fspath__ gives bytes
            raise TableError(f"path must be a file path (str or Path), got {path!r}") from None
        if not p.is_file():
            if not p.suffix and (models_dir() / "data" / f"{p}.csv").is_file():
                p = models_dir() / "data" / f"{p}.csv"
            else:
                raise TableError(f"no data file {str(path)!r}; shipped data sets: {', '.join(data_names())}")
        meta: dict[str, str] = {}
        try:
            header, rows = _read(p, meta)
        except UnicodeDecodeError as exc:  # a ValueError, but not a named one
            raise TableError(f"{p.name} is not UTF-8 text ({exc.reason} at byte {exc.start}); a table is a CSV "
                             "text file") from None
        except csv.Error as exc:
            raise TableError(f"{p.name}: not a valid CSV table: {exc}") from None
        except OSError as exc:
            raise TableError(f"cannot read {str(p)!r}: {exc.strerror or exc}") from None
        if header is None:
            raise TableError(f"{p.name}: no header row (column names) found")
        if "theta_deg" not in header:
            raise TableError(f"{p.name}: a table needs a theta_deg column (incidence from the normal, degrees)")
        repeated = sorted({h for h in header if header.count(h) > 1})
        if repeated:  # the columns would be misaligned (a dict keeps one of each name)
            raise TableError(f"{p.name}: column(s) {', '.join(map(repr, repeated))} appear more than once; "
                             "each column must be named once")
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
        words = text.split() if text else []
        if not words:  # blank, as an empty "# body:" line reads
            return None
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


def _read(p: Path, meta: dict[str, str]) -> tuple[list[str] | None, list[list[str]]]:
    """The header (None if there is none) and data rows of the table file ``p``; metadata go into ``meta``.

    Raises TableError on a row of the wrong length; decoding, csv and file errors propagate (named by the caller).
    """
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
    return header, rows


def _column(name: str, values: ArrayLike, n: int | None) -> NDArray[np.float64]:
    """``values`` as a read-only float vector (NaN or None at gaps), checked for ``n`` entries (if given)."""
    gap = "" if name in ("theta_deg", "speed") else " (NaN or None for a gap)"  # those two have no gaps
    valid = f"column {name} must hold real numbers{gap}"
    if values is None or isinstance(values, (str, bytes)):
        raise TableError(f"{valid}, got {type(values).__name__}")
    try:
        raw = np.asarray(values)
    except (TypeError, ValueError, OverflowError):  # ragged nested sequences
        raise TableError(f"{valid}, in a 1-D sequence") from None
    # casting complex to float drops the imaginary part with a ComplexWarning: refuse it instead, also
    # inside object arrays (None for a gap makes one); strings and dates are not numbers either
    if raw.dtype.kind == "O":
        bad = [x for x in raw.flat if isinstance(x, (str, bytes, complex, np.complexfloating))]
        if bad:
            raise TableError(f"{valid}, got {bad[0]!r}")
    elif raw.dtype.kind not in "biuf":
        kind = "a complex array (its imaginary part would be lost)" if raw.dtype.kind == "c" else f"dtype {raw.dtype}"
        raise TableError(f"{valid}, got {kind}")
    try:
        a = raw.astype(float)  # always a copy: the table owns and freezes it
    except (TypeError, ValueError, OverflowError):
        raise TableError(valid) from None
    if a.ndim != 1 or (n is not None and len(a) != n):
        raise TableError(f"column {name} must be 1-D with {n if n is not None else 'one value a row'} entries, "
                         f"got shape {a.shape}")
    if np.isinf(a).any():
        raise TableError(f"column {name} holds an infinite value; values must be finite{gap}")
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
