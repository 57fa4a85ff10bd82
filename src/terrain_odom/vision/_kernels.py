"""Pixel loops of the texture features, compiled by numba (cached on disk).

Each kernel is a loop that numpy and OpenCV would make in several passes
(a float conversion and a rounding; shifted copies of an image and a
comparison per neighbour) or with strided views, so it costs what the
arithmetic costs:

- :func:`grey_levels`: the exact grey image of eq. 18,
  ``(30 R + 59 G + 11 B + 50) // 100`` in integers (vectorised);
- :func:`byte_histogram`: a 256-bin histogram;
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

__all__ = ["grey_levels", "byte_histogram", "box_counts", "lbp_uniform"]


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


@numba.njit(cache=True, nogil=True)
def lbp_uniform(grey: np.ndarray, points: int, radius: float) -> np.ndarray:
    """Uniform LBP codes ``0 .. P + 1`` of a grey image, as scikit-image computes them.

    Neighbour ``p`` of pixel ``(r, c)`` is the bilinear interpolation at
    ``(r + round(-R sin(2 pi p / P), 5), c + round(R cos(2 pi p / P), 5))``
    (0 outside the image), in skimage's order of floating-point operations,
    so that the codes are the same even where a neighbour ties with the
    centre; bit ``p`` is ``neighbour - centre >= 0``; the code is
    :func:`uniform_table` of the bits.

    The interpolation always reads the pixel after the lower one (in a
    zero-padded copy): where skimage reads the same pixel twice (an integer
    position) its weight is 0, which changes no bit of the sum. The lower
    pixel is ``floor(offset)`` from the centre whatever the centre, and the
    fractions depend on the row or the column only, so the loop over a row
    is the same arithmetic for every pixel (vectorised).

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
    height, width = grey.shape
    pad = int(math.ceil(radius)) + 1
    image = np.zeros((height + 2 * pad, width + 2 * pad))
    image[pad : pad + height, pad : pad + width] = grey
    table = uniform_table(points)
    pattern = np.zeros(width, dtype=np.int32)
    value = np.empty(width)
    out = np.empty((height, width), dtype=np.uint8)
    rows = np.empty((points, height))
    cols = np.empty((points, width))
    row_step = np.empty(points, dtype=np.int64)
    col_step = np.empty(points, dtype=np.int64)
    for p in range(points):
        angle = 2.0 * np.pi * p / points
        rp = np.round(-radius * np.sin(angle), 5)
        cp = np.round(radius * np.cos(angle), 5)
        row_step[p], col_step[p] = math.floor(rp), math.floor(cp)
        rows[p] = _fractions(height, rp)
        cols[p] = _fractions(width, cp)
    on_grid = np.empty(points, dtype=np.bool_)  # an integer offset: the pixel itself, exactly
    for p in range(points):
        on_grid[p] = not rows[p].any() and not cols[p].any()
    for r in range(height):
        pattern[:] = 0
        centre = image[pad + r, pad : pad + width]
        for p in range(points):
            fr = rows[p, r]
            fc = cols[p]
            top = image[pad + r + row_step[p]]
            bottom = image[pad + r + row_step[p] + 1]
            c0 = pad + col_step[p]
            if on_grid[p]:  # (1 - 0) * x + 0 * y is x: skimage's interpolation gives the pixel
                for c in range(width):
                    pattern[c] |= np.int32(top[c0 + c] - centre[c] >= 0) << p
                continue
            for c in range(width):
                upper = (1 - fc[c]) * top[c0 + c] + fc[c] * top[c0 + c + 1]
                lower = (1 - fc[c]) * bottom[c0 + c] + fc[c] * bottom[c0 + c + 1]
                value[c] = (1 - fr) * upper + fr * lower
            for c in range(width):
                pattern[c] |= np.int32(value[c] - centre[c] >= 0) << p
        for c in range(width):
            out[r, c] = table[pattern[c]]
    return out
