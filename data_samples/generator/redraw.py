"""Redrawn keys: a body's part shapes and shaky hand drawn anew at each key, the in-betweens between the two.

An artist redraws a character at every key: a thigh is a bean in one drawing and an oval in the next, the outline
wobbles differently, proportions drift. Per solid and per key, `draw_redraw` draws a change of its shape
beyond what the skeleton explains:
- aspect: its thickness against its length (a limb's radii; an ellipsoid's or box's first radius against the
  others), key1 against key0 by exp(+-ASPECT (0.5 .. 1) amount) (so 10-22 % at amount 1), half of it each way;
- outline (per key, independently): a limb's taper (r1 / r0), bulge and its place along the limb, and bend (its
  axis sagging sideways: a bean); an ellipsoid's egg (one half longer than the other: a belly that sags);
and the shaky hand: the look's wobble field at key0, an independent one at key1 (at amount 1), a larger
amplitude (REWOBBLE_PX at amount 1). At time t every parameter is interpolated linearly between the keys' (the
wobble's angle too), so the frames between are the true in-betweens of a redrawn character. Amount 0 changes
nothing: every solid is returned as it was and the look's own wobble is kept (today's rigid shots).

The change is made on the body at rest, before posing (shots3d.posed), so it rides on the bones with the solids;
marks on a changed solid are carried along with its surface.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .bodies3d import Body, Mark
from .render3d import Rewobble, smooth_noise
from .solids import Solid, bump, frame_along

ASPECT = 0.2  # log of the largest aspect change between the keys at amount 1
TAPER = 0.15  # log of r1 / r0's change at a key, at most
BULGE = (-0.2, 0.3)  # relative radius added at the bulge's peak, at a key
BEND = 0.12  # the axis' sag at a key, at most, as a share of the limb's length
EGG = 0.2  # an ellipsoid's half longer (shorter) by up to this share, at a key
REWOBBLE_PX = 1.5  # added to the look's wobble amplitude at amount 1, px at 256 px


@dataclass(frozen=True)
class Change:
    """One solid's change at one key: log_aspect (thickness against length, log), log_taper (r1 / r0, log),
    bulge and peak (limbs), bend (2,) (limbs: the sag at the middle in units of the length, along the two axes
    perpendicular to the limb, frame_along), egg (ellipsoids)."""

    log_aspect: float = 0.0
    log_taper: float = 0.0
    bulge: float = 0.0
    peak: float = 0.5
    bend: tuple[float, float] = (0.0, 0.0)
    egg: float = 0.0

    def nil(self) -> bool:
        """True when this changes nothing."""
        return (self.log_aspect == 0.0 and self.log_taper == 0.0 and self.bulge == 0.0 and self.bend == (0.0, 0.0)
                and self.egg == 0.0)


@dataclass(frozen=True)
class Redraw:
    """A redrawn character: amount; per key (0, 1) one Change per solid of the body it was drawn for; the
    wobble's amplitude (px) and the other field (gx, gy: (H, W) float32) that key1 turns toward."""

    amount: float
    keys: tuple[tuple[Change, ...], tuple[Change, ...]]
    wobble_px: float
    gx: np.ndarray
    gy: np.ndarray

    def at(self, t: float) -> tuple[Change, ...]:
        """Every solid's change at time t in [0, 1]: each parameter linear between the keys'."""
        return tuple(_lerp(a, b, t) for a, b in zip(*self.keys))

    def rewobble(self, t: float) -> Rewobble | None:
        """The shaky hand at time t (None at amount 0: the look's own)."""
        if self.amount == 0:
            return None
        return Rewobble(self.wobble_px, min(self.amount, 1.0) * t * math.pi / 2, self.gx, self.gy)


def _lerp(a: Change, b: Change, t: float) -> Change:
    """The change at t between a (t = 0) and b (t = 1)."""
    f = lambda x, y: (1 - t) * x + t * y  # noqa: E731
    return Change(f(a.log_aspect, b.log_aspect), f(a.log_taper, b.log_taper), f(a.bulge, b.bulge), f(a.peak, b.peak),
                  (f(a.bend[0], b.bend[0]), f(a.bend[1], b.bend[1])), f(a.egg, b.egg))


