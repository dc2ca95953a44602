"""Scenario files: TOML -> validated configuration, with one-line errors naming the key.

The format is documented in ``docs/scenarios.md``. Every rank reads and validates the same
file, so a bad scenario raises the same :class:`~crane_fem.errors.ScenarioError` on every rank
before any collective call is made.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from crane_fem.errors import ScenarioError

__all__ = [
    "COUPLED_METHODS",
    "HYBRID_KEYS",
    "OPERATOR_KEYS",
    "SOLVED_INTERFACE_METHODS",
    "Contact",
    "Integrator",
    "Scenario",
    "Wheel",
    "apply_overrides",
    "apply_unsets",
    "load_scenario",
    "parse_scenario",
]

PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]
PositiveInt = Annotated[int, Field(gt=0)]
Pair = Annotated[list[float], Field(min_length=2, max_length=2)]
NonNegativePair = Annotated[list[NonNegativeFloat], Field(min_length=2, max_length=2)]
Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]
CoupledMethod = Literal["gc", "ph", "ec", "hybrid", "gc-mean"]
#: The methods that couple an explicit and an implicit subdomain (docs/scenarios.md).
COUPLED_METHODS: tuple[str, ...] = get_args(CoupledMethod)
#: The [coupling] keys of method "hybrid" only (its integrator's keyword arguments).
HYBRID_KEYS = ("impact_ratio", "interface_tolerance")
#: The methods that solve the interface rows every micro step, and their operator keys.
SOLVED_INTERFACE_METHODS = ("gc", "gc-mean", "hybrid")
OPERATOR_KEYS = ("interface_blocks", "interface_precision", "interface_truncation")


class _Section(BaseModel):
    """Strict section: no unknown keys, no string-to-number coercion (ints pass as floats)."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True)


class SecondBar(_Section):
    """A second bar to the right of the first one, for node-to-node (two-body) contact."""

    length: PositiveFloat
    elements: PositiveInt
    area: PositiveFloat = 1.0
    velocity: float = 0.0


class BarModel(_Section):
    """1D bar along x (dolfinx interval mesh, P1); its left end faces the wall at x = 0.

    ``split`` (distance from the left end, on a node) tags the cells ``left``/``right``.
    """

    kind: Literal["bar"]
    length: PositiveFloat
    elements: PositiveInt
    area: PositiveFloat = 1.0
    clamp: Literal["none", "right"] = "none"
    second_bar: SecondBar | None = None
    split: PositiveFloat | None = None

    @model_validator(mode="after")
    def _split_on_node(self) -> BarModel:
        if self.split is not None:
            k = self.split / self.length * self.elements
            if not 0 < self.split < self.length or abs(k - round(k)) > 1e-9:
                raise ValueError(
                    f"model.split = {self.split} must lie strictly inside the bar on a node "
                    f"(a multiple of length/elements = {self.length / self.elements:g})"
                )
        return self

    @property
    def groups(self) -> list[str]:
        return ["left", "right"] if self.split is not None else []


#: The crane's keys that are not dimensions of its geometry (nor recorded by its mesh).
_NOT_GEOMETRY = ("kind", "hoisted_mass", "mesh")


class CraneModel(_Section):
    """Bi-girder overhead-crane mock-up (crane_fem.geometry.crane.CraneGeometry; any of its
    dimensions may be given, metres). Groups: ``bridge_implicit``, ``trolley_frame``,
    ``zone_1..4``, ``wheel_1..4``; clamped end-carriage faces; four wheel/rail node-to-node
    contacts. ``hoisted_mass`` (kg) is carried rigidly by the trolley frame (added to its
    density); ``mesh`` reads a ``.msh`` written by ``crane-fem mesh`` instead of meshing.
    ``flanges`` gives each wheel two flanges hanging ``flange_depth`` down either side of its
    rail, ``flange_clearance`` off the rail sides, ``flange_thickness`` thick (part of
    ``wheel_k``; the other flange keys are ignored without it): lateral flange/rail-side
    node-to-node contacts (CraneMesh.flange_pairs), frictionless unilateral rows named
    ``flange_in_k``/``flange_out_k``. The wheels' friction and brakes are the ``[wheel]``
    section's."""

    kind: Literal["crane"]
    span: PositiveFloat = 4.0
    girder_spacing: PositiveFloat = 1.0
    girder_width: PositiveFloat = 0.12
    girder_height: PositiveFloat = 0.20
    end_carriage_length: PositiveFloat = 1.6
    end_carriage_width: PositiveFloat = 0.15
    end_carriage_height: PositiveFloat = 0.15
    rail_width: PositiveFloat = 0.05
    rail_height: PositiveFloat = 0.04
    trolley_position: float = 2.0
    wheel_base: PositiveFloat = 0.6
    wheel_width: PositiveFloat = 0.05
    wheel_length: PositiveFloat = 0.08
    wheel_height: PositiveFloat = 0.06
    frame_overhang: PositiveFloat = 0.10
    frame_length: PositiveFloat = 0.8
    frame_thickness: PositiveFloat = 0.05
    zone_margin: PositiveFloat = 0.06
    zone_depth: NonNegativeFloat = 0.0
    size: PositiveFloat = 0.12
    fine: PositiveFloat = 0.04
    flanges: bool = False
    flange_clearance: NonNegativeFloat = 0.005
    flange_depth: PositiveFloat = 0.02
    flange_thickness: PositiveFloat = 0.02
    hoisted_mass: NonNegativeFloat = 0.0
    mesh: str | None = None

    @property
    def groups(self) -> list[str]:
        return ["bridge_implicit", "trolley_frame"] + [
            f"{p}_{k}" for p in ("zone", "wheel") for k in range(1, 5)
        ]

    def geometry(self) -> Any:
        from crane_fem.geometry.crane import CraneGeometry

        return CraneGeometry(**self.model_dump(exclude=set(_NOT_GEOMETRY)))


