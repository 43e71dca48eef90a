"""Placement: the tree's dynamic programme against brute force, the medial graph's counts, and PCK on
generated drawings (train seeds of the tuned styles; the benchmark reports test seeds and held-out styles)."""
import itertools

import cv2
import numpy as np
import pytest

from data_samples.generator.characters import PERSON, person
from data_samples.generator.drawing import draw, make_look
from data_samples.generator.model import scaled
from data_samples.generator.styles import KID
from ops.skeleton.medial import medial_graph
from ops.skeleton.placement import WEIGHTS, _Tree, place_template
from ops.skeleton.silhouette import find_silhouette
from ops.skeleton.templates import HUMANOID, SkeletonTemplate


def test_tree_programme_finds_the_brute_force_minimum_and_min_marginals():
    rng = np.random.default_rng(0)
    template = SkeletonTemplate("fork", ("a", "b", "c", "d"), (-1, 0, 1, 1), rng.uniform(0, 1, (4, 2)))
    N = 5
    spots = rng.uniform(0, 100, (N, 2))
    euclid = np.linalg.norm(spots[:, None] - spots[None], axis=2)
    geodesic = euclid * rng.uniform(1.0, 1.5, (N, N))
    geodesic = np.minimum(geodesic, geodesic.T)
    tree = _Tree(template, spots, geodesic, np.array([0, 3]), rng.uniform(0, 20, N), np.array([0, 0, 100, 100]),
                 WEIGHTS)
    unary = tree.unary + rng.uniform(0, 0.5, tree.unary.shape)
    best, marg = tree.solve(unary)

    def energy(assign):
        e = sum(unary[j, assign[j]] for j in range(4))
        return e + sum(tree.pair[c][assign[tree.parents[c]], assign[c]] for c in range(1, 4))

    all_e = {a: energy(a) for a in itertools.product(range(N), repeat=4)}
    low = min(all_e, key=all_e.get)
    assert np.isclose(energy(tuple(best)), all_e[low])
    for j in range(4):
        for n in range(N):
            assert np.isclose(marg[j, n], min(e for a, e in all_e.items() if a[j] == n))


def test_medial_graph_of_a_cross_has_four_ends_and_a_bump_grows_none():
    cross = np.zeros((120, 120), bool)
    cross[55:65, 10:110] = True
    cross[10:110, 55:65] = True
    assert len(medial_graph(cross).ends) == 4
    bar = np.zeros((60, 160), bool)
    bar[20:40, 10:150] = True
    bar[17:20, 70:76] = True  # a 3-pixel bump on the outline
    g = medial_graph(bar)
    assert len(g.ends) == 2 and np.allclose(g.radius.max(), 10, atol=1.5)


def test_silhouette_of_a_figure_on_tinted_paper_and_refusal_of_a_blank_page():
    page = np.ones((160, 160, 3), np.float32) * np.array([0.93, 0.9, 0.8], np.float32)
    img = page.copy()
    cv2.circle(img, (80, 60), 25, (0.2, 0.2, 0.2), 2)
    cv2.line(img, (80, 85), (80, 140), (0.2, 0.2, 0.2), 3)
    sil = find_silhouette(img)
    disc = np.zeros((160, 160), np.uint8)
    cv2.circle(disc, (80, 60), 26, 1, -1)
    assert (sil.mask & (disc > 0)).sum() / (disc > 0).sum() > 0.95  # the head's inside is filled
    with pytest.raises(ValueError):
        find_silhouette(page)


def person_drawing(seed: int, style: str = "ink"):
    """A generated person, arms out, legs apart: (image, (16, 2) humanoid truth, height)."""
    rng = np.random.default_rng(seed)
    angles = {4: rng.uniform(120, 200), 5: rng.uniform(120, 200), 7: rng.uniform(-20, 60), 8: rng.uniform(-20, 60),
              10: rng.uniform(95, 115), 14: rng.uniform(65, 85)}
    pose = PERSON.pose((0.0, 0.0), angles)
    size = (224, 224)
    lo, hi = pose[:, :2].min(0) - 22, pose[:, :2].max(0) + 22
    k = 0.75 * min(size[1] / (hi[0] - lo[0]), size[0] / (hi[1] - lo[1]))
    pose[:, :2] = k * (pose[:, :2] - lo) + 0.5 * (np.array(size[::-1]) - k * (hi - lo))
    d = draw(scaled(person(seed, skirt=False), k), pose, size, make_look(style, KID, size, seed))
    i = {n: j for j, n in enumerate(PERSON.joints)}
    p = lambda n: pose[i[n], :2]  # noqa: E731
    truth = {"root": p("pelvis"), "hip": p("pelvis"), "torso": p("neck"), "neck": 0.5 * (p("neck") + p("head"))}
    for side, s in (("right", "r"), ("left", "l")):
        truth |= {f"{side}_shoulder": p(f"{s}_shoulder"), f"{side}_elbow": p(f"{s}_elbow"), f"{side}_hand": p(f"{s}_hand"),
                  f"{side}_hip": p(f"{s}_hip"), f"{side}_knee": p(f"{s}_knee"),
                  f"{side}_foot": 0.5 * (p(f"{s}_ankle") + p(f"{s}_toe"))}
    height = float(np.ptp(np.nonzero(d.union > 0.5)[0]) + 1)
    return d.rgb.astype(np.float32) / 255, np.array([truth[n] for n in HUMANOID.joints]), height


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_humanoid_lands_on_a_generated_person(seed):
    img, truth, height = person_drawing(seed)
    placed = place_template(find_silhouette(img).mask, HUMANOID)
    err = np.linalg.norm(placed.positions - truth, axis=1) / height
    assert (err < 0.15).mean() >= 0.8, dict(zip(HUMANOID.joints, err.round(2)))
    assert placed.confidence.shape == (16,) and ((placed.confidence >= 0) & (placed.confidence <= 1)).all()
    # left and right are not swapped: the right hand (image left) lies left of the left hand
    J = HUMANOID.joints
    assert placed.positions[J.index("right_hand"), 0] < placed.positions[J.index("left_hand"), 0]
