"""TTC trailer files: the generator's layout, the readers (.mat, .dat, SI, USCS), SAE -> ISO-W,
every quirk reported with its count, implausible channels dropped, unusable files refused."""
from __future__ import annotations

import hashlib
import json
from collections import Counter

import numpy as np
import pytest
import scipy.io

from identify.core.errors import InputError
from identify.io.trailer.files import OPTIONAL_COLUMNS, TRAILER_COLUMNS, read_trailer
from identify.io.ttc.files import TTC_CHANNELS
from identify.model.evaluate import evaluate
from tests.ttc_cases import UNUSABLE, session


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """Noise-free session: the loaded forces must be the model's at the loaded conditions."""
    return session(tmp_path_factory.mktemp("ttc") / "clean", seed=2, noise=0.0)


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    return session(tmp_path_factory.mktemp("ttc") / "noisy", seed=5)


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_session_layout(noisy):
    names = [f.name for f in noisy.files]
    assert names == ["SIM1run4.mat", "SIM1run4.dat", "SIM1run7.mat", "SIM1run7.dat"]
    mat = scipy.io.loadmat(noisy.files[0], simplify_cells=True)
    assert list(mat["channel"]["name"]) == list(TTC_CHANNELS)
    assert list(mat["channel"]["units"]) == [c.si_unit for c in TTC_CHANNELS.values()]
    assert mat["testid"] == "SIM1" and mat["tireid"] == "mfid-sim 225/50 R17"
    assert "not TTC data" in mat["source"]
    assert all(mat[k].ndim == 1 for k in TTC_CHANNELS)
    lines = noisy.files[1].read_text().splitlines()[:4]
    assert lines[1].split("\t") == list(TTC_CHANNELS)
    assert lines[2].split("\t")[:4] == ["s", "kph", "rpm", "deg"]
    assert len(lines[3].split("\t")) == len(TTC_CHANNELS)
    sizes = [r["samples"] for r in noisy.truth["runs"]]
    assert 55_000 < sizes[0] < 65_000 and 70_000 < sizes[1] < 82_000  # ~60k, ~76k at 100 Hz
    assert mat["ET"].size == sizes[0]
    plan = noisy.truth["plan"]
    assert plan["pressures_Pa"] == [250000.0, 212000.0, 288000.0]
    assert plan["loads_N"] == [5000.0, 2500.0, 7500.0, 6250.0, 3750.0]
    kinds = Counter(s["kind"] for s in noisy.truth["runs"][0]["segments"])
    assert kinds["warmup"] == 3 and kinds["start"] == 1 and kinds["pressure_change"] == 10


def test_cornering_slip_ratio_scatters_about_zero(noisy):
    """A real cornering run's SL is never exactly 0: the generator gives it (and SR) at least
    0.001 of noise at noise = 0.01, so the MF stages meet a noisy kappa in a cornering run."""
    mat = scipy.io.loadmat(noisy.files[0], simplify_cells=True)
    sl = mat["SL"][np.isfinite(mat["SL"])]
    # seed 5: median -8.4e-6, std 0.995e-3 on 60457 samples (AR(1) 0.7: ~1e4 independent,
    # the std's standard error ~0.7 %, the median's ~1.2e-5); without the floor both are 0
    assert abs(np.median(sl)) < 1e-4 and 0.95e-3 < np.std(sl) < 1.05e-3


def test_equal_seeds_equal_files(tmp_path):
    a = session(tmp_path / "a", seed=9, cornering_only=True)
    b = session(tmp_path / "b", seed=9, cornering_only=True)
    assert [f.name for f in a.files] == ["SIM1run4.mat", "SIM1run4.dat"]
    assert [_sha(f) for f in a.files] == [_sha(f) for f in b.files]
    assert (a.path / "truth.json").read_bytes() == (b.path / "truth.json").read_bytes()


@pytest.mark.parametrize("run", [0, 1])
def test_mat_is_the_model_at_the_loaded_conditions(clean, run):
    """Units, SAE -> ISO-W and the cleaning: every loaded sample is the truth to round-off."""
    frame = read_trailer(clean.files[2 * run])
    assert list(frame.columns) == list(TRAILER_COLUMNS) + list(OPTIONAL_COLUMNS)
    out = evaluate(clean.truth["tir"], frame.Fz.to_numpy(), frame.kappa.to_numpy(),
                   frame.alpha.to_numpy(), frame.gamma.to_numpy(),
                   np.maximum(frame.Vx.to_numpy(), 0.05), p=frame.p.to_numpy(), mode=111)
    for col in ("Fx", "Fy", "Mx", "Mz", "omega"):
        np.testing.assert_allclose(frame[col], out[col], rtol=1e-11, atol=1e-9, err_msg=col)
    assert (frame.Fz > 0).all() and frame.My.isna().all()
    # ISO-W signs: positive slip angle, negative lateral force and positive aligning moment
    small = (frame.alpha > np.deg2rad(1)) & (frame.alpha < np.deg2rad(3)) & (frame.Fz > 2000)
    assert small.sum() > 1000 and (frame.Fy[small] < 0).all() and (frame.Mz[small] > 0).all()
    assert frame.T_tread_centre.between(290, 350).all()  # [K]
    assert frame.rl.between(0.28, 0.33).all() and frame.re.between(0.25, 0.4).all()


