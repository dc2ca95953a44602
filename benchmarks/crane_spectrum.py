"""Crane scene: what the heterogeneous run loses at its interface, in frequency.

    .venv/bin/python benchmarks/crane_spectrum.py [OUTDIR]

Reads the two runs written by ``benchmarks/crane.py`` (``OUTDIR`` = ``out/bench_crane`` by
default: ``heterogeneous/`` and ``explicit/``) and compares the power spectra of the vertical
velocity of the probed wheel/rail node pairs (all four wheels summed, wheel side and rail side)
after the first landing, from ``DELAY`` after it to the end of the run, when the trolley is in
its second flight and no contact is active. The histories are sampled once per macro step
ΔT, so the spectra reach 1/(2ΔT). Prints the Markdown table kept in RESULTS.md (share of the
power per band, and the total) and writes ``benchmarks/results/crane_spectrum.png``.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np
import numpy.typing as npt

from crane_fem.compare import first_landing
from crane_fem.plotting import Run, load_runs

ROOT = Path(__file__).resolve().parent.parent
DELAY = 0.02  # s after the first landing: its contact interval is over (10 ms here)
BANDS = (0.0, 300.0, 1000.0, 2000.0)  # Hz; the last band runs to 1/(2ΔT)

FloatArray = npt.NDArray[np.float64]


def pair_velocity_spectrum(run: Run, t0: float, side: str) -> tuple[FloatArray, FloatArray]:
    """(f, P): the power spectrum of v_z of the probed pair on ``side``, summed over the
    wheels, on [t0, end] (quadratic trend removed, Hann window)."""
    h = run.history
    t = h["t"]
    keep = t >= t0
    if np.count_nonzero(keep) < 16:
        raise SystemExit(f"{run.path}: fewer than 16 samples after t = {t0:.4g} s")
    tk = t[keep]
    dt = float(np.median(np.diff(tk)))
    power = np.zeros(tk.size // 2 + 1)
    for k in range(1, 5):
        col = f"wheel{k}_{side}_vz"
        if col not in h:
            continue
        v = h[col][keep]
        v = v - np.polyval(np.polyfit(tk, v, 2), tk)
        power += np.abs(np.fft.rfft(v * np.hanning(v.size))) ** 2
    return np.fft.rfftfreq(tk.size, dt), power


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("outdir", nargs="?", default=str(ROOT / "out" / "bench_crane"))
    args = parser.parse_args()
    runs = {r.path.name: r for r in load_runs(Path(args.outdir))}
    if not {"heterogeneous", "explicit"} <= runs.keys():
        raise SystemExit(f"{args.outdir}: needs heterogeneous/ and explicit/ (run crane.py)")
    t_land = first_landing(runs["explicit"])
    if t_land is None:
        raise SystemExit(f"{args.outdir}: the explicit run has no landing")
    t0 = t_land + DELAY
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    print(f"\nPair-velocity power after t = {t0:.4f} s (first landing {t_land:.4f} s + {DELAY} s)")
    print("\n| side | band | share of the explicit run's power | heterogeneous / explicit |")
    print("|---|---|---|---|")
    for ax, side in zip(axes, ("wheel", "rail"), strict=True):
        spectra = {}
        for name in ("explicit", "heterogeneous"):
            run = runs[name]
            f, p = pair_velocity_spectrum(run, t0, side)
            spectra[name] = (f, p)
            ax.semilogy(f, np.maximum(p, 1e-30), label=run.label, lw=1.0)
        f, p_e = spectra["explicit"]
        f_h, p_h = spectra["heterogeneous"]
        edges = [*BANDS, max(f[-1], f_h[-1]) + 1.0]
        for name, (a, b) in zip(_band_names(), itertools.pairwise(edges), strict=True):
            e_band = p_e[(f >= a) & (f < b)].sum()
            h_band = p_h[(f_h >= a) & (f_h < b)].sum()
            print(f"| {side} | {name} | {100 * e_band / p_e.sum():.1f} % | {h_band / e_band:.3f} |")
        print(f"| {side} | all | 100 % | {p_h.sum() / p_e.sum():.3f} |")
        d_T = float(np.median(np.diff(runs["heterogeneous"].history["t"])))
        ax.axvline(1.0 / (8.0 * d_T), color="k", ls=":", lw=0.8, label="1/(8ΔT)")
        ax.set_title(f"{side} side: v_z power after the landing")
        ax.set_xlabel("frequency (Hz)")
        ax.legend(fontsize=8)
    axes[0].set_ylabel("power (arbitrary units)")
    path = ROOT / "benchmarks" / "results" / "crane_spectrum.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"\nfigure: {path.relative_to(ROOT)}")
    return 0


def _band_names() -> list[str]:
    names = [f"{a:.0f}–{b:.0f} Hz" for a, b in itertools.pairwise(BANDS)]
    return [*names, f"≥ {BANDS[-1]:.0f} Hz"]


if __name__ == "__main__":
    sys.exit(main())
