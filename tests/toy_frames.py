"""The toy frame set the full-frame tests share (:mod:`benchmark.toyframes`, no Blender)."""

from benchmark.toyframes import make_toy_frame_dataset

#: frame size of the shared toy frames (width, height)
TOY_FRAME_SIZE = (192, 144)


def small_toy_frames(root, *, frames_per_scene: int = 2):
    """Toy crops of 9 persons in 3 scenes and ``frames_per_scene`` calibrated 192x144
    frames of one camera (seed 2), written into ``root``; returns ``root``."""
    return make_toy_frame_dataset(root, n_persons=9, n_scenes=3, n_backgrounds=2,
                                  n_frame_scenes=1, frames_per_scene=frames_per_scene,
                                  frame_size=TOY_FRAME_SIZE, seed=2)
