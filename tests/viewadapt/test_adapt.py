import numpy as np
import pytest
import scipy.sparse as sp
from sklearn.svm import LinearSVC
from sklearn.utils.estimator_checks import parametrize_with_checks

from tests.tolerances import EXACT
from viewadapt.adapt import (
    ViewpointAdaptedClassifier, acf_remap_matrix, adapt_linear_weights, cells_to_descriptor,
    elevation_remap_matrix, hog_remap_matrix, remap_cells_to_descriptor,
)
from viewadapt.classifiers import LinearSVMDetector
from viewadapt.geometry import elevation_homography
from viewadapt.hog import hog_descriptor, hog_cells


@parametrize_with_checks([LinearSVMDetector(initial_negatives=20, mining_rounds=1),
                          ViewpointAdaptedClassifier()])
def test_sklearn_contract(estimator, check):
    check(estimator)


def test_adapted_weights_exact_on_random_inputs():
    G = elevation_remap_matrix(0.0, np.pi / 4, target_cell_size=4)
    rng = np.random.default_rng(0)
    w = rng.normal(size=G.shape[0])
    X = rng.normal(size=(50, G.shape[1]))
    assert np.allclose(X @ adapt_linear_weights(w, G), (G @ X.T).T @ w, **EXACT)


def test_wrapper_scores_equal_explicit_remap():
    rng = np.random.default_rng(1)
    n = 16 * 8 * 9
    Xs = np.abs(rng.normal(size=(80, n)))
    y = np.r_[np.ones(40), np.zeros(40)].astype(int)
    Xs[:40, :100] += 1.0
    clf = ViewpointAdaptedClassifier(LinearSVC(C=0.1), source_elevation=0.0,
                                     target_elevation=np.pi / 4).fit(Xs, y)
    Xt = np.abs(rng.normal(size=(10, n)))
    G = elevation_remap_matrix(0.0, np.pi / 4)
    want = clf.estimator_.decision_function((G @ Xt.T).T)
    assert np.allclose(clf.decision_function(Xt), want, **EXACT)
    # block representation: N(G x_t) then the source-view linear model
    clfb = ViewpointAdaptedClassifier(LinearSVC(C=0.1), source_elevation=0.0,
                                      target_elevation=np.pi / 4,
                                      representation="blocks").fit(Xs, y)
    want_b = clfb.estimator_.decision_function(remap_cells_to_descriptor(Xt, G))
    assert np.allclose(clfb.decision_function(Xt), want_b, **EXACT)


def test_cells_to_descriptor_equals_hog_descriptor():
    img = np.random.default_rng(2).integers(0, 256, (128, 64)).astype(np.uint8)
    assert np.allclose(cells_to_descriptor(hog_cells(img).ravel()), hog_descriptor(img), **EXACT)


def test_from_fitted_linear_model():
    rng = np.random.default_rng(3)
    n = 16 * 8 * 9
    svm = LinearSVC().fit(rng.normal(size=(20, n)), np.r_[np.ones(10), np.zeros(10)])
    G = elevation_remap_matrix(np.pi / 8, np.pi / 4)
    clf = ViewpointAdaptedClassifier.from_fitted(svm, remap=G)
    Xt = rng.normal(size=(5, n))
    assert np.allclose(clf.decision_function(Xt), svm.decision_function((G @ Xt.T).T), **EXACT)


def test_acf_remap_layout_identity_and_blocks():
    G = acf_remap_matrix(np.eye(3))
    assert G.shape == (10 * 32 * 16,) * 2
    assert abs(G - sp.identity(G.shape[0])).max() < 1e-12
    H = elevation_homography(0.0, np.pi / 4)
    G = acf_remap_matrix(H)
    n = 32 * 16
    # colour channels never mix with orientation channels
    assert abs(G[:4 * n, 4 * n:]).max() == 0 and abs(G[4 * n:, :4 * n]).max() == 0
    # orientation channel 0 of a cell draws on several orientation channels (A != I)
    assert G[4 * n:, 4 * n:].nnz > G[:n, :n].nnz * 6


def test_hard_negative_mining_adds_hard_ones():
    rng = np.random.default_rng(4)
    pos = rng.normal(1.0, 1.0, size=(100, 5))
    easy = rng.normal(-3.0, 0.5, size=(2000, 5))
    hard = rng.normal(0.5, 1.0, size=(100, 5))
    X = np.vstack([pos, easy, hard])
    y = np.r_[np.ones(100), np.zeros(2100)].astype(int)
    det0 = LinearSVMDetector(initial_negatives=100, mining_rounds=0, random_state=0).fit(X, y)
    det = LinearSVMDetector(initial_negatives=100, mining_rounds=2, random_state=0).fit(X, y)
    assert det.n_negatives_used_ > det0.n_negatives_used_ == 100
    # the mined model ranks the hard negatives lower relative to positives
    def fp_at_recall(d):
        s_pos, s_hard = d.decision_function(pos), d.decision_function(hard)
        return (s_hard > np.percentile(s_pos, 20)).mean()
    assert fp_at_recall(det) <= fp_at_recall(det0)


def test_errors():
    with pytest.raises(ValueError, match="source features"):
        adapt_linear_weights(np.ones(5), sp.identity(6))
    with pytest.raises(ValueError, match="features must be"):
        elevation_remap_matrix(0, 0.3, features="sift")
    with pytest.raises(ValueError, match="Only binary"):
        LinearSVMDetector().fit(np.ones((6, 2)) * np.arange(6)[:, None], [0, 1, 2, 0, 1, 2])
    with pytest.raises(ValueError, match="rows"):
        ViewpointAdaptedClassifier(remap=np.eye(3)).fit(np.ones((4, 5)) * [[0], [1], [2], [3]], [0, 1, 0, 1])
    with pytest.raises(ValueError, match="cell_shape"):
        ViewpointAdaptedClassifier(target_elevation=0.5).fit(np.arange(20.0).reshape(4, 5), [0, 1, 0, 1])
    with pytest.raises(ValueError, match=r"\[0, pi/2\)"):
        hog_remap_matrix(elevation_homography(0, 1.6))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_remap_features_is_scipys_product_exactly(dtype):
    from viewadapt.adapt import remap_features

    G = hog_remap_matrix(elevation_homography(0, np.pi / 5, distance=10), target_cell_size=4)
    X = (np.random.default_rng(3).random((37, G.shape[1])) ** 3).astype(dtype)
    want = np.asarray(G @ np.ascontiguousarray(X.T, dtype=np.float64)).T
    np.testing.assert_array_equal(remap_features(G, X), want)
    np.testing.assert_array_equal(remap_features(G.tocoo(), X[5]), want[5:6])
    with pytest.raises(ValueError, match="columns"):
        remap_features(G, X[:, 1:])


def test_descriptors_of_many_windows_are_each_windows_own():
    # more windows than one block of the blocked computation, in any memory order
    X = np.random.default_rng(4).random((300, 16 * 8 * 9))
    many = cells_to_descriptor(np.asfortranarray(X))
    for i in (0, 127, 128, 299):
        np.testing.assert_array_equal(many[i], cells_to_descriptor(X[i]))
