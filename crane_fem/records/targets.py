"""Target spectra of spectrum-compatible records: Eurocode 8's elastic spectrum, or a table.

A target is a pseudo-acceleration spectrum (m/s²) at a damping ratio, defined over a period
range. Two kinds:

- :class:`Ec8Target`: the elastic horizontal response spectrum of EN 1998-1:2004 §3.2.2.2,
  types 1 and 2, ground types A–E (Tables 3.2 and 3.3), its damping correction
  η = √(10/(5 + ξ)) ≥ 0.55 (ξ in %, expression 3.6);
- :class:`TableTarget`: periods (s) and PSA (m/s²) read from a CSV (a design spectrum, or a
  floor spectrum with its damping, e.g. a column of a run's ``spectra.csv``), interpolated
  linearly in log T – log PSA between its rows.

:func:`parse_target` reads the command line's TARGET: ``ec8:type=1,ag=0.3g,soil=B`` or a
CSV path. All functions are plain NumPy, not collective.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError
from crane_fem.spectra import G

__all__ = [
    "EC8_GROUND",
    "EC8_T_MAX",
    "EC8_VERTICAL",
    "Ec8Target",
    "TableTarget",
    "Target",
    "ec8_eta",
    "ec8_spectrum",
    "parse_target",
    "read_target_csv",
]

FloatArray = npt.NDArray[np.float64]

#: EN 1998-1 Tables 3.2 (type 1) and 3.3 (type 2): ground type -> (S, T_B s, T_C s, T_D s).
EC8_GROUND: dict[int, dict[str, tuple[float, float, float, float]]] = {
    1: {
        "A": (1.0, 0.15, 0.4, 2.0),
        "B": (1.2, 0.15, 0.5, 2.0),
        "C": (1.15, 0.20, 0.6, 2.0),
        "D": (1.35, 0.20, 0.8, 2.0),
        "E": (1.4, 0.15, 0.5, 2.0),
    },
    2: {
        "A": (1.0, 0.05, 0.25, 1.2),
        "B": (1.35, 0.05, 0.25, 1.2),
        "C": (1.5, 0.10, 0.25, 1.2),
        "D": (1.8, 0.10, 0.30, 1.2),
        "E": (1.6, 0.05, 0.25, 1.2),
    },
}
#: EN 1998-1 Table 3.4 (recommended values), the vertical spectrum: type -> (a_vg/a_g, T_B s,
#: T_C s, T_D s).
EC8_VERTICAL: dict[int, tuple[float, float, float, float]] = {
    1: (0.90, 0.05, 0.15, 1.0),
    2: (0.45, 0.05, 0.15, 1.0),
}
#: EN 1998-1 §3.2.2.2 (1)P defines the spectrum by expressions 3.2–3.5 for 0 ≤ T ≤ 4 s.
EC8_T_MAX = 4.0
_ETA_MIN = 0.55  # EN 1998-1 expression 3.6


class Target(Protocol):
    """A target pseudo-acceleration spectrum."""

    @property
    def damping(self) -> float:
        """The damping ratio ζ at which the spectrum is given."""
        ...

    @property
    def period_range(self) -> tuple[float, float]:
        """The periods (s) over which :meth:`psa` is defined, inclusive."""
        ...

    @property
    def label(self) -> str:
        """One line naming the spectrum (plots, messages)."""
        ...

    def psa(self, periods: npt.ArrayLike) -> FloatArray:
        """The pseudo-acceleration (m/s²) at ``periods`` (s), inside :attr:`period_range`."""
        ...

    def describe(self) -> dict[str, Any]:
        """The spectrum's definition for ``match.json``."""
        ...


def ec8_eta(damping: float) -> float:
    """EN 1998-1 expression 3.6: η = √(10/(5 + ξ)) ≥ 0.55, ξ = 100 ζ the viscous damping in %."""
    return max(math.sqrt(10.0 / (5.0 + 100.0 * damping)), _ETA_MIN)