class BoxBeamModel(_Section):
    """3D box beam [0, L]×[0, W]×[0, H] (gmsh, two volumes split at x = ``split``), clamped at
    x = 0; cell groups ``part_a`` (x < split) and ``part_b``; tetrahedra of size ``h``."""

    kind: Literal["box_beam"]
    length: PositiveFloat
    width: PositiveFloat
    height: PositiveFloat
    split: PositiveFloat
    h: PositiveFloat

    @model_validator(mode="after")
    def _inside(self) -> BoxBeamModel:
        if not self.split < self.length:
            raise ValueError(f"model.split = {self.split} must be < model.length = {self.length}")
        if self.h > min(self.width, self.height, self.split, self.length - self.split):
            raise ValueError(f"model.h = {self.h} is larger than a side of the beam parts")
        return self

    @property
    def groups(self) -> list[str]:
        return ["part_a", "part_b"]


class BlockModel(_Section):
    """3D elastic box [0, lx] × [0, ly] × [gap, gap + lz] (``size`` = [lx, ly, lz], m) above
    the rigid plane z = 0 of its ``plane`` contact (gap: that contact's ``gap``), P1
    tetrahedra of size about ``h``; one explicit CD-Lagrange body (the fully explicit path,
    no ``[[subdomain]]``). Cell group ``block``; facet groups ``bottom`` (z = gap, every
    vertex a contact point) and ``top``."""

    kind: Literal["block"]
    size: Annotated[list[PositiveFloat], Field(min_length=3, max_length=3)]
    h: PositiveFloat

    @model_validator(mode="after")
    def _h_fits(self) -> BlockModel:
        if self.h > min(self.size):
            raise ValueError(f"model.h = {self.h} is larger than a side of the block")
        return self

    @property
    def groups(self) -> list[str]:
        return ["block"]


class DampingRatio(_Section):
    """Rayleigh damping giving the ratio ``ratio`` at the frequencies f1 < f2 (Hz)."""

    ratio: Annotated[float, Field(ge=0.0, lt=1.0)]
    f1: PositiveFloat
    f2: PositiveFloat

    @model_validator(mode="after")
    def _order(self) -> DampingRatio:
        if not self.f1 < self.f2:
            raise ValueError(f"f1 = {self.f1} must be < f2 = {self.f2}")
        return self


class Material(_Section):
    """Linear elastic material; Rayleigh damping C = alpha M + beta K, given as ``rayleigh``
    = [alpha, beta] or as a ``damping`` ratio at two frequencies."""

    E: PositiveFloat
    rho: PositiveFloat
    nu: Annotated[float, Field(ge=0.0, lt=0.5)] = 0.3
    rayleigh: NonNegativePair = [0.0, 0.0]
    damping: DampingRatio | None = None

    @model_validator(mode="after")
    def _one_damping(self) -> Material:
        if self.damping is not None and any(self.rayleigh):
            raise ValueError("give either rayleigh or damping, not both")
        return self

    @property
    def rayleigh_coefficients(self) -> tuple[float, float]:
        """(alpha, beta) of C = alpha M + beta K."""
        if self.damping is None:
            return float(self.rayleigh[0]), float(self.rayleigh[1])
        from crane_fem.loading import rayleigh_from_damping

        d = self.damping
        return rayleigh_from_damping(d.ratio, d.f1, d.f2)


class Pulse(_Section):
    """Right-travelling cos² displacement pulse u = a cos²(π (X − center)/width), v = −c u'."""

    center: float
    width: PositiveFloat
    amplitude: float


class Initial(_Section):
    """Initial state of the first bar: uniform velocity, linear displacement [left, right],
    optionally a travelling pulse on top; of a block: its uniform velocity [vx, vy, vz]."""

    velocity: float | Vector3 = 0.0
    displacement: Pair = [0.0, 0.0]
    pulse: Pulse | None = None

    @property
    def bar_velocity(self) -> float:
        """The bar's uniform velocity (a scenario with a vector velocity is refused for a
        bar, so this is a number there)."""
        v = self.velocity
        return float(v) if not isinstance(v, list) else float(v[0])

    @property
    def velocity_vector(self) -> list[float]:
        """The uniform velocity as [vx, vy, vz] (a number: [v, 0, 0])."""
        v = self.velocity
        return [float(x) for x in v] if isinstance(v, list) else [float(v), 0.0, 0.0]


