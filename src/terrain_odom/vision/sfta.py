"""SFTA texture features (Chen et al. 2023, §3.2.1, eq. 18-21; Costa et al. 2012).

Segmentation-based fractal texture analysis describes an image by ``2 * n_t``
binary images cut from its grey levels, and each binary image by three
numbers: the box-counting fractal dimension ``D`` of its border, its size
``C`` and its mean grey level ``G``. With Chen's ``n_t = 4`` that is 24
values, ``[D_1, C_1, G_1, ..., D_8, C_8, G_8]``.

How the paper is read here
--------------------------
**Grey image (eq. 18)**: ``I_G = 0.30 R + 0.59 G + 0.11 B`` rounded to the
nearest integer, halves up, i.e. exactly ``(30 R + 59 G + 11 B + 50) // 100``
for every one of the 2**24 colours (:func:`to_grey`). OpenCV images are BGR:
pass ``colour_order="bgr"``.

**Thresholds**: the ``n_t`` multi-level Otsu thresholds ``T(1) < ... <
T(n_t)`` of the grey histogram (:func:`multiotsu_thresholds`). A threshold is
the highest grey level of the class below it: class ``k`` is
``T(k-1) < grey <= T(k)``, as in ``skimage.filters.threshold_multiotsu``.

**Binary images (eq. 19-20)**. Eq. 20 prints ``TB(i) = (0, T(i))`` for
``i <= n_t`` and ``(T(i - n_t), T(i + 1 - n_t))`` for ``i > n_t``, with
``T(n_t + 1) = 255``. With the threshold convention above, and so that every
pixel is in at least one image, the ranges are read as

- ``i = 1 .. n_t``: ``0 <= grey <= T(i)`` (everything up to threshold ``i``);
- ``i = n_t + 1 .. 2 n_t``: ``T(i - n_t) < grey <= T(i + 1 - n_t)`` (the band
  between consecutive thresholds; the last band ends at 255).

The bands are Costa's ``{t_i, t_(i+1)}`` pairs and his ``{t_n_t, n_l}`` pair.
Costa's first family is ``grey > t_i`` (his ``{t_i, n_l}`` pairs), the
complement of Chen's ``grey <= T(i)``; this module follows Chen. Costa's
reference code returns ``6 n_t - 3`` values; Chen's text, followed here,
describes ``2 n_t`` images and ``6 n_t`` values.

**Borders (eq. 21)**: a pixel of a binary image is a border pixel if it is 1
and at least one of its 8 neighbours *inside the image* is 0 (Chen: "its
eight adjacent pixels exist"). Pixels outside the frame do not count as 0,
so the image frame is not a border: a binary image that is all ones has no
border. Costa's ``findBorders`` (padding with ones) does the same.

**D_i**: the box-counting dimension of the border map
(:func:`box_counting_dimension`): boxes of side ``s = 1, 2, 4, ...`` on a grid
anchored at the top-left pixel (partial boxes at the right and bottom edges
count), ``N(s)`` the number of boxes holding at least one border pixel, ``D``
the least-squares slope of ``log N(s)`` against ``log(1 / s)`` over the box
sizes before the first at which *every* box is occupied (at least
``s = 1, 2``). Costa's ``hausDim`` fits all sizes up to the image size; but
once every box is occupied ``N(s)`` is the number of boxes whatever the set,
and these sizes pull every estimate towards 2: a circle inscribed in a
512x512 image reads 1.12 with all sizes, 0.99 here (a line 1.00, an
inscribed disc 1.96, a filled square 2.00). On the indoor floor photos the
two fits classify equally well (5-fold 1-NN on standardised SFTA: 77.6 % here,
77.0 % with all sizes).

**C_i**: Chen: "the number of non-zero value pixel points" of the binary
image, so here the binary image's pixel count (not the size of its border as
in Costa's code), **as a fraction of the image area**, in [0, 1]: a raw count
scales with the image size, and a region of interest must be comparable
with training images of another size. ``C_i * H * W`` is the raw count.

**G_i**: the mean grey level (0-255) of the binary image's pixels.

C_i and G_i come from the grey histogram alone; D_i needs the pixels.

Degenerate input
----------------
Every value is finite for any non-empty image:

- An image with ``d <= n_t`` distinct grey levels (uniform or saturated
  patches) has no proper ``n_t``-threshold split: the thresholds are its
  levels but the highest, then the highest level repeated
  (:func:`multiotsu_thresholds`), so some bands are empty.
- An empty binary image has ``C = 0``, ``D = 0`` and ``G`` = the middle of
  its grey range (``T(i) / 2``, or ``(T(i - n_t) + T(i + 1 - n_t)) / 2``).
- An empty border (a binary image that is empty or fills the frame) and a
  border of a single box at every scale (one pixel, or a 1x1 image) have
  ``D = 0``.
- Images smaller than 8x8, down to 1x1, need no special case.

Speed
-----
``bench/sfta.py`` measures it: on one core of the 2-core development machine,
with another job running, medians of about 1.4 ms for a 640x480 RGB frame
(0.3 times its PNG decoding) and 0.3 ms for a 160x120 crop.

- Thresholds: an exact dynamic programme over the histogram
  (:func:`multiotsu_thresholds`), a compiled loop in float32
  (:func:`~terrain_odom.vision._kernels.otsu_dp`).
- All ``2 n_t`` binary images are bit planes of one uint8 image (bit
  ``i - 1`` is image ``i``; ``n_t > 4`` uses one uint8 image per 8 images),
  made by one look-up-table pass over the grey image.
- The 8 borders at once: the planes minus their erosion by the 3x3 square,
  the erosion being a bitwise AND of shifted views.
- Box counts of the 8 borders at once: OR-pooling 2x2 blocks level by level
  (a transposition between the row and the column halving), and a 256-bin
  histogram of each level times a 256x8 bit table. The pooling stops as soon
  as every bit is set in all boxes or in none.
- C_i and G_i from the grey histogram: no per-pixel work.

References
----------
.. [1] Chen, Wu, Zeng, Du, "Kinematics Model Estimation of 4W Skid-Steering
   Mobile Robots Using Visual Terrain Classification", Journal of Robotics,
   2023, §3.2.1, eq. 18-21.
.. [2] Costa, Humpire-Mamani, Traina, "An efficient algorithm for fractal
   analysis of textures", SIBGRAPI 2012.
.. [3] Liao, Chen, Chung, "A fast algorithm for multilevel thresholding",
   Journal of Information Science and Engineering 17(5), 2001.
"""

