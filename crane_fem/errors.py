"""Exceptions raised by crane_fem with a one-line, user-facing message."""

__all__ = ["CraneFemError", "RunInterrupted", "ScenarioError", "UnstableRunError"]


class CraneFemError(Exception):
    """Base class: the message is one line that names the cause."""


class ScenarioError(CraneFemError):
    """A scenario file, key or value is invalid (raised identically on every rank)."""


class UnstableRunError(CraneFemError):
    """A time integration diverged; the message says where, when and Δt versus its limit."""


class RunInterrupted(CraneFemError):
    """SIGINT or SIGTERM stopped a run at a macro step; its files hold the steps done."""
