"""The protocol of a macro-step monitor: what the coupled run's loop asks of each one."""

from __future__ import annotations

from typing import Any, Protocol

from crane_fem.coupling import MacroRecord

__all__ = ["Monitor"]


class Monitor(Protocol):
    """One quantity the run follows through its macro records, kept apart from the loop.

    The loop hands every record to :meth:`update`, in the same order on every rank; a monitor
    keeps its own cadence (``last``: the run's last record, at its end or an interruption) and
    may raise to stop the run. Its peaks go to the summary by :meth:`summarize`; a checkpoint
    saves and restores it by :meth:`state_dict` / :meth:`load_state_dict`; :meth:`destroy`
    frees what it owns (PETSc objects). Collective where the monitor's docstring says so.
    """

    def update(self, rec: MacroRecord, last: bool) -> None:
        """Take the record of one macro step."""
        ...

    def summarize(self, summary: dict[str, Any]) -> None:
        """Add its entries to the run's summary (in place)."""
        ...

    def state_dict(self) -> dict[str, Any]:
        """What a checkpoint keeps of it."""
        ...

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore it from :meth:`state_dict`."""
        ...

    def destroy(self) -> None:
        """Free what it owns."""
        ...
