"""Full-frame viewpoint-adapted detection on a calibrated camera (Wang et al. 2017, Sec. 5).

The detector searches the ground plane, not the image: every world-space candidate window
sees the person through its own homography and so gets its own adapted detector, all
precomputed once per camera and applied as one operator per frame. Arrays in, arrays out:
the files around it (models, operator cache, calibrations, videos, outputs) are
:mod:`viewadapt.io`, camera estimation is :mod:`viewadapt.camera`.

Modules:

* :mod:`~viewadapt.detect.windows` -- candidate windows over the ground plane (Sec. 5.1).
* :mod:`~viewadapt.detect.channels` -- frame features: per-pixel channels once, cell maps
  at every size the windows need; the same features of a canonical window.
* :mod:`~viewadapt.detect.opencv_cells` -- OpenCV's HOG descriptor (Dalal & Triggs) as
  block-normalised cells of the frame's grid, and OpenCV's detectors over them.
* :mod:`~viewadapt.detect.templates` -- windows grouped into shared templates.
* :mod:`~viewadapt.detect.frame_remap` -- the frame ``G`` of a template, for any object
  model; :mod:`~viewadapt.detect.features` -- the feature families (HOG, OpenCV's HOG,
  ACF) the operators read.
* :mod:`~viewadapt.detect.renorm` -- the adapted OpenCV detector's per-window
  normalisation stage.
* :mod:`~viewadapt.detect.linear`, :mod:`~viewadapt.detect.trees` -- the adapted HOG/SVM
  (ours and OpenCV's) and ACF operators.
* :mod:`~viewadapt.detect.layers` -- small persons' windows on an upsampled frame band.
* :mod:`~viewadapt.detect.frameview` -- training crops as the operators read them.
* :mod:`~viewadapt.detect.kinds` -- one spec per adapted detector (HOG/SVM, ACF, OpenCV's).
* :mod:`~viewadapt.detect.detector` -- :class:`FrameDetector`, the detector a user calls.
* :mod:`~viewadapt.detect.training` -- the source detectors (HOG/SVM, ACF trees) trained on
  canonical windows and their frame-view copies.
* :mod:`~viewadapt.detect.stream` -- detections with their ground positions over a stream
  of frames, in one process or several.
* :mod:`~viewadapt.detect.evaluation` -- miss rate against false positives per image.

Example
-------
>>> from viewadapt.detect import FrameDetector
>>> from viewadapt.io import SourceDetectors, read_calibration
>>> detector = FrameDetector(read_calibration("camera.yaml"),
...                          SourceDetectors.load("source_detectors.npz"))  # doctest: +SKIP
>>> boxes = detector.detect(frame, "hog")       # (D, 5): x, y, w, h, score  # doctest: +SKIP
"""

from .windows import (
    GROUND_STRIDE_M, PERSON_BOX_WINDOW, CandidateWindows, check_ground_stride,
    check_ground_visible,
    window_homographies, select_candidate_windows, person_boxes, window_scale, distort_pixels,
    windows_through_lens, detector_window_homography,
)
from .channels import (
    HOG_CELL, N_HOG_BINS, HOG_CHANNELS, HOG_WEIGHT_SHAPE, HOG_CLIP, ACF_SHRINK, N_ACF_CHANNELS,
    N_ACF_ORIENTS, ACF_WEIGHT_SHAPE, ACF_GRADIENT_LAMBDA, fast_orientation_channels,
    FrameFeatures, check_frame, cell_sums, orientation_cell_maps, channel_slices3,
    correlate_slices, block_normalize_cells, hog_window_features, hog_frame_features,
)
from .acf_channels import (
    fast_acf_pixel_channels, acf_channel_cell_maps, acf_window_features, acf_frame_features,
)
from .opencv_cells import (
    OPENCV_CHANNELS, OPENCV_WEIGHT_SHAPE, OPENCV_L2HYS_CLIP, opencv_cell_weights,
    opencv_descriptor_weights, opencv_default_people_detector, DAIMLER_WINDOW,
    opencv_daimler_people_detector, opencv_gradients, opencv_block_cells, raw_cell_maps,
    opencv_window_features, daimler_window_features, OpenCVFrameFeatures, opencv_frame_features,
)
from .templates import (
    FRAME_CELL_SIZES, CELLS_PER_SOURCE_CELL, HOG_TOLERANCE, ACF_TOLERANCE, choose_cell_sizes,
    group_windows, patch_grid, TemplateGroup, build_template_groups, required_padding,
    check_windows, SnappedBoxes, TemplateOperator,
)
from .frame_remap import (
    SOURCE_DISTANCE_M, patch_cell_grid, resolve_object_model, window_mapping,
    from_detector_window, hog_frame_remap, cell_hog_remap, opencv_frame_remap, acf_frame_remap,
    acf_gradient_rows,
)
from .features import (
    FeatureKind, HOG_FEATURES, OPENCV_FEATURES, DAIMLER_FEATURES, ACF_FEATURES, FEATURE_MAKERS,
    FEATURE_CHANNELS,
    feature_maker_to_dict, feature_maker_from_dict,
)
from .renorm import (
    RENORM_CELLS_PER_SOURCE_CELL, STAGE_CELL_TOLERANCE, VERIFY_THRESHOLD, OPENCV_DESCRIPTOR_SIZE,
    OPENCV_STAGE_CELL_SIZES, cell_maps_of_mapping, stage_cell_sizes,
    RenormStage,
)
from .linear import (
    AdaptedLinearOperator, OPENCV_FOLD_CELL_SIZES, build_adapted_linear_operator,
    build_adapted_opencv_operator,
)
from .trees import AdaptedTreesOperator, build_adapted_trees_operator
from .layers import (
    UPSAMPLE_BELOW, UPSAMPLE_FACTOR, frame_to_band, upsampled_windows, upsampled_band,
    MultiResolutionOperator, build_multiresolution_operator,
)
from .frameview import FRAME_VIEW_SCALES, frame_view, frame_view_features, frame_view_copies
from .kinds import (
    DetectorKind, HOG_DETECTOR, ACF_DETECTOR, OPENCV_DETECTOR, DAIMLER_DETECTOR, DETECTOR_KINDS,
    PRETRAINED_KINDS, hog_kind, opencv_kind, detector_kind,
)
from .detector import DEFAULT_BOX_VOTING, DEFAULT_THRESHOLD, FrameDetections, FrameDetector
from .training import FRAME_VIEW_CHOICES, DEFAULT_FRAME_VIEW, check_frame_view, train_on_windows
from .stream import DetectorSpec, detect_stream
from .evaluation import standardize_boxes, ground_truth_rows, evaluate_detections

