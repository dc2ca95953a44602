"""Run directories read back for plotting: history, summary, label and completion status."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.io.history import read_history
from crane_fem.scenario import COUPLED_METHODS

__all__ = ["Run", "load_runs"]

FloatArray = npt.NDArray[np.float64]

#: How each unfinished status reads in the warning line.
_STATUS_WORDS = {
    "interrupted": "interrupted",
    "unstable": "stopped as unstable",
    "running": "stopped without finishing (killed, or still running)",
}


@dataclass
class Run:
    """One run directory: its history columns and summary (``{}`` when summary.json is absent)."""

    path: Path
    history: dict[str, FloatArray]
    summary: dict[str, Any]

    @property
    def method_label(self) -> str:
        """The method from summary.json: ``GC, m = 100``, ``fully explicit``, a bar's scheme."""
        s = self.summary
        if s.get("method") == "monolithic":
            return "fully explicit" if s.get("explicit_subdomains") else "fully implicit"
        if s.get("method") in COUPLED_METHODS:
            return f"{str(s['method']).upper()}, m = {s.get('ratio')}"
        if "scheme" in s:
            return str(s["scheme"])
        return ""

    @property
    def label(self) -> str:
        """Legend name: the directory name and the method, and the status if unfinished."""
        method = self.method_label
        text = f"{self.path.name}: {method}" if method else self.path.name
        return text + (f" [{self.status}]" if not self.complete else "")

    @property
    def status(self) -> str:
        """summary.json ``status``; ``running`` without a summary (the run never wrote one)."""
        return str(self.summary.get("status", "running"))

    @property
    def complete(self) -> bool:
        return self.status == "completed"

    @property
    def t_reached(self) -> float:
        """Time reached (s): summary ``t_reached_s``, else the history's last row."""
        if "t_reached_s" in self.summary:
            return float(self.summary["t_reached_s"])
        return float(self.history["t"][-1])

    @property
    def t_end(self) -> float | None:
        """The end time asked for (s): summary ``time_end_s``, else ``steps`` times the macro
        step ``dT`` (the step ``dt`` of a single-integrator run); None if the summary has
        neither."""
        s = self.summary
        if "time_end_s" in s:
            return float(s["time_end_s"])
        step = s.get("dT", s.get("dt"))
        if "steps" in s and step is not None:
            return float(s["steps"]) * float(step)
        return None

    def incomplete_message(self) -> str | None:
        """One line saying how far an unfinished run got (None for a completed run), e.g.
        ``out/x: run interrupted at t = 0.0731 s of 0.2 s; figures show the steps done``."""
        if self.complete:
            return None
        words = _STATUS_WORDS.get(self.status, f"ended with status {self.status!r}")
        end = self.t_end
        of = f" of {end:.4g} s" if end is not None else ""
        return (
            f"{self.path}: run {words} at t = {self.t_reached:.4g} s{of}; "
            "figures show the steps done"
        )


def _read_history(path: Path) -> dict[str, FloatArray]:
    history = read_history(path)
    if not history or history[next(iter(history))].size == 0:
        raise ValueError(f"{path}: no data rows")
    return history


def load_runs(outdir: Path) -> list[Run]:
    """The run in ``outdir`` or the runs in its subdirectories (sorted: heterogeneous first).

    Not collective (reads files only).
    """
    dirs = (
        [outdir]
        if (outdir / "history.csv").exists()
        else sorted(p.parent for p in outdir.glob("*/history.csv"))
    )
    if not dirs:
        raise FileNotFoundError(f"{outdir}: no history.csv here nor in a subdirectory")
    runs = []
    for d in dirs:
        summary = (
            json.loads((d / "summary.json").read_text()) if (d / "summary.json").exists() else {}
        )
        runs.append(Run(d, _read_history(d / "history.csv"), summary))
    runs.sort(key=lambda r: (r.summary.get("method") == "monolithic", r.path.name))
    return runs


def incomplete_tag(runs: list[Run]) -> str:
    """`` (incomplete: interrupted)`` for a figure of one unfinished run, `` (incomplete:
    explicit interrupted)`` naming the run among several; empty when every run completed."""
    bad = [r for r in runs if not r.complete]
    if not bad:
        return ""
    if len(runs) == 1:
        return f" (incomplete: {bad[0].status})"
    return " (incomplete: " + ", ".join(f"{r.path.name} {r.status}" for r in bad) + ")"


def figure_title(runs: list[Run], what: str) -> str:
    """A figure's title: the scenario name(s) (and the run, if alone), what it shows, and the
    incomplete tag."""
    names = sorted({str(r.summary["scenario"]) for r in runs if "scenario" in r.summary})
    head = ", ".join(names)
    if len(runs) == 1:  # the legend does not name a lone run: the title does
        method = runs[0].method_label
        run = f"{runs[0].path.name}: {method}" if method else runs[0].path.name
        head = f"{head} ({run})" if head else run
    return (f"{head}: " if head else "") + what + incomplete_tag(runs)
