"""The frame crane (Timoshenko beams, demos/frame_crane.toml) against the 3D solid mock-up it
models (demos/crane.toml), on the same vertical record, both fully explicit.

    .venv/bin/python benchmarks/frame_vs_mockup.py [--out DIR] [--report FILE]
        [--stub-widths W,W,...] [--reuse]

Runs (each a subprocess with OMP_NUM_THREADS=1, one after the other):

* ``crane-fem run SCENE -o DIR/<frame|solid> --set coupling.method="monolithic" --set
  output.xdmf=false`` on both scenes;
* ``crane-fem modes SCENE --n 6 --out DIR/<frame|solid>_modes`` on both (the contacts closed);
* the frame again with a softer wheel stub (``model.wheel_width``, the stub's only section
  key: its area, hence its axial stiffness E A / L, scales with it) for each width of
  ``--stub-widths`` (none: ``--stub-widths ""``).

``--reuse`` reads DIR/*/summary.json and DIR/*_modes/modes.json where they exist instead of
running again. The report (markdown, printed and written to FILE, default
benchmarks/out/frame_vs_mockup.md) has five parts: the static preload per wheel against the
carried weight; the first six natural frequencies; the vertical record per wheel (wheel 1 and
the spread max − min over the four), the supports, the peak von Mises stress by part and the
cost; and what the frame misses at the wheel/rail contact, measured: the static settlement of
the wheel's contact point at t = 0 (history.csv) in both models, the equivalent local
stiffness (W/4) / (δ_3D − δ_frame) when that difference is positive, the first landing's
ratios, and the frame's sensitivity to its wheel stub's stiffness. Only numbers read from the
runs' outputs (or the scene's geometry keys) are reported; what an output does not give is
marked "—".
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
EXE = ROOT / ".venv" / "bin" / "crane-fem"
FRAME = ROOT / "demos" / "frame_crane.toml"
SOLID = ROOT / "demos" / "crane.toml"

EXPLICIT = ['coupling.method="monolithic"', "output.xdmf=false"]
WHEELS = ("1", "2", "3", "4")
ENV = dict(os.environ, OMP_NUM_THREADS="1")
NA = "—"
REUSED = " (--reuse: the runs' times are those of the runs reused)"


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _call(cmd: list[str]) -> tuple[float, float]:
    """Run ``cmd``; its elapsed and CPU seconds."""
    t0, c0 = time.perf_counter(), _children_cpu()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=ENV)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return time.perf_counter() - t0, _children_cpu() - c0


def run(scene: Path, out: Path, sets: list[str], reuse: bool) -> dict[str, Any]:
    """One fully explicit run of the scene: its summary (with the process's elapsed and CPU
    seconds) and its history's first row (t = 0, the preloaded state)."""
    summary = out / "summary.json"
    if not (reuse and summary.exists()):
        cmd = [str(EXE), "run", str(scene), "-o", str(out)]
        for s in EXPLICIT + sets:
            cmd += ["--set", s]
        elapsed, cpu = _call(cmd)
        data = json.loads(summary.read_text())
        data["_process_s"], data["_cpu_s"] = elapsed, cpu
        summary.write_text(json.dumps(data, indent=1))
    data = json.loads(summary.read_text())
    with (out / "history.csv").open() as f:
        first = next(csv.DictReader(f))
    data["_t0"] = {k: float(v) for k, v in first.items() if v != ""}
    return data


def modes(scene: Path, out: Path, n: int, reuse: bool) -> dict[str, Any]:
    """``crane-fem modes`` of the scene: its modes.json (with the process's seconds)."""
    path = out / "modes.json"
    if not (reuse and path.exists()):
        elapsed, cpu = _call([str(EXE), "modes", str(scene), "--n", str(n), "--out", str(out)])
        (out / "process.json").write_text(json.dumps({"elapsed_s": elapsed, "cpu_s": cpu}))
    data = json.loads(path.read_text())
    proc = out / "process.json"
    data["_process"] = json.loads(proc.read_text()) if proc.exists() else {}
    return data


