"""Starting a shot (docs/starting.md): `inbetween new` from drawings or an AnimatedDrawings character, and
`inbetween motion` from a BVH clip or a video. Reads and writes files and says what it did; the work is in ops/.

Nothing is written until everything has been read and computed: a bad input leaves the shot directory as
it was. shot.json is written atomically, last; `new` refuses an existing one, `motion` keeps the previous
one as shot.json.bak.
"""
from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy import ndimage

from ops.errors import ShotError
from ops.motion.animated_drawings import read_character, read_retarget
from ops.motion.bvh import frame_slice, parse_bvh
from ops.motion.canvas import carried_with_bones, outline_points, pad_drawing, padding_for
from ops.motion.clip import Clip
from ops.motion.fit import fit_clip
from ops.motion.retarget import retarget
from ops.motion.shot_v2 import as_v2, key_poses, new_shot, pose_json, write_json
from ops.motion.track import read_points, read_video, track, tracks_to_clip
from ops.shotio.image_io import pixel_problem, read_image, write_image
from ops.shotio.load import MAX_FRAMES, read_shot_json
from ops.skeleton.depth import depth_order
from ops.skeleton.placement import place_template
from ops.skeleton.silhouette import find_silhouette
from ops.skeleton.templates import load_template
from ops.types import Skeleton

KEY_SPACING = 8  # default frames between keys: 0, 8, 16, ...

Say = Callable[[str], None]


def _refuse_existing(shot_dir: Path) -> None:
    if (shot_dir / "shot.json").exists():
        raise ShotError(shot_dir / "shot.json", "shot.json", "already exists; `inbetween new` never overwrites it",
                        "choose a new SHOT_DIR, or change this shot with `inbetween edit` / `inbetween motion`")


def parse_key_frames(text: str | None, n: int) -> list[int]:
    """Key frames from '0,8,20' (n of them, first 0, increasing); None: 0, 8, 16, ..."""
    if text is None:
        return [KEY_SPACING * k for k in range(n)]
    try:
        frames = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ShotError("--key-frames", "--key-frames", f"{text!r} is not a list of integers",
                        "write e.g. --key-frames 0,8,20") from None
    if len(frames) != n:
        raise ShotError("--key-frames", "--key-frames", f"gives {len(frames)} frames for {n} images",
                        "give one key frame per image")
    if frames[0] != 0 or any(b <= a for a, b in zip(frames, frames[1:])):
        raise ShotError("--key-frames", "--key-frames", f"{frames} must start at 0 and increase",
                        "write strictly increasing frames starting at 0, e.g. 0,8,20")
    if frames[-1] >= MAX_FRAMES:
        raise ShotError("--key-frames", "--key-frames", f"last key frame {frames[-1]} is beyond {MAX_FRAMES - 1}",
                        f"keep the shot within {MAX_FRAMES} frames")
    return frames


def _drawing(path: Path) -> np.ndarray:
    """A keyframe's pixels, or ShotError naming the image."""
    if not path.is_file():
        raise ShotError(path, "IMAGE", "file not found", "give the path of a drawing (PNG, JPEG, TIFF, EXR)")
    problem = pixel_problem(path)
    if problem:
        raise ShotError(path, "IMAGE", problem[0], problem[1])
    return read_image(path)


def _silhouette(path: Path, img: np.ndarray):
    try:
        return find_silhouette(img)
    except ValueError as e:
        raise ShotError(path, "IMAGE", f"is not a drawing of a character ({e})",
                        "give a drawing on paper (or an RGBA cut-out) with the character on it") from None


def _say_pose(say: Say, joints, pose: np.ndarray, confidence: np.ndarray | None) -> None:
    for j, name in enumerate(joints):
        sure = "" if confidence is None else f"  sure {confidence[j]:.2f}" + ("  (check)" if confidence[j] < 0.3 else "")
        say(f"  {name:16s} ({pose[j, 0]:7.1f}, {pose[j, 1]:7.1f})  z {pose[j, 2]:+.1f}{sure}")