__all__ = [
    "GROUND_STRIDE_M", "PERSON_BOX_WINDOW", "CandidateWindows", "check_ground_stride",
    "check_ground_visible",
    "window_homographies", "select_candidate_windows", "person_boxes", "window_scale",
    "distort_pixels", "windows_through_lens", "detector_window_homography", "HOG_CELL",
    "N_HOG_BINS", "HOG_CHANNELS",
    "HOG_WEIGHT_SHAPE", "HOG_CLIP", "ACF_SHRINK", "N_ACF_CHANNELS", "N_ACF_ORIENTS",
    "ACF_WEIGHT_SHAPE", "ACF_GRADIENT_LAMBDA", "fast_orientation_channels",
    "fast_acf_pixel_channels", "acf_channel_cell_maps", "FrameFeatures", "check_frame",
    "cell_sums", "orientation_cell_maps", "channel_slices3", "correlate_slices",
    "block_normalize_cells", "hog_window_features", "acf_window_features", "hog_frame_features",
    "acf_frame_features", "OPENCV_CHANNELS", "OPENCV_WEIGHT_SHAPE", "OPENCV_L2HYS_CLIP",
    "opencv_cell_weights", "opencv_descriptor_weights", "opencv_default_people_detector",
    "DAIMLER_WINDOW", "opencv_daimler_people_detector", "daimler_window_features",
    "opencv_gradients", "opencv_block_cells", "raw_cell_maps", "opencv_window_features",
    "OpenCVFrameFeatures", "opencv_frame_features", "FRAME_CELL_SIZES", "CELLS_PER_SOURCE_CELL",
    "HOG_TOLERANCE", "ACF_TOLERANCE", "choose_cell_sizes", "group_windows", "patch_grid",
    "TemplateGroup", "build_template_groups", "required_padding", "check_windows",
    "SnappedBoxes", "TemplateOperator", "SOURCE_DISTANCE_M", "patch_cell_grid",
    "resolve_object_model", "window_mapping", "from_detector_window", "hog_frame_remap",
    "cell_hog_remap",
    "opencv_frame_remap", "acf_frame_remap", "acf_gradient_rows", "FeatureKind", "HOG_FEATURES",
    "OPENCV_FEATURES", "DAIMLER_FEATURES", "ACF_FEATURES", "FEATURE_MAKERS", "FEATURE_CHANNELS",
    "feature_maker_to_dict", "feature_maker_from_dict", "RENORM_CELLS_PER_SOURCE_CELL",
    "STAGE_CELL_TOLERANCE",
    "VERIFY_THRESHOLD", "OPENCV_DESCRIPTOR_SIZE", "OPENCV_STAGE_CELL_SIZES", "stage_cell_sizes",
    "cell_maps_of_mapping",
    "RenormStage", "AdaptedLinearOperator", "OPENCV_FOLD_CELL_SIZES",
    "build_adapted_linear_operator", "build_adapted_opencv_operator",
    "AdaptedTreesOperator", "build_adapted_trees_operator", "UPSAMPLE_BELOW", "UPSAMPLE_FACTOR",
    "frame_to_band", "upsampled_windows", "upsampled_band", "MultiResolutionOperator",
    "build_multiresolution_operator", "FRAME_VIEW_SCALES", "frame_view", "frame_view_features",
    "frame_view_copies", "DetectorKind", "HOG_DETECTOR", "ACF_DETECTOR", "OPENCV_DETECTOR",
    "DAIMLER_DETECTOR", "DETECTOR_KINDS", "PRETRAINED_KINDS", "hog_kind", "opencv_kind",
    "detector_kind",
    "DEFAULT_BOX_VOTING",
    "DEFAULT_THRESHOLD",
    "FrameDetections", "FrameDetector", "FRAME_VIEW_CHOICES", "DEFAULT_FRAME_VIEW",
    "check_frame_view", "train_on_windows", "DetectorSpec", "detect_stream",
    "standardize_boxes", "ground_truth_rows", "evaluate_detections",
]
