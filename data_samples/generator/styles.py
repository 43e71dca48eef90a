"""Drawing styles (ink, watercolour, flat colour, pencil, scan) and the palettes that colour part materials."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Style:
    """How parts are painted.

    fill: "paper" (line art: the inside shows the paper) | "flat" (opaque colour) | "wash" (transparent watercolour).
    line: "ink" (near black) | "shade" (a darker shade of the character's colour) | "graphite" | "none".
    line_width: mean outline width (px); wobble: amplitude (px) of irregular edges; soften: Gaussian sigma (px)
    of the part's edge; photo: photographed and JPEG-compressed afterwards.
    """

    name: str
    fill: str
    line: str
    line_width: float
    paper: str
    wobble: float = 0.0
    soften: float = 0.0
    photo: bool = False


STYLES: dict[str, Style] = {
    "ink": Style("ink", "paper", "ink", 2.4, "white"),
    "watercolour": Style("watercolour", "wash", "none", 0.0, "offwhite", wobble=0.9, soften=0.9),
    "flat_colour": Style("flat_colour", "flat", "shade", 2.2, "white"),
    "pencil": Style("pencil", "paper", "graphite", 1.6, "sketch"),
    "scan": Style("scan", "paper", "ink", 2.3, "photo", photo=True),
}

# material -> (R, G, B[, opacity]) 0-255; a missing opacity is a transparent wash in the watercolour style
Palette = dict[str, tuple]

GIRL = {"skin": (245, 220, 200), "top": (240, 150, 178), "trousers": (42, 42, 52), "boots": (251, 251, 248, 0.9),
        "hair": (190, 140, 95), "skirt": (160, 200, 235)}
DINOSAUR = {"body": (118, 190, 84), "belly": (222, 234, 158), "outline": (30, 92, 42)}
FOX = {"body": (236, 136, 52), "belly": (250, 240, 225), "tip": (250, 246, 238), "outline": (112, 62, 26)}
BEAR = {"body": (170, 120, 80), "belly": (230, 200, 160), "outline": (80, 50, 30)}
LAMP = {"metal": (150, 160, 175), "shade": (235, 80, 60), "outline": (40, 45, 60)}
KID = {"skin": (240, 205, 170), "top": (90, 140, 220), "trousers": (70, 80, 110), "boots": (120, 70, 40),
       "hair": (60, 40, 30), "skirt": (230, 90, 110)}
PALETTES: dict[str, Palette] = {"girl": GIRL, "dinosaur": DINOSAUR, "fox": FOX, "bear": BEAR, "lamp": LAMP, "kid": KID}