from __future__ import annotations

import functools
import itertools
from typing import Any, Literal

import cv2
import numpy as np
from cv2.typing import MatLike
from numpy.typing import NDArray

__all__ = [
    "N_THRESHOLDS",
    "to_grey",
    "multiotsu_thresholds",
    "sfta_features",
    "box_counting_dimension",
]

N_THRESHOLDS = 4
"""Chen's ``n_t``: 4 thresholds, 8 binary images, 24 features."""

ColourOrder = Literal["rgb", "bgr"]

_N_LEVELS = 256
_LEVEL_INDEX = np.arange(_N_LEVELS)
# Rows: pixel count and grey sum of a histogram (times hist).
_MOMENT_WEIGHTS = np.stack((np.ones(_N_LEVELS), np.arange(_N_LEVELS, dtype=np.float64)))
_COLOUR_ORDERS = ("rgb", "bgr")
# _BITS[v, i] = bit i of byte v.
_BITS = np.unpackbits(
    np.arange(_N_LEVELS, dtype=np.uint8)[:, None], axis=1, bitorder="little"
).astype(np.float64)
_FLOAT32_EXACT = 2**24  # integers below this are exact in float32
_EPS: dict[type[np.floating[Any]], float] = {
    dtype: float(np.finfo(dtype).eps) for dtype in (np.float32, np.float64)
}
_CALCHIST_EXACT = 2**24  # cv2.calcHist counts in float32


