"""Dataclasses passed between pipeline stages.

Conventions: image coordinates in pixels, x right, y down, origin at the
top-left pixel's centre; images float32 in [0, 1] with straight alpha;
masks bool (H, W). Every array's shape and unit is named on its field.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Skeleton:
    """Joint names and the parent of each joint (-1 for the single root)."""

    joints: tuple[str, ...]
    parents: np.ndarray  # (J,) int64

    @property
    def bones(self) -> np.ndarray:
        """(B, 2) int64 (parent, child) joint index pairs, in child order."""
        child = np.nonzero(self.parents >= 0)[0]
        return np.stack([self.parents[child], child], axis=1).astype(np.int64)

    def adjacent_bones(self) -> np.ndarray:
        """(B, B) bool: bones sharing a joint (a bone is adjacent to itself)."""
        b = self.bones
        share = (b[:, None, :, None] == b[None, :, None, :]).any(axis=(2, 3))
        return share


EASES = ("linear", "in", "out", "in-out")  # a segment's timing (docs/shot-format.md, v2 `ease`)


@dataclass
class Shot:
    """A validated shot directory (docs/shot-format.md): N >= 1 keyframes of one character and its motion.

    Output frame i shows the pose poses[i] at the clock times[i]; keyframe k is output frame key_frames[k].
    Segment s runs from keyframe s to keyframe s + 1 (N = 1: one segment, the whole motion, one lane).
    """

    root: str  # absolute path of the shot directory
    keyframes: tuple[str, ...]  # absolute image paths, one per keyframe (N >= 1)
    size: tuple[int, int]  # (H, W) pixels
    skeleton: Skeleton
    times: np.ndarray  # (F,) float64 clock of each output frame: v1 its t (0 .. 1), v2 its frame number (0 .. F-1)
    poses: np.ndarray  # (F, J, 3) float64 joint x, y (pixels), z (depth, larger = farther) at each output frame
    t_junctions: tuple[np.ndarray, ...]  # per keyframe (k, 2) float64 pixels
    foreground_masks: tuple[str | None, ...]  # per keyframe: manual mask path or None
    occlusion_masks: tuple[tuple[str, ...], ...]  # per keyframe: manual occlusion mask paths
    ground_truth: str | None = None  # folder of reference frames, or None
    key_frames: tuple[int, ...] = ()  # output frame of each keyframe, strictly increasing, the first 0
    ease: tuple[str, ...] = ()  # per segment, one of EASES
    version: int = 1  # the format: 1 (two keys, t in [0, 1]) or 2 (any number of keys, frames)

    def __post_init__(self):
        if not self.key_frames:  # v1: the keyframes are the first and the last output frame
            self.key_frames = (0, len(self.times) - 1)
        if not self.ease:
            self.ease = ("linear",) * self.n_segments

    @property
    def n_keys(self) -> int:
        return len(self.keyframes)

    @property
    def n_segments(self) -> int:
        """Segments (k, k + 1) between consecutive keys; N = 1 has one: the drawing along the whole motion."""
        return max(1, self.n_keys - 1)

    def key_pose(self, k: int) -> np.ndarray:
        """(J, 3) pose at keyframe k."""
        return self.poses[self.key_frames[k]]

    def neighbours(self, k: int) -> tuple[int, ...]:
        """The keys next to key k: k - 1 and k + 1 where they exist."""
        return tuple(j for j in (k - 1, k + 1) if 0 <= j < self.n_keys)

    def segment_keys(self, s: int) -> tuple[int, ...]:
        """The keys of segment s: (s, s + 1), or (0,) for a one-drawing shot."""
        return (0,) if self.n_keys == 1 else (s, s + 1)

    def segment_frames(self, s: int) -> np.ndarray:
        """(T,) int64 output frames of segment s, both of its keyframes included."""
        if self.n_keys == 1:
            return np.arange(len(self.times))
        return np.arange(self.key_frames[s], self.key_frames[s + 1] + 1)

    def segment_times(self, s: int) -> np.ndarray:
        """(T,) float64 local time of segment s's frames: 0 at its first key, 1 at its last."""
        t = self.times[self.segment_frames(s)]
        span = t[-1] - t[0]
        return (t - t[0]) / span if span > 0 else np.zeros_like(t)

    def segment_poses(self, s: int) -> np.ndarray:
        """(T, J, 3) poses of segment s's frames."""
        return self.poses[self.segment_frames(s)]


