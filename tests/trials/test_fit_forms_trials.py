"""The long trials of tests/unit/test_fit_forms.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pytest

from tests.unit.test_fit_forms import (
    cfx_table,
    choice,
)


@pytest.mark.parametrize("p2, form", [(-0.280917, "quadratic_load"), (0.0, "linear_load")])
def test_form_chosen_in_19_of_20_seeds(p2, form):
    forms = [choice(cfx_table(p2, seed)).form for seed in range(20)]
    print(f"p2 = {p2}: {forms.count(form)}/20 chose {form}")
    assert forms.count(form) >= 19
