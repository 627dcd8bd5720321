"""One-off: the HOG stage on the paper's plane with one orientation map A per source cell
(the Jacobian at each cell, as the fold and image warping have it) instead of one at the
window's centre: identity cell maps (RenormStage's cell_maps) on every plane window, then
the viewadapt CLI as given. argv: the CLI's arguments (use a fresh --out: the operator
cache does not know the patch)."""
import sys

import numpy as np

import viewadapt.detect.renorm as renorm
from viewadapt.cli import main

_init = renorm.RenormStage.__init__
_ID = None


def _init_percell(self, homographies, cell_size, weights, bias, **kw):
    global _ID
    if kw.get("model") == "hog" and kw.get("cell_maps") is None:
        if _ID is None:
            ys, xs = np.mgrid[0:16, 0:8].astype(np.float64)
            _ID = np.zeros((1, 16, 8, 6))
            _ID[0, ..., 0], _ID[0, ..., 1] = 8 * xs + 3.5, 8 * ys + 3.5
            _ID[0, ..., 2] = _ID[0, ..., 5] = 1.0
        kw.update(cell_maps=_ID, cell_map_of=np.zeros(len(np.reshape(homographies, (-1, 9))),
                                                       np.int64))
    _init(self, homographies, cell_size, weights, bias, **kw)


renorm.RenormStage.__init__ = _init_percell
sys.exit(main(sys.argv[1:]))