class Contact(_Section):
    """A unilateral contact, frictionless unless ``friction`` (Coulomb's μ ≥ 0) is given.

    ``wall``: rigid plane x = 0 facing +x, the first bar's left end at x = gap.
    ``bars``: node-to-node between the first bar's right end and the second bar's left end,
    ``gap`` apart.
    ``plane``: the rigid plane z = 0 facing +z under a block (model.kind 'block') whose bottom
    face is at z = gap: every vertex of that face is a contact point, normal e_z, tangents
    e_x and e_y (the only type with a tangent plane, so the only one that takes friction).
    """

    type: Literal["wall", "bars", "plane"]
    gap: NonNegativeFloat
    name: str | None = None
    friction: NonNegativeFloat = 0.0

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.type


class Wheel(_Section):
    """The crane's wheels on their rails: ``friction`` is the Coulomb coefficient μ ≥ 0 of the
    wheel/rail pairs (0: frictionless, as before); ``braked`` (default true: a crane parked
    for an earthquake has its brakes set, the usual qualification assumption) makes the
    wheels stick by friction both across (x) and along (y) the rail, else they roll freely
    along it (friction across only)."""

    friction: NonNegativeFloat = 0.0
    braked: bool = True


class Time(_Section):
    """End time and step: ``dt`` in seconds or ``dt_factor`` times the critical explicit step."""

    end: PositiveFloat
    dt: PositiveFloat | None = None
    dt_factor: PositiveFloat | None = None

    @model_validator(mode="after")
    def _one_step_spec(self) -> Time:
        if (self.dt is None) == (self.dt_factor is None):
            raise ValueError("give exactly one of time.dt (seconds) or time.dt_factor")
        return self


class Integrator(_Section):
    """Time integrator and its parameters."""

    scheme: Literal["cd-lagrange", "moreau-jean", "penalty"] = "cd-lagrange"
    theta: Annotated[float, Field(ge=0.5, le=1.0)] | None = None
    penalty: PositiveFloat | None = None

    @model_validator(mode="after")
    def _parameters_apply(self) -> Integrator:
        if self.theta is not None and self.scheme != "moreau-jean":
            raise ValueError(f"integrator.theta applies to 'moreau-jean' only, not {self.scheme!r}")
        if self.scheme == "penalty" and self.penalty is None:
            raise ValueError("integrator.penalty (contact stiffness, N/m) is required by 'penalty'")
        if self.penalty is not None and self.scheme != "penalty":
            raise ValueError(f"integrator.penalty applies to 'penalty' only, not {self.scheme!r}")
        return self

    @property
    def theta_value(self) -> float:
        return 0.5 if self.theta is None else self.theta


class GroundMotion(_Section):
    """Seismic ground acceleration a_g(t) (relative formulation: body force −ρ a_g(t) direction).

    ``record``: a bundled record name (``el_centro_1940_up``, ``el_centro_1940_180``,
    ``el_centro_1940_270``), a path to a PEER ``.AT2`` / ``.csv`` (t, a in m/s²) file, or
    ``synthetic`` (band-limited enveloped noise: ``pga`` m/s², ``duration`` s, ``band`` Hz,
    ``seed``); several components are given as ``[[loading.ground_motion]]`` entries;
    ``scale`` multiplies it; ``direction`` is the unit vector of the shaking. ``start`` (s)
    is the record time at which the run begins (a strong-motion window), ``taper`` (s) the
    length of a half-cosine ramp from zero at the beginning of the run.
    """

    record: str
    scale: float = 1.0
    direction: Vector3 = [0.0, 0.0, 1.0]
    start: NonNegativeFloat = 0.0
    taper: NonNegativeFloat = 0.0
    pga: PositiveFloat | None = None
    duration: PositiveFloat | None = None
    band: Annotated[list[PositiveFloat], Field(min_length=2, max_length=2)] = [0.5, 15.0]
    seed: int = 0

    @model_validator(mode="after")
    def _synthetic(self) -> GroundMotion:
        synth = self.record == "synthetic"
        if synth and (self.pga is None or self.duration is None):
            raise ValueError("record 'synthetic' needs pga (m/s²) and duration (s)")
        if not synth and (self.pga is not None or self.duration is not None):
            raise ValueError("pga and duration apply to record = 'synthetic' only")
        if synth and not self.band[0] < self.band[1]:
            raise ValueError(f"band must be [f_low, f_high] with f_low < f_high (got {self.band})")
        if not any(self.direction):
            raise ValueError("direction must not be the zero vector")
        return self


class TipTraction(_Section):
    """Half-sine traction pulse t(s) = traction sin(π s / duration) on the beam's tip face."""

    traction: Vector3
    duration: PositiveFloat


class Loading(_Section):
    """Body loads: gravity acceleration vector (m/s²); a bar uses its x component."""

    gravity: Vector3 = [0.0, 0.0, 0.0]
    tip_traction: TipTraction | None = None
    ground_motion: GroundMotion | list[GroundMotion] | None = None

    @property
    def ground_motions(self) -> list[GroundMotion]:
        gm = self.ground_motion
        return [] if gm is None else gm if isinstance(gm, list) else [gm]


class SubdomainSpec(_Section):
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


