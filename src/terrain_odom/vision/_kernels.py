"""Pixel loops of the texture features, compiled by numba (cached on disk).

Each kernel is a loop that numpy and OpenCV would make in several passes
(a float conversion and a rounding; shifted copies of an image and a
comparison per neighbour) or with strided views, so it costs what the
arithmetic costs:

- :func:`grey_levels`: the exact grey image of eq. 18,
  ``(30 R + 59 G + 11 B + 50) // 100`` in integers (vectorised);
- :func:`byte_histogram`: a 256-bin histogram;
- :func:`channel_sums`: each channel's sum and sum of squares (colour statistics);
- :func:`box_counts`: the occupied boxes of side 1, 2, 4, ... of 8 bit
  planes (OR-pooling 2x2 blocks);
- :func:`lbp_uniform`: scikit-image's uniform local binary patterns, the
  same codes as ``skimage.feature.local_binary_pattern(grey, P, R,
  "uniform")`` (the same bilinear interpolation, in the same order of
  floating-point operations; the tests hold them equal pixel for pixel).

``cache=True`` keeps the machine code in ``__pycache__``: only the first
process after an install (or a change of this file) compiles, ~3 s.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "grey_levels",
    "byte_histogram",
    "channel_sums",
    "box_counts",
    "lbp_uniform",
    "lbp_tile_counts",
    "otsu_dp",
]


@numba.njit(cache=True, nogil=True)
def grey_levels(rgb: np.ndarray, out: np.ndarray) -> None:
    """Grey levels ``(30 R + 59 G + 11 B + 50) // 100`` of interleaved RGB pixels.

    The weights are constants, so that the compiler vectorises the loop
    (the division by 100 becomes a multiplication): ~0.2 ms for 640x480.

    Parameters
    ----------
    rgb : ndarray of uint8, shape (3 n,)
        Pixels R, G, B after each other (a C-contiguous (H, W, 3) image, flat).
    out : ndarray of uint8, shape (n,)
        Written.
    """
    for i in range(out.size):
        out[i] = (
            np.int32(30) * rgb[3 * i]
            + np.int32(59) * rgb[3 * i + 1]
            + np.int32(11) * rgb[3 * i + 2]
            + np.int32(50)
        ) // np.int32(100)


@numba.njit(cache=True, nogil=True)
def byte_histogram(values: np.ndarray) -> np.ndarray:
    """Count of each byte value 0-255 of a flat uint8 array, int64 (256,).

    Four interleaved sub-histograms, so that runs of one value do not wait
    on their own increments.
    """
    sub = np.zeros((4, 256), dtype=np.int64)
    n = values.size
    whole = n - n % 4
    for i in range(0, whole, 4):
        sub[0, values[i]] += 1
        sub[1, values[i + 1]] += 1
        sub[2, values[i + 2]] += 1
        sub[3, values[i + 3]] += 1
    for i in range(whole, n):
        sub[0, values[i]] += 1
    return sub[0] + sub[1] + sub[2] + sub[3]


@numba.njit(cache=True, nogil=True)
def channel_sums(values: np.ndarray) -> tuple[int, int, int, int, int, int]:
    """Sum and sum of squares of each channel of interleaved 3-channel bytes, exact integers.

    Parameters
    ----------
    values : ndarray of uint8, shape (3 n,)
        Pixels' channels after each other (a C-contiguous (H, W, 3) image, flat).

    Returns
    -------
    tuple of int
        ``sum_0, sum_1, sum_2, squares_0, squares_1, squares_2``.
    """
    s0 = s1 = s2 = q0 = q1 = q2 = np.int64(0)
    for i in range(values.size // 3):
        a, b, c = np.int64(values[3 * i]), np.int64(values[3 * i + 1]), np.int64(values[3 * i + 2])
        s0 += a
        s1 += b
        s2 += c
        q0 += a * a
        q1 += b * b
        q2 += c * c
    return s0, s1, s2, q0, q1, q2


@numba.njit(cache=True, nogil=True)
def _pool(level: np.ndarray) -> np.ndarray:
    """OR of the 2x2 blocks of a 2-D uint8 array; an odd last row or column is a partial block."""
    rows, cols = level.shape
    half_rows, half_cols = rows // 2, cols // 2
    out = np.empty(((rows + 1) // 2, (cols + 1) // 2), dtype=np.uint8)
    for i in range(half_rows):
        for j in range(half_cols):
            out[i, j] = (
                level[2 * i, 2 * j]
                | level[2 * i, 2 * j + 1]
                | level[2 * i + 1, 2 * j]
                | level[2 * i + 1, 2 * j + 1]
            )
        if cols % 2:
            out[i, half_cols] = level[2 * i, cols - 1] | level[2 * i + 1, cols - 1]
    if rows % 2:
        for j in range(half_cols):
            out[half_rows, j] = level[rows - 1, 2 * j] | level[rows - 1, 2 * j + 1]
        if cols % 2:
            out[half_rows, half_cols] = level[rows - 1, cols - 1]
    return out


@numba.njit(cache=True, nogil=True)
def box_counts(planes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Occupied boxes of side 1, 2, 4, ... of each of 8 bit planes.

    Boxes of side ``2**k`` are the pixels OR-pooled over 2x2 blocks ``k``
    times (an odd last row or column is a partial box). Stops at one box,
    or as soon as every box holds the same byte (larger boxes say nothing
    more), but not before ``k = 1``.

    Parameters
    ----------
    planes : ndarray of uint8, shape (H, W), C-contiguous

    Returns
    -------
    hists : ndarray of int64, shape (n_sizes, 256)
        Row ``k``: how many ``2**k`` boxes hold each byte value (times the
        256x8 bit table: the boxes of each plane).
    boxes : ndarray of int64, shape (n_sizes,)
        Number of ``2**k`` boxes.
    """
    longest = max(planes.shape[0], planes.shape[1])
    n_levels = 1
    while (1 << (n_levels - 1)) < longest:
        n_levels += 1
    hists = np.zeros((n_levels, 256), dtype=np.int64)
    boxes = np.zeros(n_levels, dtype=np.int64)
    level = planes
    n = 0
    while n < n_levels:
        hists[n] = byte_histogram(level.ravel())
        boxes[n] = level.size
        n += 1
        if n > 1 and hists[n - 1, level[0, 0]] == level.size:  # all boxes alike
            break
        if n < n_levels:
            level = _pool(level)
    return hists[:n], boxes[:n]