@dataclass
class Masks:
    """Foreground and occlusion masks of one keyframe (§4.1)."""

    foreground: np.ndarray  # (H, W) bool, True = character
    occlusion: list[np.ndarray]  # per region (H, W) bool, inside foreground, sorted back to front
    front_bones: list[np.ndarray]  # per region (b,) int64 bone indices drawn in front in that region
    source: str  # "manual" | "predicted" | "mixed"
    # the soft edge: drawing = coverage * colour + (1 - coverage) * paper, in the drawing's encoding
    coverage: np.ndarray  # (H, W) float32 in [0, 1]: 1 inside, fractional on anti-aliased and soft edges, 0 off foreground
    paper: np.ndarray  # (H, W, 3) float32 paper colour under every pixel, [0, 1] (white under a transparent cut-out)
    colour: np.ndarray  # (H, W, 3) float32 character colour unmixed from the paper, [0, 1]
    holes: np.ndarray  # (H, W) bool enclosed background seen through the body (not in foreground)
    n_holes: int  # connected holes, each a hole in the mesh
    warnings: list[str] = field(default_factory=list)
    # (H, W) bool each: where the bodies of two bones that are not neighbours touch (ops.segmentation.contacts);
    # the template is slit along them. Found whenever the occlusion is predicted (empty for painted regions).
    contacts: list[np.ndarray] = field(default_factory=list)
    # per region its nest group: regions of one group >= 0 are layers of one stack and may share pixels (three
    # local layers: crossed forearms, overlapping painted masks); -1, or an empty list, none
    nest_groups: list[int] = field(default_factory=list)


@dataclass
class RefinedMasks:
    """Occlusion masks deformed so their boundaries pass through the T-junctions (§4.1)."""

    foreground: np.ndarray  # (H, W) bool
    occlusion: list[np.ndarray]  # per region (H, W) bool
    front_bones: list[np.ndarray]  # per region (b,) int64
    boundaries: list[np.ndarray]  # per region (n, 2) float64 closed polyline (first != last), pixels, DP 2 px
    junctions: list[np.ndarray]  # per region (k,) int64 indices into that region's boundary polyline
    domain: list[np.ndarray]  # closed polylines (n_i, 2) float64, pixels: outlines of the area to mesh (every
    #                           pixel with coverage > 0, a little dilated), holes' outlines included
    domain_holes: np.ndarray  # (h, 2) float64 one point inside each hole of the domain (enclosed paper), pixels
    coverage: np.ndarray  # (H, W) float32 character alpha (Masks.coverage)
    paper: np.ndarray  # (H, W, 3) float32 paper colour model (Masks.paper)
    colour: np.ndarray  # (H, W, 3) float32 character colour unmixed from the paper (Masks.colour)
    warnings: list[str] = field(default_factory=list)
    slits: list[np.ndarray] = field(default_factory=list)  # open polylines (n_i, 2) float64, pixels: the mesh is cut along them
    nest_groups: list[int] = field(default_factory=list)  # per region, as Masks.nest_groups


MIN_BONE_PX = 1e-6  # shorter bones (two joints at one spot) have no direction to carry an offset


