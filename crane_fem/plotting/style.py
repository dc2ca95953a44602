"""Shared figure style: one colour and one dash pattern per run, titles, saving."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["DASHES", "figure_legend", "run_colour", "run_dash", "run_width", "save"]

#: Line styles of the runs when colour means something else (energy terms, spectra points);
#: their legend entries are grey, apart from the black curves.
DASHES = ["-", "--", ":", "-."]
#: Colours of the runs when the line style means something else (wheel / rail side).
_COLOURS = ["C0", "C3", "C2", "C4", "C1", "C5"]


def run_colour(i: int) -> str:
    return _COLOURS[i % len(_COLOURS)]


def run_dash(i: int) -> str:
    return DASHES[i % len(DASHES)]


def run_width(i: int) -> float:
    """The first run drawn wide and later ones thin on top: where runs agree, both show."""
    return 1.8 if i == 0 else 0.9


def figure_legend(fig: Any, entries: list[tuple[str, dict[str, Any]]]) -> None:
    """One legend under the axes (outside them: it covers no curve) from (label, Line2D
    keywords) entries, e.g. the runs by colour then the sides by line style, so that n × m
    curves need only n + m entries. The figure must use ``layout="constrained"``."""
    from matplotlib.lines import Line2D

    if not entries:
        return
    handles = [Line2D([], [], label=label, **kw) for label, kw in entries]
    ncol = min(len(handles), 4 if max(len(label) for label, _ in entries) < 30 else 2)
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8, frameon=False)


def save(fig: Any, path: Path, title: str | None = None) -> Path:
    """Title (suptitle), write at 120 dpi and close ``fig`` (laid out by its constrained
    layout)."""
    import matplotlib.pyplot as plt

    if title:
        fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
