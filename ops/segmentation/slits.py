"""Slits: the open polylines the template mesh is cut along: one per contact (ops.segmentation.contacts),
and one from each T-junction where a part crosses a body it is not joined to, out through the paper.

A contact's slit follows the middle of its stroke, keeps clear of the occlusion regions (their boundaries
are mesh constraints it must not cross), and an end near the outline is carried on to it, so the cut opens
a flap there rather than a slot. An end that a region cut short is carried on to that region's T-junction
instead, so the two cuts meet. An end that stops farther inside is carried on to the outline where a
neighbouring key takes the two bodies apart (parting_slits): a hand resting on the head, freed.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
from skimage.graph import MCP_Geometric
from skimage.morphology import skeletonize

from ops.geometry.polygon import densify, project_to_polyline
from ops.segmentation.bones import bone_radii, moved_with_bones, segment_distance
from ops.segmentation.contacts import MIN_CONTACT_PX, longest_path, scale_of, scale_of_box
from ops.types import Skeleton

AVOID_PX = 3  # a slit keeps this far from the occlusion regions' boundaries (mesh constraints)
SLIT_STEP_PX = 3  # spacing of a slit's polyline vertices along the contact
REACH_OUTLINE_PX = 10.0  # a slit's end this close to the outline is carried on to it (across the notch where two bodies part)
INK_COST = 8.0  # a junction slit's path: a pixel of character costs this many of paper
MAX_INK_PX = 4.0  # ... and it crosses at most this much character (the stroke at the junction)
JOIN_PX = 2 * AVOID_PX + 3  # a contact slit's end cut short by a region this near a T-junction is carried on to it
MIN_JOINED_PX = 3  # ... and then this much of it is enough (the rest of the contact runs on inside the region)
SEPARATE_PX = 16.0  # ... where the other keyframe takes the part this much farther off the body it crosses (a limb's width)
BRIDGE_PX = 30.0  # a contact's slit that stops inside the mesh this near a loop of its outline is carried on to it
#                   where the bodies part (parting_slits)
END_CLEAR_PX = 3.0  # ... nor to within this of another slit: the two would close a loop around a piece of the mesh
SEAM_BAND = 0.3  # ... between the bodies: |d_f / r_f - d_k / r_k| within this costs no more than paper


def slit_of(piece: np.ndarray, avoid: np.ndarray, domain: list[np.ndarray],
            junctions: np.ndarray | None = None) -> np.ndarray | None:
    """(k, 2) float64 open polyline along a contact piece ((H, W) bool), AVOID_PX clear of `avoid` (the
    occlusion regions: their boundaries are mesh constraints the slit must not cross), each end carried on to
    the domain's outline (closed polylines) when within REACH_OUTLINE_PX of it so the cut opens there; None
    when too little of the piece is left.

    junctions: (n, 2) T-junctions on the regions' boundaries. A contact that runs on into a region (the limb
    that touches the body beyond the part crossing it) is cut short by AVOID_PX there; its end is carried on to
    a T-junction within JOIN_PX, where the region's own cut goes on, so no bridge of mesh is left between the
    two cuts to glue the bodies together (lamp: the arm resting on the base beside the shade over it)."""
    return _slit_along(piece, *_clearance(avoid), domain, junctions, _scale_of_domain(domain))


def contact_slits(contacts: list[np.ndarray], avoid: np.ndarray, domain: list[np.ndarray],
                  junctions: np.ndarray | None = None) -> list[np.ndarray]:
    """slit_of for each contact piece ((H, W) bool) that keeps one, the regions' clearance computed once."""
    clear, band = _clearance(avoid)
    scale = _scale_of_domain(domain)
    return [s for s in (_slit_along(c, clear, band, domain, junctions, scale) for c in contacts) if s is not None]


def _scale_of_domain(domain: list[np.ndarray]) -> float:
    """The character's scale (scale_of) from its domain's closed polylines (the box of their points)."""
    if not domain:
        return 1.0
    pts = np.vstack(domain)
    return scale_of_box(*(pts.max(axis=0) - pts.min(axis=0) + 1)[::-1])


