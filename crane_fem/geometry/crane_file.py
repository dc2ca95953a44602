"""A crane mesh on disk: the gmsh ``.msh`` file crane-fem mesh writes and its geometry sidecar."""

from __future__ import annotations

import json
from dataclasses import asdict, fields
from pathlib import Path

import gmsh

from crane_fem.errors import ScenarioError
from crane_fem.geometry.crane_build import build_crane_model
from crane_fem.geometry.crane_parameters import CraneGeometry

__all__ = ["mesh_sidecar", "read_mesh_sidecar", "write_crane_mesh"]


#: The geometry keys sidecars written before them do not record (the flanges', the plate's).
_LATER_KEYS = ("flanges", "flange_clearance", "flange_depth", "flange_thickness", "trolley_size")


def mesh_sidecar(path: str | Path) -> Path:
    """The file beside a crane mesh that records the geometry it was made from:
    ``meshes/crane.msh`` -> ``meshes/crane.json``."""
    return Path(path).with_suffix(".json")


def read_mesh_sidecar(path: str | Path) -> dict[str, float | None] | None:
    """The geometry (every :class:`CraneGeometry` field; ``flanges`` a bool, ``trolley_size``
    None when not given) a crane mesh was written from, read from its sidecar
    (:func:`mesh_sidecar`), or None if it has none (not collective). A sidecar written before
    the flanges or the plate's size existed records none: their keys take their defaults
    (flanges off, the plate at ``size``).

    Raises:
        ScenarioError: the sidecar is not one written by :func:`write_crane_mesh`.
    """
    side = mesh_sidecar(path)
    if not side.is_file():
        return None
    defaults = asdict(CraneGeometry())
    values: dict[str, float | None] = {}
    try:
        geometry = json.loads(side.read_text(encoding="utf-8"))["geometry"]
        for f in fields(CraneGeometry):
            if f.name in _LATER_KEYS:
                value = geometry.get(f.name, defaults[f.name])
            else:
                value = geometry[f.name]
            if value is None and defaults[f.name] is None:
                values[f.name] = None
            elif isinstance(defaults[f.name], bool):
                if not isinstance(value, bool):
                    raise TypeError(f"{f.name} = {value!r} is not true or false")
                values[f.name] = value
            else:
                values[f.name] = float(value)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ScenarioError(
            f"model.mesh: {side} is not the geometry record crane-fem mesh writes ({exc!r}); "
            "write the mesh again with crane-fem mesh"
        ) from None
    return values


def write_crane_mesh(geo: CraneGeometry, path: str | Path) -> str:
    """Mesh the crane and write it as a gmsh 4.1 ``.msh`` file, with the geometry it was made
    from in its sidecar ``.json`` (:func:`mesh_sidecar`; not collective: one process).

    gmsh meshes deterministically (one thread), so the same parameters give the same file.
    Returns a one-line description (nodes, tetrahedra, contact pairs).
    """
    geo.validate()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.option.setNumber("Mesh.SaveAll", 0)
        gmsh.model.add("crane")
        info = build_crane_model(geo)
        gmsh.write(str(path))
        n_nodes = len(gmsh.model.mesh.getNodes()[0])
        n_tets = len(gmsh.model.mesh.getElementsByType(4)[0])
    finally:
        gmsh.finalize()
    n_pairs = sum(w.size for w, _ in info.contact_pairs)
    n_flange = sum(fp.flange_nodes.size for fp in info.flange_pairs)
    record = {
        "written_by": "crane-fem mesh",
        "mesh": path.name,
        "geometry": asdict(geo),
        "nodes": n_nodes,
        "tetrahedra": n_tets,
        "wheel_rail_pairs": n_pairs,
        "flange_rail_pairs": n_flange,
    }
    mesh_sidecar(path).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    flange = f", {n_flange} flange/rail-side node pairs" if geo.flanges else ""
    return f"{n_nodes} nodes, {n_tets} tetrahedra, {n_pairs} wheel/rail node pairs{flange}"
