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


def bars_scene(shape, seed, *, bars: int = 6):
    """A (M, N, 3) uint8 scene of blurred noise with ``bars`` bright 3-px bars: gradients of
    every orientation and strength (the OpenCV-detector tests' frames)."""
    import cv2

    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.integers(0, 256, tuple(shape) + (3,), dtype=np.uint8), (5, 5),
                           1.2)
    for _ in range(bars):
        p = rng.integers(0, [shape[1], shape[0]], 2)
        q = rng.integers(0, [shape[1], shape[0]], 2)
        cv2.line(img, tuple(int(v) for v in p), tuple(int(v) for v in q),
                 tuple(int(v) for v in rng.integers(0, 256, 3)), 3)
    return img
