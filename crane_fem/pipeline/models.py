"""Pipeline stage 2, mesh → models: the static preload, the subdomains (submesh, space,
assembled operators) and the step sizes."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from crane_fem.contact.ropes import RopeSpec
from crane_fem.errors import ScenarioError
from crane_fem.pipeline.frame import frame_bonded_points
from crane_fem.pipeline.joints import JointRows, build_joints
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.preload import BondedPoints, Preload, bonded_preload, static_preload
from crane_fem.preload.mixed import mixed_preload
from crane_fem.reactions import LOWPASS_SAMPLES, lowpass_limit
from crane_fem.scenario import BlockModel, FrameModel, GmshModel, Scenario
from crane_fem.stability import (
    critical_time_step,
    max_frequency,
    max_frequency_consistent,
    newmark_critical_step,
)
from crane_fem.subdomains import Subdomain, create_subdomain

__all__ = ["TOUCHING", "ModelStage", "bonded_points", "build_models"]


@dataclass(frozen=True)
class ModelStage:
    """The subdomains of a scenario and their steps (owns the subdomains: ``destroy``).

    Attributes:
        method, ratio: the coupling method ("monolithic" for one subdomain) and m.
        explicit, implicit: the explicit (CD-Lagrange) and implicit (Newmark) subdomains.
        explicit_names, implicit_names: their ``[[subdomain]]`` names.
        preload: the crane's static self-weight state, or None.
        dt, dT: micro and macro steps (s); dt_critical: the explicit side's critical step.
        n_steps: steps of Δt to the end time; n_macro: macro steps (coarse ones for a
            refining macro step).
        end_steps: micro steps of the run (n_macro × ratio coupled, n_steps monolithic);
        sample_steps: micro steps per sampling interval (a multiple of the macro step, the
            monolithic run's record stride).
    """

    method: str
    ratio: int
    explicit: Subdomain | None
    implicit: Subdomain | None
    explicit_names: list[str]
    implicit_names: list[str]
    preload: Preload | None
    dt_critical: float
    dt: float
    dT: float
    n_steps: int
    n_macro: int
    end_steps: int = 0
    sample_steps: int = 1
    #: The explicit side's largest frequency (rad/s): its undamped critical step is 2/ω.
    omega_max: float = 0.0
    #: A mixed model's joints (the GC interface's rows) and its beams' preloaded state (the
    #: solids' is ``preload``); None otherwise.
    joints: JointRows | None = None
    beam_preload: Preload | None = None
    #: A mixed model's fully explicit run (``coupling.method = "monolithic"``): its beams
    #: under the central difference (Newmark β = 0, γ = ½, lumped mass) at the solids' step,
    #: through the joints' rows every step (GC at m = 1: the monolithic constrained central
    #: difference, tests/test_coupling.py), Δt within both sides' critical steps.
    beams_explicit: bool = False

    @property
    def label(self) -> str:
        """The method as the user named it (``monolithic`` for a mixed model's fully
        explicit run, which ``method`` runs as GC at m = 1)."""
        return "monolithic" if self.beams_explicit else self.method

    @property
    def coupled(self) -> bool:
        return self.explicit is not None and self.implicit is not None

    def destroy(self) -> None:
        for sub in (self.explicit, self.implicit):
            if sub is not None:
                sub.destroy()


def _specs(sc: Scenario, mesh: MeshStage) -> tuple[str, int, list[tuple[str, str, list[str]]]]:
    """(method, ratio, [(name, scheme, groups)]) of the scenario's subdomains."""
    cpl = sc.coupling
    if cpl is not None and cpl.method == "monolithic" and mesh.beams is not None:
        # A mixed model fully explicit: its two element kinds' subdomains, both explicit,
        # through the joints every step (build_models: ``beams_explicit``).
        return "gc", 1, [(s.name, str(s.scheme), list(s.groups)) for s in sc.subdomain]
    if cpl is not None and cpl.method == "monolithic":
        groups = list(mesh.tagged.cell_groups)
        return "monolithic", 1, [("all", cpl.monolithic_scheme, groups)]
    if isinstance(sc.model, BlockModel) or (
        isinstance(sc.model, GmshModel | FrameModel) and not sc.subdomain
    ):  # one explicit body: the fully explicit path
        return "monolithic", 1, [("all", "cd-lagrange", list(mesh.tagged.cell_groups))]
    specs: list[tuple[str, str, list[str]]] = [
        (s.name, str(s.scheme), list(s.groups)) for s in sc.subdomain
    ]
    method = str(cpl.method) if cpl is not None else "monolithic"
    return method, (cpl.ratio if cpl is not None else 1), specs


def _time_steps(sc: Scenario, explicit: Subdomain | None, dt_critical: float) -> float:
    """Δt from the scenario, checked against the explicit subdomain's critical step.
    (Monolithic Newmark: dt_factor refers to the explicit limit of the same mesh.)"""
    if sc.time.dt is not None:
        if explicit is not None and sc.time.dt > dt_critical:
            raise ScenarioError(
                f"time.dt = {sc.time.dt:.4e} s exceeds the critical step "
                f"{dt_critical:.4e} s of explicit subdomain '{explicit.name}'"
            )
        return sc.time.dt
    assert sc.time.dt_factor is not None
    if explicit is not None and sc.time.dt_factor > 1.0:
        raise ScenarioError(
            f"time.dt_factor = {sc.time.dt_factor} > 1 puts Δt above the critical step "
            f"of explicit subdomain '{explicit.name}'"
        )
    return sc.time.dt_factor * dt_critical


def sample_steps(sc: Scenario, dt: float, unit: int) -> int:
    """Micro steps per sampling interval: ``output.sample_interval`` rounded to a whole number
    of ``unit`` (the macro step's micro steps, whose ends are the only times a coupled run
    holds both sides' state), at least one; ``unit`` when the key is unset."""
    delta = sc.output.sample_interval
    if delta is None:
        return unit
    if delta < dt:
        raise ScenarioError(
            f"output.sample_interval = {delta:g} s is below the time step Δt = {dt:.4e} s"
        )
    return unit * max(1, round(delta / (unit * dt)))


#: A contact point touches its surface at t = 0 within this fraction of the model's extent (a
#: mesh's nodes on a shared plane sit there to ~1e-12 of it): the preload bonds it, `modes`
#: ties it.
TOUCHING = 1e-9


def bonded_points(mesh: MeshStage) -> BondedPoints:
    """The t = 0 pairing of a gmsh model's node-to-surface contacts, every contact's points
    stacked in order (group: the contact's index)."""
    ids, weights, normal, gap, group, free = [], [], [], [], [], []
    for k, c in enumerate(mesh.surface_contacts):
        pr = c.pairing
        free.append(np.tile(c.rolling if c.rolling is not None else np.zeros(3), (pr.gap.size, 1)))
        tri = c.surface.vertex_ids[c.surface.triangles[pr.triangle]]
        ids.append(np.column_stack([c.points, tri]))
        weights.append(np.column_stack([np.ones(c.points.size), -pr.xi]))
        normal.append(pr.normal)
        gap.append(pr.gap)
        group.append(np.full(c.points.size, k, dtype=np.int64))
    if not ids:
        z = np.zeros((0, 4))
        return BondedPoints(
            z.astype(np.int64), z, np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64)
        )
    rolls = any(c.rolling is not None for c in mesh.surface_contacts)
    return BondedPoints(
        np.concatenate(ids).astype(np.int64),
        np.concatenate(weights),
        np.concatenate(normal),
        np.concatenate(gap),
        np.concatenate(group),
        free=np.concatenate(free) if rolls else None,
    )


