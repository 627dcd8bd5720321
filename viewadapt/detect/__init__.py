"""Full-frame viewpoint-adapted detection on a calibrated camera (Wang et al. 2017, Sec. 5).

The detector searches the ground plane, not the image: every world-space candidate window
sees the person through its own homography and so gets its own adapted detector, all
precomputed once per camera and applied as one operator per frame.

Modules (public names are re-exported here):

* :mod:`~viewadapt.detect.windows` -- candidate windows over the ground plane (Sec. 5.1).
* :mod:`~viewadapt.detect.channels` -- frame features: per-pixel channels once, cell maps
  at every size the windows need; the same features of a canonical window.
* :mod:`~viewadapt.detect.templates` -- windows grouped into shared templates; the frame
  ``G`` of each feature kind.
* :mod:`~viewadapt.detect.linear`, :mod:`~viewadapt.detect.trees` -- the adapted HOG/SVM
  and ACF operators.
* :mod:`~viewadapt.detect.layers` -- small persons' windows on an upsampled frame band.
* :mod:`~viewadapt.detect.frameview` -- training crops as the operators read them.
* :mod:`~viewadapt.detect.kinds` -- one spec per adapted detector (HOG/SVM, ACF).
* :mod:`~viewadapt.detect.detector` -- :class:`FrameDetector`, the detector a user calls;
  :mod:`~viewadapt.detect.models`, :mod:`~viewadapt.detect.cache`,
  :mod:`~viewadapt.detect.calibration`, :mod:`~viewadapt.detect.evaluation` -- its models,
  operator cache, input files and evaluation; :mod:`~viewadapt.detect.arrayfile` -- the
  on-disk format of models and cached operators (npz + JSON, never a pickle).
* :mod:`~viewadapt.detect.calibrate` -- a camera from image <-> ground-plane points (Zhang
  2000); :mod:`~viewadapt.detect.distortion` -- lens undistortion of its frames.
* :mod:`~viewadapt.detect.video` -- a camera's frames streamed from a video, a folder, a
  glob pattern or image files; :mod:`~viewadapt.detect.footage` -- detections with their
  ground positions over a stream, in one process or several;
  :mod:`~viewadapt.detect.outputs` -- the files ``viewadapt detect`` writes (CSV, COCO
  results, MOTChallenge ``det.txt``, annotated video or frames).

Example
-------
>>> from viewadapt.detect import FrameDetector, SourceDetectors, read_calibration
>>> detector = FrameDetector(read_calibration("camera.yaml"),
...                          SourceDetectors.load("source_detectors.npz"))  # doctest: +SKIP
>>> boxes = detector.detect(frame, "hog")       # (D, 5): x, y, w, h, score  # doctest: +SKIP
"""

from .cache import *  # noqa: F401,F403
from .cache import __all__ as _cache_all
from .calibrate import *  # noqa: F401,F403
from .calibrate import __all__ as _calibrate_all
from .calibration import *  # noqa: F401,F403
from .calibration import __all__ as _calibration_all
from .channels import *  # noqa: F401,F403
from .channels import __all__ as _channels_all
from .detector import *  # noqa: F401,F403
from .detector import __all__ as _detector_all
from .distortion import *  # noqa: F401,F403
from .distortion import __all__ as _distortion_all
from .evaluation import *  # noqa: F401,F403
from .evaluation import __all__ as _evaluation_all
from .footage import *  # noqa: F401,F403
from .footage import __all__ as _footage_all
from .frameview import *  # noqa: F401,F403
from .frameview import __all__ as _frameview_all
from .kinds import *  # noqa: F401,F403
from .kinds import __all__ as _kinds_all
from .layers import *  # noqa: F401,F403
from .layers import __all__ as _layers_all
from .linear import *  # noqa: F401,F403
from .linear import __all__ as _linear_all
from .models import *  # noqa: F401,F403
from .models import __all__ as _models_all
from .outputs import *  # noqa: F401,F403
from .outputs import __all__ as _outputs_all
from .templates import *  # noqa: F401,F403
from .templates import __all__ as _templates_all
from .trees import *  # noqa: F401,F403
from .trees import __all__ as _trees_all
from .video import *  # noqa: F401,F403
from .video import __all__ as _video_all
from .windows import *  # noqa: F401,F403
from .windows import __all__ as _windows_all

__all__ = (_windows_all + _channels_all + _templates_all + _linear_all + _trees_all
           + _layers_all + _frameview_all + _kinds_all + _detector_all + _models_all + _cache_all
           + _calibration_all + _calibrate_all + _distortion_all + _evaluation_all
           + _video_all + _footage_all + _outputs_all)
