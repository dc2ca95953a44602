"""In which frequency band the beam models miss the mock-up's support forces: every
support's peak vertical force and peak force magnitude low-passed at a list of cut-offs, from
the histories ``benchmarks/mixed_vs_mockup.py`` wrote (no run of its own).

    .venv/bin/python benchmarks/supports_band.py DIR [DIR ...] [--mixed NAME]
        [--report FILE]

DIR: a ``mixed_vs_mockup.py --out`` directory (``mockup/``, ``ensemble/<member>/``,
``frame/`` and the mixed crane's ``mixed*/``; ``--mixed`` picks one by name when there are
several). Each support force (x, y, z, as each run samples it) is filtered as
``output.support_lowpass_hz`` filters it (``crane_fem.reactions.lowpass_peaks``: a
4th-order Butterworth forward and backward, zero phase) on that run's own samples, then its
peak read: |f_z| and |f|. "none" is the unfiltered sampled signal (the run's summary reads
its peaks at every step, so its "support peak vertical force" may be a little higher); "—":
a run sampled fewer than ten times a period of the cut-off (the frame's 0.5 ms samples, the
mock-up's 89 µs ones above 1 kHz). A peak at the window's last instant is a force still
rising there. The spread
is the mock-up ensemble's largest |member − mock-up|, filtered alike; a beam model's value
passes when its difference is within max(10 %, spread), THEORY.md §8 (b)'s tolerance of
the support forces.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from crane_fem.reactions import lowpass_peaks

ROOT = Path(__file__).resolve().parents[1]
CUTOFFS: tuple[float | None, ...] = (None, 1000.0, 500.0, 250.0, 100.0)
TOL = 0.10  # crane_fem.tolerances: "support peak (vertical) force", 10 % of the reference


def _history(path: Path) -> dict[str, np.ndarray]:
    with path.open() as f:
        head = next(csv.reader(f))
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {k: data[:, i] for i, k in enumerate(head)}


def _peaks(h: dict[str, np.ndarray], support: int, cutoff: float | None) -> tuple[float, float]:
    """(peak |f_z|, peak |f|) of support ``support`` low-passed at ``cutoff`` Hz (N): the
    product's filter (``crane_fem.reactions.lowpass_peaks``, as ``output.support_lowpass_hz``
    applies it); NaN where the run's sampling holds fewer than ten samples a period of it."""
    t = h["t"]
    f = np.stack([h[f"support{support}_f{c}"] for c in "xyz"], axis=1)[:, None, :]
    if cutoff is None:
        return float(np.abs(f[:, 0, 2]).max()), float(np.linalg.norm(f[:, 0], axis=1).max())
    try:
        low = lowpass_peaks(t, f, cutoff)
    except ValueError:
        return float("nan"), float("nan")
    return float(low["peak_vertical"][0]), float(low["peak"][0])


def _supports(h: dict[str, np.ndarray]) -> list[int]:
    return sorted(int(k[7:-3]) for k in h if k.startswith("support") and k.endswith("_fz"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", type=Path, nargs="+")
    ap.add_argument("--mixed", default=None, help="the mixed crane's run directory's name")
    ap.add_argument("--report", type=Path, default=ROOT / "benchmarks/out/supports_band.md")
    args = ap.parse_args()
    lines = [
        "# The supports' peak forces by frequency band: the beam models against the mock-up",
        "",
        "Command: `.venv/bin/python benchmarks/supports_band.py "
        + " ".join(str(d.resolve().relative_to(ROOT)) for d in args.dirs)
        + (f" --mixed {args.mixed}" if args.mixed else "")
        + "`",
        "",
        "Each support force low-passed (4th-order Butterworth, zero phase) at the cut-off, then "
        "its peak read. Ratio: |model − mock-up| / max(10 %, ensemble spread); **bold**: out.",
        "",
    ]
    for d in args.dirs:
        mixed_dirs = sorted(p for p in d.glob("mixed*") if (p / "history.csv").exists())
        if args.mixed:
            mixed_dirs = [p for p in mixed_dirs if p.name == args.mixed]
        if not mixed_dirs:
            raise SystemExit(f"{d}: no mixed crane run (mixed*/history.csv)")
        ref = _history(d / "mockup" / "history.csv")
        members = [_history(p / "history.csv") for p in sorted((d / "ensemble").glob("*/"))]
        models = {"mixed": _history(mixed_dirs[0] / "history.csv")}
        if (d / "frame" / "history.csv").exists():
            models["frame"] = _history(d / "frame" / "history.csv")
        lines += [
            f"## {d.name} (mixed: {mixed_dirs[0].name}; {len(members)} ensemble members)",
            "",
            "| support | quantity | cut-off (Hz) | mock-up | spread | "
            + " | ".join(f"{m} | ratio" for m in models)
            + " |",
            "|---|---|---|---|---|" + "---|---|" * len(models),
        ]
        # The supports alike by symmetry at mid-span: every one listed all the same.
        for s in _supports(ref):
            for q, name in ((0, "peak vertical force"), (1, "peak force")):
                for fc in CUTOFFS:
                    r = _peaks(ref, s, fc)[q]
                    spread = max((abs(_peaks(m, s, fc)[q] - r) for m in members), default=0.0)
                    bound = max(TOL * r, spread)
                    cells = []
                    for h in models.values():
                        v = _peaks(h, s, fc)[q]
                        if np.isnan(v):  # the cut-off above this run's Nyquist frequency
                            cells += ["—", "—"]
                            continue
                        ratio = abs(v - r) / bound
                        text = f"{ratio:.2f}" if ratio <= 1.0 else f"**{ratio:.2f}**"
                        cells += [f"{v / 1e3:.1f} kN ({(v - r) / r:+.0%})", text]
                    lines.append(
                        f"| {s} | {name} | {'none' if fc is None else f'{fc:g}'} | "
                        f"{r / 1e3:.1f} kN | {spread / 1e3:.2f} kN | " + " | ".join(cells) + " |"
                    )
        lines.append("")
    args.report.write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
