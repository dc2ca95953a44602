"""The motion the run measures for response spectra: the input ground acceleration vector and
the absolute acceleration at named points of the structure (in-structure, or floor, motion).

A point is the mesh vertex nearest the given coordinates, read on the explicit side when that
side holds it, else on the implicit side (a few rows of a reduced side's basis). It is sampled
every sampling interval δ; its acceleration is the second difference of its displacement,
(u_k − 2 u_k−1 + u_k−2) / δ², plus the ground's acceleration weighted alike (¼, ½, ¼): the
relative formulation's motion is relative to the ground. That is the exact mean over the
interval of the mean velocity (a triangle filter of width 2δ, centred on t_k−1): the crane's
impacts leave ringing far above the sampling's Nyquist frequency (1–100 kHz at a clamped face),
which an instantaneous velocity or acceleration would fold into the spectra's band; the
second difference keeps it out, the same way in every method (benchmarks/RESULTS.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.loading.body import GroundMotionHistory
from crane_fem.scenario import CraneModel, Scenario
from crane_fem.subdomains import Subdomain

__all__ = ["GroundAcceleration", "PointMotions", "check_points", "default_points"]

#: A measured point farther from the mesh than this fraction of its bounding box's diagonal
#: is refused (a typo, or another unit): its nearest vertex would be somewhere else.
POINT_REACH = 0.05

FloatArray = npt.NDArray[np.float64]


class GroundAcceleration:
    """a_g(t) as a vector (m/s²): the sum of the scenario's ground motions along their
    directions (not collective)."""

    def __init__(self, sc: Scenario) -> None:
        from crane_fem.pipeline.loads import ground_motion

        self.parts: list[tuple[GroundMotionHistory, FloatArray]] = []
        for gm in sc.loading.ground_motions:
            d = np.asarray(gm.direction, dtype=np.float64)
            self.parts.append((ground_motion(gm), d / np.linalg.norm(d)))

    def __bool__(self) -> bool:
        return bool(self.parts)

    def __call__(self, t: float) -> FloatArray:
        a = np.zeros(3)
        for history, d in self.parts:
            a += history(t) * d
        return a

    def at(self, times: FloatArray) -> FloatArray:
        """a_g at many times (n, 3): the values of :meth:`__call__`, in one call."""
        a = np.zeros((times.size, 3))
        for history, d in self.parts:
            a += history.at(times)[:, None] * d[None, :]
        return a


def check_points(points: dict[str, list[float]], xyz: FloatArray, comm: MPI.Comm) -> None:
    """Refuse a point farther from every vertex than :data:`POINT_REACH` × the mesh's
    diagonal (collective: ``xyz`` this rank's vertices, (n, 3); the same one line on every
    rank)."""
    if not points:
        return
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    comm.Allreduce(np.min(xyz, axis=0) if xyz.size else lo.copy(), lo, op=MPI.MIN)
    comm.Allreduce(np.max(xyz, axis=0) if xyz.size else hi.copy(), hi, op=MPI.MAX)
    reach = POINT_REACH * float(np.linalg.norm(hi - lo))
    for name, where in points.items():
        d = np.linalg.norm(xyz - np.asarray(where)[None, :], axis=1)
        dist = comm.allreduce(float(np.min(d)) if d.size else np.inf, op=MPI.MIN)
        if dist > reach:
            raise ScenarioError(
                f"spectra.points.{name} = {list(where)}: {dist:.3g} m from the nearest point of "
                f"the structure (more than {reach:.3g} m, 5 % of its extent): a point on the "
                "structure is expected (metres, z up)"
            )


def default_points(sc: Scenario) -> dict[str, list[float]]:
    """The scenario's ``[spectra] points``, or for a crane: the trolley frame's centre (top),
    wheel 1's centre and the top of end carriage 1 under girder 1 (the girder's support)."""
    if sc.spectra.points:
        return {k: list(v) for k, v in sc.spectra.points.items()}
    if not isinstance(sc.model, CraneModel):
        return {}
    geo = sc.model.geometry()
    x1, y1 = geo.wheel_centres()[0]
    top = geo.rail_top + geo.wheel_height
    return {
        "trolley": [0.0, geo.trolley_position, top + geo.frame_thickness],
        "wheel_1": [x1, y1, geo.rail_top + 0.5 * geo.wheel_height],
        "support_1": [
            -0.5 * geo.girder_spacing,
            0.5 * geo.end_carriage_width,
            geo.end_carriage_height,
        ],
    }


@dataclass
class _Point:
    name: str
    side: str  # "explicit" or "implicit"
    blocks: npt.NDArray[np.int64]  # the owned block on this rank (0 or 1 entries)
    distance: float


class PointMotions:
    """Absolute accelerations of named points, sampled by :meth:`sample` (collective over
    the mesh communicator; the samples are global values, the same on every rank).

    Args:
        points: name → coordinates (m).
        explicit, implicit: the subdomains (either may be None).
        vertex_xyz: coordinates of the parent mesh's owned vertices (n, 3) and their global
            ids ``vertex_ids`` (the index map's).
        ground: the ground acceleration.
    """

    def __init__(
        self,
        points: dict[str, list[float]],
        explicit: Subdomain | None,
        implicit: Subdomain | None,
        vertex_xyz: FloatArray,
        vertex_ids: npt.NDArray[np.int64],
        ground: GroundAcceleration,
        comm: MPI.Comm,
    ) -> None:
        self.comm, self.ground = comm, ground
        self.points: list[_Point] = []
        for name, where in points.items():
            d = np.linalg.norm(vertex_xyz - np.asarray(where)[None, :], axis=1)
            k = int(np.argmin(d)) if d.size else -1
            # Ties (a symmetric mesh) go to the lowest coordinates, whatever the partition.
            mine = (
                (round(float(d[k]), 12), *vertex_xyz[k].tolist(), int(vertex_ids[k]))
                if k >= 0
                else (np.inf, 0.0, 0.0, 0.0, -1)
            )
            best = min(comm.allgather(mine))
            dist, gid = float(best[0]), int(best[-1])
            vid = np.array([gid], dtype=np.int64)
            side, blocks = "implicit", np.zeros(0, dtype=np.int64)
            for label, sub in (("explicit", explicit), ("implicit", implicit)):
                if sub is None:
                    continue
                b, _ = sub.owned_dofs_of(vid)
                if comm.allreduce(int(b.size), op=MPI.SUM):
                    side, blocks = label, b
                    break
            self.points.append(_Point(name, side, blocks, dist))
        any_side = explicit if explicit is not None else implicit
        self.bs = bs = any_side.bs if any_side is not None else 3
        #: The translations of a node's block (a beam's node also has 3 rotations).
        self.nc = nc = min(bs, 3)
        dofs = [
            p.blocks[0] * bs + np.arange(nc)
            for p in self.points
            if p.side == "implicit" and p.blocks.size
        ]
        self._implicit_dofs = (
            np.concatenate(dofs).astype(np.int64) if dofs else np.zeros(0, dtype=np.int64)
        )
        self.t: list[float] = []
        self.acc: list[FloatArray] = []
        #: The last two samples' displacements and times (the second difference's).
        self._u_prev: list[FloatArray] = []
        self._t_prev: list[float] = []

    def ground_row(self, t: float) -> dict[str, float]:
        """The ground acceleration's columns at ``t`` (not collective)."""
        if not self.ground:
            return {}
        ag = self.ground(t)
        return {f"ground_a{c}": float(ag[i]) for i, c in enumerate("xyz"[: self.nc])}

    @property
    def columns(self) -> list[str]:
        axes = "xyz"[: self.nc]
        cols = [f"ground_a{c}" for c in axes] if self.ground else []
        return cols + [f"{p.name}_a{c}" for p in self.points for c in axes]

    @property
    def implicit_dofs(self) -> npt.NDArray[np.int64]:
        """The owned DOFs of the implicit side's points on this rank, point by point (their
        translations)."""
        return self._implicit_dofs

    def sample(
        self,
        t: float,
        u_explicit: FloatArray | None,
        u_implicit_dofs: FloatArray | None,
    ) -> dict[str, float]:
        """Sample the points' displacements at ``t`` (the explicit side's owned field, the
        implicit side's at :attr:`implicit_dofs`) and return the row values of the points'
        columns: each point's absolute acceleration centred one sampling interval earlier
        (the ground's alone until three samples are taken) (collective)."""
        bs, nc = self.bs, self.nc
        disp = np.zeros((len(self.points), nc))
        k = 0
        for i, p in enumerate(self.points):
            if not p.blocks.size:
                continue
            if p.side == "explicit" and u_explicit is not None:
                disp[i] = u_explicit.reshape(-1, bs)[p.blocks[0], :nc]
            elif p.side == "implicit" and u_implicit_dofs is not None:
                disp[i] = u_implicit_dofs[k : k + nc]
                k += nc
        disp = self.comm.allreduce(disp, op=MPI.SUM)
        if len(self._u_prev) < 2:
            at = t
            acc = np.tile(self.ground(t)[:nc], (len(self.points), 1))
        else:
            (u2, u1), (t2, t1) = self._u_prev, self._t_prev
            h = 0.5 * (t - t2)
            ag = 0.25 * (self.ground(t2) + 2.0 * self.ground(t1) + self.ground(t))[:nc]
            acc = (disp - 2.0 * u1 + u2) / (h * h) + ag[None, :]
            at = t1
        self._u_prev = [*self._u_prev[-1:], disp]
        self._t_prev = [*self._t_prev[-1:], t]
        if self.t and self.t[-1] == at:  # the ground's alone at t_k−1 gives way
            self.t[-1], self.acc[-1] = at, acc.copy()
        else:
            self.t.append(at)
            self.acc.append(acc.copy())
        row: dict[str, float] = {}
        for i, p in enumerate(self.points):
            for j, c in enumerate("xyz"[:nc]):
                row[f"{p.name}_a{c}"] = float(acc[i, j])
        return row

    def state_dict(self) -> dict[str, Any]:
        """The samples so far and the last two displacements (a checkpoint; global
        values)."""
        shape = (len(self.t), len(self.points), self.nc)
        out: dict[str, Any] = {"t": np.asarray(self.t, dtype=np.float64)}
        out["acc"] = np.asarray(self.acc, dtype=np.float64).reshape(shape)
        out["u_prev"] = np.asarray(self._u_prev, dtype=np.float64)
        out["t_prev"] = np.asarray(self._t_prev, dtype=np.float64)
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.t = [float(x) for x in state["t"]]
        self.acc = [np.array(a, dtype=np.float64) for a in state["acc"]]
        self._u_prev = [np.array(u, dtype=np.float64) for u in state["u_prev"]]
        self._t_prev = [float(x) for x in state["t_prev"]]

    def series(self) -> tuple[FloatArray, dict[str, FloatArray]]:
        """The sample times and, per column name, its samples (ground included)."""
        t = np.asarray(self.t)
        nc = self.nc
        acc = np.asarray(self.acc).reshape(len(self.t), len(self.points), nc)
        out: dict[str, FloatArray] = {}
        if self.ground:
            g = np.array([self.ground(s)[:nc] for s in self.t]).reshape(-1, nc)
            for j, c in enumerate("xyz"[:nc]):
                out[f"ground_a{c}"] = g[:, j]
        for i, p in enumerate(self.points):
            for j, c in enumerate("xyz"[:nc]):
                out[f"{p.name}_a{c}"] = acc[:, i, j]
        return t, out