@numba.njit(cache=True, nogil=True)
def _fractions(n: int, offset: float) -> np.ndarray:
    """``(i + offset) - floor(i + offset)`` for ``i = 0 .. n - 1``, in floating point as skimage."""
    out = np.empty(n)
    for i in range(n):
        at = i + offset
        out[i] = at - math.floor(at)
    return out


@numba.njit(cache=True, nogil=True)
def uniform_table(points: int) -> np.ndarray:
    """Uniform code of every ``points``-bit pattern: its ones if it changes at most twice, else ``P + 1``.

    Changes are counted between bits ``p`` and ``p + 1`` for ``p < P - 1``
    (not around the circle), as scikit-image counts them.
    """
    table = np.empty(1 << points, dtype=np.uint8)
    for pattern in range(1 << points):
        ones = 0
        changes = 0
        for p in range(points):
            bit = (pattern >> p) & 1
            ones += bit
            if p and bit != ((pattern >> (p - 1)) & 1):
                changes += 1
        table[pattern] = ones if changes <= 2 else points + 1
    return table


LBP_TOLERANCE = 1e-3
"""Distance from the centre under which a single-precision neighbour is recomputed as skimage does.

The single-precision interpolation of a neighbour (values <= 255, four
products and three sums) is within ~1e-4 of skimage's double-precision one,
so that a difference from the centre larger than this has skimage's sign.
"""
_TOLERANCE32 = np.float32(LBP_TOLERANCE)


