"""A whole scenario file: its sections, and the checks that look across them."""

# Pydantic copies a field's default into each instance; ruff cannot see across modules that
# Section is a pydantic model.
# ruff: noqa: RUF012

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

from pydantic import Field, model_validator

from crane_fem.errors import ScenarioError
from crane_fem.scenario.base import Section
from crane_fem.scenario.coupling import (
    ADAPTIVE_KEYS,
    ADAPTIVE_METHODS,
    HYBRID_KEYS,
    OPERATOR_KEYS,
    SOLVED_INTERFACE_METHODS,
    Coupling,
    NewmarkParams,
    SubdomainSpec,
)
from crane_fem.scenario.frame import BeamSection, FrameModel, LineContact, PlaneContact, Rope
from crane_fem.scenario.frame_crane import FrameCraneModel
from crane_fem.scenario.loading import Loading
from crane_fem.scenario.model import BarModel, BlockModel, BoxBeamModel, CraneModel, GmshModel
from crane_fem.scenario.sections import (
    Contact,
    GroupMass,
    GroupMaterial,
    Initial,
    Integrator,
    Joint,
    Material,
    Monitor,
    Output,
    Spectra,
    Support,
    SurfaceContact,
    Time,
    Wheel,
)

__all__ = ["Scenario"]


#: m/s: the plausible range of a structure's bar wave speed √(E/ρ) in SI units.
WAVE_SPEED = (20.0, 20000.0)


