"""`fxdsp budget [--config F] [--json F] [--report DIR] [--target T [--optimise --config-out F]]`:
float vs fixed error budget of every block and chain in LSBs and physical units, attribution of
each chain's error to its quantisation sources, theory check of every rounding point, and
word-length exploration; floor and margin of each chain output against its ADCs, and for every
chain with a demodulator the Allan deviation of its error and a drive-frequency sweep. Every chain
of the config is covered the same way: nothing here names one."""

from __future__ import annotations

import time
from functools import partial

from tqdm import tqdm as _tqdm

from fxdsp.commands.options import FINITE
from fxdsp.chains import build
from fxdsp.float_vs_fixed import port_unit
from fxdsp.config import dumps, load_config
from fxdsp.hdl.hwreport import hw_report_path, synthesised_cost
from fxdsp.outputs import IN, OUT_DIR, OUT_FILE, json_text, plain, staged
from fxdsp.budget import DEFAULT_MARGIN, optimise as opt
from fxdsp.budget.attribution import ADDITIVITY_DB, THEORY_DB, attribute
from fxdsp.budget.floor import allan_chain, carrier_chains, demod_f_hz, drive_frequencies, drive_sweep, floor_of
from fxdsp.budget.drive_loop import TEMPS_C, at_temperature, format_allan as format_reference_allan, format_budget, ramp, \
    reference_allan
from fxdsp.budget.static import static_errors
from fxdsp.budget.table import budget_rows, format_rows
from fxdsp.budget.units import parse_target
from fxdsp.budget.report import (attr_dict, format_allan, format_attribution, format_floor, format_sweep,
                                 format_theory, write_report)
from fxdsp.errors import InputError

# progress bars on a terminal only: redirected, stderr keeps to the one line an error needs
tqdm = partial(_tqdm, disable=None)


def attributed(design) -> list[tuple[str, str]]:
    """Every (chain, output) of the design, in config order."""
    return [(c, p) for c, chain in design.chains.items() for p in chain.outputs]


def downstream_outputs(design, chain_name: str, kind: str) -> list[str]:
    """The outputs of the chain that a member of ``kind`` reaches (through the netlist)."""
    chain = design.chains[chain_name]
    net = chain.netlist
    reached = {p for p in net.order if chain.kinds[p] == kind}
    for inst in net.order:
        if any(u in reached for u in net.upstream(inst)):
            reached.add(inst)
    return [p for p, e in net.outputs.items() if e.instance in reached]


def drive_loop_budgets(design, with_ramp: bool) -> list:
    """Every drive loop of the design at TEMPS_C, and over the chamber ramp with ``with_ramp``."""
    from fxdsp.blocks.drive import Drive

    out = []
    fs_dps = design.rate_full_scale_dps
    for block in design.blocks.values():
        if isinstance(block, Drive):
            out += [at_temperature(block, t, rate_full_scale_dps=fs_dps) for t in TEMPS_C]
            if with_ramp:
                out.append(ramp(block, rate_full_scale_dps=fs_dps, progress=True))
    return out


def drive_reference_allans(design) -> list:
    """Every drive loop's NCO as a demodulator reference over an hour of lock (reference_allan)."""
    from fxdsp.blocks.drive import Drive

    return [reference_allan(b, rate_full_scale_dps=design.rate_full_scale_dps, progress=True)
            for b in design.blocks.values() if isinstance(b, Drive)]


def _scaled(st: dict, scale: float) -> dict:
    return {k: (v * scale if k in ("rms", "max_abs", "mean") else v) for k, v in st.items()}


PATHS = {"--config": IN, "--json": OUT_FILE, "--report": OUT_DIR, "--config-out": OUT_FILE}
# a search's options on a run without a search, a target's without a target: refused, not ignored
# (fxdsp.cli); a margin of 0 was read as "no margin" by a budget that had nothing to margin
ONLY_WITH = {"--config-out": ("--optimise",), "--margin": ("--optimise",), "--max-mean": ("--optimise",),
             "--drive-band": ("--optimise",), "--cost": ("--optimise",), "--metric": ("--target",),
             "--chain": ("--target",)}


