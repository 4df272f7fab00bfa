"""Feature types: which OpenCV detector/descriptor each name means, where to find its factory, and the
settings that define a target's feature configuration.

OpenCV 4.x has ``cv2.AKAZE_create`` and friends in the main module; OpenCV 5.x moved AKAZE, BRISK and KAZE
to ``cv2.xfeatures2d`` (which only the contrib wheels ship), and SURF is there only in builds with the
non-free algorithms. So every factory is looked up in both places, and a type that is missing gives one
clear error instead of an ``AttributeError`` deep in a frame loop.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import cv2

log = logging.getLogger(__name__)

#: Every feature type the detector knows, in the order the GUI lists them.
FEATURE_TYPES: tuple[str, ...] = ("ORB", "SIFT", "AKAZE", "BRISK", "KAZE", "SURF")

#: The detector parameters that belong to each type's configuration (and the OpenCV argument each sets).
#: Changing one of these changes the keypoints, so a stored target is recomputed; other parameters
#: (matching, homography) leave the target as it is.
TYPE_SETTINGS: Mapping[str, Mapping[str, str]] = {
    "ORB": {
        "max_features": "nfeatures",
        "orb_scale_factor": "scaleFactor",
        "orb_levels": "nlevels",
        "orb_fast_threshold": "fastThreshold",
    },
    "SIFT": {"max_features": "nfeatures", "sift_contrast_threshold": "contrastThreshold"},
    "AKAZE": {"akaze_threshold": "threshold"},
    "KAZE": {"kaze_threshold": "threshold"},
    "BRISK": {"brisk_threshold": "thresh"},
    "SURF": {"surf_hessian_threshold": "hessianThreshold"},
}

#: Every parameter name that is part of some feature configuration (its type's own settings).
FEATURE_PARAMETERS: frozenset[str] = frozenset({"feature_type"}.union(*(s.keys() for s in TYPE_SETTINGS.values())))
#: The parameters that decide a target's keypoints: the feature configuration, and how many tilted views of
#: the target add theirs (``view_synthesis``; every type, so it is not in TYPE_SETTINGS).
TARGET_PARAMETERS: frozenset[str] = FEATURE_PARAMETERS | {"view_tilts", "view_longitudes"}


def types_using(parameter: str) -> tuple[str, ...]:
    """The feature types whose configuration includes ``parameter`` (where a panel shows it)."""
    return tuple(t for t in FEATURE_TYPES if parameter in TYPE_SETTINGS[t])

_INSTALL_HINT = (
    "AKAZE, BRISK and KAZE live in cv2.xfeatures2d in OpenCV 5, which only the contrib wheels ship "
    "(pip install opencv-contrib-python-headless instead of opencv-python-headless)"
)


class FeatureUnavailable(ValueError):
    """The installed OpenCV cannot make this feature type (or homography method); says why and what helps."""


@dataclass(frozen=True)
class FeatureConfig:
    """The feature type and the settings that decide its keypoints and descriptors.

    A stored target records the configuration it was computed with; a detector must never match it
    with another one (SIFT descriptors against ORB ones would be numbers compared with nonsense).
    """

    type: str
    settings: tuple[tuple[str, Any], ...] = ()
    view_tilts: int = 0  # tilt levels of simulated oblique views whose keypoints join the target's
    view_longitudes: str = "all"  # at which longitudes those views are simulated (view_synthesis)

    @classmethod
    def from_parameters(cls, parameters: Any) -> FeatureConfig:
        """The configuration a detector's parameter snapshot (``detector.params``) selects."""
        feature_type = parameters.feature_type
        if feature_type not in TYPE_SETTINGS:
            raise ValueError(f"unknown feature type {feature_type!r} (known: {', '.join(FEATURE_TYPES)})")
        settings = tuple((name, getattr(parameters, name)) for name in TYPE_SETTINGS[feature_type])
        view_tilts = int(getattr(parameters, "view_tilts", 0))
        longitudes = str(getattr(parameters, "view_longitudes", "all")) if view_tilts else "all"
        return cls(feature_type, settings, view_tilts, longitudes)

    def to_dict(self) -> dict[str, Any]:
        """As written into a parameter file: ``{type: SIFT, max_features: 1000, ...}``. Without the views
        (``view_tilts``, ``view_longitudes``): they decide how many keypoints are recomputed from the stored
        image, not what a descriptor means, so a target saved with any views (or before they existed) loads
        with the current ones."""
        return {"type": self.type, **dict(self.settings)}

    def describe(self) -> str:
        pairs = list(self.settings)
        if self.view_tilts:
            pairs += [("view_tilts", self.view_tilts), ("view_longitudes", self.view_longitudes)]
        settings = ", ".join(f"{k}={v}" for k, v in pairs)
        return f"{self.type} ({settings})" if settings else self.type


