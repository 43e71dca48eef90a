"""Per keyframe, the lane both segments beside it share: masks -> refined masks -> template; per segment, each
key's side of it: textured template (from its drawing and the segment's other key's) -> deformed frames."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ops import preview
from ops.appearance.lane import deform_lane, texture_lane
from ops.blending.quality import inpainted_share
from ops.evaluation.lane_checks import agreement, agreement_warning, torn_shares, torn_warning
from ops.geometry.deform import count_flipped
from ops.geometry.topology import Solver, optimize_topology
from ops.segmentation.masks import build_masks
from ops.segmentation.refine import refine_masks
from ops.shotio.image_io import read_image
from ops.types import DeformedSequence, Masks, RefinedMasks, Shot, Template, TexturedTemplate

from .compute import STAGE_SPECS, StageDef, StageEnv, StageResult, stage
from .graph import side


def _mask_image(path: str, field: str) -> np.ndarray:
    img = read_image(path, field)
    return img[..., 0] > 0.5 if img.shape[2] < 4 else (img[..., 0] > 0.5) & (img[..., 3] > 0.5)


def key_masks(shot: Shot, k: int, drawing: np.ndarray, occlusion: str,
              call: Callable[..., Any] = lambda fn, *a, **kw: fn(*a, **kw)) -> Masks:
    """Foreground and occlusion masks of keyframe k (§4.1), its (H, W, 4) drawing given: manual masks override
    the prediction. The masks stage's computation (`call` runs build_masks: StageEnv.offload), also called
    outside a run (assets/run/junctions.py)."""
    fg = shot.foreground_masks[k]
    manual_fg = _mask_image(fg, f"masks.foreground[{k}]") if fg else None
    manual_occ = [_mask_image(p, f"masks.occlusion[{k}][{i}]") for i, p in enumerate(shot.occlusion_masks[k])] or None
    return call(build_masks, drawing, shot.key_pose(k), shot.skeleton, manual_fg, manual_occ,
                source=shot.keyframes[k], occlusion=occlusion)


def _masks(k: int):
    def compute(env: StageEnv) -> StageResult:
        """Foreground and occlusion masks of the keyframe (§4.1): manual masks override the prediction."""
        drawing = env.drawing(k)
        masks = key_masks(env.shot, k, drawing, env.settings.occlusion, env.offload)
        for w in masks.warnings:
            env.context.log.warning(w)
        meta = {"regions": len(masks.occlusion), "foreground_px": int(masks.foreground.sum()), "source": masks.source,
                "warnings": masks.warnings}
        return StageResult(masks, meta, preview.mask_overlay(drawing, masks.foreground, masks.occlusion, None, None))

    return compute


def _check_masks(masks: Masks, env: StageEnv) -> tuple[bool, str]:
    h, w = env.shot.size
    ok = masks.foreground.shape == (h, w) and masks.foreground.any()
    return ok, f"foreground {int(masks.foreground.sum())} px in a {w}x{h} frame"


def _check_occlusion_inside(masks, env) -> tuple[bool, str]:
    outside = [int((occ & ~masks.foreground).sum()) for occ in masks.occlusion]
    empty = [i for i, occ in enumerate(masks.occlusion) if not occ.any()]
    return not any(outside) and not empty, f"pixels outside the foreground per region: {outside}; empty regions: {empty}"


def _targets(shot, k: int) -> np.ndarray | list[np.ndarray]:
    """The poses key k's lane must deform well to: the neighbouring keys' (one, as a (J, 3) array, for a two-key
    shot), or for a one-drawing shot the pose of its motion farthest from the drawing's."""
    if shot.n_keys == 1:
        moved = np.abs(shot.poses[..., :2] - shot.key_pose(0)[None, :, :2]).sum(axis=(1, 2))
        return shot.poses[int(np.argmax(moved))]
    around = [shot.key_pose(j) for j in shot.neighbours(k)]
    return around[0] if len(around) == 1 else around