def stub_stiffness(scene: Path, width: float | None = None) -> tuple[float, float]:
    """The frame's wheel stub: (axial stiffness E A / L in N/m, length L in m), from the
    scene's geometry keys (``model.wheel_width`` replaced by ``width`` if given)."""
    from crane_fem.geometry.frame_crane import frame_crane_layout
    from crane_fem.scenario.frame_crane import FrameCraneModel

    data = tomllib.loads(scene.read_text())
    keys = dict(data["model"])
    if width is not None:
        keys["wheel_width"] = width
    m = FrameCraneModel(**keys)
    layout = frame_crane_layout(m)
    length = layout.trolley_level - layout.rail_top
    area = m.wheel_length * m.wheel_width
    return float(data["material"]["E"]) * area / length, length


# ---------------------------------------------------------------------------- formatting


def _f(x: float | None, fmt: str = ".4g") -> str:
    return NA if x is None else format(x, fmt)


def _spread(values: list[float], fmt: str) -> str:
    if not values:
        return NA
    return format(max(values) - min(values), fmt)


def _ratio(a: float | None, b: float | None) -> str:
    return NA if a is None or b is None or b == 0.0 else f"{a / b:.3f}"


def _table(head: list[str], rows: list[list[str]]) -> list[str]:
    return [
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
        *("| " + " | ".join(r) + " |" for r in rows),
    ]


# ---------------------------------------------------------------------------- quantities


def wheel_forces(s: dict[str, Any]) -> tuple[list[float], float, str]:
    """Static wheel forces (N, wheels 1–4), the carried weight (N) and its key, on a frame's
    summary (preload.contact_forces_N, carried_weight_N) or the mock-up's
    (preload.wheel_forces_N, trolley_weight_N)."""
    pre = s["preload"]
    if "contact_forces_N" in pre:
        forces = [pre["contact_forces_N"][f"wheel_{k}"] for k in WHEELS]
        return forces, pre["carried_weight_N"], "carried_weight_N"
    return list(pre["wheel_forces_N"]), pre["trolley_weight_N"], "trolley_weight_N"


def wheel_quantities(s: dict[str, Any]) -> dict[str, list[float]]:
    """Per quantity, its values over the four wheels (in the report's units)."""
    out: dict[str, list[float]] = {}

    def put(key: str, value: float | None) -> None:
        if value is not None:
            out.setdefault(key, []).append(value)

    for k in WHEELS:
        w = s["wheels"][k]
        lifts = w["lift_offs"]["intervals"]
        imp = w["impacts"][0] if w["impacts"] else None
        put("first lift-off (ms)", 1e3 * lifts[0][0] if lifts else None)
        put("first landing (ms)", 1e3 * imp["t_s"] if imp else None)
        put("max uplift (mm)", 1e3 * w["max_uplift_m"])
        put("first landing impulse (N s)", imp["impulse_Ns"] if imp else None)
        put("first landing duration (ms)", 1e3 * imp["duration_s"] if imp else None)
        put("first landing peak (kN)", 1e-3 * imp["peak_force_N"] if imp else None)
        put("peak wheel force (kN)", 1e-3 * w["peak_force_N"])
        put("peak wheel force time (ms)", 1e3 * w["peak_force_time_s"])
        put("lift-offs", float(w["lift_offs"]["count"]))
        put("impacts", float(len(w["impacts"])))
    return out


def mode_character(m: dict[str, Any]) -> str:
    """The directions of a mode's effective mass above 1 % of the free mass."""
    frac = m.get("effective_mass_fraction", {})
    parts = [f"{d} {100 * v:.1f} %" for d, v in frac.items() if v >= 0.01]
    return ", ".join(parts) if parts else "m_eff < 1 % in x, y, z"


