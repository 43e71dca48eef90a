"""3D bodies seen by an orthographic camera: where each ray enters and leaves a body (a depth buffer per body).

Coordinates are the camera's, in output pixels: x right, y down, z depth (larger = farther); a ray runs along
+z through every (x, y). Three kinds of body cover characters and props:
- a round cone ("limb"): the spheres swept from c0 (radius r0) to c1 (radius r1); a capsule when r0 = r1;
- an ellipsoid: a torso, a round belly, a head, a foot;
- a box: a book, a crate, a board.
A redrawn body (redraw.py) changes a solid's outline beyond its radii: a limb may bulge (its radius times
1 + bulge sin^2(pi s^g), largest at `peak` of its length) and bend (its axis sagging by `bend` (3,) at the
middle, a bean rather than an oval); an ellipsoid may be an egg (its half along its first axis longer by
1 + egg, the other half shorter by 1 - egg). All of them 0 (the default) is the plain solid, cast as before.
`cast` returns, on the pixel grid of a box of the image, the entry and exit depth of every ray (inf where
it misses), so a depth test decides per pixel which body is nearest and whether one lies behind another.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Solid:
    """One body: kind 'limb' | 'ellipsoid' | 'box'; centre (3,) px; for a limb c1 (3,) and radii (r0, r1);
    for an ellipsoid or box axes (3, 3) (rows = unit axes) and radii (3,) half-lengths along them.
    bone: index of the skeleton bone it belongs to; material: palette key; name: for the ground truth."""

    kind: str
    centre: np.ndarray
    radii: np.ndarray
    bone: int
    material: str = "body"
    name: str = ""
    c1: np.ndarray | None = None
    axes: np.ndarray | None = None
    patch: tuple | None = None  # ellipsoids: ((3,) unit direction in its own axes, cos of the cap's angle, material)
    bulge: float = 0.0  # limbs: relative radius added at `peak` (share of the length from c0); < 0 pinches
    peak: float = 0.5
    bend: np.ndarray | None = None  # limbs: (3,) px the axis sags by at its middle (None: straight)
    egg: float = 0.0  # ellipsoids: the half along +axes[0] is 1 + egg times as long, the other 1 - egg

    @property
    def profiled(self) -> bool:
        """True when the solid's outline is redrawn beyond its radii (bulge, bend or egg)."""
        return self.bulge != 0.0 or self.bend is not None or self.egg != 0.0

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """(2,) min and max (x, y) px of the body's silhouette (a bound, not tight)."""
        if self.kind == "limb" and self.profiled:
            c, r = limb_spheres(self, 33)
            pad = 0.05 * float(r.max())  # the spheres between samples move by far less
            return (c[:, :2] - r[:, None]).min(0) - pad, (c[:, :2] + r[:, None]).max(0) + pad
        if self.kind == "limb":
            r = float(max(self.radii))
            lo = np.minimum(self.centre[:2], self.c1[:2]) - r
            hi = np.maximum(self.centre[:2], self.c1[:2]) + r
            return lo, hi
        radii = np.asarray(self.radii)
        if self.egg:
            radii = radii * np.array([1 + abs(self.egg), 1.0, 1.0])  # the longer half bounds both
        half = np.abs(self.axes[:, :2] * radii[:, None]).sum(0)
        if self.kind == "ellipsoid":  # the silhouette's half-extent along x is sqrt(sum (a_k u_kx)^2)
            half = np.sqrt(((self.axes[:, :2] * radii[:, None]) ** 2).sum(0))
        return self.centre[:2] - half, self.centre[:2] + half


def limb(c0: np.ndarray, c1: np.ndarray, r0: float, r1: float, bone: int, material: str = "body",
         name: str = "") -> Solid:
    """A round cone from c0 (radius r0) to c1 (radius r1), (3,) px each."""
    return Solid("limb", np.asarray(c0, np.float64), np.array([r0, r1], np.float64), bone, material, name,
                 c1=np.asarray(c1, np.float64))


def ellipsoid(centre: np.ndarray, axes: np.ndarray, radii, bone: int, material: str = "body", name: str = "",
              kind: str = "ellipsoid", patch: tuple | None = None) -> Solid:
    """An ellipsoid (or, kind='box', a box) with (3, 3) unit axes as rows and (3,) half-lengths; patch: a cap of
    another material (a pale belly), see Solid."""
    ax = np.asarray(axes, np.float64)
    ax = ax / np.linalg.norm(ax, axis=1, keepdims=True)
    return Solid(kind, np.asarray(centre, np.float64), np.asarray(radii, np.float64), bone, material, name, axes=ax,
                 patch=patch)