def _gmsh_preload(sc: Scenario, mesh: MeshStage) -> Preload:
    """A gmsh model's or a frame's self-weight state, its closed contacts bonded
    (collective)."""
    fc = mesh.frame_contacts
    if fc is not None:
        points, groups = frame_bonded_points(fc), len(fc.names)
    else:
        points, groups = bonded_points(mesh), len(mesh.surface_contacts)
    return bonded_preload(
        mesh.tagged,
        points,
        groups,
        mesh.formulation,
        mesh.fields,
        mesh.fixed_vertices,
        np.asarray(sc.loading.gravity, dtype=np.float64),
        # Touching at t = 0: within round-off of the model's size (a mesh's nodes on a
        # shared plane sit there to ~1e-12 of it).
        TOUCHING * mesh.extent(),
        mesh.pinned_vertices,
        mesh.point_masses,
        (fc.ropes, fc.rope_X) if fc is not None and fc.ropes is not None else None,
        mesh.held_rotations,
    )


def _warn_unpressed(mesh: MeshStage) -> None:
    """Without gravity, warn (once, on rank 0) of the contacts whose points touch at t = 0:
    nothing presses them, so they hold nothing (collective: the model's extent)."""
    fc = mesh.frame_contacts
    if fc is not None:
        points, names = frame_bonded_points(fc), list(fc.names)
    else:
        points, names = bonded_points(mesh), [c.name for c in mesh.surface_contacts]
    touching = points.group[points.gap <= TOUCHING * mesh.extent()]
    resting = [names[int(k)] for k in np.unique(touching)]
    if not resting or mesh.comm.rank != 0:
        return
    which = ", ".join(repr(n) for n in resting)
    one = len(resting) == 1
    warnings.warn(
        f"loading.gravity is zero, yet contact{'' if one else 's'} {which} "
        f"touch{'es' if one else ''} at t = 0: nothing presses {'it' if one else 'them'}, so "
        f"{'it carries' if one else 'they carry'} no force and no friction; give "
        "loading.gravity = [0.0, 0.0, -9.81] for a structure that stands on its contacts",
        UserWarning,
        stacklevel=3,
    )


