"""Meshes: 1D bars (one or several disjoint segments on the x axis) as dolfinx interval meshes."""

from __future__ import annotations

from dataclasses import dataclass

import basix.ufl
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

__all__ = ["BarMesh", "Segment", "create_bar_mesh"]


@dataclass(frozen=True)
class Segment:
    """One bar: ``[x0, x0 + length]`` cut into ``elements`` equal P1 elements of area ``area``."""

    x0: float
    length: float
    elements: int
    area: float = 1.0

    @property
    def h(self) -> float:
        return self.length / self.elements


@dataclass
class BarMesh:
    """A dolfinx interval mesh of disjoint segments and the input numbering behind it.

    Input node ``first_node[s] + i`` is node i (from the left) of segment s; input cell
    ``first_cell[s] + e`` is its element e.
    """

    mesh: dolfinx.mesh.Mesh
    segments: list[Segment]
    first_node: npt.NDArray[np.int64]
    first_cell: npt.NDArray[np.int64]

    def segment_of_cell(self, input_cells: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """Segment index of each input cell index."""
        return np.searchsorted(self.first_cell, input_cells, side="right") - 1

    def segment_of_node(self, input_nodes: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """Segment index of each input node index."""
        return np.searchsorted(self.first_node, input_nodes, side="right") - 1


def create_bar_mesh(comm: MPI.Comm, segments: list[Segment]) -> BarMesh:
    """Create the interval mesh of ``segments`` (collective over ``comm``).

    Rank 0 provides the cells and nodes; dolfinx partitions them over ``comm``.
    """
    nodes_per = np.array([s.elements + 1 for s in segments], dtype=np.int64)
    cells_per = np.array([s.elements for s in segments], dtype=np.int64)
    first_node = np.concatenate([[0], np.cumsum(nodes_per)[:-1]]).astype(np.int64)
    first_cell = np.concatenate([[0], np.cumsum(cells_per)[:-1]]).astype(np.int64)
    if comm.rank == 0:
        x = np.concatenate(
            [s.x0 + s.length * np.arange(s.elements + 1) / s.elements for s in segments]
        ).reshape(-1, 1)
        cells = np.concatenate(
            [
                np.column_stack([f + np.arange(s.elements), f + 1 + np.arange(s.elements)])
                for s, f in zip(segments, first_node, strict=True)
            ]
        ).astype(np.int64)
    else:
        x = np.zeros((0, 1), dtype=np.float64)
        cells = np.zeros((0, 2), dtype=np.int64)
    domain = ufl.Mesh(basix.ufl.element("Lagrange", "interval", 1, shape=(1,)))
    mesh = dolfinx.mesh.create_mesh(comm, cells, domain, x)
    return BarMesh(mesh, list(segments), first_node, first_cell)
