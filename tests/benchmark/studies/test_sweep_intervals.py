"""``benchmark.studies.sweep_intervals``: a sweep's best estimate and crossing with
intervals over test persons, on synthetic scores whose answer is known."""

import numpy as np
import pandas as pd
import pytest

from benchmark.crops.report import paper_sweep_table, sweep_table
from benchmark.studies.sweep_intervals import (bootstrap_miss_rates, main, person_weights,
                                               sweep_intervals)

ESTIMATES = np.round(np.arange(0.0, 1.3, 0.1), 1)
TRUE = 0.6


def _scores(n_persons=40, per_person=20, n_neg=2000, seed=0):
    """Negatives N(0, 1) for every row; positives N(mu, 1) with mu peaking at the truth
    (3.5) and falling 4 per rad away; the unadapted detector's positives at mu 2."""
    rng = np.random.default_rng(seed)
    rows = []

    def add(method, est, mu):
        persons = np.repeat([f"p{i:02d}" for i in range(n_persons)], per_person)
        rows.append(pd.DataFrame({"method": method, "estimate": est, "label": 1,
                                  "score": rng.normal(mu, 1, len(persons)),
                                  "person_id": persons}))
        rows.append(pd.DataFrame({"method": method, "estimate": est, "label": 0,
                                  "score": rng.normal(0, 1, n_neg), "person_id": "bg"}))

    add("unadapted", np.nan, 2.0)
    for e in ESTIMATES:
        add("adapted", e, 3.5 - 4 * abs(e - TRUE))
    return pd.concat(rows, ignore_index=True)


def test_the_intervals_hold_the_known_answer_and_the_point_is_the_sweeps():
    scores = _scores()
    tab = sweep_intervals(scores, true_elevation=TRUE, n_boot=200, seed=1)
    row = tab.set_index("method").loc["adapted"]
    assert row["best_estimate"] == pytest.approx(TRUE)
    assert row["best_estimate_low"] <= TRUE <= row["best_estimate_high"]
    # better than unadapted while 3.5 - 4 |e - 0.6| > 2: up to e < 0.975, so 0.9
    assert row["crossing"] == pytest.approx(0.9)
    assert row["crossing_low"] <= 0.9 <= row["crossing_high"] and row["crossing_defined"] == 1
    assert row["best_mr_low"] <= row["best_mr"] <= row["best_mr_high"]
    assert row["n_persons"] == 40
    # the point estimates are sweep_table's on the pooled miss rates
    from benchmark.crops.sweep import sweep_summary

    summary = sweep_summary(scores.assign(fold="f0"))
    want = sweep_table(summary, TRUE).set_index("method").loc["adapted"]
    for col in ("best_estimate", "best_mr", "mr_at_true", "crossing"):
        assert row[col] == pytest.approx(want[col])
    # reproducible with its seed
    again = sweep_intervals(scores, true_elevation=TRUE, n_boot=200, seed=1)
    pd.testing.assert_frame_equal(tab, again)


def test_a_flat_sweep_has_wide_intervals_and_bad_input_is_one_line(tmp_path, capsys):
    scores = _scores()
    flat = scores.copy()
    adapted = flat["method"] == "adapted"
    pos = adapted & (flat["label"] == 1)
    flat.loc[pos, "score"] = np.random.default_rng(3).normal(2.6, 1, int(pos.sum()))
    row = sweep_intervals(flat, true_elevation=TRUE, n_boot=200).set_index("method").loc[
        "adapted"]
    assert row["best_estimate_high"] - row["best_estimate_low"] >= 0.3
    with pytest.raises(ValueError, match="no unadapted rows"):
        sweep_intervals(scores[scores["method"] != "unadapted"])
    with pytest.raises(ValueError, match="lack the columns \\['person_id'\\]"):
        sweep_intervals(scores.drop(columns="person_id"))
    assert main([str(tmp_path)]) == 2
    assert "holds no sweep_scores.parquet" in capsys.readouterr().err
    run = tmp_path / "run"
    run.mkdir()
    scores.to_parquet(run / "sweep_scores.parquet")
    assert main([str(run), "--boot", "50", "--target", str(TRUE)]) == 0
    text = (run / "sweep_intervals.md").read_text()
    assert "| adapted | 0.60 (" in text and "40 test persons, 50 resamples" in text
    assert (run / "sweep_intervals.csv").is_file()


