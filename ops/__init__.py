"""The method's stages as plain functions, no Dagster. Imported first by every entry point of the project: it pins
the numerical libraries' SIMD level before NumPy loads (ops/simd.py)."""
from ops import simd as _simd

_simd.pin()