def to_grey(image: NDArray, *, colour_order: ColourOrder = "rgb") -> NDArray[np.uint8]:
    """Grey image of eq. 18: ``0.30 R + 0.59 G + 0.11 B``, rounded, halves up.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3) or (H, W)
        Colour image in `colour_order`, or a grey image, which is returned as
        is (not copied). Float images are refused rather than guessed at
        (0-1 or 0-255?): convert them first, e.g.
        ``(image * 255).round().astype(np.uint8)``.
    colour_order : {"rgb", "bgr"}
        Channel order of a colour image; OpenCV's ``imread`` gives "bgr".

    Returns
    -------
    ndarray of uint8, shape (H, W)
        ``(30 R + 59 G + 11 B + 50) // 100``.

    Raises
    ------
    ValueError
        If the image is not uint8, not (H, W) or (H, W, 3), or `colour_order`
        is unknown.

    Examples
    --------
    >>> to_grey(np.array([[[100, 150, 200]]], dtype=np.uint8)).tolist()  # 140.5
    [[141]]
    >>> to_grey(np.array([[[200, 150, 100]]], dtype=np.uint8), colour_order="bgr").tolist()
    [[141]]
    """
    image = _checked(image, colour_order)
    return image if image.ndim == 2 else _grey(image, colour_order)


def _checked(image: NDArray, colour_order: ColourOrder) -> NDArray:
    """``image`` as an array, or raise :func:`to_grey`'s errors."""
    if colour_order not in _COLOUR_ORDERS:
        raise ValueError(f"colour_order must be 'rgb' or 'bgr', not {colour_order!r}")
    image = np.asarray(image)
    if image.dtype != np.uint8:
        raise ValueError(
            f"image must be uint8, got {image.dtype}; convert a float image in [0, 1] "
            "with (image * 255).round().astype(np.uint8)"
        )
    if image.ndim != 2 and (image.ndim != 3 or image.shape[2] != 3):
        raise ValueError(f"image must have shape (H, W) or (H, W, 3), got {image.shape}")
    return image


def _grey(image: NDArray, colour_order: ColourOrder) -> NDArray[np.uint8]:
    """:func:`to_grey` of a checked colour image."""
    from terrain_odom.vision._kernels import grey_levels

    rgb = image if colour_order == "rgb" else image[..., ::-1]
    grey = np.empty(image.shape[:2], dtype=np.uint8)
    grey_levels(np.ascontiguousarray(rgb).ravel(), grey.ravel())
    return grey


def _grey_and_histogram(image: NDArray, colour_order: ColourOrder) -> tuple[NDArray, NDArray]:
    """:func:`to_grey` of a checked image and its 256-bin histogram."""
    if image.ndim == 2:
        return image, _histogram(image)
    from terrain_odom.vision._kernels import byte_histogram

    grey = _grey(image, colour_order)
    return grey, byte_histogram(grey.ravel()).astype(np.float64)


