"""Carry a deformation from one cut topology of a template to another: the warm start of the cut search (§4.4).

Every incision of the same front sheet (ops.geometry.topology.incise) has the
same faces in the same order; only which copy of a vertex each corner uses
differs (the front or the pocket copy, split where sheets part). So a solution
of one topology gives every corner of the other a position: the position of the
corresponding corner. A vertex whose corners came from one vertex takes its
position; a vertex where the other topology had two sheets apart (two source
vertices) takes the one that folds the fewest of its faces. Where faces still
fold, the caller starts from rest instead.
"""
from __future__ import annotations

import numpy as np

from ops.geometry.mesh import signed_areas


def transfer_positions(x_from: np.ndarray, faces_from: np.ndarray, faces_to: np.ndarray, rest_to: np.ndarray) -> np.ndarray:
    """(n', 2) positions, pixels, of the mesh (rest_to (n', 2), faces_to (m, 3)) from positions x_from (n, 2)
    of the mesh faces_from (m, 3) whose face f is face f of faces_to (vertices of no face keep their rest
    position); ValueError if the face counts differ."""
    if faces_from.shape != faces_to.shape:
        raise ValueError(f"meshes of {len(faces_from)} and {len(faces_to)} faces do not correspond")
    n_from = int(faces_from.max()) + 1 if faces_from.size else 1
    key = np.unique(faces_to.ravel().astype(np.int64) * n_from + faces_from.ravel())  # (target, source), sorted
    pairs = np.stack([key // n_from, key % n_from], axis=1)
    x = np.array(rest_to, dtype=np.float64)
    first = np.ones(len(pairs), bool)
    first[1:] = pairs[1:, 0] != pairs[:-1, 0]
    x[pairs[first, 0]] = x_from[pairs[first, 1]]
    ambiguous = np.unique(pairs[~first, 0])
    if len(ambiguous):
        # each ambiguous vertex's faces and sources by slicing sorted arrays (a scan of every face per vertex
        # cost 4.5 ms a transfer on curled_tail's key1: 160 transfers, 11 ambiguous vertices each)
        corner = np.argsort(faces_to.ravel(), kind="stable")
        bounds = np.searchsorted(faces_to.ravel()[corner], np.stack([ambiguous, ambiguous + 1]))
        source_bounds = np.searchsorted(pairs[:, 0], np.stack([ambiguous, ambiguous + 1]))
        for v, (lo, hi), (slo, shi) in zip(ambiguous.tolist(), bounds.T.tolist(), source_bounds.T.tolist()):
            around = faces_to[np.sort(corner[lo:hi] // 3)]
            best, best_folds = None, None
            for u in pairs[slo:shi, 1].tolist():
                x[v] = x_from[u]
                folds = int((signed_areas(x, around) <= 0).sum())
                if best_folds is None or folds < best_folds:
                    best, best_folds = u, folds
            x[v] = x_from[best]
    return x
