"""(d) Long file-driven streams, >= 100k samples, for the demodulator and both tops; and the
committed chain_paper002 vectors with the hardware divider setting (one quotient bit per cycle)."""

import numpy as np
import pytest

from fxdsp.vectors import load
from hdl_util import VECTORS, run_harness
from long_common import default_design, long_stream


@pytest.mark.hdl
@pytest.mark.parametrize("name", ["demod", "chain_paper001"])
def test_long_stream(name):
    long_stream(name)


@pytest.mark.hdl
def test_long_stream_chain_paper002():
    long_stream("chain_paper002", unroll=2)


@pytest.mark.hdl
def test_golden_chain_paper002_hardware_divider():
    ins, outs, _ = load(VECTORS, "chain_paper002")
    got, _, cycles, _ = run_harness(default_design(), "chain_paper002", ins, "golden_file_chain_paper002", unroll=1)
    for port, want in outs.items():
        assert np.array_equal(got[port], want), port
    assert cycles >= 49 * len(ins["vsa"])  # one sample per ceil(42 / 1) + 7 cycles
