"""Channels that older Tire Test Consortium rounds lack or leave empty, and what stands in.

Older rounds log SR (slip ratio based on the loaded radius) but no SL, or no wheel speed N; a
channel may also be present without one finite value. :func:`ttc_substitutes` says which
channels are empty and lets SR stand in for a missing or empty SL (never a pinned SR);
:func:`sr_as_kappa` scales that SR to its free-rolling value. The trailer loader
(:func:`identify.io.trailer.files.channels_to_tidy`) gives each as a warning.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.io.trailer.channels import Channels
from identify.io.trailer.quirks import unused_slip_warning
from identify.io.ttc.channel_names import TTC_TO_TYDEX

__all__ = ["SR_FREE_ROLLING", "SR_FREE_ROLLING_RUN", "SR_FREE_SAMPLES", "SR_LINEAR",
           "SR_MIN_LOAD", "TTC_OPTIONAL",
           "sr_as_kappa", "ttc_substitutes"]


#: TYDEX name -> what follows when a TTC file lacks the channel (older rounds): not required.
TTC_OPTIONAL = {"WHROTSPD": "no wheel-speed channel: the revolution average takes V / RE, "
                             "the effective-radius stage is skipped"}


def ttc_substitutes(ch: Channels, by_canon: dict[str, list[str]]
                     ) -> list[tuple[tuple[str, ...], str, str]]:
    """Channels of a TTC file present without one finite value (not used), and SR in place
    of a slip ratio SL that is missing or empty (older rounds log SR only); ``by_canon`` is
    updated. Returns (channels, detail, action) of the warnings to give."""
    out, empty = [], set()
    for name, values in ch.data.items():
        if TTC_TO_TYDEX.get(name) and not np.isfinite(values).any():
            out.append(((name,), "no finite value in the whole run", "channel not used"))
            empty.add(name)
    sr = ch.data.get("SR")
    if set(by_canon.get("LONGSLIP", ())) <= empty and sr is not None and np.isfinite(sr).any() \
            and unused_slip_warning(sr, file=ch.file, run=ch.run, channel="SR") is None:
        by_canon["LONGSLIP"] = ["SR"]  # its warning: channels_to_tidy, after sr_as_kappa
    return out


#: |Fx| / Fz below which a sample counts as free rolling for the offset of SR [-].
SR_FREE_ROLLING = 0.02
#: |Fx| / Fz that no loaded sample of a free-rolling run (no drive or brake torque) exceeds
#: [-]: a slip-ratio sweep of any tyre drives |Fx| / Fz far beyond it [-].
SR_FREE_ROLLING_RUN = 0.25
#: Samples near free rolling that the offset of SR needs at least [-].
SR_FREE_SAMPLES = 50
#: |Fx| / Fz within which a slip-ratio sweep is taken as linear in SR for the zero crossing
#: (the slip stiffness holds to about a third of the peak force) [-].
SR_LINEAR = 0.3
#: Share of the run's median |Fz| below which a sample is not free rolling but unloaded [-].
SR_MIN_LOAD = 0.2


def sr_as_kappa(frame: pd.DataFrame) -> tuple[pd.DataFrame, str]:
    """``frame`` with kappa = SR less its free-rolling value, and the warning's detail.

    SR is based on the loaded radius: at free rolling it reads RL / Re - 1 (a few per cent
    below zero, more at a higher load), which the MF stages would take for a slip: 1 + SR =
    (1 + kappa) RL / Re, so kappa = (1 + SR) / (1 + SR0) - 1 with SR0 its free-rolling
    value, fitted as a + b Fz + c p + d alpha^2 on the samples whose |Fx| is below
    :data:`SR_FREE_ROLLING` of Fz (the MF force at zero slip is small) and whose Fz is above
    :data:`SR_MIN_LOAD` of the median (not lifted off), and subtracted; each term is held
    within its range on those samples (no extrapolation to loads free rolling never reached).
    A drive/brake run passes free rolling in a few samples per sweep: with fewer than
    :data:`SR_FREE_SAMPLES` such samples, SR0 is the zero crossing of the sweeps' linear range
    (a slope term e Fx/Fz added, the samples below :data:`SR_LINEAR` of Fz).
    """
    sr, fz = frame["kappa"].to_numpy(float), frame["Fz"].to_numpy(float)
    fx = frame["Fx"].to_numpy(float)
    loaded = np.abs(fz) > SR_MIN_LOAD * np.median(np.abs(fz))
    if loaded.sum() >= 10 and np.quantile(np.abs(fx[loaded]) / np.abs(fz[loaded]),
                                          0.995) < SR_FREE_ROLLING_RUN:
        # no drive or brake torque anywhere (a cornering run): SR moves only with the loaded
        # radius (load, slip angle), which a fit would take for a slip-ratio sweep
        return frame.assign(kappa=0.0), (
            "no slip ratio SL and no longitudinal force beyond "
            f"{100 * SR_FREE_ROLLING_RUN:g} % of Fz in the run: the wheel rolled freely, "
            "kappa is 0 (SR, based on the loaded radius, moves with the radius only)")
    # loaded: with the tyre lifted off between sweeps Fx and Fz are both near 0 and SR reads
    # whatever the radius channel does there
    free = (np.abs(frame["Fx"].to_numpy(float)) < SR_FREE_ROLLING * np.abs(fz)) \
        & (np.abs(fz) > SR_MIN_LOAD * np.median(np.abs(fz)))
    what = "no slip ratio SL: kappa is SR, the slip ratio based on the loaded radius"
    x = np.column_stack([np.ones(fz.size), fz / 1e3, frame["p"].to_numpy(float) / 1e5,
                         frame["alpha"].to_numpy(float) ** 2])
    how = (f"a + b Fz + c p + d alpha^2 fitted on {int(free.sum())} samples with |Fx| < "
           f"{100 * SR_FREE_ROLLING:g} % of Fz")
    if free.sum() >= SR_FREE_SAMPLES:
        coef, *_ = np.linalg.lstsq(x[free], sr[free], rcond=None)
    else:
        # a slip-ratio sweep passes free rolling in a few samples: take the zero crossing of
        # the linear range instead, SR = SR0 + e Fx/Fz on the samples below SR_LINEAR of Fz
        free = (np.abs(fx) < SR_LINEAR * np.abs(fz)) & loaded
        if free.sum() < SR_FREE_SAMPLES:
            return frame, (f"{what}, as read (fewer than {SR_FREE_SAMPLES} samples near free "
                           "rolling to find its offset: the Fx fits take it for a slip)")
        slope = fx / np.where(fz != 0, np.abs(fz), np.nan)
        coef, *_ = np.linalg.lstsq(np.column_stack([x, slope])[free], sr[free], rcond=None)
        coef = coef[:-1]
        how = (f"a + b Fz + c p + d alpha^2 + e Fx/Fz fitted on {int(free.sum())} samples "
               f"with |Fx| < {100 * SR_LINEAR:g} % of Fz, taken at Fx = 0")
    # evaluated within the conditions it was fitted on: a load, pressure or slip angle beyond
    # them takes the nearest one's offset. A slope from the noise of a narrow spread is not
    # extrapolated, and a term constant on the free-rolling samples (one load, one pressure),
    # whose coefficient lstsq's minimum-norm answer shares with the intercept, adds the same
    # constant everywhere.
    offset = np.clip(x, x[free].min(axis=0), x[free].max(axis=0)) @ coef
    mid = float(np.median(offset))
    return frame.assign(kappa=(1.0 + sr) / (1.0 + offset) - 1.0), (
        f"{what}, scaled to its free-rolling value ({mid:+.4f} at the median load and pressure; "
        f"{how})")
