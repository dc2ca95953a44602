"""Figures of a study directory (``crane-fem plot STUDY_DIR``, where ``study.json`` is):

- ``study_spectra.png``: per measured point and direction, each nominal case's floor
  response spectrum (thin), their envelope (max, thick) and mean (dashed);
- ``study_quantities.png``: each sign-off quantity across the nominal cases, a panel per
  kind of quantity, a line per place (wheel, support, …); the code's design value as a
  horizontal tick; a place whose quantity is beyond the scene's conditioning drawn hollow.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from crane_fem.plotting.style import run_colour, save

__all__ = ["study_figures"]

#: Display scale and unit per SI unit.
_UNITS = {"N": (1e-3, "kN"), "Pa": (1e-6, "MPa"), "m": (1e3, "mm"), "s": (1e3, "ms")}


def _case_label(case: dict[str, Any], name: str) -> str:
    labels = case.get("labels") or {}
    return " / ".join(f"{v}" for v in labels.values()) or name


def _spectra(doc: dict[str, Any], path: Path) -> Path | None:
    import matplotlib.pyplot as plt

    sp = doc.get("spectra") or {}
    curves = {k: v for k, v in sp.get("curves", {}).items() if not k.startswith("input_")}
    if not curves:
        return None
    periods = sp["periods_s"]
    n = len(curves)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(4.2 * cols, 3.2 * rows), squeeze=False, layout="constrained"
    )
    for ax, (name, c) in zip(axes.flat, curves.items(), strict=False):
        for each in c["cases"].values():
            ax.semilogx(periods, each, color="0.7", lw=0.6)
        ax.semilogx(periods, c["max"], color="k", lw=1.8, label="envelope (max)")
        ax.semilogx(periods, c["mean"], color="C3", ls="--", lw=1.2, label="mean")
        ax.set_title(name.removeprefix("psa_").replace("_", " "), fontsize=9)
        ax.set_xlabel("period (s)")
        ax.set_ylabel("PSA (m/s²)")
        ax.grid(True, which="both", lw=0.3)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=7)
    count = len(next(iter(curves.values()))["cases"])
    return save(fig, path, f"Floor response spectra over {count} cases")


def _quantities(doc: dict[str, Any], path: Path) -> Path | None:
    import matplotlib.pyplot as plt

    rows = doc.get("quantities") or {}
    if not rows:
        return None
    nominal = [n for n, c in doc["cases"].items() if not c.get("member")]
    kinds: dict[str, list[dict[str, Any]]] = {}
    for row in rows.values():
        kinds.setdefault(row["quantity"], []).append(row)
    n = len(kinds)
    cols = min(n, 3)
    nrows = -(-n // cols)
    fig, axes = plt.subplots(
        nrows, cols, figsize=(4.6 * cols, 3.3 * nrows), squeeze=False, layout="constrained"
    )
    x = list(range(len(nominal)))
    for ax, (kind, group) in zip(axes.flat, kinds.items(), strict=False):
        f, unit = _UNITS.get(group[0]["unit"], (1.0, group[0]["unit"]))
        for i, row in enumerate(group):
            y = [f * row["cases"].get(c, float("nan")) for c in nominal]
            beyond = row.get("conditioning", {}).get("beyond", False)
            colour = run_colour(i)
            ax.plot(
                x,
                y,
                marker="o",
                ms=4,
                lw=0.8,
                color=colour,
                mfc="none" if beyond else colour,
                label=row["where"] + (" (beyond conditioning)" if beyond else ""),
            )
            if "code" in row:
                ax.axhline(f * row["code"]["value"], color=colour, lw=0.5, ls=":")
        ax.set_title(kind, fontsize=9)
        ax.set_ylabel(unit)
        ax.set_xticks(
            x, [_case_label(doc["cases"][c], c) for c in nominal], rotation=60, fontsize=6
        )
        ax.grid(True, lw=0.3)
        if len(group) <= 8:
            ax.legend(fontsize=6)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    return save(
        fig, path, "Sign-off quantities across the study's cases (dotted: the code's value)"
    )


def study_figures(study_dir: Path) -> list[Path]:
    """The study's figures in ``study_dir/figures/``. Not collective."""
    import matplotlib

    matplotlib.use("Agg")
    doc = json.loads((study_dir / "study.json").read_text())
    figdir = study_dir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    made = [
        _spectra(doc, figdir / "study_spectra.png"),
        _quantities(doc, figdir / "study_quantities.png"),
    ]
    return [p for p in made if p is not None]
