#!/usr/bin/env python3
"""Prints docs/BENCHMARKS.md's accuracy tables: rows and path deviation of seed-exact,
constant-period at 50/20/10 ms and bounded-error at several tolerances, under both frequency
models, for the seed's move and for a line passing 60 mm from the base axis.

Run from the repository root: python3 scripts/accuracy_tables.py
(builds and runs `linterpd plan --format json`; needs only cargo and python3)."""
import json
import subprocess

MOVES = [
    ("seed's move", "config/linterpd.toml",
     ["--from=-926.57,535.03,50", "--to=-1144.43,659.60,186.60", "--speed", "240", "--accel-time", "200ms"]),
    ("line 60 mm from the axis", "benches/config/near-axis.toml",
     ["--from=-200,60,50", "--to=200,60,100", "--speed", "240", "--accel-time", "200ms"]),
]
METHODS = [
    ("seed-exact 50 ms", ["--period", "50ms", "--seed-exact"]),
    ("constant-period 50 ms", ["--period", "50ms"]),
    ("constant-period 20 ms", ["--period", "20ms"]),
    ("constant-period 10 ms", ["--period", "10ms"]),
    ("bounded-error 0.20 mm", ["--method", "bounded-error", "--tolerance", "0.2mm"]),
    ("bounded-error 0.10 mm", ["--method", "bounded-error", "--tolerance", "0.1mm"]),
    ("bounded-error 0.05 mm", ["--method", "bounded-error", "--tolerance", "0.05mm"]),
    ("bounded-error 0.04 mm", ["--method", "bounded-error", "--tolerance", "0.04mm"]),
]


def plan(config, args):
    cmd = ["cargo", "run", "--release", "-q", "--", "plan", "--config", config, "--format", "json"] + args
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        return None, out.stderr.strip().removeprefix("error: ")
    return json.loads(out.stdout), None


for title, config, move in MOVES:
    print(f"\n### {title}\n")
    print("| plan | model | valid | rows | words | path dev. mm | tracking mm | speed factor |")
    print("|---|---|---|---|---|---|---|---|")
    for name, extra in METHODS:
        for model in ["ideal", "fpx-divider"]:
            doc, err = plan(config, move + extra + ["--frequency-model", model])
            if err:
                print(f"| {name} | {model} | refused: {err} | | | | | |")
                continue
            f = doc["figures"]
            print(f"| {name} | {model} | {'yes' if doc['valid'] else 'no'} | {f['rows']} | {f['words']} | "
                  f"{f['path_deviation_mm']:.4f} | {f['tracking_error_mm']:.4f} | {doc['move']['speed_factor']:.3f} |")
