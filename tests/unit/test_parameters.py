"""The parameter table (identify/model/parameter_table.csv) and its accessors."""
from __future__ import annotations

import math
import re

import pytest

from identify.core.units import dimension_factor
from identify.model import parameters as P
from tests.reference_data import MFEVAL_DIR, MFEVAL_FILES, mfeval_params

EXTENSIONS = {"F_X", "F_Y", "F_Z", "F_THETA", "F_GAMMA", "F_PSI", "PCMZ2", "PCMZ3", "CMZ_FORM"}


def test_table_size_and_unique_names():
    names = [p.name for p in P.PARAMETERS]
    assert len(names) == len(set(names)) == 284 + len(EXTENSIONS)
    assert EXTENSIONS <= set(names)


@pytest.mark.parametrize("stem", MFEVAL_FILES)
def test_names_equal_mfeval_keys(stem):
    mfeval = set(mfeval_params(stem))
    ours = {p.name for p in P.PARAMETERS if p.section != "MFID_EXTENSIONS"}
    assert ours == mfeval


@pytest.mark.parametrize("stem", MFEVAL_FILES)
def test_defaults_equal_mfeval_defaults_for_absent_keys(stem):
    """Keys absent from a file took MFeval's defaults: the table must hold the same values."""
    text = (MFEVAL_DIR / f"{stem}.tir").read_text(encoding="latin-1")
    present = set()
    section = ""
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("["):
            section = s.strip("[] ").upper()
        elif s and s[0] not in "$!" and "=" in s:
            key = s.split("=")[0].strip().upper()
            present.add("MASS1" if key == "MASS" and section != "UNITS" else key)
    absent = {k: v for k, v in mfeval_params(stem).items() if k not in present}
    assert absent, "every file lacks some keys (the MF 5.2-only ones at least)"
    for name, value in absent.items():
        assert P.spec(name).default == value, name


@pytest.mark.parametrize("name,value", [
    ("FNOMIN", 4000.0), ("UNLOADED_RADIUS", 0.3135), ("VERTICAL_STIFFNESS", 200000.0),
    ("INFLPRES", 220000.0), ("NOMPRES", 220000.0), ("MASS1", 9.3), ("GRAVITY", -9.81),
    ("Q_FZ2", 1e-4), ("LONGITUDINAL_STIFFNESS", 3e5), ("PRESMAX", 1e6), ("FZMIN", 100.0),
    ("ALPMIN", -1.5), ("CAMMAX", 0.175), ("PCX1", 1.65), ("PKY1", -20.0), ("PKY4", 2.0),
    ("PKY6", -1.0), ("RBX1", 20.0), ("RVY4", 20.0), ("QSX4", 5.0), ("QSX9", 0.4),
    ("QSY7", 0.85), ("QSY8", -0.4), ("QDZ8", -0.05), ("QBZ9", 10.0), ("PHYP4", -4.0),
    ("LMUY", 1.0), ("LSGKP", 1.0), ("TYRESIDE", "LEFT"), ("USE_MODE", 124.0),
    ("HMAX_LOCAL", 2.5e-4), ("ELLIPS_ORDER", 1.8), ("Q_RB2", -1.0),
])
def test_defaults_match_section_7_4(name, value):
    assert P.spec(name).default == value
    assert P.defaults()[name] == value


def test_sections_known_and_contiguous_in_write_order():
    assert len(P.SECTIONS) == 22 and P.SECTIONS[-1] == "MFID_EXTENSIONS"
    order = []
    for p in P.PARAMETERS:
        assert p.section in P.SECTIONS, p.name
        if not order or order[-1] != p.section:
            order.append(p.section)
    assert order == list(P.SECTIONS)
    assert P.section_keys("OPERATING_CONDITIONS") == ("INFLPRES", "NOMPRES")


def test_dimensions_parse_and_strings_are_strings():
    allowed = re.compile(r"(1|[LFMTAP](\^-?\d+)?)([*/]([LFMTAP](\^-?\d+)?))*|str")
    for p in P.PARAMETERS:
        assert allowed.fullmatch(p.dimension), (p.name, p.dimension)
        if p.is_string:
            assert isinstance(p.default, str) and p.lower is None and p.upper is None
            assert not p.vary
        else:
            assert isinstance(p.default, float)
            assert dimension_factor(p.dimension, {}) == 1.0


@pytest.mark.parametrize("name,dimension", [
    ("UNLOADED_RADIUS", "L"), ("FNOMIN", "F"), ("VERTICAL_STIFFNESS", "F/L"), ("INFLPRES", "P"),
    ("LONGVL", "L/T"), ("ALPMIN", "A"), ("CAMMIN", "A"), ("IXX", "M*L^2"),
    ("YAW_STIFFNESS", "F*L/A"), ("VERTICAL_DAMPING", "F*T/L"), ("FREQ_LAT", "1/T"),
    ("MASS1", "M"), ("PKY1", "1"), ("LMUX", "1"), ("QSY7", "1"), ("TYRESIDE", "str"),
])
def test_dimension_column(name, dimension):
    assert P.spec(name).dimension == dimension


