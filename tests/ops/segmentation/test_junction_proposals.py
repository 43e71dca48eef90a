"""Tests of T-junction proposals: the T's of a drawn occlusion are found where the outlines meet; crossings are not."""
from __future__ import annotations

import cv2
import numpy as np

from ops.segmentation.junction_proposals import (
    MERGE_PX,
    line_map,
    propose_t_junctions,
    t_junction_candidates,
)
from ops.types import Masks, Skeleton

S = 128
CENTRE, RADIUS = (56.0, 64.0), 34.0
BAR_Y0, BAR_Y1 = 58, 70  # a bar lying over the disc and out past its right side
BODY, ARM = (0.45, 0.75, 0.35), (0.85, 0.55, 0.3)
INK = (0.1, 0.15, 0.1)


def occluded_drawing() -> tuple[np.ndarray, np.ndarray]:
    """A round body with a 2 px outline and a bar in front of it crossing its right edge: (colour, coverage)."""
    img = np.ones((S, S, 3), np.float32)
    c = (int(CENTRE[0]), int(CENTRE[1]))
    cv2.circle(img, c, int(RADIUS), BODY, -1, cv2.LINE_AA)
    cv2.circle(img, c, int(RADIUS), INK, 2, cv2.LINE_AA)
    cv2.rectangle(img, (40, BAR_Y0), (115, BAR_Y1), ARM, -1)
    cv2.rectangle(img, (40, BAR_Y0), (115, BAR_Y1), INK, 2)
    cover = (np.abs(img - 1.0).sum(axis=2) > 0.02).astype(np.float32)
    return img, cover


def true_junctions() -> np.ndarray:
    """(2, 2) where the body's outline meets the bar's outline outside the bar (x > centre)."""
    pts = []
    for y in (BAR_Y0, BAR_Y1):
        dx = np.sqrt(RADIUS**2 - (y - CENTRE[1]) ** 2)
        pts.append((CENTRE[0] + dx, float(y)))
    return np.array(pts)


def masks_of(colour: np.ndarray, coverage: np.ndarray, occlusion: list[np.ndarray]) -> Masks:
    """Masks as build_masks would give them for a drawing on white paper."""
    fg = coverage > 0.5
    return Masks(foreground=fg, occlusion=occlusion, front_bones=[np.array([2])] * len(occlusion), source="predicted",
                 coverage=coverage, paper=np.ones(colour.shape, np.float32), colour=colour,
                 holes=np.zeros(fg.shape, bool), n_holes=0)


SKELETON = Skeleton(("hip", "neck", "shoulder", "hand"), np.array([-1, 0, 1, 2]))
# the body's bone runs down the disc; the arm (bone 2) along the bar, in front (smaller z); they share no joint
POSE = np.array([[56.0, 92.0, 0.0], [56.0, 36.0, 0.0], [46.0, 64.0, -1.0], [112.0, 64.0, -1.0]])


def test_outline_ends_are_found_where_they_meet_the_covering_outline():
    colour, coverage = occluded_drawing()
    cands = t_junction_candidates(line_map(colour, coverage))
    for t in true_junctions():
        d = np.linalg.norm(cands.points - t, axis=1)
        assert d.min() <= 2.0, f"no candidate within 2 px of {t}: nearest {d.min():.1f}"
        best = int(np.argmin(d))
        # the stem is the body's outline: it leaves the junction away from the bar, up or down
        assert abs(cands.stems[best][1]) > 0.5
        assert (cands.stems[best][1] < 0) == (t[1] == BAR_Y0)


def test_two_lines_crossing_are_not_a_t():
    img = np.ones((S, S, 3), np.float32)
    cv2.line(img, (10, 64), (118, 64), INK, 2, cv2.LINE_AA)
    cv2.line(img, (64, 10), (64, 118), INK, 2, cv2.LINE_AA)
    cov = np.ones((S, S), np.float32)  # one flat character: the lines are texture on it
    cands = t_junction_candidates(line_map(img, cov))
    assert not len(cands.points) or np.linalg.norm(cands.points - (64.0, 64.0), axis=1).min() > 3.0


def test_proposals_are_scored_sorted_and_apart():
    colour, coverage = occluded_drawing()
    yy, xx = np.mgrid[0:S, 0:S]
    overlap = ((xx - CENTRE[0]) ** 2 + (yy - CENTRE[1]) ** 2 <= RADIUS**2) & (yy >= BAR_Y0) & (yy <= BAR_Y1)
    props = propose_t_junctions(masks_of(colour, coverage, [overlap]), POSE, SKELETON, min_score=0.0)
    assert len(props.points) == len(props.scores) == len(props.stems) == len(props.regions)
    assert np.all(np.diff(props.scores) <= 0) and props.scores.min() >= 0 and props.scores.max() <= 1
    d = np.linalg.norm(props.points[:, None] - props.points[None], axis=2) + np.eye(len(props.points)) * 1e9
    assert d.min() >= MERGE_PX
    assert (props.regions == 0).all()
    # the two true junctions are among the best proposals
    top = props.points[: max(4, len(true_junctions()))]
    for t in true_junctions():
        assert np.linalg.norm(top - t, axis=1).min() <= 2.5


def test_empty_drawing_proposes_nothing():
    colour = np.ones((64, 64, 3), np.float32)
    cov = np.zeros((64, 64), np.float32)
    cov[20:40, 20:40] = 1.0
    colour[20:40, 20:40] = BODY
    props = propose_t_junctions(masks_of(colour, cov, []), POSE * 0.5, SKELETON)
    assert props.points.shape == (0, 2) and props.scores.shape == (0,)
