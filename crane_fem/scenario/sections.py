"""The flat sections: [material], [initial], [[contact]], [wheel], [time], [integrator],
[output], [spectra], [monitor]."""

# Pydantic copies a field's default into each instance; ruff cannot see across modules that
# Section is a pydantic model.
# ruff: noqa: RUF012

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from crane_fem.scenario.base import (
    NonNegativeFloat,
    NonNegativePair,
    Pair,
    PositiveFloat,
    PositiveInt,
    Section,
    Vector3,
)

__all__ = [
    "Contact",
    "DampingRatio",
    "GroupMass",
    "GroupMaterial",
    "Initial",
    "Integrator",
    "Joint",
    "Material",
    "Monitor",
    "Output",
    "Pulse",
    "Spectra",
    "Support",
    "SurfaceContact",
    "Time",
    "Wheel",
]


class DampingRatio(Section):
    """Rayleigh damping giving the ratio ``ratio`` at the frequencies f1 < f2 (Hz)."""

    ratio: Annotated[float, Field(ge=0.0, lt=1.0)]
    f1: PositiveFloat
    f2: PositiveFloat

    @model_validator(mode="after")
    def _order(self) -> DampingRatio:
        if not self.f1 < self.f2:
            raise ValueError(f"f1 = {self.f1} must be < f2 = {self.f2}")
        return self


class Material(Section):
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


class GroupMaterial(Material):
    """The material of some volume groups of a gmsh model (``[[material]]`` entries)."""

    groups: Annotated[list[str], Field(min_length=1)]


class Pulse(Section):
    """Right-travelling cos² displacement pulse u = a cos²(π (X − center)/width), v = −c u'."""

    center: float
    width: PositiveFloat
    amplitude: float


class Initial(Section):
    """Initial state of the first bar: uniform velocity, linear displacement [left, right],
    optionally a travelling pulse on top; of a 3D structure: its uniform velocity [vx, vy,
    vz]. ``preload`` (a gmsh model, a frame): start from the static state under gravity
    (default), or undeformed (``false``: a drop, a swing released from rest)."""

    velocity: float | Vector3 = 0.0
    displacement: Pair = [0.0, 0.0]
    pulse: Pulse | None = None
    preload: bool = True

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


class Contact(Section):
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


class SurfaceContact(Section):
    """Node-to-surface contact of a gmsh model (``model.kind = "gmsh"``), large sliding: the
    vertices of the surface group ``points`` against the triangles of the surface group
    ``surface`` of another body, re-paired as they slide (crane_fem.contact.sliding);
    Coulomb ``friction`` μ ≥ 0; ``name`` (default the points group) names its outputs.
    ``rolling = [x, y, z]``: free-rolling wheels, rolling along that direction: their
    friction acts across it only (none along it), and the static preload holds no force
    along it. ``along = [x, y, z]`` (default ``rolling``): a rail's direction, along which
    and across which (along × n) the outputs also give the points' mean slip."""

    type: Literal["surface"]
    points: str
    surface: str
    friction: NonNegativeFloat = 0.0
    name: str | None = None
    rolling: Vector3 | None = None
    along: Vector3 | None = None

    @model_validator(mode="after")
    def _rolling(self) -> SurfaceContact:
        if self.rolling is not None:
            if not any(self.rolling):
                raise ValueError("rolling: must not be the zero vector")
            if self.friction <= 0.0:
                raise ValueError("rolling: applies to a contact with friction")
        if self.along is not None and not any(self.along):
            raise ValueError("along: must not be the zero vector")
        return self

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.points


class Support(Section):
    """A group clamped to the ground (a gmsh model's surface group, a frame's point group):
    fixed in the relative formulation, so it moves with the ground motion. A frame's support
    fixes the six DOFs of its points (``dofs = "clamped"``) or their translations only
    (``"pinned"``)."""

    group: str
    dofs: Literal["clamped", "pinned"] = "clamped"


class Joint(Section):
    """A beam node driving a solid's face (a mixed gmsh model, THEORY.md §11): the point group
    ``node`` (one vertex of the line mesh, on the face's centroid) tied to the surface group
    ``face`` by the rigid section's six rows (the section's resultant and moment; the face
    free to warp). ``name`` (default the face's group) names it in messages."""

    face: str
    node: str
    name: str | None = None

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.face


