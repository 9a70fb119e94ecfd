"""The characteristics vocabulary: quantity names, the dimension of each value, eigenmodes, and the
columns of the tidy characteristics table (what extraction produces and the relations fit)."""
from __future__ import annotations

__all__ = ["QUANTITIES", "MODES", "CHARACTERISTICS_COLUMNS"]

#: Quantity -> dimension of its value.
QUANTITIES: dict[str, str] = {
    "CFz": "stiffness", "CFx": "stiffness", "CFy": "stiffness",
    "CMz": "torsional_stiffness", "sigma_y": "length", "sigma_x": "length", "Re": "length",
    "FxRR": "force", "Fy_gamma": "force", "Mz_gamma": "moment", "Mx_gamma": "moment",
    "f_nat": "frequency"}
#: Eigenmodes named in the ``mode`` column of ``f_nat`` rows.
MODES = ("x", "y", "z", "theta", "gamma", "psi")
#: Columns of the tidy characteristics table.
CHARACTERISTICS_COLUMNS = ("run", "quantity", "pi_bar", "p_Pa", "Fz_N", "value", "unit",
                           "Vx_mps", "gamma_deg", "mode")
