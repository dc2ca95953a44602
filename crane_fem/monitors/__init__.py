"""What a run with subdomains follows through its macro records: the history rows and the
monitors (one module each, behind :class:`~crane_fem.monitors.protocol.Monitor`)."""

from crane_fem.monitors.create import Monitors, create_monitors
from crane_fem.monitors.history import HistoryRows
from crane_fem.monitors.protocol import Monitor

__all__ = ["HistoryRows", "Monitor", "Monitors", "create_monitors"]
