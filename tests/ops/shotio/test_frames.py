"""Output writers: exact PNG round trip, GIF frame count, contact sheet geometry and colours."""
import numpy as np
import pytest

from ops.blending.contact_sheet import (
    DIAGONAL_COLOUR,
    MARK_TINT,
    PATH_COLOUR,
    _cell_origin,
    contact_sheet_shape,
    matrix_contact_sheet,
    output_row,
)
from ops.blending.select import select_frames
from ops.evaluation.metrics import psnr
from ops.shotio.frames import write_frames, write_preview_video
from ops.shotio.image_io import read_image


def _frames(T=4, H=40, W=56, seed=0):
    rng = np.random.default_rng(seed)
    return rng.random((T, H, W, 4)).astype(np.float32)


def test_png_round_trip_exact_for_8bit_values(tmp_path):
    rng = np.random.default_rng(0)
    frames = (rng.integers(0, 256, (3, 20, 30, 4)) / 255.0).astype(np.float32)
    frames[..., 3] = np.maximum(frames[..., 3], 1 / 255)  # straight alpha keeps colour even at low alpha
    paths = write_frames(tmp_path, frames)
    assert [p.name for p in paths] == ["0000.png", "0001.png", "0002.png"]
    assert all(p.parent == tmp_path / "frames" for p in paths)
    for i, p in enumerate(paths):
        back = read_image(p)
        assert back.shape == (20, 30, 4)
        np.testing.assert_array_equal(np.round(back * 255), np.round(frames[i] * 255))
    assert not list((tmp_path / "frames").glob(".tmp-*"))  # atomic writes leave no temp files


def test_keyframe_read_back_psnr_and_exr(tmp_path):
    # A smooth "keyframe": continuous values quantize to 8 bit with error <= 1/510 -> PSNR > 50 dB.
    y, x = np.mgrid[0:48, 0:64] / 64.0
    key = np.stack([x, y, 0.5 * (x + y), np.clip(1.2 - x, 0, 1)], -1).astype(np.float32)
    frames = np.stack([key, key[::-1].copy()])
    paths = write_frames(tmp_path, frames, exr=True)
    assert psnr(read_image(paths[0]), key) >= 40.0
    exr = read_image(tmp_path / "frames_exr" / "0000.exr")
    assert exr.shape == key.shape
    np.testing.assert_allclose(exr, key, atol=1e-3)  # half float: 11-bit mantissa


def test_gif_has_T_frames(tmp_path):
    import imageio.v3 as iio
    frames = _frames(T=5)
    for i in range(5):
        frames[i, ..., 3] = 1.0
        frames[i, :, :, 0] = i / 4.0  # distinct frames (Pillow merges identical ones)
    path = write_preview_video(tmp_path / "preview.gif", frames, fps=8)
    back = iio.imread(path, index=None)
    assert back.shape[0] == 5 and back.shape[1:3] == (40, 56)


