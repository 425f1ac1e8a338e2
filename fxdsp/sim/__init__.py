"""The virtual test bench: simulated chamber runs of the three sensors of the papers.

Public API::

    from fxdsp.sim import generate_log, write_log, read_log, read_model, SCENARIOS
    log = generate_log(scenario="paper002", effects={"thermal_lag": {"tau_s": 3000.0}}, seed=1,
                       columns=("ref_temp_c", "rate_dps", "freq_hz", "quad"))
    log, truth = generate_log(..., return_truth=True)
    write_log("run.csv", log, header_comments={"scenario": "paper002"})

Modules: :mod:`~fxdsp.sim.programmes` (chamber programmes), :mod:`~fxdsp.sim.thermal` (air ->
package -> die), :mod:`~fxdsp.sim.model` (baselines and the replay JSON), :mod:`~fxdsp.sim.noise`,
:mod:`~fxdsp.sim.generate` (the log), :mod:`~fxdsp.sim.logio` (CSV), :mod:`~fxdsp.sim.gyro`
(two-mode vibratory gyro, paper 003/002/001), :mod:`~fxdsp.sim.qvba` (quartz beam pair, paper
000), :mod:`~fxdsp.sim.calibration` (the papers' calibration fits), :mod:`~fxdsp.sim.repeatability`
(run-to-run repeatability of a device: ``generate_log(..., repeatability=...)``).
"""

from fxdsp.sim.generate import OPTIONAL_COLUMNS, SCENARIOS, generate_log
from fxdsp.sim.logio import read_log, write_log
from fxdsp.sim.model import Baseline, Model, read_model, scenario_baseline, write_model
from fxdsp.sim.thermal import ThermalChain

__all__ = ["generate_log", "write_log", "read_log", "read_model", "write_model", "SCENARIOS",
           "OPTIONAL_COLUMNS", "Baseline", "Model", "ThermalChain", "scenario_baseline"]
