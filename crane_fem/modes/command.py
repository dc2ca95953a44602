"""``crane-fem modes``: mesh the scenario, solve the closed structure's lowest modes, write
their shapes, estimate the seismic loads by response spectrum, compare with a run."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.modes.eigen import solve_modes
from crane_fem.modes.estimate import spectral_estimate
from crane_fem.modes.mixed import solve_mixed_modes
from crane_fem.modes.operators import assemble_closed_structure
from crane_fem.modes.report import (
    ModesReport,
    compare_with_run,
    read_run_summary,
    report_dict,
)
from crane_fem.modes.spectral import modal_damping
from crane_fem.modes.xdmf import write_mode_shapes
from crane_fem.scenario import BarModel, GmshModel, Scenario

__all__ = ["run_modes"]


def _agree(comm: MPI.Comm, error: str | None) -> None:
    """Raise the first rank's error on every rank (collective)."""
    errors = [e for e in comm.allgather(error) if e is not None]
    if errors:
        raise ScenarioError(errors[0])


def run_modes(
    sc: Scenario,
    comm: MPI.Comm,
    n: int,
    out: Path,
    degree: int = 1,
    damping: float | None = None,
    compare: Path | None = None,
) -> ModesReport:
    """Compute, write (``out/modes.json``, ``out/modes.xdmf``) and return the modal analysis
    and the response-spectrum estimate of a scenario (collective over ``comm``; rank 0
    writes the JSON).

    Args:
        sc: the scenario: a 3D solid with clamped vertices, or a frame with clamped or
            pinned supports that leave it no rigid mode.
        n: how many of the lowest modes.
        out: the output directory.
        degree: Lagrange degree of the displacement (1: the runs' discretisation; 2 for a
            solid only).
        damping: one damping ratio for every mode, or None for the scenario's (Rayleigh per
            mode, or 5 % when it has none).
        compare: a ``crane-fem run`` directory whose peaks to set beside the estimate; the
            record's window is then that run's [0, t_reached].

    Raises:
        ScenarioError: bad input (n < 1 or above the free DOFs, a 1D bar, no support, a
            rigid mode left by the supports, degree 2 on a frame, a run directory without
            summary.json, --compare without ground motion), the same line on every rank.
    """
    from crane_fem.pipeline import build_mesh
    from crane_fem.pipeline.kinds import concrete_scenario

    if n < 1:
        raise ScenarioError(f"modes: --n must be at least 1 (got {n})")
    if degree not in (1, 2):
        raise ScenarioError(f"modes: --degree must be 1 or 2 (got {degree})")
    if damping is not None and not 0.0 <= damping < 1.0:
        raise ScenarioError(f"modes: --damping must be a ratio in [0, 1) (got {damping})")
    if isinstance(sc.model, BarModel):
        raise ScenarioError("modes: the structure must be 3D (model.kind 'bar' is 1D)")
    summary = None
    window = sc.time.end
    if compare is not None:
        if not sc.loading.ground_motions:
            raise ScenarioError("modes --compare: the scenario has no ground motion to estimate")
        error = None
        try:
            summary = read_run_summary(compare)
        except ScenarioError as exc:
            error = str(exc)
        _agree(comm, error)
        assert summary is not None
        # The run's window; its last macro step may pass time.end by a fraction of a step.
        reached = float(summary.get("t_reached_s", window))
        window = min(reached, float(summary.get("time_end_s", reached)))
    sc = concrete_scenario(sc, comm)
    if isinstance(sc.model, GmshModel) and sc.model.mixed:
        return _mixed(sc, comm, n, Path(out), degree, damping, window, summary, compare)
    mesh = build_mesh(sc, comm)
    if mesh.fixed_vertices.size == 0 and mesh.pinned_vertices.size == 0:
        raise ScenarioError("modes: the structure has no support (it has rigid modes)")
    if degree != 1 and mesh.formulation.name != "solid":
        raise ScenarioError(
            f"modes: --degree {degree} is for solids; a {mesh.formulation.name} model is P1"
        )
    # One [material], or per-group entries (cellwise on the mesh stage; one damping).
    mat = sc.material[0] if isinstance(sc.material, list) else sc.material
    gravity = np.asarray(sc.loading.gravity, dtype=np.float64)
    st = assemble_closed_structure(mesh, mat.E, mat.nu, mat.rho, gravity, degree)
    n_free = st.n_free
    try:
        if n > n_free:
            raise ScenarioError(f"modes: --n {n} is more than the {n_free} free DOFs")
        basis = solve_modes(st, n)
        # The run's damping C = α M + β K (given as such or as a ratio at two frequencies)
        # is what each mode sees in the time history.
        zeta = modal_damping(basis.omega, mat.rayleigh_coefficients, damping)
        write_mode_shapes(Path(out) / "modes.xdmf", st, basis)
        estimate = None
        if sc.loading.ground_motions:
            estimate = spectral_estimate(st, basis, sc, zeta, window)
    finally:
        st.destroy()
    rows = compare_with_run(estimate, summary) if estimate is not None and summary else []
    report = ModesReport(
        sc.name, degree, n_free, st.mass_total, basis, zeta, estimate, rows, compare
    )
    if comm.rank == 0:
        Path(out).mkdir(parents=True, exist_ok=True)
        text = json.dumps(report_dict(report), indent=2)
        (Path(out) / "modes.json").write_text(text + "\n", encoding="utf-8")
    comm.barrier()
    return report


def _mixed(
    sc: Scenario,
    comm: MPI.Comm,
    n: int,
    out: Path,
    degree: int,
    damping: float | None,
    window: float,
    summary: dict[str, Any] | None,
    compare: Path | None,
) -> ModesReport:
    """A mixed model's modes and response-spectrum estimate (crane_fem.modes.mixed), the same
    on every rank (each computes them on its own: MPI.COMM_SELF); modes.json and rank 0's
    shapes files (modes.xdmf on the solids, modes_beams.xdmf on the beams) (collective: the
    ranks agree on an error)."""
    from crane_fem.pipeline import build_mesh

    if degree != 1:
        raise ScenarioError(f"modes: --degree {degree} is for solids; a mixed model is P1")
    error, res = None, None
    try:
        shapes = out if comm.rank == 0 else None
        res = solve_mixed_modes(
            sc, build_mesh(sc, MPI.COMM_SELF), n, shapes, damping=damping, window=window
        )
    except ScenarioError as exc:
        error = str(exc)
    _agree(comm, error)
    assert res is not None
    rows = compare_with_run(res.estimate, summary) if res.estimate is not None and summary else []
    report = ModesReport(
        sc.name,
        1,
        res.free_dofs,
        res.mass_total,
        res.basis,
        res.damping,
        res.estimate,
        rows,
        compare,
        mixed=True,
    )
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        text = json.dumps(report_dict(report), indent=2)
        (out / "modes.json").write_text(text + "\n", encoding="utf-8")
    comm.barrier()
    return report
