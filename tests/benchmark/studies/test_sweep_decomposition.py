"""``benchmark.studies.sweep_decomposition``: ``G`` split into its spatial part and its
orientation maps from two elevations, and the sweep scoring such extra remappings."""

import numpy as np
import pandas as pd
import pytest

from benchmark.studies.sweep_decomposition import main, split_remap
from benchmark.toydata import make_toy_dataset
from viewadapt.adapt import hog_remap_matrix
from viewadapt.geometry import elevation_homography


def _H(e):
    return elevation_homography(0.0, e, distance=10.0, framing="plane")


@pytest.mark.parametrize("rule", ["covariant", "paper", "none"])
def test_one_elevation_for_both_parts_is_the_adapted_detectors_g(rule):
    for e in (0.3, np.pi / 4, 1.2):
        split = split_remap(_H(e), _H(e), rule, 4)
        whole = hog_remap_matrix(_H(e), target_cell_size=4, rule=rule)
        assert split.shape == whole.shape
        assert abs(split - whole).max() == pytest.approx(0, abs=1e-12)


def test_the_parts_come_from_their_own_elevations():
    # orientations from the source view itself (e = 0: the identity homography) turn
    # nothing, so G is the spatial resampling alone
    spatial_only = split_remap(_H(1.0), np.eye(3), "covariant", 4)
    assert abs(spatial_only - split_remap(_H(1.0), _H(1.0), "none", 4)).max() < 1e-9
    # the orientation maps of another elevation change G, the cells it reads do not
    mixed = split_remap(_H(1.0), _H(np.pi / 4), "covariant", 4)
    own = split_remap(_H(1.0), _H(1.0), "covariant", 4)
    assert abs(mixed - own).max() > 0.1
    cells = np.add.reduceat(np.asarray(abs(mixed).sum(0)).ravel() > 0, np.arange(0, 4608, 9))
    cells_own = np.add.reduceat(np.asarray(abs(own).sum(0)).ravel() > 0, np.arange(0, 4608, 9))
    np.testing.assert_array_equal(cells > 0, cells_own > 0)


def test_kept_cells_get_their_map_and_the_others_the_identity():
    H = _H(np.pi / 4)
    full, bare = split_remap(H, H, "covariant", 4), split_remap(H, H, "none", 4)
    keep = np.zeros(128, bool)
    keep[::3] = True
    part = split_remap(H, H, "covariant", 4, keep=keep)
    rows = np.repeat(keep, 9)                            # a source cell's 9 bins are its rows
    assert abs(part[rows] - full[rows]).max() == pytest.approx(0, abs=1e-12)
    assert abs(part[~rows] - bare[~rows]).max() == pytest.approx(0, abs=1e-12)
    assert abs(full[~rows] - bare[~rows]).max() > 0.1  # the test can tell the two apart
    assert abs(split_remap(H, H, "covariant", 4, keep=np.ones(128, bool)) - full).max() == 0
    with pytest.raises(ValueError, match="one flag per source cell"):
        split_remap(H, H, "covariant", 4, keep=np.ones(12, bool))


def test_the_sweep_scores_extra_remappings_beside_its_variants(tmp_path, capsys):
    from benchmark.crops.crossval import CrossvalConfig
    from benchmark.crops.features import FeatureCache
    from benchmark.crops.sweep import run_sweep
    from benchmark.data import load_dataset

    data = make_toy_dataset(tmp_path / "toy", n_persons=9, n_scenes=3, n_backgrounds=2, seed=1)
    ds = load_dataset(data)
    cache = FeatureCache(ds, tmp_path / "cache", progress=False)
    cfg = CrossvalConfig(detectors=("hog",), ablations=False, synthesised=False,
                         upper_bound=False, object_models=("plane",), initial_negatives=2000)
    rows = run_sweep(ds, cfg, cache, step=np.pi / 12, sigma=0.0, progress=False,
                     variants=("adapted",),
                     extra=lambda e: {"split": split_remap(_H(e), _H(e), "covariant", 4)})
    own, split = (rows[rows["method"] == m].reset_index(drop=True)
                  for m in ("adapted", "split"))
    assert len(own) > 0 and own["estimate"].nunique() == 6
    pd.testing.assert_frame_equal(own.drop(columns="method"), split.drop(columns="method"),
                                  check_exact=True)
    # the study's command: its table, figure and scores; bad input is one line
    out = tmp_path / "out"
    assert main(["--data", str(data), "--out", str(out), "--cache", str(tmp_path / "cache"),
                 "--step", str(np.pi / 36)]) == 0
    text = (out / "decomposition.md").read_text()
    for curve in ("covariant: S estimated, A true", "covariant: S true, A estimated",
                  "eq. (3): S true, A estimated", "| adapted |"):
        assert curve in text
    assert "| covariant | " in text and "| eq. (3) | " in text      # the maps' costs
    assert (out / "decomposition.png").is_file() and (out / "sweep_summary.csv").is_file()
    capsys.readouterr()
    assert main(["--data", str(data), "--out", str(tmp_path / "o2"), "--step", "1"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err == ("python -m benchmark.studies.sweep_decomposition: error: --step must "
                       "lie in (0, pi/36] radians\n")
    assert not (tmp_path / "o2").exists()


def test_orientation_cost_is_the_paired_miss_rate_difference_at_the_truth():
    from benchmark.studies.sweep_decomposition import orientation_cost

    rng = np.random.default_rng(0)
    rows = []
    persons = ["p1", "p2", "p3", "p4"]
    for method, missed in (("covariant: S true, A estimated", {0.0: {"p1"}, 0.8: {"p1", "p2"}}),
                           ("eq. (3): S true, A estimated", {0.0: {"p3"}, 0.8: {"p3"}}),
                           ("covariant: S estimated, A true", {0.0: set(), 0.8: set(persons)})):
        for e in (0.0, 0.4, 0.8):
            for s in rng.uniform(-3, -1, 300):
                rows.append((method, e, 0, s, "bg"))
            for p in persons:
                for _ in range(2):
                    rows.append((method, e, 1, -5.0 if p in missed.get(e, ()) else 1.0, p))
    scores = pd.DataFrame(rows, columns=["method", "estimate", "label", "score", "person_id"])
    cost = {c["rule"]: c for c in orientation_cost(scores, np.pi / 4, n_boot=200)}
    # only the "S true, A estimated" curves; the estimate nearest the truth is 0.8
    assert set(cost) == {"covariant", "eq. (3)"}
    c = cost["covariant"]
    assert (c["mr_identity"], c["mr_truth"], c["cost"]) == pytest.approx((0.25, 0.5, 0.25))
    # paired: a draw loses p2's share of its positives, never less than nothing
    assert 0 <= c["low"] <= 0.25 <= c["high"] < 1 and c["high"] > c["low"]
    e = cost["eq. (3)"]
    assert (e["cost"], e["low"], e["high"]) == pytest.approx((0.0, 0.0, 0.0))
