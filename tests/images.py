"""Random test images the feature tests share."""

import numpy as np

#: image shapes from tiny and degenerate to window-sized, grey and colour
SHAPES = [(37, 53), (37, 53, 3), (64, 48, 3), (128, 64, 3), (97, 131), (5, 7, 3), (1, 9, 3),
          (9, 1), (2, 2, 3)]


def random_image(shape, seed, dtype=np.uint8):
    """A random uint8 image of ``shape``; other dtypes as the same image scaled to 0..1."""
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, size=shape).astype(np.uint8)
    if dtype == np.uint8:
        return img
    return (img / 255.0).astype(dtype)
