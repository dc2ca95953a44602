"""Linear modal analysis of a scenario's structure with its contacts closed, and the
classical response-spectrum estimate of its seismic loads (``crane-fem modes``).

Modules, in the order data flows: :mod:`~crane_fem.modes.operators` (K, M of the closed
structure), :mod:`~crane_fem.modes.eigen` (SLEPc modes, effective masses),
:mod:`~crane_fem.modes.forces` (support and wheel forces of a displacement),
:mod:`~crane_fem.modes.spectral` (damping, Sa, SRSS, CQC), :mod:`~crane_fem.modes.estimate`
(the response-spectrum forces), :mod:`~crane_fem.modes.xdmf` (shapes),
:mod:`~crane_fem.modes.report` (table, JSON, comparison), :mod:`~crane_fem.modes.command`.
"""

from crane_fem.modes.command import run_modes
from crane_fem.modes.eigen import ModalBasis, solve_modes
from crane_fem.modes.estimate import SpectralEstimate, spectral_estimate
from crane_fem.modes.operators import ClosedStructure, assemble_closed_structure
from crane_fem.modes.report import ModesReport, report_lines
from crane_fem.modes.spectral import combine_cqc, combine_srss, cqc_correlation

__all__ = [
    "ClosedStructure",
    "ModalBasis",
    "ModesReport",
    "SpectralEstimate",
    "assemble_closed_structure",
    "combine_cqc",
    "combine_srss",
    "cqc_correlation",
    "report_lines",
    "run_modes",
    "solve_modes",
    "spectral_estimate",
]
