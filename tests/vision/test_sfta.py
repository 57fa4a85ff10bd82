"""Tests of the SFTA features against skimage, hand-worked images and a slow reference."""

from __future__ import annotations

import itertools
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy import ndimage
from skimage import data
from skimage.filters import threshold_multiotsu

from terrain_odom.vision import sfta
from terrain_odom.vision.sfta import (
    N_THRESHOLDS,
    box_counting_dimension,
    multiotsu_thresholds,
    sfta_features,
    to_grey,
)

REPO = Path(__file__).resolve().parents[2]
# Real floor photos where ../shared is present: they parametrize tests at collection,
# so the path is read here rather than through the conftest fixture.
INDOOR = REPO.parent / "shared" / "data" / "indoor_surface"
# Every 250th photo, plus two where skimage's float32 search returns the worse thresholds.
INDOOR_IMAGES = sorted(
    {
        *sorted(INDOOR.glob("*/*.jpg"))[::250],
        *INDOOR.glob("*/wood_0120.jpg"),
        *INDOOR.glob("*/carpet_0181.jpg"),
    }
)


def grey_histogram(grey):
    return np.bincount(grey.ravel(), minlength=256)


def exact_objective(hist, thresholds):
    """Sum over classes of S**2 / P (Otsu's criterion up to constants), exactly."""
    edges = [-1, *(int(t) for t in thresholds), 255]
    levels = np.arange(256)
    total = Fraction(0)
    for low, high in itertools.pairwise(edges):
        count = int(hist[low + 1 : high + 1].sum())
        grey_sum = int((hist[low + 1 : high + 1] * levels[low + 1 : high + 1]).sum())
        if count:
            total += Fraction(grey_sum * grey_sum, count)
    return total


# ---------------------------------------------------------------- the slow reference


def reference_box_counting(binary):
    """Box-counting dimension by explicit boxes of each size, per the module docstring."""
    height, width = binary.shape
    counts, boxes = [], []
    size = 1
    while True:
        rows, cols = -(-height // size), -(-width // size)
        padded = np.zeros((rows * size, cols * size), dtype=bool)
        padded[:height, :width] = binary
        counts.append(padded.reshape(rows, size, cols, size).any(axis=(1, 3)).sum())
        boxes.append(rows * cols)
        if rows * cols == 1:
            break
        size *= 2
    counts, boxes = np.array(counts), np.array(boxes)
    if counts[0] == 0 or len(counts) == 1:
        return 0.0
    n_fitted = max(int(np.sum(counts < boxes)), 2)
    log_inverse_size = -np.log(2.0) * np.arange(n_fitted)
    return np.polyfit(log_inverse_size, np.log(counts[:n_fitted]), 1)[0]


def reference_sfta(grey, n_t):
    """Eq. 19-21 one binary image at a time, with numpy and scipy.ndimage."""
    thresholds = [int(t) for t in multiotsu_thresholds(grey_histogram(grey), n_t)]
    ranges = [(-1, t) for t in thresholds]  # i <= n_t: 0 <= grey <= T(i)
    ranges += list(itertools.pairwise([*thresholds, 255]))  # T(i) < grey <= T(i+1)
    features = []
    for low, high in ranges:
        binary = (grey > low) & (grey <= high)
        eroded = ndimage.binary_erosion(binary, structure=np.ones((3, 3)), border_value=1)
        border = binary & ~eroded
        mean = grey[binary].mean() if binary.any() else (max(low, 0) + high) / 2
        features += [reference_box_counting(border), binary.mean(), mean]
    return np.array(features)


# --------------------------------------------------------------------- grey image


def test_grey_weights_on_a_crafted_pixel():
    # 0.30 * 100 + 0.59 * 150 + 0.11 * 200 = 140.5 -> 141 (half up); BGR swaps R and B.
    pixel = np.array([[[100, 150, 200]]], dtype=np.uint8)
    assert to_grey(pixel).tolist() == [[141]]
    assert to_grey(pixel, colour_order="bgr").tolist() == [[160]]  # 159.5
    assert to_grey(
        np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]]], dtype=np.uint8)
    ).tolist() == [
        [77, 150, 28]  # 76.5 -> 77, 150.45 -> 150, 28.05 -> 28
    ]


