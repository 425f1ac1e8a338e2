"""Float vs fixed: the bit-exact models stay within engineering bounds of the float references, and
the two IIR measures (DC-exact coefficients, error feedback) do what they claim."""

from __future__ import annotations

import numpy as np

from conftest import design_with
from fxdsp.float_vs_fixed import all_errors


def test_every_block_close_to_its_float_reference(design):
    rows = {(r.block, r.port): r for r in all_errors(design, samples=2048)}
    # requirements of the application, not readings of the code: 0.01 C temperature, 20 deg/h of
    # rate at the chain output (sensor noise of a tactical MEMS gyro is ~10 deg/h), 10 ppm of SF
    assert rows[("rtd", "temp")].max_abs < 0.01
    assert rows[("freq2temp", "temp")].max_abs < 0.01
    assert rows[("chain_paper002", "rate")].rms * rows[("chain_paper002", "rate")].scale < 20.0
    assert rows[("chain_paper001", "rate")].max_abs < 0.5
    assert rows[("piecewise_sf", "y")].max_abs * 1e6 < 10.0
    for name in ("bias_subtract", "bias_subtract001"):
        block, row = design.blocks[name], rows[(name, "y")]
        inputs_fl = max(f.fl for f in block.inputs.values())
        # exact where the output holds the difference, else one rounding (half an output LSB)
        assert row.max_abs <= (0.0 if block.out_format.fl >= inputs_fl else block.out_format.lsb / 2)
    for r in rows.values():
        assert r.overflows == 0, f"{r.block}: nominal stimulus must not overflow"


def _dc_error(edits: dict) -> float:
    d = design_with(**edits)
    f = d.blocks["iir"]
    level = int(0.3 * f.data_format.max_int)
    y = f.filter(np.full(200_000, level, dtype=np.int64))
    return float(np.abs(y[-1000:] - level).max())


def test_iir_dc_gain_exact_with_error_feedback():
    assert _dc_error({}) <= 1  # settles on the input within one LSB
    # without error feedback in-loop rounding is amplified by 1/(1 + a1 + a2) ~ 1e5 at 50 Hz / 96 kHz
    assert _dc_error({"iir.error_feedback": "off"}) > 100


def test_rtd_cvd_law_inverts_exactly():
    d = design_with(**{"rtd.law": "cvd", "rtd.r0_ohm": 500.0})
    b = d.blocks["rtd"]
    t = np.linspace(-40, 85, 251)
    assert np.allclose(b.physics.temperature(b.physics.resistance(t)), t, atol=1e-9)
    got = b.real_outputs(b.run(code=b.adc_code(t)))["temp"]
    assert np.abs(got - t).max() < 0.02
