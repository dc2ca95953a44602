"""The set-up of a run with subdomains as a row of builders, each taking only earlier
results: scenario → mesh → models (preload, subdomains, steps) → constraints (interface,
contacts) → integrators (explicit zone, Newmark side, coupling method) → the driver."""

from crane_fem.pipeline.constraints import ConstraintStage, build_constraints
from crane_fem.pipeline.integrators import IntegratorStage, build_integrators
from crane_fem.pipeline.mesh import MeshStage, build_mesh, create_tagged_mesh
from crane_fem.pipeline.models import ModelStage, build_models
from crane_fem.pipeline.simulation import Simulation, check_simulation, create_simulation

__all__ = [
    "ConstraintStage",
    "IntegratorStage",
    "MeshStage",
    "ModelStage",
    "Simulation",
    "build_constraints",
    "build_integrators",
    "build_mesh",
    "build_models",
    "check_simulation",
    "create_simulation",
    "create_tagged_mesh",
]
