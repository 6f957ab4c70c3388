"""vprobot pins the numeric libraries' kernels to AVX2 on every CPU that has it, so that results
do not depend on the CPU (vprobot/compute/kernels.py, results/cpu_spread/): checked against the
libraries' own report of the kernels they loaded (threadpoolctl, torch)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vprobot.compute.kernels import AVX2_KERNELS, has_avx2_and_fma, pin

INTEL_AVX512 = ("flags\t\t: fpu vme sse sse2 ssse3 sse4_1 sse4_2 avx fma avx2 avx512f avx512dq "
                "avx512bw avx512vl")
OLD_CPU = "flags\t\t: fpu vme sse sse2 ssse3 sse4_1 sse4_2 avx"
AVX2_CPU = has_avx2_and_fma(Path("/proc/cpuinfo").read_text()) if sys.platform == "linux" else False


def test_avx2_and_fma_are_read_from_the_cpuinfo_flags() -> None:
    assert has_avx2_and_fma(f"processor\t: 0\n{INTEL_AVX512}\n")
    assert not has_avx2_and_fma(f"processor\t: 0\n{OLD_CPU}\n")
    assert not has_avx2_and_fma("processor\t: 0\nflags\t\t: avx2\n")  # no FMA
    assert not has_avx2_and_fma("")


@pytest.mark.skipif(not AVX2_CPU, reason="the kernels are pinned on CPUs with AVX2 and FMA")
def test_pin_sets_what_the_user_did_not(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in AVX2_KERNELS:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Sandybridge")
    chosen = pin()
    assert os.environ["OPENBLAS_CORETYPE"] == "Sandybridge"
    assert chosen == {name: value for name, value in AVX2_KERNELS.items()
                      if name != "OPENBLAS_CORETYPE"}
    assert all(os.environ[name] == value for name, value in chosen.items())


REPORT = """
import json
import vprobot, numpy, scipy.linalg, threadpoolctl, torch
print(json.dumps({"blas": sorted({(info["filepath"].rsplit("/", 1)[-1], info["architecture"])
                                  for info in threadpoolctl.threadpool_info()
                                  if info["internal_api"] == "openblas"}),
                  "torch": torch.backends.cpu.get_cpu_capability()}))
"""


@pytest.mark.skipif(not AVX2_CPU, reason="the kernels are pinned on CPUs with AVX2 and FMA")
def test_importing_vprobot_first_loads_the_avx2_kernels_whatever_the_cpu_would_pick() -> None:
    env = {name: value for name, value in os.environ.items() if name not in AVX2_KERNELS}
    out = subprocess.run([sys.executable, "-c", REPORT], env=env, check=True,
                         capture_output=True, text=True).stdout
    report = json.loads(out)
    # numpy's and scipy's OpenBLAS each report the kernels they run (an AVX-512 CPU would
    # report SkylakeX, and torch AVX512, without the pin).
    assert len(report["blas"]) == 2
    assert {architecture for _, architecture in report["blas"]} == {"Haswell"}
    assert report["torch"] == "AVX2"
