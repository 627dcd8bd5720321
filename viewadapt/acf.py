"""Aggregate Channel Features (Dollár et al. 2014), with the linear part exposed.

The ACF detector's channels follow ``chnsCompute`` / ``chnsPyramid`` of Piotr Dollár's
Matlab toolbox (version 3.x) with its defaults: 10 channels per ``shrink`` x ``shrink``
block,

* ``L, U, V`` -- the image in the toolbox's scaled CIE-LUV (:func:`rgb_to_luv`), smoothed
  with a triangle filter of radius ``smooth_color``;
* ``gradient_magnitude`` -- the gradient magnitude of the smoothed LUV image (channel of
  largest magnitude per pixel), normalised by its local average
  ``M / (convTri(M, norm_radius) + norm_const)``;
* ``orientation_0 .. orientation_5`` -- that normalised magnitude binned by unsigned
  gradient orientation, bin ``k`` centred on ``k * pi / n_orients``.

Two levels are provided, as in :mod:`viewadapt.hog`:

* **Pixel channels** (:func:`acf_pixel_channels`): the ten channels at full resolution,
  before aggregation. Everything non-linear (colour conversion, gradients, magnitude
  normalisation, orientation binning) happens here, per pixel.
* **Aggregation** (:func:`aggregate_channels`): a block mean over ``shrink`` x ``shrink``
  pixels followed by a triangle smoothing -- both linear in the pixel channels. An
  aggregated channel value is therefore a weighted sum of pixel-channel values over a
  rectangle (a Haar-like feature in the sense of Wang et al. 2017, Sec. 3.2), and the
  orientation channels are HOG-like; that is what lets a viewpoint remapping
  ``G = S (x) A`` act on ACF features.

Notes
-----
Conventions (they matter to anyone remapping these channels):

* Image axes: ``x`` along columns (to the right), ``y`` along rows (**downwards**). The
  orientation is ``theta = atan2(dy, dx) mod pi`` in these axes, as in the toolbox
  (Matlab's first axis is the row axis). A vertical step edge has ``theta = 0``; a
  horizontal one ``theta = pi / 2``; intensity growing towards the bottom-right has
  ``theta = pi / 4``.
* Orientation bin ``k`` is centred on ``k * pi / n_orients`` (the toolbox's
  ``o0 = (int)(o + .5)``), covering ``[(k - 1/2), (k + 1/2)) * pi / n_orients`` modulo
  ``pi``. :mod:`viewadapt.hog` follows OpenCV instead, with centres at
  ``(k + 1/2) * pi / n_bins``.

Departures from the toolbox:

* **Orientation binning.** The toolbox's default ``softBin = 0`` interpolates each pixel
  linearly between the two nearest orientation bins (``gradQuantize`` with
  ``interpolate = softBin >= 0``); hard nearest-bin assignment is its ``softBin = -2``.
  Here the default is hard assignment (``interpolate_orientation=False``), because the
  paper's angle remapping (Wang et al. 2017, Sec. 3.2, Fig. 3 right) treats each bin as
  an interval of angles; pass ``interpolate_orientation=True`` for the toolbox default.
* **L channel.** The toolbox reads ``L`` from a 1025-entry lookup table indexed by
  ``floor(1024 * Y)``; we evaluate the CIE formula exactly. The difference is below
  ``3.3e-3`` for the darkest pixels and below ``1.5e-4`` for bright ones (in the scaled units).
* **Precision.** float64 throughout (the toolbox uses single precision, SSE reciprocal
  approximations and a 20000-entry ``acos`` table for the orientation).
* **Aggregation.** The toolbox shrinks the colour and magnitude channels with
  ``imResampleMex`` and sums the histograms with weight ``1 / shrink**2``; for an integer
  shrink both are the block mean used here.

References
----------
.. [1] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
   Detection", IEEE TPAMI 36(8), 2014.
.. [2] P. Dollár, "Piotr's Computer Vision Matlab Toolbox", version 3.x:
   ``chnsCompute.m``, ``rgbConvertMex.cpp``, ``gradientMex.cpp``, ``convTri.m``.
.. [3] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid
   Object Detection", arXiv preprint, 2017.
"""

