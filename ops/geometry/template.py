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
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ops.geometry.handles import handle_bones, place_handles
from ops.geometry.mesh import cut_along, signed_areas, triangulate_pslg
from ops.geometry.polygon import points_in_polygon, polygon_area
from ops.types import RefinedMasks, Skeleton
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

    @property
    def n_regions(self) -> int:
        """Number of occlusion regions meshed as pockets."""
        return len(self.boundaries)


def _handle_layers(P: np.ndarray, W: np.ndarray, skeleton: Skeleton, refined: RefinedMasks, n_regions: int):
    """(h,) int64 layer of each handle: r + 1 when inside region r and not of a front bone, else 0."""
    bones_of = handle_bones(W, skeleton)
    layer = np.zeros(len(P), np.int64)
    for r in range(n_regions):
        inside = points_in_polygon(P, refined.boundaries[r])
        front = set(np.asarray(refined.front_bones[r]).tolist())
        for hix in np.nonzero(inside & (layer == 0))[0]:
            if not front.intersection(bones_of[hix].tolist()):
                layer[hix] = r + 1
    return layer


def _face_regions(V: np.ndarray, F: np.ndarray, boundaries: list[np.ndarray], warnings: list[str]) -> np.ndarray:
    """(m,) int64 region of each face by centroid (region edges are mesh edges), -1 outside all regions."""
    region = np.full(len(F), -1, np.int64)
    c = V[F].mean(axis=1)
    for r, B in enumerate(boundaries):
        inside = points_in_polygon(c, B)
        clash = inside & (region >= 0)
        if clash.any():
            warnings.append(about("occlusion region", f"overlaps an earlier region on {int(clash.sum())} face(s); "
                                  "kept the earlier", name=r, at=B.mean(axis=0)))
        region[inside & (region < 0)] = r
        if not inside.any():
            warnings.append(about("occlusion region", "contains no face", name=r, at=B.mean(axis=0)))
    return region


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
    region = _face_regions(res.V, res.F, boundaries, warnings)
    layer = _handle_layers(res.V[res.point_vertex], W, skeleton, refined, len(boundaries))
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
        mode=mode, warnings=warnings,
    )
