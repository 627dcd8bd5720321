"""benchmark.studies.opencv_adaptation: its pieces (the AUC, OpenCV's hard-binned cell sums,
the per-window normalisation of exact remapped cells) against independent references, and
the study end to end on the toy MOT clip."""

import json

import cv2
import numpy as np
import pytest

from benchmark.studies.opencv_adaptation import _auc, _cell_sums, main, renorm_scores
from viewadapt.detect.opencv_cells import opencv_gradients
from viewadapt.hog import cells_to_blocks, hog_cells, normalize_blocks_l2hys
from tests.toy_frames import mot_toy_clip


def test_auc_is_the_mann_whitney_statistic():
    rng = np.random.default_rng(0)
    pos, neg = rng.normal(1, 1, 40), rng.normal(0, 1, 60)
    want = np.mean([(p > n) + 0.5 * (p == n) for p in pos for n in neg])
    assert _auc(pos, neg) == pytest.approx(want)
    assert _auc([1.0, 1.0], [1.0]) == 0.5 and _auc([2.0], [1.0]) == 1.0


def test_cell_sums_are_the_hard_binned_cells_of_opencvs_gradients():
    rng = np.random.default_rng(1)
    img = cv2.GaussianBlur(rng.integers(0, 256, (64, 48, 3), dtype=np.uint8), (5, 5), 1.0)
    mag, t = opencv_gradients(img)
    got = _cell_sums(mag, t, 8)
    want = hog_cells(img, cell_size=8, gamma=True)
    np.testing.assert_allclose(got, want, rtol=2e-3, atol=1e-2)   # float32 against float64


def test_renorm_at_identity_is_the_hard_binned_descriptor():
    rng = np.random.default_rng(2)
    img = cv2.GaussianBlur(rng.integers(0, 256, (160, 96, 3), dtype=np.uint8), (5, 5), 1.0)
    v = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), np.float64).ravel()
    H = np.array([[1.0, 0, 16], [0, 1.0, 16], [0, 0, 1.0]])
    got = renorm_scores(img, H[None], np.array([8]), v[:-1], v[-1])[0]
    cells = hog_cells(img, cell_size=8, gamma=True)[2:18, 2:10]
    want = normalize_blocks_l2hys(cells_to_blocks(cells)).ravel() @ v[:-1] + v[-1]
    assert got == pytest.approx(want, abs=1e-3)


@pytest.mark.study
def test_the_study_on_a_toy_clip(tmp_path):
    clip = mot_toy_clip(tmp_path / "clip", n_frames=2)
    out = tmp_path / "out"
    assert main([str(clip.img1), "--calibration", str(clip.calibration), "--boxes",
                 str(clip.gt), "--every", "1", "--negatives", "20", "--min-height", "10",
                 "--out", str(out)]) == 0
    d = json.loads((out / "opencv_adaptation.json").read_text())
    assert set(d["rows"]) == {"warp", "warp_cells", "renorm", "fold_exact", "fold"}
    assert d["rows"]["warp"]["corr_with_warp"] == pytest.approx(1.0)
    assert d["n_background"] == 40 and d["n_persons"] >= 1
    assert (out / "opencv_adaptation.md").read_text().startswith("# What the adapted")
