"""Two ways to give an OpenSCENARIO file other parameter values in esmini's library.

Usage: SITCOV_ESMINI=../shared/tools/esmini/bin/esmini python benchmarks/esmini_parameters.py

A: rewrite the declaration (``ScenarioFile.render``) and load the text with
``SE_InitWithString`` (what the esmini backend does); B: load the file unchanged with
``SE_Init`` and set the value in the parameter-declaration callback
(``SE_RegisterParameterDeclarationCallback`` + ``SE_SetParameterDouble``). Printed: the value
esmini reads back (``SE_GetParameterDouble``) and the median load time of 30 loads each.
"""

from __future__ import annotations

import ctypes
import statistics
import time
from pathlib import Path

from sitcov.sim.esmini._lib import PARAM_CALLBACK, library
from sitcov.sim.esmini._scenario import ScenarioFile

SCENARIO = Path(__file__).resolve().parent.parent / "examples" / "esmini" / "crossing.xosc"
VALUE = 23.5
LOADS = 30


def main() -> None:
    lib = library()
    lib.SE_SetOptionPersistent(b"disable_stdout")
    lib.SE_SetOptionPersistent(b"disable_log")
    file = ScenarioFile(SCENARIO)

    def read() -> float:
        value = ctypes.c_double()
        lib.SE_GetParameterDouble(b"TriggerDistance", ctypes.byref(value))
        return value.value

    times, seen = [], 0.0
    for _ in range(LOADS):
        start = time.perf_counter()
        lib.SE_InitWithString(file.render({"TriggerDistance": VALUE}).encode(), 0, 0, 0, 0)
        times.append(time.perf_counter() - start)
        seen = read()
        lib.SE_Close()
    median = 1000 * statistics.median(times)
    print(f"A rewritten declaration: reads {seen}, median load {median:.1f} ms")

    @PARAM_CALLBACK
    def set_value(_: object) -> None:
        lib.SE_SetParameterDouble(b"TriggerDistance", VALUE)

    times = []
    for _ in range(LOADS):
        start = time.perf_counter()
        lib.SE_RegisterParameterDeclarationCallback(set_value, None)
        lib.SE_Init(str(SCENARIO).encode(), 0, 0, 0, 0)
        times.append(time.perf_counter() - start)
        seen = read()
        lib.SE_Close()
    median = 1000 * statistics.median(times)
    print(f"B declaration callback: reads {seen}, median load {median:.1f} ms")


if __name__ == "__main__":
    main()
