"""Dense feature maps: compute channels once per frame, read any window's cells from them.

A :class:`DenseFeatureMap` holds per-pixel (or per-``shrink``-block) channels and their
integral image, so the sum of any channel over any axis-aligned rectangle on its grid costs
four look-ups. Cell features of a window at any position are such sums; so are the
remapped (adapted) features, which are linear in them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .hog import locally_normalize_channels, orientation_channels

__all__ = ["DenseFeatureMap", "hog_feature_map", "acf_feature_map"]


@dataclass(frozen=True)
class DenseFeatureMap:
    """Channels over a whole frame with an integral image.

    Parameters
    ----------
    channels : (H, W, C) ndarray
        Channel values, one row/column per ``shrink`` pixels of the frame.
    shrink : int
        Frame pixels per channel pixel.
    """

    channels: np.ndarray
    shrink: int = 1

    def __post_init__(self):
        ch = np.asarray(self.channels, dtype=np.float64)
        if ch.ndim != 3 or ch.shape[0] == 0 or ch.shape[1] == 0:
            raise ValueError(f"channels must have shape (H, W, C), got {ch.shape}")
        object.__setattr__(self, "channels", ch)
        ii = np.zeros((ch.shape[0] + 1, ch.shape[1] + 1, ch.shape[2]))
        np.cumsum(np.cumsum(ch, axis=0), axis=1, out=ii[1:, 1:])
        object.__setattr__(self, "_integral", ii)

    @property
    def frame_shape(self) -> tuple[int, int]:
        """(height, width) of the frame area covered, in frame pixels."""
        return self.channels.shape[0] * self.shrink, self.channels.shape[1] * self.shrink

    def cells(self, x0: int, y0: int, cell_size: int, n_x: int, n_y: int) -> np.ndarray:
        """Channel sums over an ``n_y`` x ``n_x`` grid of cells whose top-left pixel is
        ``(x0, y0)`` (frame pixels).

        ``x0``, ``y0`` and ``cell_size`` must be multiples of ``shrink``; the grid must lie
        inside the map.

        Returns
        -------
        (n_y, n_x, C) ndarray
        """
        s = self.shrink
        if x0 % s or y0 % s or cell_size % s or cell_size <= 0:
            raise ValueError(f"x0={x0}, y0={y0} and cell_size={cell_size} must be "
                             f"multiples of shrink={s} (cell_size > 0)")
        cx, cy, c = x0 // s, y0 // s, cell_size // s
        H, W = self.channels.shape[:2]
        if cx < 0 or cy < 0 or cx + n_x * c > W or cy + n_y * c > H:
            raise ValueError(
                f"window at ({x0}, {y0}) of {n_x * cell_size}x{n_y * cell_size} px lies "
                f"outside the {self.frame_shape[1]}x{self.frame_shape[0]} feature map"
            )
        ys = cy + np.arange(n_y + 1) * c
        xs = cx + np.arange(n_x + 1) * c
        ii = self._integral[np.ix_(ys, xs)]
        return ii[1:, 1:] - ii[:-1, 1:] - ii[1:, :-1] + ii[:-1, :-1]

    def window(self, x0: int, y0: int, *, width: int = 64, height: int = 128,
               cell_size: int = 8) -> np.ndarray:
        """Flattened cell features of one window, layout ``(n_y, n_x, C)`` row-major."""
        if width % cell_size or height % cell_size:
            raise ValueError(f"window {width}x{height} is not a multiple of cell_size={cell_size}")
        return self.cells(x0, y0, cell_size, width // cell_size, height // cell_size).ravel()


def hog_feature_map(image, *, n_bins: int = 9, gamma: bool = False,
                    normalize: str | None = None, cell_size: int = 8) -> DenseFeatureMap:
    """Per-pixel oriented-gradient channels of a whole frame (see :mod:`viewadapt.hog`).

    Window cells read from the map equal :func:`viewadapt.hog.hog_cells` of the frame's
    cells; with ``normalize="local"`` the channels are locally normalised with a
    ``2 cell_size`` neighbourhood.
    """
    O = orientation_channels(image, n_bins=n_bins, gamma=gamma)
    if normalize == "local":
        O = locally_normalize_channels(O, cell_size=cell_size)
    elif normalize is not None:
        raise ValueError(f"normalize must be None or 'local', got {normalize!r}")
    return DenseFeatureMap(O, 1)


def acf_feature_map(image, *, shrink: int = 4, **kwargs) -> DenseFeatureMap:
    """ACF channels of a whole frame at ``shrink`` (cells of one channel pixel).

    ``kwargs`` go to :func:`viewadapt.acf.acf_channels`.
    """
    from .acf import acf_channels

    ch = acf_channels(image, shrink=shrink, **kwargs)          # (C, h, w)
    return DenseFeatureMap(np.moveaxis(ch, 0, -1), shrink)
