"""The SIMD level every entry point pins (ops/simd.py): which switches, and that they make the bits the same."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from ops import simd

AVX2 = {"avx2", "fma"} <= simd.cpu_flags()
AVX512 = "avx512f" in simd.cpu_flags()
SKX = {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"}

# a stage's arithmetic that leans on NumPy's SIMD loops and BLAS: the paper model of a drawing (a least-squares
# polynomial surface in linear light, ops.segmentation.paper) and the distance of every pixel from it
PAGE = """
import hashlib, json, sys
from ops import simd
import numpy as np
from ops.segmentation.foreground import read_page
rng = np.random.default_rng(7)
y, x = np.mgrid[0:96, 0:128] / 128.0
rgb = np.stack([0.9 - 0.1 * x * y, 0.85 + 0.05 * x, 0.8 + 0.1 * y], -1) + 0.02 * rng.random((96, 128, 3))
rgb[30:60, 40:90] = rng.random((30, 50, 3)) * 0.5
page = read_page(np.clip(rgb, 0, 1).astype(np.float32))
digest = hashlib.sha256(page.paper.rgb.tobytes() + page.paper.lab.tobytes() + page.delta.tobytes()).hexdigest()
print(json.dumps({"state": simd.state(), "digest": digest}))
"""


def _python(code: str, **env: str) -> dict:
    """Run `code` in a fresh interpreter with the variables above the suite's (those of ops.simd's switches
    removed, so each process pins on its own) and return the JSON it prints last."""
    base = {k: v for k, v in os.environ.items()
            if k not in {*simd.settings_for(SKX | {"avx2", "fma"}), simd.ENV_SWITCH}}
    out = subprocess.run([sys.executable, "-c", code], env={**base, **env}, capture_output=True, text=True,
                         timeout=120, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_no_switch_without_avx2():
    assert simd.settings_for(set()) == {}
    assert simd.settings_for({"avx2"}) == {}  # Haswell's kernels need FMA too: forcing them would stop the process


def test_the_switches_follow_the_cpu():
    v3 = simd.settings_for({"avx2", "fma"})
    assert v3["OPENBLAS_CORETYPE"] == "Haswell" and "X86_V4" in v3["NPY_DISABLE_CPU_FEATURES"].split()
    assert "OPENCV_CPU_DISABLE" not in v3  # OpenCV warns of disabling a feature the CPU lacks
    assert simd.settings_for({"avx2", "fma", "avx512f"})["OPENCV_CPU_DISABLE"] == "AVX512F"
    assert simd.settings_for(SKX | {"avx2", "fma"})["OPENCV_CPU_DISABLE"].split(",") == [
        "AVX512F", "AVX512-COMMON", "AVX512-SKX"]


@pytest.mark.skipif(not AVX2, reason="the CPU has no AVX2 and FMA: nothing is pinned")
def test_importing_ops_first_holds_numpy_and_opencv_at_avx2():
    got = _python("import json, ops, cv2; from ops import simd; "
                  "print(json.dumps({**simd.state(), 'cv_skx': cv2.checkHardwareSupport(256)}))")
    assert got["level"] == simd.LEVEL and not got["late"]
    assert got["numpy"] in ("X86_V3", "X86_V2", "AVX2", "FMA3", "baseline")  # nothing of AVX-512
    assert not got["cv_skx"]


def test_a_variable_the_user_set_is_kept():
    got = _python("import json, os, ops; print(json.dumps(os.environ['OPENBLAS_CORETYPE']))",
                  OPENBLAS_CORETYPE="Sandybridge")
    assert got == "Sandybridge"


def test_numpy_loaded_first_is_reported_late():
    got = _python("import json, numpy, ops; from ops import simd; print(json.dumps(simd.state()))")
    assert got["late"]


@pytest.mark.skipif(not AVX2, reason="the CPU has no AVX2 and FMA: nothing is pinned")
def test_the_pinned_bits_are_those_of_a_machine_without_avx512():
    """A process that pins equals one whose libraries were held at AVX2 by hand (what an AVX2-only machine runs),
    one BLAS thread or several; on an AVX-512 CPU the process left native computes other bits."""
    pinned = _python(PAGE)
    by_hand = _python(PAGE, INBETWEEN_SIMD="native", OPENBLAS_NUM_THREADS="1",
                      **simd.settings_for({"avx2", "fma"}))  # NumPy and OpenBLAS held, OpenCV not told
    assert by_hand["state"]["level"] == "native" and pinned["state"]["level"] == simd.LEVEL
    assert pinned["digest"] == by_hand["digest"]
    if AVX512:
        native = _python(PAGE, INBETWEEN_SIMD="native")
        assert native["state"]["numpy"] not in ("X86_V3", "X86_V2")
        assert native["digest"] != pinned["digest"]  # what the pin is for: the other kernels' last bits


@pytest.mark.skipif(not AVX512, reason="on a CPU without AVX-512 NumPy's own kernels are already at AVX2")
def test_a_script_that_imports_numpy_first_is_told():
    """A TD's script that imports numpy before our packages computes with the CPU's own kernels: run_shot warns
    once, with the fix; importing ops first, or asking for the native kernels, says nothing."""
    code = ("import json\n{first}\nfrom ops import simd\n"
            "print(json.dumps(simd.unheld()))\n")
    told = _python(code.format(first="import numpy"))
    assert told and "import ops (or assets) before numpy" in told and simd.ENV_SWITCH in told
    assert _python(code.format(first="import ops, numpy")) is None
    assert _python(code.format(first="import numpy"), INBETWEEN_SIMD="native") is None