def draw_redraw(rng: np.random.Generator, solids: list[Solid], amount: float, size: tuple[int, int],
                wobble_px: float) -> Redraw:
    """Random changes of every solid at both keys, scaled by `amount` (0: none); the other wobble field at the
    (H, W) size; wobble_px: the look's wobble amplitude (px), to which REWOBBLE_PX * amount * size / 256 is added.
    The draws do not depend on amount, so two amounts of one rng change the same solids the same way."""
    keys: tuple[list[Change], list[Change]] = ([], [])
    a = float(amount)
    for s in solids:
        turn = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0) * ASPECT
        for k, sign in ((0, -0.5), (1, 0.5)):
            taper, bulge, peak = rng.uniform(-TAPER, TAPER), rng.uniform(*BULGE), rng.uniform(0.35, 0.65)
            sag, angle, egg = rng.uniform(0, BEND), rng.uniform(0, 2 * math.pi), rng.uniform(-EGG, EGG)
            if s.kind == "limb":
                ch = Change(a * sign * turn, a * taper, a * bulge, peak,
                            (a * sag * math.cos(angle), a * sag * math.sin(angle)))
            else:
                ch = Change(a * sign * turn, egg=a * egg if s.kind == "ellipsoid" else 0.0)
            keys[k].append(ch if a else Change())
    gx, gy = smooth_noise(rng, size, 14.0), smooth_noise(rng, size, 14.0)
    return Redraw(a, (tuple(keys[0]), tuple(keys[1])), wobble_px + REWOBBLE_PX * a * max(size) / 256.0, gx, gy)


def changed_solid(s: Solid, ch: Change) -> Solid:
    """The solid with its change (the same object when the change is nil)."""
    if ch.nil():
        return s
    if s.kind == "limb":
        length = float(np.linalg.norm(s.c1 - s.centre))
        f = frame_along(s.c1 - s.centre)
        r0, r1 = s.radii * math.exp(ch.log_aspect) * np.array([math.exp(-ch.log_taper), math.exp(ch.log_taper)])
        bend = length * (ch.bend[0] * f[1] + ch.bend[1] * f[2])
        return replace(s, radii=np.array([r0, r1]), bulge=ch.bulge, peak=ch.peak, bend=bend)
    half = 0.5 * ch.log_aspect  # longer along the first axis, thinner across it: the volume about kept
    radii = s.radii * np.exp(np.array([half, -half, -half]))
    return replace(s, radii=radii, egg=ch.egg if s.kind == "ellipsoid" else 0.0)


def carried(p: np.ndarray, before: Solid, after: Solid) -> np.ndarray:
    """(n, 3) points on `before`'s surface moved onto `after`'s (the same solid changed): along an ellipsoid's
    axes by its radii's ratios, away from a limb's axis by the ratio of its radii there, with its bend."""
    p = np.asarray(p, np.float64)
    if before is after:
        return p
    if before.kind == "limb":
        d = before.c1 - before.centre
        t = np.clip((p - before.centre) @ d / max(float(d @ d), 1e-12), 0.0, 1.0)
        on_axis = before.centre + t[:, None] * d
        r_before = before.radii[0] + t * (before.radii[1] - before.radii[0])
        r_after = (after.radii[0] + t * (after.radii[1] - after.radii[0])) * (1 + after.bulge * bump(t, after.peak))
        out = on_axis + (p - on_axis) * (r_after / np.maximum(r_before, 1e-9))[:, None]
        if after.bend is not None:
            out = out + (4 * t * (1 - t))[:, None] * after.bend
        return out
    q = (p - before.centre) @ before.axes.T
    q = q * (after.radii / before.radii)
    if after.egg:
        q[:, 0] *= np.where(q[:, 0] >= 0, 1 + after.egg, 1 - after.egg)
    return after.centre + q @ after.axes


def redrawn_body(body: Body, changes: tuple[Change, ...]) -> Body:
    """The body (at rest, before posing) with one change per solid; marks ride on their solid's surface."""
    if len(changes) != len(body.solids):
        raise ValueError(f"redrawn_body: {len(changes)} changes for {len(body.solids)} solids")
    solids = [changed_solid(s, ch) for s, ch in zip(body.solids, changes)]
    marks = [Mark(m.kind, carried(m.points, body.solids[m.solid], solids[m.solid]), m.width, m.solid)
             for m in body.marks]
    return replace(body, solids=solids, marks=marks)
