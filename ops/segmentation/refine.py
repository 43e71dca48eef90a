"""Refinement of occlusion masks by T-junctions (§4.1).

The user's T-junction clicks are trusted; the predicted (or painted) occlusion
region is not. Each region is triangulated and deformed with the same
symmetric Dirichlet machinery as the template (ops/deform.py) so that its
boundary passes exactly through its T-junctions while the rest of the
boundary is held in place; the deformed polygon is rasterized back into a
mask inside the foreground. Boundaries are closed polylines (first != last)
with positive shoelace area in image coordinates (the mesh's face
orientation), simplified by Douglas-Peucker with a 2 px tolerance, and each
T-junction is a vertex of its region's polyline. Polyline vertices lie on the
centres of the region's outermost pixels (cv2.findContours), so `rasterize`
(boundary-inclusive fill) of an unsimplified boundary gives the mask back.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from ops.geometry.deform import Deformer
from ops.geometry.mesh import boundary_loops, triangulate_pslg
from ops.geometry.polygon import densify, polygon_area, project_to_polyline, rasterize
from ops.geometry.snap import snap_into
from ops.segmentation.contacts import scale_of, thin_overlaps
from ops.segmentation.domain import mesh_domain
from ops.segmentation.junctions import assign_junctions
from ops.segmentation.slits import contact_slits, junction_slits, parting_slits
from ops.types import Masks, RefinedMasks, Skeleton, nest_group_list
from ops.warning_subject import about, inside_point

DP_EPS_PX = 2.0  # Douglas-Peucker tolerance of every output polyline
SEGMENT_PX = 4.0  # boundary edge length of the deformation mesh
MESH_DP_EPS_PX = 0.75  # tolerance of the contour the deformation mesh is built on
EIGHT = np.ones((3, 3), bool)  # 8-connectivity: the pieces of a region
MIN_PIECE_PX = 12  # a piece of a region smaller than this is no region of its own (the pair regions' minimum)


# ---------------------------------------------------------------- polylines


def _orient(P: np.ndarray) -> np.ndarray:
    """(n, 2) closed polyline with positive shoelace area (reversed if needed)."""
    return P[::-1].copy() if polygon_area(P) < 0 else P


def _largest_contour(mask: np.ndarray) -> np.ndarray:
    """(n, 2) float64 outer boundary pixel centres of the largest component of a (H, W) bool mask."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        raise ValueError("mask_boundary: empty mask")
    best = max(contours, key=lambda c: (abs(cv2.contourArea(c)), len(c)))
    return best.reshape(-1, 2).astype(np.float64)


