"""Contact sheets of a dataset directory (numpy + OpenCV; no Blender).

``contact_sheet`` lays out paired person crops: one block per elevation, the same
(person, scene, instance) in the same grid cell of every block, so the viewpoint change is
read by comparing blocks. ``preview_dataset`` writes it plus a sheet of backgrounds (with
the centre window outlined) and frames (with their boxes).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np

from viewadapt.io.bounded import parse_json, read_limited_text
from viewadapt.io.files import atomic_write_bytes

from .manifest import MAX_COCO_BYTES, read_manifest

__all__ = ["contact_sheet", "background_sheet", "frame_sheet", "preview_dataset"]


def _label(img, text, org, scale=0.45, color=(255, 255, 255)):
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1, cv2.LINE_AA)


def _read(path):
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise FileNotFoundError(f"cannot read image {path}")
    return img


def contact_sheet(out, df, *, columns: int = 12, rows: int = 3, zoom: int = 2,
                  boxes: bool = False, rng: np.random.Generator | None = None) -> np.ndarray:
    """Paired person crops: one block of ``rows x columns`` per elevation (BGR image).

    Samples are spread over persons and scenes (deterministically unless ``rng`` given).
    """
    persons = df[df["kind"] == "person"]
    if persons.empty:
        raise ValueError("no person crops in the manifest")
    keys = persons[["scene_id", "person_id", "instance"]].drop_duplicates()
    n = min(len(keys), columns * rows)
    if rng is not None:
        idx = np.sort(rng.choice(len(keys), n, replace=False))
    else:
        idx = np.round(np.linspace(0, len(keys) - 1, n)).astype(int)
    keys = keys.iloc[idx]
    elevations = sorted(persons["elevation_index"].unique())
    w, h = int(persons["width"].iloc[0]), int(persons["height"].iloc[0])
    cw, ch = w * zoom, h * zoom
    gap, head = 4, 22
    cols = min(columns, n)
    nrows = math.ceil(n / cols)
    block_h = head + nrows * (ch + gap)
    sheet = np.full((len(elevations) * block_h, cols * (cw + gap) + gap, 3), 32, np.uint8)
    by_key = persons.set_index(["scene_id", "person_id", "instance", "elevation_index"])
    for b, e in enumerate(elevations):
        el = float(persons.loc[persons["elevation_index"] == e, "elevation"].iloc[0])
        y0 = b * block_h
        _label(sheet, f"elevation {e}: {math.degrees(el):.1f} deg ({el / math.pi:.3f} pi)",
               (8, y0 + 16), 0.5)
        for k, key in enumerate(keys.itertuples(index=False)):
            r, c = divmod(k, cols)
            try:
                row = by_key.loc[(key.scene_id, key.person_id, key.instance, e)]
            except KeyError:
                continue
            img = _read(Path(out) / row["path"])
            if boxes and row["box_silhouette"]:
                bx, by, bw, bh = json.loads(row["box_silhouette"])
                p0 = (int(round((bx + 0.5) * 4)), int(round((by + 0.5) * 4)))
                p1 = (int(round((bx + bw + 0.5) * 4)), int(round((by + bh + 0.5) * 4)))
                img = cv2.resize(img, None, fx=4, fy=4, interpolation=cv2.INTER_NEAREST)
                cv2.rectangle(img, p0, p1, (0, 255, 0), 1)
            img = cv2.resize(img, (cw, ch), interpolation=cv2.INTER_NEAREST)
            yy = y0 + head + r * (ch + gap)
            xx = gap + c * (cw + gap)
            sheet[yy:yy + ch, xx:xx + cw] = img
            if b == 0:
                _label(sheet, f"{key.person_id} {key.scene_id[:6]}", (xx + 2, yy + ch - 4),
                       0.32)
    return sheet


def background_sheet(out, df, *, columns: int = 6, size: int = 192) -> np.ndarray:
    """Backgrounds (one row per elevation), the centre 64x128 window outlined."""
    bg = df[df["kind"] == "background"]
    if bg.empty:
        raise ValueError("no backgrounds in the manifest")
    keys = bg[["scene_id", "instance"]].drop_duplicates()
    keys = keys.iloc[np.round(np.linspace(0, len(keys) - 1, min(columns, len(keys))))
                     .astype(int)]
    elevations = sorted(bg["elevation_index"].unique())
    gap = 4
    sheet = np.full((len(elevations) * (size + gap) + gap, len(keys) * (size + gap) + gap, 3),
                    32, np.uint8)
    by_key = bg.set_index(["scene_id", "instance", "elevation_index"])
    for r, e in enumerate(elevations):
        for c, key in enumerate(keys.itertuples(index=False)):
            row = by_key.loc[(key.scene_id, key.instance, e)]
            img = _read(Path(out) / row["path"])
            H = np.array(json.loads(row["H_window_to_image"]))
            corners = np.array([[-0.5, -0.5, 1], [63.5, -0.5, 1], [63.5, 127.5, 1],
                                [-0.5, 127.5, 1]]) @ H.T
            corners = corners[:, :2] / corners[:, 2:]
            s = size / img.shape[1]
            img = cv2.resize(img, (size, int(round(img.shape[0] * s))),
                             interpolation=cv2.INTER_AREA)
            pts = np.round((corners + 0.5) * s - 0.5).astype(np.int32)
            cv2.polylines(img, [pts], True, (0, 255, 255), 1, cv2.LINE_AA)
            yy, xx = gap + r * (size + gap), gap + c * (size + gap)
            hh = min(img.shape[0], size)
            sheet[yy:yy + hh, xx:xx + size] = img[:hh]
            if r == 0:
                _label(sheet, key.scene_id, (xx + 3, yy + 14), 0.4)
            if c == 0:
                _label(sheet, f"e{e}", (xx + 3, yy + size - 6), 0.4)
    return sheet


def frame_sheet(out, *, columns: int = 3, max_frames: int = 6) -> np.ndarray | None:
    """Surveillance frames with full (green) and visible (yellow) boxes."""
    p = Path(out) / "frames_coco.json"
    if not p.is_file():
        return None
    coco = parse_json(read_limited_text(p, "frames_coco.json", MAX_COCO_BYTES), p)
    if not isinstance(coco, dict):
        raise ValueError(f"{p}: expected a JSON object, got a {type(coco).__name__}")
    imgs = coco["images"][:max_frames]
    if not imgs:
        return None
    tiles = []
    for im in imgs:
        img = _read(Path(out) / im["file_name"])
        for a in coco["annotations"]:
            if a["image_id"] != im["id"]:
                continue
            for key, col in (("bbox", (0, 255, 0)), ("bbox_visible", (0, 255, 255))):
                b = a.get(key)
                if b:
                    x, y, w, h = b
                    cv2.rectangle(img, (int(round(x + 0.5)), int(round(y + 0.5))),
                                  (int(round(x + w - 0.5)), int(round(y + h - 0.5))), col, 1)
            x, y = a["bbox"][:2]
            _label(img, f"{a['person_id']} occ {a['occlusion']:.2f}",
                   (int(max(0, x)), int(max(10, y - 2))), 0.3)
        tiles.append(img)
    h, w = tiles[0].shape[:2]
    cols = min(columns, len(tiles))
    nrows = math.ceil(len(tiles) / cols)
    sheet = np.full((nrows * (h + 4) + 4, cols * (w + 4) + 4, 3), 32, np.uint8)
    for k, t in enumerate(tiles):
        r, c = divmod(k, cols)
        sheet[4 + r * (h + 4):4 + r * (h + 4) + h, 4 + c * (w + 4):4 + c * (w + 4) + w] = t
    return sheet


def preview_dataset(directory, out_png, *, columns: int = 12, rows: int = 3,
                    boxes: bool = False) -> list[Path]:
    """Write contact sheets of a dataset: ``out_png`` (paired crops, a block per elevation),
    and beside it ``<stem>_backgrounds.png`` and ``<stem>_frames.png`` when present.

    Returns the written paths.
    """
    directory = Path(directory)
    out_png = Path(out_png)
    if out_png.suffix.lower() != ".png":
        raise ValueError(f"--out must name a .png file, got {out_png}")
    df = read_manifest(directory)
    written = []

    def save(path, img):
        ok, buf = cv2.imencode(".png", img)
        if not ok:  # pragma: no cover
            raise RuntimeError(f"could not encode {path}")
        atomic_write_bytes(path, buf.tobytes())
        written.append(path)

    save(out_png, contact_sheet(directory, df, columns=columns, rows=rows, boxes=boxes))
    if (df["kind"] == "background").any():
        save(out_png.with_name(out_png.stem + "_backgrounds.png"),
             background_sheet(directory, df))
    fs = frame_sheet(directory)
    if fs is not None:
        save(out_png.with_name(out_png.stem + "_frames.png"), fs)
    return written
