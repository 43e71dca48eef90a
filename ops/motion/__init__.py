"""Motion sources for a shot: BVH clips retargeted the AnimatedDrawings way, and points tracked in a video."""
