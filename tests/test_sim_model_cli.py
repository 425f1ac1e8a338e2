"""Model-replay JSON and the `fxdsp simulate` command."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from fxdsp.cli import main
from fxdsp.sim import generate_log, read_log, read_model, write_model

MODEL = {
    "baseline": {"bias_poly": [1.5, -0.2, 0.01], "sf_poly": [12.0, 0.004], "t_ref_c": 20.0,
                 "f0_hz": 5000.0, "k_hz_per_c": -0.15},
    "effects": {"thermal_lag": {"tau_s": 2000.0}},
    "source": "fxdsp diagnose (extra top-level keys are ignored)",
}


def _write(tmp_path, data, name="m.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


def test_model_replay_uses_its_polynomials_and_effects(tmp_path):
    path = _write(tmp_path, MODEL)
    log, truth = generate_log("ramp", effects={}, seed=1, model=path, noise="off", return_truth=True)
    te = truth["Te"]
    # evaluate the JSON's definition by hand: ascending powers of (T - t_ref_c); freq = f0 + k T
    x = te - 20.0
    expected = (1.5 - 0.2 * x + 0.01 * x ** 2) + (12.0 + 0.004 * x) * log["rate_dps"]
    np.testing.assert_allclose(log["output"], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(log["freq_hz"], 5000.0 - 0.15 * te, rtol=1e-14)
    # the model's thermal lag is applied: Te trails temp_c during the 0.5 C/min ramps
    assert np.abs(log["temp_c"] - te).max() > 10.0
    # effects passed alongside the model win over the model's for the same cause
    log2, truth2 = generate_log("ramp", effects={"thermal_lag": {"tau_s": 10.0}}, seed=1, model=path,
                                noise="off", return_truth=True)
    assert np.abs(log2["temp_c"] - truth2["Te"]).max() < 0.2


def test_model_round_trip(tmp_path):
    model = read_model(_write(tmp_path, MODEL))
    write_model(tmp_path / "again.json", model)
    assert read_model(tmp_path / "again.json") == model
    assert model.effects == {"thermal_lag": {"tau_s": 2000.0}}


def _mutate(path, value):
    data = copy.deepcopy(MODEL)
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


@pytest.mark.parametrize("data, field", [
    (_mutate(("baseline",), KeyError), "baseline"),
    (_mutate(("baseline", "bias_poly"), KeyError), "bias_poly"),
    (_mutate(("baseline", "sf_poly"), []), "sf_poly"),
    (_mutate(("baseline", "sf_poly"), [1.0, "x"]), r"sf_poly\[1\]"),
    (_mutate(("baseline", "f0_hz"), None), "f0_hz"),
    (_mutate(("baseline", "t_ref_c"), True), "t_ref_c"),
    (_mutate(("baseline", "bias_polly"), [1.0]), "bias_polly"),
    (_mutate(("effects", "thermal_lag"), {"tau": 3.0}), "tau"),
    (_mutate(("effects", "thermal_lag"), {"tau_s": "3"}), "tau_s"),
    (_mutate(("effects", "drift"), {"r": 1.0}), "drift"),
    (_mutate(("effects",), []), "effects"),
    ([1, 2], "model"),
    ("{not json", "JSON"),
])
def test_read_model_rejects_bad_fields_by_name(tmp_path, data, field):
    with pytest.raises(ValueError, match=field):
        read_model(_write(tmp_path, data))


def test_partial_model_keeps_the_scenario_fields(tmp_path):
    """A diagnosis of a log without rate or frequency columns omits sf_poly, f0 and k: replaying it
    takes those from the scenario and the given fields from the model."""
    from fxdsp.sim import generate_log
    from fxdsp.sim.model import scenario_baseline
    partial = {"baseline": {"bias_poly": [5.0, 0.5]}, "effects": {}}
    log, truth = generate_log(scenario="paper001", model=read_model(_write(tmp_path, partial)), seed=1,
                              columns=("rate_dps", "freq_hz"), noise="off", return_truth=True)
    scen = scenario_baseline("paper001")
    assert truth["baseline"]["bias_poly"] == [5.0, 0.5]
    assert truth["baseline"]["k_hz_per_c"] == scen.k_hz_per_c and truth["baseline"]["sf_poly"] == list(scen.sf_poly)
    assert abs(np.polyfit(log["temp_c"], log["freq_hz"], 1)[0] - scen.k_hz_per_c) < 1e-9


def test_cli_writes_a_canonical_log(tmp_path):
    out = tmp_path / "run.csv"
    rc = main(["simulate", "--scenario", "ramp", "--effect", "thermal_lag=900",
               "--effect", "warmup.a=2", "--effect", "warmup.tau_s=600", "--seed", "3",
               "--columns", "ref_temp_c,freq_hz", "--out", str(out)])
    assert rc == 0
    log, comments = read_log(out)
    assert list(log) == ["time_s", "temp_c", "output", "ref_temp_c", "freq_hz"]
    assert json.loads(comments["effects"]) == {"thermal_lag": {"tau_s": 900.0},
                                               "warmup": {"a": 2.0, "tau_s": 600.0}}
    direct = generate_log("ramp", effects={"thermal_lag": {"tau_s": 900.0},
                                           "warmup": {"a": 2.0, "tau_s": 600.0}},
                          seed=3, columns=("ref_temp_c", "freq_hz"))
    for key in direct:
        np.testing.assert_allclose(log[key], direct[key], rtol=1e-11, atol=1e-9)


def test_cli_replays_a_model(tmp_path):
    out = tmp_path / "replay.csv"
    assert main(["simulate", "--scenario", "paper001", "--model", str(_write(tmp_path, MODEL)),
                 "--noise", "off", "--out", str(out)]) == 0
    log, _ = read_log(out)
    # paper 001's programme (zero rate) with the model's sensor, not paper 001's sensor
    assert np.all(log["rate_dps"] == 0.0)
    direct = generate_log("paper001", effects={}, model=MODEL, noise="off")
    np.testing.assert_allclose(log["output"], direct["output"], rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(log["freq_hz"], direct["freq_hz"], rtol=1e-11)
    scenario_sensor = generate_log("paper001", effects={}, noise="off")
    assert np.abs(scenario_sensor["output"] - log["output"]).max() > 100.0


@pytest.mark.parametrize("args, needle", [
    (["--scenario", "paper999"], "--scenario"),
    (["--scenario", "ramp", "--effect", "thermal_lagg=3"], "thermal_lagg"),
    (["--scenario", "ramp", "--effect", "thermal_lag.tau=3"], "'tau'"),
    (["--scenario", "ramp", "--effect", "thermal_lag=fast"], "not a number"),
    (["--scenario", "ramp", "--effect", "warmup=3"], "warmup.a"),
    (["--scenario", "ramp", "--effect", "thermal_lag"], "CAUSE.PARAM=VALUE"),
    (["--scenario", "ramp", "--seed", "one"], "--seed"),
    (["--scenario", "ramp", "--columns", "temp"], "columns"),
    (["--scenario", "ramp", "--time-step=-1"], "--time-step"),
    (["--scenario", "ramp", "--model", "/nonexistent/m.json"], "model"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, args, needle):
    rc = main(["simulate", *args, "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and needle in err
    assert "Traceback" not in err
    assert not (tmp_path / "x.csv").exists()


def test_cli_unwritable_output_exits_2(tmp_path, capsys):
    rc = main(["simulate", "--scenario", "ramp", "--out", str(tmp_path / "no" / "such" / "dir.csv")])
    assert rc == 2 and "cannot write" in capsys.readouterr().err
