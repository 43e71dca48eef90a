// Skeleton editing on a shot.json object: add, delete, re-parent and rename joints, apply a template, copy a
// pose between keys. Pure functions of the object (the caller wraps them in an undo step); they keep every
// pose's joint list in step with skeleton.joints, so the result loads as a valid shot. No function assumes two
// keys: key poses are found by keyPoseIndices (v1: the first and the last pose; v2: the pose at each key frame).

const round1 = (v) => Math.round(v * 10) / 10;

/** An edit that cannot be made, with the reason the page shows. */
export class SkeletonError extends Error {}

/** Index into shot.poses of each keyframe's pose (editor/shotfile.py key_pose_indices, the same rule). */
export function keyPoseIndices(shot) {
  const poses = Array.isArray(shot.poses) ? shot.poses : [];
  if (!poses.length) return [];
  const frames = keyFramesOf(shot);
  if (!frames) return poses.length >= 2 ? [0, poses.length - 1] : [0];
  return frames.map((f) => poses.findIndex((p) => p && p.frame === f)).filter((i) => i >= 0);
}

export const V2 = 'inbetween-shot/2';

/** A v2 shot's key frames ([0] when a one-drawing shot leaves them out); null for v1. */
export function keyFramesOf(shot) {
  if (Array.isArray(shot.key_frames)) return shot.key_frames;
  return shot.format === V2 ? [0] : null;
}

/** Number of keyframes the shot has: v1 two, v2 its keyframes (at least one). */
export function keyCount(shot) {
  const n = Array.isArray(shot.keyframes) ? shot.keyframes.length : 0;
  return shot.format === V2 ? Math.max(1, n) : 2;
}

/** Make the skeleton and one pose per keyframe exist (empty), so joints can be added to a shot that has none. */
export function ensureSkeleton(shot) {
  const sk = shot.skeleton;
  if (!sk || typeof sk !== 'object' || !Array.isArray(sk.joints) || !Array.isArray(sk.parents)) {
    shot.skeleton = { joints: [], parents: [] };
    for (const p of Array.isArray(shot.poses) ? shot.poses : []) if (p && typeof p === 'object') p.joints = [];
  }
  if (!Array.isArray(shot.poses)) shot.poses = [];
  shot.poses = shot.poses.filter((p) => p && typeof p === 'object');
  for (const p of shot.poses) if (!Array.isArray(p.joints)) p.joints = [];
  if (keyPoseIndices(shot).length < keyCount(shot)) {
    // v1: the poses at t = 0 and t = 1; v2: one at every key frame
    const J = shot.skeleton.joints.length;
    const empty = () => Array.from({ length: J }, () => [0, 0, 0]);
    if (keyFramesOf(shot)) {
      for (const f of keyFramesOf(shot)) if (!shot.poses.some((p) => p.frame === f)) shot.poses.push({ frame: f, joints: empty() });
      shot.poses.sort((a, b) => a.frame - b.frame);
    } else {
      if (!shot.poses.some((p) => p.t === 0)) shot.poses.unshift({ t: 0, joints: empty() });
      if (!shot.poses.some((p) => p.t === 1)) shot.poses.push({ t: 1, joints: empty() });
    }
  }
  return shot.skeleton;
}

/** A joint name not in use: base, or base2, base3 ... */
export function freeName(shot, base = 'joint') {
  const used = new Set(shot.skeleton.joints);
  if (!used.has(base)) return base;
  let n = 2;
  while (used.has(`${base}${n}`)) n++;
  return `${base}${n}`;
}

/** Add a joint at (x, y) of keyframe k with the given parent (-1: the root; only when there is none).
 *  In every other pose it keeps the same offset from its parent (the root: the same place). Returns its index. */
export function addJoint(shot, k, x, y, parent, name = null) {
  const sk = ensureSkeleton(shot);
  if (parent < 0 && sk.parents.includes(-1)) throw new SkeletonError('the skeleton has a root already: add the joint to a joint');
  const j = sk.joints.length;
  sk.joints.push(name || freeName(shot));
  sk.parents.push(parent);
  const keyIdx = keyPoseIndices(shot)[k];
  const here = shot.poses[keyIdx].joints;
  shot.poses.forEach((pose, i) => {
    let p = [round1(x), round1(y), parent >= 0 ? here[parent][2] : 0];
    if (i !== keyIdx && parent >= 0) {
      const dx = x - here[parent][0], dy = y - here[parent][1];
      p = [round1(pose.joints[parent][0] + dx), round1(pose.joints[parent][1] + dy), pose.joints[parent][2]];
    }
    pose.joints.push(p);
  });
  return j;
}