def test_dat_equals_mat_to_its_decimals(clean):
    mat, dat = read_trailer(clean.files[2]), read_trailer(clean.files[3])
    assert len(mat) == len(dat)
    # decimals written: FZ/FY 0.01 N, SA 1e-4 deg, SL 1e-5 (x slip stiffness ~1e5 N -> ~1 N)
    for col, tol in (("t", 1e-9), ("Fz", 0.006), ("alpha", np.deg2rad(6e-5)), ("kappa", 6e-6),
                     ("p", 0.6), ("Vx", 0.0002), ("Fx", 0.006), ("T_tread_centre", 0.006)):
        np.testing.assert_allclose(dat[col], mat[col], rtol=0, atol=tol, err_msg=col)


def test_uscs_files_read_as_si_files(noisy, tmp_path):
    uscs = session(tmp_path / "uscs", seed=5, units="USCS", cornering_only=True)
    lines = uscs.files[1].read_text().splitlines()
    assert lines[2].split("\t")[:13] == ["s", "mph", "rpm", "deg", "deg", "in", "in", "psi",
                                         "lbf", "lbf", "lbf", "ft-lb", "ft-lb"]
    si, us = read_trailer(noisy.files[0]), read_trailer(uscs.files[0])
    for col in si.columns[1:]:
        np.testing.assert_allclose(us[col], si[col], rtol=1e-12, atol=1e-9, err_msg=col)


@pytest.mark.parametrize("run", [0, 1])
def test_every_quirk_is_a_warning_with_its_count(noisy, run):
    truth = noisy.truth["runs"][run]["quirks"]
    for path in noisy.files[2 * run:2 * run + 2]:
        warnings = []
        read_trailer(path, warnings=warnings)
        got = {w.kind: w for w in warnings}
        assert set(got) == {"time-order", "time-gap", "nan", "dropout", "spike", "rows"}
        for kind in ("time-order", "time-gap", "nan", "dropout", "spike"):
            assert got[kind].count == truth[kind]["count"], (path.name, kind)
        assert got["rows"].count == (truth["nan"]["count"] + truth["dropout"]["count"]
                                     + truth["spike"]["count"])
        assert got["nan"].detail.startswith("NaN/inf values in 2 stretch(es)")
        assert got["dropout"].detail.startswith(f"{truth['dropout']['events']} dropout(s)")
        spikes = Counter(s["channel"] for s in truth["spike"]["where"])
        assert got["spike"].detail.endswith(
            ", ".join(f"{c} {spikes[c]}" for c in got["spike"].channels) + " samples")
        assert set(got["spike"].channels) == set(spikes)
        assert all(w.total == noisy.truth["runs"][run]["samples"] for w in warnings)
        line = got["time-order"].line
        assert (line is None) == (path.suffix == ".mat")


def test_implausible_channels_are_dropped_with_the_reason(tmp_path):
    s = session(tmp_path / "bad", seed=1, cornering_only=True, implausible=["N", "RE", "SR"])
    warnings = []
    frame = read_trailer(s.files[0], warnings=warnings)
    dropped = {w.channels[0]: w for w in warnings if w.kind == "implausible"}
    assert set(dropped) == {"N", "RE", "SR"}
    assert dropped["N"].detail.startswith("wheel speed inconsistent with the road speed, "
                                          "V/omega: median")
    assert dropped["RE"].detail.startswith("effective rolling radius: median 3")
    assert dropped["SR"].detail == "slip ratio pinned at -1 (not used: kappa comes from SL)"
    assert all(w.action == "channel dropped" for w in dropped.values())
    assert frame.omega.isna().all() and frame.re.isna().all()
    assert frame.kappa.notna().all() and len(frame) > 59_000  # rows are kept


# ------------------------------------------------------------------ unusable files

@pytest.mark.parametrize("name,make,expected", UNUSABLE, ids=[c[0] for c in UNUSABLE])
def test_unusable_file_is_one_line_naming_file_and_channel(tmp_path, name, make, expected):
    path = make(tmp_path / "B1run1.mat")
    with pytest.raises(InputError) as err:
        read_trailer(path)
    text = expected.format(p=path)
    message = str(err.value)
    assert message.startswith(text[:-3]) if text.endswith("...") else message == text
    assert "\n" not in message


