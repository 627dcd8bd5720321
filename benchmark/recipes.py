"""Source-training recipes: what a source detector is trained on, one object for every command.

A :class:`Recipe` says which window sets a source detector trains on besides the source
view's crops and background windows, and what happens to them first:

* added negatives -- the background windows turned about their centres by a few angles,
  read from the whole image so that no border enters. They decide how an adapted detector
  ranks the angle rules: the remap ``G = S (x) A`` (Wang et al. 2017) sends the target
  view's background gradients into orientation bins that elevation-0 backgrounds leave
  almost empty, and a model that never saw such backgrounds scores them as persons;
* the ACF model's members -- its boosted trees may be the average of several models, each
  trained with its own seed (:func:`viewadapt.ensembles.average_trees`: bagging, Breiman
  1996), which removes the part of the error that depends on the draw;
* scaled positives -- the source view's crops also magnified about their centres by a few
  (horizontal, vertical) factors, so that the detector meets persons a little taller,
  shorter, wider or narrower than its crops (the scale part of the jittered positives of
  Dollar's toolbox, ``jitterImage``: translations, rotations and scales);
* camera effects -- every training window, positives and negatives alike, through its own
  draw of a real camera's artefacts (:mod:`viewadapt.camera.effects`: blur, vignetting,
  white balance, exposure, sensor noise, tone curve, resolution, JPEG), so that a detector
  trained on clean renders meets them before it meets real footage (domain randomisation,
  Tobin et al. 2017).

Every command that trains (``bench crossval``, ``sweep``, ``frames``, ``runtime``,
``demo``, ``reproduce``) takes ``--recipe NAME`` and applies the one recipe to every method
that trains within a run (unadapted, adapted and image warping share the source model;
synthesised training and the oracle get the same treatment of their own view), and records
it in ``run.json`` and in the model files.

References
----------
.. [1] P. Wang, K. Morton, P. Torrione, L. Collins, "Viewpoint Adaptation for Rigid Object
   Detection", arXiv preprint, 2017.
.. [2] L. Breiman, "Bagging Predictors", Machine Learning 24(2), 1996.
.. [3] J. Tobin et al., "Domain Randomization for Transferring Deep Neural Networks from
   Simulation to the Real World", IROS 2017.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, replace

from viewadapt.arrays import is_int
from viewadapt.camera.effects import SURVEILLANCE_CAMERA, CameraEffects

__all__ = ["Recipe", "RECIPES", "DEFAULT_RECIPE", "PAPER_RECIPE", "SURVEILLANCE_CAMERA",
           "get_recipe", "add_recipe_argument", "recipe_from_record"]


@dataclass(frozen=True)
class Recipe:
    """One source-training recipe.

    Attributes
    ----------
    name : str
        Its name on the command line (``--recipe NAME``).
    summary : str
        One line for ``--help`` and reports.
    rotations_deg : tuple of float
        Besides the source view's background windows, the same windows turned by each of
        these angles (degrees, image coordinates) about their centres
        (:func:`benchmark.crops.features.rotated_windows`); () for none.
    camera : viewadapt.camera.effects.CameraEffects or None
        Every training window (positives and negatives alike) passes through its own draw
        of these camera effects, after any warp
        (:meth:`benchmark.crops.features.WindowSet.through_camera`); the test windows do
        not. None: the renders as they are.
    svm_c : float or None
        The HOG/SVM's regularisation ``C`` for every SVM the recipe trains (crops and
        frames alike); None: each trainer's own (Dalal & Triggs' 0.01:
        ``CrossvalConfig.C``, :func:`viewadapt.detect.training.hog_svm`).
    acf_members : int
        Every ACF model the recipe trains is the average of this many models, member ``k``
        trained with seed ``seed + k`` (:func:`viewadapt.ensembles.average_trees`, member 0
        gating the others); 1: one model, as before.
    positive_scales : tuple of (float, float)
        Besides the source view's crops, the same crops magnified about their centres by
        each ``(sx, sy)`` (across, down; :func:`benchmark.crops.features.scaled_windows`,
        borders replicated); () for none.
    """

    name: str
    summary: str
    rotations_deg: tuple = ()
    camera: CameraEffects | None = None
    svm_c: float | None = None
    acf_members: int = 1
    positive_scales: tuple = ()

    def __post_init__(self):
        import math
        import numbers

        try:
            scales = tuple((float(sx), float(sy)) for sx, sy in self.positive_scales)
        except (TypeError, ValueError):
            scales = None
        if (scales is None or len(set(scales)) != len(scales)
                or not all(0 < v < math.inf for sc in scales for v in sc)
                or (1.0, 1.0) in scales):
            raise ValueError(f"recipe {self.name!r}: positive_scales must be distinct (sx, sy) "
                             f"pairs of positive numbers other than (1, 1), got "
                             f"{self.positive_scales!r}")
        object.__setattr__(self, "positive_scales", scales)

        rot = tuple(float(a) for a in self.rotations_deg)
        if not all(math.isfinite(a) and a % 360 != 0 for a in rot) or len(set(rot)) != len(rot):
            raise ValueError(f"recipe {self.name!r}: rotations must be distinct finite angles, "
                             f"not multiples of 360, got {self.rotations_deg!r}")
        object.__setattr__(self, "rotations_deg", rot)
        if self.svm_c is not None and not (isinstance(self.svm_c, numbers.Real)
                                           and not isinstance(self.svm_c, bool)
                                           and 0 < self.svm_c < math.inf):
            raise ValueError(f"recipe {self.name!r}: svm_c must be a positive number or None, "
                             f"got {self.svm_c!r}")
        if not is_int(self.acf_members) or self.acf_members < 1:
            raise ValueError(f"recipe {self.name!r}: acf_members must be an integer >= 1, got "
                             f"{self.acf_members!r}")

    def svm_C(self, default: float) -> float:
        """The SVM's ``C`` under this recipe: :attr:`svm_c`, or ``default`` when it has none."""
        return float(default if self.svm_c is None else self.svm_c)

    def __str__(self) -> str:
        return self.name

    def negative_suffixes(self) -> tuple:
        """The key suffix of each added negative set (``"rot+30"``, ...), in order."""
        return tuple(f"rot{a:+.0f}" for a in self.rotations_deg)

    def positive_suffixes(self) -> tuple:
        """The key suffix of each added positive set (``"scale1x1.1"``, ...), in order."""
        return tuple(f"scale{sx:g}x{sy:g}" for sx, sy in self.positive_scales)

    def training_suffixes(self) -> list:
        """``(kind, suffix)`` of every window set a model trains on, in order: the
        positives (kind ``"person"``), the background windows and the added negatives
        (``"background"``); the suffix tells a set apart from the plain one (``""``,
        ``"rot+30"``, ``"cam"``, ``"rot+30|cam"``, ...)."""
        sets = ([("person", "")] + [("person", a) for a in self.positive_suffixes()]
                + [("background", "")]
                + [("background", a) for a in self.negative_suffixes()])
        if self.camera is not None:
            sets = [(k, f"{a}|cam" if a else "cam") for k, a in sets]
        return sets

    def training_sets(self, positives, background, warp=None) -> list:
        """``(kind, suffix, window set)`` of :meth:`training_suffixes`, built from the
        positives and the background windows (:class:`~benchmark.crops.features.WindowSet`
        s): the added negatives, each set through ``warp`` (a function of a window set, e.g.
        the synthesised rows' homography; None for none), then through the camera."""
        from benchmark.crops.features import rotated_windows, scaled_windows

        sets = ([positives] + [scaled_windows(positives, sx, sy)
                               for sx, sy in self.positive_scales]
                + [background] + [rotated_windows(background, a) for a in self.rotations_deg])
        if warp is not None:
            sets = [warp(ws) for ws in sets]
        if self.camera is not None:
            sets = [ws.through_camera(self.camera) for ws in sets]
        return [(k, a, ws) for (k, a), ws in zip(self.training_suffixes(), sets)]

    def to_dict(self) -> dict:
        """What ``run.json`` and the model files record."""
        out = {"name": self.name, "summary": self.summary,
               "rotations_deg": list(self.rotations_deg),
               "camera": None if self.camera is None else self.camera.to_dict()}
        if self.svm_c is not None:          # recipes without one keep their records
            out["svm_c"] = float(self.svm_c)
        if self.acf_members > 1:            # so do those of one ACF model
            out["acf_members"] = int(self.acf_members)
        if self.positive_scales:            # and those without scaled positives
            out["positive_scales"] = [list(sc) for sc in self.positive_scales]
        return out


