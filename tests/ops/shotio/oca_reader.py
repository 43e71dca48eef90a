"""A reader of Open Cel Animation documents written against the OCA specification (root, layer and frame objects,
version 1.1.0), strict where the specification says importing must fail, for the tests of our export."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ops.shotio.image_io import read_image

VERSIONS = ("1.0.0", "1.1.0", "1.1.1", "1.2.0", "1.3.0")
LAYER_TYPES = ("paintlayer", "grouplayer", "vectorlayer", "ocalayer", "clonelayer")
COLOR_DEPTHS = ("U8", "U16", "F16", "F32")


@dataclass
class Cel:
    layer: str
    file: Path
    start: int
    duration: int
    meta: dict


@dataclass
class Document:
    root: dict
    cels: list[Cel]

    def at(self, frame: int, layer: str) -> Cel | None:
        """The cel of `layer` visible at document frame `frame`, or None."""
        for c in self.cels:
            if c.layer == layer and c.start <= frame < c.start + c.duration:
                return c
        return None

    def image(self, frame: int, layer: str) -> np.ndarray | None:
        c = self.at(frame, layer)
        return None if c is None else read_image(c.file)


def read_oca(path: Path) -> Document:
    """Parse and check an .oca document; AssertionError naming what breaks the specification."""
    root = json.loads(Path(path).read_text())
    assert root.get("ocaVersion") in VERSIONS, "ocaVersion must be a released OCA version"
    for key, kind in (("name", str), ("frameRate", (int, float)), ("width", int), ("height", int),
                      ("startTime", int), ("endTime", int), ("colorDepth", str), ("layers", list)):
        assert isinstance(root.get(key), kind), f"root.{key}"
    assert root["colorDepth"] in COLOR_DEPTHS
    bg = root.get("backgroundColor", [0.0, 0.0, 0.0, 0.0])
    assert len(bg) == 4 and all(0.0 <= v <= 1.0 for v in bg), "backgroundColor in [0, 1] for U8"
    names = [layer["name"] for layer in root["layers"]]
    assert len(set(names)) == len(names), "layer names must be unique"
    cels = []
    for layer in root["layers"]:
        assert layer.get("type", "paintlayer") in LAYER_TYPES
        for f in layer.get("frames", []):
            assert isinstance(f["frameNumber"], int), "frame objects need an int frameNumber (no default)"
            duration = f.get("duration", 1)
            assert isinstance(duration, int) and duration >= 1
            file = Path(path).parent / f.get("fileName", "")
            assert f.get("name") == "_blank" or file.is_file(), f"{f.get('fileName')}: a frame's file must exist"
            assert file.suffix == "." + layer.get("fileType", "png")
            cels.append(Cel(layer["name"], file, f["frameNumber"], duration, f.get("meta", {})))
        starts = sorted(c.start for c in cels if c.layer == layer["name"])
        assert len(set(starts)) == len(starts), "two cels of a layer start at one frame"
    return Document(root, cels)
