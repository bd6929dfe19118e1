"""Building a scenario, two checkouts in turns: seconds and bytes on disk.

For each of ``--repeats`` rounds, tree A and tree B (``--tree-a`` / ``--tree-b``: checkouts of this
repository; default both this one) each build scenario ``--scenario`` (default ``circle_walk``, the
paper's walk at its defaults) into a fresh temporary directory in its own subprocess
(``PYTHONPATH`` = the tree), A then B then A ... on the same machine load. Per build: the seconds of
``sionnafmcw.scenes.build`` itself (imports excluded), the CPU seconds of the whole process, the
files and bytes written. Printed: every build, the medians per tree, and B/A ratios of the build
seconds and of the bytes.

    python benchmarks/scene_build.py --tree-a /tmp/main --tree-b . [--repeats 3] [--scenario circle_walk]
        [--param body_mesh_edge=0.008 ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

WORKER = r"""
import json, os, resource, sys, time
from pathlib import Path
spec = json.loads(sys.argv[1])
from sionnafmcw import scenes
from sionnafmcw.scenes.registry import parse_value
t0 = time.perf_counter()
params = {k: parse_value(spec["scenario"], k, v) for k, v in spec["params"].items()}
out = scenes.build(spec["scenario"], spec["out"], **params)
seconds = time.perf_counter() - t0
files = [p for p in Path(out).rglob("*") if p.is_file()]
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"seconds": seconds, "cpu": usage.ru_utime + usage.ru_stime, "files": len(files),
                  "bytes": sum(p.stat().st_size for p in files)}))
"""


def build(tree: Path, scenario: str, params: dict) -> dict:
    with tempfile.TemporaryDirectory(prefix="scene-build-") as tmp:
        spec = {"scenario": scenario, "params": params, "out": str(Path(tmp) / "scene")}
        env = os.environ | {"PYTHONPATH": str(tree)}
        # cwd: a directory without a sionnafmcw package, so that PYTHONPATH decides which one is imported
        proc = subprocess.run([sys.executable, "-c", WORKER, json.dumps(spec)], env=env, capture_output=True,
                              text=True, cwd=tmp)
        if proc.returncode != 0:
            raise SystemExit(f"build with {tree} failed:\n{proc.stderr[-3000:]}")
        return json.loads(proc.stdout.strip().splitlines()[-1])


def median(values):
    values = sorted(values)
    return values[len(values) // 2] if len(values) % 2 else 0.5 * (values[len(values) // 2 - 1] + values[len(values) // 2])


def main(argv=None) -> int:
    here = Path(__file__).resolve().parents[1]
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tree-a", default=str(here), help="checkout A (default: this one)")
    p.add_argument("--tree-b", default=str(here), help="checkout B (default: this one)")
    p.add_argument("--scenario", default="circle_walk")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="scenario parameter (both trees)")
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    for flag, tree in (("--tree-a", args.tree_a), ("--tree-b", args.tree_b)):
        if not (Path(tree) / "sionnafmcw" / "__init__.py").is_file():
            p.error(f"{flag} {tree}: no sionnafmcw package there (expected a checkout of this repository)")
    if args.repeats < 1:
        p.error("--repeats must be >= 1")
    params = dict(kv.split("=", 1) for kv in args.param)
    runs = {"A": [], "B": []}
    for r in range(args.repeats):
        for name, tree in (("A", args.tree_a), ("B", args.tree_b)):
            result = build(Path(tree), args.scenario, params)
            runs[name].append(result)
            print(f"round {r + 1} {name}: build {result['seconds']:.2f} s, process CPU {result['cpu']:.2f} s, "
                  f"{result['files']} files, {result['bytes'] / 1e6:.2f} MB", flush=True)
    med = {k: {f: median([x[f] for x in v]) for f in ("seconds", "cpu", "files", "bytes")} for k, v in runs.items()}
    for name in ("A", "B"):
        m = med[name]
        print(f"{name} median: build {m['seconds']:.2f} s, process CPU {m['cpu']:.2f} s, {m['files']:.0f} files, "
              f"{m['bytes'] / 1e6:.2f} MB")
    print(f"B/A: build seconds {med['B']['seconds'] / med['A']['seconds']:.3f} "
          f"({med['A']['seconds'] / med['B']['seconds']:.1f}x faster), bytes {med['B']['bytes'] / med['A']['bytes']:.4f} "
          f"({med['A']['bytes'] / med['B']['bytes']:.0f}x smaller)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
