"""The masks of a keyframe (§4.1): foreground (with holes and soft edges) and occlusion regions.

Manual masks override the prediction (ops.segmentation.foreground; occlusion read off the drawing by
ops.segmentation.occlusion_drawing, or from the skeleton alone by ops.segmentation.occlusion); the
T-junction refinement (ops.segmentation.refine) then corrects the region boundaries where the user clicked.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from ops.errors import ShotError
from ops.segmentation.bones import thick_regions
from ops.segmentation.contacts import drawn_parts, stroke_contacts
from ops.segmentation.domain import closed_holes
from ops.segmentation.foreground import Foreground, foreground_from_mask, segment_foreground
from ops.segmentation.manual import clip_manual_occlusion, manual_front_bones
from ops.segmentation.nesting import nest_crossed_fronts
from ops.segmentation.occlusion import predict_occlusion as skeleton_occlusion
from ops.settings import OCCLUSION_PREDICTORS
from ops.types import Masks, Skeleton
from ops.warning_subject import about

NEAR_OUTSIDE_PX = 4.0  # joints this close outside the foreground are "slightly" outside


def pose_warnings(foreground: np.ndarray, pose: np.ndarray, skeleton: Skeleton) -> list[str]:
    """Warnings for joints and bone midpoints outside the (H, W) bool foreground (the template snaps them)."""
    dist_out = ndimage.distance_transform_edt(~foreground)
    h, w = foreground.shape
    xy = pose[:, :2]
    mids = xy[skeleton.bones].mean(axis=1)
    subjects = [("joint", name, "lies") for name in skeleton.joints]
    subjects += [("bone", f"{skeleton.joints[p]}-{skeleton.joints[c]}", "midpoint lies") for p, c in skeleton.bones]
    warnings = []
    for (kind, name, what), (x, y) in zip(subjects, np.concatenate([xy, mids])):
        if not (0 <= x <= w - 1 and 0 <= y <= h - 1):
            warnings.append(about(kind, f"{what} outside the image", name=name, at=(x, y), fix="check the pose"))
            continue
        d = float(dist_out[int(round(y)), int(round(x))])
        if d == 0:
            continue
        how = "slightly" if d <= NEAR_OUTSIDE_PX else "far"
        warnings.append(about(kind, f"{what} {how} outside the foreground ({d:.1f} px)", name=name, at=(x, y)))
    return warnings


def _foreground(
    drawing: np.ndarray, pose: np.ndarray, skeleton: Skeleton, manual: np.ndarray | None, source: str
) -> Foreground:
    """The foreground: the manual mask when given (its soft edge read from the drawing), else predicted.

    Raises ShotError when it is empty or the manual mask's size differs from the drawing's.
    """
    if manual is None:
        fg = segment_foreground(drawing, pose, skeleton)
        if not fg.mask.any():
            raise ShotError(
                source, "keyframes", "nothing in the drawing differs from the paper",
                "draw on plain paper or give masks.foreground",
            )
        return fg
    m = np.asarray(manual)
    if m.shape != drawing.shape[:2]:
        raise ShotError(
            source, "masks.foreground", f"size {m.shape} differs from the drawing {drawing.shape[:2]}",
            "save the mask at the keyframe's width and height",
        )
    fg = m > 0.5 if m.dtype != bool else m.copy()
    if not fg.any():
        raise ShotError(source, "masks.foreground", "the manual foreground mask is empty", "paint the character white")
    return foreground_from_mask(drawing, fg)


def build_masks(
    drawing: np.ndarray,
    pose: np.ndarray,
    skeleton: Skeleton,
    manual_foreground: np.ndarray | None = None,
    manual_occlusion: list[np.ndarray] | None = None,
    source: str = "drawing",
    occlusion: str = "skeleton",
) -> Masks:
    """Masks of a (H, W, C) float32 drawing at a (J, 3) pose; manual masks ((H, W) bool/float) override.

    manual_occlusion None or empty = predict (the shot format cannot say "no regions"); otherwise exactly
    those regions. `occlusion` picks the predictor (Settings.occlusion): "skeleton", "hybrid" (the skeleton rule's
regions shaped by the drawing), "pairs" (the hybrid's, one region per overlapping bone pair) or "drawing". `source`
    names the keyframe file in errors.
    """
    if occlusion not in OCCLUSION_PREDICTORS:
        raise ValueError(f"occlusion predictor {occlusion!r}: use one of {OCCLUSION_PREDICTORS}")
    seg = _foreground(drawing, pose, skeleton, manual_foreground, source)
    fg = seg.mask
    # bodies are as thick as drawn: a predicted mask's transparent rim must not thicken the bones' regions
    body = fg if manual_foreground is not None else fg & (seg.coverage >= 0.5)
    warnings = seg.warnings + pose_warnings(fg, pose, skeleton)
    predicted = manual_occlusion is None or len(manual_occlusion) == 0
    contacts: list[np.ndarray] = []
    groups: list[int] = []  # Masks.nest_groups: none unless a crossing or painted layers make them
    parts = drawn_parts(drawing, body, pose, skeleton) if predicted else None  # the hybrid's and the contacts'
    if predicted and occlusion == "drawing":
        # no pockets where bones that share a joint overlap: the mesh bends there, and a pocket at an elbow
        # or a hip opened as a dark blob when the limb moved (arm_cross: 25.2 -> 25.5 dB, Chamfer 30.2 -> 28.1)
        from ops.segmentation.occlusion_drawing import predict_occlusion as drawing_occlusion  # torch: only here

        regions, fronts, w = drawing_occlusion(drawing, body, pose, skeleton, joint_overlaps=False, source=source)
        warnings += w
    elif predicted:
        regions, fronts, w = skeleton_occlusion(body, pose, skeleton)
        warnings += w
        if occlusion in ("hybrid", "pairs") and regions:
            from ops.segmentation.occlusion_drawing import shape_by_drawing  # torch: only here
            from ops.segmentation.occlusion_pairs import check_fronts

            regions = shape_by_drawing(regions, fronts, drawing, body, pose, skeleton, parts)
            if occlusion == "pairs":  # one region per overlapping bone pair, its front read as the network's are
                from ops.segmentation.occlusion_drawing import split_by_pairs

                regions, fronts, w = split_by_pairs(regions, drawing, body, pose, skeleton, source)
            else:
                fronts, w = check_fronts(regions, fronts, drawing, body, pose, skeleton, source)  # the drawing's word
            warnings += w
        if occlusion != "pairs":  # pairs are one region per overlapping pair: their crossings are apart already
            regions, fronts, groups, w = nest_crossed_fronts(regions, fronts, body, pose, skeleton)
            warnings += w
    if predicted:  # painted regions are the user's word on the layers: no slits beside them
        # glued paper: what the mesh holds that is no body, slivers of holes it closes over included
        held = fg if seg.holes is None else fg | closed_holes(fg, seg.coverage, seg.holes)
        contacts = stroke_contacts(drawing, body, pose, skeleton, glued=held & ~body, parts=parts)
    else:
        kept, w = clip_manual_occlusion(list(manual_occlusion), fg)
        warnings += w
        scored = []
        thick = thick_regions(body, pose, skeleton) if kept else None
        for r in kept:
            front, depth, w = manual_front_bones(r, thick, pose, skeleton)
            warnings += w
            scored.append((-depth, r, front))
        scored.sort(key=lambda s: s[0])  # stable: ties keep the file order
        regions, fronts = [s[1] for s in scored], [s[2] for s in scored]
        groups = [0] * len(regions)  # painted regions that overlap are the user's layers, stacked by depth
    n_manual = (manual_foreground is not None) + (not predicted)
    kind = {0: "predicted", 1: "mixed", 2: "manual"}[n_manual]
    return Masks(
        foreground=fg, occlusion=regions, front_bones=fronts, coverage=seg.coverage, colour=seg.colour,
        paper=seg.paper, holes=seg.holes, n_holes=seg.n_holes, source=kind, warnings=warnings,
        contacts=contacts, nest_groups=groups,
    )
