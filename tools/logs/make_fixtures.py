"""Write the log fixtures of crates/logs/tests/fixtures from run.csv with independent tools.

asammdf writes the MDF4 files (plain, DZ-compressed, two time bases), pyarrow the Parquet
files, cantools the DBC and the CAN frames' payloads, python-can the bus-logging MDF4. airsus
must read each of them into the same run as the CSV (crates/logs/tests/read_fixtures.rs); the
malformed ones must give errors that name the file and the channel.

    python3 -m venv /tmp/logvenv && /tmp/logvenv/bin/pip install -r tools/logs/requirements.txt
    /tmp/logvenv/bin/python tools/logs/make_fixtures.py

Run from the repository root. The outputs are small and committed; rerunning rewrites them.
"""

from __future__ import annotations

import datetime
import json
import pathlib

import asammdf
import can
import cantools
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from asammdf import MDF, Signal

FIXTURES = pathlib.Path("crates/logs/tests/fixtures")
# 2026-05-04 08:00:00 UTC: the logs' wall-clock start (candump and Parquet timestamps).
EPOCH_S = 1_777_881_600
START = datetime.datetime.fromtimestamp(EPOCH_S, datetime.UTC)
# J1939 proprietary-B groups as the DBC declares them: priority 6, source address 0x2F.
ASC1_DBC_ID = 0x18FF102F
LOAD1_DBC_ID = 0x18FF112F
# The frames on the bus come from another ECU (0x21) at priority 3: only the PGN matches.
ASC1_BUS_ID = 0x0CFF1021
LOAD1_BUS_ID = 0x0CFF1121
# A frame the DBC does not define (EEC1 from the engine), which a decoder must skip.
EEC1_BUS_ID = 0x0CF00400
# Load1 follows ASC1 by 2 ms in every 100 ms cycle.
LOAD1_DELAY_S = 0.002

DBC = f"""VERSION ""

NS_ :

BS_:

BU_: ASC ECU

BO_ {ASC1_DBC_ID | 0x80000000} ASC1: 8 ASC
 SG_ BellowPressure : 0|16@1+ (0.1,0) [0|6553.5] "kPa" ECU
 SG_ AxleHeight : 16|16@1+ (0.1,-100) [-100|6453.5] "mm" ECU
 SG_ ValveState : 32|2@1+ (1,0) [0|3] "" ECU

BO_ {LOAD1_DBC_ID | 0x80000000} Load1: 8 ASC
 SG_ WheelLoad : 7|16@0+ (0.5,0) [0|32767.5] "kg" ECU
 SG_ SupplyPressure : 23|16@0+ (0.5,0) [0|32767.5] "kPa" ECU

BA_DEF_ "ProtocolType" STRING ;
BA_DEF_ BO_ "VFrameFormat" ENUM "StandardCAN","ExtendedCAN","reserved","J1939PG";
BA_DEF_DEF_ "ProtocolType" "";
BA_DEF_DEF_ "VFrameFormat" "J1939PG";
BA_ "ProtocolType" "J1939";
BA_ "VFrameFormat" BO_ {ASC1_DBC_ID | 0x80000000} 3;
BA_ "VFrameFormat" BO_ {LOAD1_DBC_ID | 0x80000000} 3;
"""


def read_run() -> pd.DataFrame:
    return pd.read_csv(FIXTURES / "run.csv")


def plain_signals(run: pd.DataFrame, time: np.ndarray) -> list[Signal]:
    """The run as an engineer's logger names it: own names, bar, raw counts with conversions."""
    return [
        Signal(run.wheel_load_kg.to_numpy(), time, name="WheelLoad", unit="kg"),
        Signal(run.valve.to_numpy().astype(np.uint8), time, name="ValveCmd", unit=""),
        Signal(run.supply_kpa.to_numpy() / 100.0, time, name="SupplyPressure", unit="bar"),
        # Raw counts of 0.1 mm and 0.1 kPa, with linear conversion blocks (CC type 1).
        Signal(
            np.round(run.height_mm.to_numpy() * 10).astype(np.int16),
            time,
            name="AxleHeight",
            unit="mm",
            conversion={"a": 0.1, "b": 0.0},
        ),
        Signal(
            np.round(run.pressure_kpa.to_numpy() * 10).astype(np.uint16),
            time,
            name="BellowPressure",
            unit="kPa",
            conversion={"a": 0.1, "b": 0.0},
        ),
        Signal(np.full(len(time), 1200.0), time, name="EngineSpeed", unit="rpm"),
    ]