def _refined(k: int):
    def compute(env: StageEnv) -> StageResult:
        """Occlusion masks deformed so their boundaries pass through the T-junctions (§4.1)."""
        masks: Masks = env.read(f"key{k}/masks")
        shot = env.shot
        refined = refine_masks(masks, shot.t_junctions[k], shot.key_pose(k), shot.skeleton, _targets(shot, k))
        for w in refined.warnings[len(masks.warnings):]:  # the masks stage already logged its own
            env.context.log.warning(w)
        pts = [b[j] for b, j in zip(refined.boundaries, refined.junctions)]
        meta = {"regions": len(refined.occlusion), "t_junctions": int(sum(len(j) for j in refined.junctions)),
                "boundary_vertices": [len(b) for b in refined.boundaries], "slits": len(refined.slits),
                "warnings": refined.warnings}
        img = preview.mask_overlay(env.drawing(k), refined.foreground, refined.occlusion,
                                   [*refined.domain, *refined.boundaries], pts, refined.slits)
        return StageResult(refined, meta, img)

    return compute


def _template(k: int):
    def compute(env: StageEnv) -> StageResult:
        """2.5D template: mesh with pockets, handles and the cut topology of least energy (§4.2-4.4)."""
        shot, s = env.shot, env.settings
        refined: RefinedMasks = env.read(f"key{k}/refined_masks")
        solver = Solver(s.mu, s.grad_tol, s.max_iter, s.topology_budget)
        template = env.offload(optimize_topology, refined, shot.key_pose(k), _targets(shot, k), shot.skeleton,
                               mode=s.template_mode, solver=solver, previous=_previous_template(env, k),
                               implied_cuts=s.implied_cuts)
        for w in template.warnings:
            env.context.log.warning(w)
        meta = {"V": len(template.rest), "F": len(template.faces), "layers": int(template.face_layer.max()) + 1,
                "regions": len(template.cut_assignment), "trials": template.trials, "energy": float(template.energy),
                "regions_reused": len(template.reused_regions), "regions_out_of_budget": len(template.budget_regions),
                "mode": template.mode, "warnings": template.warnings}
        img = preview.wireframe(env.drawing(k), template.rest, template.faces, template.face_layer, template.handles)
        return StageResult(template, meta, img)

    return compute


def _previous_template(env: StageEnv, k: int) -> Template | None:
    """The template an earlier run stored for this keyframe (its unchanged regions keep their cuts), or None.
    Only one the same code made counts: a region's key digests what its search read, not how it searched, so
    cuts chosen by an older search are searched again."""
    name = f"key{k}/template"
    try:
        _, record = env.store.provenance(name, env.partition)
        if record is None or record.get("code") != (env.code or STAGE_SPECS[name].code):
            return None
        previous = env.store.read(name, env.partition)
    except Exception:  # none yet, or damaged: search every region
        return None
    return previous if isinstance(previous, Template) else None


def _check_template_folds(template, env) -> tuple[bool, str]:
    n = count_flipped(template.rest, template.faces)
    return n == 0, f"{n} folded triangles at rest"


def _textured(s: int, k: int):
    def compute(env: StageEnv) -> StageResult:
        """Depth weights (bounded biharmonic) and texture of every layer, the hidden ones from the segment's other
        keyframe where it shows them; unseen parts inpainted (§5.1)."""
        shot, st = env.shot, env.settings
        others = [o for o in shot.segment_keys(s) if o != k]
        other = env.read(f"key{others[0]}/refined_masks") if others else None
        other_pose = shot.key_pose(others[0]) if others else None
        template: Template = env.read(f"key{k}/template")
        # the cut search's solution at the other key's pose (its targets are the neighbouring keys', in order)
        at_other = shot.neighbours(k).index(others[0]) if others else None
        start = template.target_x[at_other] if at_other is not None and at_other < len(template.target_x) else None
        textured, energy = env.offload(texture_lane, template, env.read(f"key{k}/refined_masks"), other,
                                       shot.key_pose(k), other_pose, env.resource("inpainter").get(), st.mu,
                                       st.grad_tol, st.max_iter, start)
        counts = np.bincount(textured.face_source, minlength=3)
        meta = {"faces_from_drawing": int(counts[0]), "faces_from_other_key": int(counts[1]),
                "faces_inpainted": int(counts[2]), "inpainted_px": int(textured.back_inpainted.sum()),
                "back_levels": textured.back_texture.shape[1] // max(textured.texture.shape[1], 1),
                "energy_to_other_pose": energy}
        # one back texture per back level, side by side (three local layers: two hidden layers at one pixel)
        img = preview.side_by_side([textured.texture, textured.back_texture], ["front layer", "pockets (back)"])
        return StageResult(textured, meta, img)

    return compute