def test_the_interpolated_crossing_is_where_the_curve_meets_unadapted():
    e = np.round(np.arange(0.0, 1.25, 0.1), 1)
    curve = pd.DataFrame({"method": "adapted", "estimate": e,
                          "mr_at_fppw_0.01": 0.1 + 0.5 * np.abs(e - 0.6)})
    for u, grid, meet in ((0.3, 0.9, 1.0), (0.28, 0.9, 0.96), (0.12, 0.6, 0.64)):
        summary = pd.concat([curve, pd.DataFrame({"method": ["unadapted"], "estimate": [np.nan],
                                                  "mr_at_fppw_0.01": [u]})])
        row = sweep_table(summary, 0.6).iloc[0]
        assert row["crossing"] == pytest.approx(grid)
        assert row["crossing_interp"] == pytest.approx(meet)
        assert row["band_interp"] == pytest.approx(meet - 0.6)
    # better than unadapted to the grid's end: no later point to interpolate towards
    summary = pd.concat([curve, pd.DataFrame({"method": ["unadapted"], "estimate": [np.nan],
                                              "mr_at_fppw_0.01": [0.9]})])
    assert sweep_table(summary, 0.6).iloc[0]["crossing_interp"] == pytest.approx(1.2)


def test_the_paper_level_reading_ignores_the_runs_own_unadapted_level():
    e = np.round(np.arange(0.0, 1.25, 0.1), 1)
    curve = pd.DataFrame({"method": "adapted", "estimate": e,
                          "mr_at_fppw_0.01": 0.1 + 2.0 * np.abs(e - 0.6)})
    # 0.7 at 0.9 and 0.9 at 1.0: the paper's unadapted 0.7964 is reached at 0.9482
    for u in (0.3, 0.95):
        summary = pd.concat([curve, pd.DataFrame({"method": ["unadapted"], "estimate": [np.nan],
                                                  "mr_at_fppw_0.01": [u]})])
        row = sweep_table(summary, 0.6).iloc[0]
        assert row["band_paper_level"] == pytest.approx(0.9482 - 0.6)
    assert row["band_interp"] == pytest.approx(1.025 - 0.6)        # its own level, 0.95
    # a curve that never gets as bad as the paper's unadapted reads to the grid's end
    flat = curve.assign(**{"mr_at_fppw_0.01": 0.1 + 0.2 * np.abs(e - 0.6)})
    summary = pd.concat([flat, pd.DataFrame({"method": ["unadapted"], "estimate": [np.nan],
                                             "mr_at_fppw_0.01": [0.3]})])
    assert sweep_table(summary, 0.6).iloc[0]["band_paper_level"] == pytest.approx(1.2 - 0.6)


def test_the_papers_fig6_is_read_by_the_same_rules():
    # Wang et al. 2017, Fig. 6: best 0.662 at 15 pi/72; 0.7865 at 24 pi/72 and 0.8072 at
    # 25 pi/72 against the unadapted 0.7964, so the last estimate still better is 24 pi/72
    row = paper_sweep_table().iloc[0]
    assert row["best_estimate"] == pytest.approx(15 * np.pi / 72)
    assert row["best_mr"] == pytest.approx(0.6624)
    assert row["crossing"] == pytest.approx(24 * np.pi / 72)
    assert row["band_above_truth"] == pytest.approx(24 * np.pi / 72 - np.pi / 4)
    assert 24 * np.pi / 72 < row["crossing_interp"] < 25 * np.pi / 72
    assert row["unadapted"] == pytest.approx(0.7964)
    # against its own unadapted level the paper-level reading is its interpolated crossing
    assert row["band_paper_level"] == pytest.approx(row["band_interp"])


