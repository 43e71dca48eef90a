"""One SIMD level for the numerical libraries, so that a shot computes the same bits on every x86-64 machine with AVX2.

NumPy, OpenBLAS, OpenCV and PyTorch (with MKL and oneDNN inside it) each choose their kernels for the CPU they find
when they load: on a machine with AVX-512 they take other kernels than on one with AVX2 only, and the floats differ
in the last bits. The pipeline amplifies that: the masks' unmixing divides by small coverages, the mesher places
vertices by thresholds, the cut search chooses among near-equal energies. Measured (docs/performance.md): the same
code and inputs on one machine, NumPy and OpenBLAS restricted to AVX2 against the CPU's AVX-512, moved the redrawn
eleven's shots by up to 0.67 dB (r05) and their mean from 27.698 to 27.775 dB.

`pin()` runs when the `ops` package is first imported, before NumPy loads (every entry point of this project
imports `ops` first): where the CPU has AVX2 and FMA (x86-64-v3, every x86 server CPU since about 2015), it sets each
library's own switch to that level, unless INBETWEEN_SIMD=native asks for the CPU's own kernels. A variable the user
has set is left as it is. Not covered: ONNX Runtime (RIFE) has no such switch, so RIFE's frames can differ in their
last bits between CPU families; machines without AVX2, and ARM ones, compute as they do.
"""
from __future__ import annotations

import os
import platform
import sys

ENV_SWITCH = "INBETWEEN_SIMD"  # "avx2" (the default) or "native"
LEVEL = "x86-64-v3"  # AVX2 + FMA

# NumPy's dispatch targets above x86-64-v3: NumPy 2.4's grouped names and the earlier per-feature ones (a name the
# installed NumPy does not know is an ImportWarning, which Python ignores by default)
_NUMPY_ABOVE_V3 = ("X86_V4 AVX512_ICL AVX512_SPR AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX "
                   "AVX512_CNL")
# OpenCV's AVX-512 features and the CPU flags each needs (its wheels dispatch AVX512-SKX; OpenCV warns of disabling
# a feature the CPU lacks)
_OPENCV_ABOVE_V3 = {"AVX512F": {"avx512f"}, "AVX512-COMMON": {"avx512f", "avx512cd"},
                    "AVX512-SKX": {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"}}

_state: dict = {}
_set: dict[str, str] = {}  # the variables pin() set (those the user had set are not among them)


def cpu_flags() -> set[str]:
    """The CPU's feature flags as Linux reports them (empty where /proc/cpuinfo cannot be read)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def settings_for(flags: set[str]) -> dict[str, str]:
    """The environment that holds each library at x86-64-v3 on a CPU with these flags ({} where the CPU lacks
    AVX2 or FMA: forcing AVX2 kernels there would stop the process)."""
    if not {"avx2", "fma"} <= flags:
        return {}
    env = {
        "NPY_DISABLE_CPU_FEATURES": _NUMPY_ABOVE_V3,
        "OPENBLAS_CORETYPE": "Haswell",  # OpenBLAS's AVX2 kernels (numpy's and scipy's copies read it)
        "ATEN_CPU_CAPABILITY": "avx2",  # PyTorch's own kernels
        "ONEDNN_MAX_CPU_ISA": "AVX2",  # its convolutions
        "MKL_CBWR": "AVX2",  # its MKL: the same results on every CPU with AVX2
    }
    opencv = [name for name, needs in _OPENCV_ABOVE_V3.items() if needs <= flags]
    if opencv:
        env["OPENCV_CPU_DISABLE"] = ",".join(opencv)
    return env


def pin() -> dict:
    """Set the libraries' SIMD switches (the first call in a process; later calls return what it did): a dict with
    `level` (LEVEL, or "native" and why) and `late` (NumPy was loaded before this ran, so its choice stands)."""
    if _state:
        return _state
    late = "numpy" in sys.modules
    if os.environ.get(ENV_SWITCH, "avx2").lower() == "native":
        _state.update(level="native", why=f"{ENV_SWITCH}=native", late=late)
    elif platform.machine().lower() not in ("x86_64", "amd64"):
        _state.update(level="native", why=f"not x86-64 ({platform.machine()})", late=late)
    else:
        env = settings_for(cpu_flags())
        if not env:
            _state.update(level="native", why="the CPU reports no AVX2 and FMA", late=late)
        else:
            for name, value in env.items():
                if name not in os.environ:
                    os.environ[name] = _set[name] = value
            _state.update(level=LEVEL, why="", late=late)
    return _state


def set_by_pin() -> dict[str, str]:
    """The environment variables pin() set in this process, and their values (a child process given this
    environment without them computes with the CPU's own kernels, with INBETWEEN_SIMD=native)."""
    pin()
    return dict(_set)


def numpy_dispatch() -> list[str]:
    """The dispatch targets NumPy uses in this process (its highest first)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # a NumPy before 2.0
        return []
    return [t for t in reversed(__cpu_dispatch__) if __cpu_features__.get(t)]


def state() -> dict:
    """What `pin` did and what NumPy now dispatches to, for a run's report: level, why, late, numpy."""
    return {**pin(), "numpy": (numpy_dispatch() or ["baseline"])[0]}


def unheld() -> str | None:
    """A one-line warning when the pin was asked for but NumPy computes above x86-64-v3 all the same (it was
    imported before `ops`, as a script that imports numpy first does); None when the pin holds or was not asked."""
    now = state()
    above = set(_NUMPY_ABOVE_V3.split())
    if now["level"] != LEVEL or now["numpy"] not in above:
        return None
    return (f"NumPy was imported before the inbetween packages, so this process computes with the CPU's own SIMD "
            f"kernels ({now['numpy']}) and its results may differ from other machines' in their last bits; fix: "
            f"import ops (or assets) before numpy, or set {ENV_SWITCH}=native to say this is meant")