from __future__ import annotations

import numbers

import numpy as np
from scipy import ndimage

from ._validation import check_image, check_int

__all__ = [
    "ACF_CHANNEL_NAMES",
    "acf_channel_names",
    "orientation_channel_slice",
    "orientation_bin_centers",
    "rgb_to_luv",
    "convolve_triangle",
    "triangle_kernel",
    "LUV_CONSTANTS",
    "acf_pixel_channels",
    "aggregate_channels",
    "acf_channels",
]

#: Number of colour channels (L, U, V) before the gradient channels.
_N_COLOR = 3

# --- rgbConvertMex.cpp, rgb2luv_setup: sRGB (no gamma) -> XYZ matrix, D65 white point
_RGB_TO_XYZ = np.array([[0.430574, 0.341550, 0.178325],
                        [0.222015, 0.706655, 0.071330],
                        [0.020183, 0.129553, 0.939180]])
_UN, _VN = 0.197833, 0.468331          # u', v' of the white point
_LUV_SCALE = 1.0 / 270.0               # maxi: L, u, v are divided by 270 ...
_U_OFFSET = 88.0 * _LUV_SCALE          # ... and u, v shifted by 88 / 270 and 134 / 270
_V_OFFSET = 134.0 * _LUV_SCALE         # (minu = -88 * maxi, minv = -134 * maxi)
_Y0 = (6.0 / 29.0) ** 3                # CIE L* knee
_KAPPA = (29.0 / 3.0) ** 3             # slope of L* below the knee
#: The toolbox's RGB -> LUV conversion constants, in the argument order of the compiled
#: kernel (``viewadapt._acf_kernels.rgb_to_luv_rows``): RGB -> XYZ matrix, L* knee, slope below
#: it, output scale, white point u', v', u and v offsets.
LUV_CONSTANTS = (_RGB_TO_XYZ, _Y0, _KAPPA, _LUV_SCALE, _UN, _VN, _U_OFFSET, _V_OFFSET)


def acf_channel_names(n_orients: int = 6) -> tuple[str, ...]:
    """Names of the ACF channels in output order.

    Parameters
    ----------
    n_orients : int

    Returns
    -------
    names : tuple of str, length ``4 + n_orients``
        ``("L", "U", "V", "gradient_magnitude", "orientation_0", ...)``; channel
        ``orientation_k`` is centred on ``k * pi / n_orients``.
    """
    n_orients = check_int(n_orients, "n_orients", minimum=1)
    return ("L", "U", "V", "gradient_magnitude") + tuple(
        f"orientation_{k}" for k in range(n_orients))


#: Channel names for the default ``n_orients=6`` (10 channels).
ACF_CHANNEL_NAMES = acf_channel_names(6)


def orientation_channel_slice(n_orients: int = 6) -> slice:
    """Slice selecting the orientation channels along the channel axis.

    Parameters
    ----------
    n_orients : int

    Returns
    -------
    slice
        ``slice(4, 4 + n_orients)``, e.g. ``acf_channels(img)[orientation_channel_slice()]``
        is the ``(n_orients, M // shrink, N // shrink)`` oriented-gradient stack.
    """
    n_orients = check_int(n_orients, "n_orients", minimum=1)
    return slice(_N_COLOR + 1, _N_COLOR + 1 + n_orients)


def orientation_bin_centers(n_orients: int = 6) -> np.ndarray:
    """Orientation (radians) on which each orientation channel is centred.

    Parameters
    ----------
    n_orients : int

    Returns
    -------
    centers : (n_orients,) float64 ndarray
        ``k * pi / n_orients``; with hard binning channel ``k`` collects the angles in
        ``[centers[k] - pi / (2 n_orients), centers[k] + pi / (2 n_orients))`` modulo pi,
        angles measured with the y axis pointing down (see the module Notes).
    """
    n_orients = check_int(n_orients, "n_orients", minimum=1)
    return np.arange(n_orients) * (np.pi / n_orients)