def bone_frames(xy: np.ndarray, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit (along, across) axes (h, 2) each of the bones `frames` (h, 2) at joints xy (J, 2).

    A handle with no bone (-1), or whose bone has collapsed to a point, keeps the image axes: its offset then
    only translates with the skeleton.
    """
    d = np.tile([1.0, 0.0], (len(frames), 1))
    ok = frames[:, 0] >= 0
    d[ok] = xy[frames[ok, 1]] - xy[frames[ok, 0]]
    n = np.linalg.norm(d, axis=1, keepdims=True)
    along = np.where(n > MIN_BONE_PX, d / np.maximum(n, MIN_BONE_PX), [1.0, 0.0])
    return along, np.stack([-along[:, 1], along[:, 0]], axis=1)


def handle_targets(weights: np.ndarray, offsets: np.ndarray, frames: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(h, 2) float64 targets of handles at a (J, 3) pose: their skeleton points weights (h, J) @ joints plus their
    offsets (h, 2) (along, across) turned with their bones frames (h, 2); see ops.geometry.handles."""
    xy = np.asarray(pose, np.float64)[:, :2]
    along, across = bone_frames(xy, np.asarray(frames, np.int64))
    return weights @ xy + offsets[:, :1] * along + offsets[:, 1:] * across


@dataclass
class Template:
    """2.5D partially layered template mesh (§4.2-4.4).

    Layer 0 is the front sheet covering the whole foreground; layer r + 1 is
    the pocket (the occluded part behind) of occlusion region r.
    """

    rest: np.ndarray  # (n, 2) float64 rest vertex positions, pixels (keyframe image space)
    faces: np.ndarray  # (m, 3) int64, counter-clockwise in image coordinates (y down -> positive signed area)
    face_layer: np.ndarray  # (m,) int64 layer of each face
    handles: np.ndarray  # (h,) int64 vertex indices constrained by the pose term
    handle_weights: np.ndarray  # (h, J) float64: skeleton point of each handle = handle_weights @ joints_xy
    handle_offsets: np.ndarray  # (h, 2) float64 (along, across) its bone, pixels: where the handle sits off that point
    handle_frames: np.ndarray  # (h, 2) int64 joints (parent, child) of the bone the offset turns with, -1 if none
    cut_assignment: list[np.ndarray]  # per region (s,) int8, per boundary segment 0 = sewn to front, 1 = sewn to back
    energy: float  # deformation energy to the other keyframe's pose with the chosen topology
    trials: int  # topologies evaluated
    mode: str  # "optimized" | "single-layer"
    warnings: list[str] = field(default_factory=list)
    # the cut search's record (ops.geometry.topology), per region: where its labels flip ((s,) int64 boundary-polyline
    # indices: the T-junctions, plus the cusp of an odd count), and a digest of what its search read; a later search
    # keeps the cut of every region whose digest it finds here (reused_regions), and budget_regions are the regions
    # whose search ran out of its wall-clock budget (the best cut found by then is kept)
    cut_switches: list[np.ndarray] = field(default_factory=list)
    region_keys: list[str] = field(default_factory=list)
    reused_regions: list[int] = field(default_factory=list)
    budget_regions: list[int] = field(default_factory=list)
    # per target pose of the cut search (the neighbouring keys' poses, in Shot.neighbours order), the template's
    # vertices (n, 2) pixels deformed there by the search along the motion; (0, 2) where it found none
    target_x: list[np.ndarray] = field(default_factory=list)

    def handle_targets(self, pose: np.ndarray) -> np.ndarray:
        """(h, 2) float64 handle target positions for a (J, 3) pose (ops.geometry.handles)."""
        return handle_targets(self.handle_weights, self.handle_offsets, self.handle_frames, pose)


@dataclass
class TexturedTemplate:
    """Template with depth weights and per-face texture (§5.1)."""

    template: Template
    weights: np.ndarray  # (n, J) float64 bounded biharmonic weights, rows sum to 1
    face_source: np.ndarray  # (m,) int64: 0 = the drawing (the layer in front at the keyframe), 1 = the other
    #                          keyframe, 2 = inpainted (1 and 2: the layer behind, textured from back_texture)
    texture: np.ndarray  # (H, W, 4) float32 the drawing's colour unmixed from the paper, alpha = coverage (straight)
    back_texture: np.ndarray  # (H, L W, 4) float32 texture of the hidden layers in rest coordinates, one (H, W)
    #                           image per back level side by side (L = 1 unless occlusion regions are nested)
    back_inpainted: np.ndarray  # (H, L W) bool pixels of back_texture that were inpainted
    back_level: np.ndarray | None = None  # (m,) int64 back level of each hidden face (None: all 0)

    def back_offset(self) -> np.ndarray:
        """(m,) float32 x offset, pixels, of each face's back texture in back_texture (level * W)."""
        level = np.zeros(len(self.template.faces), np.int64) if self.back_level is None else self.back_level
        return (level * self.texture.shape[1]).astype(np.float32)

    def face_depth(self, pose: np.ndarray) -> np.ndarray:
        """(m,) float64 depth of each face at a (J, 3) pose (larger = farther)."""
        vertex_depth = self.weights @ pose[:, 2]
        return vertex_depth[self.template.faces].mean(axis=1)


@dataclass
class DeformedSequence:
    """One keyframe's template deformed into every output pose (§5.1)."""

    times: np.ndarray  # (T,) float64
    vertices: np.ndarray  # (T, n, 2) float64 deformed positions, pixels
    images: np.ndarray  # (T, H, W, 4) float32 rendered RGBA, straight alpha
    inpainted: np.ndarray  # (T, H, W) bool: visible pixels whose texture was inpainted
    energies: np.ndarray  # (T,) float64 final energy per frame
    iterations: np.ndarray  # (T,) int64 solver iterations per frame
    # (T, H, W) bool: visible pixels drawn by faces scaled beyond ops.appearance.render.DISTORTION_LIMIT
    distorted: np.ndarray | None = None
    # (T,) float64: how much of the registration onto the other key's drawing each frame took (0 at the own
    # key, 1 at the other; ops.geometry.register.fade_in), None where the lane is not registered
    fade: np.ndarray | None = None


@dataclass
class ImageMatrix:
    """RIFE blends I(alpha, t) of the two deformed sequences (§5.2)."""

    times: np.ndarray  # (T,) float64
    alphas: np.ndarray  # (A,) float64 dyadic grid, 0 .. 1
    frames: np.ndarray  # (T, A, H, W, 4) float16 scaled cells, float32 bisected (image_matrix.cell_dtype; may be
    #                     a np.memmap)
    flows: np.ndarray  # (T, H, W, 4) float32 RIFE flow at alpha = 1/2: (u0, v0) to frame 0, (u1, v1) to frame 1, pixels
    computed: np.ndarray  # (T, A) bool cells that hold their blend; the others were not needed and are zero
    # (T, H, W) float32 RIFE fusion mask at alpha = 1/2 (the weight of frame 0) where the cells off 1/2 were made
    # from the alpha-1/2 flows (ops/blending/image_matrix.py, cells "scaled"); None where they were bisected
    masks: np.ndarray | None = None


@dataclass
class BlendPath:
    """A path through the image matrix: one alpha index per time (§5.2)."""

    alpha_index: np.ndarray  # (T,) int64
    cost: float
    step_costs: np.ndarray  # (T - 1,) float64 cost of each transition
    abrupt: np.ndarray  # (T - 1,) bool transitions far above the median cost


@dataclass
class BlendPaths:
    """The optimal and the diagonal path through one shot's image matrix (§5.2)."""

    times: np.ndarray  # (T,) float64
    alphas: np.ndarray  # (A,) float64
    optimal: BlendPath
    diagonal: BlendPath


@dataclass
class OutputFrames:
    """The in-between animation: one RGBA frame per output time."""

    times: np.ndarray  # (T,) float64
    alphas: np.ndarray  # (T,) float64 alpha taken at each time
    frames: np.ndarray  # (T, H, W, 4) float32 straight alpha
    blend: str  # "optimal" | "diagonal"


def nest_group_list(groups: list[int], n: int) -> list[int]:
    """Per region of n its nest group: `groups` as given (Masks.nest_groups), or all -1 where it is empty or stale."""
    return [int(g) for g in groups] if len(groups) == n else [-1] * n
