"""Discovery's problems take their coefficients from the one table of the MF stages."""
from __future__ import annotations

from identify.discover.stage_problems import DISCOVERY_STAGES
from identify.fit.mf.stage_specs import STAGES


def test_each_discovery_problem_fits_coefficients_of_its_mf_stage():
    for output, d in DISCOVERY_STAGES.items():
        fit_stage = STAGES[d.fit_stage]
        assert d.output == output == fit_stage.quantity
        assert set(d.free) <= set(fit_stage.coefficients), output
        assert not set(d.free) & set(d.candidates), output


def test_the_candidates_are_the_stages_pressure_coefficients():
    assert {k: d.candidates for k, d in DISCOVERY_STAGES.items()} == {
        "Fx": ("PPX1", "PPX2", "PPX3", "PPX4"), "Fy": ("PPY1", "PPY2", "PPY3", "PPY4", "PPY5"),
        "Mx": ("PPMX1",), "Mz": ("PPZ1", "PPZ2")}
