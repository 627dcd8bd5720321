"""One-off: where adapted OpenCV's localisation errors (best IoU with a person 0.3-0.5) at
0.1 FPPI sit against the person they frame badly, per saved grid phase (save_phases.py's
detections.json): offsets of the box's foot point in units of the person's height and
width, and its height ratio. argv: detections.json"""
import json, sys
from pathlib import Path

import numpy as np

from benchmark.footage.errors import frames_at_fppi
from benchmark.footage.run import open_clip
from viewadapt.boxes import box_iou

D = Path("../shared/data/pets09_s2l1_view001")
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
frames = list(clip.stream)
truth = [clip.truth_of(f) for f in frames]
keys = [str(f.source) for f in frames]
dets = json.loads(Path(sys.argv[1]).read_text())
for name, per in dets.items():
    fr_, thr = frames_at_fppi([np.asarray(per[k], float).reshape(-1, 5) for k in keys], truth,
                              clip.camera.image_size, regions=clip.regions, fppi=0.1)
    off = []
    for key, (d, labels, g, found, nb) in zip(keys, fr_):
        fp = labels == 0
        if not fp.any() or not len(g):
            continue
        iou = box_iou(d[fp, :4], g[:, :4])
        best, j = iou.max(1), iou.argmax(1)
        for b, jj, row in zip(best, j, d[fp]):
            if 0.3 <= b < 0.5:
                x, y, w, h = g[jj, :4]
                dx = (row[0] + row[2] / 2 - (x + w / 2)) / w
                dy = (row[1] + row[3] - (y + h)) / h
                off.append((dx, dy, row[3] / h, found[jj], key, x + w / 2, y + h, h, nb[jj]))
    print(name, f"threshold {thr:.3f}, {len(off)} localisation errors")
    for dx, dy, r, f, key, fx, fy, h, n in off:
        print(f"   foot dx {dx:+.2f} w, dy {dy:+.2f} h, height x{r:.2f}, person found: {bool(f)}"
              f"; frame {key}, person's foot ({fx:.0f}, {fy:.0f}) px, {h:.0f} px tall, "
              f"neighbour: {bool(n)}")
