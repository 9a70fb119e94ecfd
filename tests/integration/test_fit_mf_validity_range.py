"""The MF stages hold the validity conditions over the data's ranges, the limits the written
.tir states (identify.fit.mf.stages.fit_mf, identify.fit.limits.table_limits; issue 14).

Held over the start .tir's +-1.5 in slip ratio and slip angle instead, Gx_alpha > 0 and
Gy_kappa > 0 excluded the bundled tyre itself (RCX1 = RCY1 = 1.05: cos(1.05 atan(...)) turns
negative at slip angles far beyond any sweep), and its noise-free combined-slip sweeps were
fitted at RCX1 1.024, RCY1 1.035 (generated TTC sessions, docs/intervals.md). The table here
is noise-free drive/brake sweeps of that tyre to |kappa| 0.15 at slip angles to 6 deg, with the
pure-slip coefficients at the truth: the combined stages must return the truth's values.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from identify.fit.limits import TABLE_LIMIT_COLUMNS, table_limits
from identify.fit.mf.constraints import stage_constraints, violations
from identify.fit.mf.stages import fit_mf
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.parameters import defaults
from identify.simulate import default_tir_path

COMBINED = ("RBX", "RCX", "REX", "RHX", "RBY", "RCY", "REY", "RHY", "RVY")
LIMITS = {k for pair in TABLE_LIMIT_COLUMNS for k in pair}


def _drive_brake(truth: dict[str, float]) -> pd.DataFrame:
    """Noise-free kappa sweeps (-0.15..0.15) at 3 loads x 5 slip angles (-6..6 deg), one run
    each, with Fx, Fy [N] of ``truth`` (useMode 211)."""
    kappa = np.linspace(-0.15, 0.15, 61)
    rows = [pd.DataFrame({"run": f"db{lf}_{a}", "Fz": lf * truth["FNOMIN"],
                          "p": truth["NOMPRES"], "Vx": 11.1, "kappa": kappa,
                          "alpha": np.deg2rad(a), "gamma": 0.0})
            for lf in (0.6, 1.0, 1.4) for a in (-6, -3, 0, 3, 6)]
    t = pd.concat(rows, ignore_index=True)
    out = evaluate(truth, *(t[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma", "Vx")),
                   p=t["p"].to_numpy(), mode=FIT_MODE)
    return t.assign(Fx=np.asarray(out["Fx"]), Fy=np.asarray(out["Fy"]))


@pytest.fixture(scope="module")
def case():
    truth = read_tir(default_tir_path()).params()
    start = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    # everything but the combined-slip coefficients at the truth; the .tir limits MFeval's
    # defaults (+-1.5 in slip ratio and slip angle)
    start.update({k: float(truth[k]) for k in truth
                  if not isinstance(truth[k], str) and not k.startswith(COMBINED)
                  and k not in LIMITS})
    assert start["ALPMAX"] == pytest.approx(1.5) and start["KPUMAX"] == pytest.approx(1.5)
    table = _drive_brake(truth)
    return truth, table, fit_mf(table, start, stages=("Fx", "Fy"), seed=0)


def test_the_grid_is_the_data_range(case):
    _, table, mf = case
    lim = table_limits(table)
    assert lim == {"FZMIN": pytest.approx(table.Fz.min()), "FZMAX": pytest.approx(table.Fz.max()),
                   "KPUMIN": -0.15, "KPUMAX": 0.15,
                   "ALPMIN": pytest.approx(np.deg2rad(-6)), "ALPMAX": pytest.approx(np.deg2rad(6))}
    assert "CAMMIN" not in lim  # one camber: no range, the start's limits stay
    assert {k: mf.params[k] for k in lim} == lim


@pytest.mark.parametrize("stage", ["Fx", "Fy"])
def test_the_combined_coefficients_are_the_truths(case, stage):
    """Noise-free: once the truth is feasible it is the exact optimum, and every free
    coefficient comes back to 1e-8 of it (1e-15 measured; the solver stops on its gradient
    test). Before, RCX1 and RCY1 ended at 1.0244 and 1.0345 (truth 1.05), REX1 at -0.494
    (-0.4) and RBX1 at 12.27 (12)."""
    truth, _, mf = case
    r = mf.result(stage)
    assert r.converged and r.active_constraints == ()
    assert {"Fx": {"RCX1", "REX1", "RBX1"}, "Fy": {"RCY1", "REY1", "RBY1"}}[stage] <= set(r.free)
    for name in r.free:
        assert r.parameters[name] == pytest.approx(float(truth[name]), rel=1e-8, abs=1e-10), \
            name


# ----- a grid as wide as the written limits ------------------------------------------------------
# The written .tir states the ranges of every fitted point, the characteristics' too
# (identify.workflows.tir_assembly.relation_reach): a Flatplank session reaching lower loads than
# the trailer's widens FZMIN, and the MF stages must hold their conditions down to it.

def _cornering(truth: dict[str, float]) -> pd.DataFrame:
    """Noise-free slip-angle sweeps (-12..12 deg) at 0.6, 1.0, 1.4 FNOMIN, camber 0, with Fy [N]
    of ``truth`` (useMode 211)."""
    alpha = np.deg2rad(np.linspace(-12.0, 12.0, 97))
    rows = [pd.DataFrame({"run": f"c{lf}", "Fz": lf * truth["FNOMIN"], "p": truth["NOMPRES"],
                          "Vx": 11.1, "kappa": 0.0, "alpha": alpha, "gamma": 0.0})
            for lf in (0.6, 1.0, 1.4)]
    t = pd.concat(rows, ignore_index=True)
    out = evaluate(truth, *(t[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma", "Vx")),
                   p=t["p"].to_numpy(), mode=FIT_MODE)
    return t.assign(Fy=np.asarray(out["Fy"]))


@pytest.fixture(scope="module")
def steep():
    """The bundled tyre with Ey = (0.7 - 0.3 dfz)(1 + 0.1) at negative slip: 0.90 at the
    table's least load (dfz = -0.4), 1.03 at 0.2 FNOMIN (dfz = -0.8), beyond its reach."""
    truth = read_tir(default_tir_path()).params()
    truth.update(PEY1=0.7, PEY2=-0.3)
    start = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    start.update({k: float(v) for k, v in truth.items()
                  if not isinstance(v, str) and k not in LIMITS})
    # no slip-ratio range in the table: a realistic one (at MFeval's +-1.5, Gy_kappa > 0 fails
    # with the tyre's RCY1 = 1.05; module doc)
    start.update(KPUMIN=-0.15, KPUMAX=0.15)
    reach = {"FZMIN": 0.2 * truth["FNOMIN"], "FZMAX": truth["FNOMIN"]}
    return truth, _cornering(truth), start, reach


