"""Shared fixtures: the built-in design and config variants."""

from __future__ import annotations

import copy
import tomllib

import pytest

from pathlib import Path

from fxdsp.chains import build
from fxdsp.config import Config, default_config_text


# shared/ (specs and real data) sits beside the checkout, in CI as on a developer's machine; a bare
# clone has none, so every test that reads it is marked with needs_shared()
SHARED = Path(__file__).resolve().parents[2] / "shared"


def needs_shared(*rel: str):
    """Skip marker for a test that reads these files of ../shared, with a reason naming the first
    one that is absent."""
    missing = [r for r in rel if not (SHARED / r).exists()]
    return pytest.mark.skipif(bool(missing), reason=f"../shared/{missing[0]} absent (no shared/ checkout "
                              "beside this one)" if missing else "")


def default_data() -> dict:
    return tomllib.loads(default_config_text())


def design_with(chains: bool = False, **edits):
    """Build the design from the default config with dotted-path edits, e.g.
    ``design_with(**{"iir.rounding": "floor"})`` (blocks only unless ``chains``)."""
    data = copy.deepcopy(default_data())
    for dotted, value in edits.items():
        node = data
        *parents, key = dotted.split(".")
        for p in parents:
            node = node[p]
        node[key] = value
    return build(Config(data, source="<test>"), chains=chains)


@pytest.fixture(scope="session")
def design():
    return build()
