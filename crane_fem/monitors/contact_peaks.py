"""The contact groups' peaks from every micro step as a macro-step monitor, and the
summary's peak tables (wheels and flanges for a crane, else contact groups)."""

from __future__ import annotations

from typing import Any

import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.coupling.system import MicroTrace
from crane_fem.peaks import ContactPeaks
from crane_fem.pipeline import Simulation

__all__ = ["ContactPeaksMonitor", "peak_tables"]


#: Micro steps gathered before :class:`ContactPeaks` takes them: a coupled run's records are
#: macro steps of 5–100 micro steps, and the peaks' NumPy pass costs about as much for one
#: as for thousands (the peaks are the same whatever the traces' cuts: tests/test_peaks.py).
BATCH = 4096


class ContactPeaksMonitor:
    """:class:`ContactPeaks` fed with the micro steps of every macro record, gathered into
    batches of at least :data:`BATCH` (the batch under way is part of a checkpoint, so that
    a restarted run cuts its traces where the run it continues did: an impact's summed
    impulse is then the same to the bit); the static forces are the preload's wheel forces
    (the flange groups after the wheels carry none) (not collective: the records' contact
    values are global)."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        self.contacts = sim.constraints.contacts
        self.dt = md.dt
        static = None
        if md.preload is not None:
            static = np.zeros(len(self.contacts.group_names))
            static[: md.preload.wheel_force.size] = md.preload.wheel_force
        self.peaks = ContactPeaks(self.contacts.group_names, md.dt, static)
        self._pending: list[MicroTrace] = []
        self._n_pending = 0

    def update(self, rec: MacroRecord, last: bool) -> None:
        if rec.step == 0:
            self._take()
            f0 = self.contacts.group_sums(rec.contact_impulse) / self.dt
            self.peaks.start(rec.t, f0, self.contacts.group_mins(rec.gaps))
            return
        self._pending.append(rec.micro)
        self._n_pending += rec.micro.t.size
        if last or self._n_pending >= BATCH:
            self._take()

    def _joined(self) -> MicroTrace:
        """The gathered micro steps as one trace."""
        if len(self._pending) == 1:
            return self._pending[0]
        if not self._pending:
            return MicroTrace.empty(len(self.contacts.group_names))
        traces = self._pending
        return MicroTrace(
            np.concatenate([m.t for m in traces]),
            np.concatenate([m.active for m in traces]),
            np.concatenate([m.impulse for m in traces]),
            np.concatenate([m.gap for m in traces]),
        )

    def _take(self) -> None:
        """The gathered micro steps into the peaks."""
        if self._pending:
            m = self._joined()
            self.peaks.update(m.t, m.impulse, m.gap)
        self._pending.clear()
        self._n_pending = 0

    def summarize(self, summary: dict[str, Any]) -> None:
        self._take()
        summary.update(peak_tables(self.peaks))

    def state_dict(self) -> dict[str, Any]:
        m = self._joined()
        return {
            **self.peaks.state_dict(),
            "pending_t": m.t,
            "pending_impulse": m.impulse,
            "pending_gap": m.gap,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peaks.load_state_dict(state)
        self._pending.clear()
        self._n_pending = 0
        t = np.asarray(state.get("pending_t", np.zeros(0)), dtype=np.float64)
        if t.size:
            impulse = np.asarray(state["pending_impulse"], dtype=np.float64)
            gap = np.asarray(state["pending_gap"], dtype=np.float64)
            self._pending.append(MicroTrace(t, np.zeros(t.size, dtype=bool), impulse, gap))
            self._n_pending = t.size

    def destroy(self) -> None:
        pass


def peak_tables(peaks: ContactPeaks) -> dict[str, Any]:
    """The summary's peak tables from every micro step: ``wheels`` keyed by wheel number for
    a crane (its contact groups are ``wheel_<k>``) and, with flanges, ``flanges`` keyed
    ``in_<k>``/``out_<k>`` (groups ``flange_in_<k>``/``flange_out_<k>``), else
    ``contact_groups`` keyed by name."""
    table = peaks.table()
    if not table:
        return {}
    if all(name.startswith(("wheel_", "flange_")) for name in table):
        out = {"wheels": {n.removeprefix("wheel_"): v for n, v in table.items() if n[0] == "w"}}
        flanges = {n.removeprefix("flange_"): v for n, v in table.items() if n[0] == "f"}
        return out | ({"flanges": flanges} if flanges else {})
    return {"contact_groups": table}
