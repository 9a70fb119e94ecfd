"""The moments of every real TTC set, once imported, are ISO-W moments about the contact point
(identify.io.axes): the aligning torque restores the slip angle, the overturning moment grows
with Fy by a lever far shorter than the loaded radius, and camber moves Mx the way the load's
centre moves. Skipped where ``../shared/realdata`` is absent."""
from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.fit.mf.stage_data import run_sweeps
from identify.io.folder import load_folder
from tests.realdata import SETS, trailer_files

pytestmark = pytest.mark.trials


def _rolling(folder, tmp_path):
    """The free-rolling samples of ``folder``'s runs (at speed, under load) and the tyre's
    unloaded radius [m]."""
    out = tmp_path / "set"
    result = CliRunner().invoke(app, ["import", *map(str, trailer_files(folder)), "--out",
                                      str(out)])
    assert result.exit_code == 0, result.output
    mset = load_folder(out)
    t = mset.trailer
    t = t[(t["Vx"] > 5) & (t["Fz"] > 100)]
    return t[run_sweeps(t)[2]], float(mset.manifest.tyre.unloaded_radius_m)


@pytest.mark.parametrize("folder", SETS, ids=lambda d: getattr(d, "name", "absent"))
def test_moments_are_iso_w_at_the_contact_point(tmp_path, folder):
    t, r0 = _rolling(folder, tmp_path)
    alpha, gamma = np.rad2deg(t["alpha"]), np.rad2deg(t["gamma"])
    cornering = t[(gamma.abs() < 0.5) & alpha.abs().between(2, 8)]
    assert len(cornering) > 500
    # ISO-W: alpha > 0 gives Fy < 0 and a restoring Mz > 0 (a few samples of pneumatic trail
    # turned negative near the peak, or a transient, may not)
    assert np.mean(np.sign(cornering["Fy"]) == -np.sign(cornering["alpha"])) > 0.98
    assert np.mean(np.sign(cornering["Mz"]) == np.sign(cornering["alpha"])) > 0.9
    # Mx about the contact point: Fz acting at the patch's lateral shift Fy/Cy gives a small
    # positive lever; about the wheel centre the lever would be the loaded radius more
    # (MxC = MxW + r_l Fy), about 10x this
    flat = t[gamma.abs() < 0.5]
    lever = np.polyfit(flat["Fy"], flat["Mx"], 1)[0]
    assert 0 < lever < 0.25 * r0
    # camber: the top tilted to -y (gamma > 0) loads the patch's -y side, Mx < 0 at zero slip
    straight = alpha.abs() < 0.5
    mx0 = t.loc[straight & (gamma.abs() < 0.5), "Mx"].mean()
    mx4 = t.loc[straight & ((gamma - 4).abs() < 0.5), "Mx"].mean()
    assert mx4 < mx0 - 10