def ec8_spectrum(
    periods: npt.ArrayLike,
    spectrum_type: int,
    ag: float,
    ground: str,
    damping: float = 0.05,
    vertical: bool = False,
) -> FloatArray:
    """EN 1998-1 §3.2.2.2 elastic horizontal response spectrum S_e(T) (expressions 3.2–3.5).

        0 ≤ T ≤ T_B:    S_e = a_g S [1 + T/T_B (2.5 η − 1)]
        T_B ≤ T ≤ T_C:  S_e = 2.5 a_g S η
        T_C ≤ T ≤ T_D:  S_e = 2.5 a_g S η T_C/T
        T_D ≤ T ≤ 4 s:  S_e = 2.5 a_g S η T_C T_D/T²

    With ``vertical``, the §3.2.2.3 elastic vertical spectrum S_ve(T) (expressions 3.8–3.11,
    Table 3.4): the same shape with a_vg = (a_vg/a_g) a_g in place of a_g S, 3.0 in place of
    2.5, and T_B, T_C, T_D of Table 3.4 (the ground type plays no part).

    Args:
        periods: periods T (s), in [0, 4].
        spectrum_type: 1 or 2.
        ag: the design ground acceleration on type A ground a_g = γ_I a_gR (m/s²), > 0.
        ground: ground type "A" to "E".
        damping: viscous damping ratio ζ (0.05 for the 5 % spectrum).

    Returns:
        S_e (m/s²) at ``periods``.

    Raises:
        ScenarioError: an unknown type or ground type, a_g ≤ 0, periods outside [0, 4] s.
    """
    if spectrum_type not in EC8_GROUND:
        raise ScenarioError(f"EC8 spectrum type must be 1 or 2 (got {spectrum_type!r})")
    table = EC8_GROUND[spectrum_type]
    if ground not in table:
        raise ScenarioError(
            f"EC8 ground type must be one of {', '.join(table)} (got {ground!r}; S1 and S2 "
            "need a site-specific study, EN 1998-1 §3.1.2)"
        )
    if not (math.isfinite(ag) and ag > 0.0):
        raise ScenarioError(f"EC8 a_g must be a positive acceleration (got {ag!r} m/s²)")
    t = np.asarray(periods, dtype=np.float64)
    if np.any(~np.isfinite(t)) or np.any(t < 0.0) or np.any(t > EC8_T_MAX):
        raise ScenarioError(
            f"the EC8 elastic spectrum is defined for periods 0 to {EC8_T_MAX:g} s "
            f"(asked for {float(np.nanmin(t)):g} to {float(np.nanmax(t)):g} s)"
        )
    s, tb, tc, td = table[ground]
    amp = 2.5
    if vertical:
        s, tb, tc, td = EC8_VERTICAL[spectrum_type]
        amp = 3.0
    eta = ec8_eta(damping)
    plateau = amp * ag * s * eta
    se = np.where(
        t <= tb,
        ag * s * (1.0 + t / tb * (amp * eta - 1.0)),
        np.where(
            t <= tc,
            plateau,
            np.where(
                t <= td,
                plateau * tc / np.maximum(t, tc),
                plateau * tc * td / np.maximum(t, td) ** 2,
            ),
        ),
    )
    return np.asarray(se, dtype=np.float64)


@dataclass(frozen=True)
class Ec8Target:
    """The EN 1998-1 elastic horizontal spectrum of type ``spectrum_type``, a_g, ground type.

    Attributes:
        spectrum_type: 1 or 2.
        ag: design ground acceleration on type A ground (m/s²).
        ground: ground type "A" to "E".
        damping: the damping ratio ζ (η from it).
    """

    spectrum_type: int
    ag: float
    ground: str
    damping: float = 0.05
    #: The vertical spectrum (§3.2.2.3) instead of the horizontal one.
    vertical: bool = False

    def __post_init__(self) -> None:
        self.psa([0.0])  # validate

    @property
    def period_range(self) -> tuple[float, float]:
        return (0.0, EC8_T_MAX)

    @property
    def label(self) -> str:
        if self.vertical:
            return (
                f"EC8 type {self.spectrum_type} vertical, a_g = {self.ag / G:.3g} g, "
                f"{100 * self.damping:g} %"
            )
        return (
            f"EC8 type {self.spectrum_type}, a_g = {self.ag / G:.3g} g, "
            f"ground {self.ground}, {100 * self.damping:g} %"
        )

    def psa(self, periods: npt.ArrayLike) -> FloatArray:
        return ec8_spectrum(
            periods, self.spectrum_type, self.ag, self.ground, self.damping, self.vertical
        )

    def describe(self) -> dict[str, Any]:
        if self.vertical:
            s, tb, tc, td = EC8_VERTICAL[self.spectrum_type]
        else:
            s, tb, tc, td = EC8_GROUND[self.spectrum_type][self.ground]
        what = "§3.2.2.3, elastic vertical" if self.vertical else "§3.2.2.2, elastic horizontal"
        return {
            "kind": "ec8",
            "label": self.label,
            "code": f"EN 1998-1:2004 {what} spectrum",
            "direction": "vertical" if self.vertical else "horizontal",
            "type": self.spectrum_type,
            "ag_m_s2": self.ag,
            "ground": self.ground,
            "avg_over_ag" if self.vertical else "S": s,
            "T_B_s": tb,
            "T_C_s": tc,
            "T_D_s": td,
            "eta": ec8_eta(self.damping),
            "damping": self.damping,
        }


