"""The BLAS kernels numpy and scipy compute with, pinned so that a trial gives the same bits on
every x86-64 machine with AVX2 (standard library only; ``dopt/__init__.py`` calls ``pin``).

The OpenBLAS that numpy's and scipy's wheels bundle is built for many CPUs at once and picks its
kernels for the CPU it loads on: AVX-512 machines (Intel since Skylake-X, AMD since Zen 4) get
the ``SkylakeX`` kernels, which sum in another order than the AVX2 ones (``Haswell``; ``Zen``
uses the same). The iLQR backward pass and the authors' clock's fit go through BLAS, and an MPC
episode is chaotic, so a last-bit difference grows into another episode: a committed trial of
the clutter pilot, recorded where OpenBLAS chose its AVX2 kernels, reruns to its recorded cost
with ``Haswell`` or ``Zen`` and to another with ``SkylakeX``
(tests/planners/svr_mpc/test_authors_regime_replay.py). OpenBLAS reads its choice from the
environment once, when it loads, and has no call to change it later; so dopt sets
``OPENBLAS_CORETYPE=Haswell`` when it is imported before numpy, on a Linux x86-64 CPU that runs
AVX2 and FMA, unless the user set the variable (theirs wins). Imported after numpy, dopt can
only report the kernels (``kernels``; provenance's ``machine()["blas"]`` records them with
every result). On AVX-512 machines the Haswell kernels are slower for large matrices; the
planners' matrices are at most a few hundred wide.
"""

import ctypes
import logging
import os
import platform
import sys
from pathlib import Path

log = logging.getLogger(__name__)

#: OpenBLAS's environment variable for its kernels, and the kernels dopt asks for
ENV = "OPENBLAS_CORETYPE"
PINNED = "Haswell"
#: the names numpy's and scipy's bundled OpenBLAS export for "which kernels run"
_CORENAME = ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename",
             "openblas_get_corename64_", "openblas_get_corename")


def pin() -> str | None:
    """Ask OpenBLAS for the ``PINNED`` kernels before numpy loads it. Returns the kernels the
    environment now names (the user's own ``OPENBLAS_CORETYPE`` if set), or None where dopt
    leaves OpenBLAS to choose: numpy already loaded, or a CPU the pin may not run on (not
    Linux x86-64 with AVX2 and FMA)."""
    if ENV in os.environ:
        return os.environ[ENV]
    if "numpy" in sys.modules:
        log.debug("numpy was imported before dopt: OpenBLAS keeps the kernels it chose")
        return None
    if not _runs_avx2():
        return None
    os.environ[ENV] = PINNED
    return PINNED


def _runs_avx2() -> bool:
    if platform.system() != "Linux" or platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    flags = cpuinfo("flags").split()
    return "avx2" in flags and "fma" in flags


def cpuinfo(field: str) -> str:
    """The value of ``field`` ("model name", "flags", ...) for the first processor in Linux's
    /proc/cpuinfo, stripped; "" where the file or the field is absent (not Linux)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, sep, value = line.partition(":")
                if sep and key.strip() == field:
                    return value.strip()
    except OSError:
        pass
    return ""


def kernels() -> str | None:
    """The kernels numpy's OpenBLAS runs in this process ("Haswell", "SkylakeX", ...; it
    imports numpy), or None where numpy computes with another BLAS (Accelerate, in the
    arm64 wheels for macOS 14 and later) or its OpenBLAS does not say. The wheels bundle
    OpenBLAS beside the package (``numpy.libs`` on Linux and Windows) or inside it
    (``numpy/.dylibs`` on macOS)."""
    import numpy

    pkg = Path(numpy.__file__).resolve().parent
    found = [path for libs in (pkg.parent / "numpy.libs", pkg / ".dylibs")
             for pattern in ("libscipy_openblas*", "libopenblas*")
             for path in sorted(libs.glob(pattern))]
    for path in found:
        try:
            lib = ctypes.CDLL(str(path))           # already loaded: the same library
        except OSError:
            continue
        for name in _CORENAME:
            fn = getattr(lib, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                core = fn()
                return core.decode().strip() if core else None
    return None