class Coupling(_Section):
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

    @property
    def monolithic_scheme(self) -> str:
        """The single scheme of a monolithic run: ``scheme``, CD-Lagrange by default (the
        fully explicit reference; ``ratio`` and the ``[[subdomain]]`` split are ignored)."""
        return self.scheme or "cd-lagrange"


class NewmarkParams(_Section):
    """Newmark β, γ (average acceleration by default) and the implicit mass matrix."""

    beta: Annotated[float, Field(ge=0.0)] = 0.25
    gamma: Annotated[float, Field(ge=0.5)] = 0.5
    mass: Literal["consistent", "lumped"] = "consistent"


class Output(_Section):
    """What is written and how often."""

    every: PositiveInt = 1
    xdmf: bool = True
    xdmf_every: PositiveInt | None = None
    #: Crane: the bridge's peak von Mises stress is evaluated every this many macro steps.
    stress_every: PositiveInt = 1
    progress: bool | Literal["auto"] = "auto"
    #: Write the full state every this many macro steps (``crane-fem run --restart OUTDIR``
    #: continues from the latest one); scenes with subdomains only.
    checkpoint_every: PositiveInt | None = None


class Spectra(_Section):
    """Pseudo-acceleration response spectra of the input motion and of the absolute motion at
    named ``points`` (coordinates in metres, the nearest mesh vertex is used; a crane gets its
    trolley centre, wheel 1 and an end-carriage support when none is given): ``damping`` is
    the oscillators' damping ratio, ``periods`` the range [T_min, T_max] (s) sampled at
    ``count`` log-spaced periods."""

    damping: Annotated[float, Field(gt=0, lt=1)] = 0.05
    periods: Annotated[list[PositiveFloat], Field(min_length=2, max_length=2)] = [0.01, 2.0]
    count: Annotated[int, Field(ge=2)] = 100
    points: dict[str, Vector3] = {}

    @model_validator(mode="after")
    def _range(self) -> Spectra:
        if not self.periods[0] < self.periods[1]:
            raise ValueError(
                f"periods must be [T_min, T_max] with T_min < T_max (got {self.periods})"
            )
        return self


class Monitor(_Section):
    """Divergence detection: stop when the kinetic energy exceeds ``energy_growth`` times the
    energy supplied (initial energy + |external work|)."""

    energy_growth: Annotated[float, Field(gt=1)] = 10.0


