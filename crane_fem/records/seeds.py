"""Seed records of spectral matching: the bundled El Centro pair in four directions, files.

The default seeds are four horizontal motions of one station, El Centro 1940 (the
crane_fem bundled records): its two recorded components, 180 and 270, and the same pair read
in axes turned by 45°, the motions along the azimuths 225 and 315,

    a_θ(t) = cos(θ − 180°) a_180(t) + sin(θ − 180°) a_270(t),

which are as real as the recorded ones (a station's axes are arbitrary). A seed is one of
these names, a bundled record name (``el_centro_1940_up`` …) or a file (PEER ``.AT2``, in g;
else a CSV of t s, a m/s², as the scenes read them).

N records come from m seeds as follows: record k (from 0) takes seed k mod m, as recorded for
k < m and reversed in time for m ≤ k < 2m. A reversed record has the seed's Fourier amplitudes
and another phase (its strong motion comes late, its build-up is the seed's decay), so it is a
different history once matched; scaling or a sign change would not be: the matcher gives back
the same record, scaled or negated. Hence at most 2m records: more need more seeds.
Not collective.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError
from crane_fem.loading import BUNDLED, Accelerogram, bundled, read_at2, read_csv

__all__ = [
    "DEFAULT_SEEDS",
    "ROTATED",
    "SeedVariant",
    "check_seed_length",
    "el_centro_horizontal",
    "load_seed",
    "plan_variants",
]

FloatArray = npt.NDArray[np.float64]

#: The El Centro pair along azimuths 225 and 315 (degrees from north, as the components' names).
ROTATED = {"el_centro_1940_225": 225.0, "el_centro_1940_315": 315.0}
DEFAULT_SEEDS = (
    "el_centro_1940_180",
    "el_centro_1940_225",
    "el_centro_1940_270",
    "el_centro_1940_315",
)
#: A seed lasts at least this many times the target's longest period (issue 32): an oscillator
#: of that period then goes through a few cycles of the record.
LENGTH_PERIODS = 3.0


def el_centro_horizontal(azimuth: float) -> Accelerogram:
    """The El Centro 1940 horizontal motion along ``azimuth`` (degrees; 180 and 270 are the
    recorded components), on the components' time grid; the shorter one is extended by zeros
    (the ground at rest after its end)."""
    a180 = bundled("el_centro_1940_180")
    a270 = bundled("el_centro_1940_270")
    if not np.isclose(a180.t[1] - a180.t[0], a270.t[1] - a270.t[0], rtol=1e-12):
        raise AssertionError("the bundled El Centro components have different time steps")
    t = a180.t if a180.t.size >= a270.t.size else a270.t
    x, y = np.zeros(t.size), np.zeros(t.size)
    x[: a180.a.size] = a180.a
    y[: a270.a.size] = a270.a
    th = math.radians(azimuth - 180.0)
    return Accelerogram(t, math.cos(th) * x + math.sin(th) * y, f"el_centro_1940_{azimuth:g}")


def load_seed(spec: str) -> Accelerogram:
    """A seed by name (see the module docstring) or file; its name is ``spec``'s file stem.

    Raises:
        ScenarioError: a missing or unreadable file (naming it), a malformed record.
    """
    if spec in ROTATED:
        return el_centro_horizontal(ROTATED[spec])
    if spec in BUNDLED:
        return bundled(spec)
    p = Path(spec)
    if not p.exists() and not p.suffix:
        names = ", ".join([*BUNDLED, *ROTATED])
        raise ScenarioError(f"{spec}: no such seed record file, nor a bundled record ({names})")
    if p.suffix.lower() == ".at2":
        return read_at2(p)
    return read_csv(p)


def check_seed_length(seed: Accelerogram, longest_period: float) -> None:
    """Refuse a seed shorter than ``LENGTH_PERIODS`` × the target's longest period (s)."""
    need = LENGTH_PERIODS * longest_period
    if seed.duration < need:
        raise ScenarioError(
            f"seed record {seed.name} lasts {seed.duration:g} s, shorter than "
            f"{LENGTH_PERIODS:g} × the target's longest period {longest_period:g} s "
            f"= {need:g} s"
        )


@dataclass(frozen=True)
class SeedVariant:
    """The seed of one matched record.

    Attributes:
        seed: the seed's name.
        reversed: whether it is the seed reversed in time.
        record: the acceleration history to match (t from 0, s; a m/s²).
    """

    seed: str
    reversed: bool
    record: Accelerogram

    @property
    def label(self) -> str:
        return f"{self.seed} reversed" if self.reversed else self.seed


def plan_variants(seeds: list[Accelerogram], n: int) -> list[SeedVariant]:
    """The seeds of ``n`` records from ``seeds``: each in turn, then each reversed in time.

    Raises:
        ScenarioError: ``n`` < 1, no seeds, or ``n`` more than twice the number of seeds.
    """
    m = len(seeds)
    if n < 1:
        raise ScenarioError(f"--n must be at least 1 (got {n})")
    if m == 0:
        raise ScenarioError("no seed records")
    if n > 2 * m:
        raise ScenarioError(
            f"{n} records need at least {math.ceil(n / 2)} seed records (each gives two: as "
            f"recorded and reversed in time); {m} given"
        )
    out = []
    for k in range(n):
        rec = seeds[k % m]
        if k < m:
            out.append(SeedVariant(rec.name, False, rec))
        else:
            t = rec.t[-1] - rec.t[::-1]
            rev = Accelerogram(np.ascontiguousarray(t), rec.a[::-1].copy(), f"{rec.name} reversed")
            out.append(SeedVariant(rec.name, True, rev))
    return out