def test_dimension_factor():
    mm_kn = {"L": 1e-3, "F": 1e3, "A": math.pi / 180, "P": 1e9}
    assert dimension_factor("F/L", mm_kn) == pytest.approx(1e6, rel=1e-15)
    assert dimension_factor("F*L/A", mm_kn) == pytest.approx(180 / math.pi, rel=1e-15)
    assert dimension_factor("M*L^2", {"M": 1e-3, "L": 1e-3}) == pytest.approx(1e-9)
    assert dimension_factor("1/T", {"T": 1e-3}) == pytest.approx(1e3)
    assert dimension_factor("1", mm_kn) == 1.0
    with pytest.raises(ValueError):
        dimension_factor("str", mm_kn)
    with pytest.raises(ValueError):
        dimension_factor("L+F", mm_kn)


def test_bounds_ordered_and_thesis_bounds():
    for p in P.PARAMETERS:
        if p.lower is not None and p.upper is not None:
            assert p.lower < p.upper, p.name
    thesis = {"PPY5": (-1, 0), "PPZ2": (-1, 0), "QSY7": (0.5, 1),
              "QSY8": (-1, 0), "PCFX1": (-1, 1), "PCFX2": (-0.6, 0), "PCFX3": (0, 1),
              "PCFY1": (-1, 1), "PCFY2": (-0.6, 0), "PCFY3": (0, 1), "PCMZ1": (-1, 1),
              "PCX1": (1, 2), "PEX1": (-10, 1)}
    for name, (lo, hi) in thesis.items():
        assert P.bounds(name) == (lo, hi), name
    # mfid's, not the thesis's [-1, 0]: the product QSX2 PPMX1 is what the data see, and the
    # published MF 6.1 file holds QSX2 > 0 with PPMX1 = +0.155 (docs/relations.md)
    assert P.bounds("PPMX1") == (-1, 1)


@pytest.mark.parametrize("stem", MFEVAL_FILES)
def test_bounds_hold_the_published_files(stem):
    """A coefficient the fits free by default can reach the value of every published .tir:
    a bound that excludes a real tyre makes the fit trade the coefficient for others (the
    golden set's Mx stage flipped QSX2 to emulate PPMX1 = +0.15 under PPMX1 <= 0)."""
    known = {q.name: q for q in P.PARAMETERS}
    outside = []
    for name, value in mfeval_params(stem).items():
        if name not in known or not known[name].fit_default_vary or not isinstance(value, float):
            continue
        lo, hi = P.bounds(name, value)
        if not lo <= value <= hi:
            outside.append(f"{name} = {value} not in [{lo}, {hi}]")
    assert outside == []


def test_bounds_magnitude_and_unbounded():
    assert P.bounds("PKY1", -15.3) == (-150.0, -1.0)
    assert P.bounds("PKY1", 27.4) == (1.0, 150.0)
    assert P.bounds("PDY1", 0.9) == (0.5, 3.0)
    assert P.bounds("PDY1", -0.9) == (-3.0, -0.5)
    assert P.bounds("QSY8", -0.4) == (-1.0, 0.0)  # not a magnitude bound: no mirroring
    assert P.bounds("PEX2") == (-math.inf, math.inf)


def test_vary_flags():
    for p in P.PARAMETERS:
        if p.fit_default_vary:
            assert p.vary, p.name
    for p in P.PARAMETERS:
        if p.section == "SCALING_COEFFICIENTS":
            assert not p.fit_default_vary, p.name
        if p.section in ("MDI_HEADER", "UNITS", "MODEL", "DIMENSION", "OPERATING_CONDITIONS"):
            assert not p.vary, p.name
    for name in ("PCX1", "PKY1", "QBZ1", "RBX1", "QSX2", "QSY1", *P.PRESSURE_KEYS):
        assert P.spec(name).fit_default_vary, name
    assert not P.spec("PCFX2").fit_default_vary and P.spec("PCFX2").vary


def test_pressure_keys_and_extensions():
    assert len(P.PRESSURE_KEYS) == 15
    for name in P.PRESSURE_KEYS:
        assert not P.spec(name).is_string
    for name in EXTENSIONS:
        p = P.spec(name)
        assert p.section == "MFID_EXTENSIONS" and p.meaning
        assert p.default == (1.0 if name == "CMZ_FORM" else 0.0)


def test_write_for_and_tir_names():
    assert P.spec("Q_FCY2").write_for == (62,)
    assert P.spec("ENV_C1").write_for == (62,)
    assert P.spec("PTX1").write_for == () and P.spec("LSGAL").write_for == ()
    assert P.spec("PKY1").write_for == (61, 62)
    assert P.spec("MASS1").tir_key == "MASS" and P.tir_name("FNOMIN") == "FNOMIN"


def test_every_row_has_a_meaning_with_unit():
    for p in P.PARAMETERS:
        assert re.search(r"\[[^\]]+\]$", p.meaning), p.name


def test_spec_unknown_and_defaults_fresh():
    with pytest.raises(KeyError, match="not a key"):
        P.spec("NOPE")
    d = P.defaults()
    d["FNOMIN"] = 1.0
    assert P.defaults()["FNOMIN"] == 4000.0
    assert P.STRING_KEYS >= {"TYRESIDE", "LENGTH", "FILE_TYPE", "FUNCTION_NAME"}
