"""T-junction proposals from the drawing's ink, for keyframes that arrive without clicks (§4.1).

Where one part covers another, the covered part's outline stops against the covering part's outline: in the
thinned ink (a skeleton of the drawing's lines) that is a branch point where two branches run on as one
line (the covering outline) and a third, the stem, meets it at an angle (the covered outline). The ink is
every thin dark structure of the character (L* below the morphological closing of its neighbourhood), plus,
for paint without outlines, the edges between colours (a watercolour's washes). A branch point is a
candidate (and so is a line's end that stops just short of another line); each is scored by a logistic
model of what is read there: its shape, its nearness to the keyframe's predicted occlusion regions
(ops.segmentation.masks.build_masks), and whether the bodies on the two sides of the covering outline are
those of two bones that share no joint, the front one nearer (a joint's outlines meet in T's too).
Candidates closer than MERGE_PX are one. A click always wins: proposals are for keyframes without clicks,
and each carries the stem's direction so the editor can draw it as a proposal to accept or reject.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage
from skimage.morphology import skeletonize

from ops.segmentation.bones import bone_depths, bone_regions, thick_regions
from ops.segmentation.contacts import scale_of
from ops.types import Masks, RefinedMasks, Skeleton

INK_CONTRAST_L = 10.0  # L* units: a line is this much darker than the closing of its neighbourhood
INK_MAX_WIDTH_PX = 5  # half the widest line (the closing's disc radius) at the reference size
EDGE_DE = 12.0  # CIE76 step across a colour edge (paint without ink) that counts as a line
BRANCH_PX = 7  # branches are followed this far (reference size) to read their directions
MIN_BRANCH_PX = 3  # a branch shorter than this is a spur of the thinning, not a line
CROSSING_COS = 0.97  # two pairs of branches each within ~14 deg of straight on: two lines crossing, not a T
GAP_PX = 4.0  # a line that ends this close to another line (reference size) meets it
SIDE_PX = 3.0  # the bodies around a candidate are read this far from it (reference size)
NEAR_REGION_PX = 8.0  # a junction lies this close to an occlusion region (reference size)
MERGE_PX = 3.0  # candidates closer than this are one
MIN_SCORE = 0.3  # proposals below this score are left out (best recall x precision on the tuning split)
FEATURES = ("bias", "straight", "stem sine", "branch length", "line end at a gap", "near a region", "on a region",
            "front side in two bodies apart", "a stem side behind the front", "stem parts two bodies",
            "nearest bones across the outline apart", "... and the front one nearer")
# logistic weights of FEATURES, fitted on the tuning split (python benchmarks/bench_junctions.py --fit); a straight
# covering outline weighs against: the T's that matter lie on round bodies, where outlines turn at the junction
WEIGHTS = np.array([-3.51, -1.94, 0.86, 0.92, -0.42, -0.32, 0.58, 3.05, 0.21, 0.19, 0.46, 0.33])


@dataclass
class JunctionProposals:
    """Candidate T-junctions of one keyframe, best first."""

    points: np.ndarray  # (k, 2) float64 x, y pixels
    scores: np.ndarray  # (k,) float64 in [0, 1]
    stems: np.ndarray  # (k, 2) float64 unit: the covered outline's direction, pointing away from the junction
    regions: np.ndarray  # (k,) int64 index of the nearest occlusion region (-1 when there is none)


def _lab(colour: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 RGB [0, 1] -> CIE Lab."""
    return cv2.cvtColor(np.clip(np.asarray(colour, np.float32), 0.0, 1.0), cv2.COLOR_RGB2Lab)


def line_map(colour: np.ndarray, coverage: np.ndarray) -> np.ndarray:
    """(H, W) bool lines of a drawing: its ink (thin dark structures on the character, the silhouette's outline
    included) and, away from ink, the edges between its colours. colour (H, W, 3) float32 unmixed from the
    paper; coverage (H, W) float32."""
    solid = np.asarray(coverage) >= 0.5
    lab = _lab(colour)
    L = np.where(solid, lab[..., 0], 100.0).astype(np.float32)  # paper is white: an outline against it is a line
    r = max(2, int(round(INK_MAX_WIDTH_PX * scale_of(solid.shape))))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    ink = (cv2.morphologyEx(L, cv2.MORPH_BLACKHAT, disc, borderType=cv2.BORDER_REPLICATE) >= INK_CONTRAST_L) & solid
    # colour edges: the step across a pixel in Lab, smoothed a little against granulation and JPEG noise
    smooth = cv2.GaussianBlur(np.where(solid[..., None], lab, np.array([100.0, 0.0, 0.0], np.float32)), (0, 0), 1.0)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    step = 2.0 * np.sqrt((gx**2 + gy**2).sum(axis=2))  # about the CIE76 difference across a sharp edge
    edges = _thin_ridges(step, EDGE_DE)
    near_ink = ndimage.binary_dilation(ink, iterations=2)
    near_char = ndimage.binary_dilation(solid, iterations=1)
    return ink | (edges & ~near_ink & near_char)