def von_mises_rows(frame: dict[str, Any], solid: dict[str, Any]) -> list[list[str]]:
    """The mock-up's bridge parts against the frame's members (its girder k with its rail
    joined, and the explicit zones on it: zone 2k − 1 and 2k)."""
    fg = frame.get("peak_von_mises_by_group", {})
    sp = solid.get("peak_bridge_von_mises_by_part_Pa", {})

    def frame_peak(groups: list[str]) -> tuple[float, float, str] | None:
        have = [(fg[g]["peak_Pa"], fg[g]["time_s"], g) for g in groups if g in fg]
        return max(have) if have else None

    rows = []
    pairs = [
        ("end carriage 1", ["end_carriage_1"]),
        ("end carriage 2", ["end_carriage_2"]),
        ("girder 1", ["girder_1", "zone_1", "zone_2"]),
        ("rail 1", ["girder_1", "zone_1", "zone_2"]),
        ("girder 2", ["girder_2", "zone_3", "zone_4"]),
        ("rail 2", ["girder_2", "zone_3", "zone_4"]),
    ]
    for part, groups in pairs:
        f = frame_peak(groups)
        s = sp.get(part)
        rows.append(
            [
                part,
                NA if f is None else f"{f[0] / 1e6:.2f} ({f[2]}, {1e3 * f[1]:.1f} ms)",
                _f(None if s is None else s / 1e6, ".2f"),
                _ratio(s, None if f is None else f[0]),
            ]
        )
    for g in ("links", "trolley", "hook", "wheel_1"):
        if g in fg:
            rows.append(
                [
                    f"({g}, frame only)",
                    f"{fg[g]['peak_Pa'] / 1e6:.2f} ({1e3 * fg[g]['time_s']:.1f} ms)",
                    NA,
                    NA,
                ]
            )
    whole = solid.get("peak_bridge_von_mises_Pa")
    if whole is not None:
        at = solid.get("peak_bridge_von_mises_t")
        rows.append(
            [
                "whole bridge (mock-up's key)",
                NA,
                f"{whole / 1e6:.2f} ({solid.get('peak_bridge_von_mises_part')}, "
                f"{_f(None if at is None else 1e3 * at, '.1f')} ms)",
                NA,
            ]
        )
    return rows


# ---------------------------------------------------------------------------- report


#: The first landing's columns of the stub-sensitivity table, from :func:`wheel_quantities`.
_LANDING = (
    "first landing (ms)",
    "first landing impulse (N s)",
    "first landing peak (kN)",
    "first landing duration (ms)",
    "max uplift (mm)",
    "peak wheel force (kN)",
)


def _landing_row(label: str, stiffness: str, weight: float, s: dict[str, Any]) -> list[str]:
    """One run's row of the stub-sensitivity table: its label, stub stiffness, carried
    weight, wheel 1's first landing, impacts, Δt and wall time."""
    q = wheel_quantities(s)
    return [
        label,
        stiffness,
        f"{weight:.1f}",
        *(_f(q.get(key, [None])[0]) for key in _LANDING),
        f"{len(s['wheels']['1']['impacts'])}",
        f"{s['dt']:.3e}",
        _f(s.get("wall_time_s"), ".1f"),
    ]


