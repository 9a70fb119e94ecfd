"""Real-data quirks put into a simulated TTC run, each recorded so a test can count it back.

Per run: :data:`REPEATS` repeated time stamps (and one that goes back, in the drive/brake run),
one gap in time (:data:`GAP` samples missing), :data:`SPIKES` isolated one-sample spikes (30-60 %
of the channel's range) on FZ, FY, FX, MZ, P and SA, :data:`DROPOUTS` dropouts (FX, FY, FZ,
MX, MZ read exactly 0 for 3-8 samples), and two NaN stretches (every channel for 20-60 samples;
FY alone for 10-30). They sit inside sweep segments, far apart, so that none hides another.

Optionally, implausible channels: the wheel speed N near zero while V is 40 kph, RE in
hundreds of metres, SR pinned at -1.
"""
from __future__ import annotations

import numpy as np

__all__ = ["DROPOUTS", "GAP", "IMPLAUSIBLE", "REPEATS", "SPIKES", "inject", "make_implausible"]

REPEATS = 4
SPIKES = 5
DROPOUTS = 2
GAP = 30
#: Names of the implausible channels ``make_implausible`` can write.
IMPLAUSIBLE = ("N", "RE", "SR")
_SPIKE_CHANNELS = ("FZ", "FY", "FX", "MZ", "P", "SA")
_LOADS = ("FX", "FY", "FZ", "MX", "MZ")


def _positions(rng: np.random.Generator, allowed: np.ndarray, count: int,
               spacing: int = 300) -> np.ndarray:
    """``count`` sample positions among ``allowed`` (True), at least ``spacing`` apart."""
    candidates = np.flatnonzero(allowed)
    candidates = candidates[(candidates > 500) & (candidates < allowed.size - 500)]
    chosen: list[int] = []
    for i in rng.permutation(candidates):  # stops after a few draws: not a loop over samples
        if all(abs(int(i) - c) >= spacing for c in chosen):
            chosen.append(int(i))
            if len(chosen) == count:
                break
    return np.array(sorted(chosen), dtype=int)


def inject(ch: dict[str, np.ndarray], in_sweep: np.ndarray, rng: np.random.Generator,
           drive_brake: bool) -> tuple[dict[str, np.ndarray], dict]:
    """Put the quirks into the channels (file units, file order); return them and a record.

    Parameters
    ----------
    ch : dict of ndarray
        TTC channels in the file's units.
    in_sweep : ndarray of bool
        Samples inside sweep segments (where the quirks may go).
    rng : numpy.random.Generator
    drive_brake : bool
        Add one time stamp that goes back (the drive/brake run).

    Returns
    -------
    (dict, dict)
        The channels (samples of the gap removed) and what was injected: per kind the count
        and the ET values (clean time) where it sits.
    """
    ch = {k: np.array(v, dtype=float) for k, v in ch.items()}
    n_repeat = REPEATS + (1 if drive_brake else 0)
    n_nan = 2
    pos = _positions(rng, in_sweep, n_repeat + SPIKES + DROPOUTS + n_nan + 1)
    pos = rng.permutation(pos)
    rep, pos = pos[:n_repeat], pos[n_repeat:]
    spk, pos = pos[:SPIKES], pos[SPIKES:]
    drop, pos = pos[:DROPOUTS], pos[DROPOUTS:]
    nans, gap = pos[:n_nan], pos[n_nan]
    et = ch["ET"]
    record: dict = {"time-order": {"count": int(n_repeat), "at_s": sorted(et[rep].tolist())}}
    clean_et = et.copy()
    et[rep[:REPEATS]] = et[rep[:REPEATS] - 1]
    if drive_brake:
        et[rep[REPEATS]] = et[rep[REPEATS] - 1] - 0.004
    spikes = []
    for i, name in zip(spk, rng.choice(_SPIKE_CHANNELS, size=SPIKES)):
        x = ch[name]
        lo, hi = np.nanpercentile(x, [0.5, 99.5])
        x[i] = x[i] + rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.6) * (hi - lo)
        spikes.append({"channel": str(name), "at_s": float(clean_et[i])})
    record["spike"] = {"count": SPIKES, "where": spikes}
    widths = rng.integers(3, 9, size=DROPOUTS)
    for i, w in zip(drop, widths):
        for name in _LOADS:
            ch[name][i:i + w] = 0.0
    record["dropout"] = {"count": int(widths.sum()), "events": DROPOUTS,
                         "at_s": sorted(clean_et[drop].tolist())}
    w_all, w_fy = int(rng.integers(20, 61)), int(rng.integers(10, 31))
    for name in ch:
        if name not in ("ET", "RUN"):
            ch[name][nans[0]:nans[0] + w_all] = np.nan
    ch["FY"][nans[1]:nans[1] + w_fy] = np.nan
    record["nan"] = {"count": w_all + w_fy, "stretches": 2,
                     "at_s": sorted(clean_et[nans].tolist())}
    keep = np.ones(et.size, dtype=bool)
    keep[gap:gap + GAP] = False
    record["time-gap"] = {"count": 1, "samples": GAP, "at_s": float(clean_et[gap])}
    return {k: v[keep] for k, v in ch.items()}, record


def make_implausible(ch: dict[str, np.ndarray], names, rng: np.random.Generator) -> dict:
    """Make the named channels implausible (file units): N near zero, RE x 1000 (hundreds of
    metres), SR pinned at -1."""
    ch = dict(ch)
    n = ch["ET"].size
    if "N" in names:
        ch["N"] = 0.2 + 0.05 * rng.standard_normal(n)
    if "RE" in names:
        ch["RE"] = ch["RE"] * 1000.0
    if "SR" in names:
        ch["SR"] = np.full(n, -1.0)
    return ch
