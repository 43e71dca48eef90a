"""A BVH clip projected onto a 2D character rig, as AnimatedDrawings' retargeter defines it.

Per frame the actor is turned about its up axis to face +F (forward), with R its right and U up (up is the
axis the legs hang along, forward = U x R where R runs from the left hip to the right one, as AnimatedDrawings'
`forward_perp_joint_vectors` do). Each projection group looks at its joints from the front (frontal: screen
(-R, U), depth F) or from the side (sagittal: screen (F, U), depth R); `pca` picks whichever of the two planes
the group's own motion spans best (the normal closer to the third principal axis of its root-relative joint
positions over the clip). A mapped character joint's bone takes the world direction of its BVH bone
(proximal -> distal) projected on the distal joint's plane; a character joint's depth is the mean depth of
its group's drivers (larger = nearer in AnimatedDrawings, so z = -depth here); the root moves by the clip's
root motion in the root group's plane, scaled by the ratio of the character's leg length to the actor's.

One deliberate difference: AnimatedDrawings rotates a joint's whole parent frame, so unmapped siblings (the
shoulders) follow the neck bone's turn; here unmapped joints ride their own parent bone (ops.motion.fit).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ops.errors import ShotError
from ops.motion.animated_drawings import RetargetConfig, numbered_copies
from ops.motion.bvh import BVH, base_name, forward_kinematics
from ops.motion.clip import Clip
from ops.motion.fit import parents_first

AXES = np.eye(3)
SIDE_WORDS = (("Right", "Left"), ("right", "left"), ("RIGHT", "LEFT"))


def check_names(bvh: BVH, bvh_file: str | Path, config: RetargetConfig, joints: tuple[str, ...]) -> None:
    """ShotError when the config names a BVH joint the clip lacks or a character joint the skeleton lacks (numbered
    copies of a joint count as the joint: numbered_copies)."""
    have = {base_name(n) for n in bvh.names}
    for field, name in config.bvh_joints():
        if base_name(name) not in have:
            listed = ", ".join(sorted(have)[:12])
            raise ShotError(bvh_file, "HIERARCHY", f"has no joint {name!r}, which {Path(config.file).name} names in {field}",
                            f"use a retarget config written for this clip's skeleton (its joints: {listed}, ...)")
    missing = lacking(config, joints)
    if missing:
        field, name = missing[0]
        raise ShotError(config.file, field, f"names joint {name!r}, which the shot's skeleton lacks",
                        f"give a config that maps this skeleton's joints ({', '.join(joints[:8])}, ...); "
                        "AnimatedDrawings' configs map its humanoid rig, which a shot started from drawings "
                        "gets with --skeleton humanoid")


def lacking(config: RetargetConfig, joints: tuple[str, ...]) -> list[tuple[str, str]]:
    """(field, joint name) of each character joint the config names that the skeleton lacks, a joint whose numbered
    copies it has counting as present (numbered_copies)."""
    return [(field, name) for field, name in numbered_copies(config, joints)[0].char_joints() if name not in joints]


def _pairs(bvh: BVH, names: list[str]) -> tuple[int, int] | None:
    """(right, left) joint indices among names whose spellings differ only by Right/Left (or a R/L prefix)."""
    for a in names:
        for right, left in SIDE_WORDS:
            if right in a and a.replace(right, left, 1) in names:
                return bvh.index(a), bvh.index(a.replace(right, left, 1))
        if a[:1] == "R" and ("L" + a[1:]) in names:
            return bvh.index(a), bvh.index("L" + a[1:])
    return None


def body_axes(P: np.ndarray, bvh: BVH, config: RetargetConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per frame unit forward, up, right: (F, 3) each, from (F, J, 3) world positions.

    Up is the world axis the leg chains of char_bvh_root_offset hang along (snapped, as the +y / +z of
    AnimatedDrawings' motion configs); right runs from the left to the right top of those chains.
    """
    legs = np.zeros(3)
    for chain in config.root_bvh_chains:
        legs += (P[:, bvh.index(chain[-1])] - P[:, bvh.index(chain[0])]).mean(0)  # foot -> hip: up
    k = int(np.argmax(np.abs(legs)))
    up = AXES[k] * np.sign(legs[k])
    tops = [base_name(c[-1]) for c in config.root_bvh_chains]
    pair = _pairs(bvh, tops)
    if pair is None:  # the config lists the right leg first (AnimatedDrawings' examples do)
        pair = (bvh.index(tops[0]), bvh.index(tops[-1]))
    right = P[:, pair[0]] - P[:, pair[1]]
    right = right - (right @ up)[:, None] * up
    n = np.linalg.norm(right, axis=1)
    if not (n > 1e-9).any():
        raise ShotError(config.file, "char_bvh_root_offset.bvh_joints", "the two leg chains start at one point",
                        "name the left and the right leg chain of the clip")
    for f in range(len(n)):  # a degenerate frame keeps the previous frame's facing
        if n[f] <= 1e-9:
            right[f], n[f] = right[f - 1] if f else right[np.argmax(n > 1e-9)], 1.0
    right = right / np.linalg.norm(right, axis=1, keepdims=True)
    forward = np.cross(np.broadcast_to(up, right.shape), right)
    return forward, np.broadcast_to(up, right.shape).copy(), right


