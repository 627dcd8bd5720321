"""Calibrated toy surveillance frames in the generator's frame contract (numpy only).

Planar person figures of :mod:`benchmark.toydata` stand at random ground positions in a
ray-cast toy scene (textured ground and back wall) seen by a fixed elevated camera, like
the Blender generator's surveillance frames. Written next to a toy crop dataset so that
``viewadapt bench frames`` trains on the crops and detects on the frames.

Frame contract (shared with the Blender generator)
--------------------------------------------------
* ``DIR/frames/<scene>/frame_<k>.png``
* ``DIR/frames_coco.json`` -- COCO: ``images`` entries carry ``id``, ``file_name``,
  ``width``, ``height``, ``scene_id``, and the calibration ``K`` (3x3), ``R`` (3x3),
  ``t`` (3); ``annotations`` carry ``image_id``, ``category_id`` (1 = person), ``bbox``
  (full extent ``[x, y, w, h]``), ``bbox_visible``, ``occlusion`` (fraction of the full
  extent hidden), ``person_id``, ``ground_xy`` (world metres) and ``person_height``.
* manifest rows with ``kind="frame"`` (``path``, ``scene_id``, ``K``, ``R``, ``t`` as JSON).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.geometry import camera_from_pose, window_to_image_homography

from .toydata import person_figure, render_scene, scene_textures, make_toy_dataset

__all__ = ["make_toy_frames", "make_toy_frame_dataset"]


def _composite_at(frame, cam, figure, mask, xy, height, scale=4):
    """Paint a person-plane figure standing at ``xy`` into ``frame``; return its mask."""
    import cv2

    H = window_to_image_homography(cam, xy, height)
    S = np.array([[1 / scale, 0, 0.5 / scale - 0.5], [0, 1 / scale, 0.5 / scale - 0.5],
                  [0, 0, 1]])
    Hs = H @ S
    h, w = frame.shape[:2]
    fig = cv2.warpPerspective(figure, Hs, (w, h), flags=cv2.INTER_AREA)
    m = np.clip(cv2.warpPerspective(mask, Hs, (w, h), flags=cv2.INTER_AREA), 0, 1)
    return frame * (1 - m[..., None]) + fig * m[..., None], m


def _box(mask):
    ys, xs = np.nonzero(mask > 0.5)
    if len(xs) == 0:
        return None
    return [float(xs.min()), float(ys.min()), float(xs.max() - xs.min() + 1),
            float(ys.max() - ys.min() + 1)]


def scene_camera(rng, frame_size=(384, 288)):
    """A CAVIAR-like fixed camera: 3-6 m high, 30-50 degrees down, 60-75 degree field."""
    w, h = frame_size
    hfov = np.radians(rng.uniform(60, 75))
    f = (w / 2) / np.tan(hfov / 2)
    return camera_from_pose(focal=f, principal_point=((w - 1) / 2, (h - 1) / 2),
                            height=float(rng.uniform(3.0, 6.0)),
                            tilt=float(np.radians(rng.uniform(30, 50))),
                            azimuth=np.pi / 2, position_xy=(0.0, -10.0),
                            image_size=(w, h))


def make_toy_frames(out, *, n_scenes: int = 2, frames_per_scene: int = 2,
                    persons_per_frame=(3, 6), frame_size=(384, 288), noise: float = 20.0,
                    contrast: float = 0.35, seed: int = 0) -> dict:
    """Render toy surveillance frames into ``out`` and return their COCO dictionary.

    Parameters
    ----------
    out : path
        Dataset directory (frames go to ``out/frames/<scene>/frame_<k>.png``).
    n_scenes, frames_per_scene : int
    persons_per_frame : (int, int)
        Inclusive range.
    frame_size : (width, height)
    noise, contrast : float
        As the toy crops (sensor noise std, figure contrast towards grey).
    seed : int

    Returns
    -------
    dict, the COCO structure also written to ``out/frames_coco.json``; the manifest rows
    are under the key ``"_manifest_rows"`` (not written into the JSON).
    """
    import cv2

    out = Path(out)
    images, anns, rows = [], [], []
    for si in range(n_scenes):
        sid = f"fscene{si:02d}"
        ground, wall = scene_textures(np.random.default_rng([seed, 11, si]))
        cam = scene_camera(np.random.default_rng([seed, 12, si]), frame_size)
        bg = render_scene(cam, frame_size, ground, wall)
        for k in range(frames_per_scene):
            rng = np.random.default_rng([seed, 13, si, k])
            n = int(rng.integers(persons_per_frame[0], persons_per_frame[1] + 1))
            placed = []
            for _ in range(200):
                if len(placed) == n:
                    break
                xy = np.array([rng.uniform(-5, 5), rng.uniform(-8, 5)])
                hgt = float(rng.uniform(1.6, 1.9))
                if any(np.hypot(*(xy - q[0])) < 0.9 for q in placed):
                    continue
                feet = cam.project(np.array([xy[0], xy[1], 0.0]))
                head = cam.project(np.array([xy[0], xy[1], hgt]))
                W, H = frame_size
                if not (8 <= feet[0] <= W - 9 and 4 <= head[1] and feet[1] <= H - 6
                        and feet[1] - head[1] >= 20):
                    continue
                placed.append((xy, hgt, int(rng.integers(10_000))))
            # far to near (painter's order): later persons occlude earlier ones
            dist = [np.hypot(*(q[0] - cam.center[:2])) for q in placed]
            placed = [placed[i] for i in np.argsort(dist)[::-1]]
            img = bg.copy()
            masks = []
            for xy, hgt, pid in placed:
                fig, mask = person_figure(np.random.default_rng([seed, 14, pid]))
                fig = 128 + contrast * (fig - 128)
                img, m = _composite_at(img, cam, fig, mask, xy, hgt)
                masks.append(m)
            img = img + np.random.default_rng([seed, 15, si, k]).normal(0, noise, img.shape)
            rel = f"frames/{sid}/frame_{k}.png"
            p = out / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(p), np.clip(img, 0, 255).astype(np.uint8)[..., ::-1])
            image_id = len(images) + 1
            images.append({"id": image_id, "file_name": rel, "width": frame_size[0],
                           "height": frame_size[1], "scene_id": sid, "frame_index": k,
                           "K": cam.K.tolist(), "R": cam.R.tolist(), "t": cam.t.tolist()})
            for j, ((xy, hgt, pid), m) in enumerate(zip(placed, masks)):
                full = _box(m)
                if full is None:
                    continue
                vis = m.copy()
                for m2 in masks[j + 1:]:
                    vis = vis * (1 - m2)
                visible = _box(vis)
                occ = 1.0 - float(vis.sum()) / max(float(m.sum()), 1e-9)
                anns.append({"id": len(anns) + 1, "image_id": image_id, "category_id": 1,
                             "bbox": full, "bbox_visible": visible or [0, 0, 0, 0],
                             "area": full[2] * full[3], "iscrowd": 0,
                             "occlusion": round(occ, 4), "person_id": f"toyperson{pid:05d}",
                             "ground_xy": [float(xy[0]), float(xy[1])],
                             "person_height": hgt})
            rows.append(dict(path=rel, kind="frame", person_id="", scene_id=sid,
                             instance=k, elevation=float(-np.arcsin(cam.R[2, 2])),
                             elevation_index=-1, azimuth=np.pi / 2, rotation=0.0,
                             K=json.dumps(cam.K.tolist()), R=json.dumps(cam.R.tolist()),
                             t=json.dumps(cam.t.tolist()), H_window_to_image="",
                             box_silhouette="", width=frame_size[0], height=frame_size[1],
                             seed=seed, renderer="toy-planar", samples=0))
    coco = {"images": images, "annotations": anns,
            "categories": [{"id": 1, "name": "person"}],
            "info": {"renderer": "toy-planar", "seed": seed}}
    (out / "frames_coco.json").write_text(json.dumps(coco))
    coco["_manifest_rows"] = rows
    return coco


def make_toy_frame_dataset(out, *, n_persons: int = 9, n_scenes: int = 3,
                           n_backgrounds: int = 2, n_frame_scenes: int = 2,
                           frames_per_scene: int = 2, persons_per_frame=(3, 6),
                           frame_size=(384, 288), seed: int = 0) -> Path:
    """A toy crop dataset (:func:`benchmark.toydata.make_toy_dataset`) plus surveillance
    frames (:func:`make_toy_frames`) in one directory, manifest rows included."""
    out = Path(out)
    make_toy_dataset(out, n_persons=n_persons, n_scenes=n_scenes,
                     n_backgrounds=n_backgrounds, seed=seed)
    coco = make_toy_frames(out, n_scenes=n_frame_scenes, frames_per_scene=frames_per_scene,
                           persons_per_frame=persons_per_frame, frame_size=frame_size,
                           seed=seed)
    man = pd.read_parquet(out / "manifest.parquet")
    man = pd.concat([man, pd.DataFrame(coco["_manifest_rows"])], ignore_index=True)
    man.to_parquet(out / "manifest.parquet", index=False)
    man.to_csv(out / "manifest.csv", index=False)
    return out
