"""pytest: airsus FMUs under FMPy (issue #18).

Needs the release build (``cargo build --release -p airsus -p airsus-fmu``) and FMPy
(``pip install -r tools/fmu/requirements.txt``). Paths: ``$AIRSUS_BIN`` (default
``target/release/airsus``) and ``$AIRSUS_FMU_LIBRARY`` (default: found by ``airsus fmu``
beside the executable). Without the build the tests are skipped, except under CI (``$CI`` set),
where a missing build is a failure.

Run: ``python3 -m pytest tools/fmu -q``
"""

from __future__ import annotations

import os
import sys
from ctypes import byref, c_int, c_void_p
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import check_fmu  # noqa: E402

AIRSUS, LIBRARY = check_fmu.default_paths()


@pytest.fixture(scope="session")
def built() -> tuple[Path, Path | None]:
    if not AIRSUS.is_file():
        message = f"{AIRSUS} is missing: cargo build --release -p airsus -p airsus-fmu"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return AIRSUS, LIBRARY


@pytest.fixture(scope="session")
def reference(built, tmp_path_factory) -> Path:
    """The virtual truck's reference experiments (airsus generate, seed 1)."""
    out = tmp_path_factory.mktemp("ref")
    check_fmu.airsus(built[0], "generate", "--out", str(out), "--seed", "1")
    return out


@pytest.fixture(scope="session")
def fmus(built, reference, tmp_path_factory) -> dict[str, Path]:
    work = tmp_path_factory.mktemp("fmus")
    paths = {}
    for model in check_fmu.DEFAULT_MODELS:
        path = work / f"{model}.fmu"
        args = [
            "fmu",
            "--model",
            model,
            "--truck",
            str(reference / "truck.toml"),
            "--out",
            str(path),
        ]
        if built[1] is not None:
            args += ["--binary", str(built[1])]
        check_fmu.airsus(built[0], *args)
        paths[model] = path
    return paths


@pytest.mark.parametrize("run", ["ds1", "ds3"])
@pytest.mark.parametrize("model", check_fmu.DEFAULT_MODELS)
def test_matches_airsus_simulate_and_tunes(model, run, built, reference, tmp_path):
    """ds1: load steps and valve pulses (the estimation run); ds3: valve pulses."""
    failures = check_fmu.check_model(
        model,
        airsus_bin=built[0],
        library=built[1],
        run_path=reference / f"{run}.csv",
        truck_path=reference / "truck.toml",
        work=tmp_path,
    )
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("model", check_fmu.DEFAULT_MODELS)
def test_load_steps_differ_only_by_the_feed_through_at_the_step(
    model, built, reference, fmus, tmp_path
):
    """ds2 (six load steps): an FMI master reads the outputs at t_k before it sets u_k, so at
    a load step's sample the FMU's height carries the old load's lever flex, k_scl g dm (eq 3.14),
    where `airsus simulate` gives output(x(t_k), u_k). Everywhere else they agree."""
    from fmpy import read_model_description

    run_path = reference / "ds2.csv"
    run = check_fmu.read_run(run_path)
    sim_path = tmp_path / "sim.csv"
    check_fmu.airsus(
        built[0],
        "simulate",
        "--model",
        model,
        "--truck",
        str(reference / "truck.toml"),
        "--run",
        str(run_path),
        "--out",
        str(sim_path),
        "--initial-state",
        "equilibrium",
    )
    sim = check_fmu.read_run(sim_path)
    height, pressure = check_fmu.simulate_fmu(fmus[model], run, {})

    steps = np.nonzero(np.diff(run["wheel_load_kg"]))[0] + 1
    assert len(steps) >= 4
    away = np.ones(len(height), dtype=bool)
    away[steps] = False
    assert check_fmu.nrmse(sim["height_mm"][away], height[away]) >= 99.999
    assert check_fmu.nrmse(sim["pressure_kpa"], pressure) >= 99.999

    start = {v.name: v.start for v in read_model_description(str(fmus[model])).modelVariables}
    flex_mm_per_kg = float(start["kscl"]) * 9.81 * 1e3
    jumps = np.diff(run["wheel_load_kg"])[steps - 1]
    np.testing.assert_allclose(
        height[steps] - sim["height_mm"][steps], flex_mm_per_kg * jumps, rtol=1e-3
    )


