#!/usr/bin/env python3
"""Check airsus FMUs with FMPy (issue #18).

For each model (default m1, m2, truck):

1. ``airsus fmu`` exports it; ``fmpy.validation.validate_fmu`` must report no problem;
2. ``fmpy.simulate_fmu`` driven by a run's inputs must match ``airsus simulate`` on the same
   run: NRMSE >= 99.9 % on height and pressure;
3. a tunable parameter set through ``start_values`` must change the result as ``airsus
   simulate`` with the edited truck file does (NRMSE >= 99.9 % against that), and the change must
   be visible (the edited and nominal simulations differ by more than the tolerance).

The run defaults to data-set 3 of ``airsus generate`` (valve pulses at constant load).

About runs with load steps (data-sets 1, 2): a co-simulation master reads a step's outputs
*before* it sets the next inputs (FMI 2.0 §4.2.4 forbids reading outputs after setting inputs
without a step in between), so at the sample where the wheel load jumps the FMU's height still
carries the old load's lever flex (eq 3.14, about 0.6 mm per 300 kg), while ``airsus simulate``
samples output k under input k. The state trajectories are the same; only those few samples
differ. Valve runs (data-sets 3, 4) have no feed-through and compare sample for sample.

Usage::

    python3 tools/fmu/check_fmu.py [--airsus target/release/airsus]
        [--library target/release/libairsus_fmu.so] [--models m1,m2,truck]
        [--run RUN.csv --truck TRUCK.toml] [--work DIR]

Exit status 0 when every check passes, 1 otherwise.
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
THRESHOLD = 99.9
DEFAULT_MODELS = ("m1", "m2", "truck")
# The tunable parameter of the check and its truck-file home: the gas-volume cross-section's
# constant term (eq 5.1), present in every lever model; +10 % changes the pressure swing of a
# valve pulse by about as much.
PARAMETER = ("a0", "bellow", "cross_section_m2", 0, 1.10)
INPUTS = ("wheel_load_kg", "valve", "supply_kpa", "road_mm", "road_rate_mm_s")
OUTPUTS = ("height_mm", "pressure_kpa")


class CheckFailed(Exception):
    pass


def airsus(binary: Path, *args: str) -> str:
    """Runs the airsus CLI; its stderr is the message of a failure."""
    done = subprocess.run([str(binary), *args], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise CheckFailed(f"airsus {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return done.stderr


def read_run(path: Path) -> dict[str, np.ndarray]:
    """A run file (SPEC §5): the inputs, and the outputs when present."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise CheckFailed(f"{path}: no samples")
    names = rows[0].keys()
    run = {"time_s": np.array([float(r["time_s"]) for r in rows])}
    for name in ("wheel_load_kg", "supply_kpa", "road_mm", "height_mm", "pressure_kpa"):
        if name in names:
            run[name] = np.array([float(r[name]) for r in rows])
    run["valve"] = np.array([int(float(r["valve"])) for r in rows], dtype=np.int32)
    run.setdefault("road_mm", np.zeros(len(rows)))
    # The FMU moves the road at this rate over a step: the slope towards the next sample, as
    # `airsus simulate` follows a run's road (0 at the last sample).
    rate = np.zeros(len(rows))
    rate[:-1] = np.diff(run["road_mm"]) / np.diff(run["time_s"])
    run["road_rate_mm_s"] = rate
    return run


def nrmse(y: np.ndarray, yhat: np.ndarray) -> float:
    """NRMSE in percent, thesis eq 3.33: 100 (1 - ||y - yhat|| / ||y - mean(y)||)."""
    spread = np.linalg.norm(y - np.mean(y))
    if spread == 0.0:
        return 100.0 if np.allclose(y, yhat) else float("-inf")
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / spread))


def input_signals(run: dict[str, np.ndarray]) -> np.ndarray:
    """The run's inputs as FMPy wants them: a structured array, 'time' first."""
    dtype = [
        ("time", np.float64),
        ("wheel_load_kg", np.float64),
        ("valve", np.int32),
        ("supply_kpa", np.float64),
        ("road_mm", np.float64),
        ("road_rate_mm_s", np.float64),
    ]
    signals = np.zeros(len(run["time_s"]), dtype=dtype)
    signals["time"] = run["time_s"]
    for name in INPUTS:
        signals[name] = run[name]
    return signals


