"""Inpainting for flat-coloured (cartoon) art: each hole filled from its surroundings' own flat colours (§5.1).

OpenCV's Telea inpainting blends every colour around a hole, ink included, into a smear: where a pocket lies
under a covering arm, the ring around the hole is mostly the arm's dark outline, and the belly it uncovers
comes out dark olive. Flat art needs no blending. Per connected hole, the ring of drawing around it
(RING_PX wide, on the character, outside every hole) is split by its ink lines (ops.appearance.strokes) into
segments, each with one colour (its median). Where one colour per segment explains the ring
(FLAT_SHARE of its pixels within FLAT_DE of their segment's colour) and few strokes enter the hole, the
hole is flat: the strokes that enter it are paired and continued across it as curves, and the segments'
colours flood in (nearest segment by the path that crosses no continued stroke), so regions split by a line
stay split. Anything else (watercolour's granulation, pencil hatching, a photographed sheet's noise, many
loose stroke ends) is textured and keeps Telea. Ambiguities and what is done about them: an end with no
partner is not continued, and the two colours beside it meet inside the hole along the line of points
equally far from both (which continues a straight stroke roughly straight); when an end had two partners of
almost equal cost the cheaper is taken and the pair is marked ambiguous in the plan; hole pixels that no
segment reaches (cut off by crossing strokes) are left to Telea.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import cv2
import numpy as np
from scipy import ndimage
from skimage.segmentation import watershed

from ops.appearance.strokes import StrokeEnd, StrokePair, entering_strokes, ink_mask, lab, pair_ends, stroke_alpha

RING_PX = 8.0  # width of the ring of drawing around a hole whose colours and strokes decide how to fill it
STROKE_REACH_PX = 16.0  # a stroke's direction is read from this much of it outside the hole
MIN_SEGMENT_PX = 6  # ring segments smaller than this (crumbs between strokes) give no colour
FLAT_DE = 6.0  # CIE76: a ring pixel within this of its segment's colour is explained by flat colour
FLAT_SHARE = 0.8  # a hole is flat when flat colour explains this share of its ring's fill pixels
MAX_ENDS = 10  # more stroke ends than this around one hole: hatching or texture, not outlines
METHODS = ("auto", "flat")


@dataclass
class HolePlan:
    """What was found around one connected hole and how it is filled (coordinates in the whole image)."""

    pixels: np.ndarray  # (k, 2) int64 (y, x) of the hole's pixels
    box: tuple[int, int, int, int]  # (y0, y1, x0, x1) of the crop the hole was analysed in
    method: str  # "flat" | "telea"
    reason: str  # why, in words
    flat_share: float  # share of the ring's fill pixels explained by their segment's flat colour
    segments: int  # ring segments that give a colour
    ends: list[StrokeEnd] = field(default_factory=list)
    pairs: list[StrokePair] = field(default_factory=list)
    unpaired: list[int] = field(default_factory=list)


def _box(mask: np.ndarray, pad: int) -> tuple[int, int, int, int]:
    """(y0, y1, x0, x1) bounding box of a (H, W) bool mask grown by pad, clipped to the image."""
    ys, xs = np.nonzero(mask)
    h, w = mask.shape
    return max(0, ys.min() - pad), min(h, ys.max() + pad + 1), max(0, xs.min() - pad), min(w, xs.max() + pad + 1)


def _shift(end: StrokeEnd, y0: int, x0: int) -> StrokeEnd:
    """A stroke end moved from crop to image coordinates."""
    return StrokeEnd(end.point + (x0, y0), end.direction, end.width, end.colour, end.pixels + (y0, x0))


class HoleAnalysis:
    """Ring, segments, colours and stroke ends of one hole in its crop (the planes a fill needs)."""

    def __init__(self, image: np.ndarray, Lab: np.ndarray, ink: np.ndarray, solid: np.ndarray, holes: np.ndarray,
                 hole: np.ndarray):
        """Crops: image (h, w, 3) float32 RGB, Lab (h, w, 3), ink, solid (character), holes (all), hole (this one)."""
        self.image, self.hole = image, hole
        self.outside = ndimage.distance_transform_edt(~hole)
        self.ring = (self.outside > 0) & (self.outside <= RING_PX) & solid & ~holes
        ring_ink = ink & self.ring
        fill = self.ring & ~ndimage.binary_dilation(ink, iterations=1)
        seg, n = ndimage.label(fill)  # 4-connected: a diagonal line of ink parts two segments
        sizes = np.bincount(seg.ravel(), minlength=n + 1)
        big = np.nonzero(sizes >= MIN_SEGMENT_PX)[0]
        big = big[big > 0]
        self.segments = np.zeros_like(seg)
        self.colours = np.zeros((len(big) + 1, 3), np.float32)
        explained = 0
        for k, s in enumerate(big, start=1):
            px = seg == s
            self.segments[px] = k
            self.colours[k] = np.median(image[px], axis=0)
            centre = np.median(Lab[px], axis=0)
            explained += int((np.linalg.norm(Lab[px] - centre, axis=1) <= FLAT_DE).sum())
        self.n_segments = len(big)
        self.flat_share = explained / max(1, int(fill.sum()))
        self.ends = entering_strokes(image, ink & ~holes, hole, self.outside, STROKE_REACH_PX) if ring_ink.any() else []
        self.pairs, self.unpaired = pair_ends(self.ends, hole)

    def decide(self, mode: str) -> tuple[str, str]:
        """("flat" | "telea", why) for `mode` "flat" (flat wherever a segment gives a colour) or "auto"."""
        if mode == "auto" and self.flat_share < FLAT_SHARE:
            return "telea", f"textured: flat colour explains {self.flat_share:.0%} of the ring"
        if self.n_segments == 0:
            return "telea", "no segment of the ring gives a colour"
        if mode == "flat":
            return "flat", "flat fill requested"
        if len(self.ends) > MAX_ENDS:
            return "telea", f"{len(self.ends)} stroke ends run into the hole (hatching)"
        return "flat", (f"flat colour explains {self.flat_share:.0%} of the ring; {len(self.pairs)} stroke(s) "
                        f"continued, {len(self.unpaired)} end(s) left")

    def fill(self) -> tuple[np.ndarray, np.ndarray]:
        """((h, w, 3) float32 the crop with this hole flat-filled and its strokes continued, (h, w) bool hole pixels
        no segment reached)."""
        shape = self.hole.shape
        barrier = np.zeros(shape, bool)
        drawn = []
        for pair in self.pairs:
            a, b = self.ends[pair.a], self.ends[pair.b]
            width = 0.5 * (a.width + b.width)
            alpha = stroke_alpha(pair.curve, width, shape, self.hole)
            # a barrier at least one pixel wide across every diagonal, so that a 4-connected flood cannot cross it
            barrier |= stroke_alpha(pair.curve, max(width, 1.5), shape, self.hole) >= 0.5
            drawn.append((alpha, 0.5 * (a.colour + b.colour)))
        for end in self.ends:  # the visible stroke parts the segments on either side of it outside the hole too
            line = np.zeros(shape, bool)
            line[end.pixels[:, 0], end.pixels[:, 1]] = True
            barrier |= ndimage.binary_dilation(line, iterations=int(np.ceil(end.width / 2)) + 1) & ~self.hole
        markers = np.where(barrier, 0, self.segments)
        labels = watershed(np.zeros(shape, np.float32), markers, mask=(self.hole | self.ring) & ~barrier,
                           connectivity=1)
        out = self.image.copy()
        inside = self.hole & (labels > 0)
        out[inside] = self.colours[labels[inside]]
        # a barrier pixel takes its nearest labelled hole pixel's colour beneath the stroke drawn over it
        under = self.hole & ~inside
        if under.any() and inside.any():
            _, (iy, ix) = ndimage.distance_transform_edt(~inside, return_indices=True)
            near = under & barrier
            out[near] = out[iy[near], ix[near]]
            under &= ~barrier
        for alpha, colour in drawn:
            out = alpha[..., None] * colour + (1.0 - alpha[..., None]) * out
        return out.astype(np.float32), under


class FlatInpainter:
    """Inpainter for flat-coloured art: per connected hole a flat fill with continued strokes (mode "flat"), or
    that only where the hole's surroundings are flat and Telea elsewhere (mode "auto"). Pixels outside the
    holes stay exact."""

    def __init__(self, mode: str = "auto", radius: int = 5):
        if mode not in METHODS:
            raise ValueError(f"flat inpainter mode {mode!r}: use one of {METHODS}")
        if radius < 1:
            raise ValueError(f"inpainter radius {radius}: use a positive number of pixels")
        self.mode, self.radius = mode, int(radius)

    def plan(self, image: np.ndarray, hole: np.ndarray, coverage: np.ndarray | None = None
             ) -> tuple[list[HolePlan], list[tuple[HoleAnalysis, tuple[int, int, int, int], np.ndarray]]]:
        """Per connected hole of (H, W) bool `hole`: its plan, and its analysis with crop box and crop hole mask.

        image (H, W, 3) float32 RGB [0, 1]; coverage (H, W) float32 of the character in the image (pixels below
        one half are paper and give no colour); None: every pixel is character.
        """
        image = np.asarray(image, np.float32)
        holes = np.asarray(hole, bool)
        solid = np.ones(holes.shape, bool) if coverage is None else np.asarray(coverage) >= 0.5
        Lab = lab(image)
        ink = ink_mask(Lab[..., 0], solid & ~holes)
        labels, n = ndimage.label(holes, structure=np.ones((3, 3), bool))
        pad = int(np.ceil(STROKE_REACH_PX)) + 4
        plans, work = [], []
        for i in range(1, n + 1):
            one = labels == i
            y0, y1, x0, x1 = _box(one, pad)
            crop = (slice(y0, y1), slice(x0, x1))
            an = HoleAnalysis(image[crop], Lab[crop], ink[crop], solid[crop], holes[crop], one[crop])
            method, reason = an.decide(self.mode)
            pairs = [replace(p, curve=p.curve + (x0, y0)) for p in an.pairs]
            plans.append(HolePlan(np.argwhere(one), (y0, y1, x0, x1), method, reason, an.flat_share, an.n_segments,
                                  [_shift(e, y0, x0) for e in an.ends], pairs, list(an.unpaired)))
            work.append((an, (y0, y1, x0, x1), one[crop]))
        return plans, work

    def __call__(self, image: np.ndarray, hole: np.ndarray, coverage: np.ndarray | None = None) -> np.ndarray:
        """image (H, W, 3) float32 [0, 1], hole (H, W) bool, coverage (H, W) float32 or None -> (H, W, 3) float32."""
        return self.fill(image, hole, coverage)[0]

    def fill(self, image: np.ndarray, hole: np.ndarray, coverage: np.ndarray | None = None
             ) -> tuple[np.ndarray, list[HolePlan]]:
        """The filled image (H, W, 3) float32 and the plan of every hole (for previews and reports)."""
        out = np.array(image, dtype=np.float32, copy=True)
        holes = np.asarray(hole, bool)
        if not holes.any():
            return out, []
        plans, work = self.plan(out, holes, coverage)
        telea = np.zeros(holes.shape, bool)
        flat = out.copy()
        for plan, (an, (y0, y1, x0, x1), one) in zip(plans, work):
            if plan.method == "telea":
                telea[y0:y1, x0:x1] |= one
                continue
            filled, left = an.fill()
            crop = flat[y0:y1, x0:x1]
            crop[one] = filled[one]
            telea[y0:y1, x0:x1] |= left
        # one call for every textured hole (next to no flat hole, the same result as OpenCVInpainter's)
        if telea.any():
            img8 = np.round(np.clip(flat, 0.0, 1.0) * 255.0).astype(np.uint8)
            smooth = cv2.inpaint(img8, telea.astype(np.uint8), self.radius, cv2.INPAINT_TELEA)
            flat[telea] = smooth[telea].astype(np.float32) / 255.0
        out[holes] = flat[holes]
        return out, plans
