"""Shared fixtures: the virtual truck's reference experiments, a short run cut from them, and
the `airsus` command for comparisons (set AIRSUS_BIN to its path; .ci/run does)."""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
from pathlib import Path
from typing import Callable, Dict, List

import pytest

import airsus

# A few minutes of data-set 1: long enough to hold load steps, short enough to simulate fast.
SHORT_ROWS = 3000


def _airsus_bin() -> str | None:
    path = os.environ.get("AIRSUS_BIN")
    if path:
        if not Path(path).is_file():
            raise RuntimeError(f"AIRSUS_BIN={path} is not a file")
        return path
    return shutil.which("airsus")


@pytest.fixture(scope="session")
def cli() -> Callable[..., subprocess.CompletedProcess]:
    """Runs the `airsus` command; skips when it is not available."""
    binary = _airsus_bin()
    if binary is None:
        pytest.skip(
            "the airsus command is not available: build it (cargo build -p airsus) and set "
            "AIRSUS_BIN=target/debug/airsus to compare the Python results with it"
        )

    def run(*args: object, check: bool = True) -> subprocess.CompletedProcess:
        result = subprocess.run([binary, *(str(a) for a in args)], capture_output=True, text=True)
        if check and result.returncode != 0:
            raise AssertionError(f"airsus {' '.join(map(str, args))} failed:\n{result.stderr}")
        return result

    return run


@pytest.fixture(scope="session")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The virtual truck's reference study (seed 1), generated once per session."""
    out = tmp_path_factory.mktemp("reference")
    airsus.generate(out, seed=1)
    return out


@pytest.fixture(scope="session")
def short_run(reference: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first SHORT_ROWS samples of data-set 1, as a run file."""
    ds1 = airsus.read_run(reference / "ds1.csv")
    path = tmp_path_factory.mktemp("short") / "short.csv"
    airsus.write_run(ds1.iloc[:SHORT_ROWS].reset_index(drop=True), path)
    return path


def read_csv_exact(path: Path) -> Dict[str, List[float]]:
    """Columns of a CSV file parsed with Python's float() (correctly rounded, so the values
    are exactly the f64 the Rust writer printed in shortest round-trip form)."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [float(r[i]) for r in body] for i, name in enumerate(header)}
