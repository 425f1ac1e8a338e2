"""Configs of a user's own design, written the way a user would edit the built-in one (its TOML
text, key by key), for the tests that must show a command verifies *that* design."""

from __future__ import annotations

from fxdsp.config import default_config_text
from fxdsp.repro.calconfig import set_table_keys


def adc18_text(**edits) -> str:
    """The built-in config with an 18-bit sense ADC: the SF divider's input word, nothing else follows
    (the divider's numerator and quotient formats are derived from it); ``edits``: more
    ``{"table.key": value}`` changes (e.g. ``**{"lag.state_guard_bits": 8}``)."""
    text = set_table_keys(default_config_text(), "sf_divide", {"in_format": "s18.17"})
    for dotted, value in edits.items():
        table, _, key = dotted.rpartition(".")
        text = set_table_keys(text, table, {key: value})
    return text


def leaves(data: dict, prefix: str = "") -> dict:
    """{dotted path: value} of every leaf of parsed TOML (a list is one leaf)."""
    out = {}
    for k, v in data.items():
        out.update(leaves(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
    return out