def configure(parser) -> None:
    parser.add_argument("--config", help="TOML config (default: the built-in one)")
    parser.add_argument("--json", help="write every number to this JSON file")
    parser.add_argument("--report", help="directory for the Markdown report and PNG plots")
    parser.add_argument("--target", help="error target on a chain output, <value><unit>: deg/h, deg/s, FS, C, mC, "
                                         "xnoise or %%noise (a fraction of the sensor noise at the output)")
    parser.add_argument("--chain", help="chain of --target (default: the config's first chain)")
    parser.add_argument("--metric", default="rms", choices=("rms", "max"), help="error measure of --target")
    parser.add_argument("--optimise", action="store_true", help="search small word lengths meeting --target")
    parser.add_argument("--config-out", help="with --optimise: write the optimised TOML config here")
    parser.add_argument("--cost", default="total_bits", choices=("total_bits", "register_bits"),
                        help="cost the search minimises: every bit (registers, coefficients, LUT memory; default) "
                             "or register/coefficient bits only")
    parser.add_argument("--margin", type=FINITE, default=DEFAULT_MARGIN,
                        help=f"with --optimise: optimise to (1 - margin) x target (default {DEFAULT_MARGIN})")
    parser.add_argument("--max-mean", help="with --optimise: also keep |mean| (a bias) of the --target output within "
                                           "this, <value><unit> as --target")
    parser.add_argument("--drive-ramp", action="store_true",
                        help="also run every drive loop over the chamber ramp -40 -> 85 C at 1 C/min (about 4 min of "
                             "simulation per loop; without it the drive loops are budgeted at -40, 25 and 85 C)")
    parser.add_argument("--drive-allan", action="store_true",
                        help="also run every drive loop locked for an hour and give the Allan deviation of its NCO's "
                             "error as a demodulator reference, fixed minus float, against the open-loop NCO's drift "
                             "(about 2 min of simulation per loop)")
    parser.add_argument("--drive-band", action="store_true",
                        help="with --optimise on a chain with a demodulator: meet the target at every frequency of "
                             "the drive sweep too (the band a -40..85 C silicon resonator covers), not only at the "
                             "demodulator's f_hz")


def run(args) -> int:
    with staged() as stage:  # every output moved into place only when the whole run has succeeded
        return _run(args, stage)


