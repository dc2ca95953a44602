"""How far each wheel slides on its rail, and the reach of its node-to-node contact pairs.

A wheel/rail pair joins a wheel vertex to the rail vertex below it, chosen once, from the mesh:
the pair holds while the two stay close in the rail's plane. Once a wheel has slid, along or
across its rail, by half the spacing of its patch's vertices, its vertices face other rail
vertices than their pairs, and the contact no longer describes the wheel on its rail. The run
then stops with an error naming the wheel, its slip and that reach, instead of running on.

The slip of a wheel is the mean over its pairs of the wheel vertex's displacement relative to
the rail vertex, in x (across the rail) and y (along it); the largest pair's is checked
against the reach.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import CraneFemError
from crane_fem.subdomains import Subdomain

__all__ = ["SlipError", "WheelSlip", "pair_reach"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class SlipError(CraneFemError):
    """A wheel slid further than its contact pairs can follow."""


def pair_reach(rail_xy: FloatArray) -> float:
    """Half the smallest distance between two distinct vertices of a rail patch (m), from
    their (x, y) coordinates (n, 2), n ≥ 2."""
    d = np.linalg.norm(rail_xy[:, None, :] - rail_xy[None, :, :], axis=-1)
    d[np.diag_indices_from(d)] = np.inf
    return 0.5 * float(d.min())


class WheelSlip:
    """The slip of each wheel on its rail, followed at every macro step (collective over the
    explicit subdomain's communicator; the values are global, the same on every rank).

    Args:
        sub: the explicit subdomain (it holds both vertices of every pair).
        pairs: (n, 2) global parent vertex ids, (wheel vertex, rail vertex).
        wheel: (n,) wheel number (1–4) of each pair.
        reach: (4,) the reach of each wheel's pairs (m), :func:`pair_reach` of its patch.
        enforce: stop a wheel beyond its reach (node-to-node pairs); False: the reach is
            reported only (node-to-surface contacts stop the run themselves).
    """

    def __init__(
        self,
        sub: Subdomain,
        pairs: IntArray,
        wheel: IntArray,
        reach: FloatArray,
        enforce: bool = True,
    ):
        self.enforce = enforce
        self.comm = sub.submesh.comm
        self.bs = sub.bs
        self.wheel = np.asarray(wheel, dtype=np.int64)
        self.n_wheels = int(self.wheel.max(initial=0))
        self.reach = np.asarray(reach, dtype=np.float64)
        ids = pairs.ravel()
        order = np.argsort(ids, kind="stable")
        blocks, pos = sub.owned_dofs_of(ids[order])
        # Where each owned vertex of the pairs sits in the flattened (n, 2) list.
        self._blocks = blocks
        self._slot = order[pos]
        self._n = ids.size
        self.peak = np.zeros((self.n_wheels, 2))  # |across|, |along|
        self.t_peak = np.zeros((self.n_wheels, 2))
        self.peak_pair = np.zeros(self.n_wheels)

    def update(self, t: float, u: FloatArray) -> FloatArray:
        """The mean slip (x, y) of each wheel at ``t`` for the explicit side's owned field
        ``u`` (collective); keeps the peaks.

        Raises:
            SlipError: a pair slid beyond its wheel's reach (on every rank).
        """
        vals = np.zeros((self._n, 2))
        uu = u.reshape(-1, self.bs)[self._blocks, :2]
        vals[self._slot] = uu
        vals = self.comm.allreduce(vals, op=MPI.SUM).reshape(-1, 2, 2)
        rel = vals[:, 0, :] - vals[:, 1, :]  # wheel vertex − rail vertex, (n, 2)
        slip = np.zeros((self.n_wheels, 2))
        worst = np.zeros(self.n_wheels)
        for k in range(self.n_wheels):
            mine = self.wheel == k + 1
            slip[k] = rel[mine].mean(axis=0)
            worst[k] = float(np.linalg.norm(rel[mine], axis=1).max())
        mag = np.abs(slip)
        better = mag > self.peak
        self.peak[better] = mag[better]
        self.t_peak[better] = np.broadcast_to(t, better.shape)[better]
        np.maximum(self.peak_pair, worst, out=self.peak_pair)
        over = np.flatnonzero(worst > self.reach)
        if over.size and self.enforce:
            k = int(over[0])
            raise SlipError(
                f"wheel {k + 1} slid {worst[k] * 1e3:.2f} mm on its rail at t = {t:.6g} s "
                f"(across {slip[k, 0] * 1e3:+.2f} mm, along {slip[k, 1] * 1e3:+.2f} mm), "
                f"beyond the {self.reach[k] * 1e3:.2f} mm its node-to-node contact pairs "
                "can follow (half their spacing); the trolley is held on its rails only by "
                "wheel.friction (braked: wheel.braked) and, across them, by model.flanges"
            )
        return slip

    def table(self) -> dict[str, dict[str, Any]]:
        """Per wheel: the largest slip across (x) and along (y) its rail with their times,
        the largest pair's, and the reach (m)."""
        return {
            str(k + 1): {
                "max_slip_across_m": float(self.peak[k, 0]),
                "max_slip_across_time_s": float(self.t_peak[k, 0]),
                "max_slip_along_m": float(self.peak[k, 1]),
                "max_slip_along_time_s": float(self.t_peak[k, 1]),
                "max_pair_slip_m": float(self.peak_pair[k]),
                "slip_reach_m": float(self.reach[k]),
            }
            for k in range(self.n_wheels)
        }

    def state_dict(self) -> dict[str, Any]:
        """The peaks (a checkpoint)."""
        return {"peak": self.peak.copy(), "t_peak": self.t_peak.copy(), "pair": self.peak_pair}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peak = np.array(state["peak"], dtype=np.float64)
        self.t_peak = np.array(state["t_peak"], dtype=np.float64)
        self.peak_pair = np.array(state["pair"], dtype=np.float64)
