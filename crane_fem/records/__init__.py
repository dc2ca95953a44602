"""Spectrum-compatible records: ``crane-fem records match``.

A target spectrum (:mod:`.targets`: Eurocode 8's elastic spectrum or a table), seed records
(:mod:`.seeds`), their spectral matching with reqpy-m and the band check with the project's
own spectra (:mod:`.matching`), and the files the scenes and a study read (:mod:`.report`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from crane_fem.records.matching import Band, MatchedRecord, MatchResult, match_records
    from crane_fem.records.report import write_outputs
    from crane_fem.records.seeds import DEFAULT_SEEDS, SeedVariant, load_seed, plan_variants
    from crane_fem.records.targets import (
        Ec8Target,
        TableTarget,
        Target,
        ec8_spectrum,
        parse_target,
    )

#: Where each public name lives: imported on first use (PEP 562), so that the command line,
#: which imports :mod:`.cli` for its parser, does not import scipy.signal for every command.
_HOME = {
    "Band": "matching",
    "MatchedRecord": "matching",
    "MatchResult": "matching",
    "match_records": "matching",
    "write_outputs": "report",
    "DEFAULT_SEEDS": "seeds",
    "SeedVariant": "seeds",
    "load_seed": "seeds",
    "plan_variants": "seeds",
    "Ec8Target": "targets",
    "TableTarget": "targets",
    "Target": "targets",
    "ec8_spectrum": "targets",
    "parse_target": "targets",
}

__all__ = [
    "DEFAULT_SEEDS",
    "Band",
    "Ec8Target",
    "MatchResult",
    "MatchedRecord",
    "SeedVariant",
    "TableTarget",
    "Target",
    "ec8_spectrum",
    "load_seed",
    "match_records",
    "parse_target",
    "plan_variants",
    "write_outputs",
]


def __getattr__(name: str) -> Any:
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{home}"), name)
