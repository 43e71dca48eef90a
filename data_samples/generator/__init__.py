"""Synthetic drawings with ground truth: sample shots (shots.py) and the occlusion dataset (occlusion_set.py)."""