def sample_time(run: dict[str, np.ndarray]) -> float:
    t = run["time_s"]
    return float((t[-1] - t[0]) / (len(t) - 1))


def simulate_fmu(fmu: Path, run: dict[str, np.ndarray], start_values: dict, logger=None):
    """``fmpy.simulate_fmu`` over the run, sampled like the run: (height_mm, pressure_kpa)."""
    import fmpy

    t = run["time_s"]
    if "height_mm" not in run:
        raise CheckFailed("the run has no measured height to start from")
    values = {"initial_height_mm": float(run["height_mm"][0])}
    values.update(start_values)
    result = fmpy.simulate_fmu(
        str(fmu),
        start_time=float(t[0]),
        stop_time=float(t[-1]),
        output_interval=sample_time(run),
        input=input_signals(run),
        output=list(OUTPUTS),
        start_values=values,
        logger=logger,
    )
    times = result["time"]
    if len(times) != len(t) or np.max(np.abs(times - t)) > 1e-6 * max(1.0, abs(t[-1])):
        raise CheckFailed(
            f"FMPy sampled {len(times)} points from {times[0]} to {times[-1]} s, the run has {len(t)}"
        )
    return np.asarray(result["height_mm"]), np.asarray(result["pressure_kpa"])


def edit_truck(text: str, factor: float) -> tuple[str, float, float]:
    """The truck file with PARAMETER's key scaled by ``factor``: (text, old, new). Only that
    number changes; the rest of the file (comments included) stays as it was."""
    _, section, key, index, _ = PARAMETER
    lines = text.splitlines(keepends=True)
    current = None
    for i, line in enumerate(lines):
        header = re.match(r"^\s*\[([^\]]+)\]\s*(#.*)?$", line)
        if header:
            current = header.group(1).strip()
            continue
        if current != section:
            continue
        m = re.match(rf"^(\s*{re.escape(key)}\s*=\s*\[)([^\]]*)(\].*)$", line, re.S)
        if not m:
            continue
        items = [s.strip() for s in m.group(2).split(",")]
        old = float(items[index])
        new = old * factor
        items[index] = repr(new)
        lines[i] = m.group(1) + ", ".join(items) + m.group(3)
        edited = "".join(lines)
        before, after = tomllib.loads(text), tomllib.loads(edited)
        if after[section][key][index] != new:
            raise CheckFailed(f"editing {section}.{key}[{index}] did not take")
        after[section][key][index] = old
        if after != before:
            raise CheckFailed(f"editing {section}.{key}[{index}] changed other keys")
        return edited, old, new
    raise CheckFailed(f"the truck file has no [{section}] {key} = [...] line")


