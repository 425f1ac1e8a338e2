"""Which rows the hardware report holds and when a row can be reused: the instances and their
resource-shared variants, the placement seeds of each row, the recipe (tool commands and wrapper)
that goes into a row's hash, the rows of a previous report still current, and the rows that are
too big to send to the placer."""

from __future__ import annotations

from fxdsp.hdl.hwreport import row_files, row_hash
from fxdsp.hdl.params import generate
from fxdsp.hdl.synthesis import UP5K, XC7_SYNTH, module_params, wrapper


def variants(design) -> dict[str, tuple[str, dict[str, str]]]:
    """The resource-shared variants reported beside their instance's default RTL: row name ->
    (instance, the variant's own parameters), one per instance whose RTL has one (its interface,
    ``design.instances[name].rtl``). A variant has valid/ready (in_ready) whatever the instance table says."""
    return {f"{n} (ARCH=1)": (n, {k: str(v) for k, v in i.rtl.variant().items()})
            for n, i in design.hardware.items() if i.rtl.variant() is not None}


# a chain's resource targets are read against its serial row when it has one, else its default row
# a chain row's target (its table's ``hardware``, fxdsp.netlist.HARDWARE_KEYS) -> the row's column
TARGET_COLUMNS = {"lut4": "LUT", "mac16": "MAC16", "bram": "BRAM"}


DEVICE_NAMES = {"LUT": "LUT4", "MAC16": "SB_MAC16"}   # the iCE40 primitives the columns count


# the chains' serial rows are placed with ten nextpnr seeds: one seed's Fmax moves by a few MHz with no
# change in logic (a placement is one draw), so the target is judged on the lowest of them
SEED_SWEEP = tuple(range(1, 11))


def seeds_of(row_name: str) -> tuple[int, ...]:
    """The nextpnr seeds a row is placed with: :data:`SEED_SWEEP` for every chain's serial row (the
    rows an FPGA engineer signs off), else seed 1."""
    return SEED_SWEEP if row_name.startswith("chain_") and row_name.endswith(" (ARCH=1)") else (1,)


def recipe(design, name: str, params: dict[str, str] | None, ready: bool, freq: float,
           seeds: tuple[int, ...] = (1,)) -> str:
    """The tool commands and the place-and-route wrapper of a row, as text (part of its row hash)."""
    seed = " ".join(str(s) for s in seeds)
    return (f"read_verilog -defer | synth_ice40 -dsp | {XC7_SYNTH} | nextpnr-ice40 --up5k --package sg48 --seed {seed} "
            f"--freq {freq:g} | warnings\n"
            + wrapper(design, name, params, ready))


def reusable_rows(previous: dict | None, tools: dict[str, str], freq: float, need_xc7: bool) -> dict[str, dict]:
    """Rows of a previous report that may stand for a new run: same tools and target clock, keyed by
    row hash; a row without a complete result (a failed or skipped run) is never reused."""
    if not previous or previous.get("tools") != tools or previous.get("target_mhz") != freq:
        return {}
    out = {}
    for row in previous.get("rows", []):
        xc7 = row.get("xc7") or {}
        if row.get("sha256") and row.get("LUT") is not None and (xc7.get("LUT") is not None or not need_xc7):
            out[row["sha256"]] = row
    return out


def too_big(row: dict) -> str:
    """Why the synthesised module cannot place on the UP5K whatever the placer does ('' when it may):
    more SB_MAC16 or LUT4 than the device has."""
    if row["MAC16"] > UP5K["MAC16"]:
        return f"does not place: {row['MAC16']} SB_MAC16 > {UP5K['MAC16']} on the device"
    if row["LUT"] > UP5K["LUT"]:
        return f"does not place: {row['LUT']} LUT4 > {UP5K['LUT']} on the device"
    return ""


def planned_rows(design, targets: list[str]) -> dict[str, tuple[str, str, dict[str, str] | None, dict]]:
    """Row name -> (instance, module, module parameters (None: a top), the variant's own parameters)
    for ``targets`` and their resource-shared variants, in report order."""
    rows = {}
    all_variants = variants(design)
    chosen = [v for v, (inst, _) in all_variants.items() if inst in targets]
    for row_name in targets + chosen:
        name, extra = all_variants.get(row_name, (row_name, {}))
        params = module_params(design, name)
        if extra:  # a top (params None) takes only the variant's own
            params = {**(params or {}), **extra}
        rows[row_name] = (name, design.instances[name].module, params, extra)
    return rows


def row_digest(design, files: dict[str, str], plan: tuple, freq: float, seeds: tuple[int, ...] = (1,)) -> str:
    """:func:`row_hash` of one planned row (an entry of :func:`planned_rows`)."""
    name, module, params, extra = plan
    instances = [name, *design.instances[name].members]
    return row_hash(module, params, row_files(files, instances, list(design.instances)), recipe(design, name, params, bool(extra), freq, seeds))


def expected_row_hashes(design, freq: float) -> dict[str, str]:
    """Row name -> :func:`row_hash` of every row a full report of ``design`` holds, as of now."""
    files = generate(design)
    return {row: row_digest(design, files, plan, freq, seeds_of(row))
            for row, plan in planned_rows(design, list(design.hardware)).items()}
