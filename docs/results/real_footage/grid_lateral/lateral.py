"""One-off: candidate windows on a ground grid twice as dense across the camera's view
(lateral stride halved, forward stride kept): FrameDetector's windows are the union of the
grid at phase (a, b) and at (a, b + 1/2), grid indices (i, 2j) and (i, 2j + 1). Then runs
``python SCRIPT ARGS`` (e.g. ../grid_phases_adapted/phases.py) or the viewadapt CLI
(``cli ARGS``) with the patch. Use a fresh --out (the operator cache does not know it)."""
import runpy
import sys
from dataclasses import replace

import numpy as np

import viewadapt.detect.detector as det
from viewadapt.detect.windows import CandidateWindows, select_candidate_windows

_select = select_candidate_windows


def lateral_half(camera, image_size=None, *, grid_phase=(0.0, 0.0), **kw):
    a, b = grid_phase
    w0 = _select(camera, image_size, grid_phase=(a, b), **kw)
    w1 = _select(camera, image_size, grid_phase=(a, (b + 0.5) % 1.0), **kw)
    i1 = w1.grid_index.copy()
    if b + 0.5 >= 1.0:                 # its origin wrapped: its j is the j - 1 of phase b + 1/2
        i1[:, 1] -= 1
    g0 = w0.grid_index * [1, 2]
    g1 = i1 * [1, 2] + [0, 1]
    return CandidateWindows(np.concatenate([w0.ground_xy, w1.ground_xy]),
                            np.concatenate([w0.person_height, w1.person_height]),
                            np.concatenate([w0.homographies, w1.homographies]),
                            w0.image_size, np.concatenate([g0, g1]), w0.camera, w0.dist)


det.select_candidate_windows = lateral_half
if sys.argv[1] == "cli":
    from viewadapt.cli import main
    sys.exit(main(sys.argv[2:]))
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
