"""Runs: reading, writing, and errors that name file, line and column like the command's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import airsus
from conftest import read_csv_exact

GOOD = (
    "time_s,wheel_load_kg,valve,supply_kpa,height_mm,pressure_kpa\n"
    "0.0,2830,0,850,240.0,350.0\n"
    "0.1,2830,1,850,240.1,350.2\n"
    "0.2,3130,2,849.5,239.0,361.0\n"
)


def test_read_run_gives_the_file_values_in_file_units(tmp_path: Path) -> None:
    path = tmp_path / "ds1.csv"
    path.write_text(GOOD)
    run = airsus.read_run(path)
    assert list(run.columns) == list(airsus.RUN_COLUMNS)
    assert run["valve"].tolist() == [0, 1, 2]
    assert run["road_mm"].tolist() == [0.0, 0.0, 0.0], "the optional column takes its default"
    assert run["height_mm"].tolist() == [240.0, 240.1, 239.0]
    assert run["supply_kpa"].tolist() == [850.0, 850.0, 849.5]
    assert run.attrs["name"] == "ds1"
    assert run.attrs["sample_time_s"] == pytest.approx(0.1)


def test_an_inputs_only_run_has_no_output_columns(tmp_path: Path) -> None:
    path = tmp_path / "scenario.csv"
    path.write_text("time_s,wheel_load_kg,valve,supply_kpa\n0,2830,0,850\n1,2830,0,850\n")
    run = airsus.read_run(path)
    assert list(run.columns) == ["time_s", "wheel_load_kg", "valve", "supply_kpa", "road_mm"]


def test_a_generated_run_reads_back_bit_for_bit(reference: Path) -> None:
    path = reference / "ds3.csv"
    run = airsus.read_run(path)
    raw = read_csv_exact(path)
    for column, values in raw.items():
        assert run[column].to_numpy(dtype=float).tobytes() == np.array(values).tobytes(), column


def test_write_run_round_trips_exactly(reference: Path, tmp_path: Path) -> None:
    run = airsus.read_run(reference / "ds2.csv")
    out = tmp_path / "copy.csv"
    airsus.write_run(run, out)
    back = airsus.read_run(out)
    pd.testing.assert_frame_equal(run, back, check_exact=True)
    # Written twice, the same bytes.
    again = tmp_path / "again.csv"
    airsus.write_run(back, again)
    assert out.read_bytes() == again.read_bytes()


def test_write_run_accepts_a_dict_of_arrays_and_orders_the_columns(tmp_path: Path) -> None:
    t = np.arange(5) * 0.1
    out = tmp_path / "scenario.csv"
    airsus.write_run(
        {
            "valve": np.zeros(5),
            "time_s": t,
            "supply_kpa": np.full(5, 850.0),
            "wheel_load_kg": np.full(5, 2830.0),
            "comment": ["x"] * 5,
        },
        out,
    )
    assert out.read_text().splitlines()[0] == "time_s,wheel_load_kg,valve,supply_kpa,road_mm"
    assert out.read_text().splitlines()[2] == "0.1,2830,0,850,0"


def test_a_bad_cell_names_file_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(GOOD.replace("0.1,2830,1,", "0.1,2830,3,"))
    with pytest.raises(airsus.AirsusError) as err:
        airsus.read_run(path)
    assert isinstance(err.value, ValueError)
    assert str(err.value) == (
        f"{path}:3:3 (column `valve`): expected valve state 0 (closed), 1 (fill) or 2 "
        "(exhaust), found `3`"
    )


def test_errors_carry_the_commands_message(tmp_path: Path, cli) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(GOOD.replace("0.2,3130", "0.5,3130"))
    truck = tmp_path / "truck.toml"
    airsus.Truck.builtin().save(truck)
    with pytest.raises(airsus.AirsusError) as err:
        airsus.simulate("m2", truck, path)
    result = cli(
        "simulate",
        "--model",
        "m2",
        "--truck",
        truck,
        "--run",
        path,
        "--out",
        tmp_path / "sim.csv",
        check=False,
    )
    assert result.returncode != 0
    assert result.stderr.strip() == f"error: {err.value}"
    assert str(err.value).startswith(f"{path}:")
    assert "(column `time_s`): non-uniform sampling" in str(err.value)


def test_a_frame_is_checked_like_a_file(tmp_path: Path) -> None:
    path = tmp_path / "ds1.csv"
    path.write_text(GOOD)
    run = airsus.read_run(path)
    run.loc[1, "valve"] = 3
    run.attrs["name"] = "mine"
    with pytest.raises(airsus.AirsusError, match=r"^DataFrame `mine`:3:3 \(column `valve`\)"):
        airsus.write_run(run, tmp_path / "out.csv")
    assert not (tmp_path / "out.csv").exists()
    missing = airsus.read_run(path).drop(columns=["supply_kpa"])
    with pytest.raises(airsus.AirsusError, match="required column `supply_kpa` is missing"):
        airsus.write_run(missing, tmp_path / "out.csv")
    nan = airsus.read_run(path)
    nan.loc[2, "height_mm"] = np.nan
    with pytest.raises(airsus.AirsusError, match="expected a finite number, found `NaN`"):
        airsus.write_run(nan, tmp_path / "out.csv")
