"""Peaks exact to the micro step: the contact groups' peak force and its time, uplift and
lift-offs, the same whatever the output rate, for monolithic and coupled runs alike."""

from pathlib import Path

import numpy as np
import pytest

from crane_fem.bench.common import demo, run_case
from crane_fem.peaks import LIFT_GAP, LIFT_HEIGHT, ContactPeaks


def _feed(peaks: ContactPeaks, t, impulse, gap, sizes) -> None:
    a = 0
    for n in sizes:
        peaks.update(t[a : a + n], impulse[a : a + n], gap[a : a + n])
        a += n
    assert a == t.size


def test_contact_peaks_by_hand() -> None:
    """One group, 20 steps of Δt = 0.5: a chatter separation below LIFT_HEIGHT (steps 2–3),
    a lift-off across chunk boundaries (steps 6–11, 3 mm high), one still flying at the end
    (steps 17–19); the largest force at step 13. Any chunking gives the same table."""
    dt = 0.5
    t = dt * np.arange(1, 21, dtype=np.float64)
    gap = np.zeros((20, 1))
    gap[2:4, 0] = 0.5 * LIFT_HEIGHT
    gap[6:12, 0] = [1e-4, 1e-3, 3e-3, 2e-3, 5e-4, 2 * LIFT_GAP]
    gap[17:, 0] = [2e-4, 4e-4, 6e-4]
    impulse = np.where(gap > LIFT_GAP, 0.0, 1.0 * dt)
    impulse[13, 0] = 7.0 * dt
    tables = []
    for sizes in ([20], [1] * 20, [3, 5, 2, 7, 3], [7, 13]):
        peaks = ContactPeaks(["g"], dt)
        _feed(peaks, t, impulse, gap, sizes)
        tables.append(peaks.table())
    assert all(tab == tables[0] for tab in tables)
    g = tables[0]["g"]
    assert g["lift_offs"] == {
        "count": 2,
        "intervals": [[t[6], t[11]], [t[17], t[19]]],
        "apex_m": [3e-3, 6e-4],  # the second still under way: its height so far
    }
    assert g["max_uplift_m"] == 3e-3
    assert g["peak_force_N"] == 7.0
    assert g["peak_force_time_s"] == t[13]
    # The landing at step 12 strikes until the next opening (step 17): forces 1, 7, 1, 1, 1.
    assert g["impacts"] == [
        {"t_s": t[12], "impulse_Ns": 5.5, "duration_s": t[17] - t[12], "peak_force_N": 7.0}
    ]
    # With a static force of 2 N an impact's forces exceed 2 × 2 N: step 13 alone (7 N).
    for sizes in ([20], [1] * 20, [13, 7]):
        peaks = ContactPeaks(["g"], dt, static=np.array([2.0]))
        _feed(peaks, t, impulse, gap, sizes)
        assert peaks.table()["g"]["impacts"] == [
            {"t_s": t[13], "impulse_Ns": 3.5, "duration_s": dt, "peak_force_N": 7.0}
        ]


def test_max_uplift_at_the_runs_end() -> None:
    """A largest uplift at the last micro step — a flight still rising when the run ends — is
    flagged (``max_uplift_at_end``: the window cuts the flight, its value a lower bound of
    the apex), whatever the chunking and across a checkpoint; not a flight that has passed
    its apex, not a chatter below LIFT_HEIGHT, not a landed flight higher than the one under
    way. Groups: rising at the end (3 mm at the last step), past its apex (4 mm, falling),
    landed at 3 mm then rising to 2 mm, chatter rising to 0.5 LIFT_HEIGHT."""
    dt = 0.5
    t = dt * np.arange(1, 11, dtype=np.float64)
    gap = np.zeros((10, 4))
    gap[5:, 0] = [1e-4, 5e-4, 1e-3, 2e-3, 3e-3]
    gap[5:, 1] = [1e-3, 4e-3, 3e-3, 2e-3, 1e-3]
    gap[1:4, 2] = [1e-3, 3e-3, 1e-3]
    gap[7:, 2] = [5e-4, 1e-3, 2e-3]
    gap[8:, 3] = [0.2 * LIFT_HEIGHT, 0.5 * LIFT_HEIGHT]
    impulse = np.where(gap > LIFT_GAP, 0.0, dt)
    names = ["rising", "falling", "landed", "chatter"]
    for sizes in ([10], [1] * 10, [4, 6], [9, 1]):
        peaks = ContactPeaks(names, dt)
        _feed(peaks, t[: sizes[0]], impulse[: sizes[0]], gap[: sizes[0]], [sizes[0]])
        again = ContactPeaks(names, dt)  # a restart from the state after the first chunk
        again.load_state_dict(peaks.state_dict())
        _feed(again, t[sizes[0] :], impulse[sizes[0] :], gap[sizes[0] :], sizes[1:])
        table = again.table()
        flags = {k: v["max_uplift_at_end"] for k, v in table.items()}
        assert flags == {"rising": True, "falling": False, "landed": False, "chatter": False}
        apexes = {k: v["lift_offs"]["apex_m"] for k, v in table.items()}
        assert apexes == {
            "rising": [3e-3],
            "falling": [4e-3],
            "landed": [3e-3, 2e-3],
            "chatter": [],
        }
    old = peaks.state_dict()  # a checkpoint written before the flag: read as not at the end
    del old["_gap_last"], old["apexes"]
    fresh = ContactPeaks(names, dt)
    fresh.load_state_dict(old)
    assert not any(v["max_uplift_at_end"] for v in fresh.table().values())
    landed = fresh.table()["landed"]["lift_offs"]["apex_m"]  # its landed flight's: unknown
    assert np.isnan(landed[0]) and landed[1] == 1e-3  # (the state after 9 steps)