def _deformed(s: int, k: int):
    def compute(env: StageEnv) -> StageResult:
        """The textured template deformed into every pose of the segment and rendered (§4.3, §5.1); registered
        onto the other key's drawing where the skeleton leaves it off, faded in toward that key."""
        shot, st = env.shot, env.settings
        textured: TexturedTemplate = env.read(side(s, k, "textured_template"))
        backward = k != shot.segment_keys(s)[0]  # the segment's last key deforms from its own end
        others = [o for o in shot.segment_keys(s) if o != k]
        other = env.read(f"key{others[0]}/masks") if others else None
        seq = env.offload(deform_lane, textured, shot.segment_times(s), shot.segment_poses(s), backward, shot.size,
                          st.mu, st.supersample, other if st.register_lanes else None)
        folds = [count_flipped(x, textured.template.faces) for x in seq.vertices]
        meta = {"frames": len(seq.times), "folded_triangles": folds, "energy_max": float(seq.energies.max()),
                "iterations_total": int(seq.iterations.sum()),
                "inpainted_share_max": float(inpainted_share(seq.inpainted, seq.images[..., 3]).max()),
                "distorted_share_max": float(torn_shares(seq).max()), "registered": seq.fade is not None}
        warnings = [torn_warning(seq, shot.segment_poses(s), shot.key_pose(k), shot.skeleton, k)]
        if other is not None:  # the lane at the other key's pose against that key's drawing (docs/lanes.md)
            db, difference = agreement(seq.images[0 if backward else -1], other)
            meta["agreement_db"] = round(db, 3)
            warnings.append(agreement_warning(db, difference, shot.key_pose(others[0]), shot.key_pose(k),
                                              shot.skeleton, k, others[0]))
        meta["warnings"] = [w for w in warnings if w is not None]
        for w in meta["warnings"]:
            env.context.log.warning(w)
        if seq.fade is not None:  # the injectivity cap often leaves frames short of their eased weight (lanes.md)
            meta["registration_weight_at_other_key"] = float(seq.fade[0 if backward else -1])
            meta["registration_weight"] = [round(float(w), 3) for w in seq.fade]
        marks = [(seq.inpainted, preview.INPAINTED_TINT), (seq.distorted, preview.DISTORTED_TINT)]
        return StageResult(seq, meta, preview.frame_strip(seq.images, marks=marks))

    return compute


def _check_no_folds(seq: DeformedSequence, env: StageEnv) -> tuple[bool, str]:
    faces = env.read(env.stage.rsplit("/", 1)[0] + "/textured_template").template.faces
    folds = [count_flipped(x, faces) for x in seq.vertices]
    return sum(folds) == 0, f"folded triangles per frame: {folds}"


def lane_stages(k: int) -> list[StageDef]:
    """Key k's lane, shared by the segments beside it."""
    lane = f"key{k}"
    return [
        stage(f"{lane}/masks", _masks(k), checks={"masks_nonempty_in_frame": _check_masks, "occlusion_inside_foreground": _check_occlusion_inside}),
        stage(f"{lane}/refined_masks", _refined(k), checks={"occlusion_inside_foreground": _check_occlusion_inside}),
        stage(f"{lane}/template", _template(k), checks={"no_folded_triangles_at_rest": _check_template_folds}),
    ]


def side_stages(s: int, k: int) -> list[StageDef]:
    """Key k's side of segment s: its texture for the segment and its deformation through the segment's poses."""
    return [
        stage(side(s, k, "textured_template"), _textured(s, k), resources=("inpainter",)),
        stage(side(s, k, "deformed_frames"), _deformed(s, k), checks={"no_folded_triangles": _check_no_folds}),
    ]