def _say_depth(say: Say, skeleton: Skeleton, decisions) -> None:
    for front, back, sf, sb in decisions:
        name = lambda b: "-".join(skeleton.joints[k] for k in skeleton.bones[b])  # noqa: E731
        say(f"  depth: {name(front)} is drawn over {name(back)} (its outline across: {sf:.2f} vs {sb:.2f})")


def _copy(src: Path, dst: Path) -> None:
    """Copy an image into the shot; refuses to replace a different existing file."""
    if dst.exists():
        if dst.read_bytes() == src.read_bytes():
            return
        raise ShotError(dst, "IMAGE", "already exists in the shot directory and differs",
                        "start the shot in an empty directory")
    shutil.copyfile(src, dst)


def _write_new(dst: Path, image: np.ndarray) -> None:
    """Write a keyframe image the shot makes (a drawing on a grown canvas); refuses to replace an existing file."""
    if dst.exists():
        raise ShotError(dst, "IMAGE", "already exists in the shot directory", "start the shot in an empty directory")
    write_image(dst, image)


def new_from_images(shot_dir: str | Path, images: list[str | Path], skeleton: str = "humanoid",
                    key_frames: str | None = None, say: Say = print) -> Path:
    """`inbetween new SHOT_DIR IMAGE ...`: copy the drawings in as keyframes, place the template on each."""
    shot_dir = Path(shot_dir)
    _refuse_existing(shot_dir)
    if not images:
        raise ShotError(shot_dir, "IMAGE", "no drawing given", "give one image per keyframe, or --animated-drawings")
    template = load_template(skeleton)
    frames = parse_key_frames(key_frames, len(images))
    paths = [Path(p) for p in images]
    sk = Skeleton(template.joints, np.asarray(template.parents, np.int64))
    poses, size, warnings, reports = [], None, [], []
    for path in paths:
        img = _drawing(path)
        if size is None:
            size = img.shape[:2]
        elif img.shape[:2] != size:
            raise ShotError(path, "IMAGE", f"is {img.shape[1]}x{img.shape[0]}, keyframe 0 is {size[1]}x{size[0]}",
                            "give drawings of one size")
        sil = _silhouette(path, img)
        placed = place_template(sil.mask, template)
        order = depth_order(img, sil.mask, placed.positions, sk)
        poses.append(np.c_[placed.positions, order.z])
        reports.append((path, placed, order))
        warnings += [f"{path.name}: {w}" for w in sil.warnings + placed.warnings]
    # a limb's depth seen in one key holds in the keys where the drawing shows no overlap for it
    Z = np.stack([p[:, 2] for p in poses])
    for j in range(Z.shape[1]):
        seen = Z[:, j][Z[:, j] != 0]
        if len(seen):
            Z[Z[:, j] == 0, j] = seen[np.argmax(np.abs(seen))]
    for k in range(len(poses)):
        poses[k][:, 2] = Z[k]

    shot_dir.mkdir(parents=True, exist_ok=True)
    names = []
    for k, path in enumerate(paths):
        name = f"key{k}{path.suffix.lower()}"
        _copy(path, shot_dir / name)
        names.append(name)
    data = new_shot(names, frames, template.joints, template.parents, frames, np.stack(poses))
    write_json(shot_dir / "shot.json", data)
    for k, (path, placed, order) in enumerate(reports):
        say(f"{names[k]} (from {path.name}, key frame {frames[k]}): {template.name} placed, "
            f"mean sureness {placed.confidence.mean():.2f}")
        _say_pose(say, template.joints, poses[k], placed.confidence)
        _say_depth(say, sk, order.decisions)
    for w in warnings:
        say(f"warning: {w}")
    say(f"wrote {shot_dir / 'shot.json'} ({len(names)} key(s) at frames {', '.join(map(str, frames))})")
    say(f"next: inbetween edit {shot_dir}   (correct the joints; then inbetween motion or inbetween run)")
    return shot_dir / "shot.json"


