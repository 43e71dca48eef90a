"""Pipeline settings with the paper's defaults, as one documented Dagster resource."""
from __future__ import annotations

import dagster as dg
from pydantic import Field


class PipelineSettings(dg.ConfigurableResource):
    """Parameters of the method; every value is recorded in each stage's provenance."""

    mu: float = Field(200.0, description="Weight of the pose term in the deformation energy (§4.3).")
    grad_tol: float = Field(0.01, description="Stop the quasi-Newton solver at this gradient norm (§4.3).")
    max_iter: int = Field(5000, description="Iteration cap of the deformation solver (§4.3).")
    seed: int = Field(0, description="Seed of optuna's TPE sampler for odd T-junction counts (§4.4).")
    epsilon: float = Field(0.02, description="Path may step back in alpha by less than this (§5.2).")
    alpha_depth: int = Field(3, description="Recursive RIFE bisection depth: alpha grid of 2**depth + 1 values.")
    supersample: int = Field(2, description="Renderer supersampling factor per axis (anti-aliasing).")
    template_mode: str = Field("optimized", description="'optimized' (2.5D template, §4.4) or 'single-layer' (ablation).")
    blend: str = Field("optimal", description="'optimal' shortest-path blending or 'diagonal' alpha = t (§5.2).")