def _thin_ridges(step: np.ndarray, threshold: float) -> np.ndarray:
    """(H, W) bool ridge pixels of an edge strength (H, W): above threshold and a local maximum across the
    strength's own gradient direction (non-maximum suppression on 4 directions)."""
    gy, gx = np.gradient(step)
    angle = (np.round(np.arctan2(gy, gx) / (np.pi / 4)) % 4).astype(np.int64)
    pad = np.pad(step, 1, mode="edge")
    h, w = step.shape
    keep = np.zeros(step.shape, bool)
    for a, (dy, dx) in enumerate(((0, 1), (1, 1), (1, 0), (1, -1))):
        fwd = pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        back = pad[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        keep |= (angle == a) & (step >= fwd) & (step >= back)
    return keep & (step >= threshold)


_NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def _branches(skel: np.ndarray, cluster: np.ndarray, reach: int) -> list[np.ndarray]:
    """The branches leaving a cluster (c, 2) (y, x) of branch pixels of a (H, W) bool skeleton: per branch its
    pixels (n, 2) (y, x) in order from the cluster, followed up to `reach` pixels or the next branch point."""
    h, w = skel.shape
    own = {(int(y), int(x)) for y, x in cluster}
    seen = set(own)
    out = []
    for y, x in cluster:
        for dy, dx in _NEIGHBOURS:
            p = (int(y) + dy, int(x) + dx)
            if p in seen or not (0 <= p[0] < h and 0 <= p[1] < w) or not skel[p]:
                continue
            path = [p]
            seen.add(p)
            while len(path) < reach:
                cy, cx = path[-1]
                nxt = [(cy + a, cx + b) for a, b in _NEIGHBOURS
                       if 0 <= cy + a < h and 0 <= cx + b < w and skel[cy + a, cx + b] and (cy + a, cx + b) not in seen]
                if len(nxt) != 1:
                    break  # a line's end, or another branch point
                seen.add(nxt[0])
                path.append(nxt[0])
            out.append(np.array(path, np.int64))
    return out


@dataclass
class Candidates:
    """T-shaped places of a keyframe's line skeleton and what is read at each (c candidates)."""

    points: np.ndarray  # (c, 2) float64 x, y pixels
    stems: np.ndarray  # (c, 2) float64 unit direction of the stem, away from the junction
    throughs: np.ndarray  # (c, 2) float64 unit direction of the covering outline
    straight: np.ndarray  # (c,) -cos of the angle between the covering outline's two branches (1: straight)
    sine: np.ndarray  # (c,) |sin| of the angle between stem and covering outline (1: square)
    length: np.ndarray  # (c,) shortest of the T's three branches / BRANCH_PX (at most 1)
    gap: np.ndarray  # (c,) bool: a line's end short of another line (not a branch point of the skeleton)


def _direction(branch: np.ndarray, centre: np.ndarray) -> np.ndarray | None:
    """Unit (x, y) direction from centre (2,) to a branch's far end ((n, 2) (y, x) pixels), None if degenerate."""
    d = branch[-1][::-1].astype(np.float64) - centre
    n = float(np.linalg.norm(d))
    return d / n if n > 1e-9 else None


def _clean_skeleton(lines: np.ndarray, min_px: int) -> np.ndarray:
    """(H, W) bool skeleton of the lines without pieces shorter than min_px (specks of granulation, noise)."""
    skel = skeletonize(lines)
    labels, n = ndimage.label(skel, structure=np.ones((3, 3), bool))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    return skel & (sizes >= min_px)[labels]


def t_junction_candidates(lines: np.ndarray) -> Candidates:
    """Candidates of the (H, W) bool lines: every branch point of their skeleton with three branches of at
    least MIN_BRANCH_PX (its best T: the two branches nearest one straight line are the covering outline), and
    every line end that stops within GAP_PX of another line (the stem ends short of the covering outline)."""
    scale = scale_of(lines.shape)
    reach = max(BRANCH_PX, int(round(BRANCH_PX * scale)))
    skel = _clean_skeleton(lines, 2 * reach)
    count = ndimage.convolve(skel.astype(np.int32), np.ones((3, 3), np.int32), mode="constant") - 1
    clusters, _ = ndimage.label(skel & (count >= 3), structure=np.ones((3, 3), bool))
    rows = []
    for c, sl in enumerate(ndimage.find_objects(clusters), start=1):
        ys, xs = np.nonzero(clusters[sl] == c)
        cluster = np.stack([ys + sl[0].start, xs + sl[1].start], axis=1)
        centre = cluster[:, ::-1].mean(axis=0).astype(np.float64)
        branches = [b for b in _branches(skel, cluster, reach) if len(b) >= MIN_BRANCH_PX]
        dirs = [d for d in (_direction(b, centre) for b in branches) if d is not None]
        lengths = [len(b) for b, d in zip(branches, (_direction(b, centre) for b in branches)) if d is not None]
        best = _best_t(dirs, lengths, reach)
        if best is not None:
            rows.append((centre, *best, False))
    rows += _gap_candidates(skel, count, reach, GAP_PX * scale)
    if not rows:
        z = np.zeros((0, 2))
        return Candidates(z, z, z, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, bool))
    pts, stems, throughs, straight, sine, length, gap = zip(*rows)
    return Candidates(np.array(pts), np.array(stems), np.array(throughs), np.array(straight), np.array(sine),
                      np.array(length), np.array(gap, bool))


