"""The Dagster assets, the run machinery and the command line over ops/."""
import ops  # noqa: F401  (first: it pins the numerical libraries' SIMD level before NumPy loads, ops/simd.py)