# --- A host's life: FMPy's low-level API ------------------------------------------------------


class Host:
    """One FMU unzipped once, instances made with a logger that records every message."""

    def __init__(self, fmu: Path):
        from fmpy import extract, read_model_description

        self.md = read_model_description(str(fmu))
        self.unzipdir = extract(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages: list[tuple[int, str, str]] = []
        self._callbacks = []

    def callbacks(self):
        from fmpy import calloc, free
        from fmpy.fmi2 import (
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )

        def log(env, instance, status, category, message):
            self.messages.append(
                (
                    status,
                    category.decode() if category else "",
                    message.decode() if message else "",
                )
            )

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(log)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            from fmpy.logging import addLoggerProxy  # formats the printf-style message

            addLoggerProxy(byref(callbacks))
        except Exception:
            pass
        self._callbacks.append(callbacks)  # keep alive
        return callbacks

    def slave(self, name: str = "instance", guid: str | None = None):
        from fmpy.fmi2 import FMU2Slave

        slave = FMU2Slave(
            guid=guid or self.md.guid,
            unzipDirectory=self.unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        slave.instantiate(callbacks=self.callbacks(), loggingOn=True)
        return slave

    def start(self, slave, **start):
        slave.setupExperiment(startTime=0.0)
        for name, value in start.items():
            slave.setReal([self.vr[name]], [value])
        slave.enterInitializationMode()
        slave.exitInitializationMode()

    def outputs(self, slave) -> tuple[float, float]:
        h, p = slave.getReal([self.vr["height_mm"], self.vr["pressure_kpa"]])
        return h, p

    def run_pulses(
        self, slave, steps: list[float], valve_at=(0.5, 2.0), t0: float = 0.0
    ) -> tuple[list[tuple[float, float]], float]:
        """Steps of the given sizes from t0, filling from valve_at[0] to valve_at[1] s: the
        outputs after each step and the end time. (Times are sums of step sizes, as the FMU
        sums them; the valve windows allow for their rounding.)"""
        t, out = t0, []
        for h in steps:
            fill = valve_at[0] - 1e-9 <= t < valve_at[1] - 1e-9
            slave.setInteger([self.vr["valve"]], [1 if fill else 0])
            slave.doStep(t, h)
            t += h
            out.append(self.outputs(slave))
        return out, t


@pytest.fixture()
def host(fmus):
    return Host(fmus["m2"])


def test_every_fmi2_symbol_is_exported(fmus):
    from ctypes import CDLL

    from fmpy import extract

    unzipdir = Path(extract(str(fmus["m2"])))
    lib = CDLL(str(unzipdir / "binaries" / "linux64" / "airsus_fmu.so"))
    names = """GetTypesPlatform GetVersion SetDebugLogging Instantiate FreeInstance SetupExperiment
    EnterInitializationMode ExitInitializationMode Terminate Reset GetReal GetInteger GetBoolean
    GetString SetReal SetInteger SetBoolean SetString GetFMUstate SetFMUstate FreeFMUstate
    SerializedFMUstateSize SerializeFMUstate DeSerializeFMUstate GetDirectionalDerivative
    EnterEventMode NewDiscreteStates EnterContinuousTimeMode CompletedIntegratorStep SetTime
    SetContinuousStates GetDerivatives GetEventIndicators GetContinuousStates
    GetNominalsOfContinuousStates SetRealInputDerivatives GetRealOutputDerivatives DoStep
    CancelStep GetStatus GetRealStatus GetIntegerStatus GetBooleanStatus GetStringStatus""".split()
    assert len(names) == 44
    for name in names:
        assert hasattr(lib, "fmi2" + name), name


def test_several_instances_are_independent(host):
    a, b = host.slave("a"), host.slave("b")
    host.start(a)
    host.start(b, initial_height_mm=250.0)
    steps = [0.1] * 30
    ya, _ = host.run_pulses(a, steps)
    yb, _ = host.run_pulses(b, steps)
    c = host.slave("c")
    host.start(c)
    yc, _ = host.run_pulses(c, steps)
    assert ya == yc, "the same inputs give the same outputs, whatever else runs"
    assert abs(yb[0][0] - ya[0][0]) > 5.0, "instance b started 10 mm higher"
    for s in (a, b, c):
        s.terminate()
        s.freeInstance()


def test_step_sizes_do_not_matter(host):
    fine, coarse = host.slave("fine"), host.slave("coarse")
    host.start(fine)
    host.start(coarse)
    host.run_pulses(fine, [0.01] * 300)
    # The coarse one changes the valve at the same instants, with odd sizes in between.
    t = 0.0
    for h, valve in [(0.5, 0), (0.37, 1), (1.13, 1), (0.0001, 0), (0.9999, 0)]:
        coarse.setInteger([host.vr["valve"]], [valve])
        coarse.doStep(t, h)
        t += h
    yf, yc = host.outputs(fine), host.outputs(coarse)
    assert abs(yf[0] - yc[0]) < 1e-2 and abs(yf[1] - yc[1]) < 5e-2, (yf, yc)
    for s in (fine, coarse):
        s.freeInstance()


def test_reset_and_reinstantiate_start_over(host):
    s = host.slave()
    host.start(s)
    first = host.run_pulses(s, [0.1] * 25)
    s.terminate()
    s.reset()
    host.start(s)
    assert host.run_pulses(s, [0.1] * 25) == first
    s.freeInstance()
    s = host.slave()
    host.start(s)
    assert host.run_pulses(s, [0.1] * 25) == first
    s.freeInstance()


def test_fmu_state_rewinds(host):
    s = host.slave()
    host.start(s)
    _, t = host.run_pulses(s, [0.1] * 10)
    state = s.getFMUstate()
    ahead = host.run_pulses(s, [0.1] * 10, valve_at=(0.0, 1.5), t0=t)
    s.setFMUstate(state)
    assert host.run_pulses(s, [0.1] * 10, valve_at=(0.0, 1.5), t0=t) == ahead
    s.freeFMUstate(state)
    s.freeInstance()


def test_errors_are_a_status_and_a_logged_message(host):
    from fmpy.fmi1 import FMICallException

    s = host.slave()
    host.start(s)
    with pytest.raises(FMICallException) as bad_valve:
        s.setInteger([host.vr["valve"]], [7])
    assert bad_valve.value.status == 3
    assert any("valve" in m and status == 3 for status, _, m in host.messages), host.messages
    with pytest.raises(FMICallException):
        s.doStep(5.0, 0.1)  # not where the last step ended
    with pytest.raises(FMICallException):
        s.setReal([host.vr["a0"]], [-1.0])  # outside its range: fmi2Discard
    # Model Exchange functions exist and refuse.
    enter_event_mode = s.dll.fmi2EnterEventMode
    enter_event_mode.argtypes = [c_void_p]
    enter_event_mode.restype = c_int
    assert enter_event_mode(s.component) == 3
    assert any("Co-Simulation only" in m for _, _, m in host.messages), host.messages
    # Still usable after refused calls.
    s.doStep(0.0, 0.1)
    s.freeInstance()


def test_an_impossible_start_fails_cleanly_and_reset_recovers(host):
    from fmpy.fmi1 import FMICallException

    s = host.slave()
    s.setupExperiment(startTime=0.0)
    s.setReal([host.vr["initial_height_mm"]], [2000.0])
    s.enterInitializationMode()
    with pytest.raises(FMICallException):
        s.exitInitializationMode()
    assert any("initial" in m for _, _, m in host.messages), host.messages
    s.reset()
    host.start(s)
    s.doStep(0.0, 0.1)
    s.freeInstance()


def test_a_foreign_guid_or_model_exchange_is_refused(host, fmus):
    with pytest.raises(Exception, match="Failed to instantiate"):
        host.slave(guid="{00000000-0000-0000-0000-000000000001}")
    assert any("GUID" in m for _, _, m in host.messages), host.messages
    from fmpy.fmi2 import FMU2Model

    model = FMU2Model(
        guid=host.md.guid,
        unzipDirectory=host.unzipdir,
        modelIdentifier=host.md.coSimulation.modelIdentifier,
        instanceName="me",
        requireFunctions=False,
    )
    with pytest.raises(Exception, match="Failed to instantiate"):
        model.instantiate(callbacks=host.callbacks())


def test_simulate_fmu_with_default_inputs_stays_at_rest(fmus):
    import fmpy

    result = fmpy.simulate_fmu(str(fmus["m2"]), stop_time=5.0, output_interval=0.1)
    assert np.allclose(result["height_mm"], 240.0, atol=0.05), result["height_mm"][:5]