def test_the_truth_breaks_ey_below_the_tables_loads(steep):
    """The premise: over the table's loads the truth is valid, over the reach it is not."""
    truth, table, start, reach = steep
    params = {**{k: float(v) for k, v in truth.items() if not isinstance(v, str)},
              "KPUMIN": start["KPUMIN"], "KPUMAX": start["KPUMAX"]}
    assert violations({**params, **table_limits(table)}, [truth["NOMPRES"]]) == ()
    broken = violations({**params, **table_limits(table), **reach}, [truth["NOMPRES"]])
    assert len(broken) == 1 and broken[0].startswith("Fy0: Ey <= 1 fails at Fz = 1000 N")


def test_the_grid_spans_the_reach_and_the_fit_meets_it(steep):
    """Without ``reach`` the noise-free fit returns the truth (PEY1, PEY2 to 1e-6), which the
    wider limits then break; with it, Ey <= 1 is active and the fitted values meet every
    condition over the union of the ranges (FZMIN 1000 N, FZMAX the table's 7000 N)."""
    truth, table, start, reach = steep
    alone = fit_mf(table, start, stages=("Fy0",), seed=0).result("Fy0")
    assert alone.converged and alone.active_constraints == ()
    for name in ("PEY1", "PEY2"):
        assert alone.parameters[name] == pytest.approx(truth[name], abs=1e-6), name
    wide = fit_mf(table, start, stages=("Fy0",), seed=0, reach=reach)
    assert wide.params["FZMIN"] == 1000.0 and wide.params["FZMAX"] == table.Fz.max()
    r = wide.result("Fy0")
    assert r.converged and any("Ey" in c for c in r.active_constraints)
    assert violations(wide.params, [truth["NOMPRES"]]) == ()
    # held at the edge, not off by a wide berth: the Ey margin is ~0 at 1000 N
    ey = {c.name: c for c in stage_constraints("Fy0", wide.params, lambda v: wide.params,
                                               [truth["NOMPRES"]])}["Ey <= 1"]
    margin = ey.fun({})
    assert int(np.argmin(margin)) == 0 and 0 <= margin[0] < 1e-6
