"""FeatureDetector: find a selected, textured, flat object again by keypoints, descriptors and a homography.

A user selects a rectangle around the object once; the detector keeps the image of the selection and its
keypoints (the *target*). In each frame it computes keypoints and descriptors, matches them with the
target's, fits a homography to the matches and reports the selection's outline as it appears in the frame,
after checking that the outline is a plausible view of a flat object. When it reports nothing, the result's
``reason`` says why; its ``details`` are the frame's ``FeatureMatch`` and target, which the debug view draws.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from objrec_core import Bool, Change, Choice, Float, Int, Rect, SelectionRefused
from objrec_core.modules import Detections

from .base import ImageDetector, as_gray
from .features.debug import keypoints_view, side_by_side
from .features.geometry import (
    HOMOGRAPHY_METHODS,
    PolygonLimits,
    check_quadrilateral,
    estimate_homography,
    inlier_coverage,
    inside_convex,
    overlap,
    project_homogeneous,
    unavailable_homography_methods,
)
from .features.matching import MATCHERS, Matches, TrainedMatcher
from .features.refine import align_photometric, refine_homography
from .features.result import DetectionStatus, FeatureMatch, Instance
from .features.target import (
    Target,
    TargetError,
    compute_features,
    target_from_selection,
    target_from_state,
    target_to_state,
)
from .features.types import (
    FEATURE_TYPES,
    TARGET_PARAMETERS,
    FeatureConfig,
    FeatureUnavailable,
    check_available,
    create_feature2d,
    types_using,
    unavailable_feature_types,
)
from .features.view_synthesis import MAX_VIEW_TILTS, VIEW_LONGITUDES
from .messages import DetectedObject2D

log = logging.getLogger(__name__)

DEBUG_VIEWS = ("side_by_side", "keypoints")

#: What ``ready`` and a frame's reason say while no target is selected.
NO_TARGET = "no target: select one in objrec-define (drag a rectangle around the object)"
#: Attempts per frame beyond ``max_instances``: a copy found again (a duplicate) costs one and is not reported.
EXTRA_ATTEMPTS = 2


@dataclass(frozen=True)
class _Settings:
    """What a parameter snapshot decides that ``detect`` would otherwise work out again every frame: made once
    per snapshot (a snapshot is immutable and replaced on every change, so its identity says when)."""

    params: Any
    config: FeatureConfig
    limits: PolygonLimits

    @classmethod
    def of(cls, params: Any) -> _Settings:
        limits = PolygonLimits(params.min_area, params.max_area_fraction, params.min_corner_angle)
        return cls(params, FeatureConfig.from_parameters(params), limits)


@dataclass(frozen=True)
class _Model:
    """The target and a matcher trained on it, swapped together so a frame never sees one without the other."""

    target: Target
    matcher: TrainedMatcher | None  # None where the target has no keypoints with its configuration


class FeatureDetector(ImageDetector):
    """Finds the selected target by keypoint matching and a homography; see docs/feature-detection.md."""

    untuned = {"debug_view": "what the debug picture shows, not how the target is found"}  # noqa: RUF012

    # -- the feature configuration (changing any of these recomputes the target) -----------------------
    # Each type's own settings matter (and are shown) only while that type is chosen; types_using reads
    # TYPE_SETTINGS, the one table of which setting belongs to which type.
    feature_type = Choice(
        "ORB", FEATURE_TYPES, "Keypoint detector and descriptor: ORB is fastest, SIFT most robust; SURF needs non-free",
        unavailable=unavailable_feature_types,
    )
    max_features = Int(
        1000, "ORB, SIFT: the strongest keypoints kept per image", min=10, max=100000, soft_max=5000, step=10,
        relevant={"feature_type": types_using("max_features")},
    )
    orb_scale_factor = Float(
        1.2, "ORB: scale step between pyramid levels", min=1.01, max=2.0, step=0.05,
        relevant={"feature_type": types_using("orb_scale_factor")},
    )
    orb_levels = Int(
        8, "ORB: pyramid levels (more levels find the target over a wider range of sizes)", min=1, max=16,
        relevant={"feature_type": types_using("orb_levels")},
    )
    orb_fast_threshold = Int(
        20, "ORB: FAST corner threshold; lower finds more corners in flat images", min=1, max=100,
        relevant={"feature_type": types_using("orb_fast_threshold")},
    )
    sift_contrast_threshold = Float(
        0.04, "SIFT: minimum local contrast; lower finds more keypoints in low-contrast images",
        min=0.001, max=0.5, step=0.005, relevant={"feature_type": types_using("sift_contrast_threshold")},
    )
    akaze_threshold = Float(
        0.001, "AKAZE: detector response threshold", min=0.00001, max=0.1, step=0.0005,
        relevant={"feature_type": types_using("akaze_threshold")},
    )
    kaze_threshold = Float(
        0.001, "KAZE: detector response threshold", min=0.00001, max=0.1, step=0.0005,
        relevant={"feature_type": types_using("kaze_threshold")},
    )
    brisk_threshold = Int(
        30, "BRISK: AGAST corner threshold", min=1, max=255, relevant={"feature_type": types_using("brisk_threshold")}
    )
    surf_hessian_threshold = Float(
        400.0, "SURF: Hessian threshold", min=1.0, max=10000.0, soft_max=2000.0, step=50.0,
        relevant={"feature_type": types_using("surf_hessian_threshold")},
    )
    view_tilts = Int(
        0,
        "Tilt levels of simulated oblique views whose keypoints join the target's (as ASIFT): 1 squashes it 1.41x "
        "(seen 45 degrees off its normal), 2 also 2x (60 degrees), 3 also 2.83x (69 degrees). Finds a flat target "
        "seen steeply; matching time grows with the extra target keypoints (view_longitudes)",
        min=0, max=MAX_VIEW_TILTS,
    )
    view_longitudes = Choice(
        "all", VIEW_LONGITUDES,
        "Directions of the simulated squash: all (ASIFT's: 4 views at 1.41x, 5 at 2x, 8 at 2.83x; about 10x the "
        "target's keypoints at 2 tilts) or sideways (along its width only, one view per tilt: a camera at the "
        "target's height moving round it, as a robot's)",
        relevant=lambda values: values.get("view_tilts", 0) > 0,
    )
    # -- matching --------------------------------------------------------------------------------------
    matcher = Choice(
        "brute_force", MATCHERS, "brute_force is exact; flann (LSH for binary, KD-trees for float) suits big targets"
    )
    ratio_test = Bool(True, "Drop ambiguous matches (Lowe's ratio test)")
    ratio = Float(
        0.8, "Ratio test: best distance must be below this times the 2nd best", min=0.1, max=1.0, step=0.05,
        relevant={"ratio_test": (True,)},
    )
    cross_check = Bool(False, "Keep a match only if it is also the best the other way round")
    min_matches = Int(10, "Fewest good matches worth fitting a homography to", min=4, max=10000, soft_max=200)
    # -- homography and sanity checks ------------------------------------------------------------------
    homography_method = Choice(
        "USAC_MAGSAC", HOMOGRAPHY_METHODS, "Robust estimator: USAC_MAGSAC is the most accurate, RHO the fastest",
        unavailable=unavailable_homography_methods,
    )
    reprojection_threshold = Float(
        3.0, "Largest reprojection error of an inlier, in pixels (LMEDS ignores it)", min=0.1, max=50.0,
        soft_max=10.0, step=0.5,
        relevant={"homography_method": tuple(m for m in HOMOGRAPHY_METHODS if m != "LMEDS")},
    )
    homography_max_iterations = Int(
        20000,
        "Most samples the estimator draws (findHomography's maxIters); it stops sooner once confident, so more "
        "cost time only where inliers are few or absent. At 10 % inliers 2,000 find the model about half the "
        "time, 20,000 almost always (MAGSAC: at most 5 ms when nothing fits; RANSAC's samples cost 50x more)",
        min=10, max=1_000_000, soft_max=100_000,
        relevant={"homography_method": tuple(m for m in HOMOGRAPHY_METHODS if m != "LMEDS")},
    )
    homography_confidence = Float(
        0.999, "Confidence at which the estimator stops sampling (findHomography's confidence)",
        min=0.5, max=0.999999, step=0.001,
    )
    photometric_refinement = Bool(
        True,
        "After the keypoint fit, align the target's pixels with the frame's (correlation, a few ms per found copy): "
        "places the outline to a fraction of a pixel where keypoints alone leave it 1-2 px off (ORB); an "
        "alignment that fails is not taken, nor one that moves a corner more than reprojection_threshold and carries "
        "the keypoint inliers away (judged where at least 10 inliers are; with fewer, a move beyond 2x "
        "reprojection_threshold is not taken)",
    )
    min_inliers = Int(10, "Fewest homography inliers for a detection", min=4, max=10000, soft_max=200)
    min_inlier_coverage = Float(
        0.1, "Share of the selection the inliers must span; bunched or collinear inliers extrapolate badly",
        min=0.0, max=1.0, step=0.05,
    )
    min_area = Float(
        100.0, "Smallest plausible area of the found outline, in px²", min=0.0, max=1e7, soft_max=50000.0, step=10.0
    )
    max_area_fraction = Float(
        4.0, "Largest plausible area of the found outline, as a multiple of the frame's", min=0.01, max=100.0,
        soft_max=10.0, step=0.5,
    )
    min_corner_angle = Float(
        15.0, "Smallest corner angle of the found outline in degrees; flatter means squashed", min=0.0, max=89.0
    )
    # -- several copies of the target ------------------------------------------------------------------
    max_instances = Int(
        1,
        "Most copies of the target reported per frame; after each copy its matches and the keypoints inside "
        "its outline are set aside and the search repeats, with the same checks",
        min=1, max=100, soft_max=20,
    )
    max_instance_overlap = Float(
        0.5, "Overlap (intersection over union) above which a further outline is the same copy found again",
        min=0.0, max=1.0, step=0.05, relevant=lambda values: values.get("max_instances", 1) > 1,
    )
    # -- display ---------------------------------------------------------------------------------------
    debug_view = Choice(
        "side_by_side", DEBUG_VIEWS, "Stage view: frame and target side by side with matches, or keypoints on the frame"
    )

    def __init__(self, id: str | None = None, *, object_name: str | None = None, **parameters: Any) -> None:
        self._model: _Model | None = None
        self._model_lock = threading.RLock()
        self._failed: tuple[FeatureConfig, str] | None = None  # a recompute that failed, not retried per frame
        self._extractors = threading.local()  # each frame thread's own cv2.Feature2D, with its configuration
        self._settings: _Settings | None = None  # of the last snapshot a frame was detected with
        super().__init__(id, object_name=object_name, **parameters)

    # -- parameters ------------------------------------------------------------------------------------
    def parameters_changed(self, changed: set[str]) -> None:
        """A new feature configuration recomputes the target from its stored image right away (not at
        the next frame), so the GUI shows the new keypoints at once; too few of them is logged."""
        if changed & TARGET_PARAMETERS and self._model is not None:
            p = self.params
            model = self._model_for(FeatureConfig.from_parameters(p), p.matcher)
            needed = max(p.min_matches, p.min_inliers)
            if isinstance(model, _Model) and len(model.target) < needed:
                log.warning(
                    "%s: with %s the target has %d keypoints, fewer than the %d needed; it cannot be found",
                    self.label, model.target.config.describe(), len(model.target), needed,
                )

    # -- the target ------------------------------------------------------------------------------------
    @property
    def target(self) -> Target | None:
        """The current target (image, selection, keypoints, descriptors, configuration), or None."""
        model = self._model
        return model.target if model is not None else None

    def process_area_selection(self, rect: Rect, frame: np.ndarray) -> None:
        """Make the selected area the target; refuse (SelectionRefused) one with too few keypoints."""
        p = self.params
        config = FeatureConfig.from_parameters(p)
        try:
            _check_image(frame)
            target = target_from_selection(frame, rect, config)
        except (TargetError, FeatureUnavailable) as exc:
            raise SelectionRefused(str(exc)) from None
        needed = max(p.min_matches, p.min_inliers)
        if len(target) < needed:
            what = "no" if len(target) == 0 else f"only {len(target)}"
            plural = "" if len(target) == 1 else "s"
            raise SelectionRefused(
                f"the {target.rect.width}x{target.rect.height} px selection has {what} {config.type} keypoint{plural}, "
                f"{needed} are needed (min_matches/min_inliers): the area is too plain; select a textured one"
            )
        self._install(_Model(target, TrainedMatcher(target.descriptors, target.norm, p.matcher)))
        log.info("%s: target %s with %d %s keypoints", self.label, target.rect, len(target), config.type)
        self.notify([Change(self, "state")])

    def set_target(self, image: np.ndarray, rect: Rect | None = None) -> None:
        """Use ``rect`` of ``image`` (the whole image by default) as the target, as a selection would."""
        if rect is None:
            rect = Rect(0, 0, image.shape[1], image.shape[0])
        self.process_area_selection(rect, image)

    def clear_target(self) -> None:
        self._install(None)
        self.notify([Change(self, "state")])

    def _install(self, model: _Model | None) -> None:
        with self._model_lock:
            self._model = model
            self._failed = None

    def _model_for(self, config: FeatureConfig, matcher_kind: str) -> _Model | str:
        """The model for this configuration and matcher, recomputed from the stored image where they
        changed; or why there is none. Never a target computed with another configuration."""
        model = self._model
        if (
            model is not None
            and (model.target.config is config or model.target.config == config)
            and model.matcher is not None
            and model.matcher.kind == matcher_kind
        ):
            return model
        if model is None:
            return NO_TARGET
        with self._model_lock:
            model = self._model
            if model is None:
                return NO_TARGET
            target = model.target
            if target.config != config:
                if self._failed is not None and self._failed[0] == config:
                    return self._failed[1]
                try:
                    target = target.with_config(config)
                except (TargetError, FeatureUnavailable, cv2.error) as exc:
                    reason = f"the target cannot be recomputed with {config.describe()}: {exc}"
                    log.warning("%s: %s", self.label, reason)
                    self._failed = (config, reason)
                    return reason
                log.info("%s: target recomputed with %s: %d keypoints", self.label, config.describe(), len(target))
            matcher = model.matcher if target is model.target else None
            if len(target) == 0:
                matcher = None
            elif matcher is None or matcher.kind != matcher_kind:
                matcher = TrainedMatcher(target.descriptors, target.norm, matcher_kind)
            model = _Model(target, matcher)
            self._model = model
            self._failed = None
        return model

    # -- detection -------------------------------------------------------------------------------------
    def _frame_extractor(self, config: FeatureConfig) -> Any:
        """This thread's keypoint extractor: OpenCV's are not safe to share between threads running at once."""
        cached = getattr(self._extractors, "cached", None)
        if cached is None or (cached[0] is not config and cached[0] != config):  # one snapshot: one config object
            cached = (config, create_feature2d(config))
            self._extractors.cached = cached
        return cached[1]

    def detect(self, frame: np.ndarray) -> Detections:
        """Every copy of the target in the frame, up to ``max_instances``, the best supported first; the
        result's ``details`` are ``(FeatureMatch, target)``, its ``reason`` the match's when nothing was found.

        After each copy its inlier matches and the frame keypoints inside its outline are set aside and the
        remaining keypoints matched again (one-to-one, so copies do not compete for target keypoints); an
        outline overlapping one already found by more than ``max_instance_overlap`` is the same copy again
        and is not reported."""
        _check_image(frame)
        p = self.params
        settings = self._settings
        if settings is None or settings.params is not p:
            settings = self._settings = _Settings.of(p)  # one assignment: another frame thread sees old or new
        config = settings.config
        model = self._model_for(config, p.matcher)
        if isinstance(model, str):
            return self._finish(FeatureMatch(DetectionStatus.NO_TARGET, model, frame.shape), None)
        target = model.target
        if model.matcher is None:
            reason = f"the target has no {config.type} keypoints with these settings; select a textured area"
            return self._finish(FeatureMatch(DetectionStatus.NO_TARGET, reason, frame.shape), target)
        gray = as_gray(frame)
        keypoints, descriptors = compute_features(self._frame_extractor(config), gray)
        frame_points = cv2.KeyPoint_convert(keypoints).reshape(-1, 2) if keypoints else np.empty((0, 2), np.float32)
        if len(keypoints) < p.min_matches:
            reason = (
                f"too few keypoints in the frame: {len(keypoints)} {config.type} keypoints, min_matches is "
                f"{p.min_matches} (a plain, dark or blurred frame?)"
            )
            found = FeatureMatch(DetectionStatus.TOO_FEW_KEYPOINTS, reason, frame.shape, frame_points)
            return self._finish(found, target)
        candidates = model.matcher.candidates(descriptors, p.ratio if p.ratio_test else None)
        # The frame keypoints no copy found so far occupies; only a search for several copies sets any aside.
        available = np.ones(len(keypoints), dtype=bool) if p.max_instances > 1 else None
        instances: list[Instance] = []
        failed: FeatureMatch | None = None
        for _ in range(p.max_instances + EXTRA_ATTEMPTS):
            if len(instances) >= p.max_instances:
                break
            matches = model.matcher.select(candidates, descriptors, p.cross_check, available if instances else None)
            remaining = int(available.sum()) if instances and available is not None else len(keypoints)
            attempt = self._attempt(target, frame_points, matches, gray, frame.shape, remaining, settings.limits)
            if not isinstance(attempt, Instance):
                failed = attempt
                break
            if available is None:  # max_instances 1: nothing to set aside, no further copy is looked for
                instances.append(attempt)
                break
            available[matches.frame_idx[attempt.inliers]] = False
            available &= ~inside_convex(frame_points, attempt.quadrilateral)
            same = [overlap(attempt.quadrilateral, other.quadrilateral) for other in instances]
            if same and max(same) > p.max_instance_overlap:
                log.debug("%s: a copy overlapping one already found by %.0f %% set aside", self.label, max(same) * 100)
                continue
            instances.append(attempt)
        if not instances:
            assert failed is not None  # the first attempt either found a copy or failed
            return self._finish(failed, target)
        if len(instances) > 1:
            instances.sort(key=lambda instance: -instance.inlier_count)  # best supported first
        first = instances[0]
        next_reason = None
        if len(instances) < p.max_instances:
            next_reason = failed.reason if failed is not None else "further attempts found only copies already reported"
        found = FeatureMatch(
            DetectionStatus.FOUND, None, frame.shape, frame_points, first.matches, first.inliers, first.homography,
            first.quadrilateral, first.coverage, tuple(instances), next_reason,
        )
        # Each outline is handed over as it is (no copy): nothing changes a found copy's quadrilateral.
        objects = DetectedObject2D.outlined(
            self.object_name, [i.quadrilateral for i in instances], [False] * len(instances)
        )
        return self._finish(found, target, objects)

    def _attempt(
        self,
        target: Target,
        frame_points: np.ndarray,
        matches: Matches,
        gray: np.ndarray,
        frame_shape: tuple[int, ...],
        keypoints: int,
        limits: PolygonLimits,
    ) -> Instance | FeatureMatch:
        """One copy of the target from these matches in the frame ``gray``, or the failed attempt with the reason:
        every check a copy must pass, in order. ``keypoints`` is how many frame keypoints were still available."""
        p = self.params

        def failed(status: DetectionStatus, reason: str, **known: Any) -> FeatureMatch:
            # The record is made only for a failed attempt, with what was learnt up to the failing check: a
            # found copy's is made once in ``detect``, not rebuilt at every check.
            return FeatureMatch(status, reason, frame_shape, frame_points, matches, **known)

        if len(matches) < p.min_matches:
            reason = f"too few matches: {len(matches)} of {keypoints} keypoints, min_matches is {p.min_matches}"
            return failed(DetectionStatus.TOO_FEW_MATCHES, reason)
        source, destination = target.points[matches.target_idx], frame_points[matches.frame_idx]
        homography, inliers = estimate_homography(
            source,
            destination,
            p.homography_method,
            p.reprojection_threshold,
            p.homography_max_iterations,
            p.homography_confidence,
        )
        if homography is not None:
            homography, inliers = refine_homography(source, destination, homography, inliers, p.reprojection_threshold)
        if homography is None:
            reason = (
                f"no homography fits the {len(matches)} matches "
                f"({p.homography_method}, homography_max_iterations is {p.homography_max_iterations})"
            )
            return failed(DetectionStatus.NO_HOMOGRAPHY, reason, inliers=inliers, homography=homography)
        count = np.count_nonzero(inliers)
        if count < p.min_inliers:
            reason = f"too few inliers: {count} of {len(matches)} matches, min_inliers is {p.min_inliers}"
            return failed(DetectionStatus.TOO_FEW_INLIERS, reason, inliers=inliers, homography=homography)
        roi = target.roi
        inlier_source = source[inliers]
        coverage = inlier_coverage(inlier_source, roi.width * roi.height)
        if coverage < p.min_inlier_coverage:
            reason = (
                f"inliers bunched: they span {coverage:.0%} of the target, "
                f"min_inlier_coverage is {p.min_inlier_coverage:.0%}"
            )
            return failed(DetectionStatus.BUNCHED_INLIERS, reason, inliers=inliers, homography=homography,
                          coverage=coverage)
        quadrilateral, w = project_homogeneous(homography, target.corners_homogeneous)
        problem = check_quadrilateral(quadrilateral, w, frame_shape, limits)
        if problem is not None:
            return failed(DetectionStatus.DEGENERATE_POLYGON, f"degenerate polygon: {problem}", inliers=inliers,
                          homography=homography, coverage=coverage, quadrilateral=quadrilateral)
        if p.photometric_refinement:
            pairs = (inlier_source, destination[inliers])
            homography, quadrilateral = self._aligned(target, gray, homography, quadrilateral, limits, pairs)
        return Instance(matches, inliers, homography, quadrilateral, coverage)

    def _aligned(self, target: Target, gray: np.ndarray, homography: np.ndarray, quadrilateral: np.ndarray,
                 limits: PolygonLimits, inlier_pairs: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The homography and outline after the photometric refinement; the keypoint fit's where it is not taken.
        The fit's inliers (target and frame positions) judge a correction larger than reprojection_threshold."""
        roi = target.roi
        threshold = self.params.reprojection_threshold
        refined, outline, why = align_photometric(target.gray, (roi.x, roi.y, roi.width, roi.height), gray, homography,
                                                  2.0 * threshold, inlier_pairs, threshold, quadrilateral)
        if refined is None or outline is None:
            log.debug("%s: keypoint fit kept: %s", self.label, why)
            return homography, quadrilateral
        aligned, w = outline
        if check_quadrilateral(aligned, w, gray.shape, limits) is not None:
            return homography, quadrilateral
        return refined, aligned

    def _finish(self, result: FeatureMatch, target: Target | None, objects: list[DetectedObject2D] | None = None
                ) -> Detections:
        if log.isEnabledFor(logging.DEBUG):  # not even the label is worked out per frame otherwise
            log.debug("%s: %s", self.label, result.reason or "found")
        return Detections(objects or [], result.reason, (result, target))

    def ready(self) -> str | None:
        """None when a target is selected that can be found with the current settings; else why not."""
        p = self.params
        model = self._model_for(FeatureConfig.from_parameters(p), p.matcher)
        if isinstance(model, str):
            return model
        needed = max(p.min_matches, p.min_inliers)
        if len(model.target) < needed:
            what = "no" if len(model.target) == 0 else f"only {len(model.target)}"
            return (
                f"the target has {what} {p.feature_type} keypoints with these settings, {needed} are needed "
                "(min_matches/min_inliers): select a textured area"
            )
        return None

    # -- views -----------------------------------------------------------------------------------------
    def render_debug(self, frame: np.ndarray, objects: list[Any]) -> np.ndarray | None:
        """The stage view: the side-by-side match view (default) or keypoints on the frame, drawn from the
        details ``objects`` (this frame's ``detect`` result) carries."""
        details = getattr(objects, "details", None)
        result, target = details if details is not None else (None, self.target)
        if result is not None and tuple(result.frame_shape[:2]) != tuple(frame.shape[:2]):
            result = None  # a result from another frame would put points in the wrong places
        if self.params.debug_view == "keypoints":
            return keypoints_view(frame, result)
        return side_by_side(frame, target, result)

    # -- the parameter file ----------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any] | None:
        """``{target: {features, rect, roi, keypoints, opencv, image_encoding, image}}``, or None without a
        target. ``features`` is the configuration the current parameters select, which is the one the
        keypoints are recomputed with on load."""
        model = self._model
        if model is None:
            return None
        config = FeatureConfig.from_parameters(self.params)
        target = model.target
        if target.config != config:
            state = target_to_state(target)
            state["features"] = config.to_dict()
            return {"target": state}
        return {"target": target_to_state(target)}

    def prepare_state(self, state: Any, parameters: Mapping[str, Any]) -> _Model | None:
        """Decode the saved target and recompute its keypoints with the configuration ``parameters``
        select, which must be the saved one; nothing here changes the detector."""
        p = self.Parameters(**{**self.default_values(), **parameters})
        check_available(p.feature_type)
        if state is None:
            return None
        if not isinstance(state, Mapping) or set(state) != {"target"}:
            raise ValueError(f"expected a mapping with the single key 'target', found {state!r:.80}")
        target = target_from_state(state["target"], FeatureConfig.from_parameters(p))
        matcher = TrainedMatcher(target.descriptors, target.norm, p.matcher) if len(target) else None
        return _Model(target, matcher)

    def apply_state(self, prepared: _Model | None) -> None:
        self._install(prepared)


def _check_image(frame: Any) -> None:
    """Keypoint detectors take 8-bit images only; say so here rather than in an OpenCV assertion."""
    if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.ndim not in (2, 3) or frame.size == 0:
        what = f"{frame.dtype} array of shape {frame.shape}" if isinstance(frame, np.ndarray) else type(frame).__name__
        raise TargetError(f"FeatureDetector needs an 8-bit image (H x W or H x W x 3), got a {what}")