def transformed(s: Solid, rot: np.ndarray, scale: float, shift: np.ndarray) -> Solid:
    """The solid after p -> scale * rot @ p + shift ((3, 3) rotation, (3,) shift)."""
    move = lambda p: None if p is None else scale * rot @ p + shift  # noqa: E731
    axes = None if s.axes is None else s.axes @ rot.T
    out = Solid(s.kind, move(s.centre), s.radii * scale, s.bone, s.material, s.name, move(s.c1), axes, s.patch)
    if s.profiled:  # a vector, not a point: turned and scaled, never shifted
        out = replace(out, bulge=s.bulge, peak=s.peak, egg=s.egg, bend=None if s.bend is None else scale * rot @ s.bend)
    return out


def bump(s: np.ndarray, peak: float) -> np.ndarray:
    """(n,) a smooth bump over s in [0, 1]: 0 with zero slope at both ends, 1 at s = peak (in (0, 1))."""
    g = math.log(0.5) / math.log(min(max(peak, 0.05), 0.95))
    return np.sin(math.pi * np.clip(s, 0.0, 1.0) ** g) ** 2


def limb_spheres(s: Solid, k: int) -> tuple[np.ndarray, np.ndarray]:
    """A limb as k spheres along its axis: centres (k, 3) and radii (k,), with its bulge and bend."""
    t = np.linspace(0.0, 1.0, k)
    c = s.centre + t[:, None] * (s.c1 - s.centre)
    if s.bend is not None:
        c = c + (4 * t * (1 - t))[:, None] * s.bend
    r = (s.radii[0] + t * (s.radii[1] - s.radii[0])) * (1 + s.bulge * bump(t, s.peak))
    return c, r


def frame_along(direction: np.ndarray, hint: np.ndarray | None = None) -> np.ndarray:
    """(3, 3) orthonormal rows whose first is `direction` (3,) (the second as near `hint` as it can be)."""
    d = np.asarray(direction, np.float64)
    d = d / max(np.linalg.norm(d), 1e-12)
    h = np.array([0.0, 0.0, 1.0]) if hint is None else np.asarray(hint, np.float64)
    if abs(h @ d) > 0.95 * np.linalg.norm(h):
        h = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b = h - d * (h @ d)
    b /= np.linalg.norm(b)
    return np.stack([d, b, np.cross(d, b)])


