"""Speed of the compiled explicit kernel and of the heterogeneous run against the fully explicit
one, held against the machine's memory bandwidth (issue 13).

    .venv/bin/python benchmarks/speed.py [--quick] [--skip-sweep] [-o out/bench_speed]

Parts (each measured in its own process, one after the other, one BLAS thread per rank):

1. ``stream``: the STREAM triad a = b + s c (numba), on arrays far larger than the caches, on
   one rank and on two (``mpiexec -n 2``, summed), and at the working-set size of the fully
   explicit step (what the cache holds).
2. ``explicit``: the fully explicit step of a scene (the kernel alone, many steps per call):
   time, bytes of its data read and written (stiffness values and column indices, vectors),
   and the fraction of the stream roofline; the same on a 1k-DOF bar.
3. ``coupled``: a coupled micro step of a scene, split into the zone (the kernel with no
   interface rows), the interface solve, the implicit side (two solves per macro step,
   amortised) and the rest (Python at macro-step granularity: the implicit side's products,
   its books, the records).
4. ``runs``: wall time per simulated second of the time loop (``wall_time_integration_s`` of
   summary.json) for the fully explicit run, gc and gc-mean at m ∈ {10, 100, 1000}, on the
   default and the stress-grade scenes, np = 1 and 2, with the peak memory per rank.
5. ``sweep``: the explicit step and the coupled micro step (m = 100) on crane meshes from
   10k to ≥ 150k DOFs (``model.size`` 0.12 … 0.02), with fitted slopes.

The results go to ``benchmarks/results/speed.json`` and ``speed_*.png``; the tables are printed
in Markdown (copied into benchmarks/RESULTS.md with this command line).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEMOS = ROOT / "demos"
SCENES = {"default": DEMOS / "crane.toml", "stress": DEMOS / "crane_stress.toml"}
RESULTS = ROOT / "benchmarks" / "results"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
BIN = Path(sys.executable).parent


# --------------------------------------------------------------------------------------
# Parts run in their own process (``--part``), printing one JSON line on rank 0.
def _emit(comm: Any, data: dict[str, Any]) -> None:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # MB (Linux: kB)
    data["peak_memory_mb_per_rank"] = comm.allgather(peak)
    if comm.rank == 0:
        print("RESULT " + json.dumps(data), flush=True)


def part_stream(size_mb: float) -> None:
    """STREAM triad on three arrays of ``size_mb`` MB each (every rank at once)."""
    import numba
    from mpi4py import MPI

    comm = MPI.COMM_WORLD

    @numba.njit(cache=True)
    def triad(a: Any, b: Any, c: Any, s: float) -> None:
        for i in range(a.size):
            a[i] = b[i] + s * c[i]

    n = int(size_mb * 1e6 / 8)
    a, b, c = np.zeros(n), np.random.default_rng(0).random(n), np.random.default_rng(1).random(n)
    triad(a, b, c, 3.0)
    reps = max(3, int(2e9 / (24 * n)))
    best = np.inf
    for _ in range(5):
        comm.Barrier()
        t = time.perf_counter()
        for _ in range(reps):
            triad(a, b, c, 3.0)
        comm.Barrier()
        best = min(best, (time.perf_counter() - t) / reps)
    # STREAM's count: read b and c, write a, 24 B per entry (the write-allocate read of a is
    # not counted, nor is it in the kernel's bytes).
    bw = 24.0 * n / best * comm.size
    _emit(comm, {"part": "stream", "array_mb": size_mb, "np": comm.size, "GBps": bw / 1e9})


def _step_bytes(zone: Any) -> dict[str, float]:
    """Bytes one fully explicit step reads and writes, at least: the stiffness (values,
    column indices, row pointers) once, and per DOF the move pass (U, V read; U written) and
    the fused pass (U through the product, V read and written, M⁻¹, M, the load vectors)."""
    stiff = zone.data.nbytes + zone.indices.nbytes + zone.indptr.nbytes
    per_dof = 8 * (3 + 1 + 2 + 2 + 1 + zone.load_shapes.shape[0] + 1)  # + K U written
    vec = per_dof * zone.n_own
    return {"stiffness_bytes": float(stiff), "vector_bytes": float(vec)}


def part_explicit(scene: str, steps: int, extra: list[str]) -> None:
    """The fully explicit step of ``scene`` (a scenario file with the ``extra`` overrides, or
    "bar1k")."""
    from mpi4py import MPI

    from crane_fem.kernels import explicit as kx
    from crane_fem.pipeline import create_simulation
    from crane_fem.scenario import load_scenario, parse_scenario

    comm = MPI.COMM_WORLD
    if scene == "bar1k":
        sc = parse_scenario(
            {
                "name": "bar1k",
                "model": {"kind": "bar", "length": 1.0, "elements": 1000},
                "material": {"E": 1.0, "rho": 1.0},
                "initial": {"velocity": -1.0},
                "contact": [{"type": "wall", "gap": 0.1}],
                "time": {"end": 1.0, "dt_factor": 0.9},
                "coupling": {"method": "monolithic", "scheme": "cd-lagrange"},
                "output": {"xdmf": False},
            }
        )
    else:
        sc = load_scenario(scene, ["coupling.method='monolithic'", "output.xdmf=false", *extra])
    sim = create_simulation(sc, comm)
    E = sim.integrators.explicit
    assert E is not None
    sim.integrators.method.initialize(None)
    ctl = E.steps(0.0, steps, mode=kx.NONE)
    E.advance(E.steps(0.0, 10, mode=kx.NONE))
    best = np.inf
    for _ in range(5):
        comm.Barrier()
        t = time.perf_counter()
        E.advance(ctl)
        comm.Barrier()
        best = min(best, (time.perf_counter() - t) / steps)
    data = _step_bytes(E.zone)
    glob = {k: comm.allreduce(v) for k, v in data.items()}
    dofs = comm.allreduce(E.zone.n_own)
    _emit(
        comm,
        {"part": "explicit", "scene": scene, "np": comm.size, "dofs": dofs, "step_s": best, **glob},
    )
    sim.destroy()


def _operator_loop(op: Any, m: int, x: Any, y: Any) -> None:
    """A_k⁻¹ x for k = 1..m in compiled code (the interface solves of one macro step)."""
    import numba

    from crane_fem.kernels import explicit as kx

    global _OPERATOR_LOOP
    if _OPERATOR_LOOP is None:

        @numba.njit(cache=True)
        def loop(op: Any, m: int, x: Any, y: Any) -> None:
            for k in range(1, m + 1):
                kx.apply_operator(op, float(k), x, y)

        _OPERATOR_LOOP = loop
    _OPERATOR_LOOP(op, m, x, y)


_OPERATOR_LOOP: Any = None


def part_coupled(scene: str, ratio: int, extra: list[str]) -> None:
    """A coupled micro step of ``scene`` at ``ratio``, split into its parts."""
    from mpi4py import MPI

    from crane_fem.kernels import explicit as kx
    from crane_fem.pipeline import create_simulation
    from crane_fem.scenario import load_scenario

    comm = MPI.COMM_WORLD
    sets = ["output.xdmf=false", f"coupling.ratio={ratio}", *extra]
    t0 = time.perf_counter()
    sim = create_simulation(load_scenario(scene, sets), comm)
    setup = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    it = sim.integrators
    E, I, method = it.explicit, it.implicit, it.method  # noqa: E741
    assert E is not None and I is not None
    method.initialize(it.interface_force0)
    m = it.system.m

    def best_of(f: Any, n: int, reps: int = 3) -> float:
        out = np.inf
        for _ in range(reps):
            comm.Barrier()
            t = time.perf_counter()
            for _ in range(n):
                f()
            comm.Barrier()
            out = min(out, (time.perf_counter() - t) / n)
        return out

    state = E.save()
    zone = best_of(lambda: E.advance(E.steps(1e-3, m, mode=kx.NONE)), 1) / m
    E.restore(state)
    op = getattr(method, "op", None)
    x = np.random.default_rng(0).standard_normal(E.n_gamma)
    y = np.zeros_like(x)
    # In compiled code, as the kernel calls it (a call from Python adds ~5 µs of dispatch).
    iface = best_of(lambda: _operator_loop(op, m, x, y), 1) / m if op is not None else 0.0
    rhs = np.random.default_rng(1).standard_normal(I.u.size)
    solve = best_of(lambda: I.solve(rhs), 10)
    method.step()
    macro = best_of(method.step, max(2, 2000 // m), 1)
    micro = macro / m
    rest = micro - zone - iface - 2 * solve / m
    _emit(
        comm,
        {
            "part": "coupled",
            "scene": scene,
            "np": comm.size,
            "m": m,
            "extra": extra,
            "setup_s": setup,
            "micro_s": micro,
            "zone_s": zone,
            "interface_s": iface,
            "implicit_s": 2 * solve / m,
            "solve_s": solve,
            "rest_s": rest,
            "dofs_explicit": comm.allreduce(E.zone.n_own),
            "dofs_implicit": comm.allreduce(I.model.n_owned),
            "interface_dofs": E.n_gamma,
            "operator": None if it.operator_report is None else it.operator_report.__dict__,
        },
    )
    sim.destroy()


# --------------------------------------------------------------------------------------
def _run_part(np_: int, *args: str) -> dict[str, Any]:
    cmd = [str(Path(sys.executable)), __file__, "--part", *args]
    if np_ > 1:
        cmd = [str(BIN / "mpiexec"), "-n", str(np_), *cmd]
    res = subprocess.run(cmd, env=ENV, capture_output=True, text=True, check=False)
    for line in res.stdout.splitlines():
        if line.startswith("RESULT "):
            out: dict[str, Any] = json.loads(line[7:])
            return out
    raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")


def _run_scene(out: Path, scene: Path, np_: int, name: str, sets: list[str]) -> dict[str, Any]:
    """A CLI run; its summary (wall times) and peak memory."""
    d = out / name
    cmd = [str(BIN / "crane-fem"), "run", str(scene), "-o", str(d), "--no-progress"]
    for s in ["output.xdmf=false", *sets]:
        cmd += ["--set", s]
    if np_ > 1:
        cmd = [str(BIN / "mpiexec"), "-n", str(np_), *cmd]
    wrapped = ["/usr/bin/time", "-f", "MAXRSS %M", *cmd]
    res = subprocess.run(wrapped, env=ENV, capture_output=True, text=True, check=False)
    if res.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")
    summary: dict[str, Any] = json.loads((d / "summary.json").read_text())
    rss = [int(x.split()[1]) for x in res.stderr.splitlines() if x.startswith("MAXRSS")]
    summary["peak_memory_mb"] = rss[-1] / 1024.0 if rss else None
    return summary


def _fit_slope(x: list[float], y: list[float]) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--part", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("-o", "--output", default=str(ROOT / "out" / "bench_speed"))
    parser.add_argument("--quick", action="store_true", help="fewer runs, shorter windows")
    parser.add_argument("--skip-sweep", action="store_true")
    parser.add_argument(
        "--tables",
        action="store_true",
        help="print the tables and redraw the figure of the last run",
    )
    args, extra = parser.parse_known_args()
    if args.part:
        import crane_fem  # noqa: F401  (MPI before dolfinx)

        kind, *rest = args.part
        if kind == "stream":
            part_stream(float(rest[0]))
        elif kind == "explicit":
            part_explicit(rest[0], int(rest[1]), [*rest[2:], *extra])
        elif kind == "coupled":
            part_coupled(rest[0], int(rest[1]), [*rest[2:], *extra])
        return 0
    if args.tables:
        res = json.loads((RESULTS / "speed.json").read_text())
        _tables(res)
        _figures(res)
        return 0
    return _report(Path(args.output), args.quick, args.skip_sweep)


def _report(out: Path, quick: bool, skip_sweep: bool) -> int:
    out.mkdir(parents=True, exist_ok=True)
    res: dict[str, Any] = {"command": "python benchmarks/speed.py" + (" --quick" if quick else "")}
    # 1. Stream.
    res["stream"] = [_run_part(n, "stream", "200") for n in (1, 2)]
    res["stream_cache"] = [_run_part(1, "stream", str(mb)) for mb in (4.0, 16.0)]
    bw1 = res["stream"][0]["GBps"]
    bw2 = res["stream"][1]["GBps"]
    print(f"stream triad: {bw1:.1f} GB/s one rank, {bw2:.1f} GB/s two ranks", flush=True)
    # 2. Fully explicit step.
    res["explicit"] = []
    for scene in ("bar1k", str(SCENES["default"]), str(SCENES["stress"])):
        for n in (1, 2):
            steps = 20000 if scene == "bar1k" else 400
            r = _run_part(n, "explicit", scene, str(steps))
            bw = bw1 if n == 1 else bw2
            moved = r["stiffness_bytes"] + r["vector_bytes"]
            r["GBps"] = moved / r["step_s"] / 1e9
            r["roofline_fraction"] = r["GBps"] / bw
            res["explicit"].append(r)
            print(
                f"explicit step {Path(scene).stem} np={n}: {r['step_s'] * 1e6:.1f} µs, "
                f"{moved / 1e6:.2f} MB, {r['GBps']:.1f} GB/s = {r['roofline_fraction']:.2f} "
                "of the stream roofline",
                flush=True,
            )
    # 3. Coupled micro step.
    res["coupled"] = []
    ratios = (100, 200, 1000) if not quick else (200,)
    for m in ratios:
        for n in (1, 2):
            r = _run_part(n, "coupled", str(SCENES["stress"]), str(m))
            res["coupled"].append(r)
            print(
                f"coupled stress m={m} np={n}: micro {r['micro_s'] * 1e6:.1f} µs = zone "
                f"{r['zone_s'] * 1e6:.1f} + interface {r['interface_s'] * 1e6:.1f} + implicit "
                f"{r['implicit_s'] * 1e6:.1f} + rest {r['rest_s'] * 1e6:.1f}",
                flush=True,
            )
    for variant in (
        ["coupling.interface_precision='single'"],
        ["coupling.interface_blocks='zones'"],
    ):
        r = _run_part(1, "coupled", str(SCENES["stress"]), "200", *variant)
        res["coupled"].append(r)
    # 4. The scenes as written, whole, side by side with their fully explicit runs (the
    # headline speed-up), and the stress-grade scene at other ratios: speed and accuracy.
    res["scenes"] = _scenes(out, quick)
    # 5. Wall time per simulated second against m, on a window of each scene.
    res["runs"] = []
    window = {"default": 0.02 if quick else 0.05, "stress": 0.02 if quick else 0.05}
    for scene, path in SCENES.items():
        for n in (1, 2):
            cases = [("explicit", ["coupling.method='monolithic'"])]
            for method in ("gc", "gc-mean"):
                for m in (10, 100, 200, 1000):
                    cases.append(
                        (f"{method}_m{m}", [f"coupling.method='{method}'", f"coupling.ratio={m}"])
                    )
            for name, sets in cases:
                if quick and n == 2 and name != "explicit" and not name.endswith("m100"):
                    continue
                s = _run_scene(
                    out / f"{scene}_np{n}", path, n, name, [f"time.end={window[scene]}", *sets]
                )
                row = {
                    "scene": scene,
                    "np": n,
                    "case": name,
                    "window_s": window[scene],
                    "integration_s": s["wall_time_integration_s"],
                    "setup_s": s["wall_time_setup_s"],
                    "per_simulated_s": s["wall_time_integration_s"] / window[scene],
                    "peak_memory_mb": s["peak_memory_mb"],
                    "dofs_explicit": s["dofs_explicit"],
                    "dofs_implicit": s["dofs_implicit"],
                }
                res["runs"].append(row)
                print(
                    f"run {scene} np={n} {name}: {row['per_simulated_s']:.1f} s per simulated s",
                    flush=True,
                )
    # 6. Mesh sweep.
    if not skip_sweep:
        res["sweep"] = _sweep(out, quick)
    (RESULTS / "speed.json").write_text(json.dumps(res, indent=1))
    _tables(res)
    _figures(res)
    return 0


def _scenes(out: Path, quick: bool) -> list[dict[str, Any]]:
    """The default and stress-grade scenes as written (whole runs), each beside its fully
    explicit run, np = 1 and 2; on the stress-grade scene also GC at other ratios (np = 1).
    Speed (``wall_time_integration_s``) and accuracy (crane_fem.compare: the pair displacement
    up to the first landing, over the whole run, lift-offs, interface energy) from the same
    runs."""
    from crane_fem.compare import compare_runs, first_landing, pair_l2
    from crane_fem.plotting import load_runs

    rows: list[dict[str, Any]] = []
    ratios = {"default": [None], "stress": [None, 100, 500, 1000]}
    for scene, path in SCENES.items():
        for n in (1, 2):
            d = out / f"scene_{scene}_np{n}"
            exp = _run_scene(d, path, n, "explicit", ["coupling.method='monolithic'"])
            for m in ratios[scene] if n == 1 and not quick else [None]:
                name = "as_written" if m is None else f"gc_m{m}"
                sets = [] if m is None else [f"coupling.ratio={m}"]
                het = _run_scene(d, path, n, name, sets)
                a, e = load_runs(d / name)[0], load_runs(d / "explicit")[0]
                landing = first_landing(e)
                to_landing = pair_l2(a, e, landing)
                whole = pair_l2(a, e)
                cmp = compare_runs(a, e)
                row = {
                    "scene": scene,
                    "np": n,
                    "case": name,
                    "m": het["ratio"],
                    "end_s": het["steps_done"] * het["dT"],
                    "explicit_integration_s": exp["wall_time_integration_s"],
                    "integration_s": het["wall_time_integration_s"],
                    "speedup": exp["wall_time_integration_s"] / het["wall_time_integration_s"],
                    "setup_s": het["wall_time_setup_s"],
                    "explicit_setup_s": exp["wall_time_setup_s"],
                    "first_landing_s": landing,
                    "pair_l2_to_landing": {k: list(v) for k, v in to_landing.items()},
                    "pair_l2_whole": {k: list(v) for k, v in whole.items()},
                    "lift_offs": next(
                        (len(w["lift_offs_heterogeneous"]), len(w["lift_offs_explicit"]))
                        for w in cmp["wheels"].values()
                    ),
                    "interface_energy_over_work": cmp["interface_dissipated_over_external_work"],
                    "peak_memory_mb": het["peak_memory_mb"],
                    "explicit_peak_memory_mb": exp["peak_memory_mb"],
                    "dofs_explicit": het["dofs_explicit"],
                    "dofs_implicit": het["dofs_implicit"],
                }
                rows.append(row)
                worst = max(max(v) for v in to_landing.values())
                print(
                    f"scene {scene} np={n} {name} (m = {row['m']}): {row['speedup']:.2f}× the "
                    f"fully explicit run, pair L2 to the first landing {100 * worst:.2f} %",
                    flush=True,
                )
    return rows


def _sweep(out: Path, quick: bool) -> list[dict[str, Any]]:
    sizes = [0.12, 0.06, 0.04, 0.03, 0.02] if not quick else [0.12, 0.04]
    rows = []
    for size in sizes:
        fine = min(0.04, size)
        mesh = out / "meshes" / f"crane_{size:g}.msh"
        sets = [f"model.size={size!r}", f"model.fine={fine!r}"]
        if not mesh.is_file():
            mesh.parent.mkdir(parents=True, exist_ok=True)
            cmd = [str(BIN / "crane-fem"), "mesh", str(SCENES["default"]), "-o", str(mesh)]
            for s in sets:
                cmd += ["--set", s]
            subprocess.run(cmd, env=ENV, check=True, capture_output=True)
        over = [f"model.mesh='{mesh.as_posix()}'", *sets]
        e = _run_part(1, "explicit", str(SCENES["default"]), "100", *over)
        c = _run_part(1, "coupled", str(SCENES["default"]), "100", *over)
        row = {
            "size": size,
            "dofs": e["dofs"],
            "explicit_step_s": e["step_s"],
            **{
                k: c[k]
                for k in (
                    "micro_s",
                    "zone_s",
                    "interface_s",
                    "implicit_s",
                    "solve_s",
                    "rest_s",
                    "dofs_explicit",
                    "dofs_implicit",
                    "interface_dofs",
                )
            },
        }
        rows.append(row)
        print(
            f"sweep size {size}: {row['dofs']} DOFs, explicit {row['explicit_step_s'] * 1e6:.0f}"
            f" µs, coupled micro {row['micro_s'] * 1e6:.0f} µs "
            f"(solve {row['solve_s'] * 1e3:.1f} ms)",
            flush=True,
        )
    return rows


def _md(*cells: object) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _tables(res: dict[str, Any]) -> None:
    """The Markdown tables of benchmarks/RESULTS.md (printed)."""
    us = 1e6
    print(f"\nCommand: `{res['command']}`\n")
    s1, s2 = res["stream"]
    cache = " / ".join(f"{r['GBps']:.1f}" for r in res["stream_cache"])
    print(
        f"Stream triad (three arrays of 200 MB, 24 B per entry): {s1['GBps']:.1f} GB/s on one "
        f"rank, {s2['GBps']:.1f} GB/s on two; at 4 / 16 MB (in cache): {cache} GB/s.\n"
    )
    print(_md("fully explicit step", "np", "DOFs", "µs", "MB read+written", "GB/s", "of stream"))
    print(_md(*["---"] * 7))
    for r in res["explicit"]:
        mb = (r["stiffness_bytes"] + r["vector_bytes"]) / 1e6
        name = Path(r["scene"]).stem
        print(
            _md(
                name,
                r["np"],
                r["dofs"],
                f"{r['step_s'] * us:.1f}",
                f"{mb:.2f}",
                f"{r['GBps']:.1f}",
                f"{r['roofline_fraction']:.2f}",
            )
        )
    print()
    head = ("coupled micro step, stress scene", "np", "m", "µs", "zone", "interface")
    print(_md(*head, "implicit (2 solves / m)", "rest", "solve ms", "explicit / micro"))
    print(_md(*["---"] * 10))
    exp = {(Path(r["scene"]).stem, r["np"]): r["step_s"] for r in res["explicit"]}
    for r in res["coupled"]:
        ratio = exp.get(("crane_stress", r["np"]), np.nan) / r["micro_s"]
        label = "scene as written" if not r["extra"] else ", ".join(r["extra"])
        print(
            _md(
                label,
                r["np"],
                r["m"],
                f"{r['micro_s'] * us:.1f}",
                f"{r['zone_s'] * us:.1f}",
                f"{r['interface_s'] * us:.1f}",
                f"{r['implicit_s'] * us:.1f}",
                f"{r['rest_s'] * us:.1f}",
                f"{r['solve_s'] * 1e3:.2f}",
                f"{ratio:.2f}",
            )
        )
    print()
    head = ("scene (whole run)", "np", "run", "m", "time loop s", "explicit s", "speed-up")
    print(_md(*head, "pair L2 to 1st landing, wheel / rail", "whole run", "lift-offs", "E_Γ/W"))
    print(_md(*["---"] * 11))
    for r in res.get("scenes", []):
        to = r["pair_l2_to_landing"].values()
        wh = r["pair_l2_whole"].values()
        print(
            _md(
                r["scene"],
                r["np"],
                r["case"],
                r["m"],
                f"{r['integration_s']:.1f}",
                f"{r['explicit_integration_s']:.1f}",
                f"{r['speedup']:.2f}",
                f"{100 * max(v[0] for v in to):.2f} / {100 * max(v[1] for v in to):.2f} %",
                f"{100 * max(v[0] for v in wh):.1f} / {100 * max(v[1] for v in wh):.1f} %",
                f"{r['lift_offs'][0]} / {r['lift_offs'][1]}",
                f"{100 * r['interface_energy_over_work']:.1f} %",
            )
        )
    print()
    print(
        _md("scene", "np", "run", "wall s per simulated s", "explicit / run", "set-up s", "peak MB")
    )
    print(_md(*["---"] * 7))
    base = {
        (r["scene"], r["np"]): r["per_simulated_s"] for r in res["runs"] if r["case"] == "explicit"
    }
    for r in res["runs"]:
        sp = base[(r["scene"], r["np"])] / r["per_simulated_s"]
        print(
            _md(
                r["scene"],
                r["np"],
                r["case"],
                f"{r['per_simulated_s']:.1f}",
                f"{sp:.2f}",
                f"{r['setup_s']:.1f}",
                f"{r['peak_memory_mb']:.0f}",
            )
        )
    if "sweep" in res:
        sw = res["sweep"]
        d = [r["dofs"] for r in sw]
        print()
        print(_md("size m", "DOFs", "explicit step µs", "coupled micro µs", "solve ms", "ratio"))
        print(_md(*["---"] * 6))
        for r in sw:
            print(
                _md(
                    r["size"],
                    r["dofs"],
                    f"{r['explicit_step_s'] * us:.0f}",
                    f"{r['micro_s'] * us:.0f}",
                    f"{r['solve_s'] * 1e3:.1f}",
                    f"{r['explicit_step_s'] / r['micro_s']:.2f}",
                )
            )
        slopes = {
            k: _fit_slope(d, [r[k] for r in sw]) for k in ("explicit_step_s", "micro_s", "solve_s")
        }
        print(
            f"\nFitted slopes (log-log against DOFs): explicit step "
            f"{slopes['explicit_step_s']:.2f}, coupled micro step {slopes['micro_s']:.2f}, "
            f"implicit solve {slopes['solve_s']:.2f}."
        )


def _figures(res: dict[str, Any]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    ax = axes[0]
    for scene, mk in (("default", "o"), ("stress", "s")):
        for n, ls in ((1, "-"), (2, "--")):
            for method in ("gc", "gc-mean"):
                rows = [
                    r
                    for r in res["runs"]
                    if r["scene"] == scene and r["np"] == n and r["case"].startswith(method + "_")
                ]
                if not rows:
                    continue
                ms = [int(r["case"].split("_m")[1]) for r in rows]
                ax.plot(
                    ms,
                    [r["per_simulated_s"] for r in rows],
                    ls,
                    marker=mk,
                    label=f"{scene} {method} np={n}",
                )
            e = [
                r["per_simulated_s"]
                for r in res["runs"]
                if r["scene"] == scene and r["np"] == n and r["case"] == "explicit"
            ]
            if e:
                ax.axhline(e[0], ls=ls, color="k", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ratio m")
    ax.set_ylabel("wall s per simulated s (time loop)")
    ax.set_title("coupled runs; black: fully explicit")
    ax.legend(fontsize=6)
    ax = axes[2]
    st = [r for r in res.get("scenes", []) if r["scene"] == "stress" and r["np"] == 1]
    if st:
        for side, mk in ((0, "o"), (1, "s")):
            ax.plot(
                [r["speedup"] for r in st],
                [100 * max(v[side] for v in r["pair_l2_to_landing"].values()) for r in st],
                mk,
                label=("wheel" if side == 0 else "rail") + " side",
            )
        for r in st:
            ax.annotate(
                f"m = {r['m']}",
                (r["speedup"], 100 * max(v[1] for v in r["pair_l2_to_landing"].values())),
                fontsize=7,
            )
        ax.axhline(2.0, color="k", lw=0.8, ls=":")
        ax.axvline(3.0, color="k", lw=0.8, ls=":")
        ax.set_xlabel("speed-up over the fully explicit run (time loop)")
        ax.set_ylabel("pair L2 to the first landing, %")
        ax.set_title("stress-grade scene, GC: accuracy against speed")
        ax.legend(fontsize=7)
    ax = axes[1]
    if "sweep" in res:
        sw = res["sweep"]
        d = [r["dofs"] for r in sw]
        ax.loglog(d, [r["explicit_step_s"] * 1e6 for r in sw], "o-", label="explicit step")
        ax.loglog(d, [r["micro_s"] * 1e6 for r in sw], "s-", label="coupled micro step (m = 100)")
        ax.loglog(d, [r["implicit_s"] * 1e6 for r in sw], "^--", label="implicit part of it")
        ax.set_xlabel("DOFs")
        ax.set_ylabel("µs")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(RESULTS / "speed.png", dpi=120)


if __name__ == "__main__":
    sys.exit(main())
