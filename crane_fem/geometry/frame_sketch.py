"""A frame's line mesh scripted in gmsh: members between key points, split where another
key point lies on them, named line and point groups, written as a ``.msh`` file.

The frame crane's geometry and the frame tests draw their frames with it; a user may too::

    sketch = FrameSketch()
    sketch.member("girder", (0, 0, 0), (4, 0, 0), size=0.1)
    sketch.points("ends", [(0, 0, 0), (4, 0, 0)])
    sketch.write("frame.msh")
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

__all__ = ["FrameSketch"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class _Member:
    group: str
    a: FloatArray
    b: FloatArray
    size: float


@dataclass
class FrameSketch:
    """Members and named points of a frame (metres). ``tol``: coordinates within it are one
    point."""

    tol: float = 1e-9
    members: list[_Member] = field(default_factory=list)
    groups: dict[str, list[FloatArray]] = field(default_factory=dict)

    def member(
        self,
        group: str,
        a: tuple[float, float, float] | FloatArray,
        b: tuple[float, float, float] | FloatArray,
        size: float | None = None,
        elements: int | None = None,
    ) -> None:
        """A straight member from ``a`` to ``b`` in the line group ``group``, meshed with
        elements of about ``size`` (m) or ``elements`` of them."""
        pa, pb = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        length = float(np.linalg.norm(pb - pa))
        if length <= self.tol:
            raise ValueError(f"member {group!r}: its ends coincide")
        if elements is not None:
            size = length / elements
        if size is None or size <= 0.0:
            raise ValueError(f"member {group!r}: give size or elements")
        self.members.append(_Member(group, pa, pb, float(size)))

    def points(self, group: str, xyz: list[tuple[float, float, float]] | FloatArray) -> None:
        """The named point group ``group`` at the coordinates ``xyz`` (each a mesh node: on a
        member it splits it there)."""
        pts = [np.asarray(p, dtype=np.float64) for p in np.asarray(xyz, dtype=np.float64)]
        self.groups.setdefault(group, []).extend(pts)

    def _key_points(self) -> list[FloatArray]:
        out: list[FloatArray] = []
        for p in [*(m.a for m in self.members), *(m.b for m in self.members)] + [
            q for ps in self.groups.values() for q in ps
        ]:
            if not any(np.linalg.norm(p - q) <= self.tol for q in out):
                out.append(p)
        return out

    def write(self, path: str | Path, solids: Callable[[], None] | None = None) -> Path:
        """Mesh and write the frame (gmsh; not collective: call it on one rank).

        ``solids``: a mixed model's solids, added by a function called once the members are
        meshed, with their model current: it adds the solids' meshes as discrete entities
        (volumes and their named surface groups, node and element tags past the members'),
        which are written with the members (the beams' nodes are not the solids')."""
        import gmsh

        keys = self._key_points()
        gmsh.initialize(interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add("frame")
            geo = gmsh.model.geo
            tags = [geo.addPoint(*p.tolist()) for p in keys]

            def tag_of(p: FloatArray) -> int:
                d = [float(np.linalg.norm(p - q)) for q in keys]
                return tags[int(np.argmin(d))]

            lines: dict[str, list[int]] = {}
            for m in self.members:
                axis = m.b - m.a
                length = float(np.linalg.norm(axis))
                # The key points on the member, in order along it.
                s = [
                    float(np.dot(p - m.a, axis) / length**2)
                    for p in keys
                    if np.linalg.norm(np.cross(p - m.a, axis)) <= self.tol * length
                ]
                s = sorted({round(x, 12) for x in s if -1e-12 <= x <= 1.0 + 1e-12})
                for s0, s1 in itertools.pairwise(s):
                    p0, p1 = m.a + s0 * axis, m.a + s1 * axis
                    line = geo.addLine(tag_of(p0), tag_of(p1))
                    n = max(1, round((s1 - s0) * length / m.size))
                    geo.mesh.setTransfiniteCurve(line, n + 1)
                    lines.setdefault(m.group, []).append(line)
            geo.synchronize()
            for name, ls in lines.items():
                gmsh.model.addPhysicalGroup(1, ls, name=name)
            for name, ps in self.groups.items():
                gmsh.model.addPhysicalGroup(0, sorted({tag_of(p) for p in ps}), name=name)
            gmsh.model.mesh.generate(1)
            if solids is not None:
                solids()
            out = Path(path)
            out.parent.mkdir(parents=True, exist_ok=True)
            gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
            gmsh.write(str(out))
        finally:
            gmsh.finalize()
        return out
