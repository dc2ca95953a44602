"""Loading: accelerograms (PEER AT2, CSV, bundled records, synthetic) and Rayleigh damping."""

from crane_fem.loading.accelerogram import (
    BUNDLED,
    Accelerogram,
    bundled,
    rayleigh_from_damping,
    read_at2,
    read_csv,
    synthetic,
)

__all__ = [
    "BUNDLED",
    "Accelerogram",
    "bundled",
    "rayleigh_from_damping",
    "read_at2",
    "read_csv",
    "synthetic",
]