def check_model(
    model: str,
    *,
    airsus_bin: Path,
    library: Path | None,
    run_path: Path,
    truck_path: Path,
    work: Path,
) -> list[str]:
    """All checks of one model; returns the failures (empty when all passed)."""
    failures: list[str] = []
    run = read_run(run_path)
    fmu = work / f"{model}.fmu"
    args = ["fmu", "--model", model, "--truck", str(truck_path), "--out", str(fmu)]
    if library is not None:
        args += ["--binary", str(library)]
    airsus(airsus_bin, *args)

    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(fmu))
    print(f"{model}: validate_fmu: {'no problems' if not problems else problems}")
    if problems:
        failures.append(f"{model}: validate_fmu reported {problems}")

    def simulate_cli(truck: Path, out: Path) -> dict[str, np.ndarray]:
        airsus(
            airsus_bin,
            "simulate",
            "--model",
            model,
            "--truck",
            str(truck),
            "--run",
            str(run_path),
            "--out",
            str(out),
            # The FMU starts in static equilibrium at the run's first height; so does this.
            "--initial-state",
            "equilibrium",
        )
        return read_run(out)

    def compare(what: str, reference: dict[str, np.ndarray], start_values: dict):
        height, pressure = simulate_fmu(fmu, run, start_values)
        fits = (nrmse(reference["height_mm"], height), nrmse(reference["pressure_kpa"], pressure))
        print(
            f"{model}: {what}: NRMSE FMU vs airsus simulate: height {fits[0]:.4f} %, pressure {fits[1]:.4f} %"
        )
        for name, fit in zip(OUTPUTS, fits, strict=True):
            if not fit >= THRESHOLD:
                failures.append(f"{model}: {what}: {name} NRMSE {fit:.4f} % < {THRESHOLD} %")
        return height, pressure

    nominal = simulate_cli(truck_path, work / f"{model}_sim.csv")
    compare("nominal", nominal, {})

    name, section, key, index, factor = PARAMETER
    edited_text, old, new = edit_truck(truck_path.read_text(), factor)
    edited_truck = work / f"truck_{name}.toml"
    edited_truck.write_text(edited_text)
    edited = simulate_cli(edited_truck, work / f"{model}_sim_{name}.csv")
    compare(f"{name} = {new!r} (truck file: {old!r})", edited, {name: new})
    effect = nrmse(nominal["pressure_kpa"], edited["pressure_kpa"])
    print(f"{model}: the change of {name} moves the pressure to NRMSE {effect:.3f} % of nominal")
    if effect >= THRESHOLD:
        failures.append(
            f"{model}: changing {name} by {factor} barely changes the result (NRMSE {effect:.4f} %): the check would not see an ignored parameter"
        )
    return failures


def default_paths() -> tuple[Path, Path | None]:
    airsus_bin = Path(os.environ.get("AIRSUS_BIN", REPO / "target" / "release" / "airsus"))
    library = os.environ.get("AIRSUS_FMU_LIBRARY")
    return airsus_bin, (Path(library) if library else None)


def main(argv: list[str] | None = None) -> int:
    airsus_default, library_default = default_paths()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--airsus", type=Path, default=airsus_default)
    parser.add_argument(
        "--library",
        type=Path,
        default=library_default,
        help="libairsus_fmu.so (default: $AIRSUS_FMU_LIBRARY, else airsus finds it)",
    )
    parser.add_argument("--models", default=",".join(DEFAULT_MODELS))
    parser.add_argument("--run", type=Path, help="run CSV (default: ds3.csv of airsus generate)")
    parser.add_argument("--truck", type=Path, help="truck file (default: that of airsus generate)")
    parser.add_argument(
        "--work", type=Path, help="folder for the FMUs and CSVs (default: temporary)"
    )
    args = parser.parse_args(argv)

    if not args.airsus.is_file():
        print(
            f"error: {args.airsus} not found: build with `cargo build --release -p airsus -p airsus-fmu`",
            file=sys.stderr,
        )
        return 1
    work = args.work or Path(tempfile.mkdtemp(prefix="airsus-fmu-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        if args.run is None or args.truck is None:
            ref = work / "ref"
            airsus(args.airsus, "generate", "--out", str(ref), "--seed", "1")
            run_path = args.run or ref / "ds3.csv"
            truck_path = args.truck or ref / "truck.toml"
        else:
            run_path, truck_path = args.run, args.truck
        failures: list[str] = []
        for model in [m.strip() for m in args.models.split(",") if m.strip()]:
            try:
                failures += check_model(
                    model,
                    airsus_bin=args.airsus,
                    library=args.library,
                    run_path=run_path,
                    truck_path=truck_path,
                    work=work,
                )
            except CheckFailed as e:
                failures.append(f"{model}: {e}")
            except Exception as e:  # an FMPy exception is a failed check, not a crash
                failures.append(f"{model}: {type(e).__name__}: {e}")
    finally:
        if args.work is None:
            shutil.rmtree(work, ignore_errors=True)
    if failures:
        print("\nFAILED:", file=sys.stderr)
        for f in failures:
            print(f"  {f}", file=sys.stderr)
        return 1
    print("\nall FMU checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