def rgb_to_luv(image) -> np.ndarray:
    """Convert an RGB image to the toolbox's scaled CIE-LUV (``rgbConvert(I, 'luv')``).

    With ``r, g, b`` in [0, 1] (no gamma linearisation, as in the toolbox),

    .. math::
        [X, Y, Z]^T = M_{D65} [r, g, b]^T, \\qquad
        L^* = \\begin{cases} 116\\, Y^{1/3} - 16 & Y > (6/29)^3 \\\\
                             (29/3)^3\\, Y & \\text{otherwise} \\end{cases}

    .. math::
        L = L^*/270, \\quad
        U = 13 L (u' - u'_n) + 88/270, \\quad
        V = 13 L (v' - v'_n) + 134/270,

    with :math:`u' = 4X / (X + 15Y + 3Z)`, :math:`v' = 9Y / (X + 15Y + 3Z)` and the
    toolbox's constants :math:`u'_n = 0.197833`, :math:`v'_n = 0.468331` and matrix
    ``M_D65`` (``rgbConvertMex.cpp``, ``rgb2luv_setup``). ``L`` lies in
    ``[0, 100/270]``; ``U`` and ``V`` in about ``[0, 1]``; a grey pixel has
    ``U = 88/270``, ``V = 134/270`` up to the rounding of the constants (~1e-7).

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
        uint8 (0..255) or float (0..1) RGB. A grey (M, N) image is replicated to 3
        channels.

    Returns
    -------
    luv : (M, N, 3) float64 ndarray
        Channels ``L, U, V`` in the toolbox's scaling.

    Notes
    -----
    ``L`` is computed exactly rather than from the toolbox's 1025-entry table (see the
    module Notes; differences below 3.3e-3).
    """
    return _luv_from_rgb255(check_image(image))


def _luv_from_rgb255(img):
    """rgb2luv on a checked (M, N[, 3]) float64 image in 0..255 (toolbox nrm = 1/255)."""
    rgb = img / 255.0
    if rgb.ndim == 2:
        rgb = np.repeat(rgb[:, :, None], 3, axis=2)
    xyz = rgb @ _RGB_TO_XYZ.T
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    # CIE L*, scaled by 1/270 (rgb2luv_setup: lTable[i] = l * maxi)
    ls = np.where(y > _Y0, 116.0 * np.cbrt(y) - 16.0, y * _KAPPA) * _LUV_SCALE
    inv = 1.0 / (x + 15.0 * y + 3.0 * z + 1e-35)
    out = np.empty(rgb.shape, dtype=np.float64)
    out[..., 0] = ls
    out[..., 1] = ls * (13.0 * 4.0 * x * inv - 13.0 * _UN) + _U_OFFSET
    out[..., 2] = ls * (13.0 * 9.0 * y * inv - 13.0 * _VN) + _V_OFFSET
    return out


def convolve_triangle(channels, radius: float) -> np.ndarray:
    """Smooth the last two axes with the toolbox's triangle filter (``convTri``).

    For an integer ``radius = r >= 1`` the separable 1-D kernel is

    .. math:: f = [1, 2, \\ldots, r, r + 1, r, \\ldots, 1] / (r + 1)^2 ;

    for ``0 < r <= 1`` it is ``[1, p, 1] / (p + 2)`` with :math:`p = 12/(r(r+2)) - 2`
    (``r = 1`` gives ``[1, 2, 1] / 4`` either way); ``r = 0`` returns the input. Borders
    are padded symmetrically (Matlab's ``padarray(..., 'symmetric')``: the edge sample is
    repeated, ``d c b a | a b c d | d c b a``).

    Parameters
    ----------
    channels : (..., M, N) array_like
    radius : float
        0, any value in (0, 1], or an integer.

    Returns
    -------
    smoothed : (..., M, N) float64 ndarray
    """
    x = np.asarray(channels, dtype=np.float64)
    if x.ndim < 2:
        raise ValueError(f"channels must have at least 2 dimensions, got shape {x.shape}")
    kernel = triangle_kernel(radius)
    if kernel is None:
        return x.copy()
    # scipy's "reflect" is the half-sample symmetric extension (Matlab's 'symmetric')
    out = ndimage.correlate1d(x, kernel, axis=-2, mode="reflect")
    return ndimage.correlate1d(out, kernel, axis=-1, mode="reflect")