@numba.njit(cache=True, nogil=True)
def _ring(points: int, radius: float, height: int, width: int):
    """Geometry of an LBP ring as skimage computes it, for a ``height x width`` image.

    Returns the whole-pixel steps of the lower interpolation corner (rows,
    columns), the fractional offsets in double precision per row and per
    column (``(i + offset) - floor(i + offset)``: skimage's, which vary in the
    last bits with ``i``), the four single-precision corner weights, and
    whether each neighbour is a pixel itself (integer offsets).
    """
    rows = np.empty((points, height))
    cols = np.empty((points, width))
    row_step = np.empty(points, dtype=np.int64)
    col_step = np.empty(points, dtype=np.int64)
    weights = np.empty((points, 4), dtype=np.float32)
    on_grid = np.empty(points, dtype=np.bool_)
    for p in range(points):
        angle = 2.0 * np.pi * p / points
        rp = np.round(-radius * np.sin(angle), 5)
        cp = np.round(radius * np.cos(angle), 5)
        row_step[p], col_step[p] = math.floor(rp), math.floor(cp)
        rows[p] = _fractions(height, rp)
        cols[p] = _fractions(width, cp)
        on_grid[p] = rp == math.floor(rp) and cp == math.floor(cp)
        fr, fc = rp - math.floor(rp), cp - math.floor(cp)
        weights[p, 0] = (1 - fr) * (1 - fc)
        weights[p, 1] = (1 - fr) * fc
        weights[p, 2] = fr * (1 - fc)
        weights[p, 3] = fr * fc
    return row_step, col_step, rows, cols, weights, on_grid


@numba.njit(cache=True, nogil=True)
def _ring_patterns(padded, pad, r, c0, c1, ring, pattern, unsure) -> None:
    """LBP bit patterns of pixels ``c0 .. c1 - 1`` of row ``r`` (skimage's bits exactly).

    ``padded`` is the grey image with ``pad`` zero pixels around it (skimage's
    ``cval`` 0 outside). Each interpolated neighbour is first computed in
    single precision (vectorised); where it is within :data:`LBP_TOLERANCE`
    of the centre (ties: flat ground, where skimage's rounding decides) it
    is recomputed as skimage computes it, ``(1 - dr) * ((1 - dc) * a + dc * b)
    + dr * ((1 - dc) * c + dc * d)`` in double precision with its per-row and
    per-column fractions.
    """
    row_step, col_step, rows, cols, weights, on_grid = ring
    points = row_step.size
    n = c1 - c0
    pattern[:n] = 0
    unsure[:n] = 0
    centre = padded[pad + r, pad + c0 : pad + c1]
    for p in range(points):
        top = padded[pad + r + row_step[p], pad + c0 + col_step[p] :]
        bottom = padded[pad + r + row_step[p] + 1, pad + c0 + col_step[p] :]
        if on_grid[p]:  # (1 - 0) * x + 0 * y is x: skimage's interpolation gives the pixel
            bit = np.uint16(1 << p)
            for c in range(n):
                pattern[c] |= bit if top[c] >= centre[c] else np.uint16(0)
            continue
        w00, w01, w10, w11 = weights[p, 0], weights[p, 1], weights[p, 2], weights[p, 3]
        bit = np.uint16(1 << p)
        for c in range(n):
            value = (
                w00 * np.float32(top[c])
                + w01 * np.float32(top[c + 1])
                + w10 * np.float32(bottom[c])
                + w11 * np.float32(bottom[c + 1])
            )
            difference = value - np.float32(centre[c])
            pattern[c] |= bit if difference >= 0 else np.uint16(0)
            unsure[c] |= bit if abs(difference) < _TOLERANCE32 else np.uint16(0)
    for c in range(n):
        if unsure[c] == 0:
            continue
        for p in range(points):
            if not (unsure[c] >> p) & 1:
                continue
            fr, fc = rows[p, r], cols[p, c0 + c]
            top = padded[pad + r + row_step[p], pad + c0 + col_step[p] :]
            bottom = padded[pad + r + row_step[p] + 1, pad + c0 + col_step[p] :]
            upper = (1 - fc) * np.float64(top[c]) + fc * np.float64(top[c + 1])
            lower = (1 - fc) * np.float64(bottom[c]) + fc * np.float64(bottom[c + 1])
            value = (1 - fr) * upper + fr * lower
            mask = np.uint16(1 << p)
            pattern[c] = (
                (pattern[c] | mask) if value - np.float64(centre[c]) >= 0 else (pattern[c] & ~mask)
            )


