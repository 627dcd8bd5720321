"""The frame ``G`` of a template: frame cells -> the canonical window's features.

For a linear model on cell features the adapted detector of window ``n`` is
``s_n = w^T G_n x + b = (G_n^T w)^T x + b`` (Wang et al. 2017, eq. (5)-(7)), ``x`` the frame's
cell features and ``G_n = S_n (x) A_n`` the remapping from the frame cells of the window's
template patch to the canonical window's cells: :func:`hog_frame_remap` (HOG/SVM) and
:func:`acf_frame_remap` (ACF), for the paper's plane object model or any other
(:func:`window_mapping`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..adapt import acf_remap_matrix, hog_remap_matrix
from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH, crop_camera, window_to_image_homography
from ..mapping import homography_mapping
from ..objectmodel import PlaneModel, object_model, view_mapping
from ..remap import CellGrid
from .channels import (
    ACF_SHRINK, ACF_WEIGHT_SHAPE, HOG_CELL, HOG_CHANNELS, N_ACF_CHANNELS, N_ACF_ORIENTS, N_HOG_BINS,
)
from .opencv_cells import OPENCV_CHANNELS
from .windows import CandidateWindows, distort_pixels, homographies_through_lens

__all__ = ["SOURCE_DISTANCE_M", "patch_cell_grid", "resolve_object_model", "window_mapping",
           "from_detector_window", "hog_frame_remap", "cell_hog_remap", "opencv_frame_remap",
           "acf_frame_remap", "acf_gradient_rows"]


def patch_cell_grid(g) -> CellGrid:
    """The frame cells of template group ``g``'s prototype patch."""
    c = g.cell_size
    return CellGrid(g.shape[1], g.shape[0], c, origin=(g.origin[0] * c - 0.5,
                                                       g.origin[1] * c - 0.5))


#: Distance of the source view's camera from the person, metres, for object models other
#: than the plane: that of the dataset's elevation-0 crops (:func:`viewadapt.geometry.crop_camera`).
SOURCE_DISTANCE_M = 10.0


def resolve_object_model(model):
    """An object model from its name (``"plane"``, ``"body"``) or the model itself."""
    return object_model(model) if isinstance(model, str) else model


def window_mapping(windows: CandidateWindows, n: int, model="plane"):
    """Canonical-window pixels -> frame pixels of window ``n`` under the object model.

    The plane (the paper's model) gives the window's homography itself. Another model
    (e.g. the mean body, :mod:`viewadapt.objectmodel`) gives the point mapping of a person
    of that shape, seen in the source view by the elevation-0 crop camera
    (:data:`SOURCE_DISTANCE_M`) and in the frame by ``windows.camera`` at the window's
    ground position and person height (:func:`viewadapt.objectmodel.view_mapping`),
    followed by the window's homography relative to its person plane (identity on the
    native frame; the band's upsampling on an upsampled layer).

    Returns
    -------
    (3, 3) ndarray for the plane, else a callable mapping (NaN where undefined).
    """
    model = resolve_object_model(model)
    H = windows.homographies[n]
    if isinstance(model, PlaneModel):
        return H
    cam = windows.camera
    if cam is None:
        raise ValueError(f"the {model.name!r} object model needs the windows' camera "
                         "(windows from select_candidate_windows)")
    ground, height = windows.ground_xy[n], float(windows.person_height[n])
    source = crop_camera(0.0, distance=SOURCE_DISTANCE_M, person_height=height)
    body = view_mapping(model, source, cam, source_ground=(0.0, 0.0), target_ground=ground,
                        person_height=height, window=(WINDOW_WIDTH, WINDOW_HEIGHT))
    pinhole = window_to_image_homography(cam, ground, height)
    if windows.dist is None:
        # frame -> this layer's pixels: the layer's window homography against the plane's
        to_layer = homography_mapping(H @ np.linalg.inv(pinhole))
        return lambda p: to_layer(body(p))
    # through the lens: the body's pinhole pixels distorted, then the layer's own window
    # homography against the one the lens gives the plane on the frame
    dist = windows.dist
    fitted = homographies_through_lens(pinhole[None], cam.K, dist)[0]
    to_layer = homography_mapping(H @ np.linalg.inv(fitted))
    return lambda p: to_layer(_distorted(body(p), cam.K, dist))


def _distorted(points, K, dist) -> np.ndarray:
    """:func:`~viewadapt.detect.windows.distort_pixels` of the finite ``points`` (the others
    stay NaN: where the object model hides a point)."""
    p = np.asarray(points, np.float64)
    out = np.full(p.shape, np.nan)
    ok = np.all(np.isfinite(p), axis=-1)
    if ok.any():
        out[ok] = distort_pixels(p[ok], K, dist)
    return out


