"""Foreground of drawings on paper: paper model, skeleton prior, holes, soft coverage (known answers)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from scipy import ndimage

from ops.segmentation.bones import bone_capsules, segment_distance
from ops.segmentation.foreground import MARGIN_PX, foreground_from_mask, segment_foreground
from ops.segmentation.paper import estimate_paper, linear_to_srgb, srgb_to_linear
from ops.shotio.image_io import read_image
from ops.shotio.load import load_shot
from ops.types import Skeleton

OFF_WHITE = np.array([0.96, 0.94, 0.87], np.float32)
INK = np.array([0.12, 0.14, 0.30], np.float32)
SS = 4  # supersampling per axis for anti-aliased area coverage
SAMPLES = Path(__file__).resolve().parents[3] / "data_samples"


def subgrid(shape: tuple[int, int], ss: int = SS) -> np.ndarray:
    """(H * ss, W * ss, 2) float64 (x, y) sample positions inside every pixel (pixel centres at integers)."""
    ys, xs = np.mgrid[0 : shape[0] * ss, 0 : shape[1] * ss]
    return np.stack([(xs + 0.5) / ss - 0.5, (ys + 0.5) / ss - 0.5], axis=-1)


def area(inside: np.ndarray, ss: int = SS) -> np.ndarray:
    """(H, W) float32 share of each pixel's (ss x ss) samples that are inside: its area coverage."""
    h, w = inside.shape[0] // ss, inside.shape[1] // ss
    return inside.reshape(h, ss, w, ss).mean(axis=(1, 3)).astype(np.float32)


def capsule_sdf(p: np.ndarray, a, b, r: float) -> np.ndarray:
    """Signed distance, pixels, of (..., 2) points to the capsule a-b of radius r (negative inside)."""
    return segment_distance(p, np.asarray(a, float), np.asarray(b, float)) - r


