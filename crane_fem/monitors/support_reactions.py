"""The reactions of a crane's clamped faces as a macro-step monitor."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.coupling import MacroRecord
from crane_fem.coupling.system import CoupledSystem
from crane_fem.pipeline import Simulation
from crane_fem.points import GroundAcceleration
from crane_fem.reactions import SupportReactions, lowpass_peaks

__all__ = ["SupportsMonitor", "create_supports", "observe_every"]

FloatArray = npt.NDArray[np.float64]


class SupportsMonitor:
    """:class:`SupportReactions` on the fields of the side that holds the clamped faces,
    every ``output.stress_every`` sampling intervals and at the last (collective). Owns the
    reactions' PETSc matrices: :meth:`destroy` them. Its history columns hold the forces at
    the instants they were evaluated and NaN at the rows between them (``stress_every`` > 1),
    as the bridge stress's do."""

    def __init__(self, sim: Simulation, reactions: SupportReactions) -> None:
        md = sim.models
        self.reactions = reactions
        self.on_implicit = md.implicit is not None and reactions.subdomain == md.implicit.name
        # Every ``stress_every`` sampling intervals, in micro steps.
        self.every = sim.scenario.output.stress_every * md.sample_steps
        self.ground = GroundAcceleration(sim.scenario)
        #: The forces at the last sampled record (n_faces, bs), N (NaN when they were not
        #: evaluated there): the history's columns.
        self.last = np.full((reactions.n_faces, reactions.bs), np.nan)
        r = reactions
        names = ["fx", "fy", "fz", "mx", "my", "mz"] if r.bs == 6 else [f"f{c}" for c in "xyz"]
        self._columns = [
            f"support{k + 1}_{names[c]}" for k in range(r.n_faces) for c in range(r.bs)
        ]
        #: ``output.support_lowpass_hz``: the forces of the evaluation grid (every
        #: ``every`` micro steps), kept for their low-passed peaks at the end.
        self.cutoff = sim.scenario.output.support_lowpass_hz
        self._series_t: list[float] = []
        self._series_f: list[FloatArray] = []
        # The peaks between the sampling instants (crane_fem.reactions): at every record of a
        # coupled run, every ``output.peak_interval`` in a monolithic reference (a fully
        # explicit one's readings taken by the kernel, handed over once per record).
        system = sim.integrators.system
        system.observers.append(self.observe)
        if not system.coupled:
            system.observe_every = observe_every(sim.scenario.output.peak_interval, system.dt)
            if not self.on_implicit:
                system.probe = reactions.columns
                system.probe_reader = self.read

    def observe(self, system: CoupledSystem) -> None:
        """The faces' peaks at the system's current state (collective)."""
        r = self.reactions
        at = r.columns
        if self.on_implicit:
            side = system.I
            assert side is not None
            u, v = side.field_rows(side.u, at), side.field_rows(side.v, at)
        else:
            zone = system.E
            assert zone is not None
            u, v = zone.u[at], zone.v_int[at]
        r.track(system.t, u, v, self.ground(system.t))

    def read(self, times: FloatArray, u: FloatArray, v: FloatArray) -> None:
        """The faces' peaks at the kernel's readings between two records: ``u``, ``v`` (m,
        columns) at ``times`` (m,) (collective)."""
        self.reactions.track_many(times, u, v, self.ground.at(times))

    @property
    def columns(self) -> list[str]:
        """The history columns: each face's force components (N; a beam's support also its
        moment, N·m) at the row's instant, NaN at a row where they are not evaluated."""
        return self._columns

    def history_row(self) -> dict[str, float]:
        return dict(zip(self.columns, self.last.ravel().tolist(), strict=True))

    def update(self, rec: MacroRecord, last: bool) -> None:
        # Sampled, not every step; the side's values at the faces' columns only (a reduced
        # side's rows of its basis, not its whole field).
        if not (rec.micro_step % self.every == 0 or last):
            self.last = np.full_like(self.last, np.nan)
            return
        at = self.reactions.columns
        if self.on_implicit:
            uv = rec.implicit_at(at)
            assert uv is not None
            u, v = uv
        else:
            assert rec.explicit_u is not None and rec.explicit_v is not None
            u, v = rec.explicit_u[at], rec.explicit_v[at]
        self.last = self.reactions.update(rec.t, u, v, self.ground(rec.t))
        if self.cutoff is not None and rec.micro_step % self.every == 0:
            self._series_t.append(rec.t)
            self._series_f.append(self.last.copy())

    def summarize(self, summary: dict[str, Any]) -> None:
        table = self.reactions.table()
        if self.cutoff is not None and self._series_t:
            # (The reactions are global on every rank: the same peaks everywhere.)
            low = lowpass_peaks(
                np.asarray(self._series_t),
                np.asarray(self._series_f),
                self.cutoff,
                self.reactions.translations,
            )
            for k, row in enumerate(table.values()):
                row["lowpass"] = {
                    "cutoff_hz": self.cutoff,
                    "peak_force_N": float(low["peak"][k]),
                    "peak_force_time_s": float(low["t_peak"][k]),
                    "peak_vertical_N": float(low["peak_vertical"][k]),
                    "peak_vertical_time_s": float(low["t_vertical"][k]),
                }
        summary["supports"] = table

    def state_dict(self) -> dict[str, Any]:
        state = {**self.reactions.state_dict(), "last": self.last.copy()}
        if self.cutoff is not None:
            shape = (len(self._series_t), *self.last.shape)
            state["series_t"] = np.asarray(self._series_t, dtype=np.float64)
            state["series_f"] = np.asarray(self._series_f, dtype=np.float64).reshape(shape)
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.reactions.load_state_dict(state)
        self.last = np.array(state["last"], dtype=np.float64).reshape(self.last.shape)
        if self.cutoff is not None:
            self._series_t = [float(t) for t in np.asarray(state["series_t"])]
            self._series_f = list(np.asarray(state["series_f"], dtype=np.float64))

    def destroy(self) -> None:
        self.reactions.destroy()


def observe_every(interval: float, dt: float) -> int:
    """The micro steps between two observations of a monolithic run: ``interval`` (s,
    ``output.peak_interval``) rounded to whole steps of ``dt``, at least one."""
    return max(1, round(interval / dt))


def create_supports(sim: Simulation) -> SupportsMonitor | None:
    """The reactions of the clamped faces, on the side that holds them (collective; None
    without clamped DOFs)."""
    md, sc = sim.models, sim.scenario
    for sub in (md.implicit, md.explicit):
        if sub is None or sub.bs == 1:
            continue
        if sim.mesh.comm.allreduce(int(np.count_nonzero(sub.model.fixed)), op=MPI.SUM):
            rayleigh = sub.model.alpha, sub.model.beta
            # A gmsh model's faces are its [[support]] groups; a crane's, its four ends (a
            # mixed model's beams: their point supports, on their own mesh).
            beams = sim.mesh.beams
            stage = beams if beams is not None and sub is md.implicit else sim.mesh
            faces = list(stage.support_faces) or None
            return SupportsMonitor(sim, SupportReactions(sub, rayleigh, sc.loading.gravity, faces))
    return None
