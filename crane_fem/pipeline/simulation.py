"""A scenario's simulation: the records of the four set-up stages, in the order they were
built, and what the driver asks of them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.geometry import groups
from crane_fem.pipeline.constraints import ConstraintStage, build_constraints
from crane_fem.pipeline.integrators import IntegratorStage, build_integrators
from crane_fem.pipeline.mesh import MeshStage, build_mesh
from crane_fem.pipeline.models import ModelStage, build_models
from crane_fem.reduction import check_modes, interior_dofs
from crane_fem.scenario import BoxBeamModel, CraneModel, Scenario

__all__ = ["Simulation", "check_simulation", "create_simulation"]


@dataclass
class Simulation:
    """Mesh → models → constraints → integrators of one scenario (collective over the mesh's
    communicator; ``destroy`` releases everything, last built first)."""

    scenario: Scenario
    mesh: MeshStage
    models: ModelStage
    constraints: ConstraintStage
    integrators: IntegratorStage

    def probe_vertices(self) -> npt.NDArray[np.int64]:
        """Global ids of the probe: the bar's right end, the beam's tip face, or the crane's
        wheel 1 contact face (wheel side)."""
        mdl = self.scenario.model
        if isinstance(mdl, CraneModel):
            name = "wheel_patch_1"
        elif isinstance(mdl, BoxBeamModel):
            name = groups.BEAM_TIP
        else:
            name = groups.BAR_RIGHT_END
        tagged = self.mesh.tagged
        return tagged.global_vertices(tagged.facet_vertices(name))

    def destroy(self) -> None:
        self.integrators.destroy()
        self.models.destroy()


def create_simulation(sc: Scenario, comm: MPI.Comm) -> Simulation:
    """The set-up pipeline of a scenario with subdomains (collective over ``comm``)."""
    mesh = build_mesh(sc, comm)
    models = build_models(sc, mesh)
    try:
        constraints = build_constraints(sc, mesh, models)
        integrators = build_integrators(sc, mesh, models, constraints)
    except BaseException:
        models.destroy()
        raise
    return Simulation(sc, mesh, models, constraints, integrators)


def check_simulation(sc: Scenario, comm: MPI.Comm) -> None:
    """What ``run`` refuses after reading the mesh, refused without integrating: a reduced
    implicit subdomain with more modes than interior DOFs (collective; meshes and builds the
    subdomains)."""
    spec = next((s for s in sc.subdomain if s.scheme == "newmark-reduced"), None)
    if spec is None or spec.modes is None:
        return
    mesh = build_mesh(sc, comm)
    models = build_models(sc, mesh)
    try:
        constraints = build_constraints(sc, mesh, models)
        if models.implicit is not None:
            rows = constraints.l_implicit
            _, n_int = interior_dofs(models.implicit.model, rows)
            check_modes(spec.modes, n_int)
    finally:
        models.destroy()