def test_person_bootstrap_draws_persons_and_pairs_the_rows():
    w = person_weights(5, 200, np.random.default_rng(1))
    assert w.shape == (200, 5) and (w.sum(1) == 5).all() and (w >= 0).all()
    assert (w == 0).any(1).mean() > 0.5                   # most draws leave someone out
    # two rows with the same persons: person 0 missed in row 1 only
    hits = np.array([[2.0, 2, 2, 2, 2], [0, 2, 2, 2, 2]])
    counts = np.full((2, 5), 2.0)
    mr = bootstrap_miss_rates(hits, counts, 200, np.random.default_rng(1))
    assert mr.shape == (201, 2) and mr[0] == pytest.approx([0.0, 0.2])
    # the same draw for both rows: row 1's miss rate is person 0's share of that draw
    np.testing.assert_allclose(mr[1:, 1], w[:, 0] / 5)
    np.testing.assert_allclose(mr[1:, 0], 0)


def test_the_true_elevation_comes_from_the_run_and_the_papers_row_only_at_pi_4(tmp_path):
    """Without ``--target`` the study reads the true elevation the sweep recorded in
    run.json (pi/4 for a run recording none); the report does the same; the paper's Fig. 6
    row and curve appear only beside a sweep of its true elevation, pi/4."""
    import json

    from benchmark.crops.report import sweep_target, write_report
    from benchmark.crops.sweep import sweep_summary

    scores = _scores()
    run = tmp_path / "run"
    run.mkdir()
    scores.to_parquet(run / "sweep_scores.parquet")
    sweep_summary(scores.assign(fold="f0")).to_csv(run / "sweep_summary.csv", index=False)
    (run / "run.json").write_text(json.dumps({"sweep": {"target": TRUE}}))
    assert main([str(run), "--boot", "20"]) == 0
    text = (run / "sweep_intervals.md").read_text()
    row = pd.read_csv(run / "sweep_intervals.csv").set_index("method").loc["adapted"]
    assert row["band_above_truth"] == pytest.approx(0.9 - TRUE)     # measured from 0.6
    assert "paper (Wang" not in text and "no row of its data" in text
    report = write_report(run).read_text()
    assert "at the true 0.600 rad" in report and "paper (Wang" not in report
    # the reading against the paper's unadapted level belongs to a pi/4 sweep only
    assert "the paper's unadapted, above truth" not in text + report
    # the recorded truth decides "MR at truth": the adapted curve's best point, 0.6
    best = sweep_table(sweep_summary(scores.assign(fold="f0")), TRUE).iloc[0]
    assert f"| {best['best_estimate']:.2f} | {best['best_mr']:.3f} | {best['mr_at_true']:.3f} |" \
        in report
    # a run that records no target is a pi/4 sweep, with the paper's row
    (run / "run.json").write_text(json.dumps({"sweep": {}}))
    assert sweep_target(json.loads((run / "run.json").read_text())) == pytest.approx(np.pi / 4)
    assert main([str(run), "--boot", "20"]) == 0
    text, report = (run / "sweep_intervals.md").read_text(), write_report(run).read_text()
    assert "paper (Wang" in text and "paper (Wang" in report
    # its last column: the paper's row reads its own interpolated crossing there, and every
    # row of the table has as many cells as the header
    paper = paper_sweep_table().iloc[0]
    for md in (text, report):
        table = [ln for ln in md.splitlines() if ln.startswith("| ")]
        assert "the paper's unadapted, above truth" in table[0]
        assert len({ln.count(" | ") for ln in table}) == 1
        assert next(ln for ln in table if ln.startswith("| paper (Wang")).endswith(
            f" {paper['band_interp']:.2f} |")
    with pytest.raises(ValueError, match="target elevation is 'high'"):
        sweep_target({"sweep": {"target": "high"}})
