"""Unilateral frictionless contact: gap relations and exact complementarity solvers."""

from crane_fem.contact.constraints import ContactSet
from crane_fem.contact.lcp import solve_lcp, solve_mixed_lcp, solve_mixed_lcp_blocks

__all__ = ["ContactSet", "solve_lcp", "solve_mixed_lcp", "solve_mixed_lcp_blocks"]
