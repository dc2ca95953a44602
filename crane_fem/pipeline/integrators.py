"""Pipeline stage 4, constraints → integrator: the explicit zone, the Newmark side, the
coupled system and the coupling method (a :class:`~crane_fem.coupling.MacroStep`)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.contact import ContactSet
from crane_fem.coupling import (
    CoupledSystem,
    ExplicitAlone,
    ImplicitAlone,
    MacroStep,
    MethodSetup,
    OperatorReport,
    create_interface_operator,
    create_method,
)
from crane_fem.coupling.interface import zone_labels
from crane_fem.coupling.system import ImplicitSide
from crane_fem.integrators.explicit_zone import ExplicitZone
from crane_fem.integrators.newmark import Newmark
from crane_fem.integrators.newmark_reduced import ReducedNewmark
from crane_fem.kernels.explicit import InterfaceOp
from crane_fem.loading.body import AffineLoad
from crane_fem.pipeline.constraints import ConstraintStage
from crane_fem.pipeline.loads import body_load, initial_state
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.pipeline.models import ModelStage
from crane_fem.reduction import create_craig_bampton
from crane_fem.scenario import HYBRID_KEYS, SOLVED_INTERFACE_METHODS, Scenario
from crane_fem.subdomains import Subdomain
from crane_fem.timegrid import TimeGrid

__all__ = ["IntegratorStage", "build_integrators"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class IntegratorStage:
    """The integrators of a scenario (owns them: ``destroy``, collective).

    Attributes:
        explicit: the explicit zone, or None; implicit: the Newmark side (full or reduced),
            or None.
        system: the two sides and their books; method: the macro-step method.
        operator_report: what the GC interface operator keeps (gc, gc-mean, hybrid).
        interface_force0: the link forces Λ_0 of a preloaded start, or None.
        reduction: what a reduced implicit side keeps and cost (summary.json), or None.
    """

    explicit: ExplicitZone | None
    implicit: ImplicitSide | None
    system: CoupledSystem
    method: MacroStep
    operator_report: OperatorReport | None
    interface_force0: FloatArray | None
    reduction: dict[str, Any] | None = None

    def destroy(self) -> None:
        self.method.destroy()
        if self.explicit is not None:
            self.explicit.destroy()
        if self.implicit is not None:
            self.implicit.destroy()


def _static_forces(models: ModelStage, cons: ConstraintStage) -> FloatArray | None:
    """Each contact group's static force (N), the scale of its impact level for the refining
    macro step: the preload's wheel forces, and for each flange its wheel's (a flange pressed
    along its rail is steady contact; a strike's burst exceeds twice the wheel's share of the
    weight); None without a preload."""
    if models.preload is None:
        return None
    wheels = models.preload.wheel_force
    names = cons.contacts.group_names
    static = np.zeros(len(names))
    static[: wheels.size] = wheels
    for i, name in enumerate(names):
        if name.startswith(("flange_in_", "flange_out_")):
            static[i] = wheels[int(name.rsplit("_", 1)[1]) - 1]
    return static


def _interface_force0(comm: MPI.Comm, E: ExplicitZone) -> FloatArray:
    """Link forces Λ_0 holding the preloaded subdomains in equilibrium: the explicit side's
    residual f − K u on its interface rows, Λ_0 = −r_E / c (collective). Rows that share
    DOFs (a mixed model's joints): L_Eᵀ Λ_0 = −r_E in least squares, (L_E L_Eᵀ) Λ_0 =
    −L_E r_E (exact at an equilibrium)."""
    n_g = E.n_gamma
    r = E.residual(0.0)
    st = E.stack
    sel = st.rows < n_g
    if E.zone.gg_ptr.size:
        L = E.interface
        gram = L.delassus(np.ones(r.size))  # L_E L_Eᵀ
        return np.asarray(np.linalg.solve(gram, -L.apply(r)), dtype=np.float64)
    lam = np.zeros(n_g)
    lam[st.rows[sel]] = -r[st.dofs[sel]] / st.coeffs[sel]
    out: FloatArray = comm.allreduce(lam, op=MPI.SUM)
    return out


class _OperatorFactory:
    """The GC interface operator of the explicit zone and a Newmark side at a ratio, as
    ``[coupling] interface_blocks / interface_precision / interface_truncation`` ask:
    one block per body of the implicit side (exact), and per explicit zone if asked."""

    def __init__(self, sc: Scenario, models: ModelStage, cons: ConstraintStage) -> None:
        assert models.explicit is not None and models.implicit is not None
        cpl = sc.coupling
        blocks = zone_labels(models.implicit, cons.interface_vertices)
        if cpl is not None and cpl.interface_blocks == "one":
            blocks = np.zeros_like(blocks)
        if cpl is not None and cpl.interface_blocks == "zones":
            zones = cons.joint_zones
            if zones is None:
                zones = zone_labels(models.explicit, cons.interface_vertices)
            blocks = blocks * (int(zones.max()) + 1) + zones
        self.blocks = blocks
        self.truncation = (cpl.interface_truncation if cpl is not None else None) or 0.0
        self.single = cpl is not None and cpl.interface_precision == "single"
        self.report: OperatorReport | None = None

    def __call__(
        self, E: ExplicitZone, implicit: ImplicitSide, ratio: int, fixed: bool = False
    ) -> InterfaceOp:
        w = E.zone.w_gamma if E.zone.gg_ptr.size == 0 else E.W[: E.n_gamma, : E.n_gamma]
        op, report = create_interface_operator(
            w,
            implicit.W,
            implicit.gamma,
            ratio,
            self.blocks,
            self.truncation,
            self.single,
            fixed,
        )
        self.report = self.report or report
        return op


def _reduced_side(
    sc: Scenario,
    models: ModelStage,
    cons: ConstraintStage,
    sub: Subdomain,
    load: AffineLoad,
    u0: FloatArray,
    v0: FloatArray,
) -> tuple[ReducedNewmark, dict[str, Any]]:
    """Newmark on the Craig–Bampton basis of ``sub`` (crane_fem.reduction): the interface rows
    kept, the interior by the scenario's modes (or cutoff) and the static response to each
    load vector; the initial state, the preload's, projected (collective)."""
    spec = next(s for s in sc.subdomain if s.implicit)
    model = sub.model
    mass = model.M
    diagonal = None
    if sc.newmark.mass == "lumped" or mass is None:
        diagonal = model.K.duplicate()
        diagonal.zeroEntries()
        dvec = model.create_vector(np.where(model.fixed, 1.0, model.mass))
        diagonal.setDiagonal(dvec)
        dvec.destroy()
        mass = diagonal
    try:
        rows = cons.l_implicit if models.coupled else ContactSet.empty(model.comm)
        loads = [load.base, *load.shapes]
        basis = create_craig_bampton(
            model, mass, rows, loads, spec.modes, spec.cutoff, spec.static_vectors is not False
        )
        x0, err_u = basis.coordinates(u0, mass)
        xv0, err_v = basis.coordinates(v0, mass)
    finally:
        if diagonal is not None:
            diagonal.destroy()
    shapes = np.array([basis.project(f) for f in load.shapes]).reshape(-1, basis.n_r)
    rload = AffineLoad(basis.project(load.base), shapes, load.histories)
    nm = sc.newmark
    side = ReducedNewmark(model, basis, rload, models.dT, x0, xv0, nm.beta, nm.gamma)
    report = {
        "modes": basis.n_modes,
        "cutoff_hz": spec.cutoff,
        "frequency_range_hz": [float(basis.frequencies[0]), float(basis.frequencies[-1])]
        if basis.n_modes
        else [],
        "static_vectors": basis.n_static,
        # Per load vector (self-weight, then each ground-motion direction): the fraction of its
        # static response, energy norm, that the modes alone would miss (the static vectors
        # carry it when kept; computed either way).
        "static_response_missed_by_modes": basis.static_missed,
        "interface_coordinates": basis.n_b,
        "reduced_size": basis.n_r,
        "initial_state_projection_error": max(err_u, err_v),
        **{f"{k}_s": v for k, v in basis.timings.items()},
    }
    return side, report


def build_integrators(
    sc: Scenario, mesh: MeshStage, models: ModelStage, cons: ConstraintStage
) -> IntegratorStage:
    """Explicit zone, Newmark side, coupled system and method (collective)."""
    E: ExplicitZone | None = None
    I: ImplicitSide | None = None  # noqa: E741
    coupled = models.coupled
    if models.explicit is not None:
        sub = models.explicit
        u0, v0 = initial_state(sc, sub, models.preload)
        E = ExplicitZone(
            sub.model,
            body_load(sc, mesh, sub),
            models.dt,
            u0,
            v0,
            cons.l_explicit,
            cons.contacts,
        )
    reduction = None
    if models.implicit is not None:
        sub = models.implicit
        # (A mixed model's beams are preloaded on their own mesh.)
        pre = models.beam_preload if models.joints is not None else models.preload
        u0, v0 = initial_state(sc, sub, pre)
        load = body_load(sc, mesh, sub)
        nm = sc.newmark
        spec = next(s for s in sc.subdomain if s.implicit) if sc.subdomain else None
        full = models.method == "monolithic" or models.beams_explicit
        if spec is not None and spec.scheme == "newmark-reduced" and not full:
            I, reduction = _reduced_side(sc, models, cons, sub, load, u0, v0)  # noqa: E741
        else:
            # (A mixed model's fully explicit run: its beams under the central difference.)
            beta, gamma = (0.0, 0.5) if models.beams_explicit else (nm.beta, nm.gamma)
            with warnings.catch_warnings():
                if models.beams_explicit:  # (within its critical step: build_models)
                    warnings.filterwarnings("ignore", "Newmark beta = 0", RuntimeWarning)
                I = Newmark(  # noqa: E741
                    sub.model,
                    load,
                    models.dT,
                    u0,
                    v0,
                    beta,
                    gamma,
                    cons.l_implicit if coupled else None,
                    consistent_mass=nm.mass == "consistent" and not models.beams_explicit,
                )
    grid = TimeGrid(models.dt, models.end_steps, models.sample_steps)
    system = CoupledSystem(E, I, models.ratio, models.dt, grid)
    method: MacroStep
    report = None
    if coupled:
        assert E is not None and I is not None
        cpl = sc.coupling
        assert cpl is not None
        factory = None
        if models.method in SOLVED_INTERFACE_METHODS:
            factory = _OperatorFactory(sc, models, cons)
            zone = E

            def operator(side: ImplicitSide, ratio: int, fixed: bool) -> InterfaceOp:
                assert factory is not None
                return factory(zone, side, ratio, fixed)

        # The method's own keys: the scenario refuses those of another method. (A mixed
        # model's fully explicit run ignores the coupled run's, as a monolithic run does.)
        keys = (*HYBRID_KEYS, "refine_quiet", "refine_margin", "drift_correction")
        own = {} if models.beams_explicit else {k: getattr(cpl, k) for k in keys}
        setup = MethodSetup(
            operator if factory is not None else None,
            {k: v for k, v in own.items() if v is not None},
            _static_forces(models, cons),
        )
        fine = None if models.beams_explicit else cpl.fine_ratio
        method = create_method(models.method, system, setup, fine)
        report = factory.report if factory is not None else None
    else:
        # The monolithic reference records once per sampling interval.
        alone = ExplicitAlone if E is not None else ImplicitAlone
        method = alone(system, models.sample_steps)
    force0 = None
    if coupled and models.preload is not None:
        assert E is not None
        force0 = _interface_force0(mesh.comm, E)
    return IntegratorStage(E, I, system, method, report, force0, reduction)
