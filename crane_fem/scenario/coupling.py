"""How the mesh is integrated: [[subdomain]], [coupling] and [newmark], with the coupled
methods' names and the keys that apply to some of them only."""

from __future__ import annotations

from typing import Annotated, Literal, get_args

from pydantic import Field, model_validator

from crane_fem.scenario.base import NonNegativePair, PositiveFloat, PositiveInt, Section
from crane_fem.scenario.sections import DampingRatio

__all__ = [
    "ADAPTIVE_KEYS",
    "ADAPTIVE_METHODS",
    "COUPLED_METHODS",
    "HYBRID_KEYS",
    "OPERATOR_KEYS",
    "SOLVED_INTERFACE_METHODS",
    "CoupledMethod",
    "Coupling",
    "NewmarkParams",
    "SubdomainSpec",
]

CoupledMethod = Literal["gc", "ph", "ec", "hybrid", "gc-mean"]
#: The methods that couple an explicit and an implicit subdomain (docs/scenarios.md).
COUPLED_METHODS: tuple[str, ...] = get_args(CoupledMethod)
#: The [coupling] keys of method "hybrid" only (its integrator's keyword arguments).
HYBRID_KEYS = ("impact_ratio", "interface_tolerance")
#: The methods that solve the interface rows every micro step, and their operator keys.
SOLVED_INTERFACE_METHODS = ("gc", "gc-mean", "hybrid")
OPERATOR_KEYS = ("interface_blocks", "interface_precision", "interface_truncation")
#: The methods whose macro step can refine at impacts (``fine_ratio``), and the keys that
#: tune the refinement (crane_fem.coupling.adaptive).
ADAPTIVE_METHODS = ("gc", "gc-mean")
ADAPTIVE_KEYS = ("fine_ratio", "refine_quiet", "refine_margin")


class SubdomainSpec(Section):
    """A subdomain: named cell groups integrated with one scheme. ``newmark-reduced`` is
    Newmark on a Craig–Bampton basis (crane_fem.reduction): the interface kept exactly, the
    interior by ``modes`` fixed-interface normal modes or every mode below ``cutoff`` Hz,
    plus the static response to each load."""

    name: str
    groups: Annotated[list[str], Field(min_length=1)]
    scheme: Literal["cd-lagrange", "newmark", "newmark-reduced"]
    modes: PositiveInt | None = None
    cutoff: PositiveFloat | None = None
    #: newmark-reduced: add the static response to each load to the basis (the quasi-static
    #: part carried exactly; false only to measure the error it avoids).
    static_vectors: bool | None = None
    #: The damping of an implicit subdomain, instead of the material's: C = αM + βK given as
    #: ``rayleigh = [α, β]`` or as a ratio at two frequencies. Its βK costs the implicit side
    #: nothing, where on the explicit side it shrinks the critical step.
    rayleigh: NonNegativePair | None = None
    damping: DampingRatio | None = None

    @model_validator(mode="after")
    def _damping(self) -> SubdomainSpec:
        given = "rayleigh" if self.rayleigh is not None else "damping" if self.damping else None
        if given is None:
            return self
        if self.rayleigh is not None and self.damping is not None:
            raise ValueError("give either rayleigh or damping, not both")
        if not self.implicit:
            raise ValueError(
                f"{given} applies to an implicit (newmark) subdomain only: an explicit one "
                "takes the material's damping (a βK term there shrinks its critical step)"
            )
        return self

    @property
    def rayleigh_coefficients(self) -> tuple[float, float] | None:
        """(α, β) of this subdomain's own damping, or None: the material's."""
        if self.rayleigh is not None:
            return float(self.rayleigh[0]), float(self.rayleigh[1])
        if self.damping is not None:
            from crane_fem.loading import rayleigh_from_damping

            d = self.damping
            return rayleigh_from_damping(d.ratio, d.f1, d.f2)
        return None

    @model_validator(mode="after")
    def _reduction(self) -> SubdomainSpec:
        if self.scheme == "newmark-reduced":
            if (self.modes is None) == (self.cutoff is None):
                raise ValueError(
                    "scheme 'newmark-reduced' needs exactly one of modes (a count of "
                    "fixed-interface modes) or cutoff (Hz)"
                )
        elif self.modes is not None or self.cutoff is not None or self.static_vectors is not None:
            key = (
                "modes"
                if self.modes is not None
                else "cutoff"
                if self.cutoff is not None
                else "static_vectors"
            )
            raise ValueError(
                f"{key} applies to scheme 'newmark-reduced' only (the reduction of an implicit "
                f"subdomain), not {self.scheme!r}"
            )
        return self

    @property
    def implicit(self) -> bool:
        return self.scheme in ("newmark", "newmark-reduced")