def _bvh_clip(bvh_path: str | Path, retarget_path: str | Path | None, frames_spec: str | None,
              joints: tuple[str, ...], parents: np.ndarray, key_pose: np.ndarray) -> tuple[Clip, np.ndarray]:
    """(the clip retargeted onto the skeleton, the BVH frame indices it took)."""
    if retarget_path is None:
        raise ShotError(bvh_path, "--retarget", "a BVH clip needs a retarget config",
                        "give --retarget RETARGET.yaml (AnimatedDrawings' examples/config/retarget/*.yaml)")
    bvh = parse_bvh(bvh_path)
    config = read_retarget(retarget_path)
    idx = frame_slice(frames_spec, bvh.frames, bvh.frame_time)
    if len(idx) > MAX_FRAMES:
        raise ShotError(bvh_path, "--bvh-frames", f"selects {len(idx)} frames, more than {MAX_FRAMES}",
                        f"give a slice of at most {MAX_FRAMES} frames, e.g. --bvh-frames 0:{MAX_FRAMES}:1")
    return retarget(bvh, bvh_path, config, idx, joints, parents, key_pose), idx


def new_from_animated_drawings(shot_dir: str | Path, char_cfg: str | Path, bvh: str | Path | None = None,
                               retarget_cfg: str | Path | None = None, bvh_frames: str | None = None,
                               say: Say = print, keep_canvas: bool = False) -> Path:
    """`inbetween new SHOT_DIR --animated-drawings CHAR_CFG.yaml [--bvh ... --retarget ...]`: a one-drawing shot.

    With a clip, the canvas grows where the motion takes the character outside the texture (ops.motion.canvas):
    key0.png and key0_fg.png are then the drawing and its mask on the larger canvas, and the poses move with
    them. keep_canvas: the texture's own size, the frames cut where the character leaves it."""
    shot_dir = Path(shot_dir)
    _refuse_existing(shot_dir)
    ch = read_character(char_cfg)
    img = _drawing(ch.texture)
    if img.shape[:2] != ch.size:
        raise ShotError(char_cfg, "width/height", f"say {ch.size[1]}x{ch.size[0]}, texture.png is "
                        f"{img.shape[1]}x{img.shape[0]}", "give the texture's own size")
    parents = np.asarray(ch.parents, np.int64)
    sk = Skeleton(ch.joints, parents)
    if ch.mask is not None:
        mask = read_image(ch.mask, "mask.png")
        mask = (mask[..., 0] if mask.ndim == 3 else mask) > 0.5
        if mask.shape != ch.size or not mask.any():
            raise ShotError(ch.mask, "mask.png", "is empty or not the texture's size",
                            "give the character's mask (255 = character) at the texture's size")
    else:
        mask = _silhouette(ch.texture, img).mask
    key = np.c_[ch.pose, np.zeros(len(ch.joints))]
    warnings: list[str] = []
    if bvh is not None:
        clip, idx = _bvh_clip(bvh, retarget_cfg, bvh_frames, ch.joints, parents, key)
        key[:, 2] = clip.depth[0]  # the drawing has no depth of its own: the clip's first frame gives it
        poses = fit_clip(clip, parents, np.array([0]), key[None])
        warnings += clip.warnings
        decisions = []
    else:
        if retarget_cfg is not None or bvh_frames is not None:
            raise ShotError("--retarget", "--bvh", "--retarget and --bvh-frames need --bvh", "give --bvh CLIP.bvh")
        if keep_canvas:
            raise ShotError(char_cfg, "--keep-canvas", "keeps the canvas a clip would grow, and no --bvh is given",
                            "leave --keep-canvas out, or give --bvh CLIP.bvh --retarget RETARGET.yaml")
        order = depth_order(img, mask, ch.pose, sk)
        key[:, 2] = order.z
        poses, idx, decisions = key[None], np.array([0]), order.decisions

    pad = (0, 0, 0, 0)
    if bvh is not None and not keep_canvas:
        outline = outline_points(mask)
        pad = padding_for(carried_with_bones(outline, key, poses, sk), ch.size, rest=outline)
        poses = poses.copy()
        poses[:, :, 0] += pad[0]
        poses[:, :, 1] += pad[1]

    shot_dir.mkdir(parents=True, exist_ok=True)
    fg = ["key0_fg.png"] if ch.mask is not None else None
    if any(pad):  # the paper around the character: off its mask by a few pixels (the outline's soft rim)
        outside = ~ndimage.binary_dilation(mask, iterations=4)
        _write_new(shot_dir / "key0.png", pad_drawing(img, pad, outside))
        if fg:
            _write_new(shot_dir / "key0_fg.png", np.pad(mask, ((pad[1], pad[3]), (pad[0], pad[2]))).astype(np.float32))
    else:
        _copy(ch.texture, shot_dir / "key0.png")
        if fg:
            _copy(ch.mask, shot_dir / "key0_fg.png")
    data = new_shot(["key0.png"], [0], ch.joints, ch.parents, list(range(len(poses))), poses, foreground=fg)
    write_json(shot_dir / "shot.json", data)
    say(f"key0.png (from {ch.texture}): {len(ch.joints)} joints from {Path(char_cfg).name}"
        + (", mask.png as the manual foreground (masks.foreground[0])" if fg else ", no mask.png: predicted"))
    if any(pad):
        h, w = ch.size
        say(f"canvas: {w}x{h} -> {w + pad[0] + pad[2]}x{h + pad[1] + pad[3]} (left {pad[0]}, top {pad[1]}, right "
            f"{pad[2]}, bottom {pad[3]} px) so that the motion stays inside; the drawing sits at ({pad[0]}, {pad[1]}) "
            "in key0.png (--keep-canvas keeps the texture's size)")
    _say_pose(say, ch.joints, poses[0], None)
    _say_depth(say, sk, decisions)
    for w in warnings:
        say(f"warning: {w}")
    if bvh is not None:
        say(f"motion: {Path(bvh).name} frames {idx[0]}..{idx[-1]} step {idx[1] - idx[0] if len(idx) > 1 else 1} "
            f"-> {len(poses)} output frames, frame 0 = the drawing's own pose")
        say(f"wrote {shot_dir / 'shot.json'}")
        say(f"next: inbetween run {shot_dir} --out OUT   (or inbetween edit {shot_dir})")
    else:
        say(f"wrote {shot_dir / 'shot.json'} (one pose: the drawing; no motion yet)")
        say(f"next: inbetween motion {shot_dir} --bvh CLIP.bvh --retarget RETARGET.yaml   (or inbetween edit)")
    return shot_dir / "shot.json"