def lbp_pad(radius: float) -> int:
    """Zero pixels around a grey image that an LBP ring of this radius reads (and one more)."""
    return int(math.ceil(radius)) + 1


@numba.njit(cache=True, nogil=True)
def lbp_uniform_padded(padded: np.ndarray, pad: int, points: int, radius: float) -> np.ndarray:
    """:func:`lbp_uniform` of the image inside ``pad`` zero pixels (``pad >= ceil(radius) + 1``)."""
    height, width = padded.shape[0] - 2 * pad, padded.shape[1] - 2 * pad
    ring = _ring(points, radius, height, width)
    table = uniform_table(points)
    pattern = np.empty(width, dtype=np.uint16)  # P <= 16 bits
    unsure = np.empty(width, dtype=np.uint16)
    out = np.empty((height, width), dtype=np.uint8)
    for r in range(height):
        _ring_patterns(padded, pad, r, 0, width, ring, pattern, unsure)
        for c in range(width):
            out[r, c] = table[pattern[c]]
    return out


def lbp_uniform(grey: np.ndarray, points: int, radius: float) -> np.ndarray:
    """Uniform LBP codes ``0 .. P + 1`` of a grey image, as scikit-image computes them.

    ``skimage.feature.local_binary_pattern(grey, P, R, "uniform")``:
    neighbour ``p`` of pixel ``(r, c)`` is the bilinear interpolation at
    ``(r + round(-R sin(2 pi p / P), 5), c + round(R cos(2 pi p / P), 5))``
    (0 outside the image); bit ``p`` is ``neighbour - centre >= 0``; the
    code is :func:`uniform_table` of the bits. The same bits as skimage's
    even where a neighbour ties with the centre (:func:`_ring_patterns`: the
    tests hold the codes equal pixel for pixel).

    Parameters
    ----------
    grey : ndarray of uint8, shape (H, W)
    points : int
        ``P``, at most 16.
    radius : float
        ``R``, px.

    Returns
    -------
    ndarray of uint8, shape (H, W)
    """
    pad = lbp_pad(radius)
    padded = np.pad(np.asarray(grey, dtype=np.uint8), pad)
    return lbp_uniform_padded(padded, pad, points, radius)


@numba.njit(cache=True, nogil=True)
def lbp_tile_counts(
    padded: np.ndarray, pad: int, points: int, radius: float, boxes: np.ndarray
) -> np.ndarray:
    """Uniform LBP code counts of tiles of a grey image, the codes of the whole image.

    Only the tiles' pixels are coded, each with its true neighbours (in the
    next tile, or 0 outside the image), so that the counts are the
    histograms of :func:`lbp_uniform`'s map cut into the tiles.

    Parameters
    ----------
    padded : ndarray of uint8, shape (H + 2 pad, W + 2 pad)
        The grey image inside ``pad`` zero pixels (:func:`lbp_pad`).
    pad : int
    points : int
    radius : float
    boxes : ndarray of int64, shape (n_tiles, 4)
        ``(x0, y0, x1, y1)`` of each tile, half-open, inside the image.

    Returns
    -------
    ndarray of int64, shape (n_tiles, points + 2)
    """
    height, width = padded.shape[0] - 2 * pad, padded.shape[1] - 2 * pad
    ring = _ring(points, radius, height, width)
    table = uniform_table(points)
    pattern = np.empty(width, dtype=np.uint16)  # P <= 16 bits
    unsure = np.empty(width, dtype=np.uint16)
    counts = np.zeros((boxes.shape[0], points + 2), dtype=np.int64)
    for i in range(boxes.shape[0]):
        x0, y0, x1, y1 = boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3]
        for r in range(y0, y1):
            _ring_patterns(padded, pad, r, x0, x1, ring, pattern, unsure)
            for c in range(x1 - x0):
                counts[i, table[pattern[c]]] += 1
    return counts