class Scenario(_Section):
    """A whole scenario file."""

    name: str = "scenario"
    model: Annotated[BarModel | BoxBeamModel | CraneModel | BlockModel, Field(discriminator="kind")]
    material: Material
    initial: Initial = Initial()
    contact: list[Contact] = []
    time: Time
    integrator: Integrator = Integrator()
    loading: Loading = Loading()
    output: Output = Output()
    spectra: Spectra = Spectra()
    wheel: Wheel = Wheel()
    monitor: Monitor = Monitor()
    subdomain: list[SubdomainSpec] = []
    coupling: Coupling | None = None
    newmark: NewmarkParams = NewmarkParams()

    @property
    def coupled_path(self) -> bool:
        """Run through subdomains (coupled or monolithic reference) rather than the bar path
        (a block always: one CD-Lagrange subdomain built by the pipeline)."""
        return (
            bool(self.subdomain) or self.coupling is not None or isinstance(self.model, BlockModel)
        )

    @model_validator(mode="after")
    def _contacts_and_block(self) -> Scenario:
        mdl = self.model
        block = isinstance(mdl, BlockModel)
        for i, c in enumerate(self.contact):
            if c.friction > 0.0 and c.type != "plane":
                raise ValueError(
                    f"contact[{i}].friction: a {c.type!r} contact (at a 1D bar's end) has no "
                    "tangent plane; friction needs a contact of type 'plane' (model.kind "
                    "'block')"
                )
            if (c.type == "plane") != block:
                raise ValueError(
                    f"contact[{i}].type: {c.type!r} does not apply to model.kind {mdl.kind!r} "
                    f"(a block takes type 'plane', a bar 'wall' or 'bars')"
                )
        if mdl.kind in ("crane", "box_beam") and self.initial.model_fields_set:
            key = sorted(self.initial.model_fields_set)[0]
            raise ValueError(
                f"initial.{key}: model.kind {mdl.kind!r} starts at rest"
                + (" in its static preload (with gravity)" if mdl.kind == "crane" else "")
                + "; initial.* applies to a 'bar' or a 'block'"
            )
        vec = isinstance(self.initial.velocity, list)
        if vec and not block:
            raise ValueError(
                f"initial.velocity: model.kind {mdl.kind!r} takes a number (the bar's axial "
                f"velocity), not a vector (got {self.initial.velocity})"
            )
        if not block:
            return self
        if not vec and self.initial.velocity != 0.0:
            raise ValueError(
                "initial.velocity: model.kind 'block' takes a vector [vx, vy, vz] (m/s), not a "
                f"number (got {self.initial.velocity})"
            )
        if len(self.contact) > 1:
            raise ValueError("contact: a block takes at most one contact (type 'plane')")
        if self.initial.displacement != [0.0, 0.0] or self.initial.pulse is not None:
            raise ValueError(
                "initial: model.kind 'block' starts undeformed (displacement and pulse are a "
                "bar's); give its initial.velocity only"
            )
        if self.subdomain:
            raise ValueError(
                "subdomain: model.kind 'block' is one explicit CD-Lagrange body; it takes no "
                "[[subdomain]] entries"
            )
        cpl = self.coupling
        explicit = cpl is None or (
            cpl.method == "monolithic" and cpl.monolithic_scheme == "cd-lagrange"
        )
        if not explicit:
            raise ValueError(
                "coupling: model.kind 'block' runs fully explicit (method 'monolithic', scheme "
                "'cd-lagrange'); leave [coupling] out"
            )
        if self.integrator.scheme != "cd-lagrange":
            raise ValueError(
                f"integrator.scheme: model.kind 'block' runs with 'cd-lagrange', not "
                f"{self.integrator.scheme!r}"
            )
        return self

    @model_validator(mode="after")
    def _subdomains(self) -> Scenario:
        mdl = self.model
        if isinstance(mdl, BoxBeamModel | CraneModel):
            if not self.coupled_path:
                raise ValueError(
                    f"model.kind {mdl.kind!r} needs [[subdomain]] entries or "
                    "[coupling] method = 'monolithic'"
                )
            if self.contact:
                raise ValueError(
                    f"contact: not available on model.kind {mdl.kind!r} (the "
                    "crane's wheel/rail contacts come with its geometry)"
                )
            if isinstance(mdl, CraneModel) and self.coupling and self.coupling.method == "ph":
                # Its explicit side must be linear over each macro step; the crane's wheels
                # rest on their rails (active contacts) from t = 0.
                raise ValueError(
                    "coupling.method: 'ph' needs contact-free explicit subdomains, but the "
                    "crane's wheels rest on their rails from t = 0; use 'gc' (or 'gc-mean')"
                )
        if isinstance(mdl, CraneModel):
            try:
                mdl.geometry().validate()
            except ScenarioError as exc:  # name the scenario key, not the dataclass field
                raise ValueError(str(exc).replace("geometry.", "model.")) from None
        if self.loading.tip_traction is not None and not isinstance(mdl, BoxBeamModel):
            raise ValueError("loading.tip_traction applies to model.kind 'box_beam' only")
        cpl = self.coupling
        if cpl is not None and cpl.method == "monolithic":
            if cpl.scheme == "newmark" and (self.contact or isinstance(mdl, CraneModel)):
                raise ValueError(
                    "contact needs an explicit subdomain: coupling.scheme = "
                    "'newmark' cannot carry [[contact]]"
                )
            return self
        if cpl is not None and cpl.scheme is not None:
            raise ValueError("coupling.scheme applies to method 'monolithic' only")
        if cpl is not None and cpl.method not in SOLVED_INTERFACE_METHODS:
            for key in OPERATOR_KEYS:
                if getattr(cpl, key) is not None:
                    raise ValueError(
                        f"coupling.{key} applies to methods "
                        f"{', '.join(SOLVED_INTERFACE_METHODS)} only (they solve the interface "
                        "every micro step)"
                    )
        if cpl is not None and cpl.method != "hybrid":
            for key in HYBRID_KEYS:
                if getattr(cpl, key) is not None:
                    raise ValueError(f"coupling.{key} applies to method 'hybrid' only")
        if cpl is not None and cpl.impact_ratio is not None:
            if cpl.ratio % cpl.impact_ratio:
                raise ValueError(
                    f"coupling.impact_ratio = {cpl.impact_ratio} must divide coupling.ratio = "
                    f"{cpl.ratio}"
                )
        if (
            cpl is not None
            and cpl.method in ("ec", "hybrid", "gc-mean")
            and (
                self.newmark.beta,
                self.newmark.gamma,
            )
            != (0.25, 0.5)
        ):
            raise ValueError(
                f"coupling.method {cpl.method!r} needs the average-acceleration Newmark "
                "(newmark.beta = 0.25, newmark.gamma = 0.5)"
            )
        if not self.subdomain:
            if cpl is not None:
                raise ValueError(f"coupling method {cpl.method!r} needs [[subdomain]] entries")
            return self
        allowed = mdl.groups
        if not allowed:
            raise ValueError("subdomain: model.split is required to name the bar's groups")
        seen: list[str] = []
        for i, sd in enumerate(self.subdomain):
            for g in sd.groups:
                if g not in allowed:
                    raise ValueError(
                        f"subdomain[{i}].groups: unknown group {g!r}; allowed: "
                        + ", ".join(allowed)
                    )
                if g in seen:
                    raise ValueError(f"subdomain[{i}].groups: group {g!r} is in two subdomains")
                seen.append(g)
        missing = sorted(set(allowed) - set(seen))
        if missing:
            raise ValueError(f"subdomain: groups {missing} belong to no subdomain")
        implicit = [sd for sd in self.subdomain if sd.implicit]
        if len(implicit) > 1 and cpl is None:
            raise ValueError("two implicit (newmark) subdomains without a [coupling]")
        if len(implicit) > 1:
            raise ValueError("at most one newmark subdomain is supported")
        explicit = [sd for sd in self.subdomain if sd.scheme == "cd-lagrange"]
        if implicit and explicit and cpl is None:
            raise ValueError("explicit and implicit subdomains need a [coupling] section")
        if self.integrator.scheme != "cd-lagrange":
            raise ValueError(
                "integrator.scheme: with [[subdomain]] the scheme is given per subdomain"
            )
        return self

    @model_validator(mode="after")
    def _wheels_of_a_crane(self) -> Scenario:
        if self.wheel != Wheel() and not isinstance(self.model, CraneModel):
            raise ValueError("wheel: applies to model.kind 'crane' only (its wheel/rail pairs)")
        return self

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        if self.output.checkpoint_every is not None and not self.coupled_path:
            raise ValueError(
                "output.checkpoint_every: checkpoints are written by scenes with [[subdomain]] "
                "or [coupling] only"
            )
        if not isinstance(self.model, BarModel):
            return self
        types = [c.type for c in self.contact]
        for t in ("wall", "bars"):
            if types.count(t) > 1:
                raise ValueError(f"contact: at most one contact of type {t!r}")
        labels = [c.label for c in self.contact]
        if len(set(labels)) != len(labels):
            raise ValueError(f"contact: names must be unique, got {labels}")
        if ("bars" in types) != (self.model.second_bar is not None):
            raise ValueError(
                "contact type 'bars' and [model.second_bar] go together (one needs the other)"
            )
        if self.model.clamp == "right" and self.initial.displacement[1] != 0.0:
            raise ValueError("initial.displacement: the clamped right end must start at 0")
        if self.model.clamp == "right" and self.model.second_bar is not None:
            raise ValueError("model.clamp = 'right' cannot be combined with a second bar")
        if self.time.dt is not None and self.time.dt > self.time.end:
            raise ValueError(f"time.dt = {self.time.dt} exceeds time.end = {self.time.end}")
        return self


