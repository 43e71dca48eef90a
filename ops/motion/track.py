"""Points tracked through a video and mapped onto a shot's skeleton (Live Sketch's motion source).

Each point given on the first frame is followed by pyramidal Lucas-Kanade (cv2.calcOpticalFlowPyrLK) from
frame to frame, and checked by tracking it back (forward-backward error, Kalal et al. 2010): a point that
comes back further than FB_MAX_PX from where it started, or that the flow loses, is an error naming the
point and the frame. Video is decoded by the ffmpeg binary that imageio-ffmpeg ships.

The tracks drive the skeleton through its key pose: the first frame's points are mapped onto the key pose's
joints by one similarity (video pixels to drawing pixels); then every chain of bones (a run of joints
between forks) follows the similarity that carries its tracked points (its own joints and its fork) from
the first frame to the current one: its bones turn by its rotation and stretch by its scale. A chain with
fewer than two tracked points rides its parent chain; the root follows its own point, else all points.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ops.errors import ShotError
from ops.motion.clip import Clip

FB_MAX_PX = 1.5  # forward-backward error that counts a track as lost
WINDOW = (21, 21)
LEVELS = 3
MAX_VIDEO_FRAMES = 1000  # the shot format's bound on output frames


def read_video(path: str | Path, max_frames: int = MAX_VIDEO_FRAMES) -> tuple[np.ndarray, float]:
    """((F, H, W) uint8 grey frames, frames per second); ShotError when it cannot be decoded."""
    import imageio_ffmpeg

    file = Path(path)
    if not file.is_file():
        raise ShotError(file, "--video", "file not found", "give the path of a video file")
    fix = "give a video ffmpeg can decode (MP4/H.264, MOV, AVI, WebM)"
    try:
        reader = imageio_ffmpeg.read_frames(str(file), pix_fmt="gray", bpp=1)
        meta = next(reader)
        w, h = meta["size"]
        frames = []
        for raw in reader:
            frames.append(np.frombuffer(raw, np.uint8).reshape(h, w))
            if len(frames) > max_frames:
                reader.close()
                raise ShotError(file, "--video", f"has more than {max_frames} frames",
                                f"cut the clip to at most {max_frames} frames (one output frame each)")
    except ShotError:
        raise
    except (OSError, RuntimeError, StopIteration, KeyError, ValueError) as e:
        why = " ".join(str(e).split())[:160] or type(e).__name__
        raise ShotError(file, "--video", f"cannot be decoded ({why})", fix) from None
    if not frames:
        raise ShotError(file, "--video", "holds no frame", fix)
    fps = float(meta.get("fps") or 0.0)
    return np.stack(frames), fps


def read_points(path: str | Path, joints: tuple[str, ...], size: tuple[int, int]) -> dict[str, np.ndarray]:
    """{joint: (2,) x y} of POINTS.json, checked: known joints, inside the (H, W) first frame."""
    import json

    file = Path(path)
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ShotError(file, "--points", f"cannot be read as JSON ({type(e).__name__})",
                        'write {"joint name": [x, y], ...} in the video\'s first frame') from None
    if not isinstance(data, dict) or not data:
        raise ShotError(file, "--points", "is not a non-empty object", 'write {"joint name": [x, y], ...}')
    h, w = size
    out = {}
    for name, xy in data.items():
        if name not in joints:
            raise ShotError(file, name, "is not a joint of the shot's skeleton",
                            f"use the skeleton's joint names ({', '.join(joints[:8])}, ...)")
        if (not isinstance(xy, (list, tuple)) or len(xy) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xy)):
            raise ShotError(file, name, f"{xy!r} is not [x, y]", "give the point's pixel position [x, y]")
        if not (0 <= xy[0] <= w - 1 and 0 <= xy[1] <= h - 1):
            raise ShotError(file, name, f"point {list(xy)} lies outside the video's {w}x{h} frame",
                            f"give x in 0..{w - 1} and y in 0..{h - 1} (pixels of the first frame)")
        out[name] = np.asarray(xy, np.float64)
    return out


def track(frames: np.ndarray, points: dict[str, np.ndarray], video: str | Path = "--video") -> dict[str, np.ndarray]:
    """{name: (F, 2) float64 x y per frame} of points tracked through (F, H, W) uint8 frames."""
    names = list(points)
    p = np.array([points[n] for n in names], np.float32).reshape(-1, 1, 2)
    out = np.zeros((len(frames), len(names), 2))
    out[0] = p[:, 0]
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)
    for f in range(1, len(frames)):
        nxt, st, _ = cv2.calcOpticalFlowPyrLK(frames[f - 1], frames[f], p, None, winSize=WINDOW, maxLevel=LEVELS,
                                             criteria=criteria)
        back, st_b, _ = cv2.calcOpticalFlowPyrLK(frames[f], frames[f - 1], nxt, None, winSize=WINDOW,
                                                maxLevel=LEVELS, criteria=criteria)
        fb = np.linalg.norm((back - p).reshape(-1, 2), axis=1)
        lost = (st.ravel() == 0) | (st_b.ravel() == 0) | ~(fb <= FB_MAX_PX)
        if lost.any():
            i = int(np.argmax(lost))
            why = "the flow found no match" if st.ravel()[i] == 0 or st_b.ravel()[i] == 0 else \
                f"forward-backward error {fb[i]:.1f} px > {FB_MAX_PX}"
            raise ShotError(video, f"points.{names[i]}", f"track lost at frame {f} ({why})",
                            f"put the point on a spot with texture that stays in view, or cut the video before frame {f}")
        p = nxt
        out[f] = p[:, 0]
    return {n: out[:, i] for i, n in enumerate(names)}


def similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, float, np.ndarray]:
    """(rotation radians, scale, translation (2,)) least-squares similarity src -> dst of (n, 2) points (Umeyama);
    one point: translation only."""
    if len(src) == 1:
        return 0.0, 1.0, dst[0] - src[0]
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    # 2D: the optimal rotation angle from the summed cross and dot products
    dot = float((a * b).sum())
    cross = float((a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum())
    theta = float(np.arctan2(cross, dot))
    var = float((a * a).sum())
    scale = float(np.hypot(dot, cross) / var) if var > 1e-12 else 1.0
    c, s = np.cos(theta), np.sin(theta)
    t = md - scale * (np.array([[c, -s], [s, c]]) @ ms)
    return theta, scale, t


def chains(parents: np.ndarray) -> list[list[int]]:
    """Runs of joints between forks: each [start (the root or a fork), j1, ..., end (a leaf or a fork)]."""
    kids = [[] for _ in parents]
    for j, p in enumerate(parents):
        if p >= 0:
            kids[int(p)].append(j)
    root = int(np.nonzero(np.asarray(parents) < 0)[0][0])
    out, starts = [], [root]
    while starts:
        s = starts.pop()
        for c in kids[s]:
            run = [s, c]
            while len(kids[run[-1]]) == 1:
                run.append(kids[run[-1]][0])
            out.append(run)
            if kids[run[-1]]:
                starts.append(run[-1])
    return out


def tracks_to_clip(tracks: dict[str, np.ndarray], joints: tuple[str, ...], parents: np.ndarray,
                   key_pose: np.ndarray) -> Clip:
    """A Clip on the skeleton from tracked points ({joint: (F, 2)}, video pixels), through the (J, 2+) key pose."""
    parents = np.asarray(parents, np.int64)
    key = np.asarray(key_pose, np.float64)[:, :2]
    names = [n for n in tracks if n in joints]
    idx = [joints.index(n) for n in names]
    T = np.stack([tracks[n] for n in names], 1)  # (F, n, 2)
    F = T.shape[0]
    rot, sc, tr = similarity(T[0], key[idx])  # video -> drawing
    c, s = np.cos(rot), np.sin(rot)
    M = sc * np.array([[c, -s], [s, c]])
    T = T @ M.T + tr
    angles: dict[int, np.ndarray] = {}
    scales: dict[int, np.ndarray] = {}
    warnings = []
    for run in chains(parents):
        have = [k for k, j in enumerate(idx) if j in run]
        if len(have) < 2:
            continue
        motion = [similarity(T[0, have], T[f, have]) for f in range(F)]
        turn = np.unwrap(np.array([m[0] for m in motion]))
        grow = np.array([m[1] for m in motion])
        for j in run[1:]:
            d = key[j] - key[parents[j]]
            angles[j] = np.arctan2(d[1], d[0]) + turn
            scales[j] = grow
    root = int(np.nonzero(parents < 0)[0][0])
    if root in idx:
        root_xy = T[:, idx.index(root)]
    else:
        root_xy = np.zeros((F, 2))
        for f in range(F):
            r, k, t = similarity(T[0], T[f])
            cr, sr = np.cos(r), np.sin(r)
            root_xy[f] = k * np.array([[cr, -sr], [sr, cr]]) @ key[root] + t
    if not angles:
        warnings.append("no chain of bones holds two tracked points: only the root moves")
    return Clip(root=root_xy, angles=angles, scales=scales, depth=None, warnings=warnings)