def _load_v2(shot_dir: Path) -> tuple[Path, dict, list[str], Skeleton]:
    from ops.shotio.load import parse_skeleton

    file, data = read_shot_json(shot_dir)
    v2, warnings = as_v2(data, file)
    sk = parse_skeleton(v2, file)
    return file, v2, warnings, sk


def _write_motion(shot_dir: Path, file: Path, v2: dict, key_frames: np.ndarray, poses: np.ndarray,
                  source: str, warnings: list[str], say: Say) -> Path:
    n = len(poses)
    if len(key_frames) > 1:
        last = int(key_frames[-1])
        if n < last + 1:
            raise ShotError(source, "frames", f"gives {n} frames, the shot's last key is at frame {last}",
                            f"give at least {last + 1} frames (a longer slice or a smaller step)")
        if n > last + 1:
            warnings.append(f"the clip's {n - last - 1} frames after the last key (frame {last}) are left out")
            poses = poses[: last + 1]
    drawn = {float(p["frame"]): p for p in v2["poses"]}
    # the key poses exactly as written (the fit meets them to ~1e-12 px; rounding must not move them either)
    v2["poses"] = [dict(drawn[float(f)]) if f in key_frames else pose_json(f, p) for f, p in enumerate(poses)]
    shutil.copyfile(file, file.with_name("shot.json.bak"))
    write_json(file, v2)
    for w in warnings:
        say(f"warning: {w}")
    say(f"wrote {len(poses)} poses to {file} (key poses kept at frames {', '.join(map(str, key_frames))}); "
        f"the previous shot.json is shot.json.bak")
    say(f"next: inbetween run {shot_dir} --out OUT   (or inbetween edit {shot_dir})")
    return file