def triangle_kernel(radius):
    """The 1-D kernel of Dollár's ``convTri(., radius)``: ``[1, p, 1] / (p + 2)`` for
    ``radius <= 1``, a triangle of half-width ``radius + 1`` otherwise; None for 0."""
    if isinstance(radius, bool) or not isinstance(radius, numbers.Real) \
            or not np.isfinite(radius) or radius < 0:
        raise ValueError(f"triangle filter radius must be a finite number >= 0, got {radius!r}")
    r = float(radius)
    if r == 0:
        return None
    if r <= 1:
        # convTri.m: convConst('convTri1', I, 12/r/(r+2)-2)
        p = 12.0 / r / (r + 2.0) - 2.0
        return np.array([1.0, p, 1.0]) / (p + 2.0)
    if r != int(r):
        raise ValueError(
            f"triangle filter radius must be in [0, 1] or an integer, got {radius!r}")
    r = int(r)
    ramp = np.arange(1, r + 1, dtype=np.float64)
    return np.concatenate([ramp, [r + 1.0], ramp[::-1]]) / float((r + 1) ** 2)


def acf_pixel_channels(image, *, shrink: int = 4, n_orients: int = 6,
                       smooth_color: float = 1, norm_radius: float = 5,
                       norm_const: float = 0.005,
                       interpolate_orientation: bool = False) -> np.ndarray:
    """Full-resolution ACF channels, before aggregation (the non-linear part).

    With :math:`I` the LUV image smoothed by ``convTri(., smooth_color)``, per pixel

    .. math::
        c^* = \\arg\\max_c |\\nabla I_c|, \\qquad
        M = |\\nabla I_{c^*}|, \\qquad
        \\theta = \\operatorname{atan2}(\\partial_y I_{c^*}, \\partial_x I_{c^*}) \\bmod \\pi,

    .. math::
        \\tilde M = \\frac{M}{\\mathrm{convTri}(M, r_{norm}) + \\epsilon}, \\qquad
        O_k = \\tilde M \\, [\\mathrm{round}(\\theta\\, n/\\pi) \\bmod n = k]

    (Dollár et al. 2014; toolbox ``gradientMag`` / ``gradientHist``).
    Derivatives are central differences ``(I[i+1] - I[i-1]) / 2`` and one-sided
    differences on the first and last row / column (toolbox ``grad1``).

    Parameters
    ----------
    image : (M0, N0[, 3]) ndarray
        uint8 (0..255) or float (0..1) RGB, or grey. Cropped to
        ``M = M0 - M0 % shrink`` rows and ``N = N0 - N0 % shrink`` columns first
        (top-left kept), as ``chnsCompute`` does.
    shrink : int
        Aggregation block size; used here only for the crop.
    n_orients : int
        Number of orientation bins over [0, pi).
    smooth_color : float
        Triangle radius applied to L, U, V before everything else (``pColor.smooth``).
    norm_radius : float
        Triangle radius of the local magnitude average (``pGradMag.normRad``); 0 disables
        the normalisation, as in the toolbox.
    norm_const : float
        :math:`\\epsilon` above (``pGradMag.normConst``), > 0.
    interpolate_orientation : bool
        False (default): each pixel's magnitude goes to its nearest orientation bin.
        True: it is split linearly between the two nearest bin centres (the toolbox's
        ``softBin = 0``).

    Returns
    -------
    pixel_channels : (4 + n_orients, M, N) float64 ndarray
        ``[L, U, V, M~, O_0, ..., O_{n-1}]`` (see :func:`acf_channel_names`). The
        orientation channels sum to the magnitude channel.
    """
    shrink = check_int(shrink, "shrink", minimum=1)
    n_orients = check_int(n_orients, "n_orients", minimum=1)
    triangle_kernel(smooth_color)
    triangle_kernel(norm_radius)
    if isinstance(norm_const, bool) or not isinstance(norm_const, numbers.Real) \
            or not np.isfinite(norm_const) or norm_const <= 0:
        raise ValueError(f"norm_const must be a finite number > 0, got {norm_const!r}")

    img = check_image(image)
    M0, N0 = img.shape[:2]
    if M0 < shrink or N0 < shrink:
        raise ValueError(
            f"image ({M0} x {N0} pixels) is smaller than shrink={shrink} in one dimension")
    M, N = M0 - M0 % shrink, N0 - N0 % shrink
    img = img[:M, :N]

    # chnsCompute: I = convTri(rgbConvert(I, 'luv'), pColor.smooth)
    luv = _luv_from_rgb255(img).transpose(2, 0, 1)
    luv = convolve_triangle(luv, smooth_color)

    # gradientMag(I, colorChn=0): per pixel, the colour channel of largest magnitude
    gx = _central_difference(luv, axis=2)
    gy = _central_difference(luv, axis=1)
    mag2 = gx * gx + gy * gy
    best = np.argmax(mag2, axis=0)[None]  # ties -> first channel, as the toolbox's CMPGT
    gx = np.take_along_axis(gx, best, axis=0)[0]
    gy = np.take_along_axis(gy, best, axis=0)[0]
    mag = np.sqrt(np.take_along_axis(mag2, best, axis=0)[0])
    theta = np.mod(np.arctan2(gy, gx), np.pi)

    # gradMagNorm: M / (convTri(M, normRad) + normConst); normRad = 0 -> no normalisation
    if triangle_kernel(norm_radius) is not None:
        mag = mag / (convolve_triangle(mag, norm_radius) + norm_const)

    out = np.zeros((_N_COLOR + 1 + n_orients, M, N))
    out[:_N_COLOR] = luv
    out[_N_COLOR] = mag
    _bin_orientations(out[_N_COLOR + 1:], mag, theta, n_orients, interpolate_orientation)
    return out