def _canonical(v: np.ndarray, F: np.ndarray, U: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(Fr, ..., 3) vectors in per-frame body coordinates (forward, up, right)."""
    shape = (v.shape[0],) + (1,) * (v.ndim - 2) + (3,)
    return np.stack([(v * F.reshape(shape)).sum(-1), (v * U.reshape(shape)).sum(-1), (v * R.reshape(shape)).sum(-1)], -1)


def group_planes(Q: np.ndarray, bvh: BVH, config: RetargetConfig) -> dict[str, str]:
    """Group name -> 'frontal' | 'sagittal'; Q: (F, J, 3) root-relative positions in body coordinates."""
    planes = {}
    for g in config.projection_groups:
        if g.method != "pca":
            planes[g.name] = g.method
            continue
        pts = Q[:, [bvh.index(n) for n in g.bvh_joints]].reshape(-1, 3)
        pts = pts - pts.mean(0)
        if len(pts) < 3:
            planes[g.name] = "frontal"
            continue
        normal = np.linalg.svd(pts, full_matrices=False)[2][-1]  # the direction the group moves least along
        planes[g.name] = "frontal" if abs(normal[0]) > abs(normal[2]) else "sagittal"
    return planes


def project(q: np.ndarray, plane: str) -> tuple[np.ndarray, np.ndarray]:
    """Screen (..., 2) (x right, y up) and depth (...,) (larger = nearer) of body-coordinate vectors q (..., 3)."""
    if plane == "frontal":
        return np.stack([-q[..., 2], q[..., 1]], -1), q[..., 0]
    return np.stack([q[..., 0], q[..., 1]], -1), q[..., 2]


def _unwrapped_angles(screen: np.ndarray) -> np.ndarray:
    """(F,) image-axis angles (radians, y down) of (F, 2) y-up screen vectors, unwrapped; a vector seen end-on
    (projected length ~0) keeps the previous frame's angle."""
    ok = np.linalg.norm(screen, axis=1) > 1e-9
    ang = np.arctan2(-screen[:, 1], screen[:, 0])
    if not ok.any():
        return np.zeros(len(ang))
    first = int(np.argmax(ok))
    ang[:first] = ang[first]
    for f in range(first + 1, len(ang)):
        if not ok[f]:
            ang[f] = ang[f - 1]
    return np.unwrap(ang)


def retarget(bvh: BVH, bvh_file: str | Path, config: RetargetConfig, frames: np.ndarray, joints: tuple[str, ...],
             parents: np.ndarray, key_pose: np.ndarray) -> Clip:
    """The clip's selected frames (F,) as a Clip on the skeleton; key_pose (J, 2+) pixels gives the leg scale.
    A joint the config names and the skeleton has only numbered copies of drives the copies (numbered_copies)."""
    config, notes = numbered_copies(config, joints)
    check_names(bvh, bvh_file, config, joints)
    P = forward_kinematics(bvh, frames)
    F, U, R = body_axes(P, bvh, config)
    root = int(np.nonzero(bvh.parents < 0)[0][0])
    Q = _canonical(P - P[:, root:root + 1], F, U, R)
    planes = group_planes(Q, bvh, config)
    plane_of = {}
    for g in config.projection_groups:
        for n in g.bvh_joints:
            plane_of.setdefault(base_name(n), planes[g.name])

    def length(chains, pos, index) -> float:
        return float(sum(np.linalg.norm(pos[..., index(c[i + 1]), :] - pos[..., index(c[i]), :], axis=-1).mean()
                         for c in chains for i in range(len(c) - 1)))

    key = np.asarray(key_pose, np.float64)[:, :2]
    char_len = length(config.root_char_chains, key, joints.index)
    bvh_len = length(config.root_bvh_chains, P, bvh.index)
    if bvh_len <= 1e-9 or char_len <= 1e-9:
        raise ShotError(config.file, "char_bvh_root_offset", "the leg chains have no length",
                        "name chains of at least two distinct joints (foot, knee, hip)")
    scale = char_len / bvh_len  # pixels per BVH unit

    mapping, warnings = runtime_checks(config.checks, joints, key, config.mapping)
    warnings = notes + warnings
    angles = {}
    for c, (prox, dist) in mapping.items():
        plane = plane_of.get(base_name(dist))
        if plane is None:
            raise ShotError(config.file, f"char_joint_bvh_joints_mapping.{c}",
                            f"BVH joint {dist!r} is in no bvh_projection_bodypart_groups entry",
                            "add it to the group whose plane should show it")
        screen, _ = project(Q[:, bvh.index(dist)] - Q[:, bvh.index(prox)], plane)
        angles[joints.index(c)] = _unwrapped_angles(screen)

    # z per character joint: its depth group's drivers; a joint in no group takes its nearest grouped ancestor's
    J = len(joints)
    depth = np.full((len(frames), J), np.nan)
    for g in config.depth_groups:
        d = np.mean([project(Q[:, bvh.index(n)], plane_of.get(base_name(n), "frontal"))[1] for n in g.drivers], 0)
        for c in g.char_joints:
            depth[:, joints.index(c)] = -scale * d
    for j in parents_first(parents):
        if np.isnan(depth[0, j]):
            p = int(parents[j])
            depth[:, j] = depth[:, p] if p >= 0 and not np.isnan(depth[0, p]) else np.nan
    for j in parents_first(parents)[::-1]:  # the root (and anything above every group) takes a child's depth
        if np.isnan(depth[0, j]):
            kids = [c for c in range(J) if parents[c] == j and not np.isnan(depth[0, c])]
            depth[:, j] = depth[:, kids[0]] if kids else 0.0

    # root: the clip's root motion in the root group's plane (AnimatedDrawings: lateral for frontal, else forward)
    delta = np.diff(P[:, root], axis=0)
    across = -R[1:] if planes[config.root_group] == "frontal" else F[1:]
    step = np.stack([(delta * across).sum(1), -(delta @ U[0])], 1) * scale
    root_xy = np.vstack([np.zeros((1, 2)), np.cumsum(step, axis=0)])
    return Clip(root=root_xy, angles=angles, depth=depth, warnings=warnings)


def runtime_checks(checks: tuple, joints: tuple[str, ...], key_pose: np.ndarray,
                   mapping: dict[str, tuple[str, str]]) -> tuple[dict[str, tuple[str, str]], list[str]]:
    """AnimatedDrawings' `char_runtime_checks`: ['above', target, j1, j2] drops target from the mapping when the
    drawing has it below the line j1 -> j2 (a head drawn below the shoulders would flip); (mapping, warnings)."""
    mapping, warnings = dict(mapping), []
    for _, target, j1, j2 in checks:
        if target not in mapping:
            continue
        p = key_pose[:, :2] * np.array([1.0, -1.0])  # y up, as the check is written
        t, u = p[joints.index(j2)] - p[joints.index(j1)], p[joints.index(target)] - p[joints.index(j1)]
        a = np.arctan2(t[1], t[0])
        if np.sin(-a) * u[0] + np.cos(-a) * u[1] < 0:
            del mapping[target]
            warnings.append(f"{target} is drawn below {j1}-{j2}: the clip does not turn it (char_runtime_checks)")
    return mapping, warnings
