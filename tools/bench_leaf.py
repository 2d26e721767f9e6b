#!/usr/bin/env python3
"""tools/bench_leaf.py — per-ray vs work-group leaf intersection (issue 6, PantaRay Fig. 8).

Renders the same scene with --leaf-mode ray and group at several --leaf-size values,
interleaved, and reports medians over --runs of: bottom_level (ray, patch) traversals per
second, bottom_level seconds, and the leaf utilisation (micro-quad tests over work-item
slots; for the per-ray kernel a work-group is taken to run in lockstep). Eye rays only
(--depth 0), micro-triangles at a fixed level of detail, so the bottom level dominates.

--size (tools/bench, issue 8): tiny = 64x36, m = 4, one run without warm-up renders (the
ctest smoke test); small = 640x360, m = 8, 5 runs (the default); full = 1280x720, m = 8,
7 runs. --res, --lod and --runs override the size.

    tools/bench_leaf.py --runs 5 --json out/bench_leaf.json
"""
import argparse, json, os, shutil, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = {  # resolution, LOD, runs, warm-up renders
    "tiny": ("64x36", "4", 1, False),
    "small": ("640x360", "8", 5, True),
    "full": ("1280x720", "8", 7, True),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--scene", default=os.path.join(ROOT, "scene", "teapot.rib"))
    ap.add_argument("--size", choices=sorted(SIZES), default="small")
    ap.add_argument("--res", default=None)
    ap.add_argument("--lod", default=None)
    ap.add_argument("--sizes", default="1,2,4", help="leaf sizes (1, 2, 4)")
    ap.add_argument("--runs", type=int, default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    res, lod, runs, warm = SIZES[a.size]
    a.res, a.lod = a.res or res, a.lod or lod
    a.runs = a.runs if a.runs is not None else runs
    if a.runs < 1:
        ap.error("--runs must be at least 1")
    tmp = tempfile.mkdtemp(prefix="tessera-bench-leaf-")
    stats = os.path.join(tmp, "s.json")
    configs = [(mode, int(size)) for size in a.sizes.split(",") for mode in ("ray", "group")]
    samples = {c: [] for c in configs}
    base = [a.binary, "render", a.scene, "-o", os.path.join(tmp, "x.exr"), "--quiet", "--res", a.res,
            "--spp", "1", "--depth", "0", "--lod", a.lod, "--intersect", "triangles", "--stats", stats]
    for c in configs if warm else []:  # warm the kernel caches
        subprocess.run(base + ["--leaf-mode", c[0], "--leaf-size", str(c[1])], check=True)
    for _ in range(a.runs):
        for c in configs:
            subprocess.run(base + ["--leaf-mode", c[0], "--leaf-size", str(c[1])], check=True)
            with open(stats) as f:
                samples[c].append(json.load(f))
    med = statistics.median
    rows = []
    for c in configs:
        s = samples[c]
        rows.append({
            "leaf_mode": c[0], "leaf_size": c[1],
            "bottom_level_seconds": med(r["stages"]["bottom_level"] for r in s),
            "traversals_per_second": med(r["counters"]["pairs"] / r["stages"]["bottom_level"] for r in s),
            "leaf_utilisation": med(r["leaf_utilisation"] for r in s),
            "leaf_tests": s[0]["counters"]["leaf_tests"],
            "pairs": s[0]["counters"]["pairs"],
        })
    print(f"device: {samples[configs[0]][0]['device']}; {os.path.basename(a.scene)} {a.res}, eye rays, "
          f"m = {a.lod}, micro-triangles; medians of {a.runs} interleaved runs\n")
    print("| leaf mode | leaf size | bottom_level s | M traversals/s | leaf utilisation | micro-quad tests |")
    print("|---|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['leaf_mode']} | {r['leaf_size']}x{r['leaf_size']} | {r['bottom_level_seconds']:.3f} | "
              f"{r['traversals_per_second'] / 1e6:.2f} | {100 * r['leaf_utilisation']:.1f}% | {r['leaf_tests']} |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"device": samples[configs[0]][0]["device"], "size": a.size, "resolution": a.res,
                       "lod": int(a.lod), "runs": a.runs, "rows": rows}, f, indent=2)
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
