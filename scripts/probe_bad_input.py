"""Probe the command line with bad and degenerate input, the classes of issue "Bad input told apart
from bugs": numeric option values (nan, inf, -inf, -1, 0, 1e400, text), degenerate chamber logs and
foreign logs. Every run must end in exit 0, 1 or 2 with one line on stderr for 2; a traceback, exit
70 (a bug) or a run past its time limit is printed as BAD with its stderr. Not part of `make test`
(a few hundred subprocess runs, about 10 minutes on 2 cores):

    .venv/bin/python scripts/probe_bad_input.py [WORK_DIR]
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

FX = shutil.which("fxdsp") or str(Path(sys.executable).with_name("fxdsp"))
base = Path(sys.argv[1] if len(sys.argv) > 1 else "build/probe_bad_input").resolve()
shutil.rmtree(base, ignore_errors=True)
base.mkdir(parents=True)
good = base / "good.csv"
subprocess.run([FX, "simulate", "--scenario", "paper002", "--duration-scale", "0.2", "--out", str(good)], check=True)


def out(n):
    return str(base / f"o{n}")


# --- numeric option values ---------------------------------------------------------------------
log = good
table = base / "rtd.csv"
table.write_text("temperature_c,resistance_ohm\n" + "".join(f"{t},{100*(1+3.9083e-3*t-5.775e-7*t*t):.6f}\n"
                                                            for t in range(-40, 90, 10)))
V = ["nan", "inf", "-inf", "-1", "0", "1e400", "abc"]
numeric = []
for v in V:
    numeric += [
        ["calibrate", str(log), "--paper", "002", "--order", v],
        ["repro", "--paper", "003", "--sweep-points", v],
        ["budget", "--margin", v],
        ["budget", "--optimise", "--target", "1deg/h", "--margin", v],
        ["budget", "--target", f"{v}deg/h"],
        ["rtl", "--only", "rtd", "--long", v, "--out", out("rtl")],
        ["rtl", "--only", "rtd", "--seed", v, "--out", out("rtl2")],
        ["formal", "--only", "rtd", "--depth", v, "--out", out("formal")],
        ["formal", "--only", "rtd", "--timeout", v, "--out", out("formal2")],
        ["hw-report", "--only", "rtd", "--freq", v, "--out", out("hw") + ".md"],
        ["hw-report", "--only", "rtd", "--timeout", v, "--out", out("hw2") + ".md"],
        ["diagnose-bench", "--rows", v],
        ["diagnose-hidden", "--per-cause", v],
        ["diagnose-hidden", "--per-cause", "1", "--snr", v, "10"],
        ["diagnose-rtd", str(table), "--range", v, "50"],
        ["simulate", "--scenario", "paper002", "--time-step", v, "--out", out("s1") + ".csv"],
        ["simulate", "--scenario", "paper002", "--duration-scale", v, "--out", out("s2") + ".csv"],
        ["simulate", "--scenario", "paper002", "--noise", f"output={v}", "--duration-scale", "0.2", "--out", out("s3") + ".csv"],
        ["simulate", "--scenario", "paper002", "--effect", f"thermal_lag={v}", "--duration-scale", "0.2", "--out", out("s4") + ".csv"],
        ["simulate", "--scenario", "paper002", "--seed", v, "--duration-scale", "0.2", "--out", out("s5") + ".csv"],
        ["diagnose", str(log), "--json", out("d") + ".json", "--map", f"temp_c={v}"],
        ["sweep", "hidden", "--per-cause", v, "--out", out("sw")],
        ["sweep", "hidden", "--workers", v, "--per-cause", "1", "--out", out("sw2")],
        ["sweep", "montecarlo", "--seeds", v, "--out", out("sw3")],
        ["sweep", "montecarlo", "--temp-range", v, "50", "--seeds", "2", "--out", out("sw4")],
        ["bench", "--samples", v],
        ["bench", "--repeat", v, "--samples", "1000"],
    ]

# --- degenerate logs ---------------------------------------------------------------------------
lines = good.read_text().splitlines()
head = [l for l in lines if l.startswith("#")]
hdr = next(l for l in lines if not l.startswith("#"))
rows = [l for l in lines if not l.startswith("#")][1:]
cols = hdr.split(",")
data = np.array([[float(x) for x in r.split(",")] for r in rows])
def write(name, arr, header=hdr):
    p = base / name
    p.write_text(header + "\n" + "\n".join(",".join(f"{v:.12g}" for v in r) for r in arr) + "\n")
    return p
logs = {}
logs["rows3"] = write("rows3.csv", data[:3])
logs["rows10"] = write("rows10.csv", data[:10])
logs["rows50"] = write("rows50.csv", data[:50])
d = data.copy(); d[:, 0] = 0.0; logs["same_time"] = write("same_time.csv", d)
d = data.copy(); d[:, 0] = d[::-1, 0]; logs["decreasing_time"] = write("dec.csv", d)
d = data.copy(); d[:, 1] = 25.0; logs["flat_temp"] = write("flat_temp.csv", d)
d = data.copy(); d[:, 2] = 1.0; logs["flat_output"] = write("flat_out.csv", d)
d = data.copy(); d[:, 2] *= 1e300; logs["huge_output"] = write("huge.csv", d)
d = data.copy(); d[:, 2] *= 1e-300; logs["tiny_output"] = write("tiny.csv", d)
d = data.copy(); d[:, 1] = 1e6; logs["absurd_temp"] = write("absurd_temp.csv", d)
d = data.copy(); d[::2, 2] = np.nan; logs["half_nan"] = write("half_nan.csv", d)
d = data.copy(); d[:, 3:] = np.nan; logs["optional_nan"] = write("opt_nan.csv", d)
d = data.copy(); d[:, 4] = 0.0; logs["rate_zero"] = write("rate_zero.csv", d)
d = data.copy(); d[:, 0] = d[:, 0] * 1e9; logs["time_huge"] = write("time_huge.csv", d)
d = data.copy(); d[:, 0] = np.arange(len(d)) * 1e-9; logs["time_tiny"] = write("time_tiny.csv", d)
d = np.repeat(data[:1], 200, axis=0); d[:, 0] = np.arange(200) * 10; logs["constant_all"] = write("const.csv", d)
logs["only_required"] = write("req.csv", data[:, :3], header=",".join(cols[:3]))
d = data.copy(); d[:, 6] = 1e12; logs["quad_huge"] = write("quad_huge.csv", d)
d = data.copy(); d[:, 5] = 0.0; logs["freq_zero"] = write("freq_zero.csv", d)
d = data.copy(); d[:, 1] = np.where(np.arange(len(d)) % 2, 1e30, d[:, 1]); logs["temp_sentinel_half"] = write("sent.csv", d)
degenerate = []
for name, p in logs.items():
    degenerate.append((["diagnose", str(p), "--json", str(base / f"{name}.json")]))
    degenerate.append((["calibrate", str(p), "--paper", "002"]))
    degenerate.append((["calibrate", str(p), "--paper", "001"]))
    degenerate.append((["extend", str(p), "--no-rtl", "--out", str(base / f"ext_{name}")]))

# --- foreign logs ------------------------------------------------------------------------------
lines = [l for l in good.read_text().splitlines() if not l.startswith("#")]
hdr, rows = lines[0].split(","), lines[1:400]
def foreign(name, text): p = base / name; p.write_text(text); return p
semi = foreign("semi.csv", ";".join(["t", "box", "out"]) + "\n" + "\n".join(";".join(r.split(",")[:3]) for r in rows) + "\n")
dates = foreign("dates.csv", "stamp,box,out\n" + "\n".join(f"2024-01-01 {i//3600:02d}:{(i//60)%60:02d}:{i%60:02d},{r.split(',')[1]},{r.split(',')[2]}" for i, r in zip(range(0, 10*len(rows), 10), rows)) + "\n")
tabs = foreign("tabs.tsv", "t\tbox\tout\n" + "\n".join("\t".join(r.split(",")[:3]) for r in rows) + "\n")
quoted = foreign("quoted.csv", '"t","box","out"\n' + "\n".join(",".join(f'"{x}"' for x in r.split(",")[:3]) for r in rows) + "\n")
comma_dec = foreign("commadec.csv", "t;box;out\n" + "\n".join(";".join(x.replace(".", ",") for x in r.split(",")[:3]) for r in rows) + "\n")
empty_cells = foreign("empty.csv", "time_s,temp_c,output\n" + "\n".join(",".join(r.split(",")[:2]) + "," for r in rows) + "\n")
bom = base / "bom.csv"; bom.write_bytes(b"\xef\xbb\xbf" + good.read_bytes())
crlf = base / "crlf.csv"; crlf.write_bytes(good.read_bytes().replace(b"\n", b"\r\n"))
dup = foreign("dup.csv", "time_s,temp_c,output,output\n" + "\n".join(",".join(r.split(",")[:3] + [r.split(",")[2]]) for r in rows) + "\n")
ragged = foreign("ragged.csv", "time_s,temp_c,output\n" + "\n".join(",".join(r.split(",")[: 2 + (i % 3)]) for i, r in enumerate(rows)) + "\n")
hdronly = foreign("hdronly.csv", "time_s,temp_c,output\n")
emptyf = foreign("emptyfile.csv", "")
foreign_cases = [
 ["diagnose", str(semi), "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(semi), "--delimiter", ";;", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(semi), "--delimiter", "", "--map", "time_s=t"],
 ["diagnose", str(semi), "--delimiter", "\\t", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(tabs), "--delimiter", "tab", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(tabs), "--delimiter", "\t", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(dates), "--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out", "--time-format", "%Y-%m-%d %H:%M:%S"],
 ["diagnose", str(dates), "--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out", "--time-format", "%Q"],
 ["diagnose", str(dates), "--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out", "--time-format", ""],
 ["diagnose", str(dates), "--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(dates), "--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out", "--time-format", "%H"],
 ["diagnose", str(quoted), "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(comma_dec), "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(empty_cells)],
 ["diagnose", str(bom)], ["diagnose", str(crlf)], ["diagnose", str(dup)], ["diagnose", str(ragged)],
 ["diagnose", str(hdronly)], ["diagnose", str(emptyf)],
 ["diagnose", str(semi), "--map", "time_s=t,temp_c=box"], ["diagnose", str(semi), "--map", "=t"], ["diagnose", str(semi), "--map", "time_s="],
 ["diagnose", str(semi), "--delimiter", ";", "--map", "time_s=t", "--map", "time_s=box", "--map", "output=out"],
 ["diagnose", str(semi), "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=t", "--map", "output=out"],
 ["diagnose", str(semi), "--delimiter", ";", "--map", "time_s=nope", "--map", "temp_c=box", "--map", "output=out"],
 ["diagnose", str(semi), "--delimiter", ";", "--map", "quad=box", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out"],
 ["calibrate", str(dates), "--paper", "002", "--map", "time_s=stamp"],
 ["extend", str(semi), "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e1")],
 ["extend", str(dates), "--map", "time_s=stamp", "--map", "temp_c=box", "--map", "output=out", "--time-format", "%Q", "--no-rtl", "--out", str(base / "e2")],
 ["extend", str(semi), "--chain", "nope", "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e3")],
 ["extend", str(semi), "--chain", "paper001", "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e4")],
 ["extend", str(semi), "--chain", "paper000", "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e5")],
 ["extend", str(semi), "--chain", "thermometer", "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e6")],
 ["extend", str(semi), "--apply", str(emptyf), "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e7")],
 ["extend", str(semi), "--apply", str(semi), "--delimiter", ";", "--map", "time_s=t", "--map", "temp_c=box", "--map", "output=out", "--no-rtl", "--out", str(base / "e8")],
]


def one(item):
    kind, argv = item
    t0 = time.time()
    try:
        r = subprocess.run([FX, *argv], capture_output=True, text=True, timeout=120, cwd=base)
        code, err = r.returncode, r.stderr
    except subprocess.TimeoutExpired:
        code, err = "timeout", ""
    lines = [ln for ln in err.strip().splitlines() if ln.strip() and "%|" not in ln]
    bad = code in (70, "timeout") or "Traceback" in err or (code == 2 and len(lines) != 1)
    print(("BAD " if bad else "ok  ") + f"{code} [{kind}] {' '.join(argv)[:150]} {time.time() - t0:.0f}s :: "
          + (lines[-1][:200] if lines else ""), flush=True)
    if bad:
        print(err[-1500:], flush=True)
    return kind, bad


items = [("numeric", a) for a in numeric] + [("degenerate", a) for a in degenerate] + [("foreign", a) for a in foreign_cases]
with ThreadPoolExecutor(2) as pool:
    results = list(pool.map(one, items))
runs, bads = Counter(k for k, _ in results), Counter(k for k, b in results if b)
for kind in runs:
    print(f"{kind}: {runs[kind]} runs, {bads[kind]} BAD")
sys.exit(1 if bads else 0)
