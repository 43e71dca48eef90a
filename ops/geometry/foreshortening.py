"""Foreshortening (2.5D): a limb's drawn length follows its bone's projected length.

The template's rest shape is the keyframe's drawing at its own key pose, and the symmetric Dirichlet energy
measures every face against it. A bone turned toward or away from the viewer changes its length on the page
(arms folding over the chest: a forearm 30 px long at one key is 3 px long half-way), and the handles along
it, which follow the skeleton, pull its faces there; against the rest shape that is a squash of 10x, which the
energy's barrier resists, so the limb crumples between its handles and its texture tears into streaks.

Here each face's reference shape is its rest triangle stretched along its bone by the ratio of the bone's
projected lengths at the pose and at the key, S_f = I + (s - 1) d d^T (d the bone's unit direction at the key),
so a limb shortens and lengthens with its bone at no cost and keeps its width. A face's bones are blended by
weights interpolated over the mesh from the handles, each handle being on the bone its offset turns with: the
weights follow the mesh's own connectivity, so they do not reach across a cut or a pocket into another limb.
At the key's own pose every ratio is 1 and the metric is the identity (the keyframe is reproduced exactly); a
shot whose bones keep their projected lengths (a 2D rig) deforms exactly as without this.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from ops.geometry.mesh import edges_of, vertex_components
from ops.types import MIN_BONE_PX, Template

MIN_RATIO, MAX_RATIO = 0.1, 10.0  # a bone's projected length ratio is clipped to this (a bone seen end-on: 0)
STILL = 1e-6  # every ratio within this of 1: no metric (None), the energy's own rest shape


class Foreshortening:
    """The per-face reference metrics of one template, whose rest shape is drawn at `key_pose` (J, 3) px."""

    def __init__(self, template: Template, key_pose: np.ndarray):
        frames = np.asarray(template.handle_frames, np.int64).reshape(-1, 2)
        on_bone = frames[:, 0] >= 0
        self.bones = np.unique(frames[on_bone], axis=0)  # (B, 2) joints (parent, child) of the handles' bones
        xy = np.asarray(key_pose, np.float64)[:, :2]
        vec = xy[self.bones[:, 1]] - xy[self.bones[:, 0]] if len(self.bones) else np.zeros((0, 2))
        self.key_length = np.linalg.norm(vec, axis=1)  # (B,) px
        self.direction = vec / np.maximum(self.key_length, 1e-12)[:, None]  # (B, 2) unit at the key
        self.faces = np.asarray(template.faces, np.int64)
        self.face_bone = self._face_weights(template, frames, on_bone)  # (m, B)

    def _face_weights(self, template: Template, frames: np.ndarray, on_bone: np.ndarray) -> np.ndarray:
        """(m, B) float64 each face's share of each bone: the handles' bones (one-hot) interpolated harmonically
        over the mesh's edge graph (its weights stay in [0, 1] and sum to 1 in every component with a handle; a
        component without one gets none), averaged over the face's corners."""
        n, B = len(template.rest), len(self.bones)
        if B == 0:
            return np.zeros((len(self.faces), 0))
        bone_of = {tuple(b): i for i, b in enumerate(self.bones)}
        handles = np.asarray(template.handles, np.int64)[on_bone]
        bc = np.zeros((len(handles), B))
        bc[np.arange(len(handles)), [bone_of[tuple(f)] for f in frames[on_bone]]] = 1.0
        # a vertex that holds two handles (a joint shared by two bones' frames) takes their mean
        fixed, inverse = np.unique(handles, return_inverse=True)
        values = np.zeros((len(fixed), B))
        np.add.at(values, inverse, bc)
        values /= np.bincount(inverse)[:, None]
        E = edges_of(self.faces)
        A = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
        A = ((A + A.T) > 0).astype(np.float64)
        L = sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A  # the graph Laplacian: a discrete maximum principle
        comp = vertex_components(n, self.faces)
        held = np.zeros(comp.max() + 1, bool)
        held[comp[fixed]] = True
        free = np.setdiff1d(np.nonzero(held[comp])[0], fixed)
        W = np.zeros((n, B))
        W[fixed] = values
        if len(free):
            rhs = -(L[free][:, fixed] @ values)
            W[free] = np.asarray(spsolve(L[free][:, free].tocsc(), rhs)).reshape(len(free), B)
        return np.clip(W[self.faces].mean(axis=1), 0.0, 1.0)

    def ratios(self, pose: np.ndarray) -> np.ndarray:
        """(B,) float64 each bone's projected length at a (J, 3) pose over its length at the key, clipped to
        [MIN_RATIO, MAX_RATIO]; 1 for a bone shorter than MIN_BONE_PX at the key."""
        xy = np.asarray(pose, np.float64)[:, :2]
        length = np.linalg.norm(xy[self.bones[:, 1]] - xy[self.bones[:, 0]], axis=1) if len(self.bones) else np.zeros(0)
        ok = self.key_length > MIN_BONE_PX
        r = np.ones(len(self.bones))
        r[ok] = np.clip(length[ok] / self.key_length[ok], MIN_RATIO, MAX_RATIO)
        return r

    def metric(self, pose: np.ndarray) -> np.ndarray | None:
        """(m, 2, 2) float64 symmetric positive definite stretch of each face's rest triangle at a (J, 3) pose,
        sum_b w_fb (I + (s_b - 1) d_b d_b^T) + (1 - sum_b w_fb) I; None where every ratio is 1 (within STILL)."""
        s = self.ratios(pose)
        if not len(s) or np.all(np.abs(s - 1.0) <= STILL):
            return None
        k = self.face_bone * (s - 1.0)  # (m, B)
        dd = self.direction[:, :, None] * self.direction[:, None, :]  # (B, 2, 2)
        return np.eye(2)[None] + np.einsum("fb,bij->fij", k, dd)
