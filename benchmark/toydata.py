"""A numpy-only *planar* toy dataset in the generator's format, for fast pipeline tests.

Each "person" is a flat 2-D figure (head, torso, arms, legs, random colours and proportions)
painted on the person plane; each "scene" a textured ground plane and back wall with
markings. Every image is ray-cast exactly through the crop camera of
:func:`viewadapt.geometry.crop_camera`, so the planar model holds *exactly* for the persons
(unlike Blender renders of 3-D bodies): adaptation should recover most of the oracle here.
This is a test fixture and a sanity check, not a benchmark dataset. The output follows the
dataset contract of ``generator`` (``dataset.json``, ``manifest.parquet``/``.csv``,
``person/``, ``background/``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.geometry import (
    PERSON_HEIGHT_M, WINDOW_HEIGHT, WINDOW_WIDTH, Camera, crop_camera, window_to_image_homography,
)

__all__ = ["make_toy_dataset", "scene_textures", "render_scene", "person_figure"]

WALL_Y = 6.0  # the back wall stands 6 m behind the person, facing the camera


def scene_textures(rng, size=512):
    """Ground and wall textures of a toy scene (procedural noise and stripes)."""
    import cv2

    base = rng.uniform(40, 200, 3)
    ground = np.empty((size, size, 3), np.float32)
    ground[:] = base
    period = int(rng.integers(24, 96))
    yy, xx = np.mgrid[0:size, 0:size]
    tiles = (((yy // period) + (xx // period)) % 2)[..., None]
    ground += tiles * rng.uniform(-50, 50, 3)
    ground += rng.normal(0, 8, (size, size, 1))
    for _ in range(int(rng.integers(10, 30))):          # markings, bags, kerbs: clutter
        c = (int(rng.integers(0, size)), int(rng.integers(0, size)))
        col = tuple(float(v) for v in rng.uniform(0, 255, 3))
        if rng.random() < 0.5:
            cv2.rectangle(ground, c, (c[0] + int(rng.integers(5, 60)), c[1] + int(rng.integers(3, 20))),
                          col, -1)
        else:
            cv2.circle(ground, c, int(rng.integers(3, 25)), col, -1)
    wall = np.empty((size, size, 3), np.float32)
    wall[:] = rng.uniform(40, 220, 3)
    for _ in range(int(rng.integers(8, 20))):           # doors, windows, posters, poles
        x0, y0 = int(rng.integers(0, size)), int(rng.integers(0, size))
        col = tuple(float(v) for v in rng.uniform(0, 255, 3))
        cv2.rectangle(wall, (x0, y0), (x0 + int(rng.integers(6, 80)), y0 + int(rng.integers(20, 200))),
                      col, -1)
    return np.clip(ground, 0, 255), np.clip(wall, 0, 255)


def render_scene(cam: Camera, size, ground, wall, texel=0.02):
    """Ray-cast the ground plane (Z = 0) and the wall (Y = WALL_Y) into an image."""
    import cv2

    w, h = size
    xs, ys = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays = np.stack([xs, ys, np.ones_like(xs)], -1) @ np.linalg.inv(cam.K).T @ cam.R  # world
    C = cam.center
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ground = np.where(rays[..., 2] < 0, -C[2] / rays[..., 2], np.inf)
        t_wall = np.where(rays[..., 1] > 0, (WALL_Y - C[1]) / rays[..., 1], np.inf)
    use_ground = t_ground < t_wall
    t = np.where(use_ground, t_ground, t_wall)
    t = np.where(np.isfinite(t), t, 1e3)
    P = C + rays * t[..., None]
    n = ground.shape[0]
    gu = (P[..., 0] / texel) % n
    gv = (P[..., 1] / texel) % n
    wu = (P[..., 0] / texel) % n
    wv = (-P[..., 2] / texel) % n
    g = cv2.remap(ground, gu.astype(np.float32), gv.astype(np.float32), cv2.INTER_LINEAR,
                  borderMode=cv2.BORDER_WRAP)
    wl = cv2.remap(wall, wu.astype(np.float32), wv.astype(np.float32), cv2.INTER_LINEAR,
                   borderMode=cv2.BORDER_WRAP)
    return np.where(use_ground[..., None], g, wl)


def person_figure(rng, scale=4):
    """RGBA figure in the canonical window at ``scale`` x resolution (96 px tall at 1x)."""
    import cv2

    W, H = WINDOW_WIDTH * scale, WINDOW_HEIGHT * scale
    img = np.zeros((H, W, 3), np.float32)
    mask = np.zeros((H, W), np.float32)
    s = scale
    cx = 31.5 * s
    top, feet = 16 * s, 112 * s
    body = feet - top
    skin = rng.uniform([120, 90, 70], [240, 200, 180])
    shirt, trousers = rng.uniform(0, 255, 3), rng.uniform(0, 255, 3)
    head_r = body * rng.uniform(0.06, 0.075)
    shoulder = body * rng.uniform(0.11, 0.15)
    hip = shoulder * rng.uniform(0.75, 0.95)
    neck = top + 2 * head_r
    waist = top + body * rng.uniform(0.5, 0.56)
    stride = body * rng.uniform(0.0, 0.12)

    def poly(pts, col):
        p = np.round(np.array(pts)).astype(np.int32)
        cv2.fillConvexPoly(img, p, tuple(float(c) for c in col), cv2.LINE_AA)
        cv2.fillConvexPoly(mask, p, 1.0, cv2.LINE_AA)

    cv2.ellipse(img, (int(cx), int(top + head_r)), (int(head_r * 0.85), int(head_r)), 0, 0, 360,
                tuple(float(c) for c in skin), -1, cv2.LINE_AA)
    cv2.ellipse(mask, (int(cx), int(top + head_r)), (int(head_r * 0.85), int(head_r)), 0, 0, 360,
                1.0, -1, cv2.LINE_AA)
    poly([(cx - shoulder, neck), (cx + shoulder, neck), (cx + hip, waist), (cx - hip, waist)], shirt)
    leg_w = hip * 0.45
    for side in (-1, 1):
        x_hip = cx + side * hip * 0.5
        x_foot = x_hip + side * stride * 0.5
        poly([(x_hip - leg_w, waist), (x_hip + leg_w, waist), (x_foot + leg_w * 0.7, feet),
              (x_foot - leg_w * 0.7, feet)], trousers)
        x_sh = cx + side * shoulder
        x_hand = x_sh + side * body * rng.uniform(0.0, 0.06)
        arm_w = shoulder * 0.22
        poly([(x_sh - arm_w, neck), (x_sh + arm_w, neck), (x_hand + arm_w, waist + body * 0.05),
              (x_hand - arm_w, waist + body * 0.05)], shirt * 0.8)
    return img, mask


def _composite(background, cam, figure, mask, scale):
    """Paint the person-plane figure into ``background`` through ``cam``."""
    import cv2

    H = window_to_image_homography(cam, (0.0, 0.0), PERSON_HEIGHT_M)
    S = np.array([[1 / scale, 0, 0.5 / scale - 0.5], [0, 1 / scale, 0.5 / scale - 0.5], [0, 0, 1]])
    Hs = H @ S  # hi-res figure pixels -> image pixels
    h, w = background.shape[:2]
    fig = cv2.warpPerspective(figure, Hs, (w, h), flags=cv2.INTER_AREA)
    m = cv2.warpPerspective(mask, Hs, (w, h), flags=cv2.INTER_AREA)[..., None]
    m = np.clip(m, 0, 1)
    return background * (1 - m) + fig * m, m[..., 0]


def make_toy_dataset(out, *, n_persons=9, n_scenes=3, n_instances=1,
                     elevations=(0.0, np.pi / 8, np.pi / 4), n_backgrounds=2,
                     background_size=(192, 192), distance=10.0, noise=20.0, contrast=0.35,
                     seed=0) -> Path:
    """Write a planar toy dataset to ``out`` and return its path."""
    import cv2

    out = Path(out)
    scenes = {f"scene{j:02d}": scene_textures(np.random.default_rng([seed, 1, j]))
              for j in range(n_scenes)}
    persons = {}
    for i in range(n_persons):
        fig, mask = person_figure(np.random.default_rng([seed, 2, i]))
        # low contrast: pull the figure's colours towards mid-grey
        persons[f"person{i:03d}"] = (128 + contrast * (fig - 128), mask)
    rows = []

    def save(rel, img, noise_seed, **kw):
        p = out / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        # sensor noise makes the toy task less trivially separable
        img = img + np.random.default_rng(noise_seed).normal(0, noise, img.shape)
        cv2.imwrite(str(p), np.clip(img, 0, 255).astype(np.uint8)[..., ::-1])
        rows.append(dict(path=rel, **kw))

    for sid, (ground, wall) in scenes.items():
        for inst in range(n_instances):
            for pid, (fig, mask) in persons.items():
                srng = np.random.default_rng([seed, 3, int(sid[5:]), int(pid[6:]), inst])
                azim = float(srng.uniform(-0.5, 0.5))
                shift = srng.uniform(-3, 3, 2)   # where in the scene the person stands
                g2, w2 = np.roll(ground, (int(shift[0] * 50), int(shift[1] * 50)), (0, 1)), wall
                for ei, e in enumerate(elevations):
                    cam = crop_camera(e, distance=distance, azimuth=azim)
                    bg = render_scene(cam, (WINDOW_WIDTH, WINDOW_HEIGHT), g2, w2)
                    img, m = _composite(bg, cam, fig, mask, 4)
                    ys, xs = np.nonzero(m > 0.5)
                    box = [int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1),
                           int(ys.max() - ys.min() + 1)] if len(xs) else ""
                    Hw = window_to_image_homography(cam, (0, 0))
                    save(f"person/{sid}/{pid}_i{inst}_e{ei}.png", img, [seed, 5, len(rows)],
                         kind="person",
                         person_id=pid, scene_id=sid, instance=inst, elevation=float(e),
                         elevation_index=ei, azimuth=azim, rotation=0.0,
                         K=json.dumps(cam.K.tolist()), R=json.dumps(cam.R.tolist()),
                         t=json.dumps(cam.t.tolist()), H_window_to_image=json.dumps(Hw.tolist()),
                         box_silhouette=json.dumps(box), width=WINDOW_WIDTH, height=WINDOW_HEIGHT,
                         seed=int(srng.integers(2**31)), renderer="toy-planar", samples=0)
        for k in range(n_backgrounds):
            srng = np.random.default_rng([seed, 4, int(sid[5:]), k])
            azim = float(srng.uniform(-0.5, 0.5))
            shift = srng.uniform(-3, 3, 2)
            g2 = np.roll(ground, (int(shift[0] * 50), int(shift[1] * 50)), (0, 1))
            for ei, e in enumerate(elevations):
                c0 = crop_camera(e, distance=distance, azimuth=azim)
                w, h = background_size
                K = c0.K.copy()
                K[0, 2], K[1, 2] = (w - 1) / 2, (h - 1) / 2
                cam = Camera(K, c0.R, c0.t, (w, h))
                img = render_scene(cam, (w, h), g2, wall)
                Hw = window_to_image_homography(cam, (0, 0))
                save(f"background/{sid}/bg_i{k}_e{ei}.png", img, [seed, 6, len(rows)],
                     kind="background", person_id="",
                     scene_id=sid, instance=k, elevation=float(e), elevation_index=ei,
                     azimuth=azim, rotation=0.0, K=json.dumps(K.tolist()),
                     R=json.dumps(cam.R.tolist()), t=json.dumps(cam.t.tolist()),
                     H_window_to_image=json.dumps(Hw.tolist()), box_silhouette="", width=w,
                     height=h, seed=int(srng.integers(2**31)), renderer="toy-planar", samples=0)
    df = pd.DataFrame(rows)
    df.to_parquet(out / "manifest.parquet", index=False)
    df.to_csv(out / "manifest.csv", index=False)
    (out / "dataset.json").write_text(json.dumps({
        "preset": "toy", "renderer": "toy-planar", "framing": "plane", "seed": seed,
        "elevations": [float(e) for e in elevations], "distance": distance,
        "n_persons": n_persons, "n_scenes": n_scenes, "n_instances": n_instances,
        "versions": {"viewadapt": __import__("viewadapt").__version__}}, indent=2))
    return out
