"""Ground-acceleration records: PEER AT2 and CSV readers, bundled El Centro 1940, synthetic."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError

__all__ = [
    "BUNDLED",
    "Accelerogram",
    "bundled",
    "rayleigh_from_damping",
    "read_at2",
    "read_csv",
    "synthetic",
]

FloatArray = npt.NDArray[np.float64]
G = 9.80665  # standard gravity, m/s²
DATA = Path(__file__).parent / "data"
BUNDLED = {
    "el_centro_1940_up": "RSN6_IMPVALL.I_I-ELC-UP.AT2",
    "el_centro_1940_180": "RSN6_IMPVALL.I_I-ELC180-hor1.AT2",
    "el_centro_1940_270": "RSN6_IMPVALL.I_I-ELC270-hor2.AT2",
}


@dataclass(frozen=True)
class Accelerogram:
    """Ground acceleration a(t) in m/s², sampled at times t (s, increasing from 0)."""

    t: FloatArray
    a: FloatArray
    name: str

    @property
    def pga(self) -> float:
        return float(np.max(np.abs(self.a)))

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def __call__(self, time: float) -> float:
        """a(time), linear between samples, zero outside the record."""
        if time < self.t[0] or time > self.t[-1]:
            return 0.0
        return float(np.interp(time, self.t, self.a))

    def at(self, times: FloatArray) -> FloatArray:
        """a at many times: the values :meth:`__call__` gives, in one call."""
        out = np.interp(times, self.t, self.a)
        out[(times < self.t[0]) | (times > self.t[-1])] = 0.0
        return np.asarray(out, dtype=np.float64)

    def scaled(self, factor: float) -> Accelerogram:
        return Accelerogram(self.t, factor * self.a, f"{factor:g}×{self.name}")


def _bad_value(p: Path, numbered: list[tuple[int, str]]) -> str:
    """The message naming the first line of ``numbered`` (line number, text) that holds a
    value that is not a finite number."""
    for k, line in numbered:
        for tok in line.split():
            try:
                ok = math.isfinite(float(tok))
            except ValueError:
                return f"{p}: line {k}: {tok!r} is not a number"
            if not ok:
                return f"{p}: line {k}: {tok!r} is not a finite number"
    return f"{p}: a value is not a finite number"  # pragma: no cover  (the caller saw one)


def read_at2(path: str | Path) -> Accelerogram:
    """Read a PEER NGA AT2 file (4 header lines, NPTS/DT line, values in g); lines starting
    with '#' before the header are comments.

    Raises:
        ScenarioError: missing file, a malformed header / value count, or a value that is
            not a finite number (NaN, inf), naming the file and the line.
    """
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: accelerogram file not found")
    try:
        text = p.read_text(encoding="latin-1")
    except OSError as exc:
        raise ScenarioError(f"{p}: cannot read the accelerogram ({exc.strerror or exc})") from None
    numbered = [(k + 1, ln) for k, ln in enumerate(text.splitlines()) if not ln.startswith("#")]
    lines = [ln for _, ln in numbered]
    if len(lines) < 5:
        raise ScenarioError(f"{p}: not a PEER AT2 file (expected 4 header lines and values)")
    if "UNITS OF G" not in lines[2].upper():
        raise ScenarioError(f"{p}: AT2 line 3 must say 'ACCELERATION ... IN UNITS OF G'")
    m = re.search(r"NPTS\s*=\s*(\d+)\s*,\s*DT\s*=\s*([0-9.Ee+-]+)", lines[3])
    if m is None:
        raise ScenarioError(f"{p}: AT2 line 4 must read 'NPTS= n, DT= dt SEC'")
    npts = int(m.group(1))
    try:
        dt = float(m.group(2))
    except ValueError:
        dt = math.nan
    if not (math.isfinite(dt) and dt > 0.0):
        raise ScenarioError(
            f"{p}: line {numbered[3][0]}: DT must be a positive finite number, got {m.group(2)}"
        )
    try:
        values = np.array(" ".join(lines[4:]).split(), dtype=np.float64)
        finite = bool(np.all(np.isfinite(values)))
    except ValueError:
        finite = False
    if not finite:
        raise ScenarioError(_bad_value(p, numbered[4:]))
    if values.size != npts:
        raise ScenarioError(f"{p}: header says NPTS={npts} but the file holds {values.size}")
    return Accelerogram(dt * np.arange(npts, dtype=np.float64), G * values, p.stem)


#: A number written with a decimal comma (``0,01``, ``-1,5e-3``).
_DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+(?:[eE][+-]?\d+)?")


def _decimal_comma_hint(line: str) -> str:
    """The hint for a row that splits into two numbers with decimal commas once the commas
    are no longer taken as separators (``0,01;0,25``, ``0,01<tab>0,25``), else ``""``."""
    fields = [f for f in re.split(r"[;\s]+", line.strip()) if f]
    if (
        len(fields) == 2
        and all(_DECIMAL_COMMA.fullmatch(f) or re.fullmatch(r"[+-]?\d+", f) for f in fields)
        and "," in line
    ):
        return (
            f": {line.strip()!r} looks written with decimal commas; write decimal points "
            "(0.01, not 0,01), e.g. by exporting the spreadsheet with an English locale"
        )
    return ""


def read_csv(path: str | Path, units: str = "m/s2") -> Accelerogram:
    """Read a two-column record (t in s, a in ``units``: 'm/s2' or 'g'), its columns separated
    by commas, semicolons, tabs or spaces; a header row is allowed, a third column is not.

    Raises:
        ScenarioError: missing file, bad columns, a value that is not a finite number (NaN,
            inf: naming the line), or times not strictly increasing.
    """
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: accelerogram file not found")
    if units not in ("m/s2", "g"):
        raise ScenarioError(f"accelerogram units must be 'm/s2' or 'g', got {units!r}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{p}: cannot read the accelerogram ({exc})") from None
    rows: list[list[float]] = []
    for k, line in enumerate(text.splitlines()):
        parts = [s for s in re.split(r"[,;\s]+", line.strip()) if s]
        if not line.strip() or line.startswith("#"):
            continue
        try:
            row = [float(parts[0]), float(parts[1])]
        except (ValueError, IndexError):
            if rows:
                raise ScenarioError(f"{p}: line {k + 1}: expected 't, a' numbers") from None
            continue  # a header row
        if len(parts) != 2:
            raise ScenarioError(
                f"{p}: line {k + 1}: {len(parts)} columns; a record has two, 't, a' (time in s, "
                f"acceleration){_decimal_comma_hint(line)}"
            )
        if not all(math.isfinite(x) for x in row):
            raise ScenarioError(f"{p}: line {k + 1}: {line.strip()!r} is not a finite number")
        rows.append(row)
    if len(rows) < 2:
        raise ScenarioError(f"{p}: at least two 't, a' rows are needed")
    data = np.array(rows)
    if np.any(np.diff(data[:, 0]) <= 0.0):
        raise ScenarioError(f"{p}: times must be strictly increasing")
    scale = G if units == "g" else 1.0
    return Accelerogram(data[:, 0] - data[0, 0], scale * data[:, 1], p.stem)


def bundled(name: str) -> Accelerogram:
    """A record shipped with crane_fem (see ``BUNDLED``)."""
    if name not in BUNDLED:
        raise ScenarioError(f"unknown bundled record {name!r}; allowed: {', '.join(BUNDLED)}")
    rec = read_at2(DATA / BUNDLED[name])
    return Accelerogram(rec.t, rec.a, name)


def synthetic(
    duration: float,
    dt: float,
    pga: float,
    band: tuple[float, float] = (0.5, 15.0),
    seed: int = 0,
    rise: float = 0.15,
    decay: float = 0.5,
) -> Accelerogram:
    """Band-limited, enveloped white noise scaled to a target PGA (m/s²); reproducible by seed.

    Gaussian white noise is band-pass filtered in the frequency domain to [f_low, f_high] Hz and
    multiplied by a Jennings-type envelope: quadratic rise over ``rise``·duration, plateau, and
    exponential decay over the last ``decay``·duration (to 5 % at the end); then scaled so that
    max |a| = pga exactly.
    """
    if not (duration > 0 and dt > 0 and pga > 0 and 0 < band[0] < band[1] < 0.5 / dt):
        raise ScenarioError(
            "synthetic accelerogram: need duration, dt, pga > 0 and 0 < f_low < f_high < 1/(2 dt)"
        )
    n = math.floor(duration / dt) + 1
    t = dt * np.arange(n, dtype=np.float64)
    rng = np.random.default_rng(seed)
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, dt)
    spec[(f < band[0]) | (f > band[1])] = 0.0
    a = np.fft.irfft(spec, n)
    t1, t2 = rise * duration, (1.0 - decay) * duration
    env = np.where(t < t1, (t / t1) ** 2, 1.0)
    env = np.where(t > t2, np.exp(math.log(0.05) * (t - t2) / (duration - t2)), env)
    a = a * env
    return Accelerogram(t, a * (pga / np.max(np.abs(a))), f"synthetic(seed={seed})")


def rayleigh_from_damping(zeta: float, f1: float, f2: float) -> tuple[float, float]:
    """(α, β) of C = αM + βK giving damping ratio ``zeta`` at f1 and f2 (Hz), f1 < f2.

    ζ(ω) = α/(2ω) + βω/2 with α = 2ζω1ω2/(ω1 + ω2), β = 2ζ/(ω1 + ω2).
    """
    if not (zeta >= 0.0 and 0.0 < f1 < f2):
        raise ScenarioError("Rayleigh damping: need zeta >= 0 and 0 < f1 < f2")
    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2
    return 2 * zeta * w1 * w2 / (w1 + w2), 2 * zeta / (w1 + w2)