def _best_t(dirs: list[np.ndarray], lengths: list[int], reach: int):
    """(stem, through, straightness, sine, length share) of the best T among branch directions, or None."""
    if len(dirs) < 3:
        return None
    opposite = [(i, j) for i in range(len(dirs)) for j in range(i + 1, len(dirs)) if dirs[i] @ dirs[j] < -CROSSING_COS]
    if any(not ({*a} & {*b}) for a in opposite for b in opposite):
        return None  # two lines crossing: nothing covered
    best, best_value = None, -np.inf
    for i in range(len(dirs)):
        for j in range(i + 1, len(dirs)):
            straight = -float(dirs[i] @ dirs[j])
            through = dirs[i] - dirs[j]
            through /= max(float(np.linalg.norm(through)), 1e-9)
            for k in range(len(dirs)):
                if k in (i, j):
                    continue
                sine = abs(float(through[0] * dirs[k][1] - through[1] * dirs[k][0]))
                value = (1.0 + straight) * sine
                if value > best_value:
                    length = min(lengths[i], lengths[j], lengths[k]) / reach
                    best, best_value = (dirs[k], through, straight, sine, min(1.0, length)), value
    return best


def _gap_candidates(skel: np.ndarray, count: np.ndarray, reach: int, gap: float) -> list[tuple]:
    """Line ends of the skeleton (H, W) whose own direction, carried on up to `gap` px, meets another line."""
    h, w = skel.shape
    rows = []
    for y, x in np.argwhere(skel & (count == 1)):
        branch = _branches(skel, np.array([[y, x]]), reach)
        if not branch or len(branch[0]) < MIN_BRANCH_PX:
            continue
        end = np.array([x, y], np.float64)
        back = _direction(branch[0], end)
        if back is None:
            continue
        own = {(int(a), int(b)) for a, b in branch[0]} | {(int(y), int(x))}
        for t in np.arange(1.0, gap + 0.5, 0.5):
            q = end - t * back
            qy, qx = int(round(q[1])), int(round(q[0]))
            if not (0 <= qy < h and 0 <= qx < w):
                break
            hit = [(qy + a, qx + b) for a in (-1, 0, 1) for b in (-1, 0, 1)
                   if 0 <= qy + a < h and 0 <= qx + b < w and skel[qy + a, qx + b] and (qy + a, qx + b) not in own]
            if hit:
                near = np.argwhere(skel[max(0, qy - 3):qy + 4, max(0, qx - 3):qx + 4]) + (max(0, qy - 3), max(0, qx - 3))
                near = np.array([p for p in near if (int(p[0]), int(p[1])) not in own], np.float64)
                if len(near) < 2:
                    break
                c = near[:, ::-1].mean(axis=0)
                _, v = np.linalg.eigh((near[:, ::-1] - c).T @ (near[:, ::-1] - c))
                through = v[:, 1]
                sine = abs(float(through[0] * back[1] - through[1] * back[0]))
                rows.append((q, back, through, 1.0, sine, min(1.0, len(branch[0]) / reach), True))
                break
    return rows


def _merge(points: np.ndarray, scores: np.ndarray, radius: float) -> np.ndarray:
    """(k,) int64 indices of the points (n, 2) kept, best score first, none within `radius` of a better one."""
    keep: list[int] = []
    for i in np.argsort(-scores, kind="stable"):
        if all(np.linalg.norm(points[i] - points[j]) >= radius for j in keep):
            keep.append(int(i))
    return np.asarray(keep, np.int64)