def test_grey_is_exact_for_every_colour():
    colours = np.arange(2**24, dtype=np.uint32)
    rgb = np.stack([(colours >> 16) & 255, (colours >> 8) & 255, colours & 255], axis=-1)
    expected = (rgb @ np.array([30, 59, 11], dtype=np.uint32) + 50) // 100
    image = rgb.astype(np.uint8).reshape(4096, 4096, 3)
    np.testing.assert_array_equal(to_grey(image).ravel(), expected)
    np.testing.assert_array_equal(to_grey(image[..., ::-1], colour_order="bgr").ravel(), expected)


def test_grey_passes_grey_images_through_and_refuses_the_rest():
    grey = np.zeros((4, 5), dtype=np.uint8)
    assert to_grey(grey) is grey
    with pytest.raises(ValueError, match="uint8.*round"):
        to_grey(np.zeros((4, 5, 3)))
    with pytest.raises(ValueError, match=r"\(H, W\) or \(H, W, 3\)"):
        to_grey(np.zeros((4, 5, 4), dtype=np.uint8))
    with pytest.raises(ValueError, match="colour_order"):
        to_grey(grey, colour_order="hsv")


# --------------------------------------------------------------------- thresholds

REAL_IMAGES = {name: getattr(data, name)() for name in ("grass", "gravel", "brick", "camera")}


@pytest.mark.parametrize("name", REAL_IMAGES)
@pytest.mark.parametrize("n_t", [1, 2, 3])
def test_thresholds_equal_skimage_on_its_images(name, n_t):
    image = REAL_IMAGES[name]
    expected = threshold_multiotsu(image, classes=n_t + 1)
    np.testing.assert_array_equal(multiotsu_thresholds(grey_histogram(image), n_t), expected)


@pytest.mark.parametrize("path", INDOOR_IMAGES, ids=lambda p: p.name)
@pytest.mark.parametrize("n_t", [1, 2, 3])
def test_thresholds_equal_skimage_or_beat_its_float32_search(path, n_t):
    """Real photos and 160x120 crops: equal, or skimage's float32 could not tell.

    skimage accumulates in float32; where two candidates' criteria differ by
    less than its rounding (e.g. wood_0120 at n_t = 3: 7e-8 relative), it can
    return the worse one. The DP's thresholds are then the exact optimum.
    """
    grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    for image in (grey, grey[:120, :160]):
        hist = grey_histogram(image)
        ours = multiotsu_thresholds(hist, n_t)
        theirs = threshold_multiotsu(image, classes=n_t + 1)
        if not np.array_equal(ours, theirs):
            ours_value, theirs_value = exact_objective(hist, ours), exact_objective(hist, theirs)
            assert ours_value > theirs_value
            assert (ours_value - theirs_value) / ours_value < 1e-6


def test_the_float32_search_of_skimage_misses_where_the_dp_does_not():
    # 160x120 corner of camera(): levels 112-120 are empty, so thresholds
    # 111..120 give the same classes; skimage returns 121, 30 worse of 8e8.
    image = data.camera()[:120, :160]
    hist = grey_histogram(image)
    assert multiotsu_thresholds(hist, 1).tolist() == [111]
    assert threshold_multiotsu(image, classes=2).tolist() == [121]
    assert exact_objective(hist, [111]) == exact_objective(hist, [120])
    assert exact_objective(hist, [111]) > exact_objective(hist, [121])


def test_thresholds_equal_skimage_for_four_thresholds_on_a_small_image():
    image = data.brick()[:48, :48]  # skimage needs ~0.2 s here, ~4 s on camera()[::16, ::16]
    np.testing.assert_array_equal(
        multiotsu_thresholds(grey_histogram(image), 4), threshold_multiotsu(image, classes=5)
    )


def float_objectives(hist, candidates):
    """Otsu's criterion of each row of thresholds, in float64."""
    cumulative = np.zeros((2, 257))
    cumulative[:, 1:] = np.cumsum([hist, hist * np.arange(256)], axis=1)
    n = len(candidates)
    edges = np.column_stack([np.full(n, -1), candidates, np.full(n, 255)]) + 1
    count, grey_sum = cumulative[:, edges[:, 1:]] - cumulative[:, edges[:, :-1]]
    return np.divide(grey_sum**2, count, out=np.zeros(count.shape), where=count > 0).sum(axis=1)


