"""Time integrators for nonsmooth structural dynamics (one-step schemes yielding records)."""

from crane_fem.integrators.base import StepRecord, TimeIntegrator
from crane_fem.integrators.central_difference import CDLagrange
from crane_fem.integrators.moreau_jean import MoreauJean
from crane_fem.integrators.penalty import CDPenalty

__all__ = ["CDLagrange", "CDPenalty", "MoreauJean", "StepRecord", "TimeIntegrator"]