def report(
    frame: dict[str, Any],
    solid: dict[str, Any],
    fmodes: dict[str, Any],
    smodes: dict[str, Any],
    soft: list[tuple[float, dict[str, Any]]],
    header: list[str],
) -> str:
    lines = list(header)

    # 1. Preload.
    ff, fw, fkey = wheel_forces(frame)
    sf, sw, skey = wheel_forces(solid)
    lines += ["", "## 1. Static preload (self-weight, t = 0)", ""]
    rows = [[f"wheel {k}", f"{a:.6f}", f"{b:.6f}"] for k, a, b in zip(WHEELS, ff, sf, strict=True)]
    rows.append(["Σ wheels", f"{sum(ff):.6f}", f"{sum(sf):.6f}"])
    rows.append([f"carried weight (frame: {fkey}; 3D: {skey})", f"{fw:.6f}", f"{sw:.6f}"])
    fe, se = abs(sum(ff) - fw) / fw, abs(sum(sf) - sw) / sw
    rows.append(["abs(Σ − W) / W (recomputed)", f"{fe:.2e}", f"{se:.2e}"])
    rows.append(
        [
            "summary's sum_relative_error",
            _f(frame["preload"].get("sum_relative_error"), ".2e"),
            _f(solid["preload"].get("sum_relative_error"), ".2e"),
        ]
    )
    rows.append(["within 1e-8", str(fe <= 1e-8), str(se <= 1e-8)])
    flange = sum(v for n, v in frame["preload"]["contact_forces_N"].items() if "flange" in n)
    rows.append(["flange contacts' force (frame)", f"{flange:.3g}", NA])
    rows.append(
        [
            "max penetration (m)",
            _f(frame["preload"].get("max_penetration_m"), ".2e"),
            _f(solid["preload"].get("max_penetration_m"), ".2e"),
        ]
    )
    lines += _table(["static force (N)", "frame", "3D mock-up"], rows)

    # 2. Modes.
    lines += ["", "## 2. First six natural frequencies (contacts closed)", ""]
    rows = []
    fm, sm = fmodes["modes"], smodes["modes"]
    for i in range(max(len(fm), len(sm))):
        a = fm[i] if i < len(fm) else None
        b = sm[i] if i < len(sm) else None
        rows.append(
            [
                str(i + 1),
                _f(a and a["frequency_hz"], ".3f"),
                mode_character(a) if a else NA,
                _f(b and b["frequency_hz"], ".3f"),
                mode_character(b) if b else NA,
            ]
        )
    lines += _table(
        ["mode", "frame f (Hz)", "frame m_eff", "3D f (Hz)", "3D m_eff"],
        rows,
    )
    lines += [
        "",
        f"Free mass: frame {fmodes['mass_free_kg']['z']:.1f} kg of "
        f"{fmodes['mass_total_kg']:.1f} kg ({fmodes['free_dofs']} free DOFs), 3D "
        f"{smodes['mass_free_kg']['z']:.1f} kg of {smodes['mass_total_kg']:.1f} kg "
        f"({smodes['free_dofs']} free DOFs). Contacts: {smodes['contacts']}.",
    ]

    # 3. Vertical record.
    fq, sq = wheel_quantities(frame), wheel_quantities(solid)
    lines += ["", "## 3. The vertical record, per wheel (wheel 1; spread = max − min of 4)", ""]
    rows = []
    order = list(dict.fromkeys([*fq, *sq]))
    for key in order:
        a, b = fq.get(key, []), sq.get(key, [])
        fmt = ".0f" if key in ("lift-offs", "impacts") else ".4g"
        rows.append(
            [
                key,
                _f(a[0] if a else None, fmt),
                _spread(a, ".2g"),
                _f(b[0] if b else None, fmt),
                _spread(b, ".2g"),
                _ratio(b[0] if b else None, a[0] if a else None),
            ]
        )
    lines += _table(
        ["wheel quantity", "frame", "frame spread", "3D", "3D spread", "3D / frame"], rows
    )

    lines += ["", "Supports (clamped end-carriage ends):", ""]
    rows = []
    for k in ("1", "2", "3", "4"):
        a, b = frame["supports"].get(k, {}), solid["supports"].get(k, {})
        rows.append(
            [
                f"support {k}",
                f"{a['peak_force_N'] / 1e3:.2f} at {1e3 * a['peak_force_time_s']:.1f}",
                f"{b['peak_force_N'] / 1e3:.2f} at {1e3 * b['peak_force_time_s']:.1f}",
                f"{a['peak_vertical_N'] / 1e3:.2f} at {1e3 * a['peak_vertical_time_s']:.1f}",
                f"{b['peak_vertical_N'] / 1e3:.2f} at {1e3 * b['peak_vertical_time_s']:.1f}",
                f"{a['static_force_N'][2] / 1e3:.3f}",
                f"{b['static_force_N'][2] / 1e3:.3f}",
            ]
        )
    lines += _table(
        [
            "support",
            "frame peak force (kN at ms)",
            "3D peak force",
            "frame peak F_z",
            "3D peak F_z",
            "frame static F_z (kN)",
            "3D static F_z",
        ],
        rows,
    )

    lines += ["", "Peak von Mises stress (MPa; frame: beam section's outer fibres):", ""]
    lines += _table(
        ["part", "frame (its group, time)", "3D", "3D / frame"], von_mises_rows(frame, solid)
    )

    lines += ["", "Cost (noisy: shared machine, see the load average above):", ""]
    rows = []
    for label, s in (("frame", frame), ("3D mock-up", solid)):
        rows.append(
            [
                label,
                f"{s['dofs_explicit']}",
                f"{s['dt']:.3e}",
                f"{s['micro_steps']}",
                _f(s.get("wall_time_setup_s"), ".1f"),
                _f(s.get("wall_time_integration_s"), ".1f"),
                _f(s.get("wall_time_s"), ".1f"),
                _f(s.get("_process_s"), ".1f"),
                _f(s.get("_cpu_s"), ".1f"),
            ]
        )
    for label, m in (("frame modes", fmodes), ("3D modes", smodes)):
        p = m["_process"]
        rows.append(
            [
                label,
                str(m["free_dofs"]),
                NA,
                NA,
                NA,
                NA,
                NA,
                _f(p.get("elapsed_s"), ".1f"),
                _f(p.get("cpu_s"), ".1f"),
            ]
        )
    lines += _table(
        [
            "run",
            "DOFs",
            "Δt (s)",
            "steps",
            "setup s",
            "loop s",
            "wall_time_s",
            "process s",
            "CPU s",
        ],
        rows,
    )

    # 4. What the frame misses.
    lines += ["", "## 4. What the frame misses at the wheel/rail contact, measured", ""]
    f0, s0 = frame["_t0"], solid["_t0"]
    d_frame = -f0["probe_u2"] if "probe_u2" in f0 else None
    d_solid = -s0["wheel1_wheel_uz"] if "wheel1_wheel_uz" in s0 else None
    d_patch = -s0["probe_u2"] if "probe_u2" in s0 else None
    d_rail = -s0["wheel1_rail_uz"] if "wheel1_rail_uz" in s0 else None
    k_stub, l_stub = stub_stiffness(FRAME)
    rows = [
        [
            "static settlement of wheel 1's contact point δ (mm, down)",
            f"{_f(d_frame and 1e3 * d_frame, '.5f')} (probe_u2: wheel_point_1, the stub's foot)",
            f"{_f(d_solid and 1e3 * d_solid, '.5f')} (wheel1_wheel_uz; rail node "
            f"{_f(d_rail and 1e3 * d_rail, '.5f')}, wheel patch mean probe_u2 "
            f"{_f(d_patch and 1e3 * d_patch, '.5f')})",
        ],
        ["static wheel 1 force W/4 (N)", f"{ff[0]:.2f}", f"{sf[0]:.2f}"],
        [
            "static vertical reaction, support 1 (N)",
            f"{frame['supports']['1']['static_force_N'][2]:.1f}",
            f"{solid['supports']['1']['static_force_N'][2]:.1f}",
        ],
        [
            "first mode with most z mass (Hz)",
            _f(_first_vertical(fmodes), ".3f"),
            _f(_first_vertical(smodes), ".3f"),
        ],
        [
            "wheel stub axial stiffness E A / L (N/m)",
            f"{k_stub:.3e} (L = {l_stub:.3f} m, one element)",
            "— (a solid wheel on a solid rail, node-to-surface contact)",
        ],
    ]
    lines += _table(["quantity", "frame", "3D mock-up"], rows)
    lines.append("")
    if d_frame is not None and d_solid is not None:
        diff = d_solid - d_frame
        lines.append(
            f"δ_3D − δ_frame = {1e3 * diff:+.5f} mm (δ_3D / δ_frame = {d_solid / d_frame:.3f})."
        )
        if diff > 0.0:
            k_local = sf[0] / diff
            lines.append(
                f"Equivalent local stiffness k_local = (W/4) / (δ_3D − δ_frame) = {k_local:.3e} "
                f"N/m (W/4 the 3D's wheel 1 force), against the frame stub's {k_stub:.3e} N/m."
            )
        else:
            lines.append(
                "k_local = (W/4) / (δ_3D − δ_frame) is not defined: the mock-up's contact point "
                "settles LESS than the frame's under self-weight, so the difference measures the "
                "frame's larger global compliance (see the vertical mode and the supports), not "
                "the local compliance it lacks; the histories hold no girder-axis point of the "
                "3D model under the wheel to separate the two."
            )
    else:
        lines.append("The histories lack a contact-point displacement at t = 0: no δ.")

    lines += ["", "First landing and flight, 3D against frame (wheel 1):", ""]
    rows = []
    for key in (
        "first landing impulse (N s)",
        "first landing peak (kN)",
        "first landing duration (ms)",
        "max uplift (mm)",
        "peak wheel force (kN)",
    ):
        a, b = fq.get(key, [None])[0], sq.get(key, [None])[0]
        rows.append([key, _f(a), _f(b), _ratio(b, a)])
    lines += _table(["quantity", "frame", "3D", "3D / frame"], rows)

    if soft:
        lines += [
            "",
            "Frame sensitivity to its wheel stub (model.wheel_width: the stub's area; its "
            "bending about one axis scales with the width cubed, its mass with the width):",
            "",
        ]
        rows = []
        base = stub_stiffness(FRAME)[0]
        runs = [(None, frame), *soft]
        for width, s in runs:
            k = stub_stiffness(FRAME, width)[0]
            _, w, _ = wheel_forces(s)
            label = "scene" if width is None else f"{width:g}"
            rows.append(_landing_row(label, f"{k:.3e} (×{k / base:.2g})", w, s))
        rows.append(_landing_row("3D mock-up", NA, sw, solid))
        lines += _table(
            [
                "wheel_width (m)",
                "stub E A / L (N/m)",
                "carried W (N)",
                "landing (ms)",
                "impulse (N s)",
                "landing peak (kN)",
                "duration (ms)",
                "uplift (mm)",
                "peak (kN)",
                "impacts",
                "Δt (s)",
                "wall s",
            ],
            rows,
        )
    return "\n".join(lines) + "\n"