@pytest.mark.parametrize("n_t", [1, 2])
def test_dp_reaches_the_exhaustive_optimum(n_t):
    for image in (data.grass()[:120, :160], data.gravel()[200:260, 100:180], data.coins()):
        hist = grey_histogram(image)
        candidates = np.array(list(itertools.combinations(np.flatnonzero(hist)[:-1], n_t)))
        top_ten = np.argsort(float_objectives(hist, candidates))[-10:]  # then exactly
        best = max(exact_objective(hist, candidates[i]) for i in top_ten)
        assert exact_objective(hist, multiotsu_thresholds(hist, n_t)) == best


def test_exact_ties_give_the_lexicographically_smallest_thresholds():
    # {0 | 100, 200} and {0, 100 | 200} tie exactly (45000 both); so do
    # {10 | 20 | 200, 210} and {10, 20 | 200 | 210}.
    assert multiotsu_thresholds(
        grey_histogram(np.array([[0, 100, 200]], np.uint8)), 1
    ).tolist() == [0]
    hist = grey_histogram(np.array([[10, 20, 200, 210]], dtype=np.uint8))
    assert multiotsu_thresholds(hist, 2).tolist() == [10, 20]
    # A threshold in a run of empty levels sits at the lowest: the class's top level.
    assert multiotsu_thresholds(hist, 1).tolist() == [20]


def test_an_exact_tie_is_not_certified_in_float32():
    cumulative = np.array([[0.0, 1, 2, 3], [0, -100, -100, 0]])  # levels 0, 100, 200 centred
    cuts, certain = sfta._otsu_dp(cumulative, 1, np.float32)
    assert not certain
    assert sfta._otsu_dp(cumulative, 1, np.float64)[0].tolist() == cuts.tolist() == [1]


def test_float64_path_for_counts_beyond_float32():
    # Otsu's thresholds do not change when every count is multiplied; counts
    # of 1e9 are not exact in float32, so this takes the float64 programme.
    for image in (data.grass(), data.camera()):
        hist = grey_histogram(image)
        for n_t in (1, 3, 4):
            np.testing.assert_array_equal(
                multiotsu_thresholds(hist * 10**6, n_t), multiotsu_thresholds(hist, n_t)
            )


def test_thresholds_of_images_with_few_levels():
    assert multiotsu_thresholds(grey_histogram(np.full((3, 3), 7, np.uint8)), 4).tolist() == [7] * 4
    two = np.array([[50, 200]], dtype=np.uint8)
    assert multiotsu_thresholds(grey_histogram(two), 4).tolist() == [50, 200, 200, 200]
    five = np.array([[3, 9, 60, 61, 250]], dtype=np.uint8)
    assert multiotsu_thresholds(grey_histogram(five), 4).tolist() == [3, 9, 60, 61]


def test_threshold_arguments_are_checked():
    with pytest.raises(ValueError, match="256 non-negative integer"):
        multiotsu_thresholds(np.ones(255), 2)
    with pytest.raises(ValueError, match="256 non-negative integer"):
        multiotsu_thresholds(np.full(256, 0.5), 2)
    with pytest.raises(ValueError, match="256 non-negative integer"):
        multiotsu_thresholds(np.r_[-1, np.ones(255)], 2)
    with pytest.raises(ValueError, match="empty"):
        multiotsu_thresholds(np.zeros(256), 2)
    with pytest.raises(ValueError, match="n_t"):
        multiotsu_thresholds(np.ones(256), 0)
    hist = grey_histogram(data.brick())
    assert (
        multiotsu_thresholds(hist.astype(np.float32), 2).tolist()
        == multiotsu_thresholds(hist, 2).tolist()
    )


# ------------------------------------------------------------ box-counting dimension