def _central_difference(x, axis):
    """Toolbox ``grad1``: (x[i+1] - x[i-1]) / 2 inside, one-sided at the two ends."""
    x = np.moveaxis(x, axis, -1)
    g = np.zeros_like(x)
    if x.shape[-1] > 1:
        g[..., 1:-1] = (x[..., 2:] - x[..., :-2]) * 0.5
        g[..., 0] = x[..., 1] - x[..., 0]
        g[..., -1] = x[..., -1] - x[..., -2]
    return np.moveaxis(g, -1, axis)


def _bin_orientations(out, mag, theta, n_orients, interpolate):
    """Write ``mag`` into ``out[k]`` by orientation bin (gradientMex ``gradQuantize``)."""
    o = theta * (n_orients / np.pi)
    rows, cols = np.indices(mag.shape)
    if not interpolate:
        # o0 = (int)(o + .5), wrapping n_orients to 0
        k = np.floor(o + 0.5).astype(np.int64) % n_orients
        out[k, rows, cols] = mag
        return
    o0 = np.floor(o)
    frac = o - o0
    k0 = o0.astype(np.int64) % n_orients
    k1 = (k0 + 1) % n_orients
    out[k0, rows, cols] += mag * (1.0 - frac)
    # n_orients == 1 puts both halves into the same bin
    np.add.at(out, (k1, rows, cols), mag * frac)


