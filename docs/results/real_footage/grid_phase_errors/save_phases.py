"""One-off: adapted OpenCV's detections on all 150 PETS frames at given grid phases, saved
as one detections.json (method names tagged with the phase) for
benchmark.studies.footage_errors. argv: OUT_DIR a,b [a,b ...]"""
import json, sys
from pathlib import Path

import benchmark.footage.run as fr
from benchmark.frames.spec import FrameMethod

D = Path("../shared/data/pets09_s2l1_view001")
out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)
m = FrameMethod.parse("opencv_adapted")
dets = {}
for text in sys.argv[2:]:
    ph = tuple(float(v) for v in text.split(","))
    clip = fr.open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt",
                        D / "ignore.json")
    run = fr.run_footage(clip, [m], None, heights=(1.75,), grid_phase=ph)
    dets[f"opencv_adapted@{text}"] = {str(k): d.tolist() for k, d in zip(run.keys, run.detections[m])}
(out / "detections.json").write_text(json.dumps(dets))
