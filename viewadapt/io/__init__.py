"""Files: everything :mod:`viewadapt` reads or writes, and the only place it opens one.

* :mod:`~viewadapt.io.files` -- atomic files and output folders, run metadata, errors.
* :mod:`~viewadapt.io.arrayfile` -- the on-disk format of models and operators (npz of
  plain arrays + JSON, never a pickle).
* :mod:`~viewadapt.io.models` -- the source detectors a frame detector adapts
  (:class:`SourceDetectors`), and the models shipped in the package.
* :mod:`~viewadapt.io.cache` -- the adapted operators of a camera, cached on disk.
* :mod:`~viewadapt.io.calibration` -- camera calibration files (YAML or JSON, and the
  imported formats).
* :mod:`~viewadapt.io.bounded` -- the guarded readers of files from outside (size, JSON and
  YAML nesting, no YAML aliases, no XML entities).
* :mod:`~viewadapt.io.imports` -- other tools' calibrations (PETS 2009 / Tsai XML, OpenCV
  FileStorage).
* :mod:`~viewadapt.io.boxes` -- ground-truth boxes for evaluation (CSV, COCO, MOTChallenge,
  CAVIAR) and ignore regions.
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
from .bounded import (
    MAX_INPUT_BYTES, MAX_JSON_DEPTH, MAX_CALIBRATION_BYTES, MAX_CALIBRATION_DEPTH,
    read_limited_text, json_depth, check_json_depth, parse_json, parse_yaml, check_yaml, parse_xml,
)
from .imports import (
    TSAI_FIT_GRID, MAX_TSAI_FIT_ERROR_PX, ImportedCalibration, read_calibration_text,
    check_filestorage_text, calibration_format, read_imported_calibration, read_tsai_calibration,
    read_opencv_calibration, tsai_rotation, tsai_distortion_to_opencv,
)
from .hogfile import DAIMLER_FILE_LAYOUT, HOG_FILE_LAYOUT, read_opencv_hog_detector
from .calibration import (
    CalibrationFile, read_calibration_file, read_calibration, read_distortion,
    read_correspondences, CORRESPONDENCE_COLUMNS, CALIBRATION_KEYS,
)
from .boxes import (
    BOX_FORMATS, MOT_MIN_VISIBILITY, MOT_COUNTED_CLASSES, MOT_IGNORED_CLASSES, FrameBoxes,
    boxes_format, read_boxes, read_ignore_regions, frame_number,
)
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
    "operator_from_arrays", "OperatorCache", "MAX_INPUT_BYTES", "MAX_JSON_DEPTH",
    "MAX_CALIBRATION_BYTES", "MAX_CALIBRATION_DEPTH", "read_limited_text", "json_depth",
    "check_json_depth", "parse_json", "parse_yaml", "check_yaml", "parse_xml", "TSAI_FIT_GRID",
    "MAX_TSAI_FIT_ERROR_PX", "ImportedCalibration", "read_calibration_text",
    "check_filestorage_text", "calibration_format", "read_imported_calibration",
    "read_tsai_calibration", "read_opencv_calibration", "tsai_rotation",
    "tsai_distortion_to_opencv", "HOG_FILE_LAYOUT", "DAIMLER_FILE_LAYOUT", "read_opencv_hog_detector", "CalibrationFile", "read_calibration_file", "read_calibration",
    "read_distortion", "read_correspondences", "CORRESPONDENCE_COLUMNS", "CALIBRATION_KEYS",
    "BOX_FORMATS", "MOT_MIN_VISIBILITY", "MOT_COUNTED_CLASSES", "MOT_IGNORED_CLASSES",
    "FrameBoxes", "boxes_format", "read_boxes", "read_ignore_regions", "frame_number",
    "IMAGE_SUFFIXES", "Frame", "FrameStream", "open_frames", "natural_sort_key", "prefetched",
    "read_frame", "ANNOTATE_CHOICES", "CSV_COLUMNS", "DetectionWriter", "draw_detections",
    "plot_det_figure", "FAMILY_COLORS",
]
