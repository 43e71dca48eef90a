"""Randomized drawing styles for the 3D occlusion generator: line weight and breaks, fills, paper, palettes.

A style family fixes the kind of drawing; everything else is drawn at random per sample:
- ink: black outlines of any weight on white or off-white paper, the inside left as paper (or a pale fill);
- colour_lines: outlines in one colour (felt tip, marker), usually no fill, sometimes photographed;
- flat: flat colour fills with a darker outline (a shade of each part's colour, or one dark colour);
- no_outline: flat fills and no line at all, sometimes cel or soft shading;
- watercolour: transparent washes pooling at their edges, soft and wobbly, sometimes over faint pencil;
- pencil: grey graphite lines whose pressure varies, broken by the tooth of grey sketch paper;
- crayon (held out of training): thick waxy lines broken by the paper's tooth, waxy streaky fills,
  wobbly hands, often photographed.
Lines may break (gaps along a stroke), may or may not be drawn where two parts of one body meet (a crease at
an elbow) or where two materials meet (a sleeve's cuff), and texture marks (stripes, buttons, eyes) may be
left out.
"""
from __future__ import annotations

import colorsys
from dataclasses import dataclass

import numpy as np

STYLE_FAMILIES = ("ink", "colour_lines", "flat", "no_outline", "watercolour", "pencil", "crayon")
MATERIALS = ("top", "trousers", "skin", "hair", "skirt", "boots", "prop", "body", "belly", "hoof", "beak", "feet")


@dataclass(frozen=True)
class Look3D:
    """How one sample is drawn.

    fill: 'paper' | 'flat' | 'wash' | 'wax'; line: 'none' | 'fixed' (one colour, line_rgb) | 'shade' (a
    darker shade of each part) | 'graphite' | 'crayon' (a waxy line of line_rgb, broken by the paper's tooth);
    line_width: px; width_var: relative amplitude of its variation; breaks: share of a line left out;
    crease / material_lines: lines where two parts of one body meet, where two materials meet; marks: texture
    strokes; shading: 'none' | 'cel' | 'soft'; paper: a generator.paper kind; photo: photographed afterwards;
    blur: px (soft edges); wobble: px (a shaky hand: the whole drawing displaced smoothly);
    palette: material -> (3,) float reflectance in [0, 1].
    """

    family: str
    fill: str
    line: str
    line_rgb: tuple[float, float, float]
    line_width: float
    width_var: float
    breaks: float
    crease: bool
    material_lines: bool
    marks: bool
    shading: str
    paper: str
    photo: bool
    blur: float
    wobble: float
    palette: dict


def _hsv(h: float, s: float, v: float) -> tuple[float, float, float]:
    return colorsys.hsv_to_rgb(h % 1.0, float(np.clip(s, 0, 1)), float(np.clip(v, 0, 1)))


def random_palette(rng: np.random.Generator, mono: bool = False) -> dict:
    """Material -> (3,) reflectance: skin tones, clothes of any hue, animals' coats; mono = one colour for all."""
    if mono:
        c = _hsv(rng.random(), rng.uniform(0.2, 0.8), rng.uniform(0.5, 0.95))
        return {m: c for m in MATERIALS}
    skin = _hsv(rng.uniform(0.03, 0.1), rng.uniform(0.15, 0.55), rng.uniform(0.45, 0.98))
    coat = [_hsv(0.95, 0.35, 0.95), _hsv(0.07, 0.6, 0.6), _hsv(0.0, 0.0, 0.6), _hsv(0.08, 0.75, 0.9),
            _hsv(0.3, 0.55, 0.7), _hsv(0.1, 0.4, 0.85), _hsv(rng.random(), 0.6, 0.8)][int(rng.integers(7))]
    pal = {"skin": skin, "top": _hsv(rng.random(), rng.uniform(0.3, 0.9), rng.uniform(0.4, 0.95)),
           "trousers": _hsv(rng.random(), rng.uniform(0.2, 0.8), rng.uniform(0.15, 0.7)),
           "hair": _hsv(rng.uniform(0.02, 0.14), rng.uniform(0.3, 0.9), rng.uniform(0.1, 0.9)),
           "skirt": _hsv(rng.random(), rng.uniform(0.3, 0.9), rng.uniform(0.5, 0.95)),
           "boots": _hsv(rng.random(), rng.uniform(0.0, 0.7), rng.uniform(0.1, 1.0)),
           "prop": _hsv(rng.random(), rng.uniform(0.4, 1.0), rng.uniform(0.3, 0.95)),
           "body": tuple(float(np.clip(v * rng.uniform(0.85, 1.1), 0, 1)) for v in coat)}
    pal["belly"] = tuple(0.45 * np.asarray(pal["body"]) + 0.55)
    pal["hoof"] = _hsv(0.08, 0.3, rng.uniform(0.2, 0.5))
    pal["beak"] = _hsv(rng.uniform(0.08, 0.14), 0.8, 0.95)
    pal["feet"] = pal["beak"]
    return {m: tuple(float(v) for v in c) for m, c in pal.items()}