class Scenario(Section):
    """A whole scenario file."""

    name: str = "scenario"
    model: Annotated[
        BarModel
        | BoxBeamModel
        | CraneModel
        | BlockModel
        | GmshModel
        | FrameModel
        | FrameCraneModel,
        Field(discriminator="kind"),
    ]
    material: Material | list[GroupMaterial]
    initial: Initial = Initial()
    contact: list[
        Annotated[
            Contact | SurfaceContact | LineContact | PlaneContact, Field(discriminator="type")
        ]
    ] = []
    support: list[Support] = []
    mass: list[GroupMass] = []
    section: list[BeamSection] = []
    joint: list[Joint] = []
    rope: list[Rope] = []
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
            bool(self.subdomain)
            or self.coupling is not None
            or isinstance(self.model, BlockModel | GmshModel | FrameModel | FrameCraneModel)
        )

    @property
    def materials(self) -> list[tuple[list[str] | None, Material]]:
        """(volume groups, material) of each material; groups None: every group."""
        if isinstance(self.material, Material) and not isinstance(self.material, GroupMaterial):
            return [(None, self.material)]
        assert isinstance(self.material, list)
        return [(list(m.groups), m) for m in self.material]

    @property
    def uniform_material(self) -> Material:
        """The one material of a scene with a single ``[material]`` (every model kind but
        'gmsh' has one: the validation refuses a list there)."""
        assert isinstance(self.material, Material), "material: one table expected"
        return self.material

    @property
    def rayleigh_coefficients(self) -> tuple[float, float]:
        """(alpha, beta) of C = alpha M + beta K: the materials' (they agree)."""
        return self.materials[0][1].rayleigh_coefficients

    @model_validator(mode="after")
    def _gmsh_groups(self) -> Scenario:
        mdl = self.model
        own = isinstance(mdl, GmshModel | FrameModel)
        if not own and isinstance(self.material, list):
            raise ValueError(
                "material: [[material]] entries (one per set of groups) apply to model.kind "
                f"'gmsh' and 'frame'; model.kind {mdl.kind!r} takes one [material] table"
            )
        mixed = isinstance(mdl, GmshModel) and mdl.mixed
        if self.joint and not mixed:
            raise ValueError(
                "joint: [[joint]] ties a beam to a solid: it applies to model.kind 'gmsh' with "
                "line groups (beams) beside its volume groups"
            )
        if mixed:
            assert isinstance(mdl, GmshModel)
            if self.rope:
                raise ValueError("rope: [[rope]] applies to model.kind 'frame'")
            return self._mixed_groups(mdl)
        if not isinstance(mdl, FrameModel):
            for key in ("section", "rope"):
                if getattr(self, key):
                    raise ValueError(
                        f"{key}: [[{key}]] applies to model.kind 'frame', not {mdl.kind!r}"
                    )
            for i, sup in enumerate(self.support):
                if sup.dofs != "clamped":
                    raise ValueError(
                        f"support[{i}].dofs: {sup.dofs!r} applies to a frame's point supports "
                        "(a solid's face is clamped)"
                    )
            for i, ms in enumerate(self.mass):
                if ms.inertia is not None:
                    raise ValueError(
                        f"mass[{i}].inertia: rotary inertia applies to a frame's point masses"
                    )
        if isinstance(mdl, FrameModel):
            return self._frame_groups(mdl)
        if not own:
            for key, given in (("support", self.support), ("mass", self.mass)):
                if given:
                    raise ValueError(
                        f"{key}: [[{key}]] applies to model.kind 'gmsh' and 'frame' (named "
                        f"groups of your own mesh), not {mdl.kind!r}"
                    )
            for i, c in enumerate(self.contact):
                if c.type == "surface":
                    raise ValueError(
                        f"contact[{i}].type: 'surface' applies to model.kind 'gmsh' (the "
                        f'crane\'s wheels take wheel.contact = "surface"), not {mdl.kind!r}'
                    )
                if c.type in ("point-on-line", "point-on-plane"):
                    raise ValueError(
                        f"contact[{i}].type: {c.type!r} applies to model.kind 'frame', not "
                        f"{mdl.kind!r}"
                    )
            return self
        assert isinstance(mdl, GmshModel)
        volumes, surfaces = mdl.volume_groups, mdl.surface_groups
        where = f"(in {Path(mdl.mesh).name}: {', '.join(surfaces) or 'none'})"
        if isinstance(self.material, list):
            seen: dict[str, int] = {}
            for i, m in enumerate(self.material):
                for g in m.groups:
                    if g not in volumes:
                        raise ValueError(
                            f"material[{i}].groups: {g!r} is not a named volume group (in "
                            f"{Path(mdl.mesh).name}: {', '.join(volumes)})"
                        )
                    if g in seen:
                        raise ValueError(
                            f"material[{i}].groups: {g!r} already has material[{seen[g]}]"
                        )
                    seen[g] = i
                if m.rayleigh_coefficients != self.material[0].rayleigh_coefficients:
                    raise ValueError(
                        f"material[{i}]: its damping differs from material[0]'s; the damping "
                        "C = αM + βK is one per scene (give every entry the same rayleigh or "
                        "damping)"
                    )
            missing = [g for g in volumes if g not in seen]
            if missing:
                raise ValueError(f"material: volume groups {missing} have no [[material]] entry")
        for i, sup in enumerate(self.support):
            if sup.group not in surfaces:
                raise ValueError(
                    f"support[{i}].group: {sup.group!r} is not a named surface group {where}"
                )
        for i, ms in enumerate(self.mass):
            if ms.group not in volumes:
                raise ValueError(
                    f"mass[{i}].group: {ms.group!r} is not a named volume group (in "
                    f"{Path(mdl.mesh).name}: {', '.join(volumes)})"
                )
        labels = []
        for i, c in enumerate(self.contact):
            if c.type != "surface":
                raise ValueError(
                    f"contact[{i}].type: model.kind 'gmsh' takes contacts of type 'surface' "
                    f"(points on the triangles of another group), not {c.type!r}"
                )
            for key in ("points", "surface"):
                if getattr(c, key) not in surfaces:
                    raise ValueError(
                        f"contact[{i}].{key}: {getattr(c, key)!r} is not a named surface group "
                        f"{where}"
                    )
            if c.points == c.surface:
                raise ValueError(
                    f"contact[{i}]: points and surface are the same group {c.points!r}"
                )
            labels.append(c.label)
        twice = sorted({n for n in labels if labels.count(n) > 1})
        if twice:
            raise ValueError(
                f"contact: two contacts are named {twice[0]!r} (give each its own name)"
            )
        self._initial_velocity_only()
        if not self.subdomain and self.coupling is None:
            if self.integrator.scheme != "cd-lagrange":
                raise ValueError(
                    f"integrator.scheme: model.kind 'gmsh' without [[subdomain]] runs one "
                    f"explicit 'cd-lagrange' body, not {self.integrator.scheme!r}"
                )
        return self

    def _mixed_groups(self, mdl: GmshModel) -> Scenario:
        """A gmsh model of solids and beams: volume and line groups take materials, line
        groups sections; supports are surface groups (clamped) or point groups; joints tie
        a point group to a surface group; the solids run explicit and the beams implicit
        (issue 33: CD-Lagrange zones with contact, Newmark or its reduced form on the
        beams), from rest or a uniform velocity."""
        volumes, surfaces = mdl.volume_groups, mdl.surface_groups
        lines, points = mdl.line_groups, mdl.point_groups
        fname = Path(mdl.mesh).name

        def need(key: str, g: str, kind: str, names: list[str]) -> None:
            if g not in names:
                raise ValueError(
                    f"{key}: {g!r} is not a named {kind} group (in {fname}: "
                    f"{', '.join(names) or 'none'})"
                )

        self._sections_and_materials(
            lambda key, g: need(key, g, "line", lines),
            lambda key, g: need(key, g, "volume or line", volumes + lines),
            lines,
            volumes + lines,
            {},
            "groups",
        )
        for i, sup in enumerate(self.support):
            need(f"support[{i}].group", sup.group, "surface or point", surfaces + points)
            if sup.group in surfaces and sup.dofs != "clamped":
                raise ValueError(
                    f"support[{i}].dofs: {sup.dofs!r} applies to a beam's point supports (a "
                    "solid's face is clamped)"
                )
        for i, ms in enumerate(self.mass):
            need(f"mass[{i}].group", ms.group, "volume or point", volumes + points)
            if ms.inertia is not None and ms.group not in points:
                raise ValueError(
                    f"mass[{i}].inertia: rotary inertia applies to a beam's point masses"
                )
        labels = []
        for i, c in enumerate(self.contact):
            if c.type != "surface":
                raise ValueError(
                    f"contact[{i}].type: a mixed gmsh model's contacts are between its solids, "
                    f"type 'surface', not {c.type!r}"
                )
            need(f"contact[{i}].points", c.points, "surface", surfaces)
            need(f"contact[{i}].surface", c.surface, "surface", surfaces)
            labels.append(c.label)
        twice = sorted({n for n in labels if labels.count(n) > 1})
        if twice:
            raise ValueError(f"contact: two contacts are named {twice[0]!r}")
        if not self.joint:
            raise ValueError(
                f"joint: {fname} holds beams (line groups {', '.join(lines)}) beside solids: "
                'tie them by [[joint]] entries (face = "<surface group>", node = "<point '
                'group>")'
            )
        faces: dict[str, int] = {}
        nodes: dict[str, int] = {}
        for i, j in enumerate(self.joint):
            need(f"joint[{i}].face", j.face, "surface", surfaces)
            need(f"joint[{i}].node", j.node, "point", points)
            for key, name, used in (("face", j.face, faces), ("node", j.node, nodes)):
                if name in used:
                    raise ValueError(
                        f"joint[{i}].{key}: {name!r} is already joint[{used[name]}]'s (one "
                        "joint per face and per node)"
                    )
                used[name] = i
        self._initial_velocity_only()
        if (
            self.coupling is not None
            and self.coupling.method == "monolithic"
            and self.coupling.monolithic_scheme != "cd-lagrange"
        ):
            raise ValueError(
                "coupling.scheme: a mixed model's monolithic run is fully explicit ('cd-lagrange'"
                ": its solids carry the contacts, its beams the central difference)"
            )
        if self.coupling is not None and self.coupling.interface_truncation:
            raise ValueError(
                "coupling.interface_truncation: not with joints (a joint's six rows share "
                "its face's DOFs: the operator is kept whole)"
            )
        if not self.subdomain:
            raise ValueError(
                "subdomain: a mixed model needs [[subdomain]] entries: its volume groups in "
                "an explicit 'cd-lagrange' subdomain, its line groups in one 'newmark' "
                "(or 'newmark-reduced') subdomain"
            )
        for i, sd in enumerate(self.subdomain):
            solid = [g for g in sd.groups if g in volumes]
            if solid and len(solid) < len(sd.groups):
                raise ValueError(
                    f"subdomain[{i}].groups: mixes volume groups {solid} with line groups (a "
                    "subdomain is one element kind)"
                )
            if solid and sd.scheme != "cd-lagrange":
                raise ValueError(
                    f"subdomain[{i}].scheme: the solids run 'cd-lagrange' (their contacts), "
                    f"not {sd.scheme!r}"
                )
            if not solid and sd.scheme == "cd-lagrange":
                raise ValueError(
                    f"subdomain[{i}].scheme: the beams run 'newmark' or 'newmark-reduced' "
                    "(joined to the solids through their joints), not 'cd-lagrange'"
                )
        return self

    def _initial_velocity_only(self) -> None:
        """A structure of the user's own starts from its preload, with at most a uniform
        velocity."""
        extra = sorted(self.initial.model_fields_set - {"velocity", "preload"})
        if extra:
            raise ValueError(
                f"initial.{extra[0]}: model.kind {self.model.kind!r} starts undeformed (in its "
                "static preload under gravity); give its initial.velocity [vx, vy, vz] and "
                "initial.preload only"
            )
        if "velocity" in self.initial.model_fields_set and not isinstance(
            self.initial.velocity, list
        ):
            raise ValueError(
                f"initial.velocity: model.kind {self.model.kind!r} takes a vector [vx, vy, vz] "
                f"(m/s), not a number (got {self.initial.velocity})"
            )

    def _sections_and_materials(
        self,
        line: Callable[[str, str], None],
        cell: Callable[[str, str], None],
        lines: list[str],
        cells: list[str],
        ropes: dict[str, int],
        what: str,
    ) -> None:
        """Every beam line group (``lines``, ropes aside) in one ``[[section]]``, every cell
        group (``cells``) in one ``[[material]]`` of one damping; ``line`` and ``cell`` refuse
        a name that is not such a group; ``what`` names ``cells`` in the refusal."""
        seen: dict[str, int] = {}
        for i, sec in enumerate(self.section):
            for g in sec.groups:
                line(f"section[{i}].groups", g)
                if g in ropes:
                    raise ValueError(
                        f"section[{i}].groups: {g!r} is rope[{ropes[g]}]'s line (a rope is no "
                        "beam: it takes no section)"
                    )
                if g in seen:
                    raise ValueError(f"section[{i}].groups: {g!r} already has section[{seen[g]}]")
                seen[g] = i
        missing = [g for g in lines if g not in seen and g not in ropes]
        if missing:
            raise ValueError(
                f"section: line groups {missing} have no [[section]] entry (each member needs "
                "its cross-section and orientation)"
            )
        if not isinstance(self.material, list):
            return
        owner: dict[str, int] = {}
        for i, m in enumerate(self.material):
            for g in m.groups:
                cell(f"material[{i}].groups", g)
                if g in owner:
                    raise ValueError(
                        f"material[{i}].groups: {g!r} already has material[{owner[g]}]"
                    )
                owner[g] = i
            if m.rayleigh_coefficients != self.material[0].rayleigh_coefficients:
                raise ValueError(
                    f"material[{i}]: its damping differs from material[0]'s; the damping "
                    "C = αM + βK is one per scene"
                )
        lacking = [g for g in cells if g not in owner and g not in ropes]
        if lacking:
            raise ValueError(f"material: {what} {lacking} have no [[material]] entry")

    def _frame_groups(self, mdl: FrameModel) -> Scenario:
        """A frame's entries name its mesh's groups: line groups for sections, materials and
        lines, point groups for supports, masses, points and rope ends."""
        lines, points = mdl.groups, mdl.point_groups
        fname = Path(mdl.mesh).name
        where_l = f"(line groups in {fname}: {', '.join(lines)})"
        where_p = f"(point groups in {fname}: {', '.join(points) or 'none'})"

        def line(key: str, g: str) -> None:
            if g not in lines:
                raise ValueError(f"{key}: {g!r} is not a named line group {where_l}")

        def point(key: str, g: str) -> None:
            if g not in points:
                raise ValueError(f"{key}: {g!r} is not a named point group {where_p}")

        ropes: dict[str, int] = {}
        for i, r in enumerate(self.rope):
            line(f"rope[{i}].line", r.line)
            if r.line in ropes:
                raise ValueError(f"rope[{i}].line: {r.line!r} is already rope[{ropes[r.line]}]")
            ropes[r.line] = i
        self._sections_and_materials(line, line, lines, lines, ropes, "line groups")
        for i, sup in enumerate(self.support):
            point(f"support[{i}].group", sup.group)
        for i, ms in enumerate(self.mass):
            point(f"mass[{i}].group", ms.group)
        labels = []
        for i, c in enumerate(self.contact):
            if c.type not in ("point-on-line", "point-on-plane"):
                raise ValueError(
                    f"contact[{i}].type: model.kind 'frame' takes contacts of type "
                    f"'point-on-line' or 'point-on-plane', not {c.type!r}"
                )
            point(f"contact[{i}].points", c.points)
            if isinstance(c, LineContact):
                line(f"contact[{i}].line", c.line)
            labels.append(c.label)
        labels += [r.label for r in self.rope]
        twice = sorted({n for n in labels if labels.count(n) > 1})
        if twice:
            raise ValueError(
                f"contact: two contacts or ropes are named {twice[0]!r} (give each its own name)"
            )
        self._initial_velocity_only()
        if not self.subdomain and self.coupling is None and self.integrator.scheme != "cd-lagrange":
            raise ValueError(
                f"integrator.scheme: model.kind 'frame' without [[subdomain]] runs one explicit "
                f"'cd-lagrange' body, not {self.integrator.scheme!r}"
            )
        return self

    @model_validator(mode="after")
    def _contacts_and_block(self) -> Scenario:
        mdl = self.model
        block = isinstance(mdl, BlockModel)
        if isinstance(mdl, GmshModel | FrameModel):
            return self
        if isinstance(mdl, FrameCraneModel):
            for key in ("contact", "support", "mass", "section", "rope"):
                if getattr(self, key):
                    raise ValueError(
                        f"{key}: model.kind 'frame_crane' makes its own [[{key}]] entries from "
                        "its geometry keys (write the frame as model.kind 'frame' to give them)"
                    )
            if isinstance(self.material, list):
                raise ValueError("material: model.kind 'frame_crane' takes one [material] table")
            self._initial_velocity_only()
            return self
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
        if not isinstance(mdl, BarModel):
            # SI units: a structure's bar wave speed √(E/ρ) lies between a soft elastomer's
            # (tens of m/s) and beryllium's (13 km/s); E in MPa or ρ in t/mm³ fall far outside.
            for k, (_, mat) in enumerate(self.materials):
                c = math.sqrt(mat.E / mat.rho)
                key = "material" if isinstance(self.material, Material) else f"material[{k}]"
                if not WAVE_SPEED[0] <= c <= WAVE_SPEED[1]:
                    raise ValueError(
                        f"{key}: the wave speed √(E/ρ) = {c:.3g} m/s (E = {mat.E:g}, "
                        f"ρ = {mat.rho:g}) is outside [{WAVE_SPEED[0]:g}, "
                        f"{WAVE_SPEED[1]:g}] m/s: give E in Pa and ρ in kg/m³ (steel: 2.1e11, "
                        "7800)"
                    )
        names = [s.name for s in self.subdomain]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(
                f"[[subdomain]] name {twice[0]!r} is given to {names.count(twice[0])} "
                "subdomains: each needs its own (outputs are named after it)"
            )
        if isinstance(mdl, CraneModel):
            try:
                mdl.geometry().validate()
            except ScenarioError as exc:  # name the scenario key, not the dataclass field
                raise ValueError(str(exc).replace("geometry.", "model.")) from None
            grav = self.loading.gravity
            down = grav[2] < 0.0 and abs(grav[2]) >= 10.0 * max(abs(grav[0]), abs(grav[1]))
            if any(grav) and not down:
                # The static preload presses the trolley onto its rails: gravity along −z.
                raise ValueError(
                    f"loading.gravity = {list(grav)} must point down, along −z (a crane's trolley "
                    "rests on its rails by its weight: z is up, e.g. [0, 0, -9.81]), or be zero"
                )
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
        if cpl is not None and cpl.drift_correction is not None and cpl.method != "gc":
            raise ValueError("coupling.drift_correction applies to method 'gc' only")
        if cpl is not None and cpl.method != "hybrid":
            for key in HYBRID_KEYS:
                if getattr(cpl, key) is not None:
                    raise ValueError(f"coupling.{key} applies to method 'hybrid' only")
        if cpl is not None and cpl.method not in (*ADAPTIVE_METHODS, "monolithic"):
            for key in ADAPTIVE_KEYS:
                if getattr(cpl, key) is not None:
                    raise ValueError(
                        f"coupling.{key} applies to methods {', '.join(ADAPTIVE_METHODS)} only "
                        "(a macro step that refines at impacts)"
                    )
        if cpl is not None and cpl.fine_ratio is not None:
            if cpl.fine_ratio >= cpl.ratio or cpl.ratio % cpl.fine_ratio:
                raise ValueError(
                    f"coupling.fine_ratio = {cpl.fine_ratio} must be smaller than coupling.ratio "
                    f"= {cpl.ratio} and divide it (the fine macro steps tile a coarse one)"
                )
        if cpl is None or cpl.fine_ratio is None:
            for key in ("refine_quiet", "refine_margin"):
                if cpl is not None and getattr(cpl, key) is not None:
                    raise ValueError(
                        f"coupling.{key} tunes a refining macro step: it needs coupling.fine_ratio"
                    )
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
            solid = isinstance(mdl, FrameCraneModel) and mdl.wheel_zones == "solid"
            if cpl is not None and not solid:  # (solid wheel zones make their own)
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
        if self.wheel != Wheel() and not isinstance(self.model, CraneModel | FrameCraneModel):
            raise ValueError(
                "wheel: applies to model.kind 'crane' and 'frame_crane' only (their wheels)"
            )
        if isinstance(self.model, FrameCraneModel) and self.wheel.contact != "nodes":
            raise ValueError(
                "wheel.contact: a frame crane's wheels always slide on their girders' lines "
                "(leave wheel.contact out)"
            )
        solid_zones = isinstance(self.model, FrameCraneModel) and self.model.wheel_zones == "solid"
        if self.time.mass_scaling is not None and not (
            isinstance(self.model, CraneModel | GmshModel) or solid_zones
        ):
            raise ValueError(
                "time.mass_scaling: applies to model.kind 'crane' and 'gmsh' only (their "
                "tetrahedra's densities), and to a frame crane's solid wheel zones"
            )
        return self

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        if self.output.sample_interval is not None and not self.coupled_path:
            raise ValueError(
                "output.sample_interval: scenes with [[subdomain]] or [coupling] only (a 1D "
                "bar writes every output.every steps)"
            )
        if "peak_interval" in self.output.model_fields_set and not self.coupled_path:
            raise ValueError(
                "output.peak_interval: scenes with [[subdomain]] or [coupling] only (a 1D bar "
                "has no supports' reactions)"
            )
        if self.output.support_lowpass_hz is not None and not self.coupled_path:
            raise ValueError(
                "output.support_lowpass_hz: scenes with [[subdomain]] or [coupling] only (a 1D "
                "bar has no supports' reactions)"
            )
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