def test_an_impact_holds_its_rattle_and_ends_after_a_quiet_spell() -> None:
    """Δt = 0.1 ms, so an impact ends after 10 quiet steps (IMPACT_QUIET = 1 ms). A landing
    strikes in three bursts 5 quiet steps apart (one impact), then the force stays at the
    static level (the impact ends where that began). A later burst with no landing before it
    is not an impact. Any chunking gives the same impact."""
    dt = 1e-4
    n = 80
    t = dt * np.arange(1, n + 1)
    gap = np.zeros((n, 1))
    gap[:10, 0] = 1e-3  # flying from an earlier lift-off of 1 mm
    force = np.full(n, 100.0)  # the static force (weight carried)
    force[:10] = 0.0
    bursts = [10, 11, 17, 23, 24]  # loud steps: 0.1 ms rattle within the landing
    force[bursts] = [900.0, 5000.0, 700.0, 1200.0, 300.0]
    force[60] = 4000.0  # no landing before it: not an impact
    impulse = (force * dt)[:, None]
    expected = {
        "t_s": t[10],
        "impulse_Ns": float(impulse[10:25, 0].sum()),
        "duration_s": t[25] - t[10],
        "peak_force_N": 5000.0,
    }
    for sizes in ([n], [1] * n, [12, 7, 9, 30, 22], [26, 54], [10, 15, 55]):
        peaks = ContactPeaks(["g"], dt, static=np.array([100.0]))
        peaks._flying[0], peaks._onset[0], peaks._height[0] = True, 0.0, 1e-3
        _feed(peaks, t, impulse, gap, sizes)
        (got,) = peaks.table()["g"]["impacts"]
        assert got["t_s"] == expected["t_s"] and got["peak_force_N"] == pytest.approx(5000.0)
        assert got["impulse_Ns"] == pytest.approx(expected["impulse_Ns"], rel=1e-14)
        assert got["duration_s"] == pytest.approx(expected["duration_s"], rel=1e-12)


def test_impacts_of_a_group_that_starts_open() -> None:
    """A group open at the start strikes at its first closing; one striking at the end
    reports the impact under way, ending at the last time."""
    dt = 1.0
    t = np.arange(6, dtype=np.float64)
    gap = np.array([[1e-3], [5e-4], [0.0], [0.0], [0.0], [0.0]])
    impulse = np.array([[0.0], [0.0], [0.0], [2.0], [3.0], [1.0]])
    peaks = ContactPeaks(["g"], dt)
    peaks.start(t[0], impulse[0] / dt, gap[0])
    peaks.update(t[1:], impulse[1:], gap[1:])
    assert peaks.table()["g"]["impacts"] == [
        {"t_s": 3.0, "impulse_Ns": 6.0, "duration_s": 2.0, "peak_force_N": 3.0}
    ]


QUICK = demo("crane_quick")
#: Through the landing of the quick scene (the wheels come down at about 0.052 s).
END = 0.055
FRAME = demo("frame_crane")
#: Through the frame crane's first landing (its wheels lift off at 0.055 s and land at
#: 0.1265 s, fully explicit).
FRAME_END = 0.13


def _wheels(
    tmp: Path, label: str, settings: dict, scene: Path = QUICK, end: float = END
) -> tuple[dict, dict]:
    out = run_case(label, scene, {"output.xdmf": False, "time.end": end, **settings}, tmp / label)
    assert out.status == "completed"
    return out.summary["wheels"], {**out.history, "dt": out.summary["dt"]}