def grid(x0: float, y0: float, w: int, h: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Ray positions (h, w) x and y px: pixel (i, j) of the box is at (x0 + j * step, y0 + i * step)."""
    xs = x0 + step * np.arange(w)
    ys = y0 + step * np.arange(h)
    return np.meshgrid(xs, ys)


def cast(solid: Solid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit depth (px, inf where the ray misses) of rays along +z through (h, w) points x, y."""
    if solid.kind == "limb":
        return _cast_limb(solid, x, y)
    if solid.kind == "ellipsoid":
        return _cast_ellipsoid(solid, x, y)
    if solid.kind == "box":
        return _cast_box(solid, x, y)
    raise ValueError(f"unknown solid kind {solid.kind!r}")


def _cast_limb(s: Solid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The round cone as the union of spheres along its axis, a fifth of the smaller radius apart (the
    scallops between them are under 1% of a radius deep)."""
    if s.profiled:
        return _cast_profiled_limb(s, x, y)
    c0, c1 = s.centre, s.c1
    r0, r1 = s.radii
    length = float(np.linalg.norm(c1 - c0))
    k = int(np.clip(np.ceil(length / max(0.2 * min(r0, r1), 0.25)), 1, 400)) + 1
    entry = np.full(x.shape, np.inf)
    leave = np.full(x.shape, -np.inf)
    for t in np.linspace(0.0, 1.0, k):
        c = c0 + t * (c1 - c0)
        r = r0 + t * (r1 - r0)
        d2 = (x - c[0]) ** 2 + (y - c[1]) ** 2
        inside = d2 < r * r
        if not inside.any():
            continue
        half = np.sqrt(np.maximum(r * r - d2, 0.0))
        entry = np.where(inside, np.minimum(entry, c[2] - half), entry)
        leave = np.where(inside, np.maximum(leave, c[2] + half), leave)
    leave[~np.isfinite(entry)] = np.inf
    return entry, leave


def _cast_profiled_limb(s: Solid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A bulging or bent limb: the same union of spheres along its curved axis, a fifth of the smallest
    radius apart along its arc."""
    c, r = limb_spheres(s, 65)
    arc = float(np.linalg.norm(np.diff(c, axis=0), axis=1).sum())
    k = int(np.clip(np.ceil(arc / max(0.2 * float(r.min()), 0.25)), 1, 400)) + 1
    c, r = limb_spheres(s, k)
    entry = np.full(x.shape, np.inf)
    leave = np.full(x.shape, -np.inf)
    for ci, ri in zip(c, r):
        d2 = (x - ci[0]) ** 2 + (y - ci[1]) ** 2
        inside = d2 < ri * ri
        if not inside.any():
            continue
        half = np.sqrt(np.maximum(ri * ri - d2, 0.0))
        entry = np.where(inside, np.minimum(entry, ci[2] - half), entry)
        leave = np.where(inside, np.maximum(leave, ci[2] + half), leave)
    leave[~np.isfinite(entry)] = np.inf
    return entry, leave


def _cast_ellipsoid(s: Solid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|D^-1 A (p - c)| = 1 along p = (x, y, z): a quadratic in z. An egg: two half-ellipsoids, each ray's
    interval clipped to its half-space, joined."""
    if s.egg:
        return _cast_egg(s, x, y)
    m = s.axes / np.asarray(s.radii)[:, None]  # (3, 3): local, radius-normalized coordinates of a vector
    v = m[:, 2]  # of the ray direction (0, 0, 1)
    q0 = m[:, 0][:, None, None] * (x - s.centre[0]) + m[:, 1][:, None, None] * (y - s.centre[1]) \
        - v[:, None, None] * s.centre[2]
    a = float(v @ v)
    b = 2 * np.einsum("k,kij->ij", v, q0)
    c = (q0 ** 2).sum(0) - 1.0
    disc = b * b - 4 * a * c
    hit = disc > 0
    root = np.sqrt(np.where(hit, disc, 0.0))
    entry = np.where(hit, (-b - root) / (2 * a), np.inf)
    leave = np.where(hit, (-b + root) / (2 * a), np.inf)
    return entry, leave


def _cast_egg(s: Solid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The egg: on the ray, along axes[0] u(z) = u0 + a0 z; half +1 keeps u >= 0 of the ellipsoid whose first
    radius is r0 (1 + egg), half -1 keeps u <= 0 of the one with r0 (1 - egg)."""
    a0 = float(s.axes[0, 2])
    u0 = s.axes[0, 0] * (x - s.centre[0]) + s.axes[0, 1] * (y - s.centre[1]) - a0 * s.centre[2]
    entry = np.full(x.shape, np.inf)
    leave = np.full(x.shape, -np.inf)
    for side in (1.0, -1.0):
        half = replace(s, egg=0.0, radii=np.asarray(s.radii) * np.array([1 + side * s.egg, 1.0, 1.0]))
        en, ex = _cast_ellipsoid(half, x, y)
        hit = np.isfinite(en)
        if abs(a0) < 1e-12:  # the ray runs across the axis: the whole interval lies on one side
            lo, hi = np.where(side * u0 >= 0, -np.inf, np.inf), np.full(x.shape, np.inf)
        else:
            z0 = -u0 / a0  # where the ray crosses the dividing plane; side * u >= 0 beyond it or before it
            lo, hi = (z0, np.full(x.shape, np.inf)) if side * a0 > 0 else (np.full(x.shape, -np.inf), z0)
        en2, ex2 = np.maximum(en, lo), np.minimum(ex, hi)
        ok = hit & (en2 <= ex2)
        entry = np.where(ok, np.minimum(entry, en2), entry)
        leave = np.where(ok, np.maximum(leave, ex2), leave)
    leave[~np.isfinite(entry)] = np.inf
    return entry, leave


def _cast_box(s: Solid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Slab test in the box's own axes."""
    rel = np.stack([x - s.centre[0], y - s.centre[1], np.full(x.shape, -s.centre[2])])  # ray origin at z = 0
    o = np.einsum("kc,cij->kij", s.axes, rel)
    d = s.axes[:, 2]
    lo = np.full(x.shape, -np.inf)
    hi = np.full(x.shape, np.inf)
    for k in range(3):
        h = s.radii[k]
        if abs(d[k]) < 1e-12:
            out = np.abs(o[k]) > h
            lo = np.where(out, np.inf, lo)
            continue
        t1, t2 = (-h - o[k]) / d[k], (h - o[k]) / d[k]
        lo = np.maximum(lo, np.minimum(t1, t2))
        hi = np.minimum(hi, np.maximum(t1, t2))
    hit = lo < hi
    return np.where(hit, lo, np.inf), np.where(hit, hi, np.inf)