MODEL_KINDS = {
    "bar": BarModel,
    "box_beam": BoxBeamModel,
    "crane": CraneModel,
    "block": BlockModel,
}


def _allowed_keys(section: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """Keys allowed at the parent of ``loc`` (for 'unknown key' messages)."""
    model: Any = section
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        if part in MODEL_KINDS:
            model = MODEL_KINDS[part]
            continue
        field = model.model_fields.get(part)
        if field is None:
            return []
        ann = field.annotation
        candidates = [ann, *getattr(ann, "__args__", ())]
        for cand in candidates:
            inner = getattr(cand, "__args__", ())
            for c in (cand, *inner):
                if isinstance(c, type) and issubclass(c, BaseModel):
                    model = c
                    break
            else:
                continue
            break
    return sorted(model.model_fields)


#: Union-branch tags pydantic inserts in error locations besides those with a "[" in them
#: ("list[...]", "literal['auto']", "function-after[...]"); no scenario key has these names.
_SCALAR_TAGS = {"bool", "int", "float", "str", "none", "constrained-float", "constrained-int"}


def _is_tag(part: Any) -> bool:
    """A union-branch tag in an error location, not a key."""
    return isinstance(part, str) and ("[" in part or part in _SCALAR_TAGS)


def _leaf(e: Any) -> bool:
    """The error is a union branch refusing the input as a whole (its type, or a literal):
    not a branch that took the input and then found a problem inside it."""
    return bool(e["loc"]) and _is_tag(e["loc"][-1]) and e["type"] != "value_error"


def _expected(e: Any) -> list[str]:
    """What a branch expected, as alternatives: "a table", "'auto'", "a valid boolean"."""
    if e["type"] in ("model_type", "model_attributes_type", "dict_type"):
        return ["a table"]
    if e["type"] == "list_type":
        of_tables = any(c.isupper() for c in e["loc"][-1])  # a list of a model class
        return ["an array of tables" if of_tables else "an array"]
    if e["type"] == "literal_error":
        return [x.strip() for x in str(e["ctx"]["expected"]).replace(" or ", ", ").split(",")]
    msg = str(e["msg"])
    return [msg.removeprefix("Input should be ")]


def _real_errors(errors: list[Any]) -> list[Any]:
    """The errors of the union branch the input was meant for: of ``[loading.ground_motion]``
    (a table or an array of tables) with a bad value, that value's error, not also "should
    be a valid list" from the other branch; where every branch refused the input as a whole
    (a string for a table, an unknown name), one error listing what it should be."""
    # Unions where some branch took the input: its errors are the real ones.
    taken = set()
    for e in errors:
        if _leaf(e):
            continue
        loc = e["loc"]
        taken |= {loc[:i] for i in range(len(loc)) if _is_tag(loc[i])}
    out: list[Any] = []
    merged: dict[tuple[Any, ...], Any] = {}
    for e in errors:
        if not _leaf(e):
            out.append(e)
            continue
        where = e["loc"][:-1]
        if where in taken:
            continue
        if where not in merged:
            merged[where] = {**e, "loc": where, "type": "union_type", "expected": []}
            out.append(merged[where])
        merged[where]["expected"] += [x for x in _expected(e) if x not in merged[where]["expected"]]
    for e in merged.values():
        alts = e["expected"]
        e["msg"] = "Input should be " + (
            alts[0] if len(alts) == 1 else f"{', '.join(alts[:-1])} or {alts[-1]}"
        )
    return out


def _path(loc: tuple[Any, ...]) -> str:
    """``model.length``, ``subdomain[1].modes``: the key of an error location, with the tags
    pydantic inserts dropped (the discriminator after "model", union branches)."""
    raw = tuple(p for p in loc if not _is_tag(p))
    key = tuple(
        p for i, p in enumerate(raw) if not (i > 0 and raw[i - 1] == "model" and p in MODEL_KINDS)
    )
    return ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in key).replace(".[", "[")