def _dark(rng: np.random.Generator) -> tuple[float, float, float]:
    """A near-black ink: black, blue-black, sepia."""
    return [(0.06, 0.06, 0.08), (0.08, 0.1, 0.22), (0.22, 0.14, 0.08), (0.12, 0.12, 0.12)][int(rng.integers(4))]


def _felt(rng: np.random.Generator) -> tuple[float, float, float]:
    """A felt tip or crayon colour: saturated, mid to dark."""
    return _hsv(rng.random(), rng.uniform(0.55, 1.0), rng.uniform(0.35, 0.85))


def make_look3d(family: str, rng: np.random.Generator, scale: float = 1.0) -> Look3D:
    """A random look of a style family (STYLE_FAMILIES); line widths grow with `scale` (the drawing's size
    against a 256 px one)."""
    u = lambda lo, hi: float(rng.uniform(lo, hi))  # noqa: E731
    p = lambda x: bool(rng.random() < x)  # noqa: E731
    pal = random_palette(rng, mono=p(0.12))
    common = dict(crease=p(0.35), material_lines=p(0.6), marks=p(0.8), shading="none", photo=False, blur=0.0,
                  wobble=u(0, 0.8), palette=pal, breaks=u(0, 0.25) if p(0.35) else 0.0, width_var=u(0, 0.45))
    if family == "ink":
        look = dict(fill="flat" if p(0.15) else "paper", line="fixed", line_rgb=_dark(rng), line_width=u(1.0, 3.6),
                    paper=["white", "offwhite", "photo"][int(rng.integers(3))], photo=p(0.25))
        if look["fill"] == "flat":
            pal = {m: tuple(0.6 * np.asarray(c) + 0.4) for m, c in pal.items()}  # a pale fill
    elif family == "colour_lines":
        look = dict(fill="paper" if p(0.8) else "flat", line="fixed", line_rgb=_felt(rng), line_width=u(1.2, 5.0),
                    paper=["white", "offwhite", "photo", "sketch"][int(rng.integers(4))], photo=p(0.35))
        if look["fill"] == "flat":
            pal = {m: tuple(0.5 * np.asarray(c) + 0.5) for m, c in pal.items()}
    elif family == "flat":
        look = dict(fill="flat", line="shade" if p(0.6) else "fixed", line_rgb=_dark(rng), line_width=u(0.8, 3.2),
                    paper=["white", "offwhite", "photo"][int(rng.integers(3))], photo=p(0.2),
                    shading="cel" if p(0.25) else "none")
    elif family == "no_outline":
        look = dict(fill="flat", line="none", line_rgb=(0, 0, 0), line_width=0.0,
                    paper=["white", "offwhite", "photo"][int(rng.integers(3))], photo=p(0.2),
                    shading=["none", "cel", "soft"][int(rng.integers(3))], blur=u(0, 0.6))
        if len(set(pal.values())) == 1:  # one colour everywhere: shading is all there is to see
            look["shading"] = "soft"
    elif family == "watercolour":
        pencil = p(0.4)
        look = dict(fill="wash", line="graphite" if pencil else "none", line_rgb=(0.45, 0.45, 0.48),
                    line_width=u(0.6, 1.4), paper="offwhite", blur=u(0.5, 1.1), wobble=u(0.4, 1.3))
        pal = {m: tuple(0.55 * np.asarray(c) + 0.45) for m, c in pal.items()}  # washes are pale
    elif family == "pencil":
        look = dict(fill="paper" if p(0.8) else "wash", line="graphite", line_rgb=(0.27, 0.27, 0.3),
                    line_width=u(0.8, 2.2), paper="sketch" if p(0.7) else "offwhite", photo=p(0.2))
        common["breaks"] = u(0.05, 0.3)
        if look["fill"] == "wash":
            pal = {m: tuple(0.5 * np.asarray(c) + 0.5) for m, c in pal.items()}
    elif family == "crayon":
        look = dict(fill="wax" if p(0.5) else "paper", line="crayon", line_rgb=_felt(rng) if p(0.7) else _dark(rng),
                    line_width=u(2.5, 6.5), paper=["white", "offwhite", "sketch"][int(rng.integers(3))],
                    photo=p(0.5), wobble=u(0.6, 1.6))
        common["breaks"] = u(0.0, 0.2)
    else:
        raise ValueError(f"style family {family!r}: use one of {STYLE_FAMILIES}")
    merged = {**common, **look}
    merged["palette"] = pal
    merged["line_width"] = merged["line_width"] * scale
    merged["wobble"] = merged["wobble"] * scale
    return Look3D(family=family, **merged)
