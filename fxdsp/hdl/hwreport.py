"""The iCE40UP5K hardware report as data: ``hdl/HW_REPORT.json``, written by ``fxdsp hw-report``
beside the Markdown table (``hdl/HW_REPORT.md``) from the same rows, and read by whoever needs the
synthesised cost (``fxdsp budget --optimise``) without parsing Markdown.

Each row: ``name`` (block instance or top), ``module``, ``LUT`` (SB_LUT4), ``MAC16`` (SB_MAC16),
``FF``, ``BRAM`` (SB_RAM40_4K), ``fmax`` (MHz after place and route) and ``note``; a count is
null when its tool run failed, ``fmax`` when the design does not place. ``xc7`` (nested) holds the
yosys ``synth_xilinx -family xc7`` estimate of the same bare module for an Artix-7 (synthesis only,
not Vivado, no timing): ``LUT`` (LUT1..LUT6), ``DSP48E1``, ``FF`` (FDRE/FDSE/FDCE/FDPE), ``BRAM36``
(RAMB36E1), ``BRAM18`` (RAMB18E1), ``LUTRAM`` (distributed-RAM cells), ``SRL`` and ``note``; a
count is null when that run failed or timed out. ``device_xc7`` names the part the counts are read
against.

``source_sha256`` identifies what was synthesised: the RTL sources and the generated parameter
headers and ROMs of the config (:func:`source_hash`). A report whose hash differs from the current
RTL and default config is stale (the tests say so; ``make hw-report`` regenerates it).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

# hdl/ of the checkout this package runs from (RTL sources and reports): the one place that knows it
HDL_DIR = Path(__file__).resolve().parents[2] / "hdl"
REPORT_NAME = "HW_REPORT.json"
COLUMNS = ("name", "module", "LUT", "MAC16", "FF", "BRAM", "fmax", "note")
XC7_COLUMNS = ("LUT", "DSP48E1", "FF", "BRAM36", "BRAM18", "LUTRAM", "SRL", "note")


def hw_report_path() -> Path:
    """The committed JSON hardware report: the checkout's ``hdl/HW_REPORT.json``, else (package
    installed elsewhere) ``hdl/HW_REPORT.json`` under the working directory."""
    path = HDL_DIR / REPORT_NAME
    return path if path.is_file() else Path("hdl") / REPORT_NAME


def source_hash(design) -> str:
    """sha256 of everything a synthesis run reads: every RTL source and the generated parameter
    headers and ROM files of ``design``, by relative name."""
    from .params import generate

    h = hashlib.sha256()
    items = [(f"rtl/{p.name}", p.read_text(encoding="utf-8")) for p in sorted((HDL_DIR / "rtl").glob("*.v"))]
    items += [(f"gen/{name}", text) for name, text in sorted(generate(design).items())]
    for name, text in items:
        h.update(name.encode() + b"\0" + text.encode() + b"\0")
    return h.hexdigest()


def _row(row: dict) -> dict:
    out = {c: row.get(c, "" if c == "note" else None) for c in COLUMNS}
    xc7 = row.get("xc7") or {}
    out["xc7"] = {c: xc7.get(c, "" if c == "note" else None) for c in XC7_COLUMNS}
    return out


def report_json(rows: list[dict], freq_mhz: float, device: dict[str, int], source_sha256: str = "",
                device_xc7: dict | None = None) -> str:
    """The report's JSON text: the table's columns of every row (with its nested ``xc7`` estimate),
    the target clock, the devices and the hash of the sources synthesised."""
    data = {"generator": "fxdsp hw-report", "device": {"name": "iCE40UP5K", **device},
            "device_xc7": device_xc7, "target_mhz": freq_mhz, "source_sha256": source_sha256,
            "rows": [_row(row) for row in rows]}
    return json.dumps(data, indent=1, allow_nan=False) + "\n"   # strict JSON: a failed count is null


def load_hw_report(path: str | Path | None = None) -> dict | None:
    """The parsed report (default :func:`hw_report_path`), or None when there is none."""
    p = hw_report_path() if path is None else Path(path)
    if not p.is_file():
        return None
    data = json.loads(p.read_text(encoding="utf-8"))
    if not isinstance(data, dict) or not isinstance(data.get("rows"), list):
        raise ValueError(f"{p}: not a hardware report (no list of rows)")
    return data


def synthesised_cost() -> dict[str, dict[str, float]] | None:
    """LUT4 and SB_MAC16 of every synthesised instance from the report (None without one); a count
    the synthesis did not produce counts 0."""
    report = load_hw_report()
    if report is None:
        return None
    return {r["name"]: {"lut": float(r["LUT"] or 0), "mac16": float(r["MAC16"] or 0)} for r in report["rows"]}