def disc(size, filled):
    image = np.zeros((size, size), dtype=np.uint8)
    return cv2.circle(image, (size // 2, size // 2), size // 2 - 1, 1, -1 if filled else 1)


def test_dimension_of_a_straight_line_is_one():
    line = np.zeros((512, 512), dtype=bool)
    line[200, :] = True
    assert box_counting_dimension(line) == pytest.approx(1.0, abs=1e-12)
    assert box_counting_dimension(np.eye(512)) == pytest.approx(1.0, abs=1e-12)


def test_dimension_of_a_circle_outline_is_about_one():
    assert abs(box_counting_dimension(disc(512, filled=False)) - 1.0) < 0.05


def test_dimension_of_a_filled_disc_and_square_is_about_two():
    assert abs(box_counting_dimension(disc(512, filled=True)) - 2.0) < 0.05
    assert box_counting_dimension(np.ones((512, 512))) == pytest.approx(2.0, abs=1e-12)
    square = np.zeros((512, 512), dtype=bool)
    square[:256, :256] = True
    assert box_counting_dimension(square) == pytest.approx(2.0, abs=1e-12)


def test_dimension_of_degenerate_sets_is_zero():
    empty = np.zeros((33, 17), dtype=bool)
    assert box_counting_dimension(empty) == 0.0
    empty[5, 9] = True
    assert box_counting_dimension(empty) == 0.0
    assert box_counting_dimension(np.ones((1, 1))) == 0.0
    with pytest.raises(ValueError, match="2-D"):
        box_counting_dimension(np.ones(5))


@pytest.mark.parametrize("shape", [(512, 512), (480, 640), (97, 131), (5, 300), (1, 64)])
def test_dimension_equals_explicit_box_counting(shape):
    rng = np.random.default_rng(sum(shape))
    for density in (0.001, 0.05, 0.5):
        binary = rng.random(shape) < density
        assert box_counting_dimension(binary) == pytest.approx(
            reference_box_counting(binary), abs=1e-12
        )


# ------------------------------------------------------------------ SFTA features


def test_features_of_n_t_4_are_24_finite_values():
    features = sfta_features(data.grass())
    assert N_THRESHOLDS == 4
    assert features.shape == (24,) and features.dtype == np.float64
    assert np.all(np.isfinite(features))
    dimensions, sizes, means = features.reshape(8, 3).T
    assert np.all((dimensions > 1) & (dimensions < 2))  # borders of a texture
    assert np.all((sizes > 0) & (sizes < 1))
    assert np.all(np.diff(sizes[:4]) > 0)  # grey <= T(i) grows with i
    assert sizes[4:].sum() == pytest.approx(1 - sizes[0])  # the bands partition grey > T(1)


@pytest.mark.parametrize("n_t", [1, 2, 3, 5, 6])
def test_features_have_six_values_per_threshold(n_t):
    features = sfta_features(data.brick()[:100, :100], n_t)
    assert features.shape == (6 * n_t,) and np.all(np.isfinite(features))


def test_sizes_and_means_of_a_two_level_image_by_hand():
    # Left 16 columns grey 50, right 48 columns grey 200: 2 levels, so
    # T = [50, 200, 200, 200]. Images 1-4: grey <= 50 | <= 200 (x3); images
    # 5-8: (50, 200] | (200, 200] (x2, empty) | (200, 255] (empty).
    image = np.full((32, 64), 200, dtype=np.uint8)
    image[:, :16] = 50
    dimensions, sizes, means = sfta_features(image).reshape(8, 3).T
    assert sizes.tolist() == [0.25, 1, 1, 1, 0.75, 0, 0, 0]
    assert means.tolist() == [50, 162.5, 162.5, 162.5, 200, 200, 200, 227.5]
    # Image 1's border is column 15, image 5's column 16: 32 px segments,
    # N(s) = 32 / s up to s = 32, then one box fills the 32x64 image: D = 1.
    # Full and empty images have no border: D = 0.
    assert dimensions[[0, 4]] == pytest.approx([1, 1], abs=1e-12)
    assert dimensions[[1, 2, 3, 5, 6, 7]].tolist() == [0] * 6


def test_sizes_and_means_of_five_stripes_by_hand():
    # Five levels, n_t = 4: every level is a class, T = [10, 20, 30, 40].
    image = np.repeat(np.array([[10, 20, 30, 40, 90]], dtype=np.uint8), [1, 2, 3, 4, 10], axis=1)
    image = np.repeat(image, 8, axis=0)
    dimensions, sizes, means = sfta_features(image).reshape(8, 3).T
    assert sizes * 20 == pytest.approx([1, 3, 6, 10, 2, 3, 4, 10], abs=1e-12)
    assert means.tolist() == pytest.approx([10, 50 / 3, 140 / 6, 300 / 10, 20, 30, 40, 90])


def test_bgr_and_rgb_give_the_same_features():
    rgb = data.astronaut()[100:260, 150:370]
    np.testing.assert_array_equal(
        sfta_features(rgb), sfta_features(np.ascontiguousarray(rgb[..., ::-1]), colour_order="bgr")
    )
    np.testing.assert_array_equal(sfta_features(rgb), sfta_features(to_grey(rgb)))


@pytest.mark.parametrize(
    "image",
    [
        np.full((40, 30), 128, dtype=np.uint8),
        np.zeros((40, 30), dtype=np.uint8),
        np.full((40, 30, 3), 255, dtype=np.uint8),
        np.full((1, 1), 9, dtype=np.uint8),
        np.array([[0, 255]], dtype=np.uint8),
        np.arange(7, dtype=np.uint8)[:, None] * 30,
        np.random.default_rng(0).integers(0, 256, (3, 5), dtype=np.uint8),
        np.random.default_rng(1).integers(0, 256, (7, 7, 3), dtype=np.uint8),
    ],
    ids=["uniform", "black", "white", "1x1", "1x2", "7x1", "3x5", "7x7-rgb"],
)
def test_degenerate_images_give_finite_features(image):
    features = sfta_features(image)
    assert features.shape == (24,) and np.all(np.isfinite(features))
    dimensions, sizes, means = features.reshape(8, 3).T
    assert np.all((dimensions >= 0) & (dimensions <= 2))
    assert np.all((sizes >= 0) & (sizes <= 1)) and np.all((means >= 0) & (means <= 255))


def test_uniform_patch_by_hand():
    # T = [v] * 4: images 1-4 are the whole patch (no border: the frame is not
    # one), images 5-8 are empty.
    dimensions, sizes, means = sfta_features(np.full((20, 20), 100, np.uint8)).reshape(8, 3).T
    assert dimensions.tolist() == [0] * 8
    assert sizes.tolist() == [1, 1, 1, 1, 0, 0, 0, 0]
    assert means.tolist() == [100, 100, 100, 100, 100, 100, 100, 177.5]


def test_empty_images_and_bad_n_t_are_refused():
    with pytest.raises(ValueError, match="empty"):
        sfta_features(np.zeros((0, 5), dtype=np.uint8))
    with pytest.raises(ValueError, match="n_t"):
        sfta_features(data.brick(), 0)


def test_views_give_the_features_of_their_copies():
    rgb = data.astronaut()
    views = [rgb[100:220, 50:210], rgb[:, ::3], rgb.transpose(1, 0, 2), rgb[::-1]]
    for view in views:
        np.testing.assert_array_equal(
            sfta_features(view), sfta_features(np.ascontiguousarray(view))
        )


def real_crops():
    crops = {}
    for name in ("grass", "gravel", "brick"):
        image = getattr(data, name)()
        crops[name] = image
        crops[f"{name}-97x131"] = image[13:110, 200:331]
    crops["astronaut"] = to_grey(data.astronaut())
    crops["coffee-160x120"] = to_grey(data.coffee())[50:170, 100:260]
    for path in INDOOR_IMAGES[:4]:
        crops[path.name] = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    return crops


REAL_CROPS = real_crops()


@pytest.mark.parametrize("name", REAL_CROPS)
def test_bit_plane_implementation_equals_the_reference(name):
    grey = REAL_CROPS[name]
    np.testing.assert_allclose(sfta_features(grey), reference_sfta(grey, 4), rtol=0, atol=1e-9)


@pytest.mark.parametrize("n_t", [1, 3, 5])
def test_bit_plane_implementation_equals_the_reference_for_other_n_t(n_t):
    grey = data.gravel()[:150, :170]
    np.testing.assert_allclose(sfta_features(grey, n_t), reference_sfta(grey, n_t), atol=1e-9)


def test_large_histograms_are_exact():
    grey = np.zeros((4097, 4097), dtype=np.uint8)
    grey[0, 0] = 1
    hist = sfta._histogram(grey)
    assert hist[0] == 4097 * 4097 - 1 and hist[1] == 1
