"""The methods of the frames benchmark: one frozen :class:`FrameMethod` per method.

A method's name (``"hog_adapted[body, paper eq.3]"``, ``"acf_pyramid_fast"``,
``"opencv_native"``) is read once, where it enters (the command line, an earlier run's
files), with :meth:`FrameMethod.parse`; the code in between reads its fields, and the
outputs write its :attr:`~FrameMethod.name`. The tags that name an adapted variant's angle
rule and object model (:data:`RULE_TAGS`, :data:`OBJECT_MODEL_TAGS`,
:func:`variant_label`) also name the cross-validation's variants
(:data:`benchmark.crops.crossval.ADAPT_VARIANTS`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, replace

from viewadapt.detect import DETECTOR_KINDS, PRETRAINED_KINDS, detector_kind

__all__ = ["RULE_TAGS", "OBJECT_MODEL_TAGS", "OPENCV_NAMES", "GROUND_TAG", "FOLD_TAG",
           "variant_label", "FrameMethod", "FRAME_METHODS", "DEFAULT_METHODS", "expand_adapted",
           "method_arg", "frame_method"]

#: angle rule -> its tag in a variant's label (none for the default, covariant rule)
RULE_TAGS = {"covariant": "", "none": "S only", "paper": "paper eq.3"}
#: object model -> its tag in a variant's label (none for the default, the person plane)
OBJECT_MODEL_TAGS = {"plane": "", "body": "body"}
#: how a method detects -> the detector kinds that have it (a pretrained kind's pyramid --
#: ``opencv``, ``daimler`` -- is OpenCV's own ``detectMultiScale``; its adapted and warp
#: methods read the same weights)
_WINDOW_KINDS = (*DETECTOR_KINDS, *PRETRAINED_KINDS)
HOWS = {"adapted": _WINDOW_KINDS, "warp": _WINDOW_KINDS, "pyramid": _WINDOW_KINDS,
        "pyramid_fast": ("acf",)}
#: upsampling factors of the frame under a pyramid: the paper's 4x; OpenCV's also 2x
#: (``opencv_2x``) and the frame as it is (``opencv_native``)
UPSAMPLES = {k: (4, 2, 1) for k in PRETRAINED_KINDS}
PYRAMID_UPSAMPLE = 4
#: OpenCV's method names by upsampling (the Daimler detector's: ``daimler``, ``daimler_2x``,
#: ``daimler_native``)
OPENCV_NAMES = {4: "opencv", 2: "opencv_2x", 1: "opencv_native"}
_PYRAMID_SUFFIX = {4: "", 2: "_2x", 1: "_native"}
#: the tag of a pyramid whose boxes pass the ground-plane filter
GROUND_TAG = "ground"
#: the tag of an adapted detector without its per-window normalisation stage (the folded
#: operator alone; :meth:`viewadapt.detect.DetectorKind.fold`)
FOLD_TAG = "fold"


def variant_label(base: str, rule: str | None = None, object_model: str | None = None, *,
                  extra: str = "") -> str:
    """``base`` tagged with the object model, the angle rule and an ``extra`` tag, e.g.
    ``variant_label("adapted", "paper", "body")`` -> ``"adapted[body, paper eq.3]"``;
    ``base`` alone for the defaults (None, covariant, plane) and no ``extra``."""
    tags = [OBJECT_MODEL_TAGS[object_model] if object_model else "",
            RULE_TAGS[rule] if rule else "", extra]
    tags = [t for t in tags if t]
    return f"{base}[{', '.join(tags)}]" if tags else base


@dataclass(frozen=True)
class FrameMethod:
    """One method of the frames benchmark.

    Attributes
    ----------
    kind : str
        ``"hog"``, ``"acf"`` (the source detectors, :data:`viewadapt.detect.DETECTOR_KINDS`),
        ``"opencv"`` (OpenCV's default people detector) or ``"daimler"`` (OpenCV's 48x96
        Daimler detector; :data:`viewadapt.detect.PRETRAINED_KINDS`).
    how : str
        ``"adapted"`` (the viewpoint-adapted detector on the candidate windows),
        ``"warp"`` (every candidate window warped into the canonical view), ``"pyramid"``
        (the unadapted detector over an image pyramid; OpenCV's ``detectMultiScale``) or
        ``"pyramid_fast"`` (ACF over Dollár's fast feature pyramid).
    rule, object_model : str or None
        The adapted detector's angle rule (a key of :data:`RULE_TAGS`, default
        ``"covariant"``) and object model (of :data:`OBJECT_MODEL_TAGS`, default
        ``"plane"``); None for the other methods.
    upsample : int or None
        The pyramids' upsampling of the frame (default 4; OpenCV's also 2 and 1); None for
        the methods on the candidate windows.
    ground : bool
        A pyramid's boxes pass the ground-plane filter
        (:func:`benchmark.frames.methods.ground_plane_filter`): only those whose height
        agrees with an assumed person height standing at their foot point are kept -- the
        calibration used without adaptation. Only for the pyramids.
    fold : bool
        An adapted detector without its per-window normalisation stage: the folded
        operator alone (eq. (7)). Only for the adapted HOG, OpenCV and Daimler detectors on
        the paper's plane.

    Raises
    ------
    ValueError
        For a combination no method has.
    """

    kind: str
    how: str
    rule: str | None = None
    object_model: str | None = None
    upsample: int | None = None
    ground: bool = False
    fold: bool = False

    def __post_init__(self):
        if self.kind not in HOWS.get(self.how, ()):
            raise ValueError(f"no frames method detects {self.how!r} with {self.kind!r}; "
                             f"methods: {', '.join(m.name for m in FRAME_METHODS)}")
        adapted, pyramid = self.how == "adapted", self.how.startswith("pyramid")
        if adapted:
            self._fill(rule="covariant", object_model="plane")
        if pyramid:
            self._fill(upsample=PYRAMID_UPSAMPLE)
        if adapted != (self.rule is not None) or adapted != (self.object_model is not None):
            raise ValueError(f"{self.how!r} methods take {'a' if adapted else 'no'} rule "
                             f"and object model, got {self.rule!r}, {self.object_model!r}")
        if adapted and (self.rule not in RULE_TAGS or self.object_model not in OBJECT_MODEL_TAGS):
            raise ValueError(f"no adapted variant with rule {self.rule!r} and object model "
                             f"{self.object_model!r}; rules {tuple(RULE_TAGS)}, object models "
                             f"{tuple(OBJECT_MODEL_TAGS)}")
        ups = UPSAMPLES.get(self.kind, (PYRAMID_UPSAMPLE,)) if pyramid else (None,)
        if self.upsample not in ups:
            raise ValueError(f"{self.kind}_{self.how} upsamples by one of {ups}, got "
                             f"{self.upsample!r}")
        if self.ground not in (False, True) or (self.ground and not pyramid):
            raise ValueError(f"only the pyramids take the ground-plane filter, got "
                             f"{self.how!r} with ground={self.ground!r}")
        if self.fold not in (False, True) or (self.fold and not (
                adapted and detector_kind(self.kind).stages(self.object_model))):
            raise ValueError(f"only the adapted detectors with a normalisation stage (HOG "
                             f"with any object model, the others on the paper's plane) have "
                             f"a fold alone; got {self.kind}_{self.how} with object model "
                             f"{self.object_model!r}")

    def _fill(self, **defaults):
        for field, value in defaults.items():
            if getattr(self, field) is None:
                object.__setattr__(self, field, value)

    @classmethod
    def parse(cls, text) -> FrameMethod:
        """The method called ``text`` (its :attr:`name`); a one-line ValueError naming the
        methods for any other."""
        try:
            return _BY_NAME[text]
        except (KeyError, TypeError):
            raise ValueError(f"unknown method {text!r}; choose from "
                             f"{', '.join(_BY_NAME)}") from None

    @property
    def name(self) -> str:
        """The method's name in the outputs, e.g. ``"hog_adapted[body, paper eq.3]"``,
        ``"acf_pyramid_fast"``, ``"opencv_adapted"``; OpenCV's ``detectMultiScale``:
        ``"opencv"`` (4x), ``"opencv_2x"``, ``"opencv_native"``; a pyramid with the
        ground-plane filter, e.g. ``"opencv_2x[ground]"``."""
        extra = GROUND_TAG if self.ground else FOLD_TAG if self.fold else ""
        if self.kind in PRETRAINED_KINDS and self.how == "pyramid":
            return variant_label(self.kind + _PYRAMID_SUFFIX[self.upsample], extra=extra)
        return f"{self.kind}_{variant_label(self.how, self.rule, self.object_model, extra=extra)}"

    @property
    def detector(self):
        """The :class:`~viewadapt.detect.DetectorKind` of the method's detector (without its
        normalisation stage for a ``fold`` method)."""
        kind = detector_kind(self.kind)
        return kind.fold() if self.fold else kind

    @property
    def on_window_grid(self) -> bool:
        """Whether the method scores the candidate windows (adapted, warp), so that its
        detections move with the windows' ground grid (``grid_phase``); the pyramids slide
        their own windows over the frame."""
        return self.how in ("adapted", "warp")

    @property
    def needs_training(self) -> bool:
        """Whether the method reads the trained source detectors (all but OpenCV's)."""
        return self.kind not in PRETRAINED_KINDS


def _all_methods():
    out = []
    for kind in (*DETECTOR_KINDS, *PRETRAINED_KINDS):
        out += [FrameMethod(kind, "adapted", rule, model)
                for model in OBJECT_MODEL_TAGS for rule in RULE_TAGS]
        out += [FrameMethod(kind, how) for how in ("warp", "pyramid", "pyramid_fast")
                if kind in HOWS[how] and not (kind in PRETRAINED_KINDS and how == "pyramid")]
    # OpenCV's own detectMultiScale at each of its upsamplings
    out += [FrameMethod(k, "pyramid", upsample=u) for k in PRETRAINED_KINDS for u in UPSAMPLES[k]]
    return tuple(out) + tuple(replace(m, ground=True) for m in out if m.how.startswith("pyramid")) \
        + tuple(replace(m, fold=True) for m in out if m.how == "adapted"
                and m.detector.stages(m.object_model))


#: every method of the frames benchmark
FRAME_METHODS = _all_methods()
_BY_NAME = {m.name: m for m in FRAME_METHODS}
#: the methods ``bench frames`` runs by default, in its order
DEFAULT_METHODS = tuple(FrameMethod.parse(n) for n in (
    "hog_adapted", "hog_warp", "hog_pyramid", "opencv", "acf_adapted", "acf_warp",
    "acf_pyramid", "acf_pyramid_fast"))


def expand_adapted(methods, rules=None, object_models=None) -> list:
    """``methods`` (:class:`~benchmark.frames.spec.FrameMethod` s) with each adapted method
    replaced by one per object model and rule (each object model's rules in turn; a method's
    own rule or object model where ``rules`` or ``object_models`` is None), duplicates
    dropped; unchanged when both are None."""
    if not rules and not object_models:
        return list(methods)
    out = []
    for m in methods:
        if m.how != "adapted":
            out.append(m)
            continue
        out += [dataclasses.replace(m, rule=rule, object_model=model,
                                    fold=m.fold and model == "plane")
                for model in object_models or (m.object_model,) for rule in rules or (m.rule,)]
    return list(dict.fromkeys(out))


def method_arg(text) -> FrameMethod:
    """argparse type: the method called ``text`` (:meth:`FrameMethod.parse`), its error as
    argparse's."""
    import argparse

    try:
        return FrameMethod.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def frame_method(method) -> FrameMethod:
    """``method`` if it is a :class:`FrameMethod`, else the one it names
    (:meth:`FrameMethod.parse`)."""
    return method if isinstance(method, FrameMethod) else FrameMethod.parse(method)
