"""The ``crane-fem`` command: ``run``, ``check`` and ``mesh`` a scenario; its ``modes``;
``plot`` its outputs; ``bench`` the methods; a ``study`` over many runs; spectrum-compatible
``records``."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from crane_fem import _compat  # noqa: F401  (MPI before dolfinx)
from crane_fem.errors import CraneFemError

if TYPE_CHECKING:
    from crane_fem.scenario import Scenario

__all__ = ["main"]


def _key_options(parser: argparse.ArgumentParser) -> None:
    """``--set`` and ``--unset``: a scenario's keys changed on the command line."""
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY.PATH=VALUE",
        help="override a key; VALUE is a TOML value (strings quoted: key='\"text\"')",
    )
    parser.add_argument(
        "--unset",
        dest="unset",
        action="append",
        default=[],
        metavar="KEY.PATH",
        help="remove a key of the scenario (before the --set overrides are applied)",
    )


def _version() -> str:
    """The installed distribution's version (importlib.metadata), else the package's."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("crane_fem")
    except PackageNotFoundError:
        from crane_fem import __version__

        return __version__


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="crane-fem",
        description="Seismic analysis of structures with impacts (CD-Lagrange, Newmark, GC).",
    )
    parser.add_argument("--version", action="version", version=f"crane-fem {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scenario")
    run.add_argument("scenario", type=Path, help="scenario TOML file")
    run.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        help="output directory (default: out/<scenario name>)",
    )
    _key_options(run)
    run.add_argument(
        "--restart",
        type=Path,
        default=None,
        metavar="OUTDIR",
        help="continue the run whose checkpoints are in OUTDIR (output.checkpoint_every), into "
        "OUTDIR unless -o is given",
    )
    run.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="force the progress bar on/off (default: on a terminal)",
    )
    check = sub.add_parser("check", help="validate a scenario without running it")
    check.add_argument("scenario", type=Path)
    _key_options(check)
    modes = sub.add_parser(
        "modes",
        help="natural modes with the contacts closed, and the response-spectrum estimate",
    )
    modes.add_argument("scenario", type=Path)
    modes.add_argument("--n", type=int, default=20, metavar="N", help="the N lowest modes (20)")
    modes.add_argument(
        "--out", type=Path, default=None, help="default: out/<scenario file stem>_modes"
    )
    modes.add_argument(
        "--degree", type=int, choices=(1, 2), default=1, help="Lagrange degree (1: the runs')"
    )
    modes.add_argument(
        "--damping",
        type=float,
        default=None,
        metavar="ZETA",
        help="one damping ratio for every mode (default: the scenario's Rayleigh damping "
        "per mode, 5 %% without one)",
    )
    modes.add_argument(
        "--compare",
        type=Path,
        default=None,
        metavar="RUN_DIR",
        help="a `crane-fem run` directory: its peaks beside the estimate, with RS/TH",
    )
    _key_options(modes)
    plot = sub.add_parser(
        "plot",
        help="figures of a run directory, of the runs in its subdirectories, or of a study",
    )
    plot.add_argument("outdir", type=Path)
    plot.add_argument(
        "--ensemble",
        type=Path,
        action="append",
        default=[],
        metavar="DIR",
        help="the explicit ensemble's runs (record × (1 ± ε), Δt × ½; a run directory or a "
        "directory of runs): criterion (b) by max(tolerance, their spread)",
    )
    mesh = sub.add_parser("mesh", help="mesh a crane scenario's geometry to a gmsh .msh file")
    mesh.add_argument("scenario", type=Path)
    mesh.add_argument(
        "-o", "--output", type=Path, default=None, help="default: meshes/<scenario name>.msh"
    )
    _key_options(mesh)
    bench = sub.add_parser(
        "bench",
        help="run benchmark suites: speed against accuracy, stability, the crane ensemble",
    )
    bench.add_argument(
        "suites",
        nargs="*",
        metavar="SUITE",
        help="suites to run (default: stability pareto ensemble; also three_component, "
        "speed, reduction, convergence, gc_stability)",
    )
    bench.add_argument("--quick", action="store_true", help="the quick variant (≤ 10 min)")
    bench.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        help="CSV and PNG go here (default: benchmarks/out, benchmarks/out/quick with --quick)",
    )
    bench.add_argument(
        "--no-results", action="store_true", help="leave benchmarks/RESULTS.md unchanged"
    )
    study = sub.add_parser(
        "study",
        help="a study: one scene over records, positions, directions and its conditioning "
        "ensemble, on dask.distributed; the envelope tables",
    )
    study.add_argument("study", type=Path, help="study TOML file")
    study.add_argument(
        "-o", "--output", type=Path, default=None, help="default: out/<study file stem>"
    )
    study.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="cases at once on the local cluster (default: one per core)",
    )
    study.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a running dask scheduler (tcp://host:8786) instead of a local cluster",
    )
    from crane_fem.records.cli import add_parser as add_records

    add_records(sub)
    return parser


def _error(exc: Exception) -> None:
    """The one line of an error, on this rank's stderr, in one write (print makes two, which
    a launcher relaying several ranks may interleave)."""
    sys.stderr.write(f"crane-fem: error: {exc}\n")
    sys.stderr.flush()


@contextlib.contextmanager
def _one_line_warnings() -> Iterator[None]:
    """Every warning as one line on stderr (restored on exit)."""
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = lambda m, *a, **k: print(f"crane-fem: warning: {m}", file=sys.stderr)
        yield


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (0 ok, 2 bad input, 3 unstable run)."""
    from mpi4py import MPI

    from crane_fem._compat import launcher_size_mismatch, venv_mpiexec
    from crane_fem.errors import RunInterrupted, ScenarioError, UnstableRunError
    from crane_fem.scenario import load_scenario

    args = _parser().parse_args(argv)
    comm = MPI.COMM_WORLD
    rank0 = comm.rank == 0
    try:
        mismatch = launcher_size_mismatch(comm.size)
        if mismatch is not None:
            raise ScenarioError(
                f"launched by a foreign MPI launcher ({mismatch}) but this MPI sees "
                f"{comm.size} process{'es' if comm.size > 1 else ''}; use {venv_mpiexec()}"
            )
        if args.command == "plot":
            return _plot(args.outdir, args.ensemble) if rank0 else 0
        if args.command == "bench":
            return _bench(args, comm)
        if args.command in ("study", "records"):
            if comm.size > 1:
                raise ScenarioError(
                    f"crane-fem {args.command} runs in one process (a study's cases run in "
                    "processes of their own): run it without mpiexec"
                )
            if args.command == "records":
                from crane_fem.records.cli import run as run_records

                return run_records(args)
            from crane_fem.study import run_study

            code, _ = run_study(args.study, args.output, args.workers, args.scheduler)
            return code
        mesh_cmd = args.command == "mesh"
        sc = load_scenario(args.scenario, args.overrides, args.unset, read_mesh=not mesh_cmd)
        if mesh_cmd:
            from crane_fem.geometry.crane import mesh_sidecar, write_crane_mesh
            from crane_fem.scenario import CraneModel

            if not isinstance(sc.model, CraneModel):
                raise ScenarioError(f"{args.scenario}: model.kind must be 'crane' to be meshed")
            path = args.output or Path("meshes") / f"{sc.name}.msh"
            if rank0:
                info = write_crane_mesh(sc.model.geometry(), path)
                print(f"crane-fem: wrote {path} ({info}) and {mesh_sidecar(path)}")
            return 0
        if args.command == "modes":
            return _modes(sc, args, comm)
        if args.command == "check":
            with _one_line_warnings():
                what = _check(sc, comm)
            if rank0:
                print(f"{args.scenario}: ok ({sc.model.kind}; {what})")
            return 0
        return _run(sc, args, comm)
    except ScenarioError as exc:
        _error(exc)
        return 2
    except UnstableRunError as exc:
        _error(exc)
        return 3
    except RunInterrupted as exc:
        _error(exc)
        return 128 + (15 if "SIGTERM" in str(exc) else 2)
    except KeyboardInterrupt:
        # Before the time loop (set-up, meshing): nothing to keep.
        _error(CraneFemError("interrupted before the time loop; no results were written"))
        return 130
    except CraneFemError as exc:
        _error(exc)
        return 1


