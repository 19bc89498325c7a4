"""Linear identification: exact recovery, the command's numbers, model verbs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import airsus


def arx_data(n: int = 400) -> dict:
    """y(t) = 0.8 y(t-1) + 0.5 u(t-1), noise-free, u a deterministic pseudo-random signal."""
    u = np.array([((k * 7919) % 13) - 6.0 for k in range(n)])
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1]
    return {"u": u, "y": y}


def test_arx_recovers_a_known_system_exactly() -> None:
    model = airsus.ident(arx_data(), "arx", "u", "y", na=1, nb=1, nk=1, ts_s=0.1)
    assert model.parameters["a1"] == pytest.approx(-0.8, abs=1e-9)
    assert model.parameters["b1"] == pytest.approx(0.5, abs=1e-9)
    assert model.polynomials["a"] == pytest.approx([1.0, -0.8], abs=1e-9)
    assert model.ts_s == 0.1
    assert model.fit == pytest.approx(100.0, abs=1e-6)
    data = arx_data()
    np.testing.assert_allclose(model.simulate(data["u"]), data["y"], atol=1e-8)
    np.testing.assert_allclose(model.predict(data, k=1), data["y"], atol=1e-8)
    assert "ARX" in str(model)


def test_detrended_model_works_on_the_original_scale() -> None:
    data = arx_data()
    shifted = {"u": data["u"] + 100.0, "y": data["y"] + 250.0}
    model = airsus.ident(shifted, "arx", ["u"], "y", na=1, nb=1, nk=1, ts_s=0.1, detrend=True)
    assert model.offsets is not None
    sim = model.simulate(shifted)
    assert sim.shape == (400,)
    assert abs(np.mean(sim) - 250.0) < 5.0


def two_path_run(n: int, gain: float, held: bool, seed: int) -> dict:
    """y = 0.5/(1 - 0.8 q^-1) u1(t-1) + 0.3/(1 - 0.8 q^-1) u2(t-1) + noise, with
    u2 = gain * u1 (+ its own signal when u1 is held), as ``cli_ident``'s merge test."""
    rng = np.random.default_rng(seed)
    u1 = np.zeros(n) if held else np.repeat(rng.choice([-1.0, 1.0], n // 20), 20)
    u2 = gain * u1 + (rng.uniform(-1.0, 1.0, n) if held else 0.0)
    y = np.zeros(n)
    x1 = x2 = 0.0
    for t in range(1, n):
        x1 = 0.8 * x1 + 0.5 * u1[t - 1]
        x2 = 0.8 * x2 + 0.3 * u2[t - 1]
        y[t] = x1 + x2
    y += rng.uniform(-0.05, 0.05, n)
    return {"u1": u1, "u2": u2, "y": y}


def test_merged_runs_determine_what_neither_does_alone() -> None:
    loading = two_path_run(3000, 0.8, held=False, seed=1)
    valve = two_path_run(3000, 0.0, held=True, seed=2)
    orders = dict(nb=1, nf=1, nk=1, ts_s=0.1)
    model = airsus.ident(loading, "oe", ["u1", "u2"], "y", merge=valve, **orders)
    truth = {"b1(u1)": 0.5, "b1(u2)": 0.3, "f1(u1)": -0.8, "f1(u2)": -0.8}
    for name, value in truth.items():
        assert model.parameters[name] == pytest.approx(value, abs=0.02), name
    assert model.report["merged"][0]["samples"] == 3000
    with pytest.raises(airsus.AirsusError, match="rank deficient"):
        airsus.ident(loading, "oe", ["u1", "u2"], "y", **orders)
    # ARX merges too (both paths share the pole 0.8: A = 1 - 0.8 q^-1).
    arx = airsus.ident(loading, "arx", ["u1", "u2"], "y", na=1, nb=1, nk=1, ts_s=0.1, merge=[valve])
    for name, value in {"a1": -0.8, "b1(u1)": 0.5, "b1(u2)": 0.3}.items():
        assert arx.parameters[name] == pytest.approx(value, abs=0.02), name
    assert arx.report["merged"][0]["samples"] == 3000


def test_orders_the_structure_lacks_are_rejected() -> None:
    with pytest.raises(airsus.AirsusError, match="na does not apply to OE models"):
        airsus.ident(arx_data(), "oe", "u", "y", na=1, nb=1, nf=1, nk=1, ts_s=0.1)
    with pytest.raises(airsus.AirsusError, match="has no time_s column: pass the sample time"):
        airsus.ident(arx_data(), "arx", "u", "y", na=1, nb=1, nk=1)


def test_ident_equals_the_command(short_run: Path, cli) -> None:
    printed = cli(
        "ident",
        "--structure",
        "arx",
        "--na",
        "2",
        "--nb",
        "2",
        "--nk",
        "1",
        "--inputs",
        "wheel_load_kg",
        "--output",
        "height_mm",
        "--detrend",
        "--json",
        short_run,
    ).stdout
    expected = json.loads(printed)
    for data in (short_run, airsus.read_run(short_run)):
        model = airsus.ident(
            data, "arx", ["wheel_load_kg"], "height_mm", na=2, nb=2, nk=1, detrend=True
        )
        assert model.report["estimate"]["parameters"] == expected["estimate"]["parameters"]
        assert model.report["ts_s"] == expected["ts_s"]
        assert model.report["offsets"] == expected["offsets"]
