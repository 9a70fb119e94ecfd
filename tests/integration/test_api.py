"""The public Python API: docs/api.md's worked example (a notebook: one cell per python block)
runs as written, fits in memory before it saves, and the names resolve."""
from __future__ import annotations

import re
from pathlib import Path

import matplotlib

import identify

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "api.md"


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_docs_api_example_runs(tmp_path, monkeypatch, capsys):
    matplotlib.use("Agg")
    monkeypatch.chdir(ROOT)
    blocks = _python_blocks(DOC.read_text(encoding="utf-8"))
    assert blocks, "docs/api.md has no python example"
    namespace = {"OUT": str(tmp_path)}
    for code in blocks:
        exec(compile(code, str(DOC), "exec"), namespace)  # noqa: S102 - our own docs
    printed = capsys.readouterr().out
    assert "thesis-225-50R17 " in printed and "PCFX2 =" in printed
    assert (tmp_path / "cfx.png").stat().st_size > 10_000
    assert (tmp_path / "thesis-225-50R17" / "fit.json").is_file()
    assert (tmp_path / "thesis-225-50R17" / "thesis-225-50R17.tir").is_file()
    assert namespace["run"].fit_dir is None  # mfid.fit wrote nothing; run.save did
    assert (tmp_path / "discovery" / "discovery.json").is_file()
    assert identify.read_tir(tmp_path / "scaled.tir").values["LFZO"] == 1.05


def test_every_api_name_resolves_under_both_package_names():
    import mfid

    for name in identify.__all__:
        assert getattr(identify, name) is getattr(mfid, name), name
    assert mfid.__version__ == identify.__version__
    assert "fit_folder" in dir(identify)
    assert mfid.fit is identify.api.fit and "fit" in dir(mfid)
