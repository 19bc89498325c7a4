#!/usr/bin/env python3
"""Time an FMU replay under FMPy against ``airsus simulate`` on the same run (BENCHMARKS.md).

Usage: ``python3 tools/fmu/bench_fmu.py [--airsus target/release/airsus] [--repeat 5]``.
Generates the reference study (seed 1), exports m1, m2 and truck, and prints the median
wall time of ``fmpy.simulate_fmu`` over data-set 3 (600 s at 0.1 s) and of ``airsus simulate``
(the process, file reading and writing included).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import check_fmu


def median_seconds(action, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        action()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    airsus_default, _ = check_fmu.default_paths()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--airsus", type=Path, default=airsus_default)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        check_fmu.airsus(args.airsus, "generate", "--out", str(work / "ref"), "--seed", "1")
        run_path, truck = work / "ref" / "ds3.csv", work / "ref" / "truck.toml"
        run = check_fmu.read_run(run_path)
        print(f"{'model':<6} {'FMU (FMPy)':>12} {'airsus simulate':>16}")
        for model in check_fmu.DEFAULT_MODELS:
            fmu = work / f"{model}.fmu"
            check_fmu.airsus(
                args.airsus, "fmu", "--model", model, "--truck", str(truck), "--out", str(fmu)
            )
            fmu_s = median_seconds(
                lambda fmu=fmu: check_fmu.simulate_fmu(fmu, run, {}), args.repeat
            )
            command = [str(args.airsus), "simulate", "--model", model, "--truck", str(truck)]
            command += ["--run", str(run_path), "--out", str(work / "sim.csv")]
            cli_s = median_seconds(
                lambda command=command: subprocess.run(command, check=True, capture_output=True),
                args.repeat,
            )
            print(f"{model:<6} {fmu_s:>11.3f}s {cli_s:>15.3f}s")


if __name__ == "__main__":
    main()