@dataclass(frozen=True, eq=False)
class TableTarget:
    """A tabulated spectrum, log–log interpolated between its rows.

    Attributes:
        periods: strictly increasing periods (s), > 0.
        values: PSA (m/s²) at ``periods``, > 0.
        damping: the damping ratio the spectrum was computed at.
        source: where it came from (a file, a column), for labels.
    """

    periods: FloatArray
    values: FloatArray
    damping: float
    source: str
    _log: tuple[FloatArray, FloatArray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_log", (np.log(self.periods), np.log(self.values)))

    @property
    def period_range(self) -> tuple[float, float]:
        return (float(self.periods[0]), float(self.periods[-1]))

    @property
    def label(self) -> str:
        return f"{self.source}, {100 * self.damping:g} %"

    def psa(self, periods: npt.ArrayLike) -> FloatArray:
        t = np.asarray(periods, dtype=np.float64)
        lo, hi = self.period_range
        # A relative tolerance, so that a grid ending at the table's end point is inside.
        if np.any(t < lo * (1 - 1e-12)) or np.any(t > hi * (1 + 1e-12)):
            raise ScenarioError(
                f"{self.source}: the target spectrum covers {lo:g} to {hi:g} s, not "
                f"{float(t.min()):g} to {float(t.max()):g} s"
            )
        lt, lv = self._log
        return np.exp(np.interp(np.log(t), lt, lv))

    def describe(self) -> dict[str, Any]:
        return {
            "kind": "table",
            "label": self.label,
            "source": self.source,
            "damping": self.damping,
            "periods_s": self.periods.tolist(),
            "psa_m_s2": self.values.tolist(),
        }


def read_target_csv(path: str | Path, damping: float, column: str | None = None) -> TableTarget:
    """Read a target spectrum: rows of period (s), PSA (m/s²), comma-separated.

    A header row is allowed (lines starting with ``#`` are comments). A file of more than two
    columns (a run's ``spectra.csv``: ``period_s,psa_<name>,...``) needs ``column``, the
    header name of the PSA column (with or without its ``psa_`` prefix).

    Raises:
        ScenarioError: a missing or unreadable file, a value that is not a positive finite
            number, periods not strictly increasing, fewer than two rows, a bad column.
    """
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: target spectrum file not found")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{p}: cannot read the target spectrum ({exc})") from None
    header: list[str] | None = None
    rows: list[tuple[int, list[float]]] = []
    for k, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in re.split(r"[,;\t]", line.strip())]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if rows or header is not None:
                raise ScenarioError(
                    f"{p}: line {k}: {line.strip()!r} is not a row of numbers"
                ) from None
            header = cells
            continue
        rows.append((k, values))
    if len(rows) < 2:
        raise ScenarioError(f"{p}: a target spectrum needs at least two rows 'period, psa'")
    width = len(rows[0][1])
    col = 1
    if column is not None:
        names = [c.removeprefix("psa_") for c in header or []]
        if column.removeprefix("psa_") not in names[1:]:
            raise ScenarioError(
                f"{p}: no column {column!r}; its PSA columns are {', '.join(names[1:]) or 'none'}"
            )
        col = names.index(column.removeprefix("psa_"))
    elif width != 2:
        raise ScenarioError(
            f"{p}: {width} columns; name the PSA column with --column "
            f"({', '.join((header or [])[1:]) or 'the file has no header'})"
        )
    periods: list[float] = []
    psa: list[float] = []
    for k, values in rows:
        if len(values) != width:
            raise ScenarioError(f"{p}: line {k}: {len(values)} columns, the first row {width}")
        t, a = values[0], values[col]
        if not (math.isfinite(t) and math.isfinite(a) and t > 0.0 and a > 0.0):
            raise ScenarioError(f"{p}: line {k}: period and PSA must be positive finite numbers")
        if periods and t <= periods[-1]:
            raise ScenarioError(
                f"{p}: line {k}: the periods must increase (T = {t:g} s after {periods[-1]:g} s)"
            )
        periods.append(t)
        psa.append(a)
    name = f"{p.name}" if column is None else f"{p.name} [{column}]"
    return TableTarget(np.array(periods), np.array(psa), damping, name)


