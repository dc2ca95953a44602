"""The three-component crane scene (issue 16) judged as the crane is (issue 15): the explicit
ensemble, and the coupling methods by criteria (a), (b) and (c), (b) with each wheel's slip
along and across its rail and its flange impacts (:mod:`crane_fem.bench.ensemble`)."""

from __future__ import annotations

from pathlib import Path

from crane_fem.bench import Section
from crane_fem.bench.ensemble import AS_WRITTEN, GC_FIXED, Scene, report_scenes

__all__ = ["NAME", "SCENE", "SUMMARY", "run"]

NAME = "three_component"
SUMMARY = "demos/crane_3c.toml: explicit ensemble and couplings, with slip and flange impacts"

SCENE = Scene("crane_3c", [AS_WRITTEN, GC_FIXED])


def run(out: Path, quick: bool) -> list[Section]:
    """Run the scene's ensemble and methods (``quick`` changes nothing: one scene, a few
    minutes; collective, files written on rank 0)."""
    del quick
    md, files, minutes = report_scenes([SCENE], out, "three_component.csv")
    body = (
        "The three-component crane scene judged as the crane is (bench ensemble, THEORY.md "
        "§8): every coupled run against the fully explicit run with engineering tolerances, "
        "(b) with each wheel's slip along and across its rail and each flange's peak force, "
        "beside the explicit ensemble (the three components × 0.995 and × 1.005, Δt × ½). "
        f"{minutes:.1f} min.\n\n" + md
    )
    return [
        Section(
            "three-component",
            "The three-component crane scene: criteria (a), (b), (c)",
            body,
            files,
        )
    ]
