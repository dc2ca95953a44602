"""Model kinds that are the case of another: the frame crane is a frame, drawn from its
parameters. Before the set-up stages, such a scene is turned into the other kind's, so that
every stage, monitor and writer sees one kind of model (one code path)."""

from __future__ import annotations

from mpi4py import MPI

from crane_fem.scenario import Scenario, parse_scenario
from crane_fem.scenario.frame_crane import FrameCraneModel

__all__ = ["concrete_scenario"]


def concrete_scenario(sc: Scenario, comm: MPI.Comm) -> Scenario:
    """``sc`` as the kind it is a case of (a frame crane as a frame, its mesh written by rank
    0), or ``sc`` itself (collective).

    Raises:
        ScenarioError: the derived scene is refused (the same line on every rank).
    """
    mdl = sc.model
    if not isinstance(mdl, FrameCraneModel):
        return sc
    from crane_fem.geometry.frame_crane import expand_frame_crane, write_frame_crane_mesh

    path = write_frame_crane_mesh(mdl, comm)
    data = expand_frame_crane(sc.model_dump(exclude_unset=True), mdl, path)
    return parse_scenario(data, source=f"{sc.name} (frame crane)")
