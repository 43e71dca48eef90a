"""Exports for animation software: the OCA document read back by a reader of the specification, and the alpha
video decoded back with its alpha."""
import subprocess

import imageio_ffmpeg
import numpy as np

from ops.shotio.exports import write_alpha_video
from ops.shotio.frames import write_frames, write_outputs
from ops.shotio.image_io import paper_under_clear, read_image

from .oca_reader import read_oca


def _frames(T=7, H=33, W=40):
    """(T, H, W, 4) frames: a moving opaque square on transparent paper, its colour the frame index."""
    out = np.zeros((T, H, W, 4), np.float32)
    for i in range(T):
        out[i, 5:20, 3 + 3 * i:18 + 3 * i] = [i / T, 0.5, 1 - i / T, 1.0]
    return out


def test_oca_holds_every_frame_at_its_number_and_marks_the_keys(tmp_path):
    frames = _frames()
    write_outputs(tmp_path, frames, {"partition": "shot_a", "key_frames": [0, 2, 6], "frames_version": "v"},
                  ("oca",), fps=12)
    doc = read_oca(tmp_path / "oca" / "shot_a.oca")
    assert (doc.root["width"], doc.root["height"], doc.root["startTime"], doc.root["endTime"]) == (40, 33, 0, 6)
    for i in range(7):
        expected = paper_under_clear(frames[i])  # the written frames: white under full transparency
        np.testing.assert_array_equal(np.round(doc.image(i, "inbetween") * 255), np.round(expected * 255))
    keys = [layer for layer in doc.root["layers"] if layer["name"] == "keys"][0]
    assert keys["reference"] is True  # shown to the animator, never rendered
    assert [(c.start, c.duration, c.meta["inbetween"]["key"]) for c in doc.cels if c.layer == "keys"] == \
        [(0, 2, 0), (2, 4, 1), (6, 1, 2)]
    assert doc.at(4, "keys").start == 2  # frame 4 shows key 1, held until key 2


def test_oca_is_replaced_whole_when_the_shot_is_shorter(tmp_path):
    write_outputs(tmp_path, _frames(7), {"partition": "s", "key_frames": [0, 6], "frames_version": "a"}, ("oca",))
    write_outputs(tmp_path, _frames(4), {"partition": "s", "key_frames": [0, 3], "frames_version": "b"}, ("oca",))
    doc = read_oca(tmp_path / "oca" / "s.oca")
    assert doc.root["endTime"] == 3 and len(list((tmp_path / "oca" / "s" / "inbetween").iterdir())) == 4


def test_alpha_video_keeps_the_alpha_channel(tmp_path):
    frames = _frames(T=3, H=32, W=40)
    path = write_alpha_video(tmp_path / "alpha.mov", frames, fps=12)
    out = tmp_path / "back_%02d.png"
    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-i", str(path), "-pix_fmt", "rgba",
                    str(out)], check=True)
    back = [read_image(tmp_path / f"back_{i:02d}.png") for i in range(1, 4)]
    for i, b in enumerate(back):
        assert b.shape == (32, 40, 4)
        np.testing.assert_allclose(b[..., 3], frames[i, ..., 3], atol=2 / 255)  # alpha survives (10-bit 4:4:4)
        inside = frames[i, ..., 3] > 0.5
        np.testing.assert_allclose(b[inside][:, :3], frames[i][inside][:, :3], atol=6 / 255)


def test_frames_are_named_by_output_frame(tmp_path):
    paths = write_frames(tmp_path, _frames(T=12))
    assert [p.name for p in paths][-1] == "0011.png"


def _files(folder):
    """{relative path: bytes} of every file under folder, report.json left out (it names no time of writing)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != "report.json"}


def test_staged_outputs_put_in_place_are_the_outputs_written_in_place(tmp_path):
    from ops.shotio.frames import stage_outputs

    frames, report = _frames(), {"partition": "s", "key_frames": [0, 6], "frames_version": "v"}
    written, put = tmp_path / "written", tmp_path / "put"
    write_outputs(written, frames, report, ("gif", "oca"), fps=12)
    put.mkdir()
    staged = stage_outputs(put / ".staging-1-x", frames, ("gif", "oca"), fps=12)
    assert sorted(p.name for p in staged.iterdir()) == ["frames", "preview.gif"]  # the OCA links the final PNGs
    write_outputs(put, frames, report, ("gif", "oca"), fps=12, staged=staged)
    assert not [p for p in staged.rglob("*") if p.is_file()]  # moved, not copied
    assert _files(put) == _files(written)
    # the OCA's PNGs are the frames themselves (hard links), as when written in place
    assert (put / "oca" / "s" / "inbetween" / "inbetween_00003.png").stat().st_ino == \
        (put / "frames" / "0003.png").stat().st_ino


def test_a_staged_folder_missing_files_falls_back_to_writing_them(tmp_path):
    from ops.shotio.frames import stage_outputs

    frames, report = _frames(T=4), {"partition": "s", "key_frames": [0, 3], "frames_version": "v"}
    staged = stage_outputs(tmp_path / ".staging-1-x", frames, ("gif",), fps=12)
    (staged / "frames" / "0002.png").unlink()  # a writer that died midway
    (staged / "preview.gif").unlink()
    write_outputs(tmp_path / "out", frames, report, ("gif",), fps=12, staged=staged)
    assert sorted(p.name for p in (tmp_path / "out" / "frames").iterdir()) == [f"{i:04d}.png" for i in range(4)]
    assert (tmp_path / "out" / "preview.gif").stat().st_size > 0
