"""A scenario's simulation: the records of the four set-up stages, in the order they were
built, and what the driver asks of them."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.geometry import groups
from crane_fem.pipeline.constraints import ConstraintStage, build_constraints
from crane_fem.pipeline.integrators import IntegratorStage, build_integrators
from crane_fem.pipeline.kinds import concrete_scenario
from crane_fem.pipeline.mesh import MeshStage, build_mesh
from crane_fem.pipeline.models import ModelStage, build_models
from crane_fem.reduction import check_modes, interior_dofs
from crane_fem.scenario import (
    BlockModel,
    BoxBeamModel,
    CraneModel,
    FrameModel,
    GmshModel,
    Scenario,
)

__all__ = ["Simulation", "SimulationCheck", "check_simulation", "create_simulation"]

FloatArray = npt.NDArray[np.float64]


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
        """Global ids of the probe: the bar's right end, the beam's tip face, the crane's
        wheel 1 contact face (wheel side), the block's top face, or a gmsh model's or a
        frame's first contact's points (none without a contact)."""
        mdl = self.scenario.model
        if isinstance(mdl, CraneModel):
            name = "wheel_patch_1"
        elif isinstance(mdl, BoxBeamModel):
            name = groups.BEAM_TIP
        elif isinstance(mdl, BlockModel):
            name = groups.BLOCK_TOP
        elif isinstance(mdl, GmshModel):  # the first contact's points, if any
            if not self.mesh.surface_contacts:
                return np.zeros(0, dtype=np.int64)
            return self.mesh.surface_contacts[0].points
        elif self.mesh.frame_contacts is not None:  # a frame: its first contact's points
            fc = self.mesh.frame_contacts
            entries = [(c.index, c.points) for c in fc.lines] + [
                (c.index, c.points) for c in fc.planes
            ]
            if not entries:
                return np.zeros(0, dtype=np.int64)
            return min(entries, key=lambda e: e[0])[1]
        else:
            name = groups.BAR_RIGHT_END
        tagged = self.mesh.tagged
        return tagged.global_vertices(tagged.facet_vertices(name))

    def mean_motion_columns(self) -> list[str]:
        """The history columns of :meth:`mean_motion`: a block's or a frame's mass-weighted
        mean displacement and velocity (``ux_mean`` … ``vz_mean``); none for other models."""
        if not isinstance(self.scenario.model, BlockModel | FrameModel):
            return []
        if self.models.explicit is None:
            return []
        return [f"{q}{c}_mean" for q in "uv" for c in "xyz"]

    def mean_motion(self, u: FloatArray | None, v: FloatArray | None) -> dict[str, float]:
        """The mass-weighted means Σ m_i u_i / Σ m_i of each component of the explicit side's
        displacement ``u`` and velocity ``v`` (owned DOFs): the motion of the centre of mass
        (collective over the mesh's communicator for a block or a frame; {} otherwise, no
        communication)."""
        means = self._means
        if means is None or u is None or v is None:  # (a frame run on its implicit side alone)
            return {}
        cols, bs, m, m_sum = means
        n = 3
        uu, vv = u.reshape(-1, bs)[:, :n], v.reshape(-1, bs)[:, :n]
        local = np.concatenate([(m * uu).sum(axis=0), (m * vv).sum(axis=0), m_sum])
        comm = self.mesh.comm
        tot = comm.allreduce(local, op=MPI.SUM) if comm.size > 1 else local
        mass = np.concatenate([tot[2 * n :], tot[2 * n :]])
        return {c: float(x / w) for c, x, w in zip(cols, tot[: 2 * n], mass, strict=True)}

    @cached_property
    def _means(self) -> tuple[list[str], int, FloatArray, FloatArray] | None:
        """What :meth:`mean_motion` reads at every sample: its columns, the block size, the
        owned translational masses (n, 3) and their sums (None: no mean motion)."""
        cols = self.mean_motion_columns()
        sub = self.models.explicit
        if not cols or sub is None:
            return None
        m = sub.model.mass.reshape(-1, sub.bs)[:, :3]
        return cols, sub.bs, m, m.sum(axis=0)

    def destroy(self) -> None:
        self.integrators.destroy()
        self.models.destroy()


def create_simulation(sc: Scenario, comm: MPI.Comm) -> Simulation:
    """The set-up pipeline of a scenario with subdomains (collective over ``comm``)."""
    sc = concrete_scenario(sc, comm)
    mesh = build_mesh(sc, comm)
    models = build_models(sc, mesh)
    try:
        constraints = build_constraints(sc, mesh, models)
        integrators = build_integrators(sc, mesh, models, constraints)
    except BaseException:
        models.destroy()
        raise
    return Simulation(sc, mesh, models, constraints, integrators)


@dataclass(frozen=True)
class SimulationCheck:
    """What a scenario with subdomains will run, as :func:`check_simulation` found it.

    Attributes:
        method, ratio: the coupling method ("monolithic" for one subdomain) and m.
        explicit, implicit: (scheme, [[subdomain]] names) of each side, or None.
        dt, dt_critical: the micro step and the explicit side's critical step (s).
    """

    method: str
    ratio: int
    explicit: tuple[str, list[str]] | None
    implicit: tuple[str, list[str]] | None
    dt: float
    dt_critical: float
    fine_ratio: int | None = None
    #: The explicit side's undamped critical step 2/ω_max (s), its micro steps to the end
    #: and its DOFs (global): what a damping key costs.
    dt_critical_undamped: float = 0.0
    micro_steps: int = 0
    dofs_explicit: int = 0
    #: What ``time.mass_scaling`` added (one line), or None.
    mass_scaling: str | None = None

    def describe(self) -> str:
        """``gc, m = 100: cd-lagrange on contact_zones, newmark on structure; Δt = …`` or
        ``monolithic cd-lagrange; Δt = …``."""
        sides = [s for s in (self.explicit, self.implicit) if s is not None]
        if self.method == "monolithic" and len(sides) == 2:  # a mixed model fully explicit
            parts = ", ".join(f"{scheme} on {', '.join(names)}" for scheme, names in sides)
            head = f"monolithic: {parts}, through the joints every step"
        elif self.explicit is not None and self.implicit is not None:
            parts = ", ".join(f"{scheme} on {', '.join(names)}" for scheme, names in sides)
            fine = f" ({self.fine_ratio} at impacts)" if self.fine_ratio else ""
            head = f"{self.method}, m = {self.ratio}{fine}: {parts}"
        else:
            head = f"monolithic {sides[0][0]}"
        text = (
            f"{head}; Δt = {self.dt:.4e} s ({self.dt / self.dt_critical:.3g}× critical "
            f"{self.dt_critical:.4e} s)"
        )
        shrink = self.dt_critical_undamped / self.dt_critical if self.dt_critical else 1.0
        if shrink > 1.5:
            # What the damping's β K term costs: the explicit step at ~13 ns per DOF (the
            # compiled kernel at the memory bandwidth, benchmarks/RESULTS.md).
            loop = self.micro_steps * self.dofs_explicit * 13e-9
            text += (
                f"; the material's stiffness-proportional damping (β K) makes the critical "
                f"step {shrink:.3g}× smaller than undamped ({self.dt_critical_undamped:.4e} s): "
                f"{self.micro_steps} micro steps, a time loop of about {loop:.3g} s on one core "
                "for the explicit side alone (damping on the implicit side only costs nothing: "
                "[[subdomain]] damping or rayleigh)"
            )
        if self.mass_scaling is not None:
            text += f"; {self.mass_scaling}"
        return text


def _scheme(sc: Scenario, names: list[str], default: str) -> str:
    """The scheme of a side, named as in the scenario (``newmark-reduced, 40 modes``)."""
    spec = next((s for s in sc.subdomain if s.name in names), None)
    if spec is None or (sc.coupling is not None and sc.coupling.method == "monolithic"):
        return default
    if spec.scheme != "newmark-reduced":
        return str(spec.scheme)
    basis = f"{spec.modes} modes" if spec.modes else f"modes below {spec.cutoff:g} Hz"
    return f"newmark-reduced ({basis})"


def _read_records(sc: Scenario, comm: MPI.Comm) -> None:
    """Read every ground-motion record as ``run`` will (a missing or unknown record, a value
    that is not a number, a window past its end); an error on any rank is raised on all."""
    from crane_fem.pipeline.loads import ground_motion

    error: str | None = None
    try:
        for gm in sc.loading.ground_motions:
            ground_motion(gm, sc.time.end)
    except ScenarioError as exc:
        error = str(exc)
    errors = [e for e in comm.allgather(error) if e is not None]
    if errors:
        raise ScenarioError(errors[0])


def _check_points(sc: Scenario, mesh: MeshStage) -> None:
    """The measured points of ``[spectra]`` on the structure (collective)."""
    import dolfinx.mesh

    from crane_fem.points import check_points, default_points

    m = mesh.tagged.mesh
    m.topology.create_connectivity(0, m.topology.dim)  # (a box beam's mesh has none yet)
    local = np.arange(m.topology.index_map(0).size_local, dtype=np.int32)
    xyz = np.asarray(m.geometry.x)[dolfinx.mesh.entities_to_geometry(m, 0, local).ravel()]
    check_points(default_points(sc), xyz, mesh.comm)


def check_simulation(sc: Scenario, comm: MPI.Comm) -> SimulationCheck:
    """What ``run`` refuses before integrating, refused without integrating: a missing,
    unknown or malformed record, a missing or foreign mesh, Δt above the explicit side's
    critical step, subdomains that do not touch or leave a contact without an explicit side,
    a reduced implicit subdomain with more modes than interior DOFs.

    Collective over ``comm``: meshes and builds the subdomains and the constraints (no
    integrators), and destroys them.

    Returns:
        The schemes that will run on which subdomains, and the step.

    Raises:
        ScenarioError: the same one line on every rank.
    """
    _read_records(sc, comm)
    sc = concrete_scenario(sc, comm)
    mesh = build_mesh(sc, comm)
    models = build_models(sc, mesh)
    try:
        constraints = build_constraints(sc, mesh, models)
        _check_points(sc, mesh)
        spec = next((s for s in sc.subdomain if s.scheme == "newmark-reduced"), None)
        if spec is not None and spec.modes is not None and models.implicit is not None:
            _, n_int = interior_dofs(models.implicit.model, constraints.l_implicit)
            check_modes(spec.modes, n_int)
        explicit = implicit = None
        if models.explicit is not None:
            explicit = (_scheme(sc, models.explicit_names, "cd-lagrange"), models.explicit_names)
        if models.implicit is not None:
            implicit = (_scheme(sc, models.implicit_names, "newmark"), models.implicit_names)
        if models.beams_explicit:
            implicit = ("central difference", models.implicit_names)
        if not models.coupled and sc.coupling is not None and sc.coupling.method == "monolithic":
            only = (sc.coupling.monolithic_scheme, ["all"])
            explicit, implicit = (only, None) if explicit is not None else (None, only)
        fine = sc.coupling.fine_ratio if sc.coupling is not None and models.coupled else None
        side = models.explicit or models.implicit
        assert side is not None
        dofs = int(side.model.K.getSize()[0])
        return SimulationCheck(
            models.label,
            models.ratio,
            explicit,
            implicit,
            models.dt,
            models.dt_critical,
            fine,
            2.0 / models.omega_max if models.omega_max > 0 else models.dt_critical,
            models.end_steps,
            dofs,
            mesh.mass_scaling.describe() if mesh.mass_scaling is not None else None,
        )
    finally:
        models.destroy()
