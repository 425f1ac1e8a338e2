"""One record per cause (fxdsp.causes): the contract's names, the report schema's enum, and what the
simulator and the diagnosis do with each record, checked from the records themselves.

The names are checked against the contract's text (section 3 of shared/spec/measured-data.md) and
the packaged schema, not against the code; each record's claimed channels against what the
simulator's log really changes.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from conftest import SHARED, needs_shared

from fxdsp import causes
from fxdsp.schemas import diagnose_report_schema

CONTRACT = "spec/measured-data.md"

# a size each cause shows clearly at with the simulator's noise off
SIZE = {"tau_s": 1500.0, "k_per_c_per_s": 50.0, "h": 0.3, "a": 0.5, "r_per_h": 0.02, "c": 0.05,
        "k3": 1e-4, "b_per_c": 4e-4, "k2_hz_per_c2": 2e-3}
CHANNEL_COLUMN = {"output": "output", "temp_c": "temp_c", "freq_hz": "freq_hz"}


def test_the_schemas_cause_enum_is_the_registry():
    schema = diagnose_report_schema()
    assert schema["$defs"]["cause"]["enum"] == list(causes.CAUSES)
    assert set(schema["properties"]["gain"]["properties"]["channel"]["enum"]) == set(causes.CHANNELS)


@needs_shared(CONTRACT)
def test_the_registry_holds_the_contracts_causes_and_parameters():
    text = (SHARED / CONTRACT).read_text(encoding="utf-8")
    section = text[text.index("## 3."):text.index("## 4.")]
    table = {}
    for row in re.findall(r"^\| `(\w+)` \|.*\|(.*)\|$", section, re.M):
        table[row[0]] = tuple(re.findall(r"`(\w+)`", row[1]))
    assert table == causes.PARAMETERS


@pytest.mark.parametrize("name", [c for c in causes.CAUSES if c != "none"])
def test_each_cause_changes_the_channels_its_record_claims_and_no_other(name):
    from fxdsp.sim import generate_log

    record = causes.CAUSES[name]
    effect = {name: {p: SIZE[p] for p in record.parameters}}
    kw = dict(seed=4, columns=("ref_temp_c", "rate_dps", "freq_hz", "quad"), duration_scale=0.2, noise="off")
    clean, with_cause = generate_log("paper002", {}, **kw), generate_log("paper002", effect, **kw)
    changed = {ch for ch, col in CHANNEL_COLUMN.items() if not np.array_equal(clean[col], with_cause[col])}
    assert changed == set(record.channels(has_freq=True))


def test_every_named_parameter_is_sized_here():
    assert {p for c in causes.CAUSES.values() for p in c.parameters} <= set(SIZE)


@pytest.mark.parametrize("fault, message", [
    (dict(stage=None), "no simulator stage"),
    (dict(inject=None), "no simulator stage"),
    (dict(term=None, linear=None, search=None), "no term the diagnosis fits"),
    (dict(channel="quad"), "channel 'quad'"),
    (dict(draw=None), "no draw for the hidden-cause generator"),
])
def test_a_record_the_simulator_or_the_fit_would_ignore_is_refused(fault, message):
    broken = replace(causes.CAUSES["aging_drift"], name="made_up", **fault)
    with pytest.raises(AssertionError, match=message):
        causes.check_records([*causes.CAUSES.values(), broken])
