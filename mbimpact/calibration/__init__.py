"""Calibration: impact tables, bodies, and least-squares fits of impact laws to data.

``mbi.fit(mbi.ImpactTable.from_csv(path), law="rough-compliant", body=mbi.Ball(radius, mass))``
returns a :class:`Fit` with the fitted law, its parameters ± standard errors and the RMS
per column. The data sets shipped with mbimpact are in ``models/data`` (:func:`data_names`).
"""

from .bodies import Body, Motion, PointMass, Ball
from ..errors import FitError, TableError
from .least_squares import Fit, fit
from .parameters import FAMILIES, PARAMETERS, Parameter, family, law_parameters, with_parameters
from .predict import predict
from .quantities import QUANTITIES, Quantity
from .table import ImpactTable, data_names, data_path

__all__ = [
    "ImpactTable",
    "data_names",
    "data_path",
    "Body",
    "Ball",
    "PointMass",
    "Motion",
    "Fit",
    "fit",
    "predict",
    "QUANTITIES",
    "Quantity",
    "FAMILIES",
    "PARAMETERS",
    "Parameter",
    "family",
    "law_parameters",
    "with_parameters",
    "TableError",
    "FitError",
]
