"""Output files of ``viewadapt detect``, written frame by frame as detections come.

:class:`DetectionWriter` writes into one folder (the command's temporary output folder,
moved into place only when the run succeeds):

* ``detections.csv`` -- one row per detection: ``frame`` (the frame's 0-based index in the
  input, :class:`~viewadapt.io.video.Frame`), ``source`` (image or video file name),
  ``x, y, w, h`` (box, pixels), ``score`` and ``ground_x, ground_y`` (where the person
  stands, world metres on the ground plane,
  :meth:`~viewadapt.detect.FrameDetector.detect_on_ground`).
* ``detections_coco.json`` -- COCO results: a list of ``{"image_id", "category_id",
  "bbox", "score"}`` with ``image_id = frame + 1`` and ``category_id = 1`` (person).
* ``det.txt`` -- MOTChallenge detections, one line ``frame, id, bb_left, bb_top, bb_width,
  bb_height, conf, x, y, z`` per box, with ``frame`` 1-based (``frame + 1``), ``id = -1``
  and ``x, y, z = -1``, as the MOT16/MOT17 ``det.txt`` files (the ground position is in
  ``detections.csv``).
* with ``annotate="video"``: ``annotated.mp4`` (``cv2.VideoWriter``, ``mp4v``) of every
  frame with its boxes; with ``"frames"``: ``annotated/<frame:05d>_<source stem>.png``.

Pixels are written to 0.01 px, scores to 1e-6, ground positions to 1 mm; all files are
written in frame order, so the same detections give the same bytes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from viewadapt.io.files import RunError

__all__ = ["ANNOTATE_CHOICES", "CSV_COLUMNS", "DETECTION_COLOURS", "TRUTH_COLOURS",
           "AnnotationWriter", "DetectionWriter", "draw_detections", "plot_det_figure",
           "FAMILY_COLORS"]

#: ``annotate`` values of :class:`DetectionWriter` (:class:`AnnotationWriter` writes the two
#: that annotate)
ANNOTATE_CHOICES = ("video", "frames", "none")

#: figure colour of each detector family (the method name's first part)
FAMILY_COLORS = {"hog": "tab:blue", "acf": "tab:red", "opencv": "tab:gray", "daimler": "tab:olive"}
#: columns of ``detections.csv``
CSV_COLUMNS = ("frame", "source", "x", "y", "w", "h", "score", "ground_x", "ground_y")
_BOX_COLOUR = (0, 255, 0)          # BGR
#: BGR colour of a drawn detection by its label (:func:`viewadapt.detect.evaluation.frame_outcome`:
#: 1 hit, 0 false positive, -1 ignored) and of a ground-truth box by its status (1 found,
#: 0 missed, -1 ignored)
DETECTION_COLOURS = {1: (0, 200, 0), 0: (0, 0, 255), -1: (160, 160, 160)}
TRUTH_COLOURS = {1: (255, 255, 255), 0: (0, 165, 255), -1: (120, 120, 120)}


def _rect(vis, box, colour, width):
    import cv2

    x, y, w, h = box[:4]
    cv2.rectangle(vis, (int(round(x)), int(round(y))), (int(round(x + w)), int(round(y + h))),
                  colour, width)


def draw_detections(image, boxes, *, threshold: float = -np.inf, labels=None, truth=None,
                    status=None, scores: bool = False) -> np.ndarray:
    """A BGR copy of the RGB ``image`` (H, W, 3) with the ``boxes`` (D, >=4) ``(x, y, w, h,
    [score])`` whose score reaches ``threshold``.

    Without ``labels`` they are green, 1 px; with ``labels`` (D,) (1 hit, 0 false positive,
    -1 ignored, -2 not drawn) in :data:`DETECTION_COLOURS`; ``scores`` writes each one's
    score above it. ``truth`` (G, 4) boxes are drawn under them in
    :data:`TRUTH_COLOURS` by ``status`` (G,) (1 found, 0 missed -- 2 px --, -1 ignored).
    """
    import cv2

    vis = np.ascontiguousarray(np.asarray(image)[:, :, ::-1])
    b = np.asarray(boxes, dtype=np.float64)
    b = b.reshape(-1, b.shape[-1]) if b.size else np.zeros((0, 5))
    if truth is not None:
        t = np.asarray(truth, np.float64).reshape(-1, 4)
        st = np.ones(len(t), int) if status is None else np.asarray(status).ravel()
        for box, s in zip(t, st):
            _rect(vis, box, TRUTH_COLOURS[int(s)], 2 if s == 0 else 1)
    for k, box in enumerate(b):
        if b.shape[1] > 4 and box[4] < threshold:
            continue
        lab = None if labels is None else int(labels[k])
        if lab == -2:
            continue
        colour = _BOX_COLOUR if lab is None else DETECTION_COLOURS[lab]
        _rect(vis, box, colour, 1)
        if scores and b.shape[1] > 4:
            cv2.putText(vis, f"{box[4]:.2f}", (int(round(box[0])), int(round(box[1])) - 2),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.35, colour, 1, cv2.LINE_AA)
    return vis


def _csv_field(text: str) -> str:
    """``text`` as one CSV field, quoted as :mod:`csv` quotes it (``QUOTE_MINIMAL``)."""
    if any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


class AnnotationWriter:
    """Annotated frames, in order: ``annotated.mp4`` (``annotate="video"``; ``fps`` and
    ``image_size`` needed) or ``annotated/<index>_<stem>.png`` (``"frames"``) in
    ``folder``. Use as a context manager, or call :meth:`close`."""

    def __init__(self, folder, annotate: str, *, fps: float = 25.0, image_size=None):
        if annotate not in ("video", "frames"):
            raise ValueError(f"annotate must be video or frames, got {annotate!r}")
        self.folder = Path(folder)
        self._video = None
        if annotate == "video":
            import cv2

            if image_size is None or not np.isfinite(fps) or fps <= 0:
                raise ValueError("an annotated video needs the image size and a positive fps")
            path = self.folder / "annotated.mp4"
            self._video = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"),
                                          float(fps), tuple(int(v) for v in image_size))
            if not self._video.isOpened():
                raise RunError(f"cannot write {path}: this OpenCV build has no mp4v encoder "
                               "(use --annotate frames)")
        else:
            (self.folder / "annotated").mkdir()

    def write(self, frame, vis) -> None:
        """One annotated BGR frame ``vis`` of ``frame`` (``index``, ``source``)."""
        import cv2

        if self._video is not None:
            self._video.write(vis)
        else:
            name = f"{int(frame.index):05d}_{Path(frame.source).stem}.png"
            if not cv2.imwrite(str(self.folder / "annotated" / name), vis):
                raise RunError(f"cannot write {self.folder / 'annotated' / name}")

    def close(self) -> None:
        if self._video is not None:
            self._video.release()
            self._video = None

    def __enter__(self) -> "AnnotationWriter":
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False


class DetectionWriter:
    """Write the detections of frames, in order, into ``folder`` (see the module).

    Parameters
    ----------
    folder : path
        An existing folder.
    annotate : {"video", "frames", "none"}
    fps : float
        Frame rate of ``annotated.mp4``.
    image_size : (width, height)
        Size of the annotated frames.

    Use as a context manager, or call :meth:`close`; :meth:`write` once per frame.
    """

    def __init__(self, folder, *, annotate: str = "none", fps: float = 25.0,
                 image_size=None):
        if annotate not in ANNOTATE_CHOICES:
            raise ValueError(f"annotate must be one of {ANNOTATE_CHOICES}, got {annotate!r}")
        self.folder = Path(folder)
        self.annotate = annotate
        self.n_frames = self.n_detections = 0
        self._annotated = None if annotate == "none" else AnnotationWriter(
            self.folder, annotate, fps=fps, image_size=image_size)
        self._csv_file = open(self.folder / "detections.csv", "w", newline="")
        self._csv_file.write(",".join(CSV_COLUMNS) + "\n")
        self._mot = open(self.folder / "det.txt", "w")
        self._coco = open(self.folder / "detections_coco.json", "w")
        self._coco.write("[")

    def write(self, frame, detections, *, annotation=None) -> None:
        """Write one frame's detections (and its annotation).

        Parameters
        ----------
        frame : Frame
            ``index``, ``source`` and the RGB ``image`` the detections were found on.
        detections : FrameDetections
            ``boxes`` (D, 5) and ``ground_xy`` (D, 2).
        annotation : dict, optional
            Keywords of :func:`draw_detections` for the annotated frame (an operating
            point, labels, ground truth); default every box, green.
        """
        boxes = np.asarray(detections.boxes, dtype=np.float64).reshape(-1, 5)
        ground = np.asarray(detections.ground_xy, dtype=np.float64).reshape(-1, 2)
        i = int(frame.index)
        source = _csv_field(str(frame.source))
        csv_rows, mot_rows, coco_rows = [], [], []
        # every value formatted once (boxes to 0.01 px, scores to 1e-6, ground to 1 mm) and
        # the same text in the three files (JSON numbers may end in zeros)
        for (x, y, w, h, s), (gx, gy) in zip(boxes.tolist(), ground.tolist()):
            bx, by, bw, bh = f"{x:.2f}", f"{y:.2f}", f"{w:.2f}", f"{h:.2f}"
            score = f"{s:.6f}"
            box = f"{bx},{by},{bw},{bh}"
            csv_rows.append(f"{i},{source},{box},{score},{gx:.3f},{gy:.3f}\n")
            mot_rows.append(f"{i + 1},-1,{box},{score},-1,-1,-1\n")
            coco_rows.append(f'{{"image_id": {i + 1}, "category_id": 1, "bbox": [{bx}, {by}, '
                             f'{bw}, {bh}], "score": {score}}}')
        if coco_rows:
            self._coco.write(("\n" if self.n_detections == 0 else ",\n")
                             + ",\n".join(coco_rows))
        self._csv_file.write("".join(csv_rows))
        self._mot.write("".join(mot_rows))
        self.n_detections += len(coco_rows)
        if self._annotated is not None:
            self._annotated.write(frame, draw_detections(frame.image, boxes,
                                                         **(annotation or {})))
        self.n_frames += 1

    def close(self) -> None:
        """Finish the files (the COCO list, the video's index)."""
        if self._coco is None:
            return
        self._coco.write("\n]\n")
        for f in (self._csv_file, self._mot, self._coco):
            f.close()
        self._coco = None
        if self._annotated is not None:
            self._annotated.close()

    def __enter__(self) -> "DetectionWriter":
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False


def plot_det_figure(results, path_stem, title=""):
    """Miss rate against FPPI, log-log, the legend with each method's LAMR (Fig. 3)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dash = {"pyramid": "-", "warp": "--", "adapted": ":", "opencv": "-.", "native": "-."}
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    variants = sorted({m.partition("[")[2] for m in results if "[" in m})
    for m, r in sorted(results.items(), key=lambda kv: kv[1]["lamr"]):
        fam = m.split("_")[0]
        ls = dash.get(m.split("_")[-1], "-")
        if "[" in m:          # an adapted variant (rule, object model): its own dash pattern
            ls = (0, (4, 1 + variants.index(m.partition("[")[2]), 1, 1))
        fppi = np.r_[1e-3, r["fppi"]] if len(r["fppi"]) else np.array([1e-3, 10])
        mr = np.r_[1.0, r["miss_rate"]] if len(r["miss_rate"]) else np.array([1.0, 1.0])
        ax.step(np.maximum(fppi, 1e-3), mr, where="post", ls=ls, lw=2,
                color=FAMILY_COLORS.get(fam, "k"), label=f"{100 * r['lamr']:.1f}% {m}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(1e-2, 1e1)
    ax.set_ylim(5e-2, 1.0)
    ax.set_xlabel("false positives per image")
    ax.set_ylabel("miss rate")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left", title="log-average miss rate")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(f"{path_stem}.png", dpi=150)
    fig.savefig(f"{path_stem}.pdf")
    plt.close(fig)
