"""Dagster resources over ops/: RIFE, the inpainter, the settings, the stage store, the shots registry."""
import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)
