"""The report schema ships inside the package (fxdsp/schemas, package data) and is the contract's:
identical to ../shared/spec/diagnose-report.schema.json whenever that checkout is beside this one."""

from __future__ import annotations

from conftest import SHARED, needs_shared

import json

import jsonschema

from fxdsp.schemas import diagnose_report_schema

CONTRACT = "spec/diagnose-report.schema.json"


def test_packaged_schema_is_a_valid_json_schema():
    schema = diagnose_report_schema()
    jsonschema.validators.validator_for(schema).check_schema(schema)
    assert {"cause", "causes", "parameters", "gain", "rows"} <= set(schema["required"])


@needs_shared(CONTRACT)
def test_packaged_schema_is_the_contracts():
    assert diagnose_report_schema() == json.loads((SHARED / CONTRACT).read_text(encoding="utf-8")), \
        f"fxdsp/schemas differs from ../shared/{CONTRACT}: copy the contract's schema into the package"