def test_mp4_written(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    frames = _frames(T=3, H=31, W=45)  # odd sizes: padded to even for H.264
    path = write_preview_video(tmp_path / "preview.mp4", frames, fps=8)
    import imageio.v2 as imageio
    reader = imageio.get_reader(path, format="FFMPEG")
    assert reader.count_frames() == 3
    assert reader.get_data(0).shape == (32, 46, 3)
    reader.close()


def test_select_frames_from_memmap(tmp_path):
    T, A = 4, 3
    data = np.memmap(tmp_path / "m.dat", dtype=np.float32, mode="w+", shape=(T, A, 5, 6, 4))
    data[:] = (np.arange(T)[:, None] * 10 + np.arange(A)[None, :])[:, :, None, None, None]
    out = select_frames(data, np.array([0, 1, 1, 2]))
    assert out.shape == (T, 5, 6, 4) and not isinstance(out, np.memmap)
    np.testing.assert_array_equal(out[:, 0, 0, 0], [0, 11, 21, 32])
    with pytest.raises(ValueError):
        select_frames(data, np.array([0, 1]))


def test_contact_sheet_shape_and_path_colours(tmp_path):
    T, A, H, W, thumb = 5, 3, 30, 40, 32
    data = np.memmap(tmp_path / "m.dat", dtype=np.float32, mode="w+", shape=(T, A, H, W, 4))
    data[:] = 1.0
    data[..., :3] = 0.5  # mid grey, opaque: no cell pixel is pure red or blue
    data.flush()
    ro = np.memmap(tmp_path / "m.dat", dtype=np.float32, mode="r", shape=(T, A, H, W, 4))
    path_idx = np.array([0, 0, 1, 2, 2])
    diag_idx = np.array([0, 0, 1, 1, 2])
    sheet = matrix_contact_sheet(ro, np.array([0, 0.5, 1]), np.linspace(0, 1, T), path_idx, diag_idx,
                                 thumb=thumb)
    expected = (22 + 6 + A * (thumb + 6), 56 + 6 + T * (thumb + 6), 3)
    assert sheet.shape == expected == contact_sheet_shape(T, A, thumb)
    assert sheet.dtype == np.float32 and 0 <= sheet.min() and sheet.max() <= 1
    for t in range(T):
        x, y = _cell_origin(t, int(path_idx[t]), thumb)
        # left edge of the path outline
        np.testing.assert_array_equal(sheet[y + 5, x - 2], np.float32(PATH_COLOUR) / 255)
        xd, yd = _cell_origin(t, int(diag_idx[t]), thumb)
        # inset diagonal outline
        np.testing.assert_array_equal(sheet[yd + 5, xd + 2], np.float32(DIAGONAL_COLOUR) / 255)
    # a cell on neither path keeps its grey thumbnail and has no outline
    x, y = _cell_origin(0, 2, thumb)
    np.testing.assert_allclose(sheet[y + 5, x - 2], 237 / 255)
    np.testing.assert_allclose(sheet[y + thumb // 2, x + 5], 128 / 255, atol=1e-6)


def test_the_output_row_lines_up_with_the_grid_and_tints_by_weight():
    T, H, W, thumb = 4, 30, 30, 32
    frames = np.zeros((T, H, W, 4), np.float32)
    frames[..., :3], frames[..., 3] = 0.5, 1.0  # grey, opaque
    weight = np.zeros((T, H, W), np.float32)
    weight[1], weight[2] = 0.25, 1.0  # the second frame half tinted, the third fully (from a weight of one half)
    row = output_row(frames, thumb=thumb, marks=[(weight, (1.0, 0.0, 1.0))])
    assert row.shape == (thumb + 12, contact_sheet_shape(T, 1, thumb)[1], 3) and row.dtype == np.float32
    for t, k in enumerate([0.0, 0.5 * MARK_TINT, MARK_TINT, 0.0]):
        x = _cell_origin(t, 0, thumb)[0]
        want = [0.5 + 0.5 * k, 0.5 - 0.5 * k, 0.5 + 0.5 * k]  # toward magenta by k
        np.testing.assert_allclose(row[6 + thumb // 2, x + thumb // 2], want, atol=1 / 255)
    np.testing.assert_allclose(row[6 + thumb // 2, _cell_origin(0, 0, thumb)[0] - 3], 237 / 255)  # the gap: grey


def test_fully_transparent_pixels_carry_the_paper_in_every_frame_and_the_composite_is_unchanged(tmp_path):
    from ops.shotio.image_io import composite_over_white
    rng = np.random.default_rng(3)
    frames = rng.random((3, 16, 20, 4)).astype(np.float32)
    frames[..., 3] = np.where(rng.random((3, 16, 20)) < 0.4, 0.0, frames[..., 3])  # clear pixels, dark below
    frames[0, ..., :3] = np.where(frames[0, ..., 3:] == 0, 0.0, frames[0, ..., :3])  # a blend: black under clear
    frames[1, 0, 0, 3] = 0.4 / 255  # rounds to 0 in 8 bit: cleared in the PNG only
    paths = write_frames(tmp_path, frames, exr=True)
    for i, p in enumerate(paths):
        png = read_image(p)
        clear = np.round(png[..., 3] * 255) == 0
        assert clear.sum() >= 0.3 * clear.size
        np.testing.assert_array_equal(png[clear][:, :3], 1.0)  # one steady page under transparency
        over = composite_over_white(np.round(frames[i] * 255) / 255)
        np.testing.assert_allclose(composite_over_white(png), over, atol=1e-6)  # nothing visible moved
        exr = read_image(tmp_path / "frames_exr" / f"{i:04d}.exr")
        np.testing.assert_array_equal(exr[exr[..., 3] == 0][:, :3], 1.0)
    assert read_image(tmp_path / "frames_exr" / "0001.exr")[0, 0, 3] > 0  # not clear in half float: kept as drawn
