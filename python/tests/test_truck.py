"""Trucks: the reference truck, short names, range checks, files."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

import airsus

SPEC_NAMES = [
    "p0",
    "p1",
    "p2",
    "p3",
    "p4",
    "a0",
    "a1",
    "m2",
    "ig",
    "kf",
    "kw",
    "kscl",
    "rflow1",
    "rflow2",
    "ksd",
]
# Ours after the SPEC's: the area-integral volume law's dead volume, the damper table's scale,
# the tire's damping.
NAMES = [*SPEC_NAMES, "vd", "dscl", "cw"]


def test_the_reference_truck_has_the_spec_values() -> None:
    truck = airsus.Truck.builtin()
    assert truck["m2"] == 520.0
    assert truck["p1"] == 0.8362, "the corrected effective-area coefficient"
    assert truck["kw"] == 1.8e6
    assert truck["rflow1"] == 2.5e6
    assert truck.keys() == NAMES
    assert "kscl" in truck and "l3" not in truck


def test_parameters_are_set_by_short_name_within_their_range() -> None:
    truck = airsus.Truck.builtin()
    truck["m2"] = 600.0
    assert truck["m2"] == 600.0
    assert airsus.Truck.builtin()["m2"] == 520.0, "a new truck is independent"
    with pytest.raises(airsus.AirsusError, match="outside its admissible range 10 to 3000 kg"):
        truck["m2"] = -1.0
    with pytest.raises(airsus.AirsusError, match="outside its admissible range"):
        truck["kw"] = math.nan
    assert truck["m2"] == 600.0, "a rejected value leaves the parameter unchanged"
    did_you_mean = r"no parameter `rflwo1` \(did you mean `rflow1`\?\)"
    with pytest.raises(airsus.AirsusError, match=did_you_mean):
        truck["rflwo1"]


def test_parameters_table() -> None:
    table = airsus.Truck.builtin().parameters()
    assert list(table.columns) == ["name", "unit", "value", "min", "max", "description"]
    assert table["name"].tolist() == NAMES
    row = table.set_index("name").loc["m2"]
    assert (row["unit"], row["value"], row["min"], row["max"]) == ("kg", 520.0, 10.0, 3000.0)


def test_a_truck_file_round_trips(tmp_path: Path) -> None:
    truck = airsus.Truck.builtin()
    truck["m2"] = 612.5
    truck["p1"] = 0.83
    path = tmp_path / "truck.toml"
    truck.save(path)
    back = airsus.Truck.load(path)
    assert back == truck
    assert back["m2"] == 612.5 and back["p1"] == 0.83
    assert back.to_toml() == path.read_text()
    assert back.defaulted == []
    assert airsus.Truck.from_toml(path.read_text()) == truck


def test_a_truck_file_error_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "truck.toml"
    text = airsus.Truck.builtin().to_toml().replace("l3_m", "l3_mm", 1)
    path.write_text(text)
    pattern = rf"^{re.escape(str(path))}:\d+: unknown key `geometry\.l3_mm`"
    with pytest.raises(airsus.AirsusError, match=pattern):
        airsus.Truck.load(path)


def test_the_builtin_truck_is_the_commands(cli) -> None:
    printed = cli("params", "--builtin").stdout
    assert airsus.Truck.builtin().to_toml() == printed


def test_a_truck_under_the_area_integral_volume_law(tmp_path: Path) -> None:
    text = airsus.Truck.builtin().to_toml()
    text = re.sub(r"cross_section_m2 = \[[^\]]*\][^\n]*\n", "", text)
    text += '\n[bellow.gas_volume]\nlaw = "area_integral"\ndead_volume_m3 = 0.05\n'
    truck = airsus.Truck.from_toml(text)
    assert truck["vd"] == 0.05 and truck["dscl"] == 1.0 and truck["cw"] == 0.0
    with pytest.raises(airsus.AirsusError, match="its gas-volume law `area_integral`"):
        truck["a0"]
    assert "vd=0.05" in repr(truck) and "a0=" not in repr(truck)
    assert "a0=0.25" in repr(airsus.Truck.builtin())
    table = truck.parameters().set_index("name")["value"]
    assert math.isnan(table["a0"]) and table["vd"] == 0.05


def test_a_truck_under_a_spline_effective_area(tmp_path: Path) -> None:
    text = airsus.Truck.builtin().to_toml()
    text = re.sub(r"effective_area_poly_m2 = \[[^\]]*\][^\n]*\n", "", text)
    text += (
        '\n[bellow.effective_area]\nlaw = "spline"\n'
        "heights_m = [0.22, 0.3, 0.4]\nareas_m2 = [0.056, 0.054, 0.048]\n"
    )
    truck = airsus.Truck.from_toml(text)
    assert truck["s1"] == 0.054
    truck["s1"] = 0.055
    assert truck["s1"] == 0.055
    with pytest.raises(airsus.AirsusError, match="its effective-area law `spline`"):
        truck["p1"]
    with pytest.raises(airsus.AirsusError, match="effective-area law `spline`"):
        truck["s5"]
    table = truck.parameters().set_index("name")["value"]
    assert list(table.index[-3:]) == ["s0", "s1", "s2"]
    assert math.isnan(table["p1"]) and table["s2"] == 0.048
    assert "p1=" not in repr(truck)
    # What the file says survives a round trip through the text.
    assert airsus.Truck.from_toml(truck.to_toml())["s1"] == 0.055
