"""Preview of the pocket inpainting: each hole tinted by the method chosen for it, the strokes found and
continued, Telea's fill and the chosen fill side by side, so a smear or a broken outline shows at a glance."""
from __future__ import annotations

import cv2
import numpy as np

from ops.appearance.flat_fill import HolePlan

METHOD_TINT = {"flat": (0.1, 0.8, 0.2), "telea": (0.15, 0.35, 1.0)}  # green: flat fill; blue: Telea
END_COLOUR = (255, 25, 25)  # red: a stroke end on a hole's boundary, with its direction
CURVE_COLOUR = (255, 215, 0)  # yellow: a stroke continued across a hole
AMBIGUOUS_COLOUR = (255, 0, 255)  # magenta: a continuation chosen over an almost equal one
MARGIN_PX = 12


def _crop_box(hole: np.ndarray, margin: int = MARGIN_PX) -> tuple[int, int, int, int]:
    """(y0, y1, x0, x1) around every hole pixel of a (H, W) bool mask (the whole image when it is empty)."""
    h, w = hole.shape
    if not hole.any():
        return 0, h, 0, w
    ys, xs = np.nonzero(hole)
    return max(0, ys.min() - margin), min(h, ys.max() + margin + 1), max(0, xs.min() - margin), min(w, xs.max() + margin + 1)


def inpaint_preview(context: np.ndarray, hole: np.ndarray, plans: list[HolePlan], chosen: np.ndarray,
                    telea: np.ndarray, truth: np.ndarray | None = None, scale: int = 3) -> np.ndarray:
    """(h, 3 w, 3) float32 RGB panels around the holes, enlarged `scale` times: the context with each hole
    tinted by its method and the stroke ends (red), continuations (yellow; magenta when ambiguous) |
    Telea's fill | the chosen fill [| the truth, when known].

    context, chosen, telea, truth: (H, W, 3) float32 RGB [0, 1]; hole: (H, W) bool; plans: one per connected hole.
    """
    y0, y1, x0, x1 = _crop_box(hole)
    marks = np.clip(np.asarray(context, np.float32), 0, 1).copy()
    for plan in plans:
        ys, xs = plan.pixels[:, 0], plan.pixels[:, 1]
        marks[ys, xs] = 0.45 * marks[ys, xs] + 0.55 * np.asarray(METHOD_TINT[plan.method], np.float32)
    panels = [marks, np.clip(telea, 0, 1), np.clip(chosen, 0, 1)] + ([] if truth is None else [np.clip(truth, 0, 1)])
    big = [cv2.resize(np.round(p[y0:y1, x0:x1] * 255).astype(np.uint8), None, fx=scale, fy=scale,
                      interpolation=cv2.INTER_NEAREST) for p in panels]  # cv2 draws text on 8 bits only

    def at(xy: np.ndarray) -> tuple[int, int]:  # image pixel centre -> enlarged crop pixel
        return int(round((xy[0] - x0 + 0.5) * scale - 0.5)), int(round((xy[1] - y0 + 0.5) * scale - 0.5))

    for plan in plans:
        for pair in plan.pairs:
            pts = np.array([at(p) for p in pair.curve], np.int32).reshape(-1, 1, 2)
            cv2.polylines(big[0], [pts], False, AMBIGUOUS_COLOUR if pair.ambiguous else CURVE_COLOUR, 1, cv2.LINE_AA)
        for end in plan.ends:
            tail = end.point - 3.0 * max(end.width, 2.0) * end.direction
            cv2.line(big[0], at(tail), at(end.point), END_COLOUR, 1, cv2.LINE_AA)
            cv2.circle(big[0], at(end.point), 2, END_COLOUR, -1, cv2.LINE_AA)
    for img, label in zip(big, ("holes: green flat, blue Telea", "Telea", "chosen", "truth")):
        cv2.putText(img, label, (3, 11), cv2.FONT_HERSHEY_PLAIN, 0.8, (200, 25, 25), 1, cv2.LINE_AA)
    sep = np.full((big[0].shape[0], 4, 3), 255, np.uint8)
    row = [big[0]]
    for img in big[1:]:
        row += [sep, img]
    return np.concatenate(row, axis=1).astype(np.float32) / 255.0
