"""The FPGA side of a diagnosis: the bit-exact lag block (thermal_lag) and the phase trim
(quadrature_leak) improve the compensated output on held-out data; nothing is proposed for `none`."""

from __future__ import annotations

from fxdsp.diagnose.api import diagnose_log
from fxdsp.logfile import Log
from fxdsp.diagnose.report import report_dict
from fxdsp.sim import generate_log


def _diagnose(effects, seed):
    cols = generate_log(scenario="paper002", effects=effects, seed=seed, columns=("rate_dps", "quad"))
    return report_dict(diagnose_log(Log(columns=cols, source="<sim>")))


def test_lag_extension_with_the_bit_exact_block():
    rep = _diagnose({"thermal_lag": {"tau_s": 2000.0}}, seed=5)
    assert rep["cause"] == "thermal_lag"
    (ext,) = rep["fpga_extension"]
    assert ext["block"] == "lag" and abs(ext["tau_s"] - 2000.0) < 500.0
    assert ext["ratio"] > 3.0  # compensating on the die estimate beats the raw thermometer


def test_phase_trim_extension():
    rep = _diagnose({"quadrature_leak": {"c": 0.04}}, seed=6)
    assert rep["cause"] == "quadrature_leak"
    (ext,) = rep["fpga_extension"]
    assert abs(ext["phase_trim_rad"] + 0.04) < 0.01 and ext["ratio"] > 1.3


def test_no_extension_without_a_cause():
    assert _diagnose({}, seed=7)["fpga_extension"] == []
