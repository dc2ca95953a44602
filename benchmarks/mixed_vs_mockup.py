"""The mixed crane (beams + solid wheel zones, demos/frame_crane_solid.toml, coupled) against
the all-solid mock-up (demos/crane.toml) fully explicit with its conditioning ensemble: every
quantity of THEORY.md §8 (b) side by side (issue 33's acceptance table).

    .venv/bin/python benchmarks/mixed_vs_mockup.py [--out DIR] [--report FILE]
        [--size S] [--set KEY=VALUE ...] [--mixed-set KEY=VALUE ...]
        [--mockup-set KEY=VALUE ...] [--reuse]

Runs (subprocesses, OMP_NUM_THREADS=1):

* ``crane-fem mesh demos/crane.toml --set model.size=S`` (default 0.04 m: the committed mesh
  locks in bending, its frequencies 1.22–1.65× the converged solid's,
  benchmarks/out/mockup_convergence.md; at 0.04 m the first flight and the peak force have
  converged to ≤ 1.5 %);
* the mock-up fully explicit on that mesh (the reference, alone), then its ensemble
  (record × 0.995, × 1.005, Δt × ½: ``crane_fem.study.run_ensemble_members``, the study's and
  ``crane-fem bench ensemble``'s, two at a time on a local dask cluster);
* the mixed crane as its scene runs it (gc-mean, the beams Newmark, the solid zones
  CD-Lagrange) and the frame crane fully explicit (demos/frame_crane.toml, for what the solid
  zones add).

``--set KEY=VALUE`` makes a variant of both scenes (a key they share, e.g.
``model.trolley_position=1.5``: the mock-up re-meshed there); ``--mockup-set`` changes the
mock-up only (its mesh and runs, e.g. ``model.trolley_size``), ``--mixed-set`` the mixed
crane only (its run in DIR/mixed_<keys>). Give a variant its own ``--out`` and ``--report``.

The table judges each quantity by THEORY.md §8 (b): |run − reference| against max(its
tolerance, the ensemble's spread) (``crane_fem.tolerances``: ``judge_runs``,
``with_spread``). Quantities one model has and the other has not (the beams' stress by
group, the floor spectra at different points) are not judged; the bridge's peak von Mises
is, from the beam models' groups (:func:`_bridge_stress`). ``--reuse`` reads the runs
already in DIR.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
EXE = Path(sys.executable).parent / "crane-fem"
SOLID = ROOT / "demos" / "crane.toml"
MIXED = ROOT / "demos" / "frame_crane_solid.toml"
FRAME = ROOT / "demos" / "frame_crane.toml"
ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")


def _call(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=ENV)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return time.perf_counter() - t0


def _run(scene: Path, d: Path, settings: dict[str, Any], reuse: bool) -> dict[str, Any]:
    """The run's summary (its process's wall time under ``_process_s``)."""
    from crane_fem.study.cases import cli_arguments

    if not (reuse and (d / "summary.json").exists()):
        cmd = [str(EXE), "run", str(scene), "-o", str(d), "--no-progress"]
        elapsed = _call([*cmd, *cli_arguments(settings)])
        (d / "process.json").write_text(json.dumps({"elapsed_s": elapsed}))
    s = json.loads((d / "summary.json").read_text())
    s["_process_s"] = json.loads((d / "process.json").read_text())["elapsed_s"]
    return s


def _assignments(items: list[str]) -> dict[str, Any]:
    """``KEY=VALUE`` arguments as settings, each value a TOML value."""
    return {k: tomllib.loads(f"v = {v}")["v"] for k, v in (kv.split("=", 1) for kv in items)}


def _ensemble(
    scene: Path, settings: dict[str, Any], ref: dict[str, Any], d: Path, reuse: bool
) -> dict[str, dict[str, Any]]:
    """The summaries of the reference run's conditioning ensemble (record × 0.995, × 1.005,
    Δt × ½: ``crane_fem.study.run_ensemble_members``, two at a time on a local dask cluster,
    sampled at the reference's instants) in ``d``, by member; ``reuse``: those already
    there."""
    from crane_fem.study import run_ensemble_members

    names = ("x0.995", "x1.005", "dt0.5")
    if reuse and all((d / m / "summary.json").exists() for m in names):
        return {m: json.loads((d / m / "summary.json").read_text()) for m in names}
    t0 = time.perf_counter()
    done = run_ensemble_members(scene, settings, float(ref["sampling_interval_s"]), d)
    members = {}
    for label, md, result in done:
        if result.status != "completed":
            raise SystemExit(f"ensemble member {label}: {result.status} {result.error}")
        members[md.name] = json.loads((md / "summary.json").read_text())
    (d / "process.json").write_text(json.dumps({"elapsed_s": time.perf_counter() - t0}))
    return members


def _fmt(value: float, unit: str) -> str:
    if unit == "N":
        return f"{value / 1e3:.4g} kN"
    if unit == "m":
        return f"{value * 1e3:.4g} mm"
    if unit == "s":
        return f"{value * 1e3:.4g} ms"
    if unit == "Pa":
        return f"{value / 1e6:.4g} MPa"
    return f"{value:.4g} {unit}"


#: The beam models' groups that make the mock-up's bridge (girders, rails, end carriages):
#: the girders' beams, the segments under the wheels (solid zones in the mixed crane, beam
#: zones in the frame) and the end carriages; the trolley, its wheels and stubs, the hook and
#: the rope links are not the bridge.
BRIDGE = ("girder_", "zone_", "end_carriage_")


def _bridge_stress(run: dict[str, Any]) -> None:
    """Give a beam model's summary the mock-up's bridge stress keys from its groups' peaks:
    the bridge's (max over :data:`BRIDGE`'s groups) and each of the mock-up's parts': end
    carriage k its ``end_carriage_k``, girder k and rail k (the beams' girder section holds
    its rail) the max over ``girder_k`` and the zones on girder k (the mixed crane's one zone
    a girder, the frame's one a wheel, wheels 1–2 on girder 1). A beam's is its extreme
    fibres' von Mises, a solid's its largest cell value: the same sign-off quantity, not the
    same estimate."""
    groups = {k: v["peak_Pa"] for k, v in run.get("peak_von_mises_by_group", {}).items()}
    bridge = [v for k, v in groups.items() if k.startswith(BRIDGE)]
    if not bridge:
        return
    zones = sorted((k for k in groups if k.startswith("zone_")), key=lambda k: int(k[5:]))
    per = max(1, len(zones) // 2)
    parts = {}
    for k in (1, 2):
        on_girder = [groups[z] for z in zones[(k - 1) * per : k * per]]
        girder = max([groups.get(f"girder_{k}", 0.0), *on_girder])
        parts |= {f"girder {k}": girder, f"rail {k}": girder}
        parts[f"end carriage {k}"] = groups.get(f"end_carriage_{k}", 0.0)
    run["peak_bridge_von_mises_Pa"] = max(bridge)
    run["peak_bridge_von_mises_by_part_Pa"] = parts


def main() -> None:
    import crane_fem  # noqa: F401  (MPI before the study's modules)
    from crane_fem.bench.common import explicit_settings
    from crane_fem.tolerances import (
        CUT_BY_THE_WINDOW,
        judge_runs,
        signoff_quantities,
        with_spread,
    )

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "mixed_vs_mockup")
    ap.add_argument(
        "--report", type=Path, default=ROOT / "benchmarks" / "out" / "mixed_vs_mockup.md"
    )
    ap.add_argument("--size", default="0.04")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a variant: a key of both scenes (e.g. model.trolley_position=1.5), repeatable",
    )
    ap.add_argument(
        "--mixed-set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a key of the mixed crane's only (e.g. model.trolley_body='\"solid\"'): its run "
        "in DIR/mixed_<keys>, the mock-up's reused with --reuse, repeatable",
    )
    ap.add_argument(
        "--mockup-set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a key of the mock-up's only (e.g. model.trolley_size=0.0125: its mesh and runs; "
        "give the variant its own --out), repeatable",
    )
    args = ap.parse_args()
    out: Path = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started = time.strftime("%Y-%m-%d %H:%M:%S")

    mesh = out / f"crane_{args.size}.msh"
    if not (args.reuse and mesh.exists()):
        sets = [a for kv in [*args.set, *args.mockup_set] for a in ("--set", kv)]
        cmd = [str(EXE), "mesh", str(SOLID), "--set", f"model.size={args.size}", *sets]
        _call([*cmd, "-o", str(mesh)])
    variant = _assignments(args.set)
    mockup_own = _assignments(args.mockup_set)
    base = {"model.mesh": str(mesh), "model.size": float(args.size), **variant, **mockup_own}
    ref_settings = explicit_settings(SOLID, base=base)
    ref = _run(SOLID, out / "mockup", ref_settings, args.reuse)
    members = _ensemble(SOLID, ref_settings, ref, out / "ensemble", args.reuse)
    own = _assignments(args.mixed_set)
    mixed_dir = out / "_".join(["mixed", *(f"{k}={v}" for k, v in own.items())])
    mixed = _run(MIXED, mixed_dir, {"output.xdmf": False, **variant, **own}, args.reuse)
    frame = _run(
        FRAME,
        out / "frame",
        {"coupling.method": "monolithic", "output.xdmf": False, **variant},
        args.reuse,
    )

    for run in (mixed, frame):
        _bridge_stress(run)
    member_checks = [judge_runs(m, ref) for m in members.values()]
    rows = []
    has: dict[str, set[tuple[str, str]]] = {}
    for label, run in (("mixed", mixed), ("frame", frame)):
        checks = with_spread(judge_runs(run, ref), member_checks)
        rows.append((label, {(c.quantity, c.where): c for c in checks}))
        # (judge_runs counts a quantity the run lacks as zero: e.g. the wheels' slip along and
        # across in a frame crane's run from before its contacts gave them)
        has[label] = {(q.quantity, q.where) for q in signoff_quantities(run)}
        if "peak_bridge_von_mises_by_part_Pa" in run:  # (judge_runs' own check of the part)
            part = str(ref.get("peak_bridge_von_mises_part"))
            has[label].add(("bridge peak von Mises in the reference's part", part))
    ref_keys = [(c.quantity, c.where) for c in member_checks[0]]

    lines = [
        "# The mixed crane against the all-solid mock-up: THEORY.md §8 (b), side by side",
        "",
        "Command: `.venv/bin/python benchmarks/mixed_vs_mockup.py`"
        + (f" --size {args.size}" if args.size != "0.04" else "")
        + "".join(f" --set {kv}" for kv in args.set)
        + "".join(f" --mixed-set {kv}" for kv in args.mixed_set)
        + "".join(f" --mockup-set {kv}" for kv in args.mockup_set)
        + (
            f" --out {args.out} --report {args.report}"
            if args.set or args.mixed_set or args.mockup_set
            else ""
        ),
        "",
        f"Started {started}"
        + (" (--reuse: the runs of an earlier start)" if args.reuse else "")
        + "; serial processes, OMP_NUM_THREADS=1 (the ensemble two at a time). Reference: "
        f"`demos/crane.toml` fully explicit on a uniform {args.size} m P1 mesh "
        + ("" if not mockup_own else "(" + ", ".join(args.mockup_set) + ") ")
        + f"({ref['dofs_explicit'] + ref['dofs_implicit']} DOFs, {ref['_process_s']:.0f} s), its "
        "ensemble record × 0.995, × 1.005 and Δt × ½. Runs: `demos/frame_crane_solid.toml` "
        + ("as committed" if not own else "with " + ", ".join(args.mixed_set))
        + f" (gc-mean m = 20, {mixed['_process_s']:.0f} s) and `demos/frame_crane.toml` "
        f"fully explicit ({frame['_process_s']:.0f} s). The vertical record, "
        f"{ref['time_end_s']:g} s.",
        "",
        "A quantity passes when |run − mock-up| ≤ max(tolerance, spread); ratio = |run − "
        "mock-up| / that bound; **bold**: beyond it. Spread: the largest |member − mock-up| of the "
        "ensemble (beyond-conditioning quantities: spread > tolerance). ↑: a max uplift that is "
        "a flight still rising at the window's end, in that run or the mock-up (a lower bound of "
        'its apex; `max_uplift_at_end`). "not given": a quantity the run\'s summary lacks '
        "(runs from before the frame cranes gave their wheels' slip along and across the "
        "rails): not judged.",
        "",
        "| quantity | where | mock-up | spread | tolerance | mixed | ratio | frame | ratio |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    counts = {label: [0, 0] for label, _ in rows}
    beyond = 0
    for key in ref_keys:
        c0 = rows[0][1].get(key)
        if c0 is None:
            continue
        if c0.beyond_conditioning:
            beyond += 1
        cells = []
        for label, by in rows:
            c = by[key]
            if key not in has[label]:
                cells += ["not given", "—"]
                continue
            if c.reference == 0.0 and c.value == 0.0:
                cells += ["0", "—"]
                continue
            counts[label][0] += 1
            ok = c.ok
            counts[label][1] += 0 if ok else 1
            r = f"{c.ratio:.2f}"
            mark = " ↑" if c.note.startswith(CUT_BY_THE_WINDOW) else ""
            cells += [_fmt(c.value, c.unit) + mark, r if ok else f"**{r}**"]
        lines.append(
            f"| {c0.quantity} | {c0.where} | {_fmt(c0.reference, c0.unit)} | "
            f"{_fmt(c0.spread, c0.unit)} | {_fmt(c0.tolerance, c0.unit)} | "
            + " | ".join(cells)
            + " |"
        )
    lines += [""]
    for label, (n, bad) in counts.items():
        lines.append(f"- {label}: {n - bad} of {n} quantities within max(tolerance, spread).")
    lines.append(f"- Beyond the mock-up's conditioning (spread > tolerance): {beyond}.")
    (args.report).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
