"""compare_eval: per-shot scores read from two evaluations' results.csv as `inbetween eval` writes them, and the
totals issue 27's bars are read from (shots ahead of RIFE-direct, lower lanes at the goal), counted by hand here."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmarks.compare_eval import compare, main, read_scores


def frames(shot: str, method: str, psnr: list[float]) -> list[dict]:
    """The rows of one method's frames: the first and last are keys (not interior), the rest interior."""
    n = len(psnr) + 2
    values = [90.0, *psnr, 90.0]
    return [{"method": method, "frame": i, "t": i / (n - 1), "interior": 0 < i < n - 1, "psnr": v, "ssim": 0.9,
             "chamfer": 1.0, "lane": np.nan, "shot": shot} for i, v in enumerate(values)]


def lanes(shot: str, psnr: tuple[float, float]) -> list[dict]:
    return [{"method": "lane_agreement", "frame": f, "t": float(f), "interior": False, "psnr": v, "ssim": np.nan,
             "chamfer": 2.0, "lane": name, "shot": shot} for f, v, name in zip((1, 0), psnr, ("key0->key1", "key1->key0"))]


def write(folder, rows: list[dict]) -> None:
    folder.mkdir()
    pd.DataFrame(rows).to_csv(folder / "results.csv", index=False)


@pytest.fixture
def evaluations(tmp_path):
    before, after = tmp_path / "before", tmp_path / "after"
    write(before, frames("a", "ours", [30.0, 32.0]) + frames("a", "rife_direct", [28.0, 28.0]) + lanes("a", (26, 24))
          + frames("b", "ours", [20.0, 20.0]) + frames("b", "rife_direct", [21.0, 21.0]) + lanes("b", (27, 28))
          + frames("gone", "ours", [10.0]))
    write(after, frames("a", "ours", [31.0, 33.0]) + frames("a", "rife_direct", [28.0, 28.0]) + lanes("a", (26, 25.5))
          + frames("b", "ours", [22.0, 22.0]) + frames("b", "rife_direct", [21.0, 21.0]) + lanes("b", (24, 28))
          + frames("new", "ours", [10.0]))
    return before, after


def test_the_shots_in_both_are_compared_on_their_interior_frames(evaluations):
    before, after = evaluations
    table, totals = compare(read_scores(before), read_scores(after))
    assert list(table.index) == ["a", "b"] and totals["only_in_one"] == ["gone", "new"]
    assert table.loc["a", "ours_before"] == 31.0 and table.loc["a", "ours_after"] == 32.0  # the keys' 90 dB left out
    assert table.loc["a", "change"] == 1.0 and table.loc["b", "lead"] == 1.0
    assert table.loc["a", "lane_before"] == 24 and table.loc["a", "lane_after"] == 25.5  # the lower lane
    assert totals["mean_before"] == 25.5 and totals["mean_after"] == 27.0
    assert (totals["ahead_before"], totals["ahead_after"], totals["with_rife"]) == (1, 2, 2)  # b passes RIFE-direct
    assert (totals["lanes_before"], totals["lanes_after"], totals["with_lanes"]) == (1, 1, 2)  # a gains, b loses


def test_the_report_lists_the_shots_that_moved_and_the_totals(evaluations, capsys):
    before, after = evaluations
    main([str(before), str(after), "--moved", "1.5"])
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out[1:-2]] == ["b"]  # a moved by 1.0 only
    assert out[-2] == ("2 shots: ours 25.500 -> 27.000 dB (+1.500); ahead of RIFE-direct 1 -> 2 of 2; "
                       "lower lane >= 25 dB 1 -> 1 of 2")
    assert out[-1] == "evaluated in one folder only (left out): gone, new"


def test_a_folder_without_results_is_named(tmp_path):
    with pytest.raises(SystemExit, match="no results.csv"):
        read_scores(tmp_path)