def multiotsu_thresholds(hist: NDArray, n_t: int) -> NDArray[np.uint8]:
    """Exact multi-level Otsu thresholds of a 256-bin grey histogram.

    The ``n_t`` thresholds split the grey levels into ``n_t + 1`` classes
    ``T(k-1) < grey <= T(k)`` that maximise the between-class variance
    (equivalently ``sum_k S_k**2 / P_k`` over classes of pixel count ``P_k``
    and grey sum ``S_k``). Found by dynamic programming over the non-empty
    levels, ``O(n_t * 256**2)``; ``skimage.filters.threshold_multiotsu``
    searches all ``O(256**n_t)`` combinations.

    Parameters
    ----------
    hist : array_like, shape (256,)
        Pixel count (a non-negative integer) of each grey level 0-255.
    n_t : int
        Number of thresholds, >= 1.

    Returns
    -------
    ndarray of uint8, shape (n_t,)
        Non-decreasing thresholds; each is the highest grey level of the
        class below it. With ``d > n_t`` distinct levels they are strictly
        increasing, the exact optimum, and on exact ties the
        lexicographically smallest. With ``d <= n_t`` distinct levels they
        are the levels but the highest, then the highest level repeated:
        every level is a class and the remaining classes are empty
        (skimage raises).

    Raises
    ------
    ValueError
        If `hist` is not 256 non-negative integer counts with a positive
        total, or ``n_t < 1``.

    Notes
    -----
    The same as ``skimage.filters.threshold_multiotsu(image, classes=n_t +
    1)`` wherever skimage's search resolves the optimum. skimage accumulates
    in float32 and adds the lowest level's probability to the first class's
    first moment; so where two candidates differ by less than about 1e-7 of
    the criterion (e.g. thresholds in a run of empty levels) and on exact
    ties it can return another, worse or equal, candidate.

    The dynamic programme runs in float32 when the partial sums and their
    differences are exact in float32 (integers below 2**24, with grey levels
    taken relative to the mean) and keeps that answer only if, at every
    choice along the optimal path, the best candidate beats the second by
    more than twice a bound on the rounding error, so that exact arithmetic
    would choose the same; else it runs in float64. About 7 % of 160x120
    crops of real photos have such a near tie (candidates within ~4e-7 of
    the criterion) and take the float64 path, about 0.15 ms longer.

    Examples
    --------
    >>> hist = np.zeros(256, dtype=int)
    >>> hist[[10, 20, 200, 210]] = 100
    >>> multiotsu_thresholds(hist, 1).tolist()
    [20]
    >>> multiotsu_thresholds(hist, 3).tolist()
    [10, 20, 200]
    """
    hist = np.asarray(hist, dtype=np.float64)
    if hist.shape != (_N_LEVELS,) or np.any((hist < 0) | (hist != np.round(hist))):
        raise ValueError("hist must hold 256 non-negative integer counts")
    if not hist.sum() > 0:
        raise ValueError("hist is empty: its counts sum to 0")
    if n_t < 1:
        raise ValueError(f"n_t must be >= 1, got {n_t}")
    return _thresholds(_MOMENT_WEIGHTS * hist, n_t)


def sfta_features(
    image: NDArray, n_t: int = N_THRESHOLDS, *, colour_order: ColourOrder = "rgb"
) -> NDArray[np.float64]:
    """SFTA feature vector of an image (Chen et al. 2023, eq. 18-21).

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3) or (H, W)
        Colour image in `colour_order`, or grey image; any size >= 1x1.
    n_t : int
        Number of Otsu thresholds, >= 1 (Chen: 4).
    colour_order : {"rgb", "bgr"}
        Channel order of a colour image.

    Returns
    -------
    ndarray of float64, shape (6 * n_t,)
        ``[D_1, C_1, G_1, ..., D_2nt, C_2nt, G_2nt]`` for the binary images
        ``i = 1 .. 2 n_t`` (module docstring): ``D_i`` box-counting dimension
        of the border (0 to 2), ``C_i`` pixel count as a fraction of
        ``H * W`` (0 to 1), ``G_i`` mean grey level (0 to 255). Always finite.

    Raises
    ------
    ValueError
        For an empty image, ``n_t < 1``, and as :func:`to_grey`.

    Examples
    --------
    >>> left_dark = np.full((64, 64), 200, dtype=np.uint8)
    >>> left_dark[:, :32] = 50
    >>> features = sfta_features(left_dark).reshape(8, 3)  # rows D, C, G
    >>> features[0].round(9).tolist()  # grey <= T(1) = 50: the left half, border one column
    [1.0, 0.5, 50.0]
    >>> features[4].round(9).tolist()  # 50 < grey <= T(2) = 200: the right half
    [1.0, 0.5, 200.0]
    """
    if n_t < 1:
        raise ValueError(f"n_t must be >= 1, got {n_t}")
    image = _checked(image, colour_order)
    if image.size == 0:
        raise ValueError(f"image is empty: shape {image.shape[:2]}")
    grey, hist = _grey_and_histogram(image, colour_order)
    moments = _MOMENT_WEIGHTS * hist
    thresholds = _thresholds(moments, n_t)
    planes, luts = _class_tables(n_t)
    classes = thresholds.searchsorted(_LEVEL_INDEX)  # thresholds below each level
    count, grey_sum = np.dot(moments, planes[classes])
    dimensions = _border_dimensions(grey, luts[:, classes], 2 * n_t)
    if count.all():
        mean_grey = grey_sum / count
    else:  # empty binary images: the middle of their grey range
        middles = np.array(_range_middles(thresholds))
        mean_grey = np.divide(grey_sum, count, out=middles, where=count > 0)
    return np.array((dimensions, count / grey.size, mean_grey)).T.ravel()


