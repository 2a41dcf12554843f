"""truss_deploy: deployment dynamics of space deployable trusses, from Python.

A thin layer over the truss-deploy Rust library (the same simulator as the
``truss-deploy`` command): models (:class:`Model`, :mod:`truss_deploy.generate`),
simulations (:class:`Simulator`, :class:`Snapshot`) and sweeps
(:class:`truss_deploy.sweep.Sweep`, :func:`run_sweep`). Units are SI: m, s,
kg, N, J. See docs/python.md.
"""

from ._native import (
    Model,
    ModelError,
    Simulator,
    Snapshot,
    SolverError,
    SweepError,
    TrussDeployError,
    __version__,
)
from . import generate
from .sweep import SampleTask, Sweep, SweepResult, run_sweep

load = Model.load
parse = Model.parse

__all__ = [
    "Model",
    "Simulator",
    "Snapshot",
    "TrussDeployError",
    "ModelError",
    "SolverError",
    "SweepError",
    "generate",
    "load",
    "parse",
    "Sweep",
    "SweepResult",
    "SampleTask",
    "run_sweep",
    "__version__",
]