class GroupMass(Section):
    """Equipment carried rigidly by a group: a gmsh model's volume group (``mass``, kg,
    spread uniformly over its volume: added to its density), or a frame's point group
    (``mass`` shared equally by its points, with an optional rotary ``inertia`` [Ixx, Iyy,
    Izz], kg·m², about global axes)."""

    group: str
    mass: PositiveFloat
    inertia: Vector3 | None = None

    @model_validator(mode="after")
    def _inertia(self) -> GroupMass:
        if self.inertia is not None and min(self.inertia) < 0.0:
            raise ValueError(f"inertia = {self.inertia}: must not be negative")
        return self


class Wheel(Section):
    """The crane's wheels on their rails: ``friction`` is the Coulomb coefficient μ ≥ 0 of the
    wheel/rail pairs (0: frictionless, as before); ``braked`` (default true: a crane parked
    for an earthquake has its brakes set, the usual qualification assumption) makes the
    wheels stick by friction both across (x) and along (y) the rail, else they roll freely
    along it (friction across only). ``contact`` is how a wheel's vertices act on its rail:
    ``"nodes"`` (default), each on the rail vertex it touches at t = 0, which follows a slip
    of half the rail's vertex spacing; ``"surface"``, on the rail top's triangles (and the
    flanges on the rail sides), paired again as the wheel slides, up to the end of the
    explicit rail zone (``model.zone_margin`` past the wheel at each end)."""

    friction: NonNegativeFloat = 0.0
    braked: bool = True
    contact: Literal["nodes", "surface"] = "nodes"


class Time(Section):
    """End time and step: ``dt`` in seconds or ``dt_factor`` times the critical explicit step;
    ``mass_scaling``: the stable step (s) every vertex is brought to by adding mass to the
    cells around it (crane_fem.mass_scaling; crane and gmsh models)."""

    end: PositiveFloat
    dt: PositiveFloat | None = None
    dt_factor: PositiveFloat | None = None
    mass_scaling: PositiveFloat | None = None

    @model_validator(mode="after")
    def _one_step_spec(self) -> Time:
        if (self.dt is None) == (self.dt_factor is None):
            raise ValueError("give exactly one of time.dt (seconds) or time.dt_factor")
        return self


class Integrator(Section):
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


class Output(Section):
    """What is written and how often. The run is sampled on one physical interval,
    ``sample_interval`` (s; default the macro step ΔT = ratio × Δt, rounded to a whole number
    of macro steps), the same instants in every method: history rows every ``every``
    samples, XDMF frames every ``xdmf_every``, the bridge's stress and the support reactions
    every ``stress_every``, the measured points at every sample. The supports' peak forces are
    read between the samples too: at every macro step of a coupled run, every
    ``peak_interval`` (s) in a monolithic one."""

    sample_interval: PositiveFloat | None = None
    #: A monolithic run's supports' peaks are read every this interval (s), rounded to whole
    #: micro steps (at least one): about 17 readings a period of a 4 kHz ringing, the fastest
    #: a crane's face rings at after a landing, whose peak they then read to 2 % of its
    #: amplitude (docs/user-guide.md §8).
    peak_interval: PositiveFloat = 1.5e-5
    every: PositiveInt = 1
    xdmf: bool = True
    xdmf_every: PositiveInt | None = None
    #: Crane: the bridge's peak von Mises stress and the support reactions are evaluated
    #: every this many samples.
    stress_every: PositiveInt = 1
    #: The supports' peak forces also low-passed at this frequency (Hz; none: not): a
    #: 4th-order Butterworth run forward and backward (zero phase) over the reactions'
    #: samples, at least ten a period of the cut-off. After a landing a face rings at
    #: 1–4 kHz, a band the beam models do not resolve as a solid does
    #: (benchmarks/out/supports_band.md).
    support_lowpass_hz: PositiveFloat | None = None
    progress: bool | Literal["auto"] = "auto"
    #: Write the full state every this many samples (``crane-fem run --restart OUTDIR``
    #: continues from the latest one); scenes with subdomains only.
    checkpoint_every: PositiveInt | None = None


class Spectra(Section):
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


class Monitor(Section):
    """Divergence detection: stop when the kinetic energy exceeds ``energy_growth`` times the
    energy supplied (initial energy + |external work|)."""

    energy_growth: Annotated[float, Field(gt=1)] = 10.0