def from_detector_window(mapping, T):
    """A window's mapping (:func:`window_mapping`: a homography or a point mapping of the
    canonical window) read from a detector window whose pixels ``T`` maps into the
    canonical window (:func:`~viewadapt.detect.windows.detector_window_homography`)."""
    if callable(mapping):
        to_canonical = homography_mapping(T)
        return lambda p: mapping(to_canonical(p))
    return np.asarray(mapping) @ T


def hog_frame_remap(H, g, rule: str = "covariant") -> sp.csr_matrix:
    """``G`` from a frame patch of block-normalised HOG cells (n_y, n_x, 13) to the canonical
    window's (16, 8, 13) cells for the window ``H`` (canonical -> frame px: a homography or
    a point mapping, :func:`window_mapping`).

    Normalised cell features are intensive
    (:func:`~viewadapt.detect.channels.block_normalize_cells`):
    area-weighted means; ``S (x) A`` on the orientation channels, ``S`` alone on the texture
    energies (:func:`viewadapt.adapt.hog_remap_matrix`).
    """
    return hog_remap_matrix(H, source_cell_size=HOG_CELL, target_grid=patch_cell_grid(g),
                            n_bins=N_HOG_BINS, rule=rule, preserve="mean",
                            n_plain=HOG_CHANNELS - N_HOG_BINS)


def cell_hog_remap(H, g, rule: str = "covariant", *,
                   window=(WINDOW_WIDTH, WINDOW_HEIGHT)) -> sp.csr_matrix:
    """``G`` from a frame patch of intensive 9-bin cells (n_y, n_x, 9) to the canonical
    window's (16, 8, 9): ``S (x) A``, area-weighted means
    (:func:`viewadapt.adapt.hog_remap_matrix`). With another detector ``window`` (e.g.
    Daimler's 48x96), ``H`` maps that window's pixels and ``G`` gives its 8-px cells."""
    return hog_remap_matrix(H, source_cell_size=HOG_CELL, target_grid=patch_cell_grid(g),
                            n_bins=N_HOG_BINS, rule=rule, preserve="mean",
                            window=tuple(window))


def opencv_frame_remap(H, g, rule: str = "covariant", *,
                       window=(WINDOW_WIDTH, WINDOW_HEIGHT)) -> sp.csr_matrix:
    """``G`` from a frame patch of OpenCV's block-normalised cells (n_y, n_x, 36) to the
    canonical window's (16, 8, 36) (:mod:`viewadapt.detect.opencv_cells`): the 9-bin
    :func:`cell_hog_remap` on each of a cell's four normalised copies alike (channel
    ``9 q + b``); with another detector ``window``, ``H`` maps that window's pixels."""
    G9 = cell_hog_remap(H, g, rule, window=window).tocoo()
    n_bins, n_ch = N_HOG_BINS, OPENCV_CHANNELS
    r_cell, r_bin = np.divmod(G9.row, n_bins)
    c_cell, c_bin = np.divmod(G9.col, n_bins)
    q = np.arange(n_ch // n_bins)[:, None]
    rows = (r_cell * n_ch + q * n_bins + r_bin).ravel()
    cols = (c_cell * n_ch + q * n_bins + c_bin).ravel()
    shape = (G9.shape[0] // n_bins * n_ch, G9.shape[1] // n_bins * n_ch)
    return sp.csr_matrix((np.tile(G9.data, len(q)), (rows, cols)), shape=shape)


def acf_frame_remap(H, g, rule: str = "covariant") -> sp.csr_matrix:
    """``G`` from a frame patch of ACF cells (n_y, n_x, 10) to the canonical window's ACF
    channels (10, 32, 16) for the window ``H`` (a homography or a point mapping;
    :func:`viewadapt.adapt.acf_remap_matrix`)."""
    return acf_remap_matrix(H, shrink=ACF_SHRINK, n_color=N_ACF_CHANNELS - N_ACF_ORIENTS,
                            n_orients=N_ACF_ORIENTS, rule=rule, target_grid=patch_cell_grid(g),
                            target_layout="channels_last")


def acf_gradient_rows() -> np.ndarray:
    """(5120,) bool: the rows of an ACF ``G`` that give the gradient magnitude and
    orientation channels (scaled by ``s ** lambda``, :data:`ACF_GRADIENT_LAMBDA`)."""
    n_out = ACF_WEIGHT_SHAPE[1] * ACF_WEIGHT_SHAPE[2]
    return np.arange(N_ACF_CHANNELS * n_out) >= (N_ACF_CHANNELS - N_ACF_ORIENTS - 1) * n_out
