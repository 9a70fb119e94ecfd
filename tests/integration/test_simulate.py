"""The rig simulator (identify.simulate): determinism, truth, exact hub transform, noise, hide,
atomic writing, CLI. All on the reduced grid (``grid="small"``) to keep the runtime small."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.errors import InputError
from identify.io.tir import read_tir
from identify.simulate import SMALL, default_tir_path, simulate_folder
from identify.simulate.default_tyre import default_tyre_values
from identify.simulate.rig import FLATPLANK_CHANNELS
from identify.simulate.trailer import TRAILER_CHANNELS
from identify.simulate.truth import UNITS
from tests.reference_data import THESIS_CSV

P = read_tir(default_tir_path()).params()
CLEAN = dict(noise=0.0, transients=False, stick_slip=False)
QUANTITIES = {"CFz", "CFx", "CFy", "CMz", "sigma_y", "Re", "FxRR", "Fy_gamma", "Mz_gamma",
              "Mx_gamma", "f_nat"}


def sim(path, **kw):
    return simulate_folder(P, path, grid="small", **kw)


def files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def manifest(folder: Path) -> dict:
    return tomllib.loads((folder / "tyre.toml").read_text())


def to_contact(raw: pd.DataFrame, a: float, b: float) -> pd.DataFrame:
    """The Flatplank hub transform (docs/procedures.md), written out here by hand."""
    kx, ky, kz = raw.Gx1 + raw.Gx2, raw.Gy, raw.Gz1 + raw.Gz2
    tx = raw.Gz1 * (a + b) + raw.Gz2 * b
    tz = raw.Gx1 * (a + b) + raw.Gx2 * b
    g = raw.phi_wheel + raw.phi_plank
    rl = raw.loaded_radius
    c, s = np.cos(g), np.sin(g)
    return pd.DataFrame({"Fx": kx, "Fy": -ky * c - kz * s, "Fz": -ky * s + kz * c,
                         "Mx": -tx + ky * rl, "My": -tz * s + kx * rl * c,
                         "Mz": tz * c + kx * rl * s, "gamma": g})


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "tyre"
    return sim(out, seed=3)


def test_deterministic_for_a_seed(tmp_path, folder):
    again = sim(tmp_path / "a" / "tyre", seed=3)  # the folder name is the manifest's tyre id
    assert files(again.path) == files(folder.path)
    other = files(sim(tmp_path / "b" / "tyre", seed=4).path)
    same = files(folder.path)
    assert other["flatplank/vertical_p220_fz9000_s1.csv"] != \
        same["flatplank/vertical_p220_fz9000_s1.csv"]
    assert other["tyre.toml"] == same["tyre.toml"]


def test_compressed_folder_is_deterministic_and_holds_the_same_csv(tmp_path, folder):
    import gzip
    packed = sim(tmp_path / "a" / "tyre", seed=3, compress=True)
    again = sim(tmp_path / "b" / "tyre", seed=3, compress=True)
    assert files(packed.path) == files(again.path)  # no time stamp in the gzip streams
    plain, gz = files(folder.path), files(packed.path)
    runs = [k for k in plain if k.startswith(("flatplank/", "trailer/"))]
    assert runs and all(gzip.decompress(gz[f"{k}.gz"]) == plain[k] for k in runs)
    assert manifest(packed.path)["runs"][0]["file"].endswith(".csv.gz")


def test_manifest_follows_the_contract(folder):
    m = manifest(folder.path)
    assert m["tyre"]["nominal_pressure_Pa"] == 250000 and m["tyre"]["nominal_load_N"] == 5000
    assert m["tyre"]["unloaded_radius_m"] == pytest.approx(0.3205)
    assert m["tyre"]["source"] == "simulated"
    assert m["rig"]["hub_a_m"] > 0 and m["rig"]["hub_b_m"] > 0
    ids = [r["id"] for r in m["runs"]]
    assert len(ids) == len(set(ids)) == len(folder.run_ids)
    tests = {(r["kind"], r["test"]) for r in m["runs"]}
    for test in ("vertical", "longitudinal_stiffness", "lateral_stiffness", "parking",
                 "relaxation", "free_rolling", "camber"):
        assert ("flatplank", test) in tests
    for test in ("cornering", "braking_driving", "combined", "camber", "rolling_resistance"):
        assert ("trailer", test) in tests
    assert ("characteristics", "eigenfrequency") in tests
    for r in m["runs"]:
        assert (folder.path / r["file"]).is_file() and r["axes"] == "ISO-W"
        header = (folder.path / r["file"]).read_text().splitlines()[0].split(",")
        if r["kind"] == "flatplank":
            assert tuple(header) == FLATPLANK_CHANNELS
            c = r["conditions"]
            assert {"pressure_Pa", "load_N", "start_position"} <= set(c)
            assert Path(r["file"]).stem == r["id"]
        elif r["kind"] == "trailer":
            assert tuple(header) == TRAILER_CHANNELS
    relax = [r for r in m["runs"] if r["test"] == "relaxation"]
    assert {r["conditions"]["slip_angle_deg"] for r in relax} == {0.0, 1.0}


def test_truth_json_schema(folder):
    truth = json.loads((folder.path / "truth.json").read_text())
    assert truth == folder.truth
    for key in ("mfid_version", "seed", "artefacts", "grid", "rig", "tir", "hidden",
                "relations", "characteristics", "fittyp"):
        assert key in truth
    assert truth["seed"] == 3 and truth["artefacts"]["noise"] == 0.01
    assert truth["tir"]["FNOMIN"] == 5000 and truth["tir"]["PKY1"] == P["PKY1"]
    assert set(truth["relations"]) >= {"CFz", "CFx", "CFy", "CMz", "ring", "p0"}
    rows = pd.DataFrame(truth["characteristics"])
    assert set(rows["quantity"]) == QUANTITIES
    assert np.isfinite(rows["value"]).all()
    for q, unit in rows.groupby("quantity")["unit"].unique().items():
        assert list(unit) == [UNITS[q]]
    n_p, n_l = len(SMALL.pressures_bar), len(SMALL.loads)
    counts = rows["quantity"].value_counts()
    assert counts["CFz"] == counts["CFy"] == counts["sigma_y"] == counts["Re"] == n_p * n_l
    assert counts["CMz"] == n_p * len(SMALL.parking_loads)
    assert counts["Fy_gamma"] == n_p * n_l * (len(SMALL.camber_deg) - 1)
    assert counts["f_nat"] == 6 * len(SMALL.eigen_pressures_bar)
    assert rows.loc[rows.quantity == "FxRR", "Vx_mps"].notna().all()
    assert set(rows.loc[rows.quantity == "f_nat", "mode"]) == {"x", "y", "z", "theta", "gamma",
                                                               "psi"}
    eig = pd.read_csv(folder.path / "characteristics.csv")
    assert list(eig.columns[:5]) == ["quantity", "pi_bar", "Fz_N", "value", "unit"]


@pytest.mark.parametrize("artefacts", [{}, {"transients": True, "stick_slip": True,
                                            "asymmetry": 0.1}])
def test_hub_transform_recovers_contact_forces(tmp_path, artefacts):
    result = sim(tmp_path / "f", **{**CLEAN, **artefacts})
    m = manifest(result.path)
    a, b = m["rig"]["hub_a_m"], m["rig"]["hub_b_m"]
    flat = [r for r in m["runs"] if r["kind"] == "flatplank"]
    assert len(flat) == len(result.contact)
    for r in flat:
        got = to_contact(pd.read_csv(result.path / r["file"]), a, b)
        want = result.contact[r["id"]]
        for col in want.columns:
            scale = max(1.0, float(np.abs(want[col]).max()))
            np.testing.assert_allclose(got[col], want[col], rtol=0, atol=1e-9 * scale,
                                       err_msg=f"{r['id']} {col}")


def test_clean_runs_encode_the_truth(tmp_path):
    """Without noise and artefacts, simple extractions give the truth back."""
    result = sim(tmp_path / "c", **CLEAN, short_relaxation=False)
    truth = pd.DataFrame(result.truth["characteristics"])

    def true(q, p, fz):
        row = truth[(truth.quantity == q) & np.isclose(truth.pi_bar, p) & (truth.Fz_N == fz)]
        return float(row["value"].iloc[0])

    p, fz = 2.8, 6000.0
    coefficients = []
    for s in (1, 2):
        raw = pd.read_csv(result.path / f"flatplank/vertical_p280_fz9000_s{s}.csv")
        n = len(raw) // 2 + 1
        fzs = result.contact[f"vertical_p280_fz9000_s{s}"]["Fz"][:n]
        coefficients.append(np.polyfit(raw.hub_z[:n], fzs, 2))
    c2, c1, c0 = np.mean(coefficients, axis=0)
    rho = (-c1 + np.sqrt(c1 ** 2 - 4 * c2 * (c0 - fz))) / (2 * c2)
    assert 2 * c2 * rho + c1 == pytest.approx(true("CFz", p, fz), rel=1e-6)
    raw = pd.read_csv(result.path / "flatplank/free_rolling_p280_fz6000_s1.csv")
    re = np.diff(raw.plank_x)[-5:] / np.diff(raw.wheel_angle)[-5:]
    np.testing.assert_allclose(re, true("Re", p, fz), rtol=1e-9)
    slopes = []
    for s in (1, 2):
        raw = pd.read_csv(result.path / f"flatplank/lateral_stiffness_p280_fz6000_s{s}.csv")
        fy = result.contact[f"lateral_stiffness_p280_fz6000_s{s}"]["Fy"]
        slopes.append(np.polyfit(raw.plank_x[:8], fy[:8], 1)[0])
    assert np.mean(slopes) == pytest.approx(true("CFy", p, fz), rel=1e-9)
    run = result.contact["relaxation_p280_fz6000_s1_a1"]["Fy"]
    ref = result.contact["relaxation_p280_fz6000_s1_a0"]["Fy"]
    x = pd.read_csv(result.path / "flatplank/relaxation_p280_fz6000_s1_a1.csv").plank_x
    dy = (run - ref).to_numpy()
    k = len(dy) // 2
    fss = dy[-1] / -np.expm1(-x.iloc[-1] / true("sigma_y", p, fz))
    assert -x.iloc[k] / np.log1p(-dy[k] / fss) == pytest.approx(true("sigma_y", p, fz), rel=1e-6)


def test_short_relaxation_runs_stop_early(tmp_path):
    result = sim(tmp_path / "s", **CLEAN)
    truth = pd.DataFrame(result.truth["characteristics"])
    sig = truth[truth.quantity == "sigma_y"]
    longest = sig.loc[sig["value"].idxmax()]
    for r in manifest(result.path)["runs"]:
        if r["test"] != "relaxation":
            continue
        c = r["conditions"]
        own = sig[np.isclose(sig.pi_bar, c["pressure_Pa"] / 1e5) & (sig.Fz_N == c["load_N"])]
        rolled = pd.read_csv(result.path / r["file"]).plank_x.max() / own["value"].iloc[0]
        is_short = (c["pressure_Pa"] / 1e5 == pytest.approx(longest.pi_bar)
                    and c["load_N"] == longest.Fz_N)
        assert (rolled < 2.0) if is_short else (rolled > 6.5)


@pytest.mark.parametrize("rho", [0.0, 0.8])
def test_noise_level_statistics(tmp_path, rho):
    level = 0.02
    clean = sim(tmp_path / "clean", noise=0.0, ar1_rho=rho)
    noisy = sim(tmp_path / "noisy", noise=level, ar1_rho=rho)
    ratios, lag1 = [], []
    for r in manifest(noisy.path)["runs"]:
        if r["kind"] == "characteristics":
            continue
        a = pd.read_csv(clean.path / r["file"])
        b = pd.read_csv(noisy.path / r["file"])
        channels = ["Gx1", "Gx2", "Gy", "Gz1", "Gz2"] if r["kind"] == "flatplank" else \
            ["FX", "FYW", "MXW", "MYW", "MZW"]
        for ch in channels:
            rms = np.sqrt(np.mean(a[ch] ** 2))
            if rms == 0:
                assert (b[ch] == a[ch]).all()
                continue
            e = (b[ch] - a[ch]).to_numpy() / (level * rms)
            ratios.append(e)
            lag1.append(np.corrcoef(e[:-1], e[1:])[0, 1])
        untouched = [c for c in a.columns if c not in channels]
        pd.testing.assert_frame_equal(a[untouched], b[untouched])
    pooled = np.concatenate(ratios)
    assert abs(pooled.mean()) < 0.05
    assert np.std(pooled) == pytest.approx(1.0, abs=0.08 if rho else 0.03)
    assert np.median(lag1) == pytest.approx(rho, abs=0.08)


def test_hide_changes_camber_data_not_the_base_tir(tmp_path):
    base = sim(tmp_path / "base", seed=5)
    hidden = sim(tmp_path / "hidden", seed=5, hide={"PPY5": -0.6})
    fb, fh = files(base.path), files(hidden.path)
    assert fb["flatplank/camber_p220_fz3000_s1_g10.csv"] != \
        fh["flatplank/camber_p220_fz3000_s1_g10.csv"]
    assert fb["trailer/camber_p220.csv"] != fh["trailer/camber_p220.csv"]
    for same in ("flatplank/vertical_p220_fz9000_s1.csv", "trailer/cornering_p220.csv",
                 "flatplank/camber_p220_fz3000_s1_g0.csv"):
        assert fb[same] == fh[same]
    assert hidden.truth["tir"] == base.truth["tir"]
    assert hidden.truth["tir"]["PPY5"] == P["PPY5"]
    assert hidden.truth["hidden"] == {"PPY5": -0.6}
    tb, th = (pd.DataFrame(r.truth["characteristics"]) for r in (base, hidden))
    fy_b = tb[tb.quantity == "Fy_gamma"]["value"].to_numpy()
    fy_h = th[th.quantity == "Fy_gamma"]["value"].to_numpy()
    assert not np.allclose(fy_b, fy_h)  # the truth holds what the data were made from


def test_hide_relation_coefficient_and_bad_names(tmp_path):
    result = sim(tmp_path / "r", hide={"CFy.p2": -0.1}, **CLEAN)
    assert result.truth["hidden"] == {"CFy.p2": -0.1}
    assert result.truth["relations"]["CFy"]["p2"] == 0.0
    for bad in ({"NOPE": 1.0}, {"CFy.zz": 1.0}, {"PPY5": "x"}, {"FILE_TYPE": 1.0}):
        with pytest.raises(InputError):
            sim(tmp_path / "bad", hide=bad)
    assert not (tmp_path / "bad").exists()


def test_folder_never_partially_written(tmp_path, monkeypatch):
    import identify.simulate.folder as folder_module

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(folder_module, "manifest_text", boom)
    with pytest.raises(RuntimeError):
        sim(tmp_path / "out")
    assert list(tmp_path.iterdir()) == []


def test_refuses_a_non_empty_folder_unless_overwrite(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    with pytest.raises(InputError, match="not empty"):
        sim(out)
    assert [p.name for p in out.iterdir()] == ["keep.txt"]
    sim(out, overwrite=True)
    assert not (out / "keep.txt").exists() and (out / "tyre.toml").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    empty = tmp_path / "empty"
    empty.mkdir()
    assert sim(empty).path == empty


def test_default_tir_is_the_generated_one():
    values = default_tyre_values()
    for key, value in values.items():
        if not isinstance(value, str):
            assert P[key] == pytest.approx(value, rel=1e-12), key


def test_cli_simulate(tmp_path):
    runner = CliRunner()
    out = tmp_path / "cli"
    res = runner.invoke(app, ["simulate", "default", str(out), "--grid", "small", "--seed", "2",
                              "--hide", "QSY8=-0.6", "--no-transients", "--digits", "9"])
    assert res.exit_code == 0, res.output
    truth = json.loads((out / "truth.json").read_text())
    assert truth["hidden"] == {"QSY8": -0.6} and truth["artefacts"]["transients"] is False
    for bad in (["--hide", "QSY8"], ["--hide", "QSY8=abc"], ["--hide", "NOPE=1"]):
        res = runner.invoke(app, ["simulate", "default", str(tmp_path / "x"), "--grid", "small",
                                  *bad])
        assert res.exit_code == 2
        assert len(res.output.strip().splitlines()) == 1 and "error" in res.output
    res = runner.invoke(app, ["simulate", "default", str(out), "--grid", "small"])
    assert res.exit_code == 2 and "not empty" in res.output


def test_default_coefficients_near_the_thesis():
    """The simulated characteristics at the thesis grid stay close to the real tyre."""
    from identify.simulate import FULL
    from identify.simulate.coefficients import DEFAULT_RELATIONS
    from identify.simulate.model import TyreModel
    from identify.simulate.rig import DEFAULT_RIG
    from identify.simulate.truth import characteristics

    thesis = pd.read_csv(THESIS_CSV)
    model = TyreModel(P, DEFAULT_RELATIONS, DEFAULT_RIG)
    sim_rows = pd.DataFrame(characteristics(model, FULL))
    merged = thesis.merge(sim_rows, on=["quantity", "pi_bar", "Fz_N"], suffixes=("", "_sim"))
    worst = (abs(merged.value_sim / merged.value - 1) * 100).groupby(merged.quantity).max()
    limits = {"CFz": 2.0, "CFx": 2.0, "CFy": 7.0, "sigma_y": 7.5, "Re": 0.3}
    assert set(worst.index) == set(limits)
    for q, limit in limits.items():
        assert worst[q] < limit, (q, worst[q])