class Coupling(Section):
    """How subdomains are integrated: GC or PH coupling with ΔT = ratio × Δt, or the whole
    mesh as one subdomain with ``scheme`` (the monolithic reference)."""

    method: CoupledMethod | Literal["monolithic"] = "gc"
    ratio: PositiveInt = 1
    scheme: Literal["cd-lagrange", "newmark"] | None = None
    #: "hybrid": micro steps per implicit step in the macro steps where an explicit contact
    #: changes state (a divisor of ``ratio``; 1 by default).
    impact_ratio: PositiveInt | None = None
    #: "hybrid": a GC macro step whose interface energy exceeds this fraction of the
    #: mechanical energy (kinetic + internal) is redone with ``impact_ratio``.
    interface_tolerance: PositiveFloat | None = None
    #: gc, gc-mean, hybrid: the micro-step interface operator inverted by "bodies" (one block
    #: per connected body of the implicit side: exact), as "one" block (exact, slower), or by
    #: "zones" (also one block per connected explicit zone: the zones' coupling through the
    #: implicit side within a macro step dropped; crane_fem.coupling.operator).
    interface_blocks: Literal["bodies", "one", "zones"] | None = None
    #: gc, gc-mean, hybrid: the operator's eigenvectors in "double" (exact) or "single"
    #: precision (half the memory traffic; sums stay in double).
    interface_precision: Literal["double", "single"] | None = None
    #: gc, gc-mean, hybrid: drop the interface modes with 2mγ s ≤ this (0 keeps every mode:
    #: exact); each dropped mode's impulse is off by at most this fraction.
    interface_truncation: Annotated[float, Field(ge=0.0, lt=1.0)] | None = None
    #: gc, gc-mean: the macro step refines at impacts (docs/theory-notes.md §13): ``ratio``
    #: micro steps per macro step in flight and in steady contact, ``fine_ratio`` (a divisor
    #: of ``ratio``) from a coarse step before a contact closes until ``refine_quiet``
    #: seconds after the last impact, flange strike or contact change. Unset: a fixed ratio.
    fine_ratio: PositiveInt | None = None
    #: s: how long the contacts stay calm before the macro step coarsens again (default
    #: crane_fem.coupling.adaptive.QUIET_TIME).
    refine_quiet: PositiveFloat | None = None
    #: m: a contact predicted (gap + gap rate × the coarse ΔT) to come nearer than this
    #: refines the next coarse step (default crane_fem.coupling.adaptive.GAP_MARGIN).
    refine_margin: Annotated[float, Field(ge=0.0)] | None = None
    #: gc: shift each macro step's interface velocity targets by the interface displacement
    #: drift over ΔT (L_E U_E + L_I U_I, docs/theory-notes.md §16), so that the two sides'
    #: interface displacements do not drift apart at impacts. Off: GC as published.
    drift_correction: bool | None = None

    @property
    def monolithic_scheme(self) -> str:
        """The single scheme of a monolithic run: ``scheme``, CD-Lagrange by default (the
        fully explicit reference; ``ratio`` and the ``[[subdomain]]`` split are ignored)."""
        return self.scheme or "cd-lagrange"


class NewmarkParams(Section):
    """Newmark β, γ (average acceleration by default) and the implicit mass matrix."""

    beta: Annotated[float, Field(ge=0.0)] = 0.25
    gamma: Annotated[float, Field(ge=0.5)] = 0.5
    mass: Literal["consistent", "lumped"] = "consistent"
