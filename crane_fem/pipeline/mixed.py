"""A mixed gmsh model (solids and beams in one ``.msh``) seen as its two parts: the solids as a
gmsh model and the beams as a frame, each with the entries that name its groups; the joints
tie them (crane_fem.coupling.rigid_section)."""

from __future__ import annotations

from crane_fem.scenario import FrameModel, GmshModel, Scenario

__all__ = ["scenario_views"]


def scenario_views(sc: Scenario) -> tuple[Scenario, Scenario]:
    """(solids, beams): the scenario restricted to the volume and surface groups, and to the
    line and point groups as a frame on the same file (not re-validated: the whole was)."""
    mdl = sc.model
    assert isinstance(mdl, GmshModel) and mdl.mixed
    volumes, surfaces = set(mdl.volume_groups), set(mdl.surface_groups)
    lines, points = set(mdl.line_groups), set(mdl.point_groups)

    def materials(keep: set[str]) -> object:
        if not isinstance(sc.material, list):
            return sc.material
        out = []
        for m in sc.material:
            mine = [g for g in m.groups if g in keep]
            if mine:
                out.append(m.model_copy(update={"groups": mine}))
        return out

    solids = sc.model_copy(
        update={
            "material": materials(volumes),
            "support": [s for s in sc.support if s.group in surfaces],
            "mass": [m for m in sc.mass if m.group in volumes],
            "section": [],
        }
    )
    frame = FrameModel.model_construct(kind="frame", mesh=mdl.mesh)
    beams = sc.model_copy(
        update={
            "model": frame,
            "material": materials(lines),
            "support": [s for s in sc.support if s.group in points],
            "mass": [m for m in sc.mass if m.group in points],
            "contact": [],
            "rope": [],
            "joint": [],
        }
    )
    return solids, beams
