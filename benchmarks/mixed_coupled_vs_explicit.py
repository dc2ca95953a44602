"""The mixed crane coupled (its solids CD-Lagrange, its beams Newmark, gc-mean) against its
own fully explicit run (``coupling.method = "monolithic"``: the beams under the central
difference at the solids' step, through the joints every step) with that run's conditioning
ensemble: every quantity of THEORY.md §8 (b) and the wall times side by side (issue 33:
"the coupled run faster than the mixed model's fully explicit run, meeting (b) against it").

    .venv/bin/python benchmarks/mixed_coupled_vs_explicit.py [--scene TOML] [--out DIR]
        [--report FILE] [--set KEY=VALUE ...] [--reuse]

Runs (subprocesses, OMP_NUM_THREADS=1): the fully explicit reference alone, its ensemble
(record × 0.995, × 1.005, Δt × ½: ``crane_fem.study.run_ensemble_members``, two at a time on
a local dask cluster), the coupled run as the scene runs it alone. ``--set`` makes a
variant (give it its own ``--out`` and ``--report``). ``--reuse`` reads the runs already in
DIR. Judged as ``crane-fem bench ensemble`` judges (``crane_fem.tolerances``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mixed_vs_mockup import _assignments, _ensemble, _fmt, _run

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "demos" / "frame_crane_solid.toml"


def _rel(path: Path) -> str:
    """``path`` as given on the command line from the repository's root."""
    p = path.resolve()
    return str(p.relative_to(ROOT)) if p.is_relative_to(ROOT) else str(path)


def main() -> None:
    import crane_fem  # noqa: F401  (MPI before the study's modules)
    from crane_fem.bench.common import explicit_settings
    from crane_fem.tolerances import judge_runs, with_spread

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, default=SCENE)
    ap.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks" / "out" / "mixed_coupled_vs_explicit"
    )
    ap.add_argument(
        "--report", type=Path, default=ROOT / "benchmarks" / "out" / "mixed_coupled_vs_explicit.md"
    )
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument(
        "--coupled",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a setting of the coupled run only (its own directory), e.g. coupling.fine_ratio=4",
    )
    args = ap.parse_args()
    out: Path = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    scene: Path = args.scene.resolve()
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    variant, own = _assignments(args.set), _assignments(args.coupled)
    name = "coupled" + "".join(f"_{k.split('.')[-1]}{v}" for k, v in own.items())

    ref_settings = explicit_settings(scene, base=variant)
    ref = _run(scene, out / "explicit", ref_settings, args.reuse)
    members = _ensemble(scene, ref_settings, ref, out / "ensemble", args.reuse)
    coupled = _run(scene, out / name, {"output.xdmf": False, **variant, **own}, args.reuse)

    member_checks = [judge_runs(m, ref) for m in members.values()]
    checks = with_spread(judge_runs(coupled, ref), member_checks)
    n = bad = beyond = 0
    rows = []
    for c in checks:
        if c.reference == 0.0 and c.value == 0.0:
            continue
        n += 1
        bad += 0 if c.ok else 1
        beyond += 1 if c.beyond_conditioning else 0
        r = f"{c.ratio:.2f}"
        rows.append(
            f"| {c.quantity} | {c.where} | {_fmt(c.reference, c.unit)} | "
            f"{_fmt(c.spread, c.unit)} | {_fmt(c.tolerance, c.unit)} | "
            f"{_fmt(c.value, c.unit)} | {r if c.ok else f'**{r}**'} |"
        )
    t_ref, t_cpl = ref["_process_s"], coupled["_process_s"]
    loop_ref, loop_cpl = ref["wall_time_integration_s"], coupled["wall_time_integration_s"]
    command = "`.venv/bin/python benchmarks/mixed_coupled_vs_explicit.py`" + "".join(
        ([f" --scene {_rel(args.scene)}"] if scene != SCENE else [])
        + [f" --set {kv}" for kv in args.set]
        + [f" --coupled {kv}" for kv in args.coupled]
    )
    lines = [
        f"# {scene.name}: coupled against its own fully explicit run, THEORY.md §8 (b)",
        "",
        f"Command: {command}"
        + (
            f" --out {_rel(args.out)} --report {_rel(args.report)}"
            if args.set or args.coupled
            else ""
        ),
        "",
        f"Started {started}"
        + (" (--reuse: the runs of an earlier start)" if args.reuse else "")
        + "; serial processes, OMP_NUM_THREADS=1 (the ensemble two at a time).",
        "",
        "| run | method | micro steps | time loop (s) | whole process (s) |",
        "|---|---|---|---|---|",
        f"| fully explicit (reference) | {ref['method']} | {ref['micro_steps']} | "
        f"{loop_ref:.1f} | {t_ref:.1f} |",
        f"| coupled{''.join(f', {k} = {v}' for k, v in own.items())} | "
        f"{coupled['method']}, m = {coupled['ratio']} | {coupled['micro_steps']} | "
        f"{loop_cpl:.1f} | {t_cpl:.1f} |",
        "",
        f"Coupled / fully explicit: time loop {loop_cpl / loop_ref:.3f}, whole process "
        f"{t_cpl / t_ref:.3f}.",
        "",
        "A quantity passes when |coupled − explicit| ≤ max(tolerance, spread); ratio = that "
        "difference / the bound; **bold**: beyond it. Spread: the largest |member − explicit| "
        "of the ensemble.",
        "",
        "| quantity | where | explicit | spread | tolerance | coupled | ratio |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"- coupled: {n - bad} of {n} quantities within max(tolerance, spread).",
        f"- Beyond the explicit run's conditioning (spread > tolerance): {beyond}.",
    ]
    args.report.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
