"""Accelerograms (bundled El Centro 1940 AT2, CSV, synthetic) and Rayleigh damping."""

import math

import numpy as np
import pytest

from crane_fem.errors import ScenarioError
from crane_fem.loading import bundled, rayleigh_from_damping, read_at2, read_csv, synthetic

pytestmark = pytest.mark.no_kernels


@pytest.mark.parametrize(
    ("name", "npts"),
    [("el_centro_1940_up", 5378), ("el_centro_1940_180", 5372), ("el_centro_1940_270", 5346)],
)
def test_bundled_el_centro(name, npts) -> None:
    rec = bundled(name)
    assert rec.t.size == npts and rec.t[1] == pytest.approx(0.01)
    assert rec.duration == pytest.approx(0.01 * (npts - 1))
    # Strong motion: PGA between 0.1 g and 0.5 g for all three components of this record.
    assert 0.1 * 9.80665 < rec.pga < 0.5 * 9.80665
    assert rec(-1.0) == 0.0 and rec(1e3) == 0.0
    assert rec(0.005) == pytest.approx(0.5 * (rec.a[0] + rec.a[1]))


def test_csv_roundtrip_and_errors(tmp_path) -> None:
    rec = bundled("el_centro_1940_180")
    path = tmp_path / "rec.csv"
    np.savetxt(
        path, np.column_stack([rec.t, rec.a / 9.80665]), delimiter=",", header="t, a", comments=""
    )
    back = read_csv(path, units="g")
    np.testing.assert_allclose(back.a, rec.a, rtol=1e-12)
    bad = tmp_path / "bad.csv"
    bad.write_text("0, 1\n0.1, 2\n0.1, 3\n")
    with pytest.raises(ScenarioError, match="strictly increasing"):
        read_csv(bad)
    with pytest.raises(ScenarioError, match="not found"):
        read_csv(tmp_path / "none.csv")


@pytest.mark.parametrize("sep", ["; ", " ", "\t", ";"])
def test_csv_of_other_separators(tmp_path, sep) -> None:
    """A 201-row record with semicolons, spaces or tabs between its columns (a spreadsheet's
    or a logger's export) reads as the comma one does."""
    t = np.linspace(0.0, 2.0, 201)
    a = np.sin(7.0 * t)
    path = tmp_path / "rec.csv"
    path.write_text(
        "t"
        + sep
        + "a\n"
        + "".join(f"{float(x)!r}{sep}{float(y)!r}\n" for x, y in zip(t, a, strict=True))
    )
    rec = read_csv(path)
    assert rec.t.size == 201
    np.testing.assert_allclose(rec.a, a, rtol=0, atol=0)


def test_csv_with_a_third_column_refused(tmp_path) -> None:
    """A third column (another component, a velocity) is refused naming the line: which one
    is the acceleration cannot be guessed."""
    path = tmp_path / "three.csv"
    path.write_text("t, ax, ay\n0.0, 0.1, 0.2\n0.01, 0.3, 0.4\n")
    with pytest.raises(ScenarioError, match=r"three.csv: line 2: 3 columns; a record has two"):
        read_csv(path)


@pytest.mark.parametrize("sep", [";", "; ", "\t", " "])
def test_csv_with_decimal_commas_refused_with_a_hint(tmp_path, sep) -> None:
    """A record exported with decimal commas (``0,01;0,25``: a spreadsheet in a locale that
    writes them) splits into four columns; the error says why and what to write instead. Four
    columns without decimal commas get no such hint."""
    path = tmp_path / "comma.csv"
    path.write_text(f"t{sep}a\n0{sep}0\n0,01{sep}-1,5e-1\n0,02{sep}0,25\n")
    with pytest.raises(ScenarioError) as exc:
        read_csv(path)
    message = str(exc.value)
    assert message.startswith(f"{path}: line 3: 4 columns; a record has two"), message
    assert "decimal commas" in message and "0.01, not 0,01" in message, message
    path.write_text("t, a, b, c\n0.0, 0.1, 0.2, 0.3\n")
    with pytest.raises(ScenarioError) as exc:
        read_csv(path)
    assert "4 columns" in str(exc.value) and "decimal commas" not in str(exc.value)


def test_csv_units_key(tmp_path) -> None:
    """``loading.ground_motion.units = "g"`` reads a .csv in g; on another record it is
    refused."""
    from conftest import make_scenario

    from crane_fem.pipeline.loads import ground_motion

    path = tmp_path / "g.csv"
    path.write_text("0.0, 0.0\n0.01, 0.5\n0.02, 0.0\n")
    sc = make_scenario(loading={"ground_motion": {"record": str(path), "units": "g"}})
    gm = sc.loading.ground_motions[0]
    assert ground_motion(gm)(0.01) == pytest.approx(0.5 * 9.80665)
    with pytest.raises(Exception, match=r"units applies to a \.csv record"):
        make_scenario(loading={"ground_motion": {"record": "el_centro_1940_up", "units": "g"}})


def test_at2_header_errors(tmp_path) -> None:
    path = tmp_path / "x.AT2"
    path.write_text("A\nB\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= 3, DT= .01 SEC\n1 2\n")
    with pytest.raises(ScenarioError, match="NPTS=3 but the file holds 2"):
        read_at2(path)
    path.write_text("A\nB\nVELOCITY IN CM/S\nNPTS= 2, DT= .01 SEC\n1 2\n")
    with pytest.raises(ScenarioError, match="UNITS OF G"):
        read_at2(path)


def test_synthetic_pga_band_and_seed() -> None:
    a1 = synthetic(20.0, 0.01, pga=3.0, band=(1.0, 10.0), seed=7)
    a2 = synthetic(20.0, 0.01, pga=3.0, band=(1.0, 10.0), seed=7)
    a3 = synthetic(20.0, 0.01, pga=3.0, band=(1.0, 10.0), seed=8)
    assert a1.pga == pytest.approx(3.0, rel=1e-14)
    np.testing.assert_array_equal(a1.a, a2.a)
    assert not np.array_equal(a1.a, a3.a)
    spec = np.abs(np.fft.rfft(a1.a)) ** 2
    f = np.fft.rfftfreq(a1.a.size, 0.01)
    # The envelope spreads the band edges a little: ≥ 95 % of the power stays in the band.
    inside = spec[(f >= 0.8) & (f <= 12.0)].sum() / spec.sum()
    assert inside >= 0.95
    # Envelope: quiet start and end.
    assert np.max(np.abs(a1.a[:10])) < 0.05 * 3.0 and np.max(np.abs(a1.a[-10:])) < 0.2 * 3.0


def test_rayleigh_from_damping_exact_at_both_frequencies() -> None:
    alpha, beta = rayleigh_from_damping(0.05, 2.0, 20.0)
    for f in (2.0, 20.0):
        w = 2 * math.pi * f
        assert alpha / (2 * w) + beta * w / 2 == pytest.approx(0.05, rel=1e-13)
    with pytest.raises(ScenarioError):
        rayleigh_from_damping(0.05, 20.0, 2.0)
