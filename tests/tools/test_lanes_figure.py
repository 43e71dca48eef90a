"""tools/lanes_figure.py: rows are key0's lane (alpha 0), key1's lane (alpha 1), the optimal path's blend and the
truth; every tile shows the same crop, so a part drawn in two places by the lanes shows in two places; the lanes
are shown over the evaluation's paper plate."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from ops.shotio.load import load_shot
from ops.types import BlendPath, BlendPaths, ImageMatrix, Masks
from resources.registry import register_shot
from resources.store import Store
from tools.lanes_figure import LABEL_W, TILE, crop_box, lane_rows, lanes_figure

SAMPLE = Path(__file__).resolve().parents[2] / "data_samples" / "two_poses"


def square(h: int, w: int, x: int, colour) -> np.ndarray:
    """(h, w, 4) straight-alpha RGBA: a 20 px opaque square of `colour` at column x, row 100, on nothing."""
    img = np.zeros((h, w, 4), np.float32)
    img[100:120, x:x + 20] = (*colour, 1.0)
    return img


def test_rows_show_each_lane_the_blend_and_the_truth(tmp_path):
    shot_dir = shutil.copytree(SAMPLE, tmp_path / "two_poses")
    shot = load_shot(shot_dir)
    h, w = shot.size
    n_t, alphas = len(shot.times), np.linspace(0, 1, 3)
    frames = np.zeros((n_t, 3, h, w, 4), np.float32)
    for t in range(n_t):  # key0's lane a red square at the left, key1's a blue one at the right, alpha 1/2 green
        frames[t, 0], frames[t, 1], frames[t, 2] = (square(h, w, 40, (1, 0, 0)), square(h, w, 90, (0, 1, 0)),
                                                    square(h, w, 140, (0, 0, 1)))
    matrix = ImageMatrix(times=np.linspace(0, 1, n_t), alphas=alphas, frames=frames,
                         flows=np.zeros((n_t, h, w, 4), np.float32), computed=np.ones((n_t, 3), bool))
    path = BlendPath(alpha_index=np.array([0] + [1] * (n_t - 2) + [2]), cost=0.0, step_costs=np.zeros(n_t - 1),
                     abrupt=np.zeros(n_t - 1, bool))
    # another folder named two_poses ran first in this home: this one's partition key is two_poses-<hash>
    registry = tmp_path / "home" / "shots.json"
    assert register_shot(registry, shutil.copytree(SAMPLE, tmp_path / "elsewhere" / "two_poses")) == "two_poses"
    key = register_shot(registry, shot_dir)
    assert key != "two_poses"
    store = Store(tmp_path / "home" / "storage")
    store.write("seg0/rife_matrix", key, matrix)
    store.write("seg0/optimal_path", key, BlendPaths(matrix.times, alphas, path, path))
    for k in (0, 1):  # no character: the plate is the keys' own pixels
        store.write(f"key{k}/masks", key, Masks(np.zeros((h, w), bool), [], [], "predicted", np.zeros((h, w), np.float32),
                                               np.ones((h, w, 3), np.float32), np.ones((h, w, 3), np.float32),
                                               np.zeros((h, w), bool), 0))

    fig = lanes_figure(shot_dir, tmp_path / "home")
    assert fig.shape == (4 * TILE, LABEL_W + n_t * TILE, 3)  # the sample has ground truth: four rows

    def colour_in(row: int, col: int) -> np.ndarray:
        """Mean colour of the saturated pixels of a tile."""
        t = fig[row * TILE:(row + 1) * TILE, LABEL_W + col * TILE:LABEL_W + (col + 1) * TILE].astype(int)
        sat = t.max(axis=2) - t.min(axis=2) > 100
        return t[sat].mean(axis=0)

    assert np.argmax(colour_in(0, 1)) == 0 and np.argmax(colour_in(1, 1)) == 2  # red lane, blue lane
    assert np.argmax(colour_in(2, 1)) == 1 and np.argmax(colour_in(2, 0)) == 0  # the path's alpha per column


def test_crop_box_holds_everything_drawn_and_is_square():
    alpha = np.zeros((100, 200), np.float32)
    alpha[10:20, 30:80] = 1.0
    y0, y1, x0, x1 = crop_box([alpha], margin=2)
    assert y0 <= 8 and y1 >= 22 and x0 <= 28 and x1 >= 82 and (y1 - y0) == (x1 - x0)
    assert crop_box([np.zeros((50, 60), np.float32)]) == (0, 50, 0, 60)  # nothing drawn: the whole frame


def test_lanes_are_shown_over_the_paper_plate():
    """Where a lane draws nothing the row shows the plate, where it draws opaquely its own colour, and a half-covered
    pixel their mix: the tiles compare with the truth's paper, not with white."""
    h, w = 40, 60
    frames = np.zeros((3, 2, h, w, 4), np.float32)
    frames[:, 0, 5:15, 5:15] = (1, 0, 0, 1)
    frames[:, 1, 5:15, 5:15] = (0, 0, 1, 0.5)
    plate = np.full((h, w, 3), (0.9, 0.85, 0.7), np.float32)  # a cream paper
    rows = lane_rows(frames, np.array([0, 1, 1]), [0, 2], plate)
    assert [name for name, _ in rows] == ["key0 lane", "key1 lane", "blend"]
    key0, key1, blend = (ims for _, ims in rows)
    assert np.allclose(key0[0][30, 40], plate[30, 40]) and np.allclose(key0[0][10, 10], (1, 0, 0))
    assert np.allclose(key1[1][10, 10], 0.5 * np.array([0, 0, 1]) + 0.5 * plate[10, 10])
    assert np.allclose(blend[0][10, 10], (1, 0, 0)) and np.allclose(blend[1], key1[1])  # the path's alpha per time
    out = np.zeros((3, h, w, 4), np.float32)
    out[:, 20:30, 20:30] = (0, 1, 0, 1)  # output frames that differ from the cells (per-pixel alpha)
    blend = lane_rows(frames, np.array([0, 1, 1]), [0, 2], plate, out)[2][1]
    assert np.allclose(blend[0][25, 25], (0, 1, 0)) and np.allclose(blend[0][10, 10], plate[10, 10])
