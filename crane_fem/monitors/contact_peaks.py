"""The contact groups' peaks from every micro step as a macro-step monitor, and the
summary's peak tables (wheels and flanges for a crane, else contact groups)."""

from __future__ import annotations

from typing import Any

import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.peaks import ContactPeaks
from crane_fem.pipeline import Simulation

__all__ = ["ContactPeaksMonitor", "peak_tables"]


class ContactPeaksMonitor:
    """:class:`ContactPeaks` fed with the micro steps of every macro record; the static
    forces are the preload's wheel forces (the flange groups after the wheels carry none)
    (not collective: the records' contact values are global)."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        self.contacts = sim.constraints.contacts
        self.dt = md.dt
        static = None
        if md.preload is not None:
            static = np.zeros(len(self.contacts.group_names))
            static[: md.preload.wheel_force.size] = md.preload.wheel_force
        self.peaks = ContactPeaks(self.contacts.group_names, md.dt, static)

    def update(self, rec: MacroRecord, last: bool) -> None:
        if rec.step == 0:
            f0 = self.contacts.group_sums(rec.contact_impulse) / self.dt
            self.peaks.start(rec.t, f0, self.contacts.group_mins(rec.gaps))
        else:
            self.peaks.update(rec.micro.t, rec.micro.impulse, rec.micro.gap)

    def summarize(self, summary: dict[str, Any]) -> None:
        summary.update(peak_tables(self.peaks))

    def state_dict(self) -> dict[str, Any]:
        return self.peaks.state_dict()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peaks.load_state_dict(state)

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
