"""Files: everything :mod:`viewadapt` reads or writes, and the only place it opens one.

* :mod:`~viewadapt.io.files` -- atomic files and output folders, run metadata, errors.
* :mod:`~viewadapt.io.arrayfile` -- the on-disk format of models and operators (npz of
  plain arrays + JSON, never a pickle).
* :mod:`~viewadapt.io.models` -- the source detectors a frame detector adapts
  (:class:`SourceDetectors`), and the models shipped in the package.
* :mod:`~viewadapt.io.cache` -- the adapted operators of a camera, cached on disk.
* :mod:`~viewadapt.io.calibration` -- camera calibration files (YAML or JSON).
* :mod:`~viewadapt.io.boxes` -- ground-truth boxes for evaluation.
* :mod:`~viewadapt.io.video` -- a camera's frames from a video, a folder, a glob pattern or
  image files.
* :mod:`~viewadapt.io.outputs` -- the files ``viewadapt detect`` writes (CSV, COCO results,
  MOTChallenge ``det.txt``, annotated video or frames, DET figure).
* :mod:`~viewadapt.io.packaged` -- data files shipped inside the package.
"""

from .arrayfile import ArrayFileError, write_array_file, read_array_file
from .models import (
    SOURCE_DETECTORS_FORMAT, SOURCE_DETECTORS_VERSION, SourceDetectors, shipped_model_path,
)
from .cache import (
    DEFAULT_CACHE_LIMIT_GB, check_cache_limit, OPERATOR_FORMAT, OPERATOR_CLASSES,
    operator_to_arrays, operator_from_arrays, OperatorCache,
)
from .calibration import read_calibration, read_distortion
from .boxes import read_boxes
from .video import (
    IMAGE_SUFFIXES, Frame, FrameStream, open_frames, natural_sort_key, prefetched, read_frame,
)
from .outputs import (
    ANNOTATE_CHOICES, CSV_COLUMNS, DetectionWriter, draw_detections, plot_det_figure, FAMILY_COLORS,
)

__all__ = [
    "ArrayFileError", "write_array_file", "read_array_file", "SOURCE_DETECTORS_FORMAT",
    "SOURCE_DETECTORS_VERSION", "SourceDetectors", "shipped_model_path", "DEFAULT_CACHE_LIMIT_GB",
    "check_cache_limit", "OPERATOR_FORMAT", "OPERATOR_CLASSES", "operator_to_arrays",
    "operator_from_arrays", "OperatorCache", "read_calibration", "read_distortion", "read_boxes",
    "IMAGE_SUFFIXES", "Frame", "FrameStream", "open_frames", "natural_sort_key", "prefetched",
    "read_frame", "ANNOTATE_CHOICES", "CSV_COLUMNS", "DetectionWriter", "draw_detections",
    "plot_det_figure", "FAMILY_COLORS",
]
