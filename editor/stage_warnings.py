"""The stages' warnings as the page shows them: each at the joint, T-junction, bone or region it names.

Every stage records its warnings (the input repairs and hints it made) in its provenance. Those about one
thing of the shot name it (ops/warning_subject.py); the page places them on their keyframe, at the subject
where it is now (a joint by name, a T-junction nearest to where it was) or where the stage saw it.
"""
from __future__ import annotations

import re

from assets.graph import shot_graph
from ops.warning_subject import parse
from resources.store import Store

KEY_STAGE = re.compile(r"^(?:seg\d+/)?key(\d+)/")  # a key's lane, or its side of a segment (the lane deformed)


def stage_warnings(store: Store, partition: str, stages=shot_graph(2).stages) -> list[dict]:
    """The stored stages' warnings, upstream first, each once per keyframe: {"stage", "k" (None: not a
    keyframe's lane or side), "text", "kind" (None: about the keyframe or the shot as a whole), "names", "index",
    "at" ([x, y] keyframe pixels or None), "problem", "fix"}."""
    out, seen = [], set()
    for name in stages:
        _, recorded = store.provenance(name, partition)
        m = KEY_STAGE.match(name)
        k = int(m.group(1)) if m else None
        for text in (recorded or {}).get("warnings") or []:
            if not isinstance(text, str) or (k, text) in seen:
                continue  # a lane's later stages carry its earlier ones' warnings on (refined masks: the masks')
            seen.add((k, text))
            s = parse(text)
            if s is None:
                problem, _, fix = text.partition("; fix: ")
                out.append({"stage": name, "k": k, "text": text, "kind": None, "names": [], "index": None,
                            "at": None, "problem": problem, "fix": fix or None})
            else:
                out.append({"stage": name, "k": k, "text": text, "kind": s.kind, "names": list(s.names),
                            "index": s.index, "at": list(s.at) if s.at else None, "problem": s.problem, "fix": s.fix})
    return out
