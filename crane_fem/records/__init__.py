"""Spectrum-compatible records: ``crane-fem records match``.

A target spectrum (:mod:`.targets`: Eurocode 8's elastic spectrum or a table), seed records
(:mod:`.seeds`), their spectral matching with reqpy-m and the band check with the project's
own spectra (:mod:`.matching`), and the files the scenes and a study read (:mod:`.report`).
"""

from crane_fem.records.matching import Band, MatchedRecord, MatchResult, match_records
from crane_fem.records.report import write_outputs
from crane_fem.records.seeds import DEFAULT_SEEDS, SeedVariant, load_seed, plan_variants
from crane_fem.records.targets import Ec8Target, TableTarget, Target, ec8_spectrum, parse_target

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
