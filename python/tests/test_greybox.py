"""Grey-box estimation: a parameter is recovered from data its own model made; progress."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest

import airsus


def measured_by(truck: airsus.Truck, short_run: Path) -> pd.DataFrame:
    """The short run's inputs with the outputs `truck` simulates (no noise)."""
    run = airsus.read_run(short_run)
    sim = airsus.simulate("m2", truck, run)
    measured = run.copy()
    measured["height_mm"] = sim["height_mm"].to_numpy()
    measured["pressure_kpa"] = sim["pressure_kpa"].to_numpy()
    measured.attrs["name"] = "synthetic"
    return measured


def test_greybox_recovers_a_parameter(reference: Path, short_run: Path) -> None:
    nominal = airsus.Truck.load(reference / "truck.toml")
    truth = nominal.copy()
    truth["p0"] = nominal["p0"] + 0.002
    events = []
    fit = airsus.greybox(
        "m2", nominal, [measured_by(truth, short_run)], free=["p0"], progress=events.append
    )
    assert fit.converged, fit.stop_reason
    assert fit.estimates.loc["p0", "estimate"] == pytest.approx(truth["p0"], abs=1e-4)
    assert fit.estimates.loc["p0", "nominal"] == nominal["p0"]
    assert bool(fit.estimates.loc["p0", "identifiable"])
    # Both standard deviations: as if white, and with residuals correlated in time (here
    # of the solver's round-off: the data are noise-free).
    assert math.isfinite(fit.estimates.loc["p0", "std"])
    assert math.isfinite(fit.estimates.loc["p0", "std_correlated"])
    reported = fit.report["parameters"][0]["std_correlated"]
    assert reported == fit.estimates.loc["p0", "std_correlated"]
    assert fit.truck["p0"] == fit.estimates.loc["p0", "estimate"]
    assert fit.truck["m2"] == nominal["m2"], "only the freed parameter moves"
    assert fit.trades is None, "nothing was traded: one run, one parameter"
    assert list(fit.nrmse.index) == ["synthetic"]
    assert fit.nrmse.loc["synthetic", "pressure_estimated"] > 99.0
    assert fit.report["model"] == "m2"
    assert "Grey-box estimation, model m2" in str(fit)
    assert any(e["event"] == "stage" for e in events)
    assert any(e["event"] == "iteration" for e in events)


def test_a_raising_progress_callback_stops_the_call(reference: Path, short_run: Path) -> None:
    truck = airsus.Truck.load(reference / "truck.toml")

    def stop(event: dict) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        airsus.greybox("m2", truck, short_run, free="p0", max_iterations=2, progress=stop)


def test_bounds_must_name_a_freed_parameter(reference: Path, short_run: Path) -> None:
    truck = reference / "truck.toml"
    with pytest.raises(airsus.AirsusError, match="`m2` is not in free"):
        airsus.greybox("m2", truck, short_run, free="p0", bounds={"m2": (400.0, 600.0)})
    with pytest.raises(airsus.AirsusError, match="has no parameter `q0`"):
        airsus.greybox("m2", truck, short_run, free=["q0"])


def test_greybox_equals_the_command(reference: Path, short_run: Path, tmp_path: Path, cli) -> None:
    import json

    truck = reference / "truck.toml"
    out = tmp_path / "est.toml"
    printed = cli(
        "greybox",
        "--model",
        "m2",
        "--free",
        "p0,m2",
        "--truck",
        truck,
        "--run",
        short_run,
        "--max-iterations",
        "5",
        "--json",
        "--out",
        out,
    ).stdout
    expected = json.loads(printed)
    fit = airsus.greybox("m2", truck, short_run, free="p0,m2", max_iterations=5)
    for got, want in zip(fit.report["parameters"], expected["parameters"]):
        assert got["name"] == want["name"]
        assert got["estimate"] == want["estimate"], got["name"]
    assert fit.report["stop"] == expected["stop"]
    assert fit.truck == airsus.Truck.load(out)


def test_default_free_set_and_noise_weighting_equal_the_command(
    reference: Path, short_run: Path, cli
) -> None:
    import json

    truck = reference / "truck.toml"
    printed = cli(
        "greybox", "--model", "m2", "--truck", truck, "--run", short_run,
        "--normalisation", "noise-level", "--max-iterations", "3", "--json",
    ).stdout  # fmt: skip
    expected = json.loads(printed)
    fit = airsus.greybox("m2", truck, short_run, normalisation="noise-level", max_iterations=3)
    # No `free`: the registry's default set for m2 (no valve action in this run).
    names = [p["name"] for p in fit.report["parameters"]]
    assert names == airsus.models().set_index("name").loc["m2"]["default_free"]
    for got, want in zip(fit.report["parameters"], expected["parameters"]):
        assert (got["name"], got["estimate"]) == (want["name"], want["estimate"])
    with pytest.raises(airsus.AirsusError, match="normalisation `noise`"):
        airsus.greybox("m2", truck, short_run, normalisation="noise")