def _rope_frequency(sub: Subdomain, ropes: RopeSpec) -> float:
    """The largest √(k (1/m_a + 1/m_b)) of the ropes (rad/s), m the ends' lumped
    translational masses (collective)."""
    ends = np.unique(np.r_[ropes.a, ropes.b])
    blocks, pos = sub.owned_dofs_of(ends)
    mass = np.zeros(ends.size)
    mass[pos] = sub.model.mass.reshape(-1, sub.bs)[blocks, 0]
    mass = sub.submesh.comm.allreduce(mass, op=MPI.SUM)
    m_a = mass[np.searchsorted(ends, ropes.a)]
    m_b = mass[np.searchsorted(ends, ropes.b)]
    return float(np.max(np.sqrt(ropes.stiffness * (1.0 / m_a + 1.0 / m_b)), initial=0.0))


def _check_newmark_step(
    sc: Scenario, implicit: Subdomain, scheme: str, ratio: int, dt: float, dT: float
) -> None:
    """A conditionally stable Newmark side (β < γ/2: β = 0 is the central difference) must
    take its macro step within its own critical step (collective; nothing computed for the
    default average acceleration). Raises ScenarioError naming coupling.ratio."""
    beta, gamma = sc.newmark.beta, sc.newmark.gamma
    if beta >= 0.5 * gamma:
        return
    if scheme != "newmark":
        raise ScenarioError(
            f"newmark.beta = {beta:g} < newmark.gamma / 2: a conditionally stable Newmark is "
            f"not checked on the reduced side ('{scheme}'); take newmark.beta >= {0.5 * gamma:g}"
        )
    model = implicit.model
    consistent = sc.newmark.mass == "consistent" and model.M is not None
    omega = max_frequency_consistent(model) if consistent else max_frequency(model)
    limit = newmark_critical_step(omega, beta, gamma)
    if dT > limit:
        most = max(0, math.floor(limit / dt))
        raise ScenarioError(
            f"coupling.ratio = {ratio}: the macro step ΔT = {dT:.4e} s exceeds the critical "
            f"step {limit:.4e} s of the implicit subdomain '{implicit.name}' under "
            f"newmark.beta = {beta:g} (conditionally stable: ΔT ω_max ≤ (γ/2 − β)^(−1/2), "
            f"ω_max = {omega:.4e} rad/s); "
            + (f"take coupling.ratio <= {most}" if most >= 1 else "raise newmark.beta")
        )