def _format_error(source: str, exc: ValidationError) -> str:
    """One line: ``source: key.path: what is wrong (got value)``, then the keys of any other
    distinct problems (``[also: material.E]``)."""

    # An unknown key is usually the root cause (a typo that also leaves a key missing); of a
    # union "table or array of tables", the table branch speaks for a table.
    def rank(e: Any) -> tuple[bool, bool]:
        in_list = any(isinstance(p, str) and p.startswith("list[") for p in e["loc"])
        return e["type"] != "extra_forbidden", in_list

    errors = sorted(_real_errors(exc.errors()), key=rank)
    err = errors[0]
    raw = tuple(p for p in err["loc"] if not _is_tag(p))
    path = _path(err["loc"])
    kind = err["type"]
    if kind == "union_tag_invalid":
        path = f"{path}.kind"
        kinds = ", ".join(repr(k) for k in MODEL_KINDS)
        msg = f"unknown kind {err['input'].get('kind')!r}; allowed: {kinds}"
    elif kind == "extra_forbidden":
        allowed = ", ".join(_allowed_keys(Scenario, raw))
        msg = f"unknown key; allowed here: {allowed}"
    elif kind == "missing":
        msg = "required key is missing"
    elif kind == "union_type":
        msg = f"{err['msg']} (got {err['input']!r})"
    elif kind in ("model_type", "model_attributes_type", "dict_type"):
        msg = f"Input should be a table (got {err['input']!r})"
    else:
        msg = err["msg"]
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
        if kind != "value_error":
            msg = f"{msg} (got {err['input']!r})"
    others = [o or "(top level)" for o in dict.fromkeys(_path(e["loc"]) for e in errors[1:])]
    others = [o for o in others if o != (path or "(top level)")]
    tail = f" [also: {', '.join(others)}]" if others else ""
    where = f"{path}: " if path else ""
    return f"{source}: {where}{msg}{tail}"


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario mapping.

    Raises:
        ScenarioError: with a one-line message naming the key and what is allowed.
    """
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_format_error(source, exc)) from None


def _parse_value(text: str, key: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        raise ScenarioError(
            f"--set {key}={text}: value is not a TOML value (quote strings: {key}='\"{text}\"')"
        ) from None


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Apply ``key.path=value`` overrides (values parsed as TOML) to a scenario mapping; a
    number in the path indexes an array of tables (``subdomain.1.modes=100``)."""
    for item in overrides:
        if "=" not in item:
            raise ScenarioError(f"--set {item}: expected key.path=value")
        key, text = item.split("=", 1)
        key = key.strip()
        parts = key.split(".")
        if not key or any(not p for p in parts):
            raise ScenarioError(f"--set {item}: empty key")
        node: Any = data
        for i, part in enumerate(parts[:-1]):
            here = ".".join(parts[: i + 1])
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise ScenarioError(
                        f"--set {key}: {here}: an array of {len(node)} tables takes an index "
                        f"0..{len(node) - 1}"
                    )
                node = node[int(part)]
                continue
            nxt = node.get(part) if isinstance(node, dict) else None
            if nxt is None:
                nxt = {}
                node[part] = nxt
            if not isinstance(nxt, dict | list):
                raise ScenarioError(f"--set {key}: {here} is not a table and has no keys")
            node = nxt
        if not isinstance(node, dict):
            raise ScenarioError(f"--set {key}: {'.'.join(parts[:-1])} is not a table")
        node[parts[-1]] = _parse_value(text.strip(), key)
    return data


def apply_unsets(data: dict[str, Any], keys: list[str]) -> dict[str, Any]:
    """Remove keys (``loading.ground_motion.pga``; a number in the path indexes an array of
    tables, as for :func:`apply_overrides`) from a scenario mapping, so that they take their
    defaults or, with ``--set``, other keys can replace them.

    Raises:
        ScenarioError: a key that is not in the scenario, naming it.
    """
    for key in keys:
        parts = key.strip().split(".")
        if not key.strip() or any(not p for p in parts):
            raise ScenarioError(f"--unset {key}: empty key")
        node: Any = data
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            if isinstance(node, list) and part.isdigit() and int(part) < len(node):
                if last:
                    del node[int(part)]
                else:
                    node = node[int(part)]
                continue
            if not isinstance(node, dict) or part not in node:
                raise ScenarioError(f"--unset {key}: no key {'.'.join(parts[: i + 1])} to unset")
            if last:
                del node[part]
            else:
                node = node[part]
    return data


