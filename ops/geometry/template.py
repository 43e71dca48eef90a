"""Initial 2.5D template: front-sheet triangulation, occlusion regions and skeleton handles (§4.2).

The front sheet (layer 0) is a constrained Delaunay triangulation of the
character's domain (every component, paper enclosed by the body left open as
holes; ops.segmentation.domain) whose occlusion-region boundaries are internal
constraint loops, so every region is a union of faces. Where two bodies only touch (a contact,
ops.segmentation.contacts) the sheet is slit along the shared stroke (mesh.cut_along). Each region r later gets a pocket (layer
r + 1, a copy of its faces) whose sewing is decided by the cut assignment
(ops.topology). Handles are vertices inserted at every joint and at
fixed fractions along every bone (ops.geometry.handles); inside region r a handle sits on the front
sheet if its bone is one of the region's front bones, otherwise on the pocket.

Three local layers: where two regions of one nest group overlap (both forearms folded over the chest: the top
forearm's region covers the lower forearm and the chest, the lower forearm's the chest, and the two share the
crossing; ops.segmentation.nesting), the regions are stacked front to back by their front bones' depth, and
each region's pocket copies the bottom-most copy of each of its faces so far (ops.geometry.topology.incise). A
handle descends through the stack to the first region whose front bones hold its bone.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ops.geometry.handles import handle_bones, place_handles
from ops.geometry.mesh import cut_along, signed_areas, triangulate_pslg
from ops.geometry.polygon import points_in_polygon, polygon_area
from ops.types import RefinedMasks, Skeleton, nest_group_list
from ops.warning_subject import about

FACES_PER_FOREGROUND = 1000.0  # default max_area = foreground area / this
FLAT_AREA_PX2 = 1e-6  # a face smaller than this is flat: Triangle's output along a constraint at a hair's angle


@dataclass
class TemplateBase:
    """Front-sheet mesh before incision: everything topology optimization needs."""

    V: np.ndarray  # (n, 2) float64 front-sheet vertices, pixels
    F: np.ndarray  # (m, 3) int64 front-sheet faces, positive signed area
    face_region: np.ndarray  # (m,) int64 occlusion region containing the face, -1 if none
    handle_vertex: np.ndarray  # (h,) int64 front-sheet vertex of each handle
    handle_layer: np.ndarray  # (h,) int64 0 = front sheet, r + 1 = pocket of region r
    handle_weights: np.ndarray  # (h, J) float64 one-hot (joint) or (1 - u, u) at u along a bone
    handle_offsets: np.ndarray  # (h, 2) float64 offset from the skeleton point along/across its bone (handles.py)
    handle_frames: np.ndarray  # (h, 2) int64 joints of the bone the offset turns with
    boundaries: list[np.ndarray]  # per region (n_r, 2) float64 boundary polyline, pixels
    boundary_vertex: list[np.ndarray]  # per region (n_r,) int64 mesh vertex of each polyline vertex
    junctions: list[np.ndarray]  # per region (k_r,) int64 sorted indices into boundaries[r]
    mode: str  # "optimized" | "single-layer"
    warnings: list[str] = field(default_factory=list)
    region_faces: list[np.ndarray] = field(default_factory=list)  # per region (f_r,) int64 its faces, ascending:
    #                                                                 face_region's, plus those it shares (nested)
    stack: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (R,) regions front to back
    nested: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))  # (R, R) regions sharing faces
    handle_regions: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))  # (h, R) the pockets a
    #                                                                 handle descends through (handle_layer's last)

    @property
    def n_regions(self) -> int:
        """Number of occlusion regions meshed as pockets."""
        return len(self.boundaries)


MIN_NESTED_FACES = 6  # regions of one nest group sharing fewer faces only touch (outlines simplified across each
#                      other): the shared faces go to the earlier region, as for regions of no common group


def _handle_layers(P: np.ndarray, W: np.ndarray, skeleton: Skeleton, refined: RefinedMasks, stack: np.ndarray,
                   nested: np.ndarray) -> np.ndarray:
    """(h, R) bool: the regions whose pockets each handle at P (h, 2) descends through. Regions in `stack` order
    (front to back): a handle inside a region whose front bones hold none of its bones goes down into its pocket,
    where only the regions nested with that one can take it further; inside one whose front bones hold it, it
    stays where it is, above the regions nested with that one."""
    bones_of = handle_bones(W, skeleton)
    n = len(stack)
    inside = np.stack([points_in_polygon(P, refined.boundaries[r]) for r in range(n)], axis=1) if n else \
        np.zeros((len(P), 0), bool)
    through = np.zeros((len(P), n), bool)
    for hix in range(len(P)):
        allowed = np.ones(n, bool)  # first any region; below a pocket only the regions nested with it
        for r in stack:
            if not (inside[hix, r] and allowed[r]):
                continue
            front = set(np.asarray(refined.front_bones[r]).tolist())
            if front.intersection(bones_of[hix].tolist()):
                allowed &= ~nested[r]  # on this region's front: above the regions beneath it here
                continue
            through[hix, r] = True
            allowed = nested[r].copy()
    return through


def _face_regions(V: np.ndarray, F: np.ndarray, boundaries: list[np.ndarray], groups: list[int],
                  warnings: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """((m,) int64 first region of each face by centroid (region edges are mesh edges), -1 outside all regions;
    (R, m) bool every region's faces). Two regions of one nest group (RefinedMasks.nest_groups, >= 0) sharing at
    least MIN_NESTED_FACES faces are layers of one stack and both keep them; other regions give shared faces to
    the earlier one, with a warning (two predicted regions overlapping by accident)."""
    region = np.full(len(F), -1, np.int64)
    c = V[F].mean(axis=1)
    member = np.zeros((len(boundaries), len(F)), bool)
    for r, B in enumerate(boundaries):
        inside = points_in_polygon(c, B)
        if not inside.any():
            warnings.append(about("occlusion region", "contains no face", name=r, at=B.mean(axis=0)))
        for q in range(r):
            shared = inside & member[q]
            stacked = groups[r] >= 0 and groups[q] == groups[r] and shared.sum() >= MIN_NESTED_FACES
            if shared.any() and not stacked:
                warnings.append(about("occlusion region", f"overlaps region {q} on {int(shared.sum())} face(s); "
                                      "kept the earlier", name=r, at=B.mean(axis=0)))
                inside &= ~shared
        member[r] = inside
        region[inside & (region < 0)] = r
    return region, member


def _stack(member: np.ndarray, refined: RefinedMasks, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((R,) int64 regions front to back, (R, R) bool regions sharing faces). Without nesting the regions keep
    their order; with it they are sorted by their front bones' mean joint depth (smaller z in front)."""
    R = len(member)
    nested = (member.astype(np.int64) @ member.T.astype(np.int64)) > 0
    np.fill_diagonal(nested, False)
    if not nested.any():
        return np.arange(R, dtype=np.int64), nested
    z = np.asarray(pose, np.float64)[:, 2]
    depth = []
    for r in range(R):
        bones = np.asarray(refined.front_bones[r], np.int64)
        depth.append(float(z[bones].mean()) if len(bones) else np.inf)
    return np.lexsort((np.arange(R), np.asarray(depth))).astype(np.int64), nested


def _degenerate(res) -> bool:
    """Whether a triangulation (mesh.MeshResult) has flat faces (area under FLAT_AREA_PX2)."""
    return bool(len(res.F)) and float(signed_areas(res.V, res.F).min()) < FLAT_AREA_PX2


def build_template(
    refined: RefinedMasks,
    pose: np.ndarray,
    skeleton: Skeleton,
    mode: str = "optimized",
    max_area: float | None = None,
    min_angle: float = 20.0,
) -> TemplateBase:
    """Triangulate the foreground with occlusion constraints and insert handles; pose (J, 3) pixels/depth."""
    if mode not in ("optimized", "single-layer"):
        raise ValueError(f"mode must be 'optimized' or 'single-layer', got {mode!r}")
    domain = [np.asarray(L, dtype=np.float64) for L in refined.domain]
    boundaries = [np.asarray(b, dtype=np.float64) for b in refined.boundaries] if mode == "optimized" else []
    area = sum(polygon_area(L) for L in domain)  # hole outlines have negative area
    max_area = area / FACES_PER_FOREGROUND if max_area is None else float(max_area)
    handles = place_handles(pose, skeleton, domain, refined.foreground.shape)
    warnings = list(handles.warnings)
    slits = list(refined.slits) if mode == "optimized" else []

    def mesh(cuts):
        """CDT of the domain with the regions' loops, the handles and the slits `cuts`."""
        return triangulate_pslg(domain + boundaries, max_area, min_angle, holes=refined.domain_holes,
                                points=handles.points, n_domain=len(domain), slits=cuts)

    def attempt(cuts):
        """The mesh with the slits `cuts`, or None when Triangle fails on them or emits flat faces."""
        try:
            res = mesh(cuts)
        except RuntimeError:  # Triangle: "invalid geometry on input" (slits crossing each other or a loop)
            return None
        return None if _degenerate(res) else res

    res = attempt(slits) if slits else mesh([])
    if res is None:
        # a slit meeting the outline or a region's loop at a hair's angle can make Triangle emit flat faces,
        # which no deformation can start from, or fail outright: mesh without the slits that do it, say so
        kept = [c for c in slits if attempt([c]) is not None]
        res = attempt(kept) if kept else None
        if res is None:
            kept, res = [], mesh([])
        warnings.append(f"{len(slits) - len(kept)} contact slit(s) left out: the mesh along them failed or came "
                        "out flat (the touching parts stay joined there)")
    warnings += res.warnings
    # copies of the slit's vertices are appended: every index into res.V keeps its meaning
    res.V, res.F, _ = cut_along(res.V, res.F, res.slit_edges)
    if (res.point_vertex < 0).any():  # place_handles puts every handle 2 px inside the domain: a bug if it happens
        lost = [handles.names[i] for i in np.nonzero(res.point_vertex < 0)[0]]
        raise ValueError(f"handles {lost} could not be inserted as mesh vertices")
    W = handles.weights
    groups = nest_group_list(refined.nest_groups, len(refined.boundaries))
    region, member = _face_regions(res.V, res.F, boundaries, groups, warnings)
    stack, nested = _stack(member, refined, pose)
    through = _handle_layers(res.V[res.point_vertex], W, skeleton, refined, stack, nested)
    layer = np.zeros(len(through), np.int64)
    for r in stack:  # the deepest pocket each handle descends to
        layer[through[:, r]] = r + 1
    if nested.any():
        pairs = sorted({(int(min(a, b)), int(max(a, b))) for a, b in zip(*np.nonzero(nested))})
        warnings.append(f"occlusion regions {pairs} overlap: stacked front to back {stack.tolist()} by their front "
                        "bones' depth (three local layers where they share faces)")
    junctions = [np.unique(np.asarray(refined.junctions[r], dtype=np.int64)) for r in range(len(boundaries))]
    for r, jn in enumerate(junctions):
        if len(jn) and (jn.min() < 0 or jn.max() >= len(boundaries[r])):
            raise ValueError(f"occlusion region {r}: T-junction index outside its {len(boundaries[r])}-vertex boundary")
        if len(jn) % 2 and len(jn) == len(boundaries[r]):
            warnings.append(about("occlusion region", "every boundary vertex is a T-junction, no room for a cusp; "
                                  "dropped one", name=r, at=boundaries[r].mean(axis=0)))
            junctions[r] = jn[:-1]
    bvert = res.loop_vertex[len(domain):]
    for r, (bv, jn) in enumerate(zip(bvert, junctions)):
        if (bv[jn] < 0).any():
            raise ValueError(f"occlusion region {r}: a T-junction vertex fell outside the foreground mesh")
    assert (signed_areas(res.V, res.F) > 0).all()
    return TemplateBase(
        V=res.V, F=res.F, face_region=region, handle_vertex=res.point_vertex, handle_layer=layer,
        handle_weights=W, handle_offsets=handles.offsets, handle_frames=handles.frames, boundaries=boundaries, boundary_vertex=bvert, junctions=junctions,
        mode=mode, warnings=warnings, region_faces=[np.flatnonzero(m) for m in member], stack=stack,
        nested=nested, handle_regions=through,
    )