def _check(sc: Scenario, comm: Any) -> str:
    """What ``run`` refuses before integrating, refused here (collective: builds the mesh and
    the subdomains, or the bar's problem, and destroys them); returns the scheme that will
    run and its step, e.g. ``gc, m = 100: cd-lagrange on contact_zones, newmark on
    structure; Δt = 1.3026e-06 s (0.9× critical 1.4473e-06 s)``."""
    if sc.coupled_path:
        from crane_fem.pipeline import check_simulation

        return check_simulation(sc, comm).describe()
    from crane_fem.driver import Simulation

    sim = Simulation(sc, comm)
    try:
        limit = min(sim.dt_critical, sim.dt_critical_penalty or math.inf)
        what = "critical" if sim.dt_critical_penalty is None else "critical with the springs"
        return (
            f"{sc.integrator.scheme}; Δt = {sim.dt:.4e} s ({sim.dt / limit:.3g}× {what} "
            f"{limit:.4e} s)"
        )
    finally:
        sim.destroy()


def _run(sc: Scenario, args: argparse.Namespace, comm: Any) -> int:
    """Prepare the output directory, run, and say where the outputs are (collective)."""
    from crane_fem.driver import run_scenario
    from crane_fem.io import prepare_output_dir
    from crane_fem.io.results import results_lines, run_line

    rank0 = comm.rank == 0
    restart = args.restart
    outdir = args.output if args.output is not None else restart or Path("out") / sc.name
    # The run continues in the restart directory: its files are kept. Another output
    # directory is a new run's: cleared.
    same = restart is not None and Path(outdir).resolve() == Path(restart).resolve()
    removed = prepare_output_dir(outdir, comm, restart=same)
    if rank0 and removed:
        names = ", ".join(removed)
        print(f"crane-fem: removed the outputs of an earlier run in {outdir}/: {names}")
    with _one_line_warnings():
        result = run_scenario(sc, outdir, comm, progress=args.progress, restart=restart)
    s = result.summary
    if rank0:
        print(f"crane-fem: {run_line(sc.name, s)}")
        for line in results_lines(s):
            print(f"crane-fem: {line}")
        xdmf = sorted(p.name for p in Path(outdir).glob("*.xdmf"))
        extra = [f for f in ("results.csv", "spectra.csv") if (Path(outdir) / f).exists()]
        files = ["history.csv", "summary.json", *extra, *xdmf]
        print(f"crane-fem: outputs in {outdir}/ ({', '.join(files)})")
    return 0