def _run(args, stage) -> int:
    t0 = time.time()
    cfg = load_config(args.config)
    design = build(cfg)
    if args.chain is None:
        args.chain = next(iter(design.chains), None)
    if args.optimise and not args.target:
        raise InputError("--optimise: needs --target <value><unit>")
    opt.check_search(args.chain, args.margin, chains=design.chains, search=args.optimise, cost_model=args.cost,
                     drive_band=args.optimise and args.drive_band)
    # the target's chain first: a target that names no output of it is refused before the rest is run
    own = {(c, p): attribute(design, c, p) for c, p in attributed(design) if c == args.chain}
    noise = {p: a.sensor_noise_rms for (c, p), a in own.items()}
    target = parse_target(args.target, design, args.chain, noise) if args.target else None
    max_mean = parse_target(args.max_mean, design, args.chain, noise, "--max-mean") if args.max_mean else None
    result = None
    if args.optimise:
        opt.check_search(args.chain, target=target, max_mean=max_mean)
        # the search before the rest of the budget: a target it cannot reach (even at the widest
        # words) is one line at once, not after every section of the budget has been computed
        freqs = tuple(drive_frequencies(demod_f_hz(cfg, design, target.chain))) if args.drive_band else ()
        result = opt.optimise(cfg, target, args.metric, args.margin, progress=tqdm, cost_model=args.cost,
                              max_mean=max_mean, frequencies=freqs)
    attrs = {key: own[key] if key in own else attribute(design, *key) for key in attributed(design)}

    print(f"fxdsp budget: config {cfg.source}, seed {design.seed}")
    print("\n1. bit-exact vs float reference (float fed with the same stored inputs), nominal stimulus:")
    rows = budget_rows(design)
    print(format_rows(rows))
    statics = {}
    for c, chain in design.chains.items():
        if chain.sensor is None:
            continue
        for p, st in static_errors(design, c).items():
            unit, scale = port_unit(design, c, p)
            statics[(c, p)] = st = _scaled(st, scale)
            print(f"{c}.{p} at {st['samples'] // 1024} quasi-static chamber temperatures (settled): rms "
                  f"{st['rms']:.4g} {unit}, max {st['max_abs']:.4g}, mean {st['mean']:+.4g}, overflows "
                  f"{st['overflows']}")
    print("\n2. attribution (one source quantised at a time, the rest in float; vs float on the analog inputs):")
    for a in attrs.values():
        print(format_attribution(a))
    floors = [floor_of(a) for a in attrs.values()]
    print("\nfloor and margin (floor = the input ADCs' quantisation carried to the output; margin = 20 log10"
          "(total / floor); dominant: a non-ADC source with rms >= total / 2):")
    for f in floors:
        print(format_floor(f))
    print(f"\n3. theory check (flag: more than {THEORY_DB} dB worse than theory):")
    for a in attrs.values():
        if a.theory:
            print(format_theory(a))
    carriers = {c: downstream_outputs(design, c, "demod") for c in carrier_chains(design)}
    print("\n4. Allan deviation of the fixed-point error (every output of a chain with a demodulator):")
    allans = [a for c, ports in carriers.items() for a in allan_chain(design, c, ports)]
    for al in allans:
        print(format_allan(al))
    if not allans:
        print("  none: no chain of this config has a demodulator and a sensor")
    print("\n5. drive-frequency sweep (the demodulator reference tracks the drive loop, which moves with "
          "temperature):")
    t_sweep = time.time()
    sweeps = [s for c, ports in carriers.items()   # a bar only if it ever takes > 2 s
              for s in drive_sweep(cfg, c, ports, progress=partial(tqdm, delay=2.0))]
    t_sweep = time.time() - t_sweep
    for sw in sweeps:
        print(format_sweep(sw))
    print(f"  ({sum(len(sw.points) for sw in sweeps)} points in {t_sweep:.1f} s)")
    loops = drive_loop_budgets(design, args.drive_ramp)
    print("\n6. drive loops (bit-exact and float closed on the simulated mode from power-on; floor = the float loop "
          "on the same drive ADC codes; margin = 20 log10(fixed / floor) of the frequency noise):")
    for lb in loops:
        print(format_budget(lb))
    if not loops:
        print("  none: this config has no drive loop")
    references = drive_reference_allans(design) if args.drive_allan else []
    for ra in references:
        print(format_reference_allan(ra))

    out = {"config": cfg.name, "seed": design.seed,
           "table": [r.as_dict() for r in rows],
           "static": [{"chain": c, "port": p, "unit": port_unit(design, c, p)[0], **st}
                      for (c, p), st in statics.items()],
           "attribution": [attr_dict(a) for a in attrs.values()], "additivity_tolerance_db": ADDITIVITY_DB,
           "theory_limit_db": THEORY_DB, "floor": [f.as_dict() for f in floors],
           "allan": [al.as_dict() for al in allans], "drive_sweep": [sw.as_dict() for sw in sweeps],
           "drive_loop": [lb.as_dict() for lb in loops],
           "drive_reference_allan": [ra.as_dict() for ra in references],
           "null_means": "an infinite or undefined value (an exact port's SNR, a margin without a floor)"}
    status = 0
    if target:
        row = next(r for r in rows if r.stats.block == target.chain and r.stats.port == target.port)
        measured = (row.stats.rms if args.metric == "rms" else row.stats.max_abs) * row.stats.scale
        st = statics.get((target.chain, target.port))
        if st is not None:
            measured = max(measured, st["rms"] if args.metric == "rms" else st["max_abs"])
        meets = measured <= target.value
        kind = "nominal and quasi-static" if st is not None else "nominal"
        print(f"\ntarget {args.target} on {target.chain}.{target.port} ({args.metric}, {kind}): "
              f"{target.value:.4g} {target.unit}; this config: {measured:.4g} {target.unit} -> "
              f"{'MET' if meets else 'NOT MET'}")
        out["target"] = {"text": args.target, "value": target.value, "unit": target.unit, "chain": target.chain,
                         "port": target.port, "metric": args.metric, "measured": measured, "met": meets}
        if result is not None:
            print(f"\n7. word-length search ({result.evaluations} evaluations, greedy min+b):")
            print(opt.format_result(result))
            dc, nc = result.default_cost, result.cost
            synth = opt.synth_estimate(synthesised_cost(), design.instances[target.chain].members,
                                       dc["register_bits"], nc["register_bits"])
            if synth:
                print(f"  synthesised ({hw_report_path()}, default widths): LUT {synth['lut_default']:.0f}, MAC16 "
                      f"{synth['mac16_default']:.0f}; estimate at the new widths: LUT {synth['lut_estimate']:.0f}")
            else:
                print(f"  synthesised cost: {hw_report_path()} not found (bits only)")
            if args.config_out:
                header = opt.config_header(result, "fxdsp budget --optimise", cfg.source)
                written = stage.path(args.config_out)
                written.write_text(dumps(result.data, header), encoding="utf-8")
                build(str(written))  # must load
                print(f"  wrote {args.config_out}")
            out["optimise"] = result.as_dict(synth=synth)
        elif not meets:
            status = 1

    if args.report:
        write_report(stage.dir(args.report), design, cfg, rows, attrs, statics, target, result, args, floors, allans,
                sweeps, loops, references)
        print(f"\nreport written to {args.report}/budget.md")
    if args.json:  # no wall-clock time in it: the same config and seed give the same bytes
        stage.write_text(args.json, json_text(plain(out), "--json", indent=1))
    print(f"\n({time.time() - t0:.1f} s)")
    return status