@pytest.mark.slow
@pytest.mark.serial
def test_monolithic_peak_between_output_rows_is_exact(tmp_path) -> None:
    """The frame crane fully explicit through its first landing (11 600 micro steps of 11 µs;
    the 3D quick crane's landing takes 42 000 of 1.3 µs, at a row each). With a row every
    micro step (ratio 1) the summary's peak force of each wheel is the largest row, at its
    time, and its uplift the largest gap; with rows every 3 × 100 micro steps the rows miss
    the landing's peak altogether (it falls between two of them: their largest force is 2 %
    of it, measured) but the summary reports the same peak, time, uplift and lift-off."""
    # (Rows every micro step: the members' stress and the supports, which read whole fields,
    # only every 1000 of them — they are not what this test is about.)
    frame = {"scene": FRAME, "end": FRAME_END}
    dense_settings = {"coupling.method": "monolithic", "coupling.ratio": 1}
    dense, hd = _wheels(tmp_path, "dense", {**dense_settings, "output.stress_every": 1000}, **frame)
    sparse, hs = _wheels(
        tmp_path,
        "sparse",
        {"coupling.method": "monolithic", "coupling.ratio": 100, "output.every": 3},
        **frame,
    )
    assert set(dense) == {"1", "2", "3", "4"}
    for k, w in dense.items():
        f = hd[f"force_wheel_{k}"]
        # The row sums forces Λ/Δt, the peak divides the summed Λ: the same to round-off.
        assert w["peak_force_N"] == pytest.approx(f.max(), rel=1e-12)
        assert w["peak_force_time_s"] == pytest.approx(hd["t"][f.argmax()], rel=1e-15)
        assert w["peak_force_time_s"] > 0.1265  # the landing's
        assert w["max_uplift_m"] == pytest.approx(hd[f"gap_wheel_{k}"].max(), rel=1e-12)
        assert w["lift_offs"]["count"] == 1  # the flight of 0.055–0.1265 s
        # A point-on-line contact is placed along its line once per record (100 micro steps
        # or 1): the two runs' micro steps differ in their last bits (measured: the uplift
        # 1.4e-9 relative, the peak force to the bit), so to 1e-8 here; the 3D quick
        # crane's node pairs give the bit (test_coupled_peak_does_not_depend_on_output_rate).
        s = sparse[k]
        assert s["peak_force_N"] == pytest.approx(w["peak_force_N"], rel=1e-8)
        assert s["peak_force_time_s"] == pytest.approx(w["peak_force_time_s"], rel=1e-12)
        assert s["max_uplift_m"] == pytest.approx(w["max_uplift_m"], rel=1e-8)
        assert s["lift_offs"]["count"] == w["lift_offs"]["count"]
        np.testing.assert_allclose(
            s["lift_offs"]["intervals"], w["lift_offs"]["intervals"], rtol=1e-12
        )
        # The sparse rows missed it: their largest force is far below (2 % measured).
        assert hs[f"force_wheel_{k}"].max() < 0.5 * s["peak_force_N"]
        assert not np.any(np.isclose(hs["t"], s["peak_force_time_s"], rtol=0, atol=1e-12))


@pytest.mark.slow
@pytest.mark.serial  # two ranks: their wheels tables against serial ones, test_adaptive.py
def test_coupled_peak_does_not_depend_on_output_rate(tmp_path) -> None:
    """The quick crane as written (m = 100, refined at impacts): rows every sampling interval
    (100 micro steps) or every 4th, the same wheels table, to the bit; the peak falls
    between rows, at a micro step's time, above every row. (On two ranks the same peak
    tracker, fed by the same micro steps, reports what a serial run does: the wheels tables
    of the same scene through its landing, serial against two ranks, in
    test_adaptive.py::test_quick_scene_as_written_mpiexec_same_as_serial.)"""
    every1, h1 = _wheels(tmp_path, "every1", {"output.every": 1})
    every4, h4 = _wheels(tmp_path, "every4", {"output.every": 4})
    assert every1 == every4  # the same micro steps, computed the same way: to the bit
    dt = h1["dt"]
    for k, w in every1.items():
        assert w["peak_force_N"] > h1[f"force_wheel_{k}"].max()
        assert w["peak_force_N"] > h4[f"force_wheel_{k}"].max()
        j = w["peak_force_time_s"] / dt
        assert abs(j - round(j)) < 1e-6 and round(j) % 100 != 0  # a micro step between rows
        assert w["lift_offs"]["count"] == 1
