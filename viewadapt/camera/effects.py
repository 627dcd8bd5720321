"""What a real camera does to an image after the lens: blur, vignetting, white balance and
exposure, sensor noise, tone curve, low resolution and JPEG compression.

:class:`CameraEffects` holds the range each effect is drawn from;
:meth:`CameraEffects.draw` draws one set of parameters (a plain dict, so that what was
applied can be recorded), and :func:`apply_camera_effects` applies such a dict to an 8-bit
RGB image, in the order a camera pipeline does: optical blur and vignetting on the scene's
light, per-channel gains (white balance and exposure), sensor noise (shot noise that grows
with the signal plus a read-noise floor), the tone curve (gamma), resampling to a lower
resolution and back, and JPEG compression. Renders pass through it to look less clean;
detectors trained on renders pass their training windows through it so that they meet
real footage's artefacts at training time (domain randomisation: Tobin et al. 2017).

References
----------
.. [1] J. Tobin, R. Fong, A. Ray, J. Schneider, W. Zaremba, P. Abbeel, "Domain
   Randomization for Transferring Deep Neural Networks from Simulation to the Real World",
   IROS 2017.
.. [2] S. W. Hasinoff, "Photon, Poisson noise", Computer Vision: A Reference Guide, 2014
   (signal-dependent sensor noise).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["CameraEffects", "apply_camera_effects", "EFFECT_KEYS", "SURVEILLANCE_CAMERA"]

#: The parameters :meth:`CameraEffects.draw` returns, in the order they are applied.
EFFECT_KEYS = ("blur_sigma", "vignetting", "gains", "noise_sigma", "gamma", "downscale",
               "jpeg_quality")


def _range(name, value, lo, hi):
    a, b = (float(v) for v in value)
    if not (math.isfinite(a) and math.isfinite(b) and lo <= a <= b <= hi):
        raise ValueError(f"{name} must be a range (low, high) with {lo} <= low <= high <= "
                         f"{hi}, got {value!r}")
    return a, b


@dataclass(frozen=True)
class CameraEffects:
    """Ranges of camera effects; each draw takes every parameter uniformly from its range.

    Attributes
    ----------
    blur_sigma : (low, high)
        Gaussian optical blur, px (0 = none).
    vignetting : (low, high)
        Relative light fall-off at the image corners (``1 - v r^2``, ``r`` 1 at a corner).
    white_balance : float
        Largest relative deviation of the red and blue gains from green (0 = neutral).
    exposure : (low, high)
        Overall gain.
    noise_sigma : (low, high)
        Sensor noise std at mid-grey, 8-bit levels: shot noise growing as the square root of
        the signal, with a floor of a quarter of it in the dark (read noise).
    gamma : (low, high)
        Tone curve: the [0, 1] signal is raised to ``1 / gamma`` (1 = none; above 1
        brightens the mid-tones).
    downscale : (low, high)
        Resolution factor: the image is resampled to this fraction of its size and back
        (1 = none).
    jpeg_quality : (low, high) or None
        JPEG quality (1-100) of a compression round trip; None = no compression.
    """

    blur_sigma: tuple = (0.0, 0.0)
    vignetting: tuple = (0.0, 0.0)
    white_balance: float = 0.0
    exposure: tuple = (1.0, 1.0)
    noise_sigma: tuple = (0.0, 0.0)
    gamma: tuple = (1.0, 1.0)
    downscale: tuple = (1.0, 1.0)
    jpeg_quality: tuple | None = None

    def __post_init__(self):
        set_ = lambda k, v: object.__setattr__(self, k, v)       # noqa: E731
        set_("blur_sigma", _range("blur_sigma", self.blur_sigma, 0.0, 10.0))
        set_("vignetting", _range("vignetting", self.vignetting, 0.0, 0.9))
        set_("exposure", _range("exposure", self.exposure, 0.1, 10.0))
        set_("noise_sigma", _range("noise_sigma", self.noise_sigma, 0.0, 64.0))
        set_("gamma", _range("gamma", self.gamma, 0.2, 5.0))
        set_("downscale", _range("downscale", self.downscale, 0.1, 1.0))
        wb = float(self.white_balance)
        if not (math.isfinite(wb) and 0.0 <= wb <= 0.9):
            raise ValueError(f"white_balance must lie in [0, 0.9], got {self.white_balance!r}")
        set_("white_balance", wb)
        if self.jpeg_quality is not None:
            q = _range("jpeg_quality", self.jpeg_quality, 1, 100)
            set_("jpeg_quality", (int(round(q[0])), int(round(q[1]))))

    def draw(self, rng) -> dict:
        """One set of parameters (:data:`EFFECT_KEYS`), drawn with ``rng`` (a numpy
        ``Generator``) in a fixed order, whether or not an effect is on, so that the draws
        of one effect do not depend on the others' ranges."""
        u = lambda r: float(rng.uniform(r[0], r[1]))              # noqa: E731
        out = {"blur_sigma": u(self.blur_sigma), "vignetting": u(self.vignetting)}
        wb = rng.uniform(-self.white_balance, self.white_balance, size=2)
        e = u(self.exposure)
        out["gains"] = [e * (1 + float(wb[0])), e, e * (1 + float(wb[1]))]
        out["noise_sigma"] = u(self.noise_sigma)
        out["gamma"] = u(self.gamma)
        out["downscale"] = u(self.downscale)
        q = int(rng.integers(self.jpeg_quality[0], self.jpeg_quality[1] + 1)) \
            if self.jpeg_quality is not None else None
        out["jpeg_quality"] = q
        out["noise_seed"] = int(rng.integers(2**31 - 1))
        return out

    def to_dict(self) -> dict:
        """The ranges, JSON-ready (lists for the tuples)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


#: Camera effects of surveillance footage, each range set from what such cameras do (not
#: fitted to any clip): slight defocus, corner fall-off, white balance and exposure off by
#: up to 15 % and 30 %, a few levels of sensor noise, a tone curve either side of linear,
#: effective resolution down to half (interlacing, cheap optics) and JPEG/MPEG-like
#: compression. The training recipes and the generator's ``surveillance`` setting use it.
SURVEILLANCE_CAMERA = CameraEffects(blur_sigma=(0.0, 1.2), vignetting=(0.0, 0.3),
                                    white_balance=0.15, exposure=(0.7, 1.3),
                                    noise_sigma=(1.0, 6.0), gamma=(0.8, 1.25),
                                    downscale=(0.5, 1.0), jpeg_quality=(30, 90))


def apply_camera_effects(image, params: dict) -> np.ndarray:
    """``image`` ((M, N, 3) uint8 RGB) through the effects ``params``
    (:meth:`CameraEffects.draw`); a new (M, N, 3) uint8 array. Parameters at their neutral
    values leave the image unchanged."""
    import cv2

    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"an (M, N, 3) uint8 RGB image is needed, got {img.dtype} "
                         f"{img.shape}")
    M, N = img.shape[:2]
    gains = np.asarray(params["gains"], np.float32)
    changes = (params["blur_sigma"] > 0 or params["vignetting"] > 0
               or not np.allclose(gains, 1) or params["noise_sigma"] > 0
               or params["gamma"] != 1)
    out = img
    if changes:
        x = img.astype(np.float32) / 255.0
        if params["blur_sigma"] > 0:
            x = cv2.GaussianBlur(x, (0, 0), float(params["blur_sigma"]),
                                 borderType=cv2.BORDER_REFLECT_101)
        if params["vignetting"] > 0:
            yy, xx = np.mgrid[0:M, 0:N].astype(np.float32)
            r2 = ((xx - (N - 1) / 2) ** 2 + (yy - (M - 1) / 2) ** 2) / \
                max(((N - 1) / 2) ** 2 + ((M - 1) / 2) ** 2, 1e-9)
            x = x * (1.0 - float(params["vignetting"]) * r2)[..., None]
        x = x * gains[None, None, :]
        if params["noise_sigma"] > 0:
            rng = np.random.default_rng(int(params.get("noise_seed", 0)))
            s = float(params["noise_sigma"]) / 255.0
            std = s * np.sqrt(np.maximum(np.clip(x, 0, 1) / 0.5, 1 / 16))
            x = x + std * rng.standard_normal(x.shape).astype(np.float32)
        x = np.clip(x, 0.0, 1.0)
        if params["gamma"] != 1:
            x = x ** (1.0 / float(params["gamma"]))
        out = np.clip(np.rint(x * 255.0), 0, 255).astype(np.uint8)
    if params["downscale"] < 1:
        m = max(1, int(round(M * params["downscale"])))
        n = max(1, int(round(N * params["downscale"])))
        small = cv2.resize(out, (n, m), interpolation=cv2.INTER_AREA)
        out = cv2.resize(small, (N, M), interpolation=cv2.INTER_LINEAR)
    if params.get("jpeg_quality") is not None:
        ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(out[..., ::-1]),
                               [cv2.IMWRITE_JPEG_QUALITY, int(params["jpeg_quality"])])
        if not ok:                                    # pragma: no cover - OpenCV failure
            raise RuntimeError("OpenCV could not encode the JPEG round trip")
        out = cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1]
    return img.copy() if out is img else np.ascontiguousarray(out)
