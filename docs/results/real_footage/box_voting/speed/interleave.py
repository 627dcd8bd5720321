"""Voting's cost per frame in the bench footage harness, both settings interleaved frame by
frame in one process (machine drift cancels): opencv_adapted and hog_adapted, with
opencv_2x (voted) run on every frame as in bench footage."""
import time, glob, numpy as np, cv2
from viewadapt.io.calibration import read_calibration_file
from viewadapt.io.models import SourceDetectors
from benchmark.frames.methods import FrameMethods
from benchmark.frames.runtime import single_thread
from viewadapt.detect.detector import DEFAULT_BOX_VOTING
P = "/work/shared/data/pets09_s2l1_view001"
cal = read_calibration_file(P + "/calibration/View_001.xml")
models = SourceDetectors.load("viewadapt/data/source_detectors.npz")
files = sorted(glob.glob(P + "/img1/*.jpg"))
files = [f for f in files if int(f[-10:-4]) % 2 == 1][:150]
kw = dict(person_heights=(1.75,), cache_dir="/tmp/s16/opcache2", lens=np.asarray(cal.dist).tolist())
fms = {v: FrameMethods(cal.camera, models, box_voting=v, **kw) for v in (0.0, 1.0)}
ms = ["opencv_adapted", "hog_adapted"]
for fm in fms.values():
    for m in ms: fm.prepare(m)
t = {(v, m): [] for v in fms for m in ms}
with single_thread():
    for i, f in enumerate(files):
        img = cv2.imread(f)[:, :, ::-1].copy()
        order = list(fms) if i % 2 == 0 else list(fms)[::-1]
        for m in ms:
            for v in order:
                if i == 0: fms[v].detect(m, img)
                s = time.perf_counter(); fms[v].detect(m, img); t[(v, m)].append(time.perf_counter() - s)
        fms[1.0].detect("opencv_2x", img)
for m in ms:
    a, b = np.array(t[(0.0, m)]), np.array(t[(1.0, m)])
    print(f"{m}: plain {1/a.mean():.1f} fps ({1e3*a.mean():.1f} ms), voted {1/b.mean():.1f} fps ({1e3*b.mean():.1f} ms), paired mean diff {1e3*(b-a).mean():+.2f} ms, median {1e3*np.median(b-a):+.2f} ms, over {len(a)} frames")