def parting_slits(slits: list[np.ndarray], regions: np.ndarray, domain: list[np.ndarray], coverage: np.ndarray,
                  pose: np.ndarray, skeleton: Skeleton, other_pose: np.ndarray | list[np.ndarray]
                  ) -> list[np.ndarray]:
    """Contact slits ((n, 2) float64 each, contact_slits) whose end stops inside the mesh, carried on to the
    outline where the bodies on its two sides part.

    A contact's stroke often runs out where the two bodies' inks merge (a hand drawn against the head, the last
    pixels of an arm along the body), short of the outline: the slit is then a slot, and the bodies stay sewn
    around its end. Where a neighbouring key's pose (J, 3) (or one of a list) takes them apart (the bone nearest
    the end and the nearest bone not its neighbour end SEPARATE_PX farther apart, as junction_slits asks), an
    end within BRIDGE_PX of a loop of the domain (the outline or a hole's) is carried on to it along the
    cheapest way through the mesh (`_way_out`, the (H, W) bool regions closed to it) between the two bodies:
    character costs nothing extra where the two bones are equally far in units of their bodies' radii (the
    seam between a thin arm and a wide torso lies at the arm's side, not half way between the bones) and
    INK_COST more beyond SEAM_BAND of that, so the way runs on between the bodies, not across a limb to its far
    side.

    Never across another slit or to within END_CLEAR_PX of one, and never so that both of a slit's ends lie on
    one loop: either would close a loop around a piece of the mesh (of two such ends, the one the other key
    parts less stays). Nor an end at a region (within AVOID_PX + 2 px): the region's T-junction or cut opens
    it. The pose (J, 3) is the keyframe's."""
    scale = scale_of(coverage)
    loops = [[_nearest_on(s[e], domain) for e in (0, -1)] for s in slits]  # per slit, per end: (dist, foot, loop)
    if not any(0.5 < d <= BRIDGE_PX * scale for ends in loops for d, _, _ in ends):
        return list(slits)  # every end on a loop or far inside: nothing to carry on (most keys)
    others = [other_pose] if np.ndim(other_pose) == 2 else list(other_pose)
    ends_xy = pose[skeleton.bones, :2].astype(np.float64)
    other_ends = [np.asarray(o)[skeleton.bones, :2].astype(np.float64) for o in others]
    adjacent = skeleton.adjacent_bones()
    inside = _fill(domain, coverage.shape)
    radii = bone_radii(coverage >= 0.5, pose, skeleton)
    reach = int(np.ceil(BRIDGE_PX * scale)) + 2
    # an end at a region (cut short by its clearance, or carried on to its T-junction) is the region's to open
    at_region = ndimage.binary_dilation(regions, iterations=AVOID_PX + 2) if regions.any() else regions
    out = list(slits)
    for i, slit in enumerate(out):
        taken = None  # the other slits' points, made when a way out is found
        ways = {}  # end (0 first, 1 last) -> (how far the other key parts the bodies, way out, its loop)
        for n, e in enumerate((0, -1)):
            p = np.asarray(slit[e], np.float64)
            if not 0.5 < loops[i][n][0] <= BRIDGE_PX * scale or _at(at_region, p):
                continue
            dist = np.array([segment_distance(p, a, b) for a, b in ends_xy])
            f = int(np.argmin(dist))
            bodies = np.flatnonzero(~adjacent[f])
            if not len(bodies):
                continue
            k = int(bodies[np.argmin(dist[bodies])])
            apart = _parted(p, f, k, ends_xy, other_ends)
            if apart < SEPARATE_PX * scale:
                continue
            seam = _seam(coverage.shape, p, reach, ends_xy[f], radii[f], ends_xy[k], radii[k])
            way = _way_out(p, coverage, inside, regions, domain, reach, seam, max_ink=None,
                           max_length=1.5 * BRIDGE_PX * scale)
            if way is None:
                continue
            if taken is None:
                rest = [densify(s, 1.0, closed=False) for j, s in enumerate(out) if j != i]
                taken = cKDTree(np.vstack(rest)) if rest else False
            if taken and (taken.query(way[-1])[0] < END_CLEAR_PX * scale
                          or taken.query(densify(way, 1.0, closed=False))[0].min() < 1.5):
                continue  # it would close a loop with another slit, or cross one
            ways[n] = (apart, way, _nearest_on(way[-1], domain)[2])
        for n in sorted(ways, key=lambda n: ways[n][0]):  # the end the other key parts less gives way
            d, _, loop = loops[i][1 - n]
            other = ways[1 - n][2] if 1 - n in ways else (loop if d <= 0.5 else None)
            if other == ways[n][2]:
                del ways[n]
        if 0 in ways:
            slit = np.vstack([ways[0][1][:0:-1], slit])
        if 1 in ways:
            slit = np.vstack([slit, ways[1][1][1:]])
        out[i] = slit
    return out


