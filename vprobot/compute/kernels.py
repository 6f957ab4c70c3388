"""The same arithmetic on every x86-64 CPU with AVX2: the numeric libraries' kernels pinned before
they load.

OpenBLAS (numpy's and scipy's), MKL and oneDNN (torch's) pick their kernels by the CPU they run
on: an AVX-512 machine sums the same matrix products in another order than an AVX2 one (and one
without FMA in yet another), and the last bits differ. vprobot's geometry goes through such
products, and a last-bit difference can move a sensed point across a voxel boundary or the
coverage's matching distance: a coverage then moves by a few ground-truth points and a planner
may choose another view (results/cpu_spread/). So, where the CPU has AVX2 and FMA, vprobot asks
each library for its AVX2 kernels (a setting the library documents), unless the user set the
variable; the results are then identical across Intel and AMD, AVX2 and AVX-512. On a CPU
without AVX2 the libraries choose as usual and results may differ in the last bits.

The libraries read these variables when they load, so `pin` runs before anything imports numpy
(`vprobot/__init__.py`); child processes inherit them.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

AVX2_KERNELS = {
    "OPENBLAS_CORETYPE": "Haswell",  # OpenBLAS's AVX2 + FMA kernels
    "MKL_CBWR": "AVX2",  # MKL's conditional numerical reproducibility
    "MKL_ENABLE_INSTRUCTIONS": "AVX2",
    "ONEDNN_MAX_CPU_ISA": "AVX2",
    "ATEN_CPU_CAPABILITY": "avx2",  # torch's own vectorised kernels
}
"""The variable and value that pins each library to its AVX2 kernels."""


def has_avx2_and_fma(cpuinfo: str) -> bool:
    """Whether the `flags` of /proc/cpuinfo's text name both AVX2 and FMA."""
    for line in cpuinfo.splitlines():
        if line.startswith("flags"):
            flags = set(line.partition(":")[2].split())
            return {"avx2", "fma"} <= flags
    return False


def pin() -> dict[str, str]:
    """Set each of `AVX2_KERNELS` the environment does not set yet, on an x86-64 Linux CPU with
    AVX2 and FMA; nothing elsewhere.

    Returns:
        The variables it set.
    """
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        return {}
    try:
        cpuinfo = Path("/proc/cpuinfo").read_text(errors="replace")
    except OSError:
        return {}
    if not has_avx2_and_fma(cpuinfo):
        return {}
    chosen = {name: value for name, value in AVX2_KERNELS.items() if name not in os.environ}
    os.environ.update(chosen)
    return chosen