def _rotated():
    from benchmark.crops.features import ROTATIONS_DEG

    return ROTATIONS_DEG


#: ``stretched``'s added positives (across, down); ``widened`` adds their mirror too.
_TALLER = ((1.0, 1.15), (1.0, 1.3))
#: ``averaged``, which ``scaled``, ``stretched`` and ``widened`` extend by their positives.
_AVERAGED = Recipe("averaged", "as regularised, and every ACF model the average of 9 boosted "
                               "models, each trained with its own seed (docs/training.md point "
                               "38)",
                   svm_c=0.001, acf_members=9)

#: The recipes by name. ``elevation0`` is the paper's training (source-view negatives only);
#: ``rotated`` adds the rotated background windows (docs/angle_rules_and_body_model.md,
#: "Retraining with other negatives"); ``regularised`` is the paper's windows with the
#: HOG/SVM's C chosen on the PETS 2009 development clip (docs/training.md point 24);
#: ``averaged`` is ``regularised`` with the ACF model averaged over 9 seeds, the number
#: chosen on rendered frames of another render (docs/training.md point 38); ``scaled`` is
#: ``averaged`` with every positive also 10 % shorter and 10 % taller (docs/training.md
#: point 68); ``stretched`` is ``averaged`` with every positive also 15 % and 30 % taller
#: (docs/training.md point 69), ``widened`` the same also shorter by as much (point 70).
RECIPES = {
    "elevation0": Recipe("elevation0", "the source view's background windows only (the "
                                       "paper's training)"),
    "rotated": Recipe("rotated", "the source view's background windows, and the same windows "
                                 "turned by +-30 and +-60 degrees about their centres",
                      rotations_deg=_rotated()),
    "camera": Recipe("camera", "as rotated, every training window through its own draw of "
                               "surveillance-camera effects (blur, vignetting, white "
                               "balance, exposure, sensor noise, gamma, resolution, JPEG)",
                     rotations_deg=_rotated(), camera=SURVEILLANCE_CAMERA),
    "regularised": Recipe("regularised", "the source view's background windows only, the "
                                         "HOG/SVM at C = 0.001 instead of 0.01 (a wider "
                                         "margin; docs/training.md point 24)",
                          svm_c=0.001),
    "averaged": _AVERAGED,
    "scaled": replace(_AVERAGED, name="scaled",
                      summary="as averaged, and every positive crop also magnified vertically "
                              "by 0.9 and by 1.1 about its centre (persons 10 % shorter and "
                              "taller; docs/training.md point 68)",
                      positive_scales=((1.0, 0.9), (1.0, 1.1))),
    "stretched": replace(_AVERAGED, name="stretched",
                         summary="as averaged, and every positive crop also magnified "
                                 "vertically by 1.15 and by 1.3 about its centre (persons up "
                                 "to 30 % taller, as an adapted detector whose elevation "
                                 "estimate is too high sees them; docs/training.md point 69)",
                         positive_scales=_TALLER),
    "widened": replace(_AVERAGED, name="widened",
                       summary="as stretched, and every positive crop also shrunk vertically "
                               "by 1/1.15 and by 1/1.3 about its centre (persons up to 30 % "
                               "taller and shorter; docs/training.md point 70)",
                       positive_scales=tuple((sx, 1 / sy) for sx, sy in reversed(_TALLER))
                       + _TALLER),
}
#: The recipe a command uses unless ``--recipe`` says otherwise: the recipe of the shipped
#: source detectors (``viewadapt/data/source_detectors.npz``), so that what a benchmark
#: trains is what ``viewadapt detect`` ships; how it was chosen: docs/training.md, "Defaults".
DEFAULT_RECIPE = "averaged"
#: The paper's training: ``reproduce``'s default (the paper's protocol on its clean renders),
#: and the recipe of the studies whose results the docs cite, so that their commands still
#: give those results.
PAPER_RECIPE = "elevation0"


