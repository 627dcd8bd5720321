"""One-off: on frames where adapted OpenCV's worst grid phase frames a person badly, every
candidate window whose person box overlaps that person's box (IoU >= 0.3): its adapted
score (with the stage) and image warping's score of the same window, at the worst phase
(1/4, 3/4) and the default grid, boxes standardised to the 0.41 aspect as the protocol
compares them. Shows whether the off-centre window wins in the detector
itself (warping agrees) or in the adapted approximation. Output: person_windows.txt"""
from pathlib import Path

import numpy as np

from benchmark.footage.run import open_clip
from benchmark.frames.methods import warp_scores
from viewadapt.boxes import box_iou
from viewadapt.detect import FrameDetector
from viewadapt.detect.evaluation import standardize_boxes
from viewadapt.detect.stream import pretrained_kinds

D = Path("../shared/data/pets09_s2l1_view001")
CASES = [("000103.jpg", (385, 276)), ("000105.jpg", (399, 279)), ("000037.jpg", (395, 255))]
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
frames = {str(f.source): f for f in clip.stream if str(f.source) in {c[0] for c in CASES}}
lines = []
for ph in ((0.25, 0.75), (0.0, 0.0)):
    det = FrameDetector(clip.camera, None, kinds=pretrained_kinds("opencv", ""),
                        lens=np.asarray(clip.dist).tolist(), grid_phase=ph)
    op = det.operator("opencv")
    boxes = standardize_boxes(det.windows.person_boxes())     # as the protocol compares them
    for key, foot in CASES:
        f = frames[key]
        t = clip.truth_of(f)
        g = standardize_boxes(np.asarray(t.boxes, float).reshape(-1, 4))
        j = np.argmin(np.hypot(g[:, 0] + g[:, 2] / 2 - foot[0], g[:, 1] + g[:, 3] - foot[1]))
        s = op.scores(op.frame_features(f.image))
        iou = box_iou(boxes, g[j:j + 1])[:, 0]
        idx = np.flatnonzero(iou >= 0.3)
        w = warp_scores(f.image, det.windows.homographies[idx], None, "opencv")
        order = np.argsort(-s[idx])[:6]
        lines.append(f"phase {ph}, frame {key}, person box {np.round(g[j]).tolist()}: "
                     f"{len(idx)} windows with IoU >= 0.3")
        for k in order:
            b = boxes[idx[k]]
            dx = (b[0] + b[2] / 2 - (g[j, 0] + g[j, 2] / 2)) / g[j, 2]
            lines.append(f"   IoU {iou[idx[k]]:.2f}  dx {dx:+.2f} w  adapted {s[idx[k]]:+.3f}"
                         f"  warping {w[k]:+.3f}")
        best_w = np.argmax(w)
        b = boxes[idx[best_w]]
        lines.append(f"   warping's best: IoU {iou[idx[best_w]]:.2f}, dx "
                     f"{(b[0] + b[2] / 2 - (g[j, 0] + g[j, 2] / 2)) / g[j, 2]:+.2f} w, "
                     f"warping {w[best_w]:+.3f}, adapted {s[idx[best_w]]:+.3f}")
out = Path(__file__).with_name("person_windows.txt")
out.write_text("\n".join(lines) + "\n")
print("\n".join(lines))
