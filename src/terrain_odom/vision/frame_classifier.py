"""One camera frame to one terrain label: region of interest, SFTA + colour features, KNN vote.

:class:`FrameClassifier` is the per-frame step of the run, pure (it takes a
decoded RGB image). It places the region of interest from the current wheel
speeds and ICR estimate
(:func:`~terrain_odom.vision.camera.region_of_interest`; the whole frame with
``use_roi=False``), classifies it, and returns a :class:`FrameClassification`
with the label and how far ahead the classified ground is: the distance to
the predicted pose at the region's centre, or with the whole frame to the
ground point at the image centre. (The ground at the region's pixel centre,
nearer because perspective gives near ground more pixels, did worse in
``bench/chen2023.py`` with 32-px tiles voting over the whole box:
terrain/no-terrain error 0.45, 0.50, 0.47 against 0.37, 0.51, 0.36.) Only
the tiles whose centre is inside the footprint's projection vote
(:func:`~terrain_odom.vision.features.tiles_within`).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from terrain_odom.config import RoiConfig
from terrain_odom.config.classifier import feature_parts
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.records import Sighting
from terrain_odom.vision.camera import GroundCamera, crop, region_of_interest

if TYPE_CHECKING:  # scikit-learn and the feature code load with a classifier, not with this module
    from terrain_odom.vision.classifier import TerrainClassifier

__all__ = ["FULL_FRAME", "FrameClassification", "FrameClassifier"]

FULL_FRAME = "full_frame"
"""``roi_status`` of a frame classified whole (``use_roi=False``)."""


@dataclass
class FrameClassification:
    """What was done with one frame.

    ``label`` is ``""`` and ``confidence``/``box`` are empty when the region
    of interest has no usable box (``roi_status`` ``outside`` or
    ``too_small``); ``ms_features`` is the feature-extraction (SFTA and
    colour) time and ``ms_knn`` the KNN vote's, ``ms_total`` includes the
    region of interest (and decoding, when the caller adds it); ``ahead`` is
    the distance from the robot to the classified ground, m;
    ``ms_features_full`` and ``ms_knn_full`` the same on the whole frame
    when that is timed for comparison; ``min_confidence`` the model's
    threshold of sightings (:attr:`sighting`,
    :attr:`~terrain_odom.vision.classifier.TerrainClassifier.sighting_threshold`).
    """

    t: float
    label: str = ""
    confidence: float = float("nan")
    box: tuple[int, int, int, int] | None = None
    ms_features: float = float("nan")
    ms_total: float = float("nan")
    roi_status: str = ""
    ahead: float = float("nan")
    ms_features_full: float = float("nan")
    ms_knn: float = float("nan")
    ms_knn_full: float = float("nan")
    min_confidence: float = 0.0

    @property
    def sighting(self) -> Sighting | None:
        """The terrain seen (label and distance ahead), for the terrain tracker.

        None without a label, and for a label of confidence 0 (unknown
        ground) or below the model's ``min_confidence`` (chosen from its
        cross-validated reliability): the tracker does not count such a frame.
        """
        if not self.label or not self.confidence > 0 or self.confidence < self.min_confidence:
            return None
        return Sighting(self.label, self.ahead)


class FrameClassifier:
    """Classify camera frames at the ground the robot is about to cover.

    Parameters
    ----------
    classifier : TerrainClassifier
    camera : GroundCamera
        Must match the frames' size (checked on every frame with ``use_roi``).
    roi : RoiConfig
    use_roi : bool
        False: classify the whole frame.
    time_full_frame : bool
        Also time features and KNN on the whole frame (its label is not
        used), for Chen's Table 2 comparison (see :meth:`classify`).
    """

    def __init__(
        self,
        classifier: TerrainClassifier,
        camera: GroundCamera,
        roi: RoiConfig,
        *,
        use_roi: bool = True,
        time_full_frame: bool = False,
    ) -> None:
        _check_feature_width(classifier)
        self.classifier = classifier
        self.camera = camera
        self.roi = roi
        self.use_roi = use_roi
        self.time_full_frame = time_full_frame

    def classify(
        self,
        t: float,
        image: np.ndarray,
        v_l: float,
        v_r: float,
        icr_params: np.ndarray,
        *,
        whole_first: bool = False,
    ) -> FrameClassification:
        """Classify one frame.

        Parameters
        ----------
        t : float
            Frame time, s (recorded only).
        image : ndarray, shape (height, width, 3)
            The frame, RGB, uint8.
        v_l, v_r : float
            Current track surface speeds, m/s.
        icr_params : ndarray, shape (3,) or (4,)
            Current ``y_l, y_r, x_icr(, alpha)``.
        whole_first : bool
            With ``time_full_frame``, time the whole frame before the region
            (else after it): alternated by the caller, so that each meets the
            cold caches of the first classification equally often.

        Returns
        -------
        FrameClassification

        Raises
        ------
        ConfigError
            With ``use_roi``, if the image size is not the camera's.
        InputFileError
            A grey frame (equal channels) given to a model with colour features.
        """
        started = time.perf_counter()
        height, width = image.shape[:2]
        camera = self.camera
        if self.use_roi and (width, height) != (camera.width, camera.height):
            raise ConfigError(
                f"image is {width}x{height} px but the camera configuration says "
                f"{camera.width}x{camera.height} (camera.width/height)"
            )
        self._check_colour(t, image)
        record = FrameClassification(t, min_confidence=self.classifier.sighting_threshold)
        if self.use_roi:
            result = region_of_interest(camera, self.roi, v_l, v_r, icr_params)
            record.roi_status = result.status.value
            record.box = result.box
            record.ahead = result.ahead
            region = footprint = None
            if result.box is not None:  # the footprint's tiles vote, not its bounding box's
                region = crop(image, result)
                footprint = result.image_polygon - np.array(result.box[:2], dtype=float)
        else:
            record.roi_status = FULL_FRAME
            record.box = (0, 0, width, height)
            record.ahead = self._image_centre_ahead
            region, footprint = image, None
        whole = self.time_full_frame and self.use_roi and region is not None
        whole_first = whole and whole_first
        if whole_first:
            record.ms_features_full, record.ms_knn_full = self._time_whole(image)
        if region is not None:
            (record.label, record.confidence), record.ms_features, record.ms_knn = (
                self._classify_timed(region, footprint)
            )
            record.ms_total = 1e3 * (time.perf_counter() - started)
            if whole_first:
                record.ms_total -= record.ms_features_full + record.ms_knn_full
        if whole and not whole_first:
            record.ms_features_full, record.ms_knn_full = self._time_whole(image)
        elif self.time_full_frame and not whole:
            record.ms_features_full, record.ms_knn_full = record.ms_features, record.ms_knn
        return record

    def _check_colour(self, t: float, image: np.ndarray) -> None:
        """Refuse a grey frame for a colour model: its colour features would be constant."""
        features = self.classifier.config.features
        if feature_parts(features)[1] is None:  # no colour statistics
            return
        sample = image[::8, ::8]
        if np.array_equal(sample[..., 0], sample[..., 1]) and np.array_equal(
            sample[..., 1], sample[..., 2]
        ):
            raise InputFileError(
                f"the frame at t = {t:g} s is grey (equal colour channels) but the model "
                f"uses {features} features (colour): give colour frames, or a model trained "
                "without colour (e.g. --features sfta)"
            )

    def _classify_timed(
        self, region: np.ndarray, footprint: np.ndarray | None
    ) -> tuple[tuple[str, float], float, float]:
        """``(label, confidence)``, feature time and KNN time (ms) of a region."""
        from terrain_odom.vision.features import image_features

        started = time.perf_counter()
        features = image_features(region, self.classifier.config, footprint)
        extracted = time.perf_counter()
        result = self.classifier.vote(features)
        return result, 1e3 * (extracted - started), 1e3 * (time.perf_counter() - extracted)

    def _time_whole(self, image: np.ndarray) -> tuple[float, float]:
        """Feature and KNN time on the whole frame, ms (its label is not used)."""
        return self._classify_timed(image, None)[1:]

    @functools.cached_property
    def _image_centre_ahead(self) -> float:
        """Distance to the ground at the image centre, m (0 if it is above the horizon)."""
        camera = self.camera
        centre = [(camera.width - 1) / 2.0, (camera.height - 1) / 2.0]
        ahead = float(np.hypot(*camera.backproject([centre])[0]))
        return ahead if np.isfinite(ahead) else 0.0


def _check_feature_width(classifier: TerrainClassifier) -> None:
    """Refuse a model whose training features are not what its settings describe.

    Raises
    ------
    InputFileError
        The width of the training features differs from that of the features
        its configuration computes (a damaged or hand-made model file).
    """
    from terrain_odom.vision.features import image_features

    config = classifier.config
    probe = np.random.default_rng(0).integers(0, 256, (64, 64, 3), dtype=np.uint8)
    expected = image_features(probe, config).shape[1]
    width = classifier.training_features.shape[1]
    if width != expected:
        raise InputFileError(
            f"the model's training features have {width} columns, but its settings "
            f"(features {config.features}, n_t {config.n_t}, pyramid_levels {config.pyramid_levels}) "
            f"compute {expected}: a damaged or hand-made model file; retrain it with "
            "'terrain-odom train'"
        )
