"""Scenario loads and initial states of a subdomain: self-weight, ground motion (−M ι a_g(t)
per direction), the box beam's tip traction; the bar's initial field, the block's uniform
velocity, the crane's preload."""

from __future__ import annotations

import math

import dolfinx
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from crane_fem.errors import ScenarioError
from crane_fem.geometry import groups
from crane_fem.loading import Accelerogram
from crane_fem.loading.body import AffineLoad, GroundMotionHistory, PulseHistory
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.preload import Preload
from crane_fem.scenario import BarModel, GroundMotion, Scenario
from crane_fem.subdomains import Subdomain

__all__ = ["body_load", "ground_motion", "initial_state"]

FloatArray = npt.NDArray[np.float64]


def _record(gm: GroundMotion) -> Accelerogram:
    """A bundled record, an .AT2 / .csv file or a synthetic record, scaled."""
    from crane_fem.loading import BUNDLED, bundled, read_at2, read_csv, synthetic

    record = gm.record
    if record == "synthetic":
        assert gm.pga is not None and gm.duration is not None
        rec = synthetic(gm.duration, 0.002, gm.pga, (gm.band[0], gm.band[1]), gm.seed)
    elif record in BUNDLED:
        rec = bundled(record)
    elif record.lower().endswith(".at2"):
        rec = read_at2(record)
    elif record.lower().endswith(".csv"):
        rec = read_csv(record, gm.units or "m/s2")
    else:
        raise ScenarioError(
            f"loading.ground_motion.record: {record!r} is neither a bundled record "
            f"({', '.join(BUNDLED)}), 'synthetic', nor an .AT2/.csv file"
        )
    return rec.scaled(gm.scale)


def ground_motion(gm: GroundMotion, end: float | None = None) -> GroundMotionHistory:
    """a_g at run time t: the record from ``gm.start`` on, tapered in over ``gm.taper``;
    with the run's ``end`` (s), a record that stops before it is refused (the ground would
    stand still after it, silently)."""
    record = _record(gm)
    if gm.start >= record.duration:
        raise ScenarioError(
            f"loading.ground_motion.start = {gm.start} s is past the end of the record "
            f"({record.duration:g} s)"
        )
    left = record.duration - gm.start
    if end is not None and left < end * (1.0 - 1e-9) - 1e-12:
        raise ScenarioError(
            f"loading.ground_motion: the record {gm.record!r} from start = {gm.start:g} s "
            f"lasts {left:.4g} s, less than time.end = {end:g} s (the ground would stand still "
            "after it): shorten time.end or start the window earlier"
        )
    return GroundMotionHistory(record, gm.start, gm.taper)


def _facet_traction_load(
    sub: Subdomain, tip_vertices: npt.NDArray[np.int64], traction: list[float]
) -> FloatArray:
    """Owned nodal forces of a unit-time traction on the submesh facets whose vertices all
    lie in ``tip_vertices`` (global parent ids); zero if the subdomain has no such facet."""
    msh = sub.submesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    msh.topology.create_connectivity(tdim - 1, 0)
    facets = dolfinx.mesh.exterior_facet_indices(msh.topology)
    f2v = msh.topology.connectivity(tdim - 1, 0)
    on_tip = [f for f in facets if np.all(np.isin(sub.vertex_global[f2v.links(f)], tip_vertices))]
    idx = np.asarray(on_tip, dtype=np.int32)
    mt = dolfinx.mesh.meshtags(msh, tdim - 1, idx, np.ones(idx.size, dtype=np.int32))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=mt)
    w = ufl.TestFunction(sub.V)
    t = dolfinx.fem.Constant(msh, np.asarray(traction, dtype=np.float64))
    vec = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(ufl.inner(t, w) * ds(1)))
    vec.ghostUpdate(addv=True, mode="reverse")  # addv=True: ADD_VALUES
    out = np.array(vec.array_r, dtype=np.float64)
    vec.destroy()
    out[sub.model.fixed] = 0.0
    return out


def body_load(sc: Scenario, mesh: MeshStage, sub: Subdomain) -> AffineLoad:
    """The subdomain's body load: self-weight, plus −M ι a_g(t) per ground motion or the tip
    traction pulse (owned DOFs, N; collective for the traction's assembly)."""
    m = sub.model
    bs = sub.bs
    n_t = sub.formulation.translations

    def on_translations(vector: list[float] | FloatArray) -> FloatArray:
        """A node's load per unit mass: the vector on its translations (a beam's rotations
        take none)."""
        out = np.zeros(bs)
        out[:n_t] = np.asarray(vector, dtype=np.float64)[:n_t]
        return out

    g = on_translations(sc.loading.gravity)
    if bs == 1:
        grav = m.mass * g[0]
    else:
        grav = (m.mass.reshape(-1, bs) * g[None, :]).ravel()
    grav[m.fixed] = 0.0
    motions = sc.loading.ground_motions
    if motions:
        histories, units = [], []
        for gm in motions:
            histories.append(ground_motion(gm, sc.time.end))
            d = np.asarray(gm.direction, dtype=np.float64)
            d = on_translations(d / np.linalg.norm(d))
            unit = -(m.mass.reshape(-1, bs) * d[None, :]).ravel()  # −M ι per unit a_g
            unit[m.fixed] = 0.0
            units.append(unit)
        return AffineLoad(grav, np.array(units), tuple(histories))
    tip = sc.loading.tip_traction
    if tip is None:
        return AffineLoad(grav)
    tagged = mesh.tagged
    tip_v = tagged.global_vertices(tagged.facet_vertices(groups.BEAM_TIP))
    unit = _facet_traction_load(sub, tip_v, tip.traction)
    return AffineLoad(grav, unit[None, :], (PulseHistory(tip.duration),))


def initial_state(
    sc: Scenario, sub: Subdomain, preload: Preload | None
) -> tuple[FloatArray, FloatArray]:
    """(U_0, V_0) on the subdomain's owned DOFs: the bar's initial field (uniform velocity,
    linear displacement, a travelling pulse), or the preloaded state, with a uniform initial
    velocity [vx, vy, vz] on the translations where one is given (not collective)."""
    n_own = sub.model.n_owned
    u0, v0 = np.zeros(n_own), np.zeros(n_own)
    mdl = sc.model
    if isinstance(mdl, BarModel):
        x = sub.V.tabulate_dof_coordinates()[: sub.n_owned_blocks, 0]
        X = x - next((c.gap for c in sc.contact if c.type == "wall"), 0.0)
        ul, ur = sc.initial.displacement
        u0 = ul + (ur - ul) * X / mdl.length
        v0 = np.full(n_own, sc.initial.bar_velocity)
        p = sc.initial.pulse
        if p is not None:
            c = math.sqrt(sc.uniform_material.E / sc.uniform_material.rho)
            z = (X - p.center) / p.width
            inside = np.abs(z) < 0.5
            u0 = u0 + np.where(inside, p.amplitude * np.cos(math.pi * z) ** 2, 0.0)
            du = np.where(inside, -p.amplitude * math.pi / p.width * np.sin(2 * math.pi * z), 0.0)
            v0 = v0 - c * du
    if isinstance(sc.initial.velocity, list):  # a uniform velocity [vx, vy, vz]
        node = np.zeros(sub.bs)
        node[: sub.formulation.translations] = sc.initial.velocity_vector
        v0 = np.tile(node, sub.n_owned_blocks)
    if preload is not None:
        blocks = sub.parent_vertex[: sub.n_owned_blocks]
        u0 = preload.displacement[blocks].ravel().copy()
    u0[sub.model.fixed] = 0.0
    v0[sub.model.fixed] = 0.0
    return u0, v0