_EC8_KEYS = ("type", "ag", "soil", "direction")


def _parse_ag(text: str) -> float:
    """An acceleration in m/s², or in g with a ``g`` suffix (``0.3g``)."""
    t = text.strip().lower()
    scale = 1.0
    if t.endswith("g"):
        t, scale = t[:-1].strip(), G
    elif t.endswith("m/s2"):
        t = t[:-4].strip()
    try:
        value = float(t) * scale
    except ValueError:
        raise ScenarioError(
            f"EC8 ag must be an acceleration in m/s² or in g with a 'g' suffix (got {text!r})"
        ) from None
    return value


def _parse_ec8(spec: str, damping: float) -> Ec8Target:
    keys: dict[str, str] = {}
    body = spec.split(":", 1)[1]
    for item in filter(None, (s.strip() for s in body.split(","))):
        key, sep, value = item.partition("=")
        key = key.strip().lower()
        if not sep or key not in _EC8_KEYS:
            allowed = ", ".join(f"{k}=…" for k in _EC8_KEYS)
            raise ScenarioError(f"EC8 target {spec!r}: {item!r} is not one of {allowed}")
        keys[key] = value.strip()
    direction = keys.pop("direction", "horizontal").lower()
    if direction not in ("horizontal", "vertical"):
        raise ScenarioError(
            f"EC8 target {spec!r}: direction must be horizontal or vertical (got {direction!r})"
        )
    vertical = direction == "vertical"
    if vertical:
        keys.setdefault("soil", "A")  # the vertical spectrum has no ground factor
    missing = [k for k in _EC8_KEYS[:3] if k not in keys]
    if missing:
        raise ScenarioError(
            f"EC8 target {spec!r} needs {', '.join(missing)} (e.g. ec8:type=1,ag=0.3g,soil=B)"
        )
    try:
        kind = int(keys["type"])
    except ValueError:
        raise ScenarioError(f"EC8 spectrum type must be 1 or 2 (got {keys['type']!r})") from None
    return Ec8Target(kind, _parse_ag(keys["ag"]), keys["soil"].upper(), damping, vertical)


def parse_target(spec: str, damping: float, column: str | None = None) -> Target:
    """The target named on the command line.

    ``ec8:type=T,ag=A,soil=S`` (T 1 or 2; A in m/s², or in g with a ``g`` suffix: ``0.3g``;
    S a ground type A–E) is the EN 1998-1 elastic horizontal spectrum at ``damping``, with
    ``direction=vertical`` the vertical one (no ground type needed); anything
    else is a CSV file of (period s, PSA m/s²) computed at ``damping``.

    Raises:
        ScenarioError: a malformed code spectrum, a bad file (see :func:`read_target_csv`).
    """
    if spec.lower().startswith("ec8:"):
        return _parse_ec8(spec, damping)
    if re.match(r"^[a-z0-9]+:", spec, re.IGNORECASE) and not Path(spec).exists():
        raise ScenarioError(
            f"target {spec!r}: unknown code spectrum {spec.split(':')[0]!r} (known: ec8), "
            "and no such file"
        )
    return read_target_csv(spec, damping, column)
