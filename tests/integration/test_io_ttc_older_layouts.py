"""TTC files of the older layout and files assembled by hand (issue 46): no ``channel`` struct
(the TTC SI convention, or USCS told by the pressure's magnitude, said in a warning; ``--units``
overrides), a channel of another length than the time (left out with a warning), radius
channels in a wrong unit (left out), specimens of one tyre, an unloaded radius without a usable
RL, SR standing in for SL in a free-rolling cornering run, channels wrapped in one struct (read
from its fields) and an unnamed matrix (refused with its name)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.io

from identify.core.tyre_size import find_tyre_size
from identify.io.common import Problems
from identify.io.trailer.files import read_trailer
from identify.io.ttc.files import PSI_BELOW, read_ttc, reader_notes
from identify.workflows.import_session import import_session, tyre_model
from tests.ttc_cases import import_refused, read_clean

LBF = 4.4482216152605
PSI = 6894.757293168361


def _session(n=3000, *, uscs=False, seed=0):
    """A cornering run in TTC SI (or USCS) units: slip-angle sweeps at three loads."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.02
    sa = 12.0 * np.sin(2 * np.pi * t / 20.0)
    fz = np.repeat([-650.0, -1100.0, -1550.0], n // 3 + 1)[:n] + rng.normal(0, 5, n)
    fy = -1.6 * fz * np.sin(1.3 * np.arctan(0.25 * sa))
    ch = {"ET": t, "V": np.full(n, 40.0), "N": np.full(n, 40.0 / 3.6 / 0.25 * 60 / (2 * np.pi)),
          "SA": sa, "IA": np.zeros(n), "P": np.full(n, 83.0) + rng.normal(0, 0.2, n),
          "FX": 0.01 * fz + rng.normal(0, 3, n), "FY": fy, "FZ": fz,
          "MX": 0.02 * fy, "MZ": -0.01 * fy, "RL": np.full(n, 24.0) + fz / 1e3,
          "SR": -0.03 + 0.001 * sa ** 2 + rng.normal(0, 1e-3, n)}
    if uscs:
        ch = ch | {"V": ch["V"] / 1.609344, "P": ch["P"] * 1e3 / PSI, "FX": ch["FX"] / LBF,
                   "FY": ch["FY"] / LBF, "FZ": ch["FZ"] / LBF, "RL": ch["RL"] / 2.54,
                   "MX": ch["MX"] / (LBF * 0.3048), "MZ": ch["MZ"] / (LBF * 0.3048)}
    return ch


def _mat(path, ch, **extra):
    scipy.io.savemat(path, {k: np.asarray(v).reshape(-1, 1) for k, v in ch.items()} | extra,
                     format="5")
    return path



def test_a_file_without_channel_struct_takes_the_ttc_si_convention_with_a_warning(tmp_path):
    path = _mat(tmp_path / "B1run1.mat", _session())
    run = read_clean(path)
    assert run.units["P"] == "kPa" and run.units["RL"] == "cm" and run.units["FZ"] == "N"
    warnings = []
    frame = read_trailer(path, warnings=warnings)
    note = next(w for w in warnings if w.channels == ("channel",))
    assert "TTC SI" in note.detail and note.action == "units assumed"
    assert frame["p"].median() == pytest.approx(83_000, rel=1e-3)  # kPa -> Pa
    assert frame["rl"].median() == pytest.approx(0.229, abs=1e-3)  # cm -> m


def test_a_file_without_channel_struct_in_psi_is_read_as_uscs(tmp_path):
    si = read_trailer(_mat(tmp_path / "si.mat", _session()))
    path = _mat(tmp_path / "us.mat", _session(uscs=True))
    assert read_clean(path).units["FZ"] == "lbf"
    warnings = []
    us = read_trailer(path, warnings=warnings)
    assert any("USCS" in w.detail for w in warnings)
    for col in ("p", "Fz", "Fy", "Mz", "Vx", "rl"):  # the same run, whatever its units
        np.testing.assert_allclose(us[col].to_numpy(), si[col].to_numpy(), rtol=1e-9,
                                   atol=1e-9)


def test_the_psi_threshold_lies_below_every_pressure_in_kpa():
    # no tyre is tested below 6.5 psi (45 kPa), so a kPa file is never read as psi; a psi file
    # above 45 psi (a truck tyre) is read as kPa and needs --units (the warning says so)
    assert 6 * PSI / 1e3 < PSI_BELOW < 55.0


def test_units_given_replace_the_assumed_convention(tmp_path):
    path = _mat(tmp_path / "B1run1.mat", _session())
    si = read_trailer(path)
    given = read_trailer(path, units={"P": "psi"})  # the user says so: no conflict
    assert given["p"].median() == pytest.approx(si["p"].median() * PSI / 1e3, rel=1e-9)


def test_a_longer_run_vector_is_left_out_with_a_warning_and_the_rest_is_read(tmp_path):
    ch = _session()
    path = _mat(tmp_path / "B1run1.mat", ch, RUN=np.full(5000, 25, dtype=np.uint8))
    run = read_clean(path)
    assert "RUN" not in run.data and run.data["FZ"].size == 3000
    assert reader_notes(run.attrs)[-1] == ("RUN", "5000 samples, but ET has 3000",
                                           "channel left out")
    warnings = []
    read_trailer(path, warnings=warnings)
    assert any(w.channels == ("RUN",) and w.action == "channel left out" for w in warnings)


def test_radius_channels_in_a_wrong_unit_are_left_out(tmp_path):
    ch = _session()
    ch["RL"] = ch["RL"] / 2.54 * 0.3048  # inches x 0.3048, as a team's script wrote them
    warnings = []
    frame = read_trailer(_mat(tmp_path / "B1run1.mat", ch), warnings=warnings)
    assert frame["rl"].isna().all()
    assert any(w.channels == ("RL",) and w.kind == "implausible" for w in warnings)


def test_specimens_of_one_tyre_are_one_tyre_model():
    assert tyre_model("Hoosier 20.5x7.0-13 -- Tire 37") == "Hoosier 20.5x7.0-13"
    assert tyre_model("Avon 7.0/20.0-13 tyre #2") == "Avon 7.0/20.0-13"
    assert tyre_model("Hoosier 43075 16x7.5-10 R25B") == "Hoosier 43075 16x7.5-10 R25B"


def test_a_size_is_found_inside_a_tireid():
    size = find_tyre_size("Hoosier 20.5x7.0-13 -- Tire 37")
    assert size.unloaded_radius_m == pytest.approx(20.5 * 0.0254 / 2)
    assert find_tyre_size("Michelin 225/50 R17 94V").rim_radius_m == pytest.approx(0.2159)
    assert find_tyre_size("Tire 37") is None


def test_import_of_specimens_without_usable_rl_takes_the_size_in_the_tireid(tmp_path):
    files = []
    for i, specimen in enumerate(("Tire 37", "Tire 38")):
        ch = _session(seed=i)
        ch["RL"] = ch["RL"] / 2.54 * 0.3048
        del ch["N"]  # no wheel speed either
        ch["ET"] = ch["ET"] + 1000.0 * i  # another run, not the same one read twice
        files.append(_mat(tmp_path / f"B1052run{25 + i}.mat", ch,
                          tireid=f"Hoosier 20.5x7.0-13 -- {specimen}"))
    result = import_session(files, tmp_path / "out", nominal_pressure_Pa=83_000,
                            nominal_load_N=1100)
    assert result.tyre_id == "Hoosier-20.5x7.0-13"
    assert result.unloaded_radius_m == pytest.approx(0.26035, abs=1e-4)  # to 0.1 mm
    assert any("20.5x7.0-13" in n and "nominal radius" in n for n in result.notes)


def test_sr_of_a_free_rolling_run_is_no_slip_ratio_sweep(tmp_path):
    # SR moves with the loaded radius over a slip-angle sweep (here by 0.14): taken as kappa
    # it would read as slip-ratio sweeps, and the cornering run as combined slip
    warnings = []
    frame = read_trailer(_mat(tmp_path / "B1run1.mat", _session()), warnings=warnings)
    assert (frame["kappa"] == 0).all()
    assert any("rolled freely" in w.detail for w in warnings)


def test_sr_of_a_drive_brake_run_is_taken_at_the_zero_crossing_of_its_linear_range(tmp_path):
    # fast slip-ratio sweeps pass free rolling in a sample or two: the offset of SR comes
    # from the linear range's zero crossing (Fx = 0 at SR = -0.03 here)
    n = 3000
    t = np.arange(n) * 0.02
    sr = -0.03 + 0.3 * np.sin(2 * np.pi * t / 4.0)
    fz = np.repeat([-650.0, -1100.0, -1550.0], n // 3)
    fx = -fz * 2.0 * np.tanh(12.0 * (sr + 0.03))
    ch = _session(n) | {"SA": np.zeros(n), "SR": sr, "FX": fx, "FZ": fz, "FY": np.zeros(n),
                        "MX": np.zeros(n), "MZ": np.zeros(n)}
    warnings = []
    frame = read_trailer(_mat(tmp_path / "B1run33.mat", ch), warnings=warnings)
    at_zero = np.abs(frame["Fx"]) < 0.02 * frame["Fz"]
    assert np.abs(frame.loc[at_zero, "kappa"]).max() < 2e-3  # not the -0.03 of SR
    assert any("taken at Fx = 0" in w.detail for w in warnings)


def test_import_without_usable_rl_takes_the_effective_radius_from_the_wheel_speed(tmp_path):
    ch = _session()  # V / omega = 0.25 m at every load
    ch["RL"] = ch["RL"] / 2.54 * 0.3048
    result = import_session([_mat(tmp_path / "B1run1.mat", ch, tireid="Hoosier 20.5x7.0-13")],
                            tmp_path / "out", nominal_pressure_Pa=83_000, nominal_load_N=1100)
    assert result.unloaded_radius_m == pytest.approx(0.25, abs=1e-4)  # not the size's 0.2604
    assert any("V / omega" in n for n in result.notes)


def test_channels_held_as_the_fields_of_one_struct_are_read_with_a_warning(tmp_path):
    """A team's export that wraps every channel in one struct (``run26.FX``) reads as the
    same run as the channels saved one by one, and a warning names the struct."""
    ch = _session()
    flat = read_clean(_mat(tmp_path / "flat.mat", ch))
    path = tmp_path / "wrapped.mat"
    scipy.io.savemat(path, {"run26": {k: np.asarray(v).reshape(-1, 1) for k, v in ch.items()},
                            "tireid": "Hoosier 20.5x7.0-13"}, format="5")
    warnings = []
    frame = read_trailer(path, warnings=warnings)
    note = next(w for w in warnings if w.channels == ("run26",))
    assert "struct" in note.detail and note.action == "channels read from its fields"
    wrapped = read_ttc_quiet(path)
    assert set(wrapped.data) == set(flat.data)
    for name in flat.data:
        np.testing.assert_array_equal(wrapped.data[name], flat.data[name])
    assert wrapped.attrs["tireid"] == "Hoosier 20.5x7.0-13"
    assert frame["Fy"].abs().max() > 1000.0


def test_an_unnamed_matrix_is_refused_with_its_name_and_shape(tmp_path):
    """Columns without names cannot be told apart: one line naming the matrix and what to do."""
    ch = _session(n=300)
    path = tmp_path / "matrix.mat"
    scipy.io.savemat(path, {"FILE": np.column_stack(list(ch.values()))}, format="5")
    problems = Problems()
    assert read_ttc(path, problems) is None
    (line,) = [str(p) for p in problems.finish()]
    assert "'FILE' (300 x 13) names no channel" in line and "a variable of its own" in line


def read_ttc_quiet(path):
    """read_ttc of a file that may carry reader notes (warnings), asserting no problem."""
    problems = Problems()
    run = read_ttc(path, problems)
    assert problems.total == 0 and run is not None
    return run


@pytest.mark.parametrize(("changed", "unit", "taken"), [
    ({"SA": np.deg2rad, "IA": np.deg2rad}, "rad", ("SA", "IA")),
    ({"V": lambda v: v / 3.6}, "m/s", ("V",)),
    ({"RL": lambda r: r / 100.0}, "m", ("RL",)),
])
def test_a_converted_file_without_units_is_read_in_the_unit_its_magnitudes_show(
        tmp_path, changed, unit, taken):
    """A team script kept the TTC names but wrote radians, m/s or metres: the magnitudes tell
    (a sweep within 0.35 that saturates the force; V / omega a radius only in m/s; a radius
    of 0.24 'cm'), the unit is taken with a warning per channel, and the table is the one the
    file in the convention's units gives."""
    ch = _session()
    reference = read_trailer(_mat(tmp_path / "B1run1.mat", ch))
    converted = _mat(tmp_path / "B1run2.mat", ch | {k: f(ch[k]) for k, f in changed.items()})
    warnings = []
    frame = read_trailer(converted, warnings=warnings)
    notes = {w.channels[0]: w for w in warnings if w.action.startswith("unit taken as")}
    assert set(notes) == set(taken) and all(notes[k].action == f"unit taken as {unit}"
                                            for k in taken)
    for col in ("alpha", "gamma", "Vx", "rl", "Fy"):
        np.testing.assert_allclose(frame[col].to_numpy(), reference[col].to_numpy(),
                                   rtol=1e-12, atol=1e-12)


def test_a_spike_in_a_slip_angle_in_radians_does_not_hide_its_unit(tmp_path):
    """A rig's spike (one sample of 5) in a slip angle the file holds in radians: still
    radians."""
    ch = _session()
    sa = np.deg2rad(ch["SA"])
    sa[100] = 5.0
    warnings = []
    read_trailer(_mat(tmp_path / "B1run1.mat", ch | {"SA": sa, "IA": np.deg2rad(ch["IA"])}),
                 warnings=warnings)
    assert {w.channels[0] for w in warnings if w.action == "unit taken as rad"} == {"SA", "IA"}


def test_a_file_in_the_convention_units_takes_no_other_unit(tmp_path):
    """The same checks leave a file in the TTC SI convention as it is, a drive/brake run at a
    slip angle of zero included (SA within 0.35 deg, but no saturated lateral force)."""
    ch = _session()
    braking = ch | {"SA": np.zeros_like(ch["SA"]), "FY": 0.02 * ch["FZ"]}
    for i, channels in enumerate((ch, braking)):
        warnings = []
        read_trailer(_mat(tmp_path / f"B1run{i}.mat", channels), warnings=warnings)
        assert not [w for w in warnings if w.action.startswith("unit taken as")]


def test_a_positive_load_in_a_ttc_file_is_refused_naming_the_sae_axes(tmp_path):
    ch = _session(n=600)
    lines = import_refused([_mat(tmp_path / "B1run1.mat", ch | {"FZ": -ch["FZ"]})],
                           tmp_path / "out")
    assert any("median FZ is positive" in line and "SAE" in line and "--axes" in line
               for line in lines), lines


def test_a_csv_with_the_ttc_names_and_no_units_reads_as_the_mat_without_struct(tmp_path):
    """A team's CSV export of a TTC run (TTC names, no units) is the run its .mat gives: the
    TTC convention with its warning, SAE axes; a unit the user gives replaces the assumed."""
    ch = _session()
    reference = read_trailer(_mat(tmp_path / "B1run1.mat", ch))
    csv = tmp_path / "B1run1.csv"
    pd.DataFrame(ch).to_csv(csv, index=False)
    warnings = []
    frame = read_trailer(csv, warnings=warnings)
    note = next(w for w in warnings if w.channels == ("channel",))
    assert note.detail.startswith("no units in the CSV header: the TTC SI")
    for col in ("alpha", "Fy", "Fz", "Mz", "p", "Vx", "rl"):
        np.testing.assert_allclose(frame[col].to_numpy(), reference[col].to_numpy(),
                                   rtol=1e-9)
    # the user's unit wins over the assumed one
    told = read_trailer(csv, units={"P": "psi"}, warnings=[])
    assert told["p"].median() == pytest.approx(reference["p"].median() * PSI / 1e3, rel=1e-9)