def test_logged_load_steps_are_eased_each_over_its_own_time(
    reference: Path, short_run: Path
) -> None:
    # The short run holds one logged load change, which the virtual truck's wheel took over
    # seconds: by default it is eased over a time estimated with the parameters.
    truck = reference / "truck.toml"
    eased = airsus.greybox("m2", truck, short_run, free="p0,m2", max_iterations=5)
    assert "logged load steps eased over" in eased.load, eased.load
    [[transition_s]] = eased.load_transitions_s
    assert 1.0 < transition_s <= 15.0
    assert eased.load_ramp_s is not None and 0.0 < eased.load_ramp_s <= 15.0
    logged = airsus.greybox(
        "m2", truck, short_run, free="p0,m2", max_iterations=5, load_ramp="logged"
    )
    assert (logged.load, logged.load_transitions_s, logged.load_ramp_s) == ("", [[]], None)
    fits = [f.nrmse.loc[f.nrmse.index[0]] for f in (logged, eased)]
    assert fits[1]["height_estimated"] > fits[0]["height_estimated"]
    with pytest.raises(airsus.AirsusError, match="load_ramp `bogus`"):
        airsus.greybox("m2", truck, short_run, free="p0", load_ramp="bogus")


def test_an_estimation_run_simulates_with_the_transitions_greybox_fitted(
    reference: Path, short_run: Path
) -> None:
    truck = reference / "truck.toml"
    fit = airsus.greybox("m2", truck, short_run, free="p0,m2", max_iterations=5)
    [transitions] = fit.load_transitions_s
    sim = airsus.simulate("m2", fit.truck, short_run, load_transitions_s=transitions)
    logged = airsus.simulate("m2", fit.truck, short_run)
    # The eased load explains the run better than the steps as logged, as in the fit.
    assert sim.attrs["nrmse"]["height_mm"] > logged.attrs["nrmse"]["height_mm"]
    with pytest.raises(airsus.AirsusError, match="1 logged load change"):
        airsus.simulate("m2", fit.truck, short_run, load_transitions_s=[3.0, 4.0])
    with pytest.raises(airsus.AirsusError, match="not both"):
        airsus.simulate("m2", fit.truck, short_run, load_ramp_s=3.0, load_transitions_s=transitions)


def test_greybox_takes_a_force_map(reference: Path, short_run: Path) -> None:
    nominal = airsus.Truck.load(reference / "truck.toml")
    truth = nominal.copy()
    truth["p0"] = nominal["p0"] + 0.002
    measured = measured_by(truth, short_run)
    fit = airsus.greybox(
        "m2",
        nominal,
        [measured],
        free=["p0"],
        force_map=reference / "force_map.csv",
        initial_state="equilibrium",
        load_ramp="logged",
        max_iterations=5,
    )
    # The map is the virtual truck's, whose area is not the nominal quartic's: it pulls p0
    # away from the value the run alone recovers, but the run still rules.
    assert fit.estimates.loc["p0", "estimate"] != pytest.approx(truth["p0"], abs=1e-9)
    assert fit.nrmse.loc["synthetic", "pressure_estimated"] > 90.0
    for bad, match in [
        ({"force_map_noise_n": 0.0}, "force_map_noise_n 0"),
        ({"force_map": reference / "no_map.csv"}, "no_map.csv"),
    ]:
        options = {"force_map": reference / "force_map.csv", **bad}
        with pytest.raises(airsus.AirsusError, match=match):
            airsus.greybox("m2", nominal, [measured], free=["p0"], max_iterations=1, **options)


def test_greybox_trades_no_estimation_run_for_the_others(reference: Path) -> None:
    """Model 3 from the reference file on four runs: its pooled estimate explained two runs'
    outputs worse than the file did; it is refitted with them weighted more (issue #12)."""
    runs = [reference / name for name in ("ds1.csv", "ds3.csv", "lev1.csv", "road1.csv")]
    events: list = []
    fit = airsus.greybox("m3", reference / "truck.toml", runs, progress=events.append)
    assert fit.trades is not None and "weighted more" in fit.trades, fit.trades
    # Each refit is announced while it runs.
    assert any(e["event"] == "stage" and "round 1 of at most" in e["message"] for e in events), (
        events
    )
    for output in ("height", "pressure"):
        gained = fit.nrmse[f"{output}_estimated"] - fit.nrmse[f"{output}_nominal"]
        assert (gained >= -0.1).all(), fit.nrmse
    # The note names each run and output the pooled estimate traded, with its score.
    assert "the pooled estimate explained" in fit.trades and "lev1's height -" in fit.trades

    # allow_trades keeps the pooled estimate (as MATLAB's greyest returns it) and names each
    # trade; no refit runs.
    events.clear()
    pooled = airsus.greybox(
        "m3", reference / "truck.toml", runs, progress=events.append, allow_trades=True
    )
    assert pooled.trades is not None and "kept as fitted (trades allowed)" in pooled.trades
    assert not any("round 1 of at most" in e.get("message", "") for e in events), events
    lost = pooled.nrmse["height_estimated"] - pooled.nrmse["height_nominal"]
    assert (lost < -0.1).any(), pooled.nrmse
