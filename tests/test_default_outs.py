"""Commands never write into the tracked docs by default (issue 34): ``sample_efficiency``
defaults to ``out/sample_efficiency``; ``hri-bench figures`` needs an ``--out`` (the README's
commands that regenerate the docs' figures name ``--out docs/figures``).
"""

from types import SimpleNamespace

import pytest

from hri_bench.cli import main
from hri_bench.report import sample_efficiency


def test_sample_efficiency_writes_under_out_by_default(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    summary = {k: {} for k in ("episodes_to_90pct_oracle", "episodes_to_r0_per_episode",
                               "final_score", "final_score_from_passive")}
    monkeypatch.setattr(sample_efficiency, "run_sample_efficiency",
                        lambda cfg, verbose: SimpleNamespace(to_dict=lambda: summary))
    monkeypatch.setattr(sample_efficiency, "plot", lambda result, path: path)
    assert sample_efficiency.main(["--seeds", "1"]) == 0
    assert (tmp_path / "out" / "sample_efficiency" / "sample_efficiency.json").is_file()
    assert not (tmp_path / "docs").exists()


def test_figures_needs_an_out(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["figures"])
    assert exc.value.code == 2
    assert "the following arguments are required: --out" in capsys.readouterr().err