def _resolve_paths(data: dict[str, Any], base: Path) -> None:
    """Make the scenario's relative file paths relative to the scenario file's directory:
    ``model.mesh`` and every ground-motion record that is a file (not a bundled name, not
    ``synthetic``), as an include would be; ``--set`` values included."""
    from crane_fem.loading.accelerogram import BUNDLED

    mdl = data.get("model")
    if isinstance(mdl, dict) and isinstance(mdl.get("mesh"), str):
        mesh = Path(mdl["mesh"])
        if not mesh.is_absolute():
            mdl["mesh"] = str(base / mesh)
    loading = data.get("loading")
    gm = loading.get("ground_motion") if isinstance(loading, dict) else None
    for motion in gm if isinstance(gm, list) else [gm]:
        if not isinstance(motion, dict):
            continue
        record = motion.get("record")
        if not isinstance(record, str) or record == "synthetic" or record in BUNDLED:
            continue
        if not Path(record).is_absolute():
            motion["record"] = str(base / record)


#: The crane model's keys that describe its mesh (those of
#: :class:`crane_fem.geometry.crane.CraneGeometry`).
_MESH_KEYS = tuple(k for k in CraneModel.model_fields if k not in _NOT_GEOMETRY)


def _fill_from_mesh(mdl: dict[str, Any]) -> tuple[list[str], dict[str, float] | None]:
    """Give a crane's geometry keys that the scenario leaves out the values its
    ``model.mesh`` was written with (the mesh's sidecar, crane_fem.geometry.crane.mesh_sidecar).
    Returns the keys the scenario gives and the mesh's geometry (None: no sidecar)."""
    from crane_fem.geometry.crane import read_mesh_sidecar

    given = [k for k in _MESH_KEYS if k in mdl]
    written = read_mesh_sidecar(mdl["mesh"]) if Path(mdl["mesh"]).is_file() else None
    if written is not None:
        for key in _MESH_KEYS:
            mdl.setdefault(key, written[key])
    return given, written


def _check_mesh_geometry(
    mdl: CraneModel, given: list[str], written: dict[str, float] | None
) -> None:
    """A crane's ``model.mesh`` exists and its geometry keys given in the scenario are those
    it was written with. Not collective (every rank reads the same files, before any
    collective call).

    Raises:
        ScenarioError: the mesh is not a file; a geometry key differs from the mesh's; the
            mesh has no sidecar while geometry keys are given (they cannot be checked).
    """
    from crane_fem.geometry.crane import mesh_sidecar

    assert mdl.mesh is not None
    mesh = Path(mdl.mesh)
    if not mesh.is_file():
        raise ScenarioError(f"model.mesh: {mesh} is not a file (write it with crane-fem mesh)")
    if written is None:
        if given:
            keys = ", ".join(f"model.{k}" for k in given)
            raise ScenarioError(
                f"model.mesh: {mesh} has no {mesh_sidecar(mesh).name} recording the geometry "
                f"it was made from, so {keys} cannot be checked against it: write it with "
                "crane-fem mesh, or drop those keys to take the mesh as it is"
            )
        return
    for key in given:
        value = float(getattr(mdl, key))
        if abs(value - written[key]) > 1e-12 * max(abs(written[key]), 1.0):
            raise ScenarioError(
                f"model.{key} = {value:g} disagrees with model.mesh {mesh} (made with "
                f"{key} = {written[key]:g}, {mesh_sidecar(mesh).name}): drop the key to use "
                "that mesh, or unset model.mesh to mesh the geometry (crane-fem mesh writes it)"
            )


def load_scenario(
    path: str | Path,
    overrides: list[str] | None = None,
    unset: list[str] | None = None,
    *,
    read_mesh: bool = True,
) -> Scenario:
    """Read, unset keys (``unset``), override (``overrides``) and validate a scenario file.

    Relative paths (``model.mesh``, record files) are relative to the scenario file. A
    crane's ``model.mesh`` is checked against its geometry keys unless ``read_mesh`` is
    False (``crane-fem mesh``, which writes the mesh from them).

    Not collective: every rank may call it; all ranks raise the same error on bad input.

    Raises:
        ScenarioError: missing/unreadable file, TOML syntax, a key to unset that is not
            there, invalid keys/values, or geometry keys that disagree with the mesh.
    """
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: scenario file not found")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: TOML syntax error: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{p}: cannot read the scenario: {exc}") from None
    data.setdefault("name", p.stem)
    apply_unsets(data, unset or [])
    apply_overrides(data, overrides or [])
    _resolve_paths(data, p.parent)
    mdl = data.get("model")
    mesh = isinstance(mdl, dict) and mdl.get("kind") == "crane" and isinstance(mdl.get("mesh"), str)
    mesh = mesh and read_mesh
    try:
        # The keys are validated with the mesh's geometry, then compared with it.
        given, written = _fill_from_mesh(mdl) if mesh and isinstance(mdl, dict) else ([], None)
        sc = parse_scenario(data, str(p))
        if mesh:
            assert isinstance(sc.model, CraneModel)
            _check_mesh_geometry(sc.model, given, written)
    except ScenarioError as exc:
        msg = str(exc)
        raise ScenarioError(msg if msg.startswith(f"{p}: ") else f"{p}: {msg}") from None
    return sc
