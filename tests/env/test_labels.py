"""The video's label layout (:func:`maopg.env.labels.place_labels`): near, apart, inside."""

from __future__ import annotations

import numpy as np

from maopg.env.labels import DOT, GAP, LIFT, place_labels

WIDTH, HEIGHT = 640, 480


def _boxes(spots, sizes):
    return [(x, y, x + w, y + h) for (x, y), (w, h) in zip(spots, sizes, strict=True)]


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _check(points, sizes, width=WIDTH, height=HEIGHT):
    """Every label placed, inside the picture, on no other label and on no labelled point."""
    spots = place_labels(np.array(points, dtype=float), sizes, width, height)
    assert all(spot is not None for spot in spots)
    boxes = _boxes(spots, sizes)
    for i, (x0, y0, x1, y1) in enumerate(boxes):
        assert x0 >= 0 and y0 >= 0 and x1 <= width and y1 <= height, (i, boxes[i])
        for j in range(i):
            assert not _overlap(boxes[i], boxes[j]), (i, j)
        for px, py in points:
            dot = (px - DOT, py - DOT, px + DOT + 1, py + DOT + 1)
            assert not _overlap(boxes[i], dot), (i, (px, py))
    return spots


def test_a_lone_label_sits_centred_just_above_its_point():
    (spot,) = _check([(300, 200)], [(50, 17)])
    assert spot == (275, 200 - LIFT - 17)


def test_a_label_stands_over_the_thing_it_names_when_told_where_its_top_is():
    points, sizes = np.array([(300.0, 200.0), (100.0, 100.0)]), [(50, 17), (50, 17)]
    tops = np.array([(302.0, 170.0), (np.nan, np.nan)])
    spots = place_labels(points, sizes, WIDTH, HEIGHT, tops)
    assert spots == [(275, 170 - LIFT - 17), (75, 100 - LIFT - 17)]  # centred on the point


def test_labels_of_one_point_stack_apart_near_it():
    spots = _check([(300, 200)] * 4, [(50, 17)] * 4)
    assert spots[0] == (275, 200 - LIFT - 17)
    for x, y in spots:
        assert abs(x + 25 - 300) < 80 and abs(y - 200) < 80  # still near the point


def test_labels_at_the_edges_are_pushed_inside():
    points = [(0, 0), (WIDTH - 1, 0), (0, HEIGHT - 1), (WIDTH - 1, HEIGHT - 1), (320, 2)]
    spots = _check(points, [(60, 17)] * 5)
    assert spots[0][0] == 0 and spots[1][0] == WIDTH - 60  # clamped, not dropped
    assert spots[2][1] + 17 <= HEIGHT and spots[4][1] >= 0


def test_points_outside_the_picture_or_behind_get_no_label():
    spots = place_labels(
        np.array([(np.nan, np.nan), (-5, 10), (10, HEIGHT), (10, 10)]), [(40, 15)] * 4, 640, 480
    )
    assert spots[:3] == [None, None, None] and spots[3] is not None


def test_a_crowd_of_labels_never_overlaps():
    """Forty labels of random sizes at random points, twelve of them at one spot."""
    rng = np.random.default_rng(0)
    points = [tuple(p) for p in rng.uniform((0, 0), (WIDTH, HEIGHT), size=(28, 2)).round()]
    points += [(320.0, 240.0)] * 12
    sizes = [(int(w), 17) for w in rng.integers(30, 90, size=40)]
    _check(points, sizes)


def test_labels_keep_a_gap_and_follow_the_order_given():
    """The first label takes its place of choice; the second, at the same point, another,
    at least GAP pixels away."""
    spots = _check([(100, 100), (100, 100)], [(40, 15), (40, 15)])
    (a, b) = _boxes(spots, [(40, 15)] * 2)
    assert spots[0] == (80, 100 - LIFT - 15)
    apart = max(b[0] - a[2], a[0] - b[2], b[1] - a[3], a[1] - b[3])
    assert apart >= GAP


def test_a_picture_too_small_for_every_label_drops_the_last_ones():
    spots = place_labels(np.array([(50, 20)] * 6), [(90, 16)] * 6, 100, 40)
    placed = [s for s in spots if s is not None]
    assert 1 <= len(placed) < 6 and spots[0] is not None
    boxes = _boxes(placed, [(90, 16)] * len(placed))
    assert not any(_overlap(a, b) for i, a in enumerate(boxes) for b in boxes[:i])
