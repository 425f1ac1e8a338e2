"""JSON schemas the package honours, shipped as package data so that an installed fxdsp (or a
checkout without the contract beside it) carries them. ``diagnose-report.schema.json`` is a copy of
the measured-data contract's ``spec/diagnose-report.schema.json``; a test keeps the two identical."""

from __future__ import annotations

import json
from importlib import resources

DIAGNOSE_REPORT_SCHEMA = "diagnose-report.schema.json"


def diagnose_report_schema() -> dict:
    """The JSON schema of the report ``fxdsp diagnose --json`` writes."""
    return json.loads(resources.files(__name__).joinpath(DIAGNOSE_REPORT_SCHEMA).read_text(encoding="utf-8"))