def box_counting_dimension(binary: NDArray) -> float:
    """Box-counting dimension of the non-zero pixels of a 2-D image.

    Boxes of side ``s = 1, 2, 4, ...`` on a grid anchored at pixel (0, 0),
    partial boxes at the right and bottom edges included; ``N(s)`` boxes
    hold a non-zero pixel; the dimension is the least-squares slope of
    ``log N(s)`` against ``log(1 / s)`` over the sizes before the first at
    which every box is occupied, and at least ``s = 1, 2`` (module
    docstring). In a 512x512 image: a straight line 1, a circle outline
    0.99, an inscribed disc 1.96, a square 2.

    Parameters
    ----------
    binary : array_like, shape (H, W)
        Image; non-zero (True) pixels are the set.

    Returns
    -------
    float
        The dimension, in [0, 2]; 0 for an empty set, a single pixel or a
        1x1 image.

    Raises
    ------
    ValueError
        If `binary` is not a non-empty 2-D array.

    Examples
    --------
    >>> line = np.zeros((64, 64), dtype=bool)
    >>> line[10, :] = True
    >>> round(box_counting_dimension(line), 9)
    1.0
    >>> round(box_counting_dimension(np.ones((64, 64), dtype=bool)), 9)
    2.0
    """
    binary = np.asarray(binary)
    if binary.ndim != 2 or binary.size == 0:
        raise ValueError(f"binary must be a non-empty 2-D image, got shape {binary.shape}")
    from terrain_odom.vision._kernels import box_counts

    hists, boxes = box_counts(np.ascontiguousarray(binary != 0, dtype=np.uint8))
    return float(_dimensions(np.dot(hists, _BITS)[:, :1], boxes[:, None])[0])


def _histogram(grey: MatLike) -> NDArray:
    """Pixel count of each grey level, shape (256,), exact."""
    if grey.size >= _CALCHIST_EXACT:
        return np.bincount(grey.ravel(), minlength=_N_LEVELS)
    return cv2.calcHist([grey], [0], None, [_N_LEVELS], [0, _N_LEVELS]).ravel()


def _thresholds(moments: NDArray[np.float64], n_t: int) -> NDArray[np.uint8]:
    """:func:`multiotsu_thresholds` from ``moments = [hist, hist * grey]``, (2, 256)."""
    (levels,) = moments[0].nonzero()
    if levels.size <= n_t:
        last = np.full(n_t + 1 - levels.size, levels[-1])
        return np.concatenate((levels[:-1], last)).astype(np.uint8)
    return levels[_otsu_cuts(moments[:, levels], n_t) - 1].astype(np.uint8)


