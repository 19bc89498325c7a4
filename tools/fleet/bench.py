"""Benchmark of the fleet jobs (issue #17): truck-days per core-hour for `weigh` and
`calibrate`, in one process without Spark, in a local pool of two processes, and on Spark
local[1] and local[2]; Spark's overhead against the same work without it.

    python tools/fleet/bench.py --fleet FLEET            # a fleet from `airsus fleet generate`
    python tools/fleet/bench.py --generate 8 --airsus target/release/airsus

Each figure is the best of `--repeat` runs, end to end: reading the Parquet logs, the work,
collecting the result (Spark also writes it). The Spark session's start (JVM) is timed apart:
a cluster pays it once per job, not per truck. Prints a Markdown table for BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from functools import partial
from typing import Callable, List, Tuple

from airsus import fleet


def best_of(repeat: int, work: Callable[[], object]) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        work()
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fleet", help="a generated fleet folder")
    parser.add_argument("--generate", type=int, default=0, help="generate N trucks x 1 day")
    parser.add_argument("--airsus", default="airsus", help="the airsus command to generate with")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-spark", action="store_true")
    args = parser.parse_args()

    scratch = tempfile.mkdtemp(prefix="airsus-fleet-bench-")
    try:
        fleet_dir = args.fleet
        if fleet_dir is None:
            if args.generate <= 0:
                parser.error("give --fleet or --generate N")
            fleet_dir = os.path.join(scratch, "fleet")
            subprocess.run(
                [
                    args.airsus,
                    "fleet",
                    "generate",
                    "--trucks",
                    str(args.generate),
                    "--out",
                    fleet_dir,
                ],
                check=True,
            )
        trucks = fleet.fleet_trucks(fleet_dir)
        days = sum(
            len([f for f in os.listdir(folder) if f.endswith(".parquet")]) for _, folder in trucks
        )
        calibration = fleet.run_local("calibrate", fleet_dir, processes=1)
        rows: List[Tuple[str, str, int, float]] = []
        for task in ("weigh", "calibrate"):
            extra = {"calibration": calibration} if task == "weigh" else {}
            for processes in (1, 2):
                seconds = best_of(
                    args.repeat,
                    partial(fleet.run_local, task, fleet_dir, processes=processes, **extra),
                )
                label = "one process" if processes == 1 else "local pool, 2 processes"
                rows.append((task, label, processes, seconds))

        spark_start = float("nan")
        if not args.no_spark:
            os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
            from airsus import spark as airsus_spark

            cal_path = os.path.join(scratch, "calibrate.parquet")
            calibration.to_parquet(cal_path, index=False)
            for cores in (1, 2):
                started = time.perf_counter()
                session = airsus_spark.session(f"local[{cores}]", "airsus-bench")
                spark_start = time.perf_counter() - started
                try:
                    for task, mode in [
                        (t, m) for t in ("weigh", "calibrate") for m in airsus_spark.MODES
                    ]:
                        out = os.path.join(scratch, f"out-{cores}")
                        kwargs = {"calibration": cal_path} if task == "weigh" else {}
                        seconds = best_of(
                            args.repeat,
                            partial(
                                airsus_spark.run_job,
                                session,
                                task,
                                fleet_dir,
                                out,
                                mode=mode,
                                **kwargs,
                            ),
                        )
                        rows.append((task, f"Spark local[{cores}], {mode}", cores, seconds))
                finally:
                    session.stop()

        print(f"{len(trucks)} trucks, {days} truck-days (24 h at 10 Hz each)\n")
        print(
            "| task | how | cores | time (s) | s per truck-day per core | truck-days per core-hour | Spark overhead |"
        )
        print("|---|---|---|---|---|---|---|")
        plain = {(t, c): s for t, how, c, s in rows if not how.startswith("Spark")}
        for task, how, cores, seconds in rows:
            per_day = seconds * cores / days
            overhead = ""
            if how.startswith("Spark"):
                overhead = f"{100 * (seconds / plain[(task, cores)] - 1):+.0f} %"
            print(
                f"| {task} | {how} | {cores} | {seconds:.2f} | {per_day:.3f} | "
                f"{3600 / per_day:.0f} | {overhead} |"
            )
        if not args.no_spark:
            print(f"\nSpark session start (JVM, not in the figures): {spark_start:.1f} s")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