def test_simulate_command_writes_a_ttc_session(tmp_path):
    from typer.testing import CliRunner

    from identify.cli.app import app

    runner = CliRunner()
    out = tmp_path / "ttc"
    result = runner.invoke(app, ["simulate", "--format", "ttc", "default", str(out), "--seed",
                                 "4", "--units", "USCS", "--cornering-only", "--implausible",
                                 "N,RE", "--implausible", "SR", "--input-noise", "0.002"])
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith(f"wrote {out}: SIM1run4 (cornering, ")
    assert sorted(p.name for p in out.iterdir()) == ["SIM1run4.dat", "SIM1run4.mat",
                                                      "truth.json"]
    truth = json.loads((out / "truth.json").read_text())
    assert truth["units"] == "USCS" and truth["implausible"] == ["N", "RE", "SR"]
    assert truth["tir"]["FNOMIN"] == 5000.0 and truth["seed"] == 4
    assert truth["noise"] == 0.01 and truth["input_noise"] == 0.002
    bad = runner.invoke(app, ["simulate", "--format", "ttc", "default", str(tmp_path / "x"),
                              "--implausible", "XX"])
    assert bad.exit_code == 2
    assert bad.stderr.strip() == ("error: --implausible: unknown implausible channel 'XX' "
                                  "(one of N, RE, SR)")
    bad = runner.invoke(app, ["simulate", "--format", "ttc", "default", str(tmp_path / "y"),
                              "--input-noise", "-1"])
    assert bad.exit_code == 2
    assert bad.stderr.strip() == "error: --input-noise: input noise must be >= 0, not -1.0"
    assert not (tmp_path / "y").exists()


def test_lagged_slip_lags_a_ramp_by_the_relaxation_length_over_the_speed():
    """A first-order lag in rolling distance: a slip-angle ramp at a constant speed is seen
    relaxation / Vx later, exactly (first-order hold), after the start-up transient; a
    constant slip angle is seen as it is; a relaxation of 0 changes nothing."""
    from identify.simulate.ttc_plan import RATE
    from identify.simulate.ttc_signals import lagged_slip

    t = np.arange(400) / RATE
    vx = np.full(t.size, 11.1)  # 40 kph
    rate = np.deg2rad(5.6)  # [rad/s]: the generator's sweep rate
    seen = lagged_slip(0.01 + rate * t, vx, 0.5)
    lag_s = (0.01 + rate * t[200:] - seen[200:]) / rate
    np.testing.assert_allclose(lag_s, 0.5 / 11.1, rtol=1e-9)
    np.testing.assert_allclose(lagged_slip(np.full(50, 0.03), vx[:50], 0.5), 0.03, rtol=1e-14)
    alpha = np.sin(t)
    assert lagged_slip(alpha, vx, 0.0) is alpha


def test_relaxation_lags_the_forces_not_the_recorded_slip_angle(tmp_path):
    """--relaxation 0.5: the SA channel (the slip angle set) is the same as without it, the
    lateral force differs where the slip angle moves: by about C_alpha x 5.6 deg/s x 0.045 s
    (a few hundred newtons, 734 N at the 99th percentile), not by the ~4 kN a lag of 0.5 s
    would give; truth.json says so."""
    plain = session(tmp_path / "plain", seed=4, noise=0.0, cornering_only=True)
    lagged = session(tmp_path / "lagged", seed=4, noise=0.0, cornering_only=True,
                     relaxation=0.5)
    assert lagged.truth["relaxation_m"] == 0.5 and plain.truth["relaxation_m"] == 0.0
    a, b = (scipy.io.loadmat(s.files[0]) for s in (plain, lagged))
    np.testing.assert_array_equal(a["SA"], b["SA"])
    d = np.abs(a["FY"] - b["FY"])
    d = d[np.isfinite(d)]  # 99th percentile: a step of the slip angle set (end of a warm-up)
    assert 100.0 < np.percentile(d, 99) < 1500.0  # is followed over 0.5 m, by design


def test_input_noise_sets_the_noise_of_the_operating_conditions_only(tmp_path):
    """input_noise = 0: the slip, camber, load and speed channels are those of a noise-free
    session, the forces and moments keep their 1 % (a rig whose inputs are known exactly;
    bench/ttc_truth.py --input-noise). Compared where neither session has a logging quirk
    (spikes, dropouts, repeated rows and a time gap are drawn after the noise, at other
    samples: the two are matched on their time stamps)."""
    exact = session(tmp_path / "exact", seed=4, cornering_only=True, input_noise=0.0)
    clean = session(tmp_path / "clean", seed=4, cornering_only=True, noise=0.0)
    assert exact.truth["input_noise"] == 0.0 and exact.truth["noise"] == 0.01
    a, b = (scipy.io.loadmat(s.files[0], squeeze_me=True) for s in (exact, clean))
    ticks = [np.round(m["ET"] * 100).astype(int) for m in (a, b)]
    _, ia, ib = np.intersect1d(*ticks, return_indices=True)
    assert ia.size > 0.99 * ticks[0].size
    for name in ("SA", "SL", "IA", "FZ", "V"):
        same = a[name][ia] == b[name][ib]
        assert same.mean() > 0.99, name
    for name in ("FY", "MZ", "MX"):
        assert np.isclose(a[name][ia], b[name][ib], rtol=1e-6, atol=0).mean() < 0.01, name
    with pytest.raises(InputError, match="input noise"):
        session(tmp_path / "bad", input_noise=-0.1)