def get_recipe(recipe) -> Recipe:
    """A :class:`Recipe` from its name (or the recipe itself); ``ValueError`` naming the
    choices for any other value."""
    if isinstance(recipe, Recipe):
        return recipe
    if isinstance(recipe, str) and recipe in RECIPES:
        return RECIPES[recipe]
    raise ValueError(f"unknown recipe {recipe!r}; choose one of {', '.join(RECIPES)}")


def recipe_from_record(record) -> Recipe | None:
    """The recipe a ``run.json`` or model file recorded (:meth:`Recipe.to_dict`), or None
    when it records none (files written before recipes existed) or one this version does
    not know under that name with those settings."""
    if not isinstance(record, dict) or record.get("name") not in RECIPES:
        return None
    r = RECIPES[record["name"]]
    return r if record == r.to_dict() else None


def add_recipe_argument(parser, *, what: str = "the source detectors",
                        default: str = DEFAULT_RECIPE, why: str = "") -> None:
    """``--recipe NAME`` on ``parser`` (default :data:`DEFAULT_RECIPE`, or ``default``
    with the reason ``why`` stated in the help)."""
    # argparse %-formats help texts: a summary's own "%" must reach it doubled
    lines = "; ".join(f"{r.name}: {r.summary}" for r in RECIPES.values()).replace("%", "%%")
    parser.add_argument("--recipe", type=_recipe_type, default=get_recipe(default),
                        metavar="NAME",
                        help=f"source-training recipe of {what}, the same for every method "
                             f"that trains (default {default}{why}): {lines}")


def _recipe_type(text: str) -> Recipe:
    try:
        return get_recipe(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