def _seam(shape: tuple[int, int], around: np.ndarray, reach: int, bone_f: np.ndarray, r_f: float,
          bone_k: np.ndarray, r_k: float) -> np.ndarray:
    """(H, W) float64 in [0, 1]: 1 on the seam between two bodies ((2, 2) bone segments, radii px), where a
    pixel's distance to each bone in units of that body's radius is equal, falling to 0 at SEAM_BAND apart;
    computed within `reach` px of the (2,) point `around` (where _way_out looks), 0 beyond."""
    out = np.zeros(shape, np.float64)
    x0, y0 = max(int(around[0]) - reach, 0), max(int(around[1]) - reach, 0)
    x1, y1 = min(int(around[0]) + reach + 1, shape[1]), min(int(around[1]) + reach + 1, shape[0])
    yy, xx = np.mgrid[y0:y1, x0:x1]
    pts = np.stack([xx, yy], axis=-1).astype(np.float64)
    rho = segment_distance(pts, *bone_f) / max(r_f, 1.0) - segment_distance(pts, *bone_k) / max(r_k, 1.0)
    out[y0:y1, x0:x1] = np.clip(1.0 - np.abs(rho) / SEAM_BAND, 0.0, 1.0)
    return out


def _parted(p: np.ndarray, f: int, k: int, ends_xy: np.ndarray, other_ends: list[np.ndarray]) -> float:
    """How much farther, pixels, a (2,) point p carried with bone f lies from bone k at the neighbouring keys'
    poses than here (the most over them); ends_xy (B, 2, 2) the bones here, other_ends the same there."""
    here = segment_distance(p, *ends_xy[k])
    return max(float(segment_distance(_moved_with_bone(p, ends_xy[f], e[f]), *e[k])) - float(here)
               for e in other_ends)