def simplify(P: np.ndarray, eps: float = DP_EPS_PX, keep: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Douglas-Peucker of a closed (n, 2) polyline keeping vertices `keep` (k,): (simplified (m, 2), new index of each kept vertex)."""
    if keep is None or len(keep) == 0:
        Q = cv2.approxPolyDP(P.astype(np.float32).reshape(-1, 1, 2), eps, True).reshape(-1, 2)
        return Q.astype(np.float64), np.zeros(0, np.int64)
    keep = np.asarray(keep, np.int64)
    anchors = np.unique(keep)
    if len(anchors) == 1:  # an open chain needs two distinct ends: add the vertex farthest away
        anchors = np.unique([anchors[0], int(np.argmax(np.linalg.norm(P - P[anchors[0]], axis=1)))])
    n, out, starts = len(P), [], []
    for a, b in zip(anchors, np.roll(anchors, -1)):
        # open chain from kept vertex a to the next kept vertex b (wrapping); DP keeps its endpoints
        span = (b - a) % n or n
        chain = P[(a + np.arange(span + 1)) % n]
        Q = cv2.approxPolyDP(chain.astype(np.float32).reshape(-1, 1, 2), eps, False).reshape(-1, 2)
        starts.append(sum(len(c) for c in out))
        out.append(Q[:-1].astype(np.float64))
        out[-1][0] = P[a]  # exact (float32 rounding in approxPolyDP)
    return np.concatenate(out), np.asarray(starts, np.int64)[np.searchsorted(anchors, keep)]


def mask_boundary(mask: np.ndarray, eps: float = DP_EPS_PX) -> np.ndarray:
    """(n, 2) float64 outer boundary of a (H, W) bool mask's largest component, pixels, DP-simplified, positive area."""
    Q, _ = simplify(_largest_contour(mask), eps)
    return _orient(Q)


def _insert_points(P: np.ndarray, Q: np.ndarray, reuse_px: float = 0.75) -> tuple[np.ndarray, np.ndarray]:
    """Closed (n, 2) polyline P with the feet of points Q (k, 2) inserted: (new polyline, (k,) distinct vertex of each).

    A foot on top of an existing vertex reuses it (no near-zero edge); when two junctions would share
    a vertex (both project onto one corner) the farther one takes the nearest free vertex instead.
    """
    param, dist = project_to_polyline(Q, P)
    n = len(P)
    edge = np.floor(param).astype(int) % n
    foot = P[edge] + (param - np.floor(param))[:, None] * (P[(edge + 1) % n] - P[edge])
    near = np.rint(param).astype(int) % n
    taken: dict[int, int] = {}  # existing vertex -> junction
    inserted: list[int] = []  # junctions whose foot becomes a new vertex
    late: list[int] = []  # junctions resolved after insertion
    for i in np.argsort(dist, kind="stable"):
        v = int(near[i])
        if np.linalg.norm(foot[i] - P[v]) < reuse_px:
            if v in taken:
                late.append(int(i))
            else:
                taken[v] = int(i)
        elif all(np.linalg.norm(foot[i] - foot[j]) >= reuse_px for j in inserted):
            inserted.append(int(i))
        else:
            late.append(int(i))
    ins = np.asarray(inserted, np.int64)
    key = np.concatenate([np.arange(n, dtype=np.float64), param[ins]])
    order = np.argsort(key, kind="stable")
    pos = np.empty(len(order), np.int64)
    pos[order] = np.arange(len(order))
    out = np.concatenate([P, foot[ins]])[order]
    idx = np.full(len(Q), -1, np.int64)
    for v, i in taken.items():
        idx[i] = pos[v]
    idx[ins] = pos[n + np.arange(len(ins))]
    for i in late:
        d = np.linalg.norm(out - Q[i], axis=1)
        d[idx[idx >= 0]] = np.inf
        idx[i] = int(np.argmin(d))
    return out, idx


# ---------------------------------------------------------------- refinement


def _handles(B: np.ndarray, jv: np.ndarray, J: np.ndarray, pull: float) -> np.ndarray:
    """(h,) int64 boundary positions held in place: a sparse subset of B (n, 2) far from the junctions J (k, 2)."""
    d = np.linalg.norm(B[:, None, :] - J[None], axis=2).min(axis=1)
    d[jv] = -1.0
    radius = max(4.0 * pull, 2.0 * SEGMENT_PX)
    far = np.nonzero(d >= radius)[0][::2]
    if len(far) < 3:
        far = np.argsort(-d)[: min(3, int((d >= 0).sum()))]
    return far.astype(np.int64)


def _deform_boundary(P: np.ndarray, J: np.ndarray, warnings: list[str]) -> np.ndarray:
    """(m, 2) deformed outer boundary loop of the region inside the closed (n, 2) polyline P, through J (k, 2)."""
    D, jpos = _insert_points(densify(P, SEGMENT_PX), J)
    area = abs(polygon_area(D))
    res = triangulate_pslg([D], max_area=max(SEGMENT_PX**2, area / 2000.0))
    warnings.extend(res.warnings)
    loop = boundary_loops(res.F)[0]
    where = {int(v): i for i, v in enumerate(loop)}
    jv = res.loop_vertex[0][jpos]
    if (jv < 0).any() or any(int(v) not in where for v in jv):
        raise ValueError("refine_region: a junction vertex is not on the mesh's outer boundary")
    jb = np.array([where[int(v)] for v in jv], np.int64)
    pull = float(np.linalg.norm(res.V[jv] - J, axis=1).max())
    held = loop[_handles(res.V[loop], jb, J, pull)]
    handles = np.concatenate([jv, held])
    targets = np.concatenate([J, res.V[held]])
    out = Deformer(res.V, res.F, handles).solve(targets, x0=None)
    if not out.converged:
        warnings.append(f"occlusion refinement: deformation stopped at gradient norm {out.grad_norm:.3g} (not converged)")
    X = np.asarray(out.x, np.float64).reshape(-1, 2).copy()
    X[jv] = J  # the solver's pose term is soft; the junctions themselves are exact
    return X[loop]


def refine_region(
    mask: np.ndarray, junctions: np.ndarray, foreground: np.ndarray, warnings: list[str] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Deform a (H, W) bool region so its boundary passes through (k, 2) junctions (pixels, inside the foreground).

    Returns (refined (H, W) bool mask inside the foreground, boundary (n, 2) float64 DP-simplified
    polyline, (k,) int64 indices of the junction vertices in it, ascending = boundary order).
    """
    warnings = [] if warnings is None else warnings
    J = np.asarray(junctions, np.float64).reshape(-1, 2)
    if len(J) == 0:
        return mask & foreground, mask_boundary(mask), np.zeros(0, np.int64)
    P = _orient(_largest_contour(mask))
    if len(P) < 3:
        raise ValueError("refine_region: the region is too thin to triangulate")
    # a fine pre-simplification, so that only the final 2 px pass departs visibly from the contour
    B = _deform_boundary(simplify(P, MESH_DP_EPS_PX)[0], J, warnings)
    B = _orient(B)  # mesh loops follow the faces' positive orientation; guard anyway
    if polygon_area(B) <= 0:
        raise ValueError("refine_region: the deformed boundary is degenerate")
    Q, jq = simplify(B, keep=_positions(B, J))
    others = np.setdiff1d(np.arange(len(Q)), jq)
    snapped, moved = snap_into(foreground, Q[others])
    if moved.any():
        warnings.append(f"occlusion refinement: {int(moved.sum())} boundary vertex(es) outside the foreground moved onto it")
        Q[others] = snapped
    refined = rasterize(Q, mask.shape) & foreground
    order = np.argsort(jq)
    return refined, Q, jq[order]


def _positions(B: np.ndarray, J: np.ndarray) -> np.ndarray:
    """(k,) int64 index of the vertex of B (n, 2) lying exactly at each junction J (k, 2)."""
    d = np.linalg.norm(B[:, None, :] - J[None], axis=2)
    return np.argmin(d, axis=0).astype(np.int64)


def _split_pieces(regions: list[np.ndarray], fronts: list[np.ndarray], junctions: list[np.ndarray],
                  groups: list[int], warnings: list[str]
                  ) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], list[int]]:
    """The regions (each (H, W) bool) with one region per 8-connected piece of every region that has no
    T-junction, each piece with its region's front bones, nest group (and no junction); a region with
    T-junctions as it is.

    A template meshes a region's pocket from one boundary loop, so a region in pieces used to free its largest
    piece only and glue the rest: the skeleton's capsules overlapping into one mask make the legs behind a
    round belly and the forearm across the chest one region, and only the legs were freed (the forearm, lifted,
    dragged the chest up with it). The pieces are separate overlaps; one under MIN_PIECE_PX is left out, as
    every piece but the largest was before. A region with T-junctions keeps its largest piece, refined through
    its clicks (below)."""
    out: tuple[list, list, list, list] = ([], [], [], [])
    for r, (region, front, J, group) in enumerate(zip(regions, fronts, junctions, groups)):
        labels, n = ndimage.label(region, structure=EIGHT)
        if n < 2 or len(J):
            pieces = [region]
        else:
            sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
            keep = np.flatnonzero(sizes >= MIN_PIECE_PX) + 1
            pieces = [labels == i for i in keep] if len(keep) else [region]
            small = n - len(keep)
            if not len(keep):
                text = f"has {n} pieces, each under {MIN_PIECE_PX} px: its boundary describes the largest"
            elif len(keep) == 1:
                text = f"has {n} pieces: the {small} under {MIN_PIECE_PX} px left out"
            else:
                text = f"has {n} pieces: made one region of each" + (
                    f" of the {len(keep)} of at least {MIN_PIECE_PX} px ({small} smaller left out)" if small else "")
            warnings.append(about("occlusion region", text, name=r, at=inside_point(region)))
        for piece in pieces:
            out[0].append(piece)
            out[1].append(front)
            out[2].append(J)
            out[3].append(group)
    return out


def refine_masks(masks: Masks, t_junctions: np.ndarray, pose: np.ndarray, skeleton: Skeleton,
                 other_pose: np.ndarray | list[np.ndarray] | None = None) -> RefinedMasks:
    """Refine every occlusion region of `masks` by the keyframe's (k, 2) T-junctions (pixels) at its (J, 3) pose.

    Every click is kept: a region is grown to meet a click far from it, or started at a click when there is
    no region at all (ops.segmentation.junctions). With the other keyframe's (J, 3) pose (or the list of the
    neighbouring keys' poses), a part that one of them takes off the body it crosses here is also slit free at its T-junctions (ops.segmentation.slits.junction_slits).
    """
    warnings = list(masks.warnings)
    fg = masks.foreground
    regions, front_bones, per_region, w = assign_junctions(np.asarray(t_junctions, np.float64).reshape(-1, 2),
                                                           masks.occlusion, masks.front_bones, fg, pose, skeleton)
    warnings += w
    groups = nest_group_list(masks.nest_groups, len(masks.occlusion))
    groups += [-1] * (len(regions) - len(groups))  # a region started at a click stacks with none
    regions, front_bones, per_region, groups = _split_pieces(regions, front_bones, per_region, groups, warnings)
    thin = thin_overlaps(regions, masks.contacts, scale_of(fg))
    occ, fronts, bounds, juncs, nests = [], [], [], [], []
    for r, (region, front, J, group) in enumerate(zip(regions, front_bones, per_region, groups)):
        if thin[r] and not len(J):
            warnings.append(about("occlusion region", f"({int(region.sum())} px) lies along a contact of two touching "
                                  "bodies: slit along the contact instead of a pocket", name=r, at=inside_point(region)))
            continue
        n_comp = ndimage.label(region, structure=EIGHT)[1]
        at = inside_point(region)
        if n_comp > 1:  # only a region with T-junctions is still in pieces here (_split_pieces)
            warnings.append(about("occlusion region", f"has {n_comp} pieces; only the largest is refined and kept",
                                  name=r, at=at))
        if region.sum() < 3:
            warnings.append(about("occlusion region", "is smaller than 3 px and was dropped", name=r, at=at))
            continue
        try:
            refined, B, jidx = refine_region(region, J, fg, warnings)
        except ValueError as err:  # a degenerate region: keep it as given rather than lose the shot
            warnings.append(about("occlusion region", f"not refined ({err}); its {len(J)} T-junction(s) ignored",
                                  name=r, at=at))
            refined, B, jidx = region & fg, mask_boundary(region), np.zeros(0, np.int64)
        if not refined.any() or len(B) < 3:
            warnings.append(about("occlusion region", "vanished during refinement and was dropped", name=r, at=at))
            continue
        occ.append(refined)
        fronts.append(front)
        bounds.append(B)
        juncs.append(jidx)
        nests.append(group)
    domain, holes = mesh_domain(fg, masks.coverage, masks.holes)
    taken = np.any(occ, axis=0) if occ else np.zeros_like(fg)
    junction_points = np.concatenate([B[j] for B, j in zip(bounds, juncs)]) if bounds else np.zeros((0, 2))
    slits = contact_slits(masks.contacts, taken, domain, junction_points)
    if other_pose is not None:  # the other keyframe tells which parts leave the bodies they cross
        slits = parting_slits(slits, taken, domain, masks.coverage, pose, skeleton, other_pose)
        touching = np.any(masks.contacts, axis=0) if masks.contacts else None
        ends = np.array([s[e] for s in slits for e in (0, -1)]).reshape(-1, 2)  # a contact's slit may end on a junction
        slits += junction_slits(bounds, juncs, fronts, taken, domain, masks.coverage, pose, skeleton, other_pose,
                                touching, cut=ends)
    return RefinedMasks(
        foreground=fg,
        occlusion=occ,
        front_bones=fronts,
        boundaries=bounds,
        junctions=juncs,
        domain=domain,
        domain_holes=holes,
        coverage=masks.coverage,
        paper=masks.paper,
        colour=masks.colour,
        warnings=warnings,
        slits=slits,
        nest_groups=nests,
    )