def _otsu_cuts(moments: NDArray[np.float64], n_t: int) -> NDArray[np.intp]:
    """Optimal class boundaries over the non-empty grey levels.

    Parameters
    ----------
    moments : ndarray of float64, shape (2, m)
        Pixel count (positive integer) and grey sum of each non-empty grey
        level, in increasing grey order; ``m > n_t``.
    n_t : int
        Number of thresholds.

    Returns
    -------
    ndarray of intp, shape (n_t,)
        Cuts ``0 < c_1 < ... < c_n_t < m``: class ``k`` holds levels
        ``c_(k-1) .. c_k - 1`` (``c_0 = 0``, ``c_(n_t+1) = m``).
    """
    cumulative = np.zeros((2, moments.shape[1] + 1))
    np.cumsum(moments, axis=1, out=cumulative[:, 1:])
    # Grey levels relative to the rounded mean c: the objective changes by a
    # constant, and its values, hence the float32 errors, shrink to about N
    # times the between-class variance. The sums S_b stay integers; they fall
    # while grey < c, then rise to N * (mean - c) <= N / 2.
    n_pixels, grey_sum = cumulative[:, -1].tolist()
    cumulative[1] -= round(grey_sum / n_pixels) * cumulative[0]
    if n_pixels / 2 - cumulative[1].min() < _FLOAT32_EXACT:  # so are all differences
        cuts, certain = _otsu_dp(cumulative, n_t, np.float32)
        if certain:
            return cuts
    return _otsu_dp(cumulative, n_t, np.float64)[0]


def _otsu_dp(
    cumulative: NDArray, n_t: int, dtype: type[np.floating[Any]]
) -> tuple[NDArray[np.intp], bool]:
    """Dynamic programme of :func:`_otsu_cuts` in `dtype`.

    ``value[b - 1, a] = (S_b - S_a)**2 / (P_b - P_a)`` is the objective of
    the class of levels ``a .. b - 1`` (cumulative count ``P``, grey sum
    ``S``); ``best[k][a]`` the best sum over ``k + 1`` classes covering
    levels ``a .. m - 1``. The cuts are then chosen left to right, each the
    first optimal one, which gives the lexicographically smallest optimum.

    Parameters
    ----------
    cumulative : ndarray of float64, shape (2, m + 1)
        ``P`` and ``S`` from 0 (integers, exact in `dtype`).
    n_t : int
    dtype : type
        np.float32 or np.float64.

    Returns
    -------
    cuts : ndarray of intp, shape (n_t,)
    certain : bool
        Whether every choice beat its runner-up by more than twice the bound
        on the rounding error, so that exact arithmetic chooses the same.
    """
    from terrain_odom.vision._kernels import otsu_dp

    # A candidate sums <= n_t + 1 class values (2 roundings each) with <= n_t
    # additions of non-negative terms, and is <= the optimum F: its error is
    # <= (n_t + 2) u F, u = eps / 2 (to first order). A margin over twice that
    # (with (n_t + 3) for the higher orders) at every choice makes exact
    # arithmetic choose the same.
    bound = dtype((n_t + 3) * _EPS[dtype])
    counts, sums = cumulative.astype(dtype)
    cuts, certain = otsu_dp(counts, sums, n_t, bound)
    return cuts, bool(certain)


