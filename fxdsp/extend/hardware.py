"""The extended config's hardware: golden vectors, Verilog headers and ROMs, a cocotb regression on
Icarus, and the cost before/after from the committed hardware report.

The regression streams every block of the chosen chain (and its generated top) through its
RTL with this config's generated parameters, against the bit-exact model, with the generic driver
of ``fxdsp sweep rtl`` (:func:`fxdsp.sweep.rtl.run_block`: corners first, gapped valid). A lag that
updates on every N-th chain sample (``DECIM`` = fs / rate_hz, thousands) changes its state only a
few times in a short stream, so the lag is also run alone at its update rate (decimation 1, the
same alpha word): the arithmetic of every update is checked; the decimation counter itself is the
test suite's (a 5-sample decimation in tests/hdl/test_hdl_chain_stages.py, and its mutant).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np


def chain_blocks(design, chain: str) -> tuple[str, ...]:
    """The instances ``extend`` checks for ``chain``: the config chain's members (its netlist) and
    its generated top (the thermometer chain is the ``[chain.thermometer]`` extend writes)."""
    top = design.chain(f"chain_{chain}", "fxdsp extend's regression")
    return (*(m.replace(".", "_") for m in top.netlist.instances), top.name)


def regression(design, roles, has_lag: bool, build_root: Path | None = None, seed: int = 0,
               rtl_dir: Path | None = None, only: tuple[str, ...] | None = None) -> dict:
    """Per block: ok, samples, cycles, first errors. ValueError when Icarus or cocotb is missing.
    ``roles``: the extended chain (:class:`fxdsp.extend.roles.Roles`); ``rtl_dir``: other Verilog
    sources (default: the package's); ``only``: these labels."""
    from fxdsp.extend.evaluate import without_lag
    from fxdsp.sweep.rtl import RTL_DIR, check_tools, run_block

    rtl_dir = RTL_DIR if rtl_dir is None else Path(rtl_dir)
    check_tools(rtl_dir)
    lag = roles.tables.get("lag", "lag").replace(".", "_")
    # a lag member is checked per update below (in a config's chain it may update only every
    # DECIM-th sample; extend's own chain updates it on every row)
    runs = [(name, design, name) for name in chain_blocks(design, roles.chain) if not (has_lag and name == lag)]
    if has_lag:
        per_update = not roles.written
        runs.append((f"{lag} (per update)" if per_update else lag,
                     without_lag(design.config, roles) if per_update else design, lag))
    runs = [r for r in runs if only is None or r[0] in only]
    results = {}
    with tempfile.TemporaryDirectory(prefix="fxdsp-extend-") as tmp:
        root = Path(tmp) if build_root is None else Path(build_root)
        for k, (label, d, name) in enumerate(runs):
            block_seed = int(np.random.SeedSequence([seed, k]).generate_state(1)[0])
            results[label] = run_block(d, name, root / name.replace(" ", "_") / str(k), rtl_dir, block_seed)
    return {"simulator": "icarus", "blocks": results, "passed": all(r["ok"] for r in results.values())}


def cost(design, chain: str, has_lag: bool) -> dict | None:
    """LUT4 / SB_MAC16 / FF of the chain before and after, from the committed report's rows (the
    default config's word lengths: an estimate for this config): the chain's top, or (a chain the
    default config does not have, such as the thermometer chain) its members but the lag. None
    without a report."""
    from fxdsp.hdl.hwreport import load_hw_report

    report = load_hw_report()
    if report is None:
        return None
    rows = {r["name"]: r for r in report["rows"]}
    members = [m for m in chain_blocks(design, chain)[:-1] if m != "lag"]
    before_names = [f"chain_{chain}"] if f"chain_{chain}" in rows else members
    after_names = before_names + (["lag"] if has_lag else [])

    def total(names):
        got = [rows[n] for n in names if n in rows]
        picks = {"LUT4": lambda r: r.get("LUT"), "SB_MAC16": lambda r: r.get("MAC16"), "FF": lambda r: r.get("FF"),
                 "xc7 LUT": lambda r: (r.get("xc7") or {}).get("LUT"),
                 "xc7 DSP48E1": lambda r: (r.get("xc7") or {}).get("DSP48E1")}
        return {key: int(sum(pick(r) or 0 for r in got)) if got else None for key, pick in picks.items()}

    return {"before": total(before_names), "after": total(after_names), "before_rows": before_names,
            "after_rows": after_names, "source": "hdl/HW_REPORT.json rows (default-config word lengths)"}