@numba.njit(cache=True, nogil=True)
def _best_after(value: np.ndarray, best: np.ndarray, out: np.ndarray) -> None:
    """``out[a] = max over b > a of value[b - 1, a] + best[b]`` (b < m; -inf if there is none)."""
    m = best.size
    out[:] = -np.inf
    for b in range(1, m):
        after = best[b]
        row = value[b - 1]
        for a in range(b):  # vectorised: a max per lane
            out[a] = max(out[a], row[a] + after)


@numba.njit(cache=True, nogil=True)
def _top_two(candidates: np.ndarray) -> tuple[int, float, float]:
    """Index of the first largest value, the largest and the second largest (may equal it)."""
    first = 0
    for i in range(1, candidates.size):
        if candidates[i] > candidates[first]:
            first = i
    runner_up = -np.inf
    for i in range(candidates.size):
        if i != first and candidates[i] > runner_up:
            runner_up = candidates[i]
    return first, candidates[first], runner_up


@numba.njit(cache=True, nogil=True, error_model="numpy")  # no zero-division branch: vectorised
def otsu_dp(counts: np.ndarray, sums: np.ndarray, n_t: int, bound: float):
    """Optimal Otsu cuts over ``m`` non-empty grey levels, in the precision of the inputs.

    The dynamic programme of :func:`terrain_odom.vision.sfta._otsu_dp`, in
    the arithmetic of ``counts``' dtype (float32 or float64) and the same
    operations: ``value[b - 1, a] = (S_b - S_a)**2 / (P_b - P_a)`` (one
    rounding each for the difference, the square and the quotient),
    ``best[j][a]`` the best sum of ``j + 1`` classes from level ``a``, the
    cuts chosen left to right as the first best.

    Parameters
    ----------
    counts, sums : ndarray, shape (m + 1,)
        Cumulative pixel count ``P`` and grey sum ``S`` from 0, both float32
        or both float64 (integers, exact in that type when the caller relies
        on ``certain``).
    n_t : int
        Number of cuts, < m.
    bound : float
        ``(n_t + 3) * eps`` of the dtype, cast to it.

    Returns
    -------
    cuts : ndarray of intp, shape (n_t,)
    certain : bool
        Whether every choice beat its runner-up by more than ``bound`` times
        the optimum (then exact arithmetic chooses the same).
    """
    m = counts.size - 1
    value = np.empty((m, m), dtype=counts.dtype)  # row b - 1: classes a .. b - 1, a < b
    for b in range(1, m + 1):
        row = value[b - 1]
        count, total = counts[b], sums[b]
        for a in range(b):  # vectorised
            difference = total - sums[a]
            row[a] = difference * difference / (count - counts[a])
    best = np.empty((n_t, m), dtype=counts.dtype)
    best[0] = value[m - 1]  # one class: levels a .. m - 1
    for j in range(1, n_t):
        _best_after(value, best[j - 1], best[j])
    cuts = np.empty(n_t, dtype=np.intp)
    candidates = np.empty(m - 1, dtype=counts.dtype)
    margin = np.inf
    optimum = candidates[0]
    for k in range(n_t):
        start = 0 if k == 0 else cuts[k - 1]
        after = best[n_t - 1 - k]
        candidates[:start] = -np.inf  # no class from level start ends before it
        for b in range(start + 1, m):
            candidates[b - 1] = value[b - 1, start] + after[b]
        first, top, runner_up = _top_two(candidates)
        cuts[k] = first + 1
        if k == 0:
            optimum = top
        margin = min(margin, top - runner_up)
    return cuts, m == 2 or margin > bound * optimum
