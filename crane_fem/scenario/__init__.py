"""Scenario files: TOML -> validated configuration, with one-line errors naming the key.

The format is documented in ``docs/scenarios.md``. Every rank reads and validates the same
file, so a bad scenario raises the same :class:`~crane_fem.errors.ScenarioError` on every rank
before any collective call is made.
"""

from crane_fem.scenario.coupling import (
    COUPLED_METHODS,
    HYBRID_KEYS,
    OPERATOR_KEYS,
    SOLVED_INTERFACE_METHODS,
    Coupling,
    NewmarkParams,
    SubdomainSpec,
)
from crane_fem.scenario.frame import BeamSection, FrameModel, LineContact, PlaneContact, Rope
from crane_fem.scenario.load import load_scenario, parse_scenario
from crane_fem.scenario.loading import GroundMotion, Loading, TipTraction
from crane_fem.scenario.model import (
    MODEL_KINDS,
    BarModel,
    BlockModel,
    BoxBeamModel,
    CraneModel,
    GmshModel,
    SecondBar,
)
from crane_fem.scenario.overrides import apply_overrides, apply_unsets
from crane_fem.scenario.root import Scenario
from crane_fem.scenario.sections import (
    Contact,
    DampingRatio,
    GroupMass,
    GroupMaterial,
    Initial,
    Integrator,
    Joint,
    Material,
    Monitor,
    Output,
    Pulse,
    Spectra,
    Support,
    SurfaceContact,
    Time,
    Wheel,
)

__all__ = [
    "COUPLED_METHODS",
    "HYBRID_KEYS",
    "MODEL_KINDS",
    "OPERATOR_KEYS",
    "SOLVED_INTERFACE_METHODS",
    "BarModel",
    "BeamSection",
    "BlockModel",
    "BoxBeamModel",
    "Contact",
    "Coupling",
    "CraneModel",
    "DampingRatio",
    "FrameModel",
    "GmshModel",
    "GroundMotion",
    "GroupMass",
    "GroupMaterial",
    "Initial",
    "Integrator",
    "Joint",
    "LineContact",
    "Loading",
    "Material",
    "Monitor",
    "NewmarkParams",
    "Output",
    "PlaneContact",
    "Pulse",
    "Rope",
    "Scenario",
    "SecondBar",
    "Spectra",
    "SubdomainSpec",
    "Support",
    "SurfaceContact",
    "Time",
    "TipTraction",
    "Wheel",
    "apply_overrides",
    "apply_unsets",
    "load_scenario",
    "parse_scenario",
]
