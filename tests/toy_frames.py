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


def mot_toy_clip(root, *, n_frames: int, flag_last: bool = False, dist=None):
    """The toy frames of :func:`small_toy_frames` as a MOTChallenge sequence: ``img1/000001.png``
    ..., ``gt.txt`` (each frame's last box flagged 0 with ``flag_last``), a calibration
    JSON (with ``dist`` if given) and a quickly trained model. Returns a namespace with
    ``root, frames, cam, img1, gt, calibration, model, cache``."""
    import json
    import shutil
    from pathlib import Path
    from types import SimpleNamespace

    from benchmark.data import load_dataset
    from benchmark.frames.methods import load_frames, train_source_detectors
    from benchmark.recipes import PAPER_RECIPE

    root = Path(root)
    data = small_toy_frames(root / "data", frames_per_scene=n_frames)
    frames = sorted(load_frames(data), key=lambda f: int(f.path.stem.split("_")[1]))
    # the paper's training: under the default recipe's wider margin (C = 0.001) a quick model
    # of these few windows stays nearly silent on the toy frames
    train_source_detectors(load_dataset(data), quick=True, frame_view="none",
                           recipe=PAPER_RECIPE).save(root / "model.npz")
    cam = frames[0].camera
    img1 = root / "mot" / "img1"
    img1.mkdir(parents=True)
    lines = []
    for k, f in enumerate(frames, 1):
        shutil.copy(f.path, img1 / f"{k:06d}.png")
        for j, (x, y, w, h) in enumerate(f.gt):
            flag = 0 if flag_last and j == len(f.gt) - 1 else 1
            lines.append(f"{k},{j + 1},{x},{y},{w},{h},{flag},-1,-1,-1")
    gt = root / "mot" / "gt.txt"
    gt.write_text("\n".join(lines) + "\n")
    calibration = root / "cam.json"
    doc = {"image_size": list(cam.image_size), "K": cam.K.tolist(), "R": cam.R.tolist(),
           "t": cam.t.tolist()}
    if dist is not None:
        doc["dist"] = list(dist)
    calibration.write_text(json.dumps(doc))
    return SimpleNamespace(root=root, frames=frames, cam=cam, img1=img1, gt=gt,
                           calibration=calibration, model=root / "model.npz",
                           cache=root / "cache")