@functools.lru_cache(maxsize=16)
def _class_tables(n_t: int) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Which binary images each Otsu class belongs to (eq. 20).

    Class ``k`` (the grey levels with ``k`` thresholds below them) is in
    images ``i = k + 1 .. n_t`` (``grey <= T(i)``) and in image ``n_t + k``
    (the band above ``T(k)``).

    Returns
    -------
    planes : ndarray of float64, shape (n_t + 1, 2 n_t)
        1 where class ``k`` is in image ``i + 1``.
    luts : ndarray of uint8, shape (ceil(2 n_t / 8), n_t + 1)
        The same as bits: image ``i`` is bit ``(i - 1) % 8`` of byte
        ``(i - 1) // 8``.
    """
    classes = np.arange(n_t + 1)[:, None]
    planes = np.hstack((classes <= np.arange(n_t), classes == np.arange(1, n_t + 1)))
    luts = np.packbits(planes, axis=1, bitorder="little").T.copy()
    planes = planes.astype(np.float64)
    planes.flags.writeable = luts.flags.writeable = False
    return planes, luts


def _range_middles(thresholds: NDArray) -> list[float]:
    """Middle of the grey range of each binary image: T(i) / 2, then (T(i) + T(i+1)) / 2."""
    bounds = [*thresholds.tolist(), _N_LEVELS - 1]
    first = [upper / 2 for upper in bounds[:-1]]
    return first + [(lower + upper) / 2 for lower, upper in itertools.pairwise(bounds)]


def _border_dimensions(grey: NDArray[np.uint8], luts: NDArray, n_planes: int) -> NDArray:
    """Box-counting dimension of the border of each binary image.

    Parameters
    ----------
    grey : ndarray of uint8, shape (H, W)
    luts : ndarray of uint8, shape (n_bytes, 256)
        Grey level -> bit planes, 8 binary images a byte.
    n_planes : int
        Number of binary images.

    Returns
    -------
    ndarray of float64, shape (n_planes,)
    """
    from terrain_odom.vision._kernels import box_counts

    padded = cv2.copyMakeBorder(grey, 1, 1, 1, 1, cv2.BORDER_REPLICATE)
    dimensions = []
    for lut in luts:
        hists, boxes = box_counts(np.asarray(_border(cv2.LUT(padded, lut))))
        dimensions.append(_dimensions(np.dot(hists, _BITS), boxes[:, None]))
    return (dimensions[0] if len(dimensions) == 1 else np.concatenate(dimensions))[:n_planes]


def _border(padded: MatLike) -> MatLike:
    """Border pixels of 8 bit planes at once (eq. 21).

    Parameters
    ----------
    padded : ndarray of uint8, shape (H + 2, W + 2)
        Bit planes with a replicated one-pixel frame, so that pixels outside
        the image never count as 0.

    Returns
    -------
    ndarray of uint8, shape (H, W)
        Bit ``i`` set where plane ``i`` is 1 and some 8-neighbour is 0:
        the plane minus its erosion by the 3x3 square (a bitwise AND over
        the neighbourhood, which contains the pixel itself).
    """
    rows = cv2.bitwise_and(cv2.bitwise_and(padded[:, :-2], padded[:, 1:-1]), padded[:, 2:])
    eroded = cv2.bitwise_and(cv2.bitwise_and(rows[:-2], rows[1:-1]), rows[2:])
    return cv2.bitwise_xor(padded[1:-1, 1:-1], eroded)


def _dimensions(counts: NDArray[np.float64], boxes: NDArray[np.int64]) -> NDArray[np.float64]:
    """Box-counting dimension per column of box counts.

    Parameters
    ----------
    counts : ndarray of float64, shape (n_sizes, n)
        Occupied boxes of side ``2**k`` (:func:`~terrain_odom.vision._kernels.box_counts`); overwritten.
    boxes : ndarray of int64, shape (n_sizes, 1)
        Number of boxes of side ``2**k``.

    Returns
    -------
    ndarray of float64, shape (n,)
        Least-squares slope of ``log N`` against ``log(1 / s)`` over the
        sizes before the first at which every box is occupied (at least
        ``s = 1, 2``); 0 for empty columns and for a single size.
    """
    n_sizes = boxes.size
    if n_sizes == 1:
        return np.zeros(counts.shape[1])
    weights = _SLOPE_WEIGHTS[(counts < boxes).sum(axis=0), :n_sizes]
    np.maximum(counts, 1.0, out=counts)
    return np.dot(weights, np.log(counts, out=counts)).diagonal()  # row j . column j


def _slope_weights(max_sizes: int) -> NDArray[np.float64]:
    """Row ``n``: least-squares slope weights on ``log(1 / 2**k)``, ``k < max(n, 2)``.

    ``weights[n] @ y`` is the slope of ``y[:max(n, 2)]`` against ``-k log 2``.
    """
    weights = np.zeros((max_sizes + 1, max_sizes))
    for n in range(2, max_sizes + 1):
        x = -np.log(2.0) * np.arange(n)
        centred = x - x.mean()
        weights[n, :n] = centred / (centred @ centred)
    weights[:2] = weights[2]
    return weights


_SLOPE_WEIGHTS = _slope_weights(64)
