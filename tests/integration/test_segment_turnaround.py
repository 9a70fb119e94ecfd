"""Slip-angle turn-arounds of a sweep (identify.segment.turnaround) and the Mz taken out there
before the MF stages (identify.workflows.trailer_prep)."""
import numpy as np
import pandas as pd

from identify.segment.turnaround import TURN_AFTER, TURN_BEFORE, turnaround_mask


def _sweep(dt: float, amplitude_deg: float = 12.0, rate_deg_s: float = 4.0,
           hold_s: float = 2.0) -> pd.DataFrame:
    """A triangle sweep 0 -> +A -> -A -> 0 at a constant rate, then a hold at 0, sampled every
    ``dt`` s; its turn-arounds are at A/rate and 3 A/rate [s]."""
    t_sweep = 4 * amplitude_deg / rate_deg_s
    t = np.arange(0.0, t_sweep + hold_s, dt)
    phase = np.clip(t, 0, t_sweep) * rate_deg_s / amplitude_deg  # 0..4
    tri = np.where(phase < 1, phase, np.where(phase < 3, 2 - phase, phase - 4))
    return pd.DataFrame({"run": "r", "t": t, "alpha": np.deg2rad(amplitude_deg * tri)})


def test_the_samples_around_each_reversal_are_marked_and_no_others():
    for dt in (0.01, 0.02):
        frame = _sweep(dt)
        mask = turnaround_mask(frame)
        turns = np.array([3.0, 9.0])  # A/rate and 3 A/rate
        t = frame["t"].to_numpy()
        lag = t[:, None] - turns[None, :]
        expected = ((lag >= -TURN_BEFORE) & (lag <= TURN_AFTER)).any(axis=1)
        # a sample exactly at a window's edge may fall either side by rounding of the times
        edge = (np.isclose(lag, -TURN_BEFORE, atol=1e-9)
                | np.isclose(lag, TURN_AFTER, atol=1e-9)).any(axis=1)
        np.testing.assert_array_equal(mask[~edge], expected[~edge])
        assert mask[~edge].sum() >= 2 * round((TURN_BEFORE + TURN_AFTER) / dt) - 2
        # the sweep's return to 0 and the hold there are no turn-around
        assert not mask[t > 10.0].any()


def test_a_held_angle_with_noise_and_a_step_programme_have_no_turnaround():
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 20.0, 0.01)
    held = pd.DataFrame({"run": "h", "t": t,
                         "alpha": np.deg2rad(3.0 + 0.05 * rng.standard_normal(t.size))})
    assert not turnaround_mask(held).any()
    steps = pd.DataFrame({"run": "s", "t": t, "alpha": np.deg2rad(np.floor(t / 4.0))})
    assert not turnaround_mask(steps).any()


def test_each_run_is_taken_on_its_own_and_the_order_of_rows_is_kept():
    a, b = _sweep(0.01), _sweep(0.02).assign(run="other")
    both = pd.concat([a, b], ignore_index=True)
    mask = turnaround_mask(both)
    np.testing.assert_array_equal(mask[: len(a)], turnaround_mask(a))
    np.testing.assert_array_equal(mask[len(a):], turnaround_mask(b))
    assert turnaround_mask(both.iloc[:0]).size == 0


def test_prepare_trailer_takes_mz_out_at_turnarounds_only():
    """Mz is NaN at the marked samples, every other channel and sample as loaded; the count is
    recorded for fit.json."""
    from types import SimpleNamespace

    from identify.workflows.trailer_prep import prepare_trailer
    frame = _sweep(0.01).assign(Mz=1.0, Fy=2.0, Mx=3.0)
    mset = SimpleNamespace(trailer=frame, manifest=SimpleNamespace(runs=()), warnings=())
    td = prepare_trailer(mset, segment=False)
    mask = turnaround_mask(frame)
    assert td.mz_turnaround == mask.sum() > 0
    assert td.table["Mz"].isna().to_numpy().tolist() == mask.tolist()
    pd.testing.assert_frame_equal(td.table.drop(columns="Mz"), frame.drop(columns="Mz"))
    assert (frame["Mz"] == 1.0).all()  # the input is not modified
    assert td.to_dict()["mz_turnaround_samples"] == mask.sum()


def test_the_report_says_how_many_mz_samples_were_left_out():
    from identify.report.trailer_pages import segment_lines
    lines = segment_lines({"trailer": {"segmentation": None, "mz_turnaround_samples": 42}})
    assert any("turn-around" in line and "42 samples" in line for line in lines)
    assert not any("turn-around" in line for line in segment_lines({"trailer": {}}))
