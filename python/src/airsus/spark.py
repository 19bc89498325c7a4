"""The fleet jobs on Apache Spark: ``python -m airsus.spark weigh|calibrate|leaks``.

::

    python -m airsus.spark calibrate --fleet FLEET --out OUT [--master local[2]]
    python -m airsus.spark weigh --fleet FLEET --out OUT [--calibration OUT/calibrate]
    python -m airsus.spark leaks --fleet FLEET --out OUT

Each job reads the fleet's Parquet logs (``FLEET/logs``, partitioned by ``truck_id``), groups
them by truck and applies the task's per-truck function of :mod:`airsus.fleet` with
``applyInPandas``: the airsus wheel does the work on the executors, Spark only distributes it.
The result is written as Parquet to ``OUT/<task>/`` (one row per standstill, per truck, or per
truck and day; schemas in :data:`airsus.fleet.SCHEMAS`), the same rows that
:func:`airsus.fleet.run_local` computes without Spark.

On a cluster, ship a packed environment with airsus to the executors and run this file as the
driver script (it imports airsus absolutely), e.g.::

    spark-submit --master yarn --archives airsus_env.tar.gz#env \\
        --conf spark.pyspark.python=./env/bin/python \\
        "$(python -c 'import airsus.spark as s; print(s.__file__)')" \\
        weigh --fleet s3a://bucket/fleet --out s3a://bucket/results

(``PYSPARK_PYTHON`` must name a Python that has ``airsus`` installed on every executor.)
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence

import pandas as pd

# Absolute, so that spark-submit can run this file as the driver script.
from airsus import fleet


def _read_text(spark: Any, path: str) -> str:
    """A small text file, local or on any file system Spark reads (hdfs://, s3a://)."""
    if "://" not in path:
        try:
            with open(path, encoding="utf-8") as f:
                return f.read()
        except OSError as e:
            raise SystemExit(f"error: cannot read {path}: {e.strerror}") from None
    return str(spark.read.text(path, wholetext=True).first()[0])


def session(master: Optional[str], app_name: str, conf: Sequence[str] = ()) -> Any:
    """A Spark session. With a ``local[...]`` master the driver binds to 127.0.0.1 and the web
    UI is off (nothing listens beyond this machine); without one (spark-submit's master)
    nothing is overridden. ``conf`` items are ``key=value``."""
    from pyspark.sql import SparkSession

    builder = SparkSession.builder.appName(app_name)
    if master:
        builder = builder.master(master)
    # Only when asked for local mode here: under spark-submit (master None) the cluster's
    # executors must reach the driver at its own address.
    if master and master.startswith("local"):
        builder = (
            builder.config("spark.driver.host", "127.0.0.1")
            .config("spark.driver.bindAddress", "127.0.0.1")
            .config("spark.ui.enabled", "false")
        )
    builder = builder.config("spark.sql.execution.arrow.pyspark.enabled", "true")
    for item in conf:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"error: --conf {item!r} is not key=value")
        builder = builder.config(key, value)
    return builder.getOrCreate()


def _apply(
    task: str, truck_text: str, calibration: Optional[Dict[int, Dict[str, Any]]]
) -> Callable[[pd.DataFrame], pd.DataFrame]:
    """The function Spark applies to each truck's rows: everything it needs travels in the
    closure (the truck file's text, the calibrations as plain dicts)."""

    def per_truck(pdf: pd.DataFrame) -> pd.DataFrame:
        return fleet.run_task(task, pdf, truck_text, calibration)

    return per_truck


#: How the trucks' rows reach the per-truck function (``auto``: ``files`` for a local master
#: and a plain path, where every task sees the driver's files; ``groupby`` otherwise).
MODES = ("auto", "groupby", "files")


def resolve_mode(spark: Any, mode: str, fleet_dir: str) -> str:
    """The mode ``auto`` stands for on this session and fleet path (see :data:`MODES`)."""
    if mode != "auto":
        return mode
    master = str(spark.sparkContext.master)
    return "files" if master.startswith("local") and "://" not in fleet_dir else "groupby"


def _per_truck_files(
    per_truck: Callable[[pd.DataFrame], pd.DataFrame],
) -> Callable[[Iterator[pd.DataFrame]], Iterator[pd.DataFrame]]:
    """For ``mode="files"``: each row names a truck and its folder; the executor reads the
    truck's Parquet files itself and applies the per-truck function."""

    def apply(batches: Iterator[pd.DataFrame]) -> Iterator[pd.DataFrame]:
        for batch in batches:
            for truck_id, folder in zip(batch["truck_id"], batch["folder"]):
                yield per_truck(fleet.read_truck_logs(str(folder), int(truck_id)))

    return apply