def features(cands: Candidates, masks: Masks | RefinedMasks, pose: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(c, len(FEATURES)) float64 what the scoring weighs at each candidate (see FEATURES).

    Bodies are the bones' thick regions (ops.segmentation.bones.thick_regions: within each bone's radius of it,
    overlapping where bodies overlap); the front side is the side of the covering outline away from the stem,
    the stem's sides are either side of the stem, each sampled SIDE_PX (scaled) from the junction.
    """
    shape = masks.foreground.shape
    c = len(cands.points)
    out = np.zeros((c, len(FEATURES)))
    if c == 0:
        return out
    scale = scale_of(shape)
    out[:, 0] = 1.0
    out[:, 1], out[:, 2], out[:, 3], out[:, 4] = cands.straight, cands.sine, cands.length, cands.gap
    if masks.occlusion:
        dist = ndimage.distance_transform_edt(~np.any(masks.occlusion, axis=0))
        d = _at(dist, cands.points)
        out[:, 5] = np.clip(1.0 - d / (NEAR_REGION_PX * scale), 0.0, 1.0)
        out[:, 6] = d <= 2.0 * scale
    bodies = thick_regions(masks.foreground, pose, skeleton)  # (B, H, W)
    adjacent = skeleton.adjacent_bones()
    depth = bone_depths(pose, skeleton)
    r = SIDE_PX * scale
    normal = cands.stems - (cands.stems * cands.throughs).sum(axis=1, keepdims=True) * cands.throughs
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-9)
    front = _members(bodies, cands.points - r * normal)  # (c, B)
    sides = [_members(bodies, cands.points + r * normal + sign * r * cands.throughs) for sign in (-1.0, 1.0)]
    for i in range(c):
        f = np.nonzero(front[i])[0]
        out[i, 7] = any(not adjacent[a, b] for a in f for b in f if a < b)
        for side in sides:
            for b in np.nonzero(side[i] & ~front[i])[0]:
                if any(not adjacent[a, b] and depth[a] < depth[b] for a in f):
                    out[i, 8] = 1.0
        out[i, 9] = (sides[0][i] != sides[1][i]).any()  # the stem parts two different bodies (or body and paper)
    # the same read by the nearest bone alone (a Voronoi of the bones): joints (an upper arm under the
    # shoulder's outline, a neck into the body) have neighbours on the two sides, occlusions do not
    voronoi = bone_regions(masks.foreground, pose, skeleton)
    owner = np.where(voronoi.any(axis=0), np.argmax(voronoi, axis=0), -1)
    f_own = _at(owner, cands.points - r * normal)
    for side in (-1.0, 1.0):
        s_own = _at(owner, cands.points + r * normal + side * r * cands.throughs)
        apart = (f_own >= 0) & (s_own >= 0) & (f_own != s_own)
        apart[apart] = ~adjacent[f_own[apart], s_own[apart]]
        out[:, 10] = np.maximum(out[:, 10], apart)
        nearer = apart.copy()
        nearer[apart] = depth[f_own[apart]] < depth[s_own[apart]]
        out[:, 11] = np.maximum(out[:, 11], nearer)
    return out


def _at(field: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(k,) values of a (H, W) field at the pixels nearest points (k, 2) x, y (clipped to the image)."""
    ij = np.clip(np.round(points[:, ::-1]).astype(np.int64), 0, np.array(field.shape[:2]) - 1)
    return field[ij[:, 0], ij[:, 1]]


def _members(bodies: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(k, B) bool: which of the (B, H, W) bodies hold each of the points (k, 2) x, y."""
    ij = np.clip(np.round(points[:, ::-1]).astype(np.int64), 0, np.array(bodies.shape[1:]) - 1)
    return bodies[:, ij[:, 0], ij[:, 1]].T


def score(f: np.ndarray) -> np.ndarray:
    """(c,) in [0, 1]: the logistic score of features (c, len(FEATURES)) with WEIGHTS."""
    return 1.0 / (1.0 + np.exp(-(f @ WEIGHTS)))


def propose_t_junctions(masks: Masks | RefinedMasks, pose: np.ndarray, skeleton: Skeleton,
                        min_score: float = MIN_SCORE) -> JunctionProposals:
    """T-junction proposals of one keyframe from its masks (coverage, colour unmixed from the paper, occlusion
    regions) at its (J, 3) pose: the candidates of its lines (t_junction_candidates) scored by their shape,
    their nearness to an occlusion region and the bodies around them (features, score), those scoring at
    least min_score, none within MERGE_PX of a better one, best first."""
    empty = JunctionProposals(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros(0, np.int64))
    cands = t_junction_candidates(line_map(masks.colour, masks.coverage))
    if not len(cands.points):
        return empty
    s = score(features(cands, masks, pose, skeleton))
    ok = np.nonzero(s >= min_score)[0]
    keep = ok[_merge(cands.points[ok], s[ok], MERGE_PX * scale_of(masks.foreground.shape))]
    region = np.full(len(keep), -1, np.int64)
    if masks.occlusion and len(keep):
        d = np.stack([_at(ndimage.distance_transform_edt(~np.asarray(m, bool)), cands.points[keep])
                      for m in masks.occlusion])
        region = np.argmin(d, axis=0).astype(np.int64)
    return JunctionProposals(cands.points[keep], s[keep], cands.stems[keep], region)