def _clearance(avoid: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(H, W) bool pixels within AVOID_PX of the regions `avoid`, and the band just outside them (where a contact
    the regions cut short stops); (None, None) without regions."""
    if not avoid.any():
        return None, None
    clear = ndimage.binary_dilation(avoid, iterations=AVOID_PX)
    return clear, ndimage.binary_dilation(clear, iterations=2) & ~clear


def _slit_along(piece: np.ndarray, clear: np.ndarray | None, band: np.ndarray | None, domain: list[np.ndarray],
                junctions: np.ndarray | None, scale: float) -> np.ndarray | None:
    """slit_of, given the regions' clearance and the band around it (_clearance)."""
    cut_off = None  # where the regions cut this contact short
    if clear is not None:
        if (piece & clear).any():
            cut_off = band
        piece = piece & ~clear
    labels, n = ndimage.label(piece, structure=np.ones((3, 3), bool))
    if n == 0:
        return None
    sizes = np.bincount(labels.ravel())[1:]
    piece = labels == 1 + int(np.argmax(sizes))
    path = longest_path(skeletonize(piece))
    joins: list = [None, None]
    if cut_off is not None and junctions is not None and len(junctions) and len(path):
        J = np.asarray(junctions, np.float64)
        gaps = [np.linalg.norm(J - np.asarray(end, np.float64), axis=1) for end in (path[0], path[-1])]
        for e, end in enumerate((path[0], path[-1])):
            if cut_off[int(end[1]), int(end[0])] and gaps[e].min() <= JOIN_PX * scale:
                joins[e] = int(np.argmin(gaps[e]))
        if joins[0] is not None and joins[0] == joins[1]:  # one junction: the nearer end goes to it
            joins[int(gaps[0].min() <= gaps[1].min())] = None
        joins = [None if j is None else J[j].tolist() for j in joins]
    if len(path) < (MIN_JOINED_PX if any(joins) else MIN_CONTACT_PX):
        return None
    path = path[:: SLIT_STEP_PX][:-1].tolist() + [path[-1].tolist()]
    ends = []
    for end, join in zip((path[0], path[-1]), joins):
        dist, foot, _ = _nearest_on(np.asarray(end, np.float64), domain)
        ends.append(join if join is not None else foot.tolist() if 0.5 <= dist <= REACH_OUTLINE_PX else None)
    out = ([ends[0]] if ends[0] else []) + path + ([ends[1]] if ends[1] else [])
    return np.asarray(out, np.float64)


def junction_slits(boundaries: list[np.ndarray], junctions: list[np.ndarray], front_bones: list[np.ndarray],
                   regions: np.ndarray, domain: list[np.ndarray], coverage: np.ndarray, pose: np.ndarray,
                   skeleton: Skeleton, other_pose: np.ndarray | list[np.ndarray], contacts: np.ndarray | None = None,
                   cut: np.ndarray | None = None) -> list[np.ndarray]:
    """Open polylines (n, 2) float64 from T-junctions out through the paper to the mesh's outline (or a hole's).
    regions: (H, W) bool pixels of the occlusion regions, which a slit does not cross; contacts: (H, W) bool
    strokes where two bodies touch (ops.segmentation.contacts), which a way out runs along as on paper; cut:
    (m, 2) points where a slit already ends (a contact's, carried on to a junction by slit_of): such a junction
    has its way out, and a second slit beside it would leave a sliver of mesh between the two.

    At a T-junction a part's outline passes in front of another body's. The region's cut stops there, on the
    drawn stroke, but the mesh reaches on past the outline (its soft rim and margin) and fills the concave
    corner between the two outlines: that fillet glued the part to the body it crosses (tail's curled tip to
    its base). The slit follows the cheapest way out of the corner, a pixel of character costing INK_COST of
    paper, so it runs through the corner's paper rather than along either outline, crosses at most
    MAX_INK_PX of character (the stroke at the junction) and reaches the outline within REACH_OUTLINE_PX
    (times 1.5 for its bends). Only where the part and the body are not joined: the region's front bone
    nearest the junction and the nearest other bone not its neighbour (the body it crosses, not its own
    chain) share no neighbouring bone (an upper arm under a sleeve stays sewn at the shoulder, thighs under
    a skirt at the hem), and only where the other keyframe's pose (J, 3) (or one of a list: the neighbouring keys') takes the part off that body: the
    junction, carried with its front bone, ends SEPARATE_PX farther from the crossed bone. A part that stays
    on the body (a hand resting on a belly in both keyframes) stays sewn at the junction: freed, it slid with
    its handles where the drawing had it still (flat_colour's claw). Where the part and the body touch beyond
    the junction (crossed shins whose feet touch below the crossing) the corner holds no paper, and the way
    out follows their contact, where the template parts them anyway: without it the feet stayed sewn, and
    legs_cross's key1 lane dragged them into one blob as the legs uncrossed.
    """
    h, w = coverage.shape
    inside = _fill(domain, (h, w))
    adjacent = skeleton.adjacent_bones()
    ends_xy = pose[skeleton.bones, :2].astype(np.float64)  # (B, 2, 2)
    others = [other_pose] if np.ndim(other_pose) == 2 else list(other_pose)  # the neighbouring keys' poses
    other_ends = [np.asarray(o)[skeleton.bones, :2].astype(np.float64) for o in others]
    scale = scale_of(coverage)
    reach = int(np.ceil(REACH_OUTLINE_PX * 1.5)) + 2
    out = []
    for B, J, front in zip(boundaries, junctions, front_bones):
        front = np.asarray(front, np.int64)
        behind = np.setdiff1d(np.arange(len(skeleton.bones)), front)
        if not len(front) or not len(behind):
            continue
        for p in np.asarray(B, np.float64)[np.asarray(J, np.int64)]:
            if cut is not None and len(cut) and np.min(np.linalg.norm(cut - p, axis=1)) < 1e-6:
                continue  # a contact's slit already goes on from this junction: its way out
            dist = np.array([segment_distance(p, a, b) for a, b in ends_xy])
            f = front[np.argmin(dist[front])]
            crossed = behind[~adjacent[f, behind]]  # the part's own chain (the upper arm of a forearm) crosses nothing
            if not len(crossed):
                continue
            k = crossed[np.argmin(dist[crossed])]
            if (adjacent[f] & adjacent[k]).any():  # joined through one bone: a sleeve's shoulder, a skirt's hem
                continue
            if _parted(p, f, k, ends_xy, other_ends) < SEPARATE_PX * scale:  # no neighbouring key takes it off
                continue
            slit = _way_out(p, coverage, inside, regions, domain, reach, contacts)
            if slit is not None:
                out.append(slit)
    return out


def _moved_with_bone(p: np.ndarray, bone: np.ndarray, bone_there: np.ndarray) -> np.ndarray:
    """(2,) point p moved rigidly with a bone from (2, 2) ends `bone` to `bone_there` (its length may change:
    the point keeps its fraction along the bone and its offset across it)."""
    return moved_with_bones(np.asarray(p, np.float64)[None], np.asarray(bone, np.float64)[None],
                            np.asarray(bone_there, np.float64)[None])[0]


def _fill(loops: list[np.ndarray], shape: tuple[int, int]) -> np.ndarray:
    """(H, W) bool inside closed polylines (holes of a domain: its negative loops left out by even-odd)."""
    m = np.zeros(shape, np.uint8)
    if loops:
        cv2.fillPoly(m, [np.round(np.asarray(L, np.float64) * 16).astype(np.int32) for L in loops], 1, shift=4)
    return m > 0


def _way_out(p: np.ndarray, coverage: np.ndarray, inside: np.ndarray, regions: np.ndarray,
             domain: list[np.ndarray], reach: int, contacts: np.ndarray | None = None,
             max_ink: float | None = MAX_INK_PX, max_length: float = 1.5 * REACH_OUTLINE_PX) -> np.ndarray | None:
    """(n, 2) polyline from junction p to the domain's outline along the cheapest path of pixels (character
    costs INK_COST, paper 1; the (H, W) contacts, bool or a weight in [0, 1], take that share of a character
    pixel's cost away: a contact's stroke is where two bodies part anyway; the occlusion regions are closed to
    it but at p), or None when it crosses more than max_ink px of character (None: any) or runs longer than
    max_length px."""
    h, w = coverage.shape
    x0, y0 = max(int(p[0]) - reach, 0), max(int(p[1]) - reach, 0)
    x1, y1 = min(int(p[0]) + reach + 1, w), min(int(p[1]) + reach + 1, h)
    start = (int(round(p[1])) - y0, int(round(p[0])) - x0)
    if not (0 <= start[0] < y1 - y0 and 0 <= start[1] < x1 - x0):
        return None
    cov = np.clip(coverage[y0:y1, x0:x1].astype(np.float64), 0.0, 1.0)
    if contacts is not None:  # a contact's stroke is where two bodies part anyway: no character to cross
        cov *= 1.0 - np.asarray(contacts[y0:y1, x0:x1], np.float64)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    cost = 1.0 + INK_COST * cov
    cost[regions[y0:y1, x0:x1] & (np.hypot(xx - p[0], yy - p[1]) > 1.5)] = np.inf
    ends = np.argwhere(~inside[y0:y1, x0:x1])
    if not len(ends):
        return None
    mcp = MCP_Geometric(cost)
    acc, _ = mcp.find_costs([start], ends=[tuple(e) for e in ends.tolist()], find_all_ends=False)
    end = tuple(ends[int(np.argmin(acc[ends[:, 0], ends[:, 1]]))].tolist())
    if not np.isfinite(acc[end]):
        return None
    path = np.asarray(mcp.traceback(end))  # (n, 2) (row, col), p's pixel first
    pts = path[:, ::-1].astype(np.float64) + [x0, y0]
    length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    inked = max_ink is not None and cov[path[:, 0], path[:, 1]].sum() > max_ink
    if inked or length > max_length or len(pts) < 2:
        return None
    _, foot, _ = _nearest_on(pts[-2], domain)  # the last pixel inside the domain, carried on to its outline
    return np.vstack([p[None], pts[1:-1][SLIT_STEP_PX::SLIT_STEP_PX], foot[None]])


def _nearest_on(point: np.ndarray, loops: list[np.ndarray]) -> tuple[float, np.ndarray, int]:
    """(distance, (2,) foot, index) of a (2,) point on the nearest of closed polylines (n_i, 2)."""
    best = (np.inf, np.asarray(point, np.float64), -1)
    for k, L in enumerate(loops):
        L = np.asarray(L, np.float64)
        param, dist = project_to_polyline(np.asarray(point, np.float64)[None], L)
        i, t = int(param[0]), float(param[0] % 1.0)
        if dist[0] < best[0]:
            best = (float(dist[0]), L[i] + t * (L[(i + 1) % len(L)] - L[i]), k)
    return best


def _at(mask: np.ndarray, p: np.ndarray) -> bool:
    """Whether the (2,) point's pixel is set in the (H, W) bool mask (False off it)."""
    c, r = int(round(p[0])), int(round(p[1]))
    return 0 <= r < mask.shape[0] and 0 <= c < mask.shape[1] and bool(mask[r, c])
