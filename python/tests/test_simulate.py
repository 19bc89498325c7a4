"""Simulation: the command's numbers to the last bit, from files and from frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import airsus
from conftest import read_csv_exact

MODELS = ["m1", "m2", "m2x", "m2xh", "m3", "truck"]


def test_the_model_registry() -> None:
    registry = airsus.models()
    assert registry["name"].tolist() == MODELS
    assert list(registry.columns) == [
        "name",
        "description",
        "parameters",
        "units",
        "states",
        "roles",
        "default_free",
        "valve_free",
        "road_free",
        "road_refit",
    ]
    m2 = registry.set_index("name").loc["m2"]
    assert "m2" in m2["parameters"] and "p0" in m2["parameters"]
    assert len(m2["states"]) == 5
    assert m2["roles"][m2["states"].index("n_mol")] == "bellow_air"
    assert m2["default_free"] == ["p0", "p1", "p2", "p3", "p4", "m2", "ig"]
    assert m2["road_free"] == ["dscl"] and "dscl" in m2["parameters"]
    assert registry.set_index("name").loc["m3"]["road_free"] == []
    truck = registry.set_index("name").loc["truck"]
    assert truck["road_refit"] == ["dscl", "kw", "ig", "kf"] and m2["road_refit"] == []
    assert truck["roles"][truck["states"].index("gas_t_k")] == "gas_temperature"


@pytest.mark.parametrize("model", MODELS)
def test_simulate_equals_the_command_bit_for_bit(
    model: str, reference: Path, short_run: Path, tmp_path: Path, cli
) -> None:
    truck = reference / "truck.toml"
    out = tmp_path / f"sim_{model}.csv"
    cli("simulate", "--model", model, "--truck", truck, "--run", short_run, "--out", out)
    expected = read_csv_exact(out)
    sim = airsus.simulate(model, truck, short_run)
    for column in ("time_s", "height_mm", "pressure_kpa"):
        got = sim[column].to_numpy()
        want = np.array(expected[column])
        diff = np.max(np.abs(got - want))
        assert got.tobytes() == want.tobytes(), f"{model} {column}: max difference {diff}"


def test_a_frame_simulates_like_its_file(reference: Path, short_run: Path) -> None:
    truck = airsus.Truck.load(reference / "truck.toml")
    from_file = airsus.simulate("m2", truck, short_run)
    frame = airsus.read_run(short_run)
    from_frame = airsus.simulate("m2", truck, frame)
    from_dict = airsus.simulate("m2", truck, {c: frame[c].to_numpy() for c in frame.columns})
    for other in (from_frame, from_dict):
        for column in ("time_s", "height_mm", "pressure_kpa"):
            assert other[column].to_numpy().tobytes() == from_file[column].to_numpy().tobytes()
    assert from_file.attrs["model"] == "m2"
    # The default start: the history states fitted to the run's first seconds.
    assert "fitted to the first seconds" in from_file.attrs["initial"]
    assert from_file.attrs["nrmse"]["height_mm"] is not None


def test_states_and_initial_conditions(reference: Path, short_run: Path) -> None:
    truck = reference / "truck.toml"
    run = airsus.read_run(short_run)
    sim = airsus.simulate("m2", truck, run, initial_state="equilibrium", states=True)
    assert sim.attrs["initial"].startswith("static equilibrium at sensor height")
    states = airsus.models().set_index("name").loc["m2"]["states"]
    assert list(sim.columns) == ["time_s", "height_mm", "pressure_kpa", *states]
    # Starting from a given state (the state at the first sample) reproduces the run.
    x0 = sim.loc[0, states].to_numpy(dtype=float)
    again = airsus.simulate("m2", truck, run, initial_state=x0)
    np.testing.assert_allclose(again["height_mm"], sim["height_mm"], rtol=0, atol=1e-6)
    # An inputs-only scenario needs an initial condition.
    inputs = run.drop(columns=["height_mm", "pressure_kpa"])
    with pytest.raises(airsus.AirsusError, match="has no measured outputs to start from"):
        airsus.simulate("m2", truck, inputs)
    by_height = airsus.simulate("m2", truck, inputs, {"height_mm": float(run["height_mm"][0])})
    np.testing.assert_array_equal(by_height["height_mm"], sim["height_mm"])
    p0 = float(sim["pressure_kpa"][0])
    by_pressure = airsus.simulate("m2", truck, inputs, {"pressure_kpa": p0})
    assert by_pressure["pressure_kpa"][0] == pytest.approx(p0, abs=1e-6)


def test_unknown_model_gets_a_suggestion(reference: Path, short_run: Path) -> None:
    with pytest.raises(airsus.AirsusError, match=r"unknown model `m22` \(did you mean"):
        airsus.simulate("m22", reference / "truck.toml", short_run)


def test_the_prefix_start_fits_the_history_states_as_the_command_does(
    reference: Path, tmp_path: Path, cli
) -> None:
    # The virtual truck's true parameters on data-set 3: only the start differs.
    truck = reference / "truth" / "truck.toml"
    run = reference / "ds3.csv"
    out = tmp_path / "prefix.csv"
    cli(
        "simulate", "--model", "truck", "--truck", truck, "--run", run, "--out", out,
        "--initial-state", "prefix",
    )  # fmt: skip
    expected = read_csv_exact(out)
    sim = airsus.simulate("truck", truck, run, initial_state="prefix")
    assert sim["pressure_kpa"].to_numpy().tobytes() == np.array(expected["pressure_kpa"]).tobytes()
    assert "fitted to the first seconds" in sim.attrs["initial"]
    equilibrium = airsus.simulate("truck", truck, run, initial_state="equilibrium")
    assert sim.attrs["nrmse"]["pressure_kpa"] > 90.0 > equilibrium.attrs["nrmse"]["pressure_kpa"]
    with pytest.raises(airsus.AirsusError, match="unknown start `prefx`"):
        airsus.simulate("truck", truck, run, initial_state="prefx")
    # `joint` belongs to an estimation (greybox, study), as the command says.
    with pytest.raises(airsus.AirsusError, match="a simulation fits none"):
        airsus.simulate("truck", truck, run, initial_state="joint")


def test_an_eased_load_simulates_as_the_command_and_differs_from_the_steps(
    reference: Path, short_run: Path, tmp_path: Path, cli
) -> None:
    truck = reference / "truck.toml"
    out = tmp_path / "eased.csv"
    cli(
        "simulate", "--model", "m2", "--truck", truck, "--run", short_run,
        "--out", out, "--load-ramp-s", "5",
    )  # fmt: skip
    expected = read_csv_exact(out)
    eased = airsus.simulate("m2", truck, short_run, load_ramp_s=5.0)
    assert eased["height_mm"].tolist() == expected["height_mm"]
    assert eased["pressure_kpa"].tolist() == expected["pressure_kpa"]
    stepped = airsus.simulate("m2", truck, short_run)
    assert np.max(np.abs(eased["height_mm"] - stepped["height_mm"])) > 0.5
    with pytest.raises(airsus.AirsusError, match="expected a transition time"):
        airsus.simulate("m2", truck, short_run, load_ramp_s=-1.0)