def aggregate_channels(pixel_channels, shrink: int = 4, smooth_channels: float = 1) -> np.ndarray:
    """Aggregate pixel channels into ACF channels: block mean, then triangle smoothing.

    .. math::
        A_c[i, j] = \\frac{1}{s^2} \\sum_{u < s,\\, v < s} P_c[s i + u, s j + v],
        \\qquad C_c = \\mathrm{convTri}(A_c, r_{smooth})

    Both steps are linear in ``P``:
    ``aggregate_channels(a * P + b * Q) == a * aggregate_channels(P) + b * aggregate_channels(Q)``.

    Parameters
    ----------
    pixel_channels : (C, M, N) array_like
        E.g. from :func:`acf_pixel_channels`. Rows and columns beyond a multiple of
        ``shrink`` are dropped.
    shrink : int
        Block size ``s`` (``pChns.shrink``).
    smooth_channels : float
        Triangle radius applied to every aggregated channel (``chnsPyramid``'s
        ``pPyramid.smooth``); 0 disables it.

    Returns
    -------
    channels : (C, M // shrink, N // shrink) float64 ndarray

    Notes
    -----
    Block means and the triangle filter are sums of pixel values over rectangles with
    fixed weights (Haar-like features, Wang et al. 2017, Sec. 3.2), so a viewpoint
    remapping of the aggregated channels is a linear map of the pixel channels. The one
    non-linear step of ACF that is not a pure per-pixel function of the image, the
    magnitude normalisation ``M / (convTri(M, 5) + 0.005)``, is applied per pixel in
    :func:`acf_pixel_channels`, *before* aggregation; it does not prevent remapping the
    aggregated features. (Its 5-pixel neighbourhood is not itself warped, so remapping
    approximates the features of a warped image, as it does for the gradients.)
    """
    shrink = check_int(shrink, "shrink", minimum=1)
    triangle_kernel(smooth_channels)
    P = np.asarray(pixel_channels)
    if P.ndim != 3:
        raise ValueError(f"pixel_channels must have shape (C, M, N), got shape {P.shape}")
    if P.dtype == object or not np.issubdtype(P.dtype, np.number):
        raise TypeError(f"pixel_channels must be numeric, got dtype {P.dtype}")
    P = P.astype(np.float64, copy=False)
    C, M, N = P.shape
    if C == 0:
        raise ValueError("pixel_channels has no channels")
    if M < shrink or N < shrink:
        raise ValueError(
            f"pixel_channels ({M} x {N} pixels) is smaller than shrink={shrink} "
            "in one dimension")
    if not np.all(np.isfinite(P)):
        raise ValueError("pixel_channels contains NaN or infinite values")
    Mb, Nb = M // shrink, N // shrink
    blocks = P[:, :Mb * shrink, :Nb * shrink].reshape(C, Mb, shrink, Nb, shrink)
    agg = blocks.sum(axis=(2, 4)) * (1.0 / (shrink * shrink))
    return convolve_triangle(agg, smooth_channels)


def acf_channels(image, *, shrink: int = 4, n_orients: int = 6, smooth_color: float = 1,
                 norm_radius: float = 5, norm_const: float = 0.005,
                 smooth_channels: float = 1,
                 interpolate_orientation: bool = False) -> np.ndarray:
    """Aggregate Channel Features of an image (toolbox ``chnsCompute`` + smoothing).

    Equivalent to ``aggregate_channels(acf_pixel_channels(image, ...), shrink,
    smooth_channels)``.

    Parameters
    ----------
    image : (M0, N0[, 3]) ndarray
        uint8 (0..255) or float (0..1) RGB, or grey; cropped to a multiple of ``shrink``.
    shrink, n_orients, smooth_color, norm_radius, norm_const, interpolate_orientation
        See :func:`acf_pixel_channels`.
    smooth_channels : float
        See :func:`aggregate_channels`.

    Returns
    -------
    channels : (4 + n_orients, M0 // shrink, N0 // shrink) float64 ndarray
        ``[L, U, V, gradient_magnitude, orientation_0, ...]`` (:data:`ACF_CHANNEL_NAMES`
        for the default 6 orientations). A 128 x 64 window gives (10, 32, 16), the
        5120-dimensional ACF feature vector once flattened.

    Examples
    --------
    >>> import numpy as np
    >>> from viewadapt.acf import acf_channels
    >>> acf_channels(np.zeros((128, 64, 3), np.uint8)).shape
    (10, 32, 16)
    """
    pixel = acf_pixel_channels(image, shrink=shrink, n_orients=n_orients,
                               smooth_color=smooth_color, norm_radius=norm_radius,
                               norm_const=norm_const,
                               interpolate_orientation=interpolate_orientation)
    return aggregate_channels(pixel, shrink, smooth_channels)