def _off_canvas(shot_dir: Path, v2: dict, sk: Skeleton, key_frames: np.ndarray, keys: np.ndarray,
                poses: np.ndarray) -> list[str]:
    """A warning where the motion carries a key's drawing off its canvas: each frame's character is the nearest
    key's outline (its manual foreground, else its silhouette) carried with the bones (ops.motion.canvas)."""
    names = v2.get("keyframes") or []
    fgs = (v2.get("masks") or {}).get("foreground") or [None] * len(names)
    if len(key_frames) > 1:  # the frames after the last key are left out (_write_motion)
        poses = poses[: int(key_frames[-1]) + 1]
    worst, frames, size = 0.0, [], None
    for k, name in enumerate(names):
        img = read_image(shot_dir / name)
        size = img.shape[:2]
        if k < len(fgs) and fgs[k]:
            m = read_image(shot_dir / fgs[k], "masks.foreground")
            mask = (m[..., 0] if m.ndim == 3 else m) > 0.5
        else:
            try:
                mask = find_silhouette(img).mask
            except ValueError:
                continue
        mine = [f for f in range(len(poses)) if int(np.argmin(np.abs(key_frames - f))) == k]
        if not mine:
            continue
        reach = carried_with_bones(outline_points(mask), keys[k], poses[mine], sk)
        h, w = size
        out = np.maximum.reduce([-reach[..., 0], -reach[..., 1], reach[..., 0] - (w - 1), reach[..., 1] - (h - 1)])
        over = out.max(axis=1)  # per frame, px beyond the canvas
        frames += [f for f, o in zip(mine, over) if o > 0.5]
        worst = max(worst, float(over.max(initial=0.0)))
    if not frames:
        return []
    return [f"the motion takes the character up to {worst:.0f} px off the canvas at {len(frames)} frame(s) "
            f"({frames[0]}-{frames[-1]}), where the frames are cut; fix: pad the keyframes and their masks and move "
            "the poses by as much (inbetween new --animated-drawings --bvh does this itself)"]


def motion_from_bvh(shot_dir: str | Path, bvh: str | Path, retarget_cfg: str | Path | None,
                    bvh_frames: str | None = None, say: Say = print) -> Path:
    """`inbetween motion SHOT_DIR --bvh CLIP.bvh --retarget RETARGET.yaml`: the clip fitted to the key poses."""
    shot_dir = Path(shot_dir)
    file, v2, warnings, sk = _load_v2(shot_dir)
    kf, keys = key_poses(v2, file)
    clip, idx = _bvh_clip(bvh, retarget_cfg, bvh_frames, sk.joints, sk.parents, keys[0])
    poses = fit_clip(clip, sk.parents, kf, keys) if len(clip.root) > kf.max() else None
    if poses is None:
        raise ShotError(bvh, "--bvh-frames", f"selects {len(idx)} frames, the shot's last key is at frame {kf.max()}",
                        f"give at least {kf.max() + 1} frames")
    say(f"motion: {Path(bvh).name} frames {idx[0]}..{idx[-1]} ({len(idx)}), retargeted by {Path(retarget_cfg).name}")
    warnings += _off_canvas(file.parent, v2, sk, kf, keys, poses)
    return _write_motion(shot_dir, file, v2, kf, poses, str(bvh), warnings + clip.warnings, say)


def motion_from_video(shot_dir: str | Path, video: str | Path, points: str | Path, say: Say = print) -> Path:
    """`inbetween motion SHOT_DIR --video CLIP.mp4 --points POINTS.json`: tracked points drive the skeleton."""
    shot_dir = Path(shot_dir)
    file, v2, warnings, sk = _load_v2(shot_dir)
    kf, keys = key_poses(v2, file)
    frames, fps = read_video(video)
    pts = read_points(points, sk.joints, frames.shape[1:])
    if len(frames) <= kf.max():
        raise ShotError(video, "--video", f"has {len(frames)} frames, the shot's last key is at frame {kf.max()}",
                        f"give a video of at least {kf.max() + 1} frames")
    tracks = track(frames, pts, video)
    clip = tracks_to_clip(tracks, sk.joints, sk.parents, keys[0])
    poses = fit_clip(clip, sk.parents, kf, keys)
    say(f"motion: {len(pts)} points tracked through {len(frames)} frames of {Path(video).name}"
        + (f" ({fps:g} fps)" if fps else ""))
    warnings += _off_canvas(file.parent, v2, sk, kf, keys, poses)
    return _write_motion(shot_dir, file, v2, kf, poses, str(video), warnings + clip.warnings, say)

