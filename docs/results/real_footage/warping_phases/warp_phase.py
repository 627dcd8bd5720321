"""One-off: adapted HOG and image warping of the same model (shipped) on all 150 PETS frames
at one grid phase of the candidate windows (the bench footage runner, FrameDetector's
grid_phase); detections saved for pairing. argv: OUT_DIR a,b"""
import json, sys
from pathlib import Path

import benchmark.footage.run as fr
from benchmark.frames.spec import FrameMethod
from viewadapt.io import SourceDetectors, shipped_model_path

D = Path("../shared/data/pets09_s2l1_view001")
out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)
ph = tuple(float(v) for v in sys.argv[2].split(","))
methods = [FrameMethod.parse("hog_adapted"), FrameMethod.parse("hog_warp")]
clip = fr.open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt",
                    D / "ignore.json")
run = fr.run_footage(clip, methods, SourceDetectors.load(shipped_model_path()), heights=(1.75,),
                     grid_phase=ph)
(out / "detections.json").write_text(json.dumps(
    {m.name: {str(k): d.tolist() for k, d in zip(run.keys, run.detections[m])} for m in methods}))
(out / "seconds.json").write_text(json.dumps({m.name: run.seconds[m] for m in methods}))
