"""Crane runs: where two runs' wheel-pair displacements differ (trolley modes, time scales).

    .venv/bin/python benchmarks/crane_modes.py RUN REFERENCE

RUN and REFERENCE are run directories of a crane scene (history.csv, summary.json). Prints, for
the wheel side and the rail side of the probed contact pairs:

- the four pairs' u_z − u_z0 split into heave (mean of the four), roll (girder 1 against
  girder 2: wheels 1, 2 against 3, 4), pitch (wheels 1, 3 against 2, 4) and twist; each part's
  share of the reference and the L2 difference of RUN's part, both relative to the reference's
  wheel-1 response norm (the measure of crane_fem.compare.pair_l2);
- wheel 1's relative L2 difference after both signals are averaged over 1 and 2 ms (what is
  left without the kHz ripple) and with RUN shifted in time by the best of ±0.3 ms (a lag);
- the worst pair L2 (crane_fem.compare.pair_l2) up to the onset of each lift-off of the
  reference's wheel 1 after the first: how far the runs agree before each new flight.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from crane_fem.compare import lift_off_episodes, pair_l2
from crane_fem.plotting import Run, load_runs

#: Wheel 1: (−x, −y), 2: (−x, +y), 3: (+x, −y), 4: (+x, +y) (CraneGeometry.wheel_centres).
PARTS = {
    "heave": [1, 1, 1, 1],
    "roll": [1, 1, -1, -1],
    "pitch": [1, -1, 1, -1],
    "twist": [1, -1, -1, 1],
}


def _pairs(run: Run, side: str, t: np.ndarray) -> np.ndarray:
    cols = [run.history[f"wheel{k}_{side}_uz"] for k in range(1, 5)]
    return np.array([np.interp(t, run.history["t"], c - c[0]) for c in cols])


def main() -> int:
    run, ref = (load_runs(Path(a))[0] for a in sys.argv[1:3])
    t = run.history["t"]
    dT = float(t[1] - t[0])
    for side in ("wheel", "rail"):
        a, b = _pairs(run, side, t), _pairs(ref, side, t)
        scale = float(np.linalg.norm(b[0]))
        print(f"{side} side (% of the reference's wheel-1 norm):")
        for name, signs in PARTS.items():
            w = np.array(signs) / 4.0
            share = np.linalg.norm(w @ b) / scale
            diff = np.linalg.norm(w @ a - w @ b) / scale
            print(f"  {name:6s} share {share:.3f}  difference {100 * diff:.2f} %")
        for width in (1e-3, 2e-3):
            kernel = np.ones(max(1, round(width / dT)))
            kernel /= kernel.size
            x, y = (np.convolve(s, kernel, "same") for s in (a[0], b[0]))
            print(f"  wheel 1 averaged over {1e3 * width:g} ms: {100 * _rel(x, y):.2f} %")
        c = ref.history[f"wheel1_{side}_uz"]
        shifts = np.linspace(-3e-4, 3e-4, 61)
        errs = [_rel(a[0], np.interp(t + s, ref.history["t"], c - c[0])) for s in shifts]
        i = int(np.argmin(errs))
        print(f"  wheel 1 shifted by {1e3 * shifts[i]:.2f} ms: {100 * errs[i]:.2f} %")
    for onset, _ in lift_off_episodes(ref.history["t"], ref.history["gap_wheel_1"])[1:]:
        l2 = pair_l2(run, ref, onset).values()
        wheel, rail = (max(x[i] for x in l2) for i in (0, 1))
        print(
            f"up to the lift-off at t = {onset:.4f} s: wheel / rail {100 * wheel:.2f} / "
            f"{100 * rail:.2f} %"
        )
    return 0


def _rel(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.linalg.norm(x - y) / np.linalg.norm(y))


if __name__ == "__main__":
    sys.exit(main())