def run_job(
    spark: Any,
    task: str,
    fleet_dir: str,
    out: Optional[str] = None,
    *,
    calibration: Optional[str] = None,
    mode: str = "auto",
) -> pd.DataFrame:
    """Runs a task over the fleet on ``spark``; writes ``out/<task>/`` when ``out`` is given
    and returns the result collected to the driver, sorted as :func:`airsus.fleet.run_local`
    sorts it.

    ``mode="groupby"``: Spark reads the logs and hands each truck's rows to the function
    (``groupBy("truck_id").applyInPandas``): any file system Spark reads, at the price of a
    shuffle of every row. ``mode="files"``: Spark distributes the list of trucks and each task
    reads its truck's files with pyarrow (``mapInPandas``): no shuffle, for a fleet folder
    every executor sees at the same path (local, NFS, a mounted bucket). Both give the same
    rows; ``files`` costs a fraction of ``groupby`` (BENCHMARKS.md). ``mode="auto"``:
    :func:`resolve_mode`."""
    if mode not in MODES:
        raise SystemExit(f"error: unknown mode {mode!r}; the modes are: {', '.join(MODES)}")
    ddl = fleet.spark_ddl(task)
    if out is not None:
        try:
            fleet.refuse_output_over_inputs(
                os.path.join(out, task), fleet.fleet_inputs(fleet_dir, calibration)
            )
        except ValueError as e:
            raise SystemExit(f"error: {e}") from None
    logs = os.path.join(fleet_dir, "logs")
    if not os.path.isdir(logs) and "://" not in fleet_dir:
        raise SystemExit(f"error: {fleet_dir} holds no fleet: {logs} is not a folder")
    truck_text = _read_text(spark, os.path.join(fleet_dir, "truck.toml"))
    cal: Optional[Dict[int, Dict[str, Any]]] = None
    if calibration is not None:
        if task != "weigh":
            raise SystemExit("error: --calibration goes with weigh")
        # A local result is read without a Spark job (a job costs about a second).
        rows = (
            pd.read_parquet(calibration)
            if "://" not in calibration
            else spark.read.parquet(calibration).toPandas()
        )
        cal = {int(r["truck_id"]): dict(r) for _, r in rows.iterrows()}
    per_truck = _apply(task, truck_text, cal)
    if resolve_mode(spark, mode, fleet_dir) == "files":
        try:
            trucks = fleet.fleet_trucks(fleet_dir)
        except ValueError as e:
            raise SystemExit(f"error: {e}") from None
        # Two tasks a core: a task per truck costs ~0.1 s of scheduling and worker round trip
        # each (measured: +15 % on 20 trucks at local[2]); two a core still balance the load.
        slices = max(1, min(len(trucks), 2 * spark.sparkContext.defaultParallelism))
        listing = spark.sparkContext.parallelize(
            [(truck_id, folder) for truck_id, folder in trucks], numSlices=slices
        ).toDF("truck_id long, folder string")
        result = listing.mapInPandas(_per_truck_files(per_truck), schema=ddl)
    else:
        frame = spark.read.parquet(logs)
        if "truck_id" not in frame.columns:
            raise SystemExit(f"error: {logs} is not partitioned by truck_id (truck_id=K/ folders)")
        # Only what the tasks read crosses the shuffle.
        wanted = [c for c in frame.columns if c in fleet.LOG_COLUMNS or c == "truck_id"]
        result = frame.select(*wanted).groupBy("truck_id").applyInPandas(per_truck, schema=ddl)
    if out is None:
        return fleet.sort_result(task, result.toPandas())
    # Computed once: written from the cache, collected from it.
    result = result.persist()
    try:
        result.write.mode("overwrite").parquet(os.path.join(out, task))
        return fleet.sort_result(task, result.toPandas())
    finally:
        result.unpersist()


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m airsus.spark",
        description="airsus fleet jobs on Apache Spark: weigh, calibrate or find leaks per "
        "truck over a fleet's Parquet logs.",
    )
    parser.add_argument("task", choices=fleet.TASKS)
    parser.add_argument("--fleet", required=True, help="the fleet folder (logs/, truck.toml)")
    parser.add_argument("--out", required=True, help="results go to OUT/<task>/ as Parquet")
    parser.add_argument("--master", default=None, help="Spark master, e.g. local[2] or yarn")
    parser.add_argument(
        "--calibration",
        default=None,
        help="weigh: a calibrate result (OUT/calibrate) to correct each truck's loads",
    )
    parser.add_argument(
        "--mode",
        choices=MODES,
        default="auto",
        help="groupby: Spark reads the logs and groups them by truck (a shuffle); files: "
        "Spark distributes the trucks and each task reads its own files (no shuffle; the "
        "fleet folder must be at the same path on every executor); auto (default): files "
        "for a local master and a plain path, else groupby",
    )
    parser.add_argument(
        "--conf", action="append", default=[], metavar="KEY=VALUE", help="Spark settings"
    )
    args = parser.parse_args(argv)
    spark = session(args.master, f"airsus-{args.task}", args.conf)
    try:
        result = run_job(
            spark,
            args.task,
            args.fleet,
            args.out,
            calibration=args.calibration,
            mode=args.mode,
        )
    finally:
        spark.stop()
    trucks = result["truck_id"].nunique() if len(result) else 0
    print(
        f"{args.task}: {len(result)} rows for {trucks} trucks -> "
        f"{os.path.join(args.out, args.task)}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
