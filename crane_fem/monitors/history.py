"""The history of a run with subdomains: its columns and the row of each macro record
(energies, contact groups, the probe, the interface, a crane's wheel/rail pairs)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.coupling import ENERGY_KEYS, MacroRecord
from crane_fem.pipeline import Simulation

__all__ = ["HistoryRows"]


class HistoryRows:
    """The history columns of a run with subdomains and the row of each record (collective:
    the probe and pair values are reduced over the communicator)."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        md, it = sim.models, sim.integrators
        self.contacts = sim.constraints.contacts
        self.groups = self.contacts.group_names
        sub = md.explicit or md.implicit
        assert sub is not None
        self.bs = sub.bs
        probe = sim.probe_vertices()
        # The probe's owned blocks on each side (the implicit side's interface copies left out:
        # the explicit side has them); a side's field is read only where it holds the probe.
        #: (side, blocks, the blocks' DOFs): the implicit side reads the DOFs' rows.
        self.probe_blocks: list[tuple[str, npt.NDArray[np.int64], npt.NDArray[np.int64]]] = []
        for side, sub in (("explicit", md.explicit), ("implicit", md.implicit)):
            if sub is None:
                continue
            excl = sim.constraints.interface_vertices if side == "implicit" else np.zeros(0)
            blocks, _ = sub.owned_dofs_of(np.setdiff1d(probe, excl))
            if side == "implicit" and sim.mesh.beams is not None:
                blocks = blocks[:0]  # a mixed model's probe is on its solids' mesh
            dofs = (blocks[:, None] * self.bs + np.arange(self.bs)).ravel()
            self.probe_blocks.append((side, blocks, dofs))
        cols = ["t", *ENERGY_KEYS, *it.method.history_keys(), "total"]
        cols += ["kinetic_explicit", "internal_explicit", "kinetic_implicit", "internal_implicit"]
        cols += ["contact_force", "active_contacts"]
        cols += [f"gap_{g}" for g in self.groups] + [f"force_{g}" for g in self.groups]
        cols += [f"probe_u{c}" for c in range(self.bs)] + [f"probe_v{c}" for c in range(self.bs)]
        cols += ["interface_force_norm", "interface_velocity_jump"]
        cols += ["interface_impulse", "interface_impulse_defect"]
        cols += sim.mean_motion_columns()  # a block: its centre of mass
        # Crane: one wheel/rail node pair per wheel (the first pair of each patch), vertical
        # displacement and velocity on both sides (the paper's Figs. 5–6).
        self.pairs: list[tuple[int, int, int]] = []
        crane = sim.mesh.crane
        if crane is not None:
            for k in range(1, 5):
                i = int(np.flatnonzero(crane.wheel == k)[0])
                self.pairs.append((k, int(crane.pairs[i, 0]), int(crane.pairs[i, 1])))
                cols += [f"wheel{k}_{s}_{q}" for s in ("wheel", "rail") for q in ("uz", "vz")]
        self.columns = cols

    def row(self, rec: MacroRecord) -> dict[str, float]:
        sim, bs = self.sim, self.bs
        md = sim.models
        comm = sim.mesh.comm
        e = rec.energy
        row: dict[str, float] = {"t": rec.t}
        row.update({k: e[k] for k in self.columns if k in e})
        gaps, force = self.contacts.rope_values(rec.gaps, rec.contact_impulse / md.dt)
        row["contact_force"] = float(force.sum())
        row["active_contacts"] = float(np.count_nonzero(force > 0))
        gmin = self.contacts.group_mins(gaps)
        gsum = self.contacts.group_sums(force)
        for i, g in enumerate(self.groups):
            row[f"gap_{g}"] = float(gmin[i])
            row[f"force_{g}"] = float(gsum[i])
        su, sv, cnt = np.zeros(bs), np.zeros(bs), 0
        for side, blocks, dofs in self.probe_blocks:
            if blocks.size == 0:
                continue
            if side == "explicit":
                assert rec.explicit_u is not None and rec.explicit_v is not None
                u = rec.explicit_u.reshape(-1, bs)[blocks]
                v = rec.explicit_v.reshape(-1, bs)[blocks]
            else:  # the probe's rows only (a reduced side does not expand its field)
                uv = rec.implicit_at(dofs)
                assert uv is not None
                u, v = (x.reshape(-1, bs) for x in uv)
            su = su + u.sum(axis=0)
            sv = sv + v.sum(axis=0)
            cnt += int(blocks.size)
        tot = np.concatenate([su, sv, [cnt]])
        if comm.size > 1:
            tot = comm.allreduce(tot, op=MPI.SUM)
        for k in range(bs):
            row[f"probe_u{k}"] = float(tot[k] / max(tot[-1], 1))
            row[f"probe_v{k}"] = float(tot[bs + k] / max(tot[-1], 1))
        row["interface_force_norm"] = float(np.linalg.norm(rec.interface_impulse))
        row["interface_velocity_jump"] = rec.interface_velocity_jump
        row["interface_impulse"] = rec.impulse_explicit
        row["interface_impulse_defect"] = rec.impulse_defect
        row.update(sim.mean_motion(rec.explicit_u, rec.explicit_v))
        if self.pairs:
            sub = md.explicit
            assert sub is not None and rec.explicit_u is not None and rec.explicit_v is not None
            ids = np.array([v for _, w_, r in self.pairs for v in (w_, r)])
            order = np.argsort(ids)
            blocks, pos = sub.owned_dofs_of(ids[order])
            vals = np.zeros((ids.size, 2))
            dz = blocks * sub.bs + 2
            vals[order[pos], 0] = rec.explicit_u[dz]
            vals[order[pos], 1] = rec.explicit_v[dz]
            vals = comm.allreduce(vals, op=MPI.SUM)
            for n_p, (k, _, _) in enumerate(self.pairs):
                for s_i, side in enumerate(("wheel", "rail")):
                    row[f"wheel{k}_{side}_uz"] = float(vals[2 * n_p + s_i, 0])
                    row[f"wheel{k}_{side}_vz"] = float(vals[2 * n_p + s_i, 1])
        return row
