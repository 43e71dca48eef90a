"""Skeletons a shot starts from: templates and their placement on a drawing."""
