"""Slip-angle turn-arounds of a sweep, where the aligning-torque channel is not steady state.

A trailer sweeps the slip angle back and forth (0 -> +a -> -a -> 0). Where the steering reverses
at a sweep end, the rig's steering snaps: the slip angle jumps by a few tenths of a degree
within one sample and the steering system rings. The aligning-torque channel sees that as a
torque impulse of the order of the tyre's whole Mz, against the sweep direction, decaying
within a few tenths of a second (a damped oscillation of the steering's yaw compliance), while
Fy and Mx hardly move. The Magic Formula is a steady-state model: those samples are the rig's
response, not the tyre's characteristic, and the dense sweeps' end bins are made of them alone
(the jump carries the slip angle beyond the sweep's steady extent). :func:`turnaround_mask`
finds them; identify.workflows.trailer_prep takes Mz out of them (NaN) before the MF stages,
and says how many.

A turn-around is a sample whose slip angle is the extreme (maximum or minimum) of the samples
within TURN_SPAN of it, with the slip angle moving by more than TURN_SWING between it and each
side of that span: an actively swept reversal, not a held angle's noise nor a sweep that stops.
The samples from TURN_BEFORE before to TURN_AFTER after it are marked (times, not samples: the
ringing is the rig's, at any sample rate).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.ndimage import maximum_filter1d, minimum_filter1d

__all__ = ["TURN_AFTER", "TURN_BEFORE", "TURN_SPAN", "TURN_SWING", "turnaround_mask"]

TURN_SPAN = 0.5
"""[s] half-width of the window whose extreme a turn-around is."""
TURN_SWING = np.deg2rad(0.5)
"""[rad] slip-angle change within TURN_SPAN on both sides of a turn-around."""
TURN_BEFORE = 0.06
"""[s] samples this long before a turn-around are marked (the jump starts a few samples before
the extreme sample)."""
TURN_AFTER = 0.3
"""[s] samples this long after a turn-around are marked (the ringing has decayed)."""


def turnaround_mask(frame: pd.DataFrame) -> np.ndarray:
    """Per row of a tidy trailer table (columns run, t [s], alpha [rad]): whether it lies within
    [-TURN_BEFORE, +TURN_AFTER] of a slip-angle turn-around of its run (see the module notes).

    Rows are taken per run in their order; a run without a finite time step has none.
    """
    out = np.zeros(len(frame), dtype=bool)
    if frame.empty:
        return out
    codes = pd.factorize(frame["run"], use_na_sentinel=False)[0]
    t_all = frame["t"].to_numpy(float)
    a_all = frame["alpha"].to_numpy(float)
    for code in np.unique(codes):
        rows = np.flatnonzero(codes == code)
        t, a = t_all[rows], a_all[rows]
        ok = np.isfinite(t) & np.isfinite(a)
        dt = np.diff(t[ok])
        dt = dt[dt > 0]
        if dt.size == 0:
            continue
        rows, t, a = rows[ok], t[ok], a[ok]
        w = max(int(round(TURN_SPAN / float(np.median(dt)))), 1)
        size = 2 * w + 1
        is_max = a == maximum_filter1d(a, size, mode="nearest")
        is_min = a == minimum_filter1d(a, size, mode="nearest")
        idx = np.flatnonzero(is_max | is_min)
        idx = idx[(idx >= w) & (idx < a.size - w)]
        swing = np.minimum(np.abs(a[idx] - a[idx - w]), np.abs(a[idx] - a[idx + w]))
        turns = np.sort(t[idx[swing > TURN_SWING]])
        if turns.size == 0:
            continue
        # the nearest turn-around at or after each sample, and the nearest before it
        after = np.searchsorted(turns, t, side="left")
        next_turn = turns[np.minimum(after, turns.size - 1)]
        prev_turn = turns[np.maximum(after - 1, 0)]
        near = (((next_turn >= t) & (next_turn - t <= TURN_BEFORE))
                | ((prev_turn <= t) & (t - prev_turn <= TURN_AFTER))
                | (next_turn == t))
        out[rows] = near
    return out
