"""One-off: adapted HOG's stage with raw cells finer than a source cell (rho), paired with
image warping's saved detections on PETS. argv: out.json rho [rho ...]"""
import json, sys, time
from pathlib import Path
import numpy as np
import viewadapt.detect.renorm as renorm
from benchmark.footage.run import open_clip, run_footage
from benchmark.frames.spec import FrameMethod
from viewadapt.io import SourceDetectors
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap
D = Path("../shared/data/pets09_s2l1_view001")
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
models = SourceDetectors.load(Path("viewadapt/data/source_detectors.npz"))
m = FrameMethod.parse("hog_adapted")
size = clip.camera.image_size
warp = json.loads(Path("/tmp/s9/foot_warp/detections.json").read_text())
out = {}
res = {}
import viewadapt.detect.kinds as K
for rho in sys.argv[2:]:
    r, thr = map(float, rho.split(','))
    renorm.RENORM_CELLS_PER_SOURCE_CELL = r
    K.HOG_DETECTOR.verify_threshold = thr
    t = time.time()
    clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
    run = run_footage(clip, [m], models, heights=(1.75,))
    keys = [str(k) for k in run.keys]
    ws = [np.asarray(warp["hog_warp"][k], float).reshape(-1, 5) for k in keys]
    ad0 = [np.asarray(warp["hog_adapted"][k], float).reshape(-1, 5) for k in keys]
    mt, _ = evaluation_matches(run.detections[m], run.truth, size, regions=clip.regions)
    mw, _ = evaluation_matches(ws, run.truth, size, regions=clip.regions)
    m0, _ = evaluation_matches(ad0, run.truth, size, regions=clip.regions)
    dw = paired_groups_bootstrap([mt], [mw], block=10)
    d0 = paired_groups_bootstrap([mt], [m0], block=10)
    res[rho] = dict(lamr=matches_lamr(mt), warp=matches_lamr(mw), shipped=matches_lamr(m0),
                    minus_warp=dw, minus_shipped=d0, fps=run.n_frames / run.seconds[m],
                    wall=time.time() - t)
    print(rho, res[rho], flush=True)
    Path(sys.argv[1]).write_text(json.dumps(res, indent=1))
    np.save(f"/tmp/s10/dets_rho{rho}.npy", np.array(run.detections[m], dtype=object), allow_pickle=True)