def paint(paper: np.ndarray, layers: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """(H, W, 3) float32: (coverage (H, W), colour (3,)) layers composited in order over a paper colour."""
    shape = layers[0][0].shape
    img = np.broadcast_to(np.asarray(paper, np.float32), shape + (3,)).copy()
    for cov, colour in layers:
        img = cov[..., None] * np.asarray(colour, np.float32) + (1 - cov[..., None]) * img
    return img


def noisy(img: np.ndarray, sigma: float = 0.004, seed: int = 0) -> np.ndarray:
    """The image with Gaussian sensor noise, clipped to [0, 1]."""
    rng = np.random.default_rng(seed)
    return np.clip(img + rng.normal(0, sigma, img.shape).astype(np.float32), 0, 1)


def psnr(a: np.ndarray, b: np.ndarray, where: np.ndarray) -> float:
    """PSNR, dB, of two (H, W, 3) images in [0, 1] over the (H, W) bool pixels `where`."""
    mse = float(((a - b)[where] ** 2).mean())
    return 10 * np.log10(1.0 / max(mse, 1e-12))


def recomposed(fg) -> np.ndarray:
    """(H, W, 3) coverage * colour + (1 - coverage) * paper of a Foreground."""
    c = fg.coverage[..., None]
    return c * fg.colour + (1 - c) * fg.paper


def chain(names: list[str]) -> Skeleton:
    """A skeleton whose joints form one chain, root first."""
    return Skeleton(tuple(names), np.arange(len(names)) - 1)


def hand_on_hip(size: int = 192):
    """Line art: an outlined torso and an outlined arm whose hand rests on the hip, enclosing a loop of paper.

    Returns (drawing, pose (5, 3), skeleton, filled body (H, W) bool, enclosed paper (H, W) bool).
    """
    shape = (size, size)
    p = subgrid(shape)
    torso = capsule_sdf(p, (80, 45), (80, 150), 24)
    arm = np.minimum(capsule_sdf(p, (98, 50), (150, 95), 9), capsule_sdf(p, (150, 95), (100, 138), 9))
    half = 1.3  # stroke half-width, pixels
    # the arm is drawn in front: the torso's outline is hidden where the arm covers it
    stroke = (np.abs(arm) <= half) | ((np.abs(torso) <= half) & (arm > half))
    drawing = paint(OFF_WHITE, [(area(stroke), INK)])
    centres = subgrid(shape, 1)
    body = (capsule_sdf(centres, (80, 45), (80, 150), 24) <= 0) | (
        np.minimum(capsule_sdf(centres, (98, 50), (150, 95), 9), capsule_sdf(centres, (150, 95), (100, 138), 9)) <= 0
    )
    outside, _ = ndimage.label(~body)
    enclosed = (outside > 0) & (outside != outside[0, 0])
    skeleton = chain(["hips", "neck", "shoulder", "elbow", "hand"])
    pose = np.array([[80, 150, 0], [80, 45, 0], [98, 50, 0], [150, 95, 0], [100, 138, 0.0]])
    return noisy(drawing), pose, skeleton, body, enclosed


def test_paper_enclosed_by_an_arm_is_a_hole():
    drawing, pose, skeleton, body, enclosed = hand_on_hip()
    fg = segment_foreground(drawing, pose, skeleton)
    assert fg.n_holes == 1
    # the loop minus the outline's half-width and the mask's rim
    core = ndimage.distance_transform_edt(enclosed) > 6
    assert core.sum() > 150 and not (fg.mask & core).any() and fg.holes[core].all()
    assert fg.mask[ndimage.binary_erosion(body, iterations=1)].all()  # the hollow arm and torso stay character


def test_a_bone_along_the_arms_inner_stroke_grazes_the_hole_without_opening_it():
    """Joints clicked on a thin arm's inner outline (the side facing the loop) put its bones within a capsule's
    width of the enclosed paper: the paper is still background seen through the loop (a raised forearm beside the
    face, realdev rd03), while a bone whose line runs through the paper makes it a limb's inside."""
    drawing, pose, skeleton, _, enclosed = hand_on_hip()
    towards_loop = np.array([[-0.654, 0.756], [-1.0, 0.0], [-0.652, -0.758]])  # shoulder, elbow, hand
    core = ndimage.distance_transform_edt(enclosed) > 6
    for offset, hole in ((12.0, True), (16.0, False)):  # the arm's centre to its inner stroke: 9 px
        moved = pose.copy()
        moved[2:, :2] += offset * towards_loop
        fg = segment_foreground(drawing, moved, skeleton)
        assert (fg.n_holes == 1 and fg.holes[core].all()) if hole else fg.n_holes == 0, offset


def test_lamp_arms_and_base_enclose_a_hole():
    """Solid strokes, bones along them: the triangle of paper between the arms and the base is background."""
    shape = (180, 180)
    p = subgrid(shape)
    strokes = [((40, 150), (140, 150), 5), ((60, 150), (100, 70), 4), ((100, 70), (125, 146), 4)]
    ink = np.min([capsule_sdf(p, a, b, r) for a, b, r in strokes], axis=0) <= 0
    drawing = noisy(paint(OFF_WHITE, [(area(ink), INK)]))
    skeleton = Skeleton(("base_l", "base_r", "pivot", "elbow", "head"), np.array([-1, 0, 0, 2, 3]))
    pose = np.array([[40, 150, 0], [140, 150, 0], [60, 150, 0], [100, 70, 0], [125, 146, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    assert fg.n_holes == 1 and fg.holes[130, 95] and not fg.mask[130, 95]
    assert fg.mask[area(ink) >= 0.5].all()


def test_white_shirt_crossed_by_a_bone_is_not_a_hole():
    shape = (192, 192)
    p = subgrid(shape)
    torso = capsule_sdf(p, (96, 40), (96, 150), 26)
    arms = np.minimum(capsule_sdf(p, (62, 45), (62, 125), 8), capsule_sdf(p, (130, 45), (130, 125), 8))
    belt = np.abs(p[..., 1] - 110) <= 1.3
    half = 1.3
    stroke = (np.abs(arms) <= half) | (((np.abs(torso) <= half) | (belt & (torso < 0))) & (arms > half))
    drawing = noisy(paint(OFF_WHITE, [(area(stroke), INK)]))
    skeleton = Skeleton(("hips", "neck", "l_shoulder", "l_hand", "r_shoulder", "r_hand"), np.array([-1, 0, 1, 2, 1, 4]))
    pose = np.array([[96, 150, 0], [96, 40, 0], [62, 45, 0], [62, 125, 0], [130, 45, 0], [130, 125, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    centres = subgrid(shape, 1)
    shirt = (capsule_sdf(centres, (96, 40), (96, 150), 24) <= 0) & (centres[..., 1] < 106)
    assert fg.n_holes == 0 and fg.mask[shirt].all()
    assert (fg.coverage[shirt] == 1).all()  # the white shirt is opaque character, not paper showing through


def test_insides_cut_open_by_the_frame_are_filled_where_bones_run():
    """Outlined legs run off the bottom edge: their insides are character, the page between them is not."""
    shape = (160, 128)
    p = subgrid(shape)
    legs = [((46, 95), (43, 230)), ((82, 95), (85, 230))]
    body = np.minimum.reduce([capsule_sdf(p, (64, 30), (64, 80), 22)] + [capsule_sdf(p, a, b, 9) for a, b in legs])
    drawing = noisy(paint(OFF_WHITE, [(area(np.abs(body) <= 1.3), INK)]))
    skeleton = Skeleton(("hips", "neck", "l_hip", "l_foot", "r_hip", "r_foot"), np.array([-1, 0, 0, 2, 0, 4]))
    pose = np.array([[64, 90, 0], [64, 25, 0], [46, 95, 0], [44, 158, 0], [82, 95, 0], [84, 158, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    pixel_sdf = body.reshape(shape[0], SS, shape[1], SS).mean(axis=(1, 3))
    assert fg.mask[pixel_sdf <= 0].all()
    gap = (pixel_sdf > 5) & (np.abs(np.arange(128) - 64) < 10)[None, :] & (np.arange(160) > 110)[:, None]
    assert gap.sum() > 200 and not fg.mask[pixel_sdf > 5].any()  # the page, between the legs too


def test_pale_skinned_watercolour_on_off_white_paper_is_whole():
    """No outlines: pale skin, a pink top, black trousers and white boots, softly edged, on off-white paper."""
    shape = (200, 160)
    p = subgrid(shape)
    parts = {
        "skin": (np.minimum(capsule_sdf(p, (80, 35), (80, 40), 17),
                            np.minimum(capsule_sdf(p, (62, 70), (35, 110), 6), capsule_sdf(p, (98, 70), (125, 110), 6))),
                 (1.0, 0.87, 0.77)),
        "top": (capsule_sdf(p, (80, 68), (80, 100), 18), (0.96, 0.72, 0.78)),
        "trousers": (np.minimum(capsule_sdf(p, (72, 115), (68, 160), 8), capsule_sdf(p, (88, 115), (92, 160), 8)),
                     (0.08, 0.08, 0.1)),
        "boots": (np.minimum(capsule_sdf(p, (62, 172), (68, 172), 8), capsule_sdf(p, (92, 172), (98, 172), 8)),
                  (1.0, 1.0, 1.0)),
    }
    layers = []
    for sdf, colour in parts.values():
        inside = sdf <= 0
        soft = ndimage.gaussian_filter(area(inside).astype(np.float64), 1.0).astype(np.float32)
        layers.append((soft, colour))
    drawing = noisy(paint(OFF_WHITE, layers))
    skeleton = Skeleton(
        ("hips", "neck", "head", "l_hand", "r_hand", "l_foot", "r_foot"), np.array([-1, 0, 1, 1, 1, 0, 0])
    )
    pose = np.array([[80, 110, 0], [80, 60, 0], [80, 30, 0], [38, 106, 0], [122, 106, 0], [66, 172, 0],
                     [94, 172, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    for name, (sdf, _) in parts.items():
        pixel_sdf = sdf.reshape(shape[0], SS, shape[1], SS).mean(axis=(1, 3))
        assert fg.mask[pixel_sdf <= -1].all(), name
    truth = np.zeros(shape, bool)
    for sdf, _ in parts.values():
        truth |= sdf.reshape(shape[0], SS, shape[1], SS).mean(axis=(1, 3)) <= 0
    drawn = fg.coverage >= 0.5
    assert (drawn & truth).sum() / (drawn | truth).sum() > 0.93


def test_every_bone_touched_component_is_kept_and_specks_dropped():
    shape = (160, 160)
    p = subgrid(shape)
    head = np.abs(capsule_sdf(p, (80, 30), (80, 30), 16)) <= 1.5  # an outlined head, drawn apart from the body
    body = capsule_sdf(p, (80, 58), (80, 120), 2.0) <= 0  # a stick body
    hand = capsule_sdf(p, (125, 80), (135, 85), 4) <= 0  # a hand floating off the (undrawn) arm
    speck = capsule_sdf(p, (20, 140), (22, 141), 2.5) <= 0  # dirt on the page
    scribble = capsule_sdf(p, (130, 140), (150, 130), 2.0) <= 0  # a signature no bone reaches
    drawing = noisy(paint(OFF_WHITE, [(area(head | body | hand | speck | scribble), INK)]))
    skeleton = Skeleton(("hips", "neck", "head", "hand"), np.array([-1, 0, 1, 1]))
    pose = np.array([[80, 120, 0], [80, 58, 0], [80, 22, 0], [130, 82, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    for part in (head, body, hand):
        assert fg.mask[area(part) >= 0.5].all()
    assert fg.mask[area(capsule_sdf(p, (80, 30), (80, 30), 12) <= 0) > 0].all()  # the head's inside is filled
    assert not fg.mask[area(speck) > 0].any() and not fg.mask[area(scribble) > 0].any()


def test_an_arm_outlined_in_separate_strokes_beside_its_bone_is_kept():
    """Faint pencil: an arm's outline drawn as dashes 7 px either side of its bone, no bone touching them and no
    inside enclosed. The dashes (strokes, within a body's reach) are kept with a warning; a dot as near the bone
    and a stroke 30 px from every bone are not."""
    shape = (160, 160)
    p = subgrid(shape)
    body = capsule_sdf(p, (40, 30), (40, 130), 2.0) <= 0  # a stick body, on its bone
    dashes = np.zeros(p.shape[:2], bool)
    for x0 in (62, 84, 106):  # three dashes on each side of the arm's bone (y = 60), 8 px apart
        for y in (53, 67):
            dashes |= capsule_sdf(p, (x0, y), (x0 + 12, y), 1.2) <= 0
    dot = capsule_sdf(p, (75, 84), (75, 84), 2.5) <= 0  # a dot 24 px below the bone, within its reach: no stroke
    far = capsule_sdf(p, (80, 120), (110, 120), 1.2) <= 0  # a stroke 60 px from the arm, 40 from the body
    drawing = noisy(paint(OFF_WHITE, [(area(body | dashes | dot | far), INK)]))
    skeleton = Skeleton(("hips", "neck", "hand"), np.array([-1, 0, 1]))
    pose = np.array([[40, 130, 0], [40, 60, 0], [130, 60, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    assert fg.mask[area(body) >= 0.5].all() and fg.mask[area(dashes) >= 0.5].all()
    assert not fg.mask[area(dot) > 0].any() and not fg.mask[area(far) > 0].any()
    assert any("kept 6 stroke(s)" in w for w in fg.warnings)


def dashed_ellipse(p: np.ndarray, centre, radii, half: float, gaps: int, gap_px: float) -> np.ndarray:
    """(..., ) bool: an ellipse's outline of stroke half-width `half` at (..., 2) points p, broken by `gaps`
    evenly spaced gaps about gap_px long (along the outline)."""
    d = (p - np.asarray(centre, float)) / np.asarray(radii, float)
    r = np.hypot(d[..., 0], d[..., 1])
    stroke = np.abs(r - 1) * min(radii) <= half
    angle = np.arctan2(d[..., 1], d[..., 0]) % (2 * np.pi)
    gap = gap_px / np.mean(radii)  # radians of outline per gap
    phase = (angle + 0.3) % (2 * np.pi / gaps)
    return stroke & (phase > gap)


def test_a_belly_outlined_in_broken_strokes_is_filled_and_its_dashes_kept():
    """Breaks of 9 px, wider than the closing seals (2 px radius at this size): the inside a bone runs through
    the middle of is the body, and every dash around it is kept with it, not dropped as specks."""
    shape = (192, 192)
    p = subgrid(shape)
    belly = dashed_ellipse(p, (96, 110), (38, 50), 1.4, gaps=6, gap_px=9)
    neck = capsule_sdf(p, (96, 20), (96, 58), 1.6) <= 0  # a stick neck that meets the belly's top
    drawing = noisy(paint(OFF_WHITE, [(area(belly | neck), INK)]))
    skeleton = chain(["hips", "neck", "head"])
    pose = np.array([[96, 150, 0], [96, 70, 0], [96, 22, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    centres = subgrid(shape, 1)
    inside = ((centres[..., 0] - 96) / 36) ** 2 + ((centres[..., 1] - 110) / 48) ** 2 <= 1
    assert fg.mask[inside].all()
    assert fg.mask[area(belly) >= 0.5].all()  # dashes no bone touches are kept: they bound the filled inside
    assert any("broken strokes" in w for w in fg.warnings)


def test_background_between_a_stick_arm_and_the_head_stays_page():
    """A stick arm raised beside an outlined head, its hand 9 px from the head; the arm's bones drawn 5 px off
    its strokes, into the paper between them. Closed across the hand's gap that paper is enclosed and a bone
    crosses it, but only along its edge: it is background, not a body part drawn in broken strokes."""
    shape = (192, 192)
    p = subgrid(shape)
    head = np.abs(capsule_sdf(p, (110, 48), (110, 48), 20)) <= 1.4
    body = capsule_sdf(p, (110, 68), (110, 170), 1.6) <= 0
    arm = np.minimum(capsule_sdf(p, (110, 100), (40, 85), 1.6), capsule_sdf(p, (40, 85), (82, 30), 1.6)) <= 0
    drawing = noisy(paint(OFF_WHITE, [(area(head | body | arm), INK)]))
    skeleton = Skeleton(("hips", "neck", "head", "elbow", "hand"), np.array([-1, 0, 1, 1, 3]))
    # the arm's bones 5 px off its strokes, towards the head
    pose = np.array([[110, 170, 0], [112, 89, 0], [110, 48, 0], [51, 81, 0], [90.5, 36.5, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    between = area(capsule_sdf(p, (70, 70), (80, 75), 3) <= 0) > 0  # paper between the arm, head and body
    assert not fg.mask[between].any()
    assert not any("broken strokes" in w for w in fg.warnings)


def test_rgba_cutout_uses_its_alpha():
    shape = (128, 128)
    p = subgrid(shape)
    ring = (capsule_sdf(p, (64, 64), (64, 64), 40) <= 0) & (capsule_sdf(p, (64, 64), (64, 64), 14) > 0)
    alpha = area(ring)
    rgba = np.zeros(shape + (4,), np.float32)  # black, fully transparent canvas
    rgba[..., :3] = (0.95, 0.95, 0.95)  # a white character: only its alpha tells it from a white page
    rgba[..., 3] = alpha
    skeleton = chain(["a", "b"])
    pose = np.array([[64, 34, 0], [64, 94, 0.0]])  # crosses the transparent middle: alpha still rules
    fg = segment_foreground(rgba, pose, skeleton)
    np.testing.assert_array_equal(fg.mask, alpha > 0)
    np.testing.assert_allclose(fg.coverage, alpha)
    assert fg.n_holes == 1 and fg.holes[64, 64]
    over_white = alpha[..., None] * rgba[..., :3] + (1 - alpha[..., None])
    assert psnr(recomposed(fg), over_white, np.ones(shape, bool)) > 60


def test_paper_model_recovers_a_smooth_gradient():
    shape = (160, 200)
    ys, xs = np.mgrid[0 : shape[0], 0 : shape[1]]
    x, y = xs / shape[1], ys / shape[0]
    # warm paper lit from the upper left, darker towards one corner: a smooth field of linear light
    light = 1.0 - 0.35 * ((x - 0.2) ** 2 + (y - 0.1) ** 2) - 0.1 * x * y
    truth = linear_to_srgb(srgb_to_linear(np.array([0.97, 0.93, 0.84], np.float32)) * light[..., None])
    rng = np.random.default_rng(3)
    p = subgrid(shape)
    strokes = np.zeros(p.shape[:2], bool)
    for _ in range(25):  # scribbled ink over about a tenth of the page
        a, b = rng.uniform([10, 10], [190, 150], (2, 2))
        strokes |= capsule_sdf(p, a, b, rng.uniform(1.0, 3.0)) <= 0
    drawing = noisy(area(strokes)[..., None] * np.float32([0.2, 0.1, 0.1]) + (1 - area(strokes)[..., None]) * truth,
                    0.006)
    paper = estimate_paper(drawing)
    err = np.abs(paper.rgb - truth)
    assert err.max() < 0.02 and err.mean() < 0.004
    assert 0.5 < paper.noise < 3.0  # the page's grain, in ΔE: neither zero nor the ink


def test_jpeg_scan_of_grainy_unevenly_lit_paper():
    """Pencil-grey outline on grainy, vignetted paper, saved as a quality-40 JPEG: one clean silhouette."""
    shape = (192, 256)
    p = subgrid(shape)
    body = capsule_sdf(p, (90, 96), (170, 96), 50)
    ys, xs = np.mgrid[0 : shape[0], 0 : shape[1]]
    light = 1.0 - 0.5 * (((xs - 40) / 256.0) ** 2 + ((ys - 20) / 192.0) ** 2)
    paper = linear_to_srgb(srgb_to_linear(np.float32([0.93, 0.9, 0.82])) * light[..., None])
    rng = np.random.default_rng(5)
    grain = ndimage.gaussian_filter(rng.normal(0, 0.06, shape), 1.2)[..., None].astype(np.float32)
    cov = area(np.abs(body) <= 1.2)
    drawing = np.clip(cov[..., None] * np.float32([0.35, 0.35, 0.38]) + (1 - cov[..., None]) * paper + grain, 0, 1)
    ok, jpeg = cv2.imencode(".jpg", np.round(drawing[..., ::-1] * 255).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, 40])
    scan = cv2.imdecode(jpeg, cv2.IMREAD_COLOR)[..., ::-1].astype(np.float32) / 255
    fg = segment_foreground(scan, np.array([[90, 96, 0], [170, 96, 0.0]]), chain(["a", "b"]))
    truth = body.reshape(shape[0], SS, shape[1], SS).mean(axis=(1, 3)) <= 0
    drawn = fg.coverage >= 0.5
    assert ok and (drawn & truth).sum() / (drawn | truth).sum() > 0.95
    assert ndimage.label(fg.mask)[1] == 1 and fg.n_holes == 0


def anti_aliased_disc(shape=(96, 96), centre=(47.3, 50.6), radius=21.7):
    """(H, W) float32 exact area coverage of a disc (16 x 16 samples per pixel)."""
    p = subgrid(shape, 16)
    return area(np.linalg.norm(p - np.asarray(centre), axis=-1) <= radius, 16)


def test_coverage_of_an_anti_aliased_disc_is_its_area_and_unmixing_reproduces_it():
    cov = anti_aliased_disc()
    drawing = noisy(paint(OFF_WHITE, [(cov, INK)]), 0.002)
    skeleton = chain(["a", "b"])
    pose = np.array([[40, 45, 0], [55, 55, 0.0]])
    fg = segment_foreground(drawing, pose, skeleton)
    edge = (cov > 0) & (cov < 1)
    assert np.abs(fg.coverage - cov)[edge].mean() < 0.03
    assert np.abs(fg.coverage - cov).max() < 0.1
    assert (fg.coverage[cov == 1] == 1).all() and (fg.coverage[~fg.mask] == 0).all()
    assert fg.mask[cov > 0.05].all()  # the whole drawn width is in the mask
    assert psnr(recomposed(fg), drawing, fg.mask) >= 40


def test_anti_aliased_line_art_keeps_its_outer_fringe_and_is_reproduced():
    drawing, pose, skeleton, body, _ = hand_on_hip()
    fg = segment_foreground(drawing, pose, skeleton)
    assert psnr(recomposed(fg), drawing, fg.mask) >= 40
    # the fringe outside the outline is fractional, the outline's inner side opaque
    outer = fg.mask & (fg.coverage > 0) & (fg.coverage < 1)
    assert outer.sum() > 200
    assert not (outer & ndimage.binary_erosion(body, iterations=3)).any()


def test_soft_watercolour_blob_is_reproduced_with_fractional_edge():
    shape = (128, 128)
    p = subgrid(shape)
    blob = area(capsule_sdf(p, (50, 60), (80, 66), 26) <= 0)
    wash = ndimage.gaussian_filter(blob.astype(np.float64), 2.5).astype(np.float32)  # a bleeding edge
    drawing = noisy(paint(OFF_WHITE, [(wash * 0.85, (0.55, 0.7, 0.95))]), 0.003)
    fg = segment_foreground(drawing, np.array([[50, 60, 0], [80, 66, 0.0]]), chain(["a", "b"]))
    assert psnr(recomposed(fg), drawing, fg.mask) >= 40
    assert ((fg.coverage > 0.05) & (fg.coverage < 0.95)).sum() > 0.5 * ((wash > 0.05) & (wash < 0.95)).sum()
    assert fg.mask[wash > 0.2].all() and fg.n_holes == 0


def test_manual_mask_gets_coverage_from_the_drawing():
    cov = anti_aliased_disc()
    drawing = noisy(paint(OFF_WHITE, [(cov, INK)]), 0.002)
    manual = ndimage.distance_transform_edt(cov == 0) <= 3  # painted by hand, 3 px past the drawn edge
    fg = foreground_from_mask(drawing, manual)
    np.testing.assert_array_equal(fg.mask, manual)
    assert np.abs(fg.coverage - cov)[(cov > 0) & (cov < 1)].mean() < 0.05
    assert (fg.coverage[manual & (cov == 0)] < 0.05).all()  # the painted margin is transparent
    assert psnr(recomposed(fg), drawing, fg.mask) >= 40


def test_curled_tail_sample_gets_its_enclosed_paper_as_a_hole():
    shot = load_shot(SAMPLES / "tail")
    drawing = read_image(shot.keyframes[1])
    fg = segment_foreground(drawing, shot.key_pose(1), shot.skeleton)
    paper = drawing[..., :3].min(axis=-1) > 0.9
    labels, _ = ndimage.label(paper)
    sizes = np.bincount(labels.ravel())
    sizes[labels[0, 0]] = 0  # the page around the tail
    sizes[np.unique(labels[bone_capsules(paper.shape, shot.key_pose(1), shot.skeleton, 1.0)])] = 0  # inside the tail
    loop = labels == int(np.argmax(sizes))  # the largest paper region the curled tail encloses
    inner = ndimage.distance_transform_edt(loop) > 4  # less the mask's rim past the outline
    assert fg.n_holes >= 1 and inner.sum() > 50
    assert fg.holes[inner].mean() > 0.9 and not fg.mask[inner].any()


def test_tight_manual_mask_keeps_the_outline_drawn_width():
    """A mask painted a pixel inside the drawn edge: the drawing is still reproduced, the mask kept as painted."""
    cov = anti_aliased_disc()
    drawing = noisy(paint(OFF_WHITE, [(cov, INK)]), 0.002)
    tight = ndimage.distance_transform_edt(cov >= 0.999) > 1  # cuts the soft edge and a pixel of full ink
    assert (cov[~tight] > 0.5).sum() > 50
    fg = foreground_from_mask(drawing, tight)
    np.testing.assert_array_equal(fg.mask, tight)
    everywhere = np.ones(tight.shape, bool)
    assert psnr(recomposed(fg), drawing, everywhere) >= 40
    assert (fg.coverage[ndimage.distance_transform_edt(~tight) > MARGIN_PX + 1] == 0).all()


def test_paper_glued_between_two_bodies_has_no_opaque_specks():
    """Two painted bars 7 px apart, the gap inside the silhouette (closed over) but for a 1 px sliver of paper
    down its middle. Walking outward from a gap pixel crosses the sliver into the other bar's edge; the walk
    must end at the page, or that pixel reads as covered by a stroke and stays an opaque paper speck."""
    from ops.segmentation.coverage import unmix

    h, w = 40, 48
    solid = np.zeros((h, w), bool)
    solid[5:35, 10:37] = True
    solid[5:35, 23] = False  # the sliver: page
    bars = np.zeros_like(solid)
    bars[5:35, 10:20] = bars[5:35, 27:37] = True
    paper = np.full((h, w, 3), (0.95, 0.94, 0.90), np.float32)
    rgb = paper.copy()
    rgb[bars] = (0.93, 0.55, 0.65)
    rgb[solid & ~bars] += 0.01  # the paper's grain: above the paper threshold, far below ink
    delta = np.where(bars, 30.0, np.where(solid, 1.5, 0.2)).astype(np.float32)
    ink = delta > 4.0
    coverage, _ = unmix(rgb, paper, solid, solid, ink, ink, delta, 4.0, 1.0)
    gap = solid & ~bars
    assert coverage[gap].max() < 0.5
    assert (coverage[bars] == 1).all()


def test_a_drawing_on_a_wide_page_is_read_as_on_its_own():
    """Gaps are sealed by the character's size, not its page's: legs_cross's key0 on a page 300 px wider on every
    side (856 px: a page-sized seal would be 7 px and glue the legs together) gets the same foreground."""
    shot = load_shot(SAMPLES / "legs_cross")
    drawing = read_image(shot.keyframes[0])
    pose = shot.key_pose(0)
    alone = segment_foreground(drawing, pose, shot.skeleton)
    pad = 300
    page = np.pad(drawing, ((pad, pad), (pad, pad), (0, 0)), mode="edge")  # its corners are paper
    wide = segment_foreground(page, pose + [pad, pad, 0], shot.skeleton)
    assert not wide.mask[:pad].any() and not wide.mask[-pad:].any()
    inner = wide.mask[pad:-pad, pad:-pad]
    assert (inner != alone.mask).sum() <= 0.002 * alone.mask.sum()  # the paper read on the wider page moves a few rim pixels
    np.testing.assert_array_equal(wide.holes[pad:-pad, pad:-pad], alone.holes)
