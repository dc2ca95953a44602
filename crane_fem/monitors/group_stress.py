"""The peak von Mises stress of each volume group of a gmsh model as a macro-step monitor (the
general case of the crane's bridge stress: a part an engineer signs off)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from mpi4py import MPI

from crane_fem.coupling import MacroRecord
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.pipeline import Simulation
from crane_fem.scenario import FrameModel, GmshModel
from crane_fem.stress import CellStress

__all__ = ["GroupStress", "create_group_stress"]


class GroupStress:
    """Per volume group, the largest von Mises stress over its cells (each cell's E, ν), on
    whichever side holds them, every ``output.stress_every`` sampling intervals and at the
    last (collective). History columns ``<group>_von_mises_max``: the value at the instants
    it is evaluated, NaN at the rows between."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        ropes = {r.line for r in sim.scenario.rope}  # a rope is no beam: no stress
        # The parent meshes (a mixed model's solids, then its beams: their own mesh).
        meshes = [sim.mesh.tagged] + ([sim.mesh.beams.tagged] if sim.mesh.beams else [])
        self.groups = [g for t in meshes for g in t.cell_groups if g not in ropes]
        self.every = sim.scenario.output.stress_every * md.sample_steps

        def groups_of(tagged: TaggedMesh) -> np.ndarray:
            n = tagged.mesh.topology.index_map(tagged.mesh.topology.dim)
            out = np.full(n.size_local + n.num_ghosts, -1, dtype=np.int64)
            for k, name in enumerate(self.groups):
                if name in tagged.cell_groups:
                    tag = tagged.cell_groups[name]
                    out[tagged.cell_tags.indices[tagged.cell_tags.values == tag]] = k
            return out

        self.sides: list[tuple[str, CellStress, np.ndarray, np.ndarray]] = []
        for side, sub in (("explicit", md.explicit), ("implicit", md.implicit)):
            if sub is None:
                continue
            vm = sub.stress()
            own = sub.parent_cells[: vm.n_cells]
            beams = sim.mesh.beams
            labels = groups_of(
                beams.tagged if beams is not None and sub is md.implicit else sim.mesh.tagged
            )[own]
            sel = np.flatnonzero(labels >= 0).astype(np.int32)
            self.sides.append((side, vm, sel, labels[sel]))
        self.comm = sim.mesh.comm
        n_g = len(self.groups)
        self.peak = np.zeros(n_g)
        self.t_peak = np.zeros(n_g)
        self.location = np.zeros((n_g, 3))
        self.last = np.full(n_g, math.nan)
        #: A frame's per group largest |N|, |V1|, |V2|, |T|, |M1|, |M2| (none for solids).
        framed = any(hasattr(vm, "last_forces") for _, vm, _, _ in self.sides)
        self.forces = np.zeros((n_g, 6 if framed else 0))
        self._columns = [f"{g}_von_mises_max" for g in self.groups]

    @property
    def columns(self) -> list[str]:
        return self._columns

    def history_row(self) -> dict[str, float]:
        return dict(zip(self.columns, self.last.tolist(), strict=True))

    def update(self, rec: MacroRecord, last: bool) -> None:
        if not (rec.micro_step % self.every == 0 or last):
            self.last[:] = math.nan
            return
        now = np.zeros(len(self.groups))
        where = np.zeros((len(self.groups), 3))
        for side, vm, cells, labels in self.sides:
            u = rec.explicit_u if side == "explicit" else rec.implicit_u
            assert u is not None
            values, at = vm.peaks_by(u, cells, labels, len(self.groups), self.comm)
            better = values > now
            now[better], where[better] = values[better], at[better]
            forces = getattr(vm, "last_forces", None)
            if forces is not None:  # a beam's section forces, of the same evaluation
                local = np.zeros((len(self.groups), forces.shape[1]))
                np.maximum.at(local, labels, np.abs(forces[cells]))
                # A buffer reduction: a pickled one applies MAX to whole arrays and fails.
                self.comm.Allreduce(MPI.IN_PLACE, local, op=MPI.MAX)
                self.forces = np.maximum(self.forces, local)
        self.last = now
        up = now > self.peak
        self.peak[up], self.t_peak[up], self.location[up] = now[up], rec.t, where[up]

    def summarize(self, summary: dict[str, Any]) -> None:
        """``peak_von_mises_by_group``: per group its peak (Pa), when (s) and where (m); for
        a frame's member group also the largest magnitude of each section force over the run
        (``peak_section_forces``: N, V1, V2 in N, T, M1, M2 in N·m)."""
        table: dict[str, Any] = {}
        for k, g in enumerate(self.groups):
            row: dict[str, Any] = {
                "peak_Pa": float(self.peak[k]),
                "time_s": float(self.t_peak[k]),
                "location_m": self.location[k].tolist(),
            }
            if self.forces.shape[1]:
                names = ("N", "V1", "V2", "T", "M1", "M2")
                row["peak_section_forces"] = dict(zip(names, self.forces[k].tolist(), strict=True))
            table[g] = row
        summary["peak_von_mises_by_group"] = table

    def state_dict(self) -> dict[str, Any]:
        return {
            "peak": self.peak.copy(),
            "t_peak": self.t_peak.copy(),
            "location": self.location.copy(),
            "last": self.last.copy(),
            "forces": self.forces.copy(),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peak = np.asarray(state["peak"], dtype=np.float64)
        self.t_peak = np.asarray(state["t_peak"], dtype=np.float64)
        self.location = np.asarray(state["location"], dtype=np.float64).reshape(-1, 3)
        self.last = np.asarray(state["last"], dtype=np.float64)
        self.forces = np.asarray(state["forces"], dtype=np.float64).reshape(self.forces.shape)

    def destroy(self) -> None:
        pass


def create_group_stress(sim: Simulation) -> GroupStress | None:
    """The group stresses of a gmsh model or a frame (None for the built-in models)."""
    if not isinstance(sim.scenario.model, GmshModel | FrameModel):
        return None
    return GroupStress(sim)
