"""viewadapt: viewpoint adaptation for rigid object detectors (Wang et al. 2017).

A person seen from an elevated camera is approximately a plane warped by a homography.
Instead of warping every candidate window into the training view (Li et al. 2008), remap
the features with ``G = S (x) A`` -- cell resampling by exact area overlaps, orientation
resampling by mapped bin intervals -- and, for a linear classifier, fold it into the
weights: ``w' = G^T w``.

Modules (public names are re-exported here):

* :mod:`viewadapt.geometry` -- cameras, the planar person model, homographies, Jacobians.
* :mod:`viewadapt.hog`, :mod:`viewadapt.acf` -- features with their linear part exposed.
* :mod:`viewadapt.remap` -- ``S``, ``A``, ``G``.
* :mod:`viewadapt.mapping` -- ``G`` from any point mapping (the homography is a special case).
* :mod:`viewadapt.surface`, :mod:`viewadapt.objectmodel` -- depth maps and exact
  correspondences of meshes; the person plane and a mean-body object model.
* :mod:`viewadapt.adapt` -- classifier adaptation and the adapted-classifier wrapper.
* :mod:`viewadapt.warp` -- the image-warping baseline.
* :mod:`viewadapt.classifiers`, :mod:`viewadapt.boosting` (trees: :mod:`viewadapt.treegrow`)
  -- linear SVM, boosted trees.
* :mod:`viewadapt.metrics` (matching: :mod:`viewadapt.matching`), :mod:`viewadapt.nms`,
  :mod:`viewadapt.boxes` -- evaluation.
* :mod:`viewadapt.arrays` -- named arrays checked as they are read back.

Subpackages (names not re-exported here):

* :mod:`viewadapt.detect` -- full-frame detection on a calibrated camera: world-space
  candidate windows, the per-position adapted detectors applied as one operator, and
  :class:`viewadapt.detect.FrameDetector`.
* :mod:`viewadapt.camera` -- a camera from ground-point correspondences; lens distortion.
* :mod:`viewadapt.io` -- every file the library reads or writes: models, the operator
  cache, calibration files, videos, ``detect``'s outputs, atomic output folders.
* :mod:`viewadapt.commands`, :mod:`viewadapt.cli` -- ``viewadapt detect``, ``viewadapt
  calibrate`` and the command line.

``import viewadapt`` never imports Blender (bpy), torch or anny.
"""

from .version import __version__  # noqa: F401

from .acf import *  # noqa: F401,F403
from .acf import __all__ as _acf_all
from .adapt import *  # noqa: F401,F403
from .adapt import __all__ as _adapt_all
from .boosting import *  # noqa: F401,F403
from .boosting import __all__ as _boosting_all
from .classifiers import *  # noqa: F401,F403
from .classifiers import __all__ as _classifiers_all
from .geometry import *  # noqa: F401,F403
from .geometry import __all__ as _geometry_all
from .hog import *  # noqa: F401,F403
from .hog import __all__ as _hog_all
from .mapping import *  # noqa: F401,F403
from .mapping import __all__ as _mapping_all
from .objectmodel import *  # noqa: F401,F403
from .objectmodel import __all__ as _objectmodel_all
from .surface import *  # noqa: F401,F403
from .surface import __all__ as _surface_all
from .metrics import *  # noqa: F401,F403
from .metrics import __all__ as _metrics_all
from .nms import *  # noqa: F401,F403
from .nms import __all__ as _nms_all
from .remap import *  # noqa: F401,F403
from .remap import __all__ as _remap_all
from .warp import *  # noqa: F401,F403
from .warp import __all__ as _warp_all

from . import detect  # noqa: E402,F401  (the subpackage, names not re-exported)

__all__ = sorted(set(_acf_all + _adapt_all + _boosting_all + _classifiers_all
                     + _geometry_all + _hog_all + _metrics_all + _nms_all
                     + _remap_all + _warp_all + _mapping_all + _objectmodel_all
                     + _surface_all))
