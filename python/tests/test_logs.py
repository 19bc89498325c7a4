"""Runs from logs (MDF4, Parquet, CAN) in Python, and Parquet written by airsus read by pyarrow.

The fixtures are those of the Rust tests (crates/logs/tests/fixtures), written from run.csv by
asammdf, pyarrow, cantools and python-can (tools/logs/make_fixtures.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

import airsus

FIXTURES = Path(__file__).resolve().parents[2] / "crates" / "logs" / "tests" / "fixtures"
MDF_COLUMNS = {
    "wheel_load_kg": "WheelLoad",
    "valve": "ValveCmd",
    "supply_kpa": "SupplyPressure",
    "height_mm": "AxleHeight",
    "pressure_kpa": "BellowPressure",
}


@pytest.fixture(scope="module")
def csv_run():
    return airsus.read_run(FIXTURES / "run.csv")


def assert_same(frame, reference, rows=None, shift_s=0.0):
    rows = len(reference) if rows is None else rows
    assert len(frame) == rows
    for column in reference.columns:
        expected = reference[column].to_numpy()[:rows] + (shift_s if column == "time_s" else 0.0)
        np.testing.assert_allclose(
            frame[column].to_numpy(), expected, rtol=1e-12, atol=1e-9, err_msg=column
        )


def test_an_mdf4_log_reads_as_the_csv_it_was_written_from(csv_run):
    run = airsus.read_run(FIXTURES / "run_plain.mf4", columns=MDF_COLUMNS)
    assert run.attrs["format"] == "MDF4"
    assert run.attrs["notes"] == []
    assert run["valve"].dtype == np.int64
    assert_same(run, csv_run)


def test_a_parquet_log_with_timestamps_and_a_unit_in_bar(csv_run):
    run = airsus.read_run(
        FIXTURES / "run.parquet",
        columns={"time_s": "timestamp", "supply_kpa": ("supply_bar", "bar")},
    )
    assert run.attrs["format"] == "Parquet"
    assert any("since 1970" in note for note in run.attrs["notes"])
    assert_same(run, csv_run)


def test_a_can_log_through_the_dbc_resampled_and_said_so(csv_run):
    run = airsus.read_run(
        FIXTURES / "run.log",
        columns={**MDF_COLUMNS, "valve": "ValveState"},
        dbc=FIXTURES / "truck.dbc",
        resample="zoh",
        sample_s=0.1,
    )
    assert any("zero-order hold" in note for note in run.attrs["notes"])
    assert_same(run, csv_run, rows=len(csv_run) - 1, shift_s=0.002)


def test_two_time_bases_without_resampling_raise_naming_the_file():
    with pytest.raises(airsus.AirsusError, match=r"run_two_bases\.mf4.*different time bases"):
        airsus.read_run(FIXTURES / "run_two_bases.mf4", columns=MDF_COLUMNS)
    with pytest.raises(airsus.AirsusError, match="needs `sample_s`"):
        airsus.read_run(FIXTURES / "run_two_bases.mf4", columns=MDF_COLUMNS, resample="zoh")


def test_parquet_written_by_airsus_is_read_by_pyarrow(csv_run, tmp_path):
    path = tmp_path / "run.parquet"
    airsus.write_run(csv_run, path)
    table = pq.read_table(path)
    assert table.column_names[:2] == ["time_s", "valve"]
    assert b"units" in table.schema.metadata
    frame = table.to_pandas()
    for column in ["time_s", "wheel_load_kg", "supply_kpa", "height_mm", "pressure_kpa"]:
        np.testing.assert_allclose(frame[column], csv_run[column], rtol=1e-12, err_msg=column)
    assert (frame["valve"].to_numpy() == csv_run["valve"].to_numpy()).all()
    # And back through airsus.
    assert_same(airsus.read_run(path), csv_run)


def test_simulate_accepts_a_parquet_run_named_as_the_contract(tmp_path, csv_run):
    # A Parquet file with the contract's names is a run file like any CSV.
    parquet = tmp_path / "run.parquet"
    airsus.write_run(csv_run, parquet)
    truck = FIXTURES / "truck.toml"
    from_csv = airsus.simulate("truck", truck, FIXTURES / "run.csv")
    from_parquet = airsus.simulate("truck", truck, parquet)
    np.testing.assert_allclose(from_parquet["pressure_kpa"], from_csv["pressure_kpa"], rtol=1e-6)