def _first_vertical(m: dict[str, Any]) -> float | None:
    """The frequency (Hz) of the mode with the largest z effective mass among those given."""
    best = max(m["modes"], key=lambda x: x.get("effective_mass_fraction", {}).get("z", 0.0))
    return best["frequency_hz"] if best.get("effective_mass_fraction", {}).get("z") else None


def _record(scene: Path) -> str:
    """The scene's ground motion and end time, as written."""
    data = tomllib.loads(scene.read_text())
    gm = data["loading"]["ground_motion"]
    return (
        f"{gm['record']} × {gm.get('scale', 1.0):g} from {gm.get('start', 0.0):g} s "
        f"(taper {gm.get('taper', 0.0):g} s) along {gm.get('direction')}, "
        f"end {data['time']['end']:g} s"
    )


def _flange_peak(s: dict[str, Any]) -> str:
    flanges = s.get("flanges", {})
    if not flanges:
        return "none in the summary"
    return f"{max(f['peak_force_N'] for f in flanges.values()):.3g} N over {len(flanges)}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "frame_vs_mockup")
    ap.add_argument(
        "--report", type=Path, default=ROOT / "benchmarks" / "out" / "frame_vs_mockup.md"
    )
    ap.add_argument("--stub-widths", default="0.025,0.005")
    ap.add_argument("--n-modes", type=int, default=6)
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args(argv)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    solid = run(SOLID, out / "solid", [], args.reuse)
    frame = run(FRAME, out / "frame", [], args.reuse)
    soft = []
    for w in (float(x) for x in args.stub_widths.split(",") if x.strip()):
        d = out / f"frame_wheel_width_{w:g}"
        soft.append((w, run(FRAME, d, [f"model.wheel_width={w!r}"], args.reuse)))
    smodes = modes(SOLID, out / "solid_modes", args.n_modes, args.reuse)
    fmodes = modes(FRAME, out / "frame_modes", args.n_modes, args.reuse)
    given = " ".join(["benchmarks/frame_vs_mockup.py", *(sys.argv[1:] if argv is None else argv)])
    header = [
        "# Frame crane against the 3D mock-up, fully explicit",
        "",
        f"Command: `.venv/bin/python {given}`",
        "",
        f"Runs: `crane-fem run demos/frame_crane.toml` and `demos/crane.toml`, each with "
        f"`--set 'coupling.method=\"monolithic\"' --set output.xdmf=false`, and `crane-fem "
        f"modes SCENE --n {args.n_modes}`; OMP_NUM_THREADS=1, one process at a time, in "
        f"{out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}/. Started {started}, "
        f"load average at the start {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f} "
        f"({os.cpu_count()} cores){REUSED if args.reuse else ''}.",
        "",
        f"Record: frame {_record(FRAME)}; 3D {_record(SOLID)}. Frame flange contacts' peak "
        f"force: {_flange_peak(frame)}; the 3D scene has no flange contact.",
    ]
    text = report(frame, solid, fmodes, smodes, soft, header)
    args.report.parent.mkdir(parents=True, exist_ok=True)
    args.report.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