def _check_lowpass(sc: Scenario, mesh: MeshStage, sample_dt: float) -> None:
    """``output.support_lowpass_hz`` needs supports and reactions sampled at least
    :data:`LOWPASS_SAMPLES` times a period of its cut-off. Raises ScenarioError."""
    cutoff = sc.output.support_lowpass_hz
    if cutoff is None:
        return
    if mesh.crane is None and not sc.support:
        raise ScenarioError(
            f"output.support_lowpass_hz = {cutoff:g}: this model has no supports (a crane's "
            "clamped ends or [[support]] groups) whose forces it would filter"
        )
    interval = sc.output.stress_every * sample_dt
    if cutoff > lowpass_limit(interval) * (1.0 + 1e-9):
        raise ScenarioError(
            f"output.support_lowpass_hz = {cutoff:g}: the support forces are sampled every "
            f"{interval:.4e} s (output.sample_interval × output.stress_every), fewer than "
            f"{LOWPASS_SAMPLES} samples a period of the cut-off; take output.support_lowpass_hz "
            f"<= {lowpass_limit(interval):.4g} or sample more often"
        )


def build_models(sc: Scenario, mesh: MeshStage) -> ModelStage:
    """Preload, subdomains and steps (collective)."""
    mdl, mat = sc.model, sc.materials[0][1]  # E, ν, ρ where uniform (else mesh.materials)
    tagged, fixed = mesh.tagged, mesh.fixed_vertices
    method, ratio, specs = _specs(sc, mesh)
    cpl = sc.coupling
    beams_explicit = mesh.beams is not None and cpl is not None and cpl.method == "monolithic"
    rayleigh = sc.rayleigh_coefficients
    preload = None
    if mesh.crane is not None and np.any(np.asarray(sc.loading.gravity) != 0.0):
        assert mesh.density is not None
        preload = static_preload(
            tagged,
            mesh.crane.pairs,
            mesh.crane.wheel,
            fixed,
            mat.E,
            mat.nu,
            mesh.density,
            np.asarray(sc.loading.gravity, dtype=np.float64),
            ["trolley_frame"] + [f"wheel_{k}" for k in range(1, 5)],
        )
    users = isinstance(mdl, GmshModel | FrameModel)
    mixed = mesh.beams is not None  # its preload: through its joints, once they are built
    if users and not mixed and sc.initial.preload and np.any(np.asarray(sc.loading.gravity) != 0.0):
        preload = _gmsh_preload(sc, mesh)
    if users and not np.any(np.asarray(sc.loading.gravity) != 0.0):
        _warn_unpressed(mesh)
    explicit_specs = [s for s in specs if s[1] == "cd-lagrange"]
    implicit_specs = [s for s in specs if s[1] in ("newmark", "newmark-reduced")]
    explicit = implicit = None
    if explicit_specs:
        explicit = create_subdomain(
            tagged,
            "+".join(s[0] for s in explicit_specs),
            "cd-lagrange",
            tagged.cells([g for s in explicit_specs for g in s[2]]),
            mesh.formulation,
            mesh.fields,
            rayleigh,
            fixed,
            consistent_mass=False,
            pinned_vertices=mesh.pinned_vertices,
            point_masses=mesh.point_masses,
            held_rotations=mesh.held_rotations,
        )
    if implicit_specs:
        spec = next((s for s in sc.subdomain if s.name == implicit_specs[0][0]), None)
        own = spec.rayleigh_coefficients if spec is not None else None
        # A mixed model's beams are their own mesh (the implicit side); else the same one.
        src = mesh.beams if mesh.beams is not None else mesh
        implicit = create_subdomain(
            src.tagged,
            implicit_specs[0][0],
            implicit_specs[0][1],
            src.tagged.cells(implicit_specs[0][2]),
            src.formulation,
            src.fields,
            own if own is not None else rayleigh,
            src.fixed_vertices,
            consistent_mass=sc.newmark.mass == "consistent" and not beams_explicit,
            pinned_vertices=src.pinned_vertices,
            point_masses=src.point_masses,
            held_rotations=src.held_rotations,
        )
    joints = beam_preload = None
    if mesh.beams is not None and explicit is not None and implicit is not None:
        # A mixed model: its joints' rows, and its preload through them (the solids and the
        # beams on their own meshes: after the subdomains).
        joints = build_joints(sc, mesh, explicit, implicit)
        if sc.initial.preload and np.any(np.asarray(sc.loading.gravity) != 0.0):
            preload, beam_preload = mixed_preload(
                explicit,
                implicit,
                joints.l_explicit,
                joints.l_implicit,
                bonded_points(mesh),
                len(mesh.surface_contacts),
                np.asarray(sc.loading.gravity, dtype=np.float64),
                TOUCHING * mesh.extent(),
            )
    # Δt from the explicit subdomain's own critical step.
    step_sub = explicit if explicit is not None else implicit
    assert step_sub is not None
    omega_max = max_frequency(step_sub.model)
    fc = mesh.frame_contacts
    if fc is not None and fc.ropes is not None and explicit is not None:
        # A rope's spring is not in K: its end masses' frequency √(k (1/m_a + 1/m_b)) joins
        # the explicit side's (bounded as the root of their squares' sum: an end may also
        # sit on a beam).
        omega_max = math.hypot(omega_max, _rope_frequency(explicit, fc.ropes))
    if beams_explicit:  # the beams' central difference too: the larger ω_max sets Δt
        assert implicit is not None
        omega_max = max(omega_max, max_frequency(implicit.model))
    dt_critical = critical_time_step(omega_max, *rayleigh)
    dt = _time_steps(sc, explicit, dt_critical)
    coupled = explicit is not None and implicit is not None
    n_steps = max(1, math.ceil(sc.time.end / dt - 1e-9))
    if coupled:
        dT = dt * ratio
        if dT > sc.time.end * (1.0 + 1e-9):
            raise ScenarioError(
                f"time.end = {sc.time.end:g} s is shorter than one macro step ΔT = "
                f"coupling.ratio × Δt = {ratio} × {dt:.4e} = {dT:.4e} s: lower coupling.ratio "
                "or lengthen time.end"
            )
        n_macro = max(1, math.ceil(sc.time.end / dT - 1e-9))
        end = n_macro * ratio
        assert implicit is not None
        if beams_explicit:  # (its step within the beams' own: dt_critical above)
            assert cpl is not None
            sample = sample_steps(sc, dt, cpl.ratio)
        else:
            _check_newmark_step(sc, implicit, implicit_specs[0][1], ratio, dt, dT)
            sample = sample_steps(sc, dt, ratio)
    else:
        # A monolithic reference records at the coupled run's sampling instants: one macro
        # step per sampling interval (the two histories share one time grid).
        dT = dt
        unit = sc.coupling.ratio if sc.coupling is not None else 1
        sample = sample_steps(sc, dt, unit)
        n_macro = math.ceil(n_steps / sample)
        end = n_steps
    _check_lowpass(sc, mesh, sample * dt)
    return ModelStage(
        method,
        ratio,
        explicit,
        implicit,
        [s[0] for s in explicit_specs],
        [s[0] for s in implicit_specs],
        preload,
        dt_critical,
        dt,
        dT,
        n_steps,
        n_macro,
        end,
        sample,
        omega_max,
        joints,
        beam_preload,
        beams_explicit,
    )