def write_mdf(run: pd.DataFrame) -> None:
    time = run.time_s.to_numpy()
    for name, compression in [
        ("run_plain.mf4", 0),
        ("run_dz.mf4", 1),
        ("run_dz_transposed.mf4", 2),
    ]:
        mdf = MDF(version="4.10")
        mdf.header.start_time = START
        mdf.append(plain_signals(run, time), comment="airsus fixture from run.csv")
        mdf.save(FIXTURES / name, overwrite=True, compression=compression)

    # Two time bases: the inputs at the CSV's samples, the outputs 50 ms later.
    shifted = time[:-1] + 0.05
    height = np.interp(shifted, time, run.height_mm.to_numpy())
    pressure = np.interp(shifted, time, run.pressure_kpa.to_numpy())
    inputs = [
        s for s in plain_signals(run, time) if s.name in ("WheelLoad", "ValveCmd", "SupplyPressure")
    ]
    outputs = [
        Signal(height, shifted, name="AxleHeight", unit="mm"),
        Signal(pressure, shifted, name="BellowPressure", unit="kPa"),
    ]
    mdf = MDF(version="4.10")
    mdf.header.start_time = START
    mdf.append(inputs, comment="valve controller, 10 Hz")
    mdf.append(outputs, comment="suspension sensors, 10 Hz, 50 ms later")
    mdf.save(FIXTURES / "run_two_bases.mf4", overwrite=True)

    # The reference resampling (numpy, not airsus): onto 0.1 s from the later start, linear
    # for the continuous signals, held for the valve.
    grid = 0.05 + 0.1 * np.arange(len(shifted))
    held = np.searchsorted(time, grid, side="right") - 1
    expected = pd.DataFrame(
        {
            "time_s": grid,
            "wheel_load_kg": np.interp(grid, time, run.wheel_load_kg.to_numpy()),
            "valve": run.valve.to_numpy()[held],
            "supply_kpa": np.interp(grid, time, run.supply_kpa.to_numpy()),
            "height_mm": np.interp(grid, shifted, height),
            "pressure_kpa": np.interp(grid, shifted, pressure),
        }
    )
    expected.to_csv(FIXTURES / "expected_two_bases_linear.csv", index=False, float_format="%.17g")

    data = (FIXTURES / "run_plain.mf4").read_bytes()
    (FIXTURES / "truncated.mf4").write_bytes(data[: len(data) // 2])
    (FIXTURES / "wrong_magic.mf4").write_bytes(b"MDX     " + data[8:400])


def write_parquet(run: pd.DataFrame) -> None:
    start = pd.Timestamp(EPOCH_S, unit="s", tz="UTC")
    table = pa.table(
        {
            "timestamp": pa.array(
                start + pd.to_timedelta(run.time_s, unit="s"), pa.timestamp("us", tz="UTC")
            ),
            "wheel_load_kg": run.wheel_load_kg.to_numpy(),
            "valve": pa.array(run.valve.to_numpy(), pa.int8()),
            "supply_bar": run.supply_kpa.to_numpy() / 100.0,
            "height_mm": run.height_mm.to_numpy(),
            "pressure_kpa": run.pressure_kpa.to_numpy(),
        }
    )
    units = {"supply_bar": "bar", "height_mm": "mm", "pressure_kpa": "kPa", "wheel_load_kg": "kg"}
    table = table.replace_schema_metadata(
        {**(table.schema.metadata or {}), b"units": json.dumps(units)}
    )
    pq.write_table(table, FIXTURES / "run.parquet")  # snappy, nullable columns

    # The contract's own names, zstd, several row groups, no metadata at all.
    plain = pa.Table.from_pandas(run.drop(columns=["road_mm"]), preserve_index=False)
    plain = plain.replace_schema_metadata({})
    pq.write_table(plain, FIXTURES / "run_zstd.parquet", compression="zstd", row_group_size=300)

    bad = pa.table(
        {
            "time_s": run.time_s.to_numpy(),
            "wheel_load_kg": run.wheel_load_kg.to_numpy(),
            "valve": run.valve.to_numpy(),
            "supply_kpa": run.supply_kpa.to_numpy(),
            "height_mm": run.height_mm.to_numpy(),
            "pressure_kpa": run.pressure_kpa.astype(str).to_numpy(),
        }
    )
    pq.write_table(bad, FIXTURES / "string_column.parquet")
    data = (FIXTURES / "run.parquet").read_bytes()
    (FIXTURES / "truncated.parquet").write_bytes(data[: int(len(data) * 0.6)])


def can_frames(run: pd.DataFrame, db: cantools.database.Database) -> list[can.Message]:
    """The run as J1939 frames every 100 ms, payloads encoded by cantools."""
    asc1 = db.get_message_by_name("ASC1")
    load1 = db.get_message_by_name("Load1")
    frames = []
    for row in run.itertuples():
        t = EPOCH_S + round(row.time_s * 1e6) / 1e6
        frames.append(
            can.Message(
                timestamp=t,
                arbitration_id=ASC1_BUS_ID,
                is_extended_id=True,
                data=asc1.encode(
                    {
                        "BellowPressure": row.pressure_kpa,
                        "AxleHeight": row.height_mm,
                        "ValveState": row.valve,
                    }
                ),
            )
        )
        frames.append(
            can.Message(
                timestamp=t + LOAD1_DELAY_S,
                arbitration_id=LOAD1_BUS_ID,
                is_extended_id=True,
                data=load1.encode(
                    {"WheelLoad": row.wheel_load_kg, "SupplyPressure": row.supply_kpa}
                ),
            )
        )
        frames.append(
            can.Message(
                timestamp=t + 0.004,
                arbitration_id=EEC1_BUS_ID,
                is_extended_id=True,
                data=bytes([0xF0, 0x7D, 0x7D, 0x40, 0x1F, 0xFF, 0xFF, 0xFF]),
            )
        )
    return frames


def write_can(run: pd.DataFrame) -> None:
    (FIXTURES / "truck.dbc").write_text(DBC)
    db = cantools.database.load_file(FIXTURES / "truck.dbc")
    frames = can_frames(run, db)

    # candump -l format, as python-can's CanutilsLogWriter writes it.
    with can.CanutilsLogWriter(FIXTURES / "run.log", channel="can0") as writer:
        for frame in frames:
            writer.on_message_received(frame)

    # ASAM MDF4 bus logging (CAN_DataFrame), as python-can's MF4Writer writes it.
    path = FIXTURES / "run_can.mf4"
    path.unlink(missing_ok=True)
    with can.io.MF4Writer(path) as writer:
        # MF4Writer counts time from when it was made; count from the log's start instead, so
        # the fixture does not depend on the day it was written (private, python-can 4.6).
        writer._mdf.header.start_time = START
        writer.last_timestamp = writer._start_time = float(EPOCH_S)
        for frame in frames:
            writer.on_message_received(frame)

    # A reference decode by cantools, matching on the PGN as J1939 does, for the first frames.
    rows = []
    for frame in frames[:30]:
        pgn = (frame.arbitration_id >> 8) & 0x3FFFF
        message = next((m for m in db.messages if (m.frame_id >> 8) & 0x3FFFF == pgn), None)
        if message is None:
            continue
        for name, value in message.decode(frame.data).items():
            rows.append(
                {"time_s": frame.timestamp - EPOCH_S, "signal": name, "value": float(value)}
            )
    pd.DataFrame(rows).to_csv(
        FIXTURES / "expected_can_decode.csv", index=False, float_format="%.10g"
    )


def main() -> None:
    run = read_run()
    write_mdf(run)
    write_parquet(run)
    write_can(run)
    versions = {
        "asammdf": asammdf.__version__,
        "pyarrow": pa.__version__,
        "cantools": cantools.__version__,
        "python-can": can.__version__,
        "numpy": np.__version__,
        "pandas": pd.__version__,
    }
    (FIXTURES / "VERSIONS.json").write_text(json.dumps(versions, indent=2) + "\n")
    for path in sorted(FIXTURES.iterdir()):
        print(f"{path.stat().st_size:>9}  {path.name}")


if __name__ == "__main__":
    main()