/** Delete joint j: its children go to its parent; the root may go only when it has at most one child (who
 *  becomes the root). */
export function deleteJoint(shot, j) {
  const sk = shot.skeleton;
  const children = sk.parents.map((p, c) => (p === j ? c : -1)).filter((c) => c >= 0);
  if (sk.parents[j] === -1 && children.length > 1) {
    throw new SkeletonError(`${sk.joints[j]} is the root of ${children.length} limbs: re-parent all but one first`);
  }
  const up = sk.parents[j];
  const parents = sk.parents.map((p) => (p === j ? up : p));
  sk.joints.splice(j, 1);
  parents.splice(j, 1);
  sk.parents = parents.map((p) => (p > j ? p - 1 : p));
  for (const pose of shot.poses) pose.joints.splice(j, 1);
}

/** Whether joint a is joint b or lies below it. */
export function isBelow(shot, a, b) {
  const parents = shot.skeleton.parents;
  for (let j = a, steps = 0; j >= 0 && steps <= parents.length; j = parents[j], steps++) if (j === b) return true;
  return false;
}

/** Make joint `parent` the parent of joint `child` (the bone drawn from one onto the other). */
export function reparent(shot, child, parent) {
  const sk = shot.skeleton;
  if (child === parent) throw new SkeletonError('a joint cannot be its own parent');
  if (isBelow(shot, parent, child)) {
    throw new SkeletonError(`${sk.joints[parent]} lies below ${sk.joints[child]}: that bone would close a loop`);
  }
  sk.parents[child] = parent;
}

/** Rename joint j; names stay unique and non-empty. */
export function renameJoint(shot, j, name) {
  const clean = String(name).trim();
  if (!clean) throw new SkeletonError('a joint needs a name');
  if (shot.skeleton.joints.some((n, i) => n === clean && i !== j)) throw new SkeletonError(`there is a joint ${clean} already`);
  shot.skeleton.joints[j] = clean;
}

/** Whether the shot's skeleton is the template's (same joints, same parents). */
export function isTemplate(shot, tpl) {
  const sk = shot.skeleton;
  return !!sk && JSON.stringify(sk.joints) === JSON.stringify(tpl.joints) && JSON.stringify(sk.parents) === JSON.stringify(tpl.parents);
}

/** Place template `tpl` ({joints, parents, positions (u, v) in the unit box}) in box [x0, y0, x1, y1] of keyframe k.
 *  When the skeleton is another one, it is replaced: every keyframe's pose starts from this box, and poses
 *  between the keys go (their joints meant the old skeleton). When it is the template already, only keyframe
 *  k's pose is placed. Returns true when the skeleton was replaced. */
export function applyTemplate(shot, tpl, k, box) {
  const [x0, y0, x1, y1] = [Math.min(box[0], box[2]), Math.min(box[1], box[3]), Math.max(box[0], box[2]), Math.max(box[1], box[3])];
  const placed = tpl.positions.map(([u, v]) => [round1(x0 + u * (x1 - x0)), round1(y0 + v * (y1 - y0)), 0]);
  const replace = !isTemplate(shot, tpl);
  if (replace) {
    shot.skeleton = { joints: [...tpl.joints], parents: [...tpl.parents] };
    const keep = new Set(keyPoseIndices(shot));
    shot.poses = (Array.isArray(shot.poses) ? shot.poses : []).filter((p, i) => keep.has(i));
    ensureSkeleton(shot);
    for (const pose of shot.poses) pose.joints = placed.map((p) => [...p]);
  } else {
    shot.poses[keyPoseIndices(shot)[k]].joints = placed;
  }
  return replace;
}

/** Copy keyframe `from`'s pose to keyframe `to` (a start for posing it). */
export function copyPose(shot, from, to) {
  const idx = keyPoseIndices(shot);
  shot.poses[idx[to]].joints = shot.poses[idx[from]].joints.map((p) => [...p]);
}
