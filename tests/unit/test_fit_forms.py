"""Form selection by the data (identify.fit.relations.forms): the nested pair, F test and held-out
check.

Characteristic tables are generated from the CFx relation of the simulator's default tyre
(quadratic in load, p2 = -0.28 at Fz0 = 4 kN) and from the same relation with p2 = 0, on the
Flatplank design (5 pressures x 3 loads), with 0.5 % relative noise per cell (the extraction's
per-cell standard error is 0.2-0.5 %, tests/unit/test_extract_accuracy.py). The full-pipeline
version (simulated raw runs, extraction, fit) runs in the trials.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from identify.fit.optimize import fit
from identify.fit.relations import problems as R
from identify.fit.relations.forms import FormChoice, choose_form, f_test, least_squares_fit
from identify.fit.relations.problems import Context
from identify.model import relations as rel
from identify.simulate.coefficients import DEFAULT_RELATIONS

PRESSURES_BAR = (1.9, 2.2, 2.5, 2.7, 3.0)
LOADS_N = (3000.0, 5000.0, 7000.0)
CTX = Context(fz0=5000.0, p0_bar=2.5, tir={"UNLOADED_RADIUS": 0.3135})
BUILDERS = {f: (lambda c, x, f=f: R.cfx(c, x, form=f)) for f in ("linear_load", "quadratic_load")}


def cfx_table(p2: float, seed: int, noise: float = 0.005) -> pd.DataFrame:
    cfx = dataclasses.replace(DEFAULT_RELATIONS.cfx, p2=p2)
    pi, fz = (a.ravel() for a in np.meshgrid(PRESSURES_BAR, LOADS_N))
    true = cfx(fz, rel.dpi(pi, 2.5))
    value = true * (1 + noise * np.random.default_rng(seed).standard_normal(true.size))
    return pd.DataFrame({"quantity": "CFx", "pi_bar": pi, "p_Pa": pi * 1e5, "Fz_N": fz,
                         "value": value, "unit": "N/m"})


def choice(chars: pd.DataFrame) -> FormChoice:
    results = {f: fit(b(chars, CTX)) for f, b in BUILDERS.items()}
    return choose_form("CFx", results, BUILDERS, chars, CTX, "CFx")


@pytest.mark.parametrize("seed", [0, 1])
def test_quadratic_form_is_chosen_when_the_data_curve(seed):
    c = choice(cfx_table(-0.280917, seed))
    assert c.form == "quadratic_load" and c.p_value < 1e-6
    assert c.held_out_pct["quadratic_load"] < c.held_out_pct["linear_load"]


@pytest.mark.parametrize("seed", [0, 1])
def test_linear_form_is_kept_when_the_data_do_not_curve(seed):
    c = choice(cfx_table(0.0, seed))
    assert c.form == "linear_load" and c.p_value > 0.01, c.reason


def test_override_and_json_round_trip():
    chars = cfx_table(0.0, 3)
    results = {f: fit(b(chars, CTX)) for f, b in BUILDERS.items()}
    c = choose_form("CFx", results, BUILDERS, chars, CTX, "CFx", override="quadratic_load")
    assert c.form == "quadratic_load" and c.overridden and "--form" in c.reason
    assert FormChoice.from_dict(c.to_dict()).to_dict() == c.to_dict()
    assert c.p_value > 0.01  # the statistics are kept: the user overrode a non-significant term
    with pytest.raises(ValueError, match="unknown form"):
        choose_form("CFx", results, BUILDERS, chars, CTX, "CFx", override="cubic")


def test_f_test_against_the_exact_distribution():
    # under the simpler model the F statistic of a nested pair is F(1, n - k) distributed, so its
    # p-values are uniform; PCFX2 is bounded to <= 0, so in about half the noise draws the
    # quadratic fit sits on the bound (F = 0, p = 1) and the test rejects in alpha/2 of them
    p = []
    for seed in range(200):
        chars = cfx_table(0.0, 100 + seed)
        lin, quad = (least_squares_fit(BUILDERS[f], chars, CTX,
                                       fit(BUILDERS[f](chars, CTX), n_starts=1))
                     for f in ("linear_load", "quadratic_load"))
        p.append(f_test(lin, quad)[1])
    # so P(p < a) = a/2 (the chi-bar-square mixture of a one-sided test): check at a = 0.2,
    # 0.5 and 1 % within 3.5 binomial standard deviations
    p = np.array(p)
    for level in (0.2, 0.5):
        sd = np.sqrt(level / 2 * (1 - level / 2) / p.size)
        assert abs(np.mean(p < level) - level / 2) < 3.5 * sd, level
    assert np.mean(p < 0.01) < 0.03
