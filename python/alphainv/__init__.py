"""alphainv: the alpha-invariant nonlinear damping model of joints with friction, in Python.

A thin layer over the C++ library (no second implementation): the model (alpha, eq. 33;
AlphaModel, eqs. 38-42; InertiaModel, eq. 6; LinearModel, eqs. 24-26; Controller, eq. 10;
Effects, generated from the library's effect table; AlphaEstimator), the formats (Dataset,
Model), and the work (simulate, fit, diagnose, validate). Batches on a process pool or a Dask
cluster: alphainv.batch. Errors raise alphainv.Error (a ValueError with file, line, field).
"""

from ._error import Error
from ._alphainv import (
    EFFECTS,
    AlphaEstimator,
    AlphaModel,
    Controller,
    Dataset,
    DiagnoseResult,
    Effects,
    EffectParameter,
    EffectSpec,
    FitResult,
    InertiaModel,
    JointModel,
    LinearModel,
    Model,
    Run,
    SimulationResult,
    ValidationResult,
    alpha,
    alpha_cycle_average,
    alpha_instantaneous,
    alpha_sine_steady_state,
    diagnose,
    fit,
    simulate,
    validate,
)

__version__ = "0.1.0"

__all__ = [
    "EFFECTS", "AlphaEstimator", "AlphaModel", "Controller", "Dataset", "DiagnoseResult",
    "Effects", "EffectParameter", "EffectSpec", "Error", "FitResult", "InertiaModel",
    "JointModel", "LinearModel", "Model", "Run", "SimulationResult", "ValidationResult",
    "alpha", "alpha_cycle_average", "alpha_instantaneous", "alpha_sine_steady_state",
    "diagnose", "fit", "simulate", "validate",
]