def _lookup_factory(feature_type: str) -> Callable[..., Any] | None:
    """The ``XXX_create`` function, from ``cv2`` (OpenCV 4) or ``cv2.xfeatures2d`` (OpenCV 5, contrib)."""
    name = f"{feature_type}_create"
    factory = getattr(cv2, name, None)
    if factory is not None:
        return factory
    klass = getattr(cv2, feature_type, None)  # some builds only have cv2.AKAZE.create
    if klass is not None and callable(getattr(klass, "create", None)):
        return klass.create
    xfeatures2d = getattr(cv2, "xfeatures2d", None)
    if xfeatures2d is not None:
        return getattr(xfeatures2d, name, None)
    return None


@functools.cache
def unavailable_reason(feature_type: str) -> str | None:
    """None where this OpenCV can make the type; otherwise why not, in words a user can act on."""
    if feature_type not in TYPE_SETTINGS:
        return f"unknown feature type {feature_type!r} (known: {', '.join(FEATURE_TYPES)})"
    factory = _lookup_factory(feature_type)
    if factory is None:
        hint = _INSTALL_HINT if feature_type != "SURF" else "SURF needs an OpenCV contrib build with non-free"
        return f"{feature_type} is not available in the installed OpenCV {cv2.__version__}: {hint}"
    try:
        factory()  # SURF exists in contrib builds but refuses to be created without the non-free option
    except cv2.error as exc:
        message = str(exc).strip() or "cannot be created"
        message = message.split("error:", 1)[-1].strip()  # drop OpenCV's source path and line
        return f"{feature_type} cannot be created in the installed OpenCV {cv2.__version__}: {message}"
    return None


def available_feature_types() -> list[str]:
    """The types this OpenCV can make, for widgets and benchmarks."""
    return [t for t in FEATURE_TYPES if unavailable_reason(t) is None]


def unavailable_feature_types() -> dict[str, str]:
    """``{type: reason}`` for the types this OpenCV cannot make (the ``unavailable`` of ``feature_type``)."""
    return {t: reason for t in FEATURE_TYPES if (reason := unavailable_reason(t)) is not None}


def check_available(feature_type: str) -> None:
    """Raise FeatureUnavailable with the reason where the type cannot be made here."""
    reason = unavailable_reason(feature_type)
    if reason is not None:
        raise FeatureUnavailable(reason)


def create_feature2d(config: FeatureConfig) -> Any:
    """A new ``cv2.Feature2D`` for the configuration. New each time: OpenCV's feature objects are not
    documented as safe to share between threads, and the GUI thread recomputes targets while a worker
    detects."""
    check_available(config.type)
    factory = _lookup_factory(config.type)
    assert factory is not None  # check_available found it
    arguments = {TYPE_SETTINGS[config.type][name]: value for name, value in config.settings}
    return factory(**arguments)


def is_binary_norm(norm: int) -> bool:
    """Binary descriptors (ORB, BRISK, AKAZE's MLDB) compare by Hamming distance; float ones by L2."""
    return norm in (cv2.NORM_HAMMING, cv2.NORM_HAMMING2)


def descriptor_norm(extractor: Any, descriptors: Any | None = None) -> int:
    """The norm to compare these descriptors with: the extractor's own default (which knows that ORB
    with WTA_K 3 or 4 needs HAMMING2), checked against the descriptors' element type."""
    norm = int(extractor.defaultNorm())
    if descriptors is not None and descriptors.size:
        binary = descriptors.dtype == "uint8"
        if binary != is_binary_norm(norm):
            # Should not happen with OpenCV's own types; trust the data, which is what gets compared.
            log.warning("descriptor type %s disagrees with the extractor's norm %d", descriptors.dtype, norm)
            norm = cv2.NORM_HAMMING if binary else cv2.NORM_L2
    return norm