def _modes(sc: Scenario, args: argparse.Namespace, comm: Any) -> int:
    """Modal analysis and response-spectrum estimate; the table on rank 0 (collective)."""
    from crane_fem.modes import report_lines, run_modes

    out = args.out if args.out is not None else Path("out") / f"{args.scenario.stem}_modes"
    with _one_line_warnings():
        report = run_modes(sc, comm, args.n, out, args.degree, args.damping, args.compare)
    if comm.rank == 0:
        for line in report_lines(report):
            print(f"crane-fem: {line}")
        files = "modes.json, modes.xdmf, modes.h5" + (
            ", modes_beams.xdmf, modes_beams.h5" if report.mixed else ""
        )
        print(f"crane-fem: outputs in {out}/ ({files})")
    return 0


def _bench(args: argparse.Namespace, comm: Any) -> int:
    """Run the suites one after the other; their tables replace their blocks of RESULTS.md."""
    import time

    from crane_fem.bench import ALL_SUITES, SUITES, load_suite
    from crane_fem.bench.report import RESULTS, update_results
    from crane_fem.errors import ScenarioError

    names = args.suites or SUITES
    unknown = [n for n in names if n not in ALL_SUITES]
    if unknown:
        raise ScenarioError(
            f"bench: unknown suite {unknown[0]!r} (expected one of {', '.join(ALL_SUITES)})"
        )
    command = (
        "crane-fem bench"
        + (" --quick" if args.quick else "")
        + "".join(f" {n}" for n in args.suites)
    )
    out = args.output or Path("benchmarks/out") / ("quick" if args.quick else "")
    t0 = time.perf_counter()
    for name in names:
        t = time.perf_counter()
        sections = load_suite(name).run(out, args.quick)
        if comm.rank == 0:
            for sec in sections:
                if not args.no_results:
                    update_results(RESULTS, sec.key, sec.title, command, sec.body)
                for f in sec.files:
                    print(f"crane-fem: wrote {f}")
            print(f"crane-fem: bench {name}: {time.perf_counter() - t:.0f} s")
    if comm.rank == 0:
        where = "" if args.no_results else f"; tables in {RESULTS}"
        print(f"crane-fem: bench done in {(time.perf_counter() - t0) / 60:.1f} min{where}")
    return 0


def _plot(outdir: Path, ensemble: list[Path]) -> int:
    from crane_fem.compare import describe, write_comparison
    from crane_fem.plotting import plot_figures

    if (outdir / "study.json").is_file():
        from crane_fem.plotting.study import study_figures

        for p in study_figures(outdir):
            print(f"crane-fem: wrote {p}")
        return 0

    try:
        figures = plot_figures(outdir)
        compared = write_comparison(outdir, ensemble)
    except (FileNotFoundError, ValueError) as exc:
        _error(exc)
        return 2
    for line in figures.warnings:
        print(f"crane-fem: warning: {line}")
    for p in figures.paths:
        print(f"crane-fem: wrote {p}")
    if compared is not None:
        path, result = compared
        print(f"crane-fem: wrote {path}")
        for line in describe(result):
            print(f"crane-fem: {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
