"""Scenario -> subdomains on a tagged mesh -> coupled (or monolithic-reference) integrator."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import dolfinx
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

from crane_fem.contact import ContactSet
from crane_fem.coupling import (
    CoupledSystem,
    ExplicitAlone,
    ImplicitAlone,
    MacroStep,
    create_interface_operator,
    method_class,
)
from crane_fem.coupling.interface import build_interface, constraint_set, zone_labels
from crane_fem.errors import ScenarioError
from crane_fem.geometry import TaggedMesh, create_box_beam, create_split_bar, groups
from crane_fem.geometry.box_beam import BoxBeam
from crane_fem.geometry.crane import CraneMesh, create_crane_mesh
from crane_fem.integrators.explicit_zone import ExplicitZone
from crane_fem.integrators.newmark import Newmark
from crane_fem.loading import Accelerogram
from crane_fem.loading.body import AffineLoad, GroundMotionHistory, PulseHistory
from crane_fem.mesh import Segment
from crane_fem.preload import Preload, static_preload
from crane_fem.scenario import (
    HYBRID_KEYS,
    BarModel,
    BoxBeamModel,
    Coupling,
    CraneModel,
    GroundMotion,
    Scenario,
)
from crane_fem.stability import critical_time_step, max_frequency
from crane_fem.subdomains import Subdomain, create_subdomain, global_ids

__all__ = ["CoupledSimulation", "create_tagged_mesh"]

FloatArray = npt.NDArray[np.float64]


def create_tagged_mesh(comm: MPI.Comm, sc: Scenario) -> TaggedMesh | CraneMesh:
    """The parent mesh of the scenario with its named groups (collective)."""
    mdl = sc.model
    if isinstance(mdl, CraneModel):
        return create_crane_mesh(comm, mdl.geometry(), mdl.mesh)
    if isinstance(mdl, BoxBeamModel):
        return create_box_beam(comm, BoxBeam(mdl.length, mdl.width, mdl.height, mdl.split, mdl.h))
    assert isinstance(mdl, BarModel)
    x0 = next((c.gap for c in sc.contact if c.type == "wall"), 0.0)
    split = mdl.split if mdl.split is not None else mdl.length  # all cells "left"
    return create_split_bar(comm, Segment(x0, mdl.length, mdl.elements, mdl.area), split)


def _ground_motion_at(gm: GroundMotion) -> GroundMotionHistory:
    """a_g at run time t: the record from ``gm.start`` on, tapered in over ``gm.taper``."""
    record = _ground_motion(gm)
    if gm.start >= record.duration:
        raise ScenarioError(
            f"loading.ground_motion.start = {gm.start} s is past the end of the record "
            f"({record.duration:g} s)"
        )
    return GroundMotionHistory(record, gm.start, gm.taper)


def _hybrid_options(cpl: Coupling | None) -> dict[str, Any]:
    """The "hybrid" keys given in [coupling] (the integrator's defaults otherwise)."""
    if cpl is None:
        return {}
    return {k: getattr(cpl, k) for k in HYBRID_KEYS if getattr(cpl, k) is not None}


def _ground_motion(gm: GroundMotion) -> Accelerogram:
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
        rec = read_csv(record)
    else:
        raise ScenarioError(
            f"loading.ground_motion.record: {record!r} is neither a bundled record "
            f"({', '.join(BUNDLED)}), 'synthetic', nor an .AT2/.csv file"
        )
    return rec.scaled(gm.scale)


@dataclass
class _Spec:
    name: str
    scheme: str
    groups: list[str]


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


class CoupledSimulation:
    """Subdomains, interface, contacts, loads and the coupled integrator of a scenario.

    Collective over ``comm``; ``destroy`` releases everything.

    Attributes:
        dt, dT: micro and macro steps (s); dt_critical: critical step of the explicit side.
        n_macro: number of macro steps.
    """

    def __init__(self, sc: Scenario, comm: MPI.Comm) -> None:
        self.scenario = sc
        self.comm = comm
        made = create_tagged_mesh(comm, sc)
        self.crane: CraneMesh | None = made if isinstance(made, CraneMesh) else None
        self.tagged: TaggedMesh = made.tagged if isinstance(made, CraneMesh) else made
        mdl, mat = sc.model, sc.material
        cpl = sc.coupling
        all_groups = list(self.tagged.cell_groups)
        if cpl is not None and cpl.method == "monolithic":
            specs = [_Spec("all", cpl.monolithic_scheme, all_groups)]
            method, ratio = "monolithic", 1
        else:
            specs = [_Spec(s.name, s.scheme, list(s.groups)) for s in sc.subdomain]
            method = cpl.method if cpl is not None else "monolithic"
            ratio = cpl.ratio if cpl is not None else 1
        self.method, self.ratio = method, ratio

        # Clamped vertices (global parent ids).
        if isinstance(mdl, CraneModel):
            clamp_local = self.tagged.facet_vertices("clamped")
        elif isinstance(mdl, BoxBeamModel):
            clamp_local = self.tagged.facet_vertices(groups.BEAM_CLAMPED)
        elif mdl.clamp == "right":
            clamp_local = self.tagged.facet_vertices(groups.BAR_RIGHT_END)
        else:
            clamp_local = np.zeros(0, dtype=np.int32)
        fixed = self.tagged.global_vertices(clamp_local)
        area = mdl.area if isinstance(mdl, BarModel) else 1.0
        rayleigh = mat.rayleigh_coefficients
        density = self._cell_density() if isinstance(mdl, CraneModel) else None
        self.preload: Preload | None = None
        if self.crane is not None and np.any(np.asarray(sc.loading.gravity) != 0.0):
            assert density is not None
            self.preload = static_preload(
                self.tagged,
                self.crane.pairs,
                self.crane.wheel,
                fixed,
                mat.E,
                mat.nu,
                density,
                np.asarray(sc.loading.gravity, dtype=np.float64),
                ["trolley_frame"] + [f"wheel_{k}" for k in range(1, 5)],
            )

        explicit_specs = [s for s in specs if s.scheme == "cd-lagrange"]
        implicit_specs = [s for s in specs if s.scheme == "newmark"]
        self.explicit_names = [s.name for s in explicit_specs]
        self.implicit_names = [s.name for s in implicit_specs]
        self.E_sub: Subdomain | None = None
        self.I_sub: Subdomain | None = None
        if explicit_specs:
            names = [g for s in explicit_specs for g in s.groups]
            self.E_sub = create_subdomain(
                self.tagged,
                "+".join(self.explicit_names),
                "cd-lagrange",
                self.tagged.cells(names),
                mat.E,
                mat.nu,
                mat.rho,
                area,
                rayleigh,
                fixed,
                consistent_mass=False,
                cell_density=density,
            )
        if implicit_specs:
            nm = sc.newmark
            self.I_sub = create_subdomain(
                self.tagged,
                implicit_specs[0].name,
                "newmark",
                self.tagged.cells(implicit_specs[0].groups),
                mat.E,
                mat.nu,
                mat.rho,
                area,
                rayleigh,
                fixed,
                consistent_mass=nm.mass == "consistent",
                cell_density=density,
            )

        # Step sizes: Δt from the explicit subdomain's own critical step.
        # (Monolithic Newmark: dt_factor refers to the explicit limit of the same mesh.)
        step_sub = self.E_sub if self.E_sub is not None else self.I_sub
        assert step_sub is not None
        self.dt_critical = critical_time_step(max_frequency(step_sub.model), *rayleigh)
        if sc.time.dt is not None:
            self.dt = sc.time.dt
            if self.E_sub is not None and self.dt > self.dt_critical:
                raise ScenarioError(
                    f"time.dt = {self.dt:.4e} s exceeds the critical step "
                    f"{self.dt_critical:.4e} s of explicit subdomain '{self.E_sub.name}'"
                )
        else:
            assert sc.time.dt_factor is not None
            if self.E_sub is not None and sc.time.dt_factor > 1.0:
                raise ScenarioError(
                    f"time.dt_factor = {sc.time.dt_factor} > 1 puts Δt above the critical step "
                    f"of explicit subdomain '{self.E_sub.name}'"
                )
            self.dt = sc.time.dt_factor * self.dt_critical
        coupled = self.E_sub is not None and self.I_sub is not None
        self.dT = self.dt * (ratio if coupled else 1)
        self.n_macro = max(1, math.ceil(sc.time.end / self.dT - 1e-9))

        # Interface.
        vertices = np.zeros(0, dtype=np.int64)
        le = ContactSet.empty(comm)
        li = ContactSet.empty(comm)
        if coupled:
            assert self.E_sub is not None and self.I_sub is not None
            vertices, le, li = build_interface(self.E_sub, self.I_sub)
            if vertices.size == 0:
                raise ScenarioError("subdomain: the explicit and implicit subdomains do not touch")
        self.interface_vertices = vertices

        # Contacts (explicit side), initial state and loads.
        contacts = ContactSet.empty(comm)
        if self.crane is not None:
            if self.E_sub is None:
                raise ScenarioError("the crane's wheel/rail contacts need an explicit subdomain")
            contacts = self._pair_contacts(self.E_sub, self.crane)
        elif sc.contact:
            if self.E_sub is None:
                raise ScenarioError("contact: needs an explicit (cd-lagrange) subdomain")
            contacts = self._wall_contacts(self.E_sub)
        self.contacts = contacts

        self.E_int: ExplicitZone | None = None
        self.I_int: Newmark | None = None
        if self.E_sub is not None:
            u0, v0 = self._initial(self.E_sub)
            self.E_int = ExplicitZone(
                self.E_sub.model, self._load(self.E_sub), self.dt, u0, v0, le, contacts
            )
        if self.I_sub is not None:
            u0, v0 = self._initial(self.I_sub)
            nm = sc.newmark
            self.I_int = Newmark(
                self.I_sub.model,
                self._load(self.I_sub),
                self.dT,
                u0,
                v0,
                nm.beta,
                nm.gamma,
                li if coupled else None,
                consistent_mass=nm.mass == "consistent",
            )
        self.system = CoupledSystem(
            self.E_int, self.I_int, ratio if coupled else 1, li if coupled else None, self.dt
        )
        self.integrator: MacroStep
        if coupled:
            cls = method_class(method)
            kwargs: dict[str, Any] = {}
            if method in ("gc", "gc-mean", "hybrid"):
                kwargs["operator"] = self._operator(self.I_int, ratio)  # type: ignore[arg-type]
            if method == "hybrid":
                kwargs["refined_operator"] = lambda side: self._operator(
                    side, round(side.dT / self.dt)
                )
                kwargs.update(_hybrid_options(cpl))
            self.integrator = cls(self.system, **kwargs)
        else:
            # The monolithic reference steps as the coupled run records: `ratio` steps per
            # macro step, so that the two histories share one time grid.
            stride = cpl.ratio if cpl is not None else 1
            n_steps = max(1, math.ceil(sc.time.end / self.dt - 1e-9))
            alone = ExplicitAlone if self.E_int is not None else ImplicitAlone
            self.integrator = alone(self.system, stride, n_steps)
            self.n_macro = self.integrator.n_macro
        self.interface_force0 = self._interface_force0() if coupled else None

    def _operator(self, implicit: Newmark, ratio: int) -> Any:
        """The GC interface operator of the explicit zone and ``implicit`` at ``ratio``, as
        ``[coupling] interface_blocks`` and ``interface_truncation`` ask."""
        assert self.E_int is not None and self.E_sub is not None and self.I_sub is not None
        cpl = self.scenario.coupling
        # One block per body of the implicit side (exact), and per explicit zone if asked.
        blocks = zone_labels(self.I_sub, self.interface_vertices)
        if cpl is not None and cpl.interface_blocks == "zones":
            zones = zone_labels(self.E_sub, self.interface_vertices)
            blocks = blocks * (int(zones.max()) + 1) + zones
        truncation = (cpl.interface_truncation if cpl is not None else None) or 0.0
        single = cpl is not None and cpl.interface_precision == "single"
        op, self.operator_report = create_interface_operator(
            self.E_int.zone.w_gamma, implicit.W, implicit.gamma, ratio, blocks, truncation, single
        )
        return op

    # -------------------------------------------------------------------------------------
    def _cell_density(self) -> FloatArray:
        """Density of every local parent cell: ρ, plus the hoisted mass spread over the
        trolley frame (carried rigidly)."""
        mdl = self.scenario.model
        assert isinstance(mdl, CraneModel)
        rho = self.scenario.material.rho
        msh = self.tagged.mesh
        imap = msh.topology.index_map(msh.topology.dim)
        density = np.full(imap.size_local + imap.num_ghosts, rho)
        if mdl.hoisted_mass > 0.0:
            tag = self.tagged.cell_groups["trolley_frame"]
            dx = ufl.Measure("dx", domain=msh, subdomain_data=self.tagged.cell_tags)
            one = dolfinx.fem.Constant(msh, np.float64(1.0))
            vol = msh.comm.allreduce(
                dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * dx(tag))), op=MPI.SUM
            )
            frame = self.tagged.cell_tags.indices[self.tagged.cell_tags.values == tag]
            density[frame] += mdl.hoisted_mass / vol
        return density

    def _interface_force0(self) -> FloatArray | None:
        """Link forces Λ_0 holding the preloaded subdomains in equilibrium: the explicit
        side's residual f − K u on its interface rows, Λ_0 = −r_E / c (None from rest)."""
        if self.preload is None or self.E_int is None:
            return None
        E = self.E_int
        n_g = E.n_gamma
        r = E.residual(0.0)
        st = E.stack
        sel = st.rows < n_g
        lam = np.zeros(n_g)
        lam[st.rows[sel]] = -r[st.dofs[sel]] / st.coeffs[sel]
        out: FloatArray = self.comm.allreduce(lam, op=MPI.SUM)
        return out

    def _wall_contacts(self, sub: Subdomain) -> ContactSet:
        sc = self.scenario
        left = self.tagged.global_vertices(self.tagged.facet_vertices(groups.BAR_LEFT_END))
        blocks, _ = sub.owned_dofs_of(left)
        have = global_ids(self.comm, sub.parent_vertex[blocks])
        if have.size != left.size:
            raise ScenarioError(
                "contact: the wall touches the bar's left end, which must belong "
                "to an explicit (cd-lagrange) subdomain"
            )
        wall = next(c for c in sc.contact if c.type == "wall")
        return constraint_set(
            sub, left, 1.0, np.array([wall.gap]), [wall.label], np.zeros(1, dtype=np.int64)
        )

    def _pair_contacts(self, sub: Subdomain, crane: CraneMesh) -> ContactSet:
        """Vertical node-to-node contacts g = u_z(wheel) − u_z(rail) ≥ 0 (touching at t = 0)."""
        pairs = crane.pairs
        rows, dofs, coeffs = [], [], []
        for side, coeff in ((0, 1.0), (1, -1.0)):
            order = np.argsort(pairs[:, side])
            sorted_v = pairs[order, side]
            blocks, pos = sub.owned_dofs_of(sorted_v)
            rows.append(order[pos])
            dofs.append(blocks * sub.bs + 2)
            coeffs.append(np.full(blocks.size, coeff))
        have = self.comm.allreduce(sum(r.size for r in rows), op=MPI.SUM)
        if have != 2 * pairs.shape[0]:
            raise ScenarioError(
                "the wheels and their rail zones must belong to explicit (cd-lagrange) subdomains"
            )
        names = [f"wheel_{k}" for k in range(1, 5)]
        g0 = np.zeros(pairs.shape[0])
        if self.preload is not None:
            # Start with every gap at exactly 0: the preload's residual interpenetration
            # F/k_p is an artefact of its penalty springs (see crane_fem.preload).
            d = self.preload.displacement
            g0 = np.where(self.preload.closed, -(d[pairs[:, 0], 2] - d[pairs[:, 1], 2]), 0.0)
        return ContactSet(
            self.comm,
            g0,
            np.concatenate(rows).astype(np.int64),
            np.concatenate(dofs).astype(np.int64),
            np.concatenate(coeffs),
            (crane.wheel - 1).astype(np.int64),
            names,
            # A pair held closed drifts by round-off (ε |u|): 1e-12 of the span absorbs it.
            tol=1e-12 * self.scenario.model.span,  # type: ignore[union-attr]
        )

    def _initial(self, sub: Subdomain) -> tuple[FloatArray, FloatArray]:
        sc = self.scenario
        n_own = sub.model.n_owned
        u0, v0 = np.zeros(n_own), np.zeros(n_own)
        mdl = sc.model
        if isinstance(mdl, BarModel):
            x = sub.V.tabulate_dof_coordinates()[: sub.n_owned_blocks, 0]
            X = x - next((c.gap for c in sc.contact if c.type == "wall"), 0.0)
            ul, ur = sc.initial.displacement
            u0 = ul + (ur - ul) * X / mdl.length
            v0 = np.full(n_own, sc.initial.velocity)
            p = sc.initial.pulse
            if p is not None:
                c = math.sqrt(sc.material.E / sc.material.rho)
                z = (X - p.center) / p.width
                inside = np.abs(z) < 0.5
                u0 = u0 + np.where(inside, p.amplitude * np.cos(math.pi * z) ** 2, 0.0)
                du = np.where(
                    inside, -p.amplitude * math.pi / p.width * np.sin(2 * math.pi * z), 0.0
                )
                v0 = v0 - c * du
        if self.preload is not None:
            blocks = sub.parent_vertex[: sub.n_owned_blocks]
            u0 = self.preload.displacement[blocks].ravel().copy()
        u0[sub.model.fixed] = 0.0
        v0[sub.model.fixed] = 0.0
        return u0, v0

    def _load(self, sub: Subdomain) -> AffineLoad:
        """The subdomain's body load: self-weight, plus −M ι a_g(t) per ground motion or the
        tip traction pulse (owned DOFs, N)."""
        sc = self.scenario
        m = sub.model
        g = np.asarray(sc.loading.gravity, dtype=np.float64)
        bs = sub.bs
        if bs == 1:
            grav = m.mass * g[0]
        else:
            grav = (m.mass.reshape(-1, bs) * g[None, :bs]).ravel()
        grav[m.fixed] = 0.0
        motions = sc.loading.ground_motions
        if motions:
            histories, units = [], []
            for gm in motions:
                histories.append(_ground_motion_at(gm))
                d = np.asarray(gm.direction, dtype=np.float64)
                d = d / np.linalg.norm(d)
                unit = -(m.mass.reshape(-1, bs) * d[None, :bs]).ravel()  # −M ι per unit a_g
                unit[m.fixed] = 0.0
                units.append(unit)
            return AffineLoad(grav, np.array(units), tuple(histories))
        tip = sc.loading.tip_traction
        if tip is None:
            return AffineLoad(grav)
        tip_v = self.tagged.global_vertices(self.tagged.facet_vertices(groups.BEAM_TIP))
        unit = _facet_traction_load(sub, tip_v, tip.traction)
        return AffineLoad(grav, unit[None, :], (PulseHistory(tip.duration),))

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
        return self.tagged.global_vertices(self.tagged.facet_vertices(name))

    def destroy(self) -> None:
        self.integrator.destroy()
        if self.E_int is not None:
            self.E_int.destroy()
        if self.I_int is not None:
            self.I_int.destroy()
        for sub in (self.E_sub, self.I_sub):
            if sub is not None:
                sub.destroy()
