#!/usr/bin/env python3
"""tools/bench_render.py — the foundation benchmark (issue: teapot at 1280x720, 1 spp, m = 8).

Runs `tessera render` repeatedly with --stats and reports medians: whole-render wall time
with a warm kernel cache, the per-stage split, bottom_level (ray, patch) traversals per
second, and the kernel build time cold (empty Tessera and PoCL caches) and from the cache.
Prints a Markdown table and writes JSON (--json). Timings are medians of --runs runs; the
machine is noisy, so compare ratios measured in the same run, never single numbers.

--size (tools/bench, issue 8): tiny = 128x72, m = 5, one run, no cold run (the caches of the
environment are used; for the ctest smoke test); small = 1280x720, m = 8, 7 runs (the
issue's benchmark, the default); full = the same with 15 runs. --res, --max-lod and --runs
override the size. --stats-out keeps the --stats file of the run with the median wall time
(tools/profile draws it).

    tools/bench_render.py --runs 7 --json out/bench_render.json
"""
import argparse, json, os, shutil, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = {  # resolution, max LOD, runs, cold run
    "tiny": ("128x72", "5", 1, False),
    "small": ("1280x720", "8", 7, True),
    "full": ("1280x720", "8", 15, True),
}


def render(binary, scene, args, env, stats_path):
    cmd = [binary, "render", scene, "-o", os.path.join(os.path.dirname(stats_path), "bench.png"),
           "--quiet", "--stats", stats_path] + args
    subprocess.run(cmd, check=True, env=env)
    with open(stats_path) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--scene", default=os.path.join(ROOT, "scene", "teapot.rib"))
    ap.add_argument("--size", choices=sorted(SIZES), default="small")
    ap.add_argument("--res", default=None)
    ap.add_argument("--max-lod", default=None)
    ap.add_argument("--runs", type=int, default=None)
    ap.add_argument("--no-cold", action="store_true", help="skip the run with empty caches")
    ap.add_argument("--json", default=None)
    ap.add_argument("--stats-out", default=None, help="copy the median run's --stats file here")
    a = ap.parse_args()
    res, max_lod, runs_n, cold_run = SIZES[a.size]
    a.res, a.max_lod = a.res or res, a.max_lod or max_lod
    a.runs = a.runs if a.runs is not None else runs_n
    cold_run = cold_run and not a.no_cold
    if a.runs < 1:
        ap.error("--runs must be at least 1")
    args = ["--res", a.res, "--spp", "1", "--max-lod", a.max_lod]
    tmp = tempfile.mkdtemp(prefix="tessera-bench-")
    env = dict(os.environ)
    if cold_run:  # private, empty caches: the cold run compiles everything
        env.update(TESSERA_CACHE_DIR=os.path.join(tmp, "tcache"), POCL_CACHE_DIR=os.path.join(tmp, "pcache"))
    cold = render(a.binary, a.scene, args, env, os.path.join(tmp, "cold.json")) if cold_run else None
    paths = [os.path.join(tmp, f"stats-{i}.json") for i in range(a.runs)]
    runs = [render(a.binary, a.scene, args, env, p) for p in paths]
    med = lambda xs: statistics.median(xs)
    stages = {k: med([r["stages"][k] for r in runs]) for k in runs[0]["stages"]}
    wall = med([r["wall_seconds"] for r in runs])
    pairs = runs[0]["counters"]["pairs"]
    result = {
        "device": runs[0]["device"], "runs": a.runs, "resolution": a.res, "max_lod": int(a.max_lod),
        "size": a.size, "scene": os.path.basename(a.scene),
        "wall_seconds_median": wall,
        "wall_seconds_cold": cold["wall_seconds"] if cold else None,
        "kernel_build_seconds_cold": cold["kernel_build_seconds"] if cold else None,
        "kernel_build_seconds_cached": med([r["kernel_build_seconds"] for r in runs]),
        "stages_median": stages,
        "pairs": pairs,
        "bottom_level_pairs_per_second": med([r["counters"]["pairs"] / r["stages"]["bottom_level"] for r in runs]),
        "iterations": runs[0]["counters"]["iterations"],
        "peak_rss_bytes": med([r["peak_rss_bytes"] for r in runs]),
        # every run's wall time and the sum of its stage seconds (which exclude scene
        # loading, device set-up and the kernel build, so the sum is below the wall time)
        "per_run": [{"wall_seconds": r["wall_seconds"], "stage_seconds_sum": sum(r["stages"].values()),
                     "rays": r["counters"]["rays"] + r["counters"]["shadow_rays"]} for r in runs],
    }
    if a.stats_out:  # the run whose wall time is the median (the lower middle one for even counts)
        order = sorted(range(a.runs), key=lambda i: runs[i]["wall_seconds"])
        shutil.copyfile(paths[order[(a.runs - 1) // 2]], a.stats_out)
    total = sum(stages.values())
    print(f"device: {result['device']}; {result['scene']} {a.res}, 1 spp, m = {a.max_lod}; "
          f"medians of {a.runs} runs\n")
    print("| stage | seconds | share |\n|---|---:|---:|")
    for k, v in stages.items():
        print(f"| {k} | {v:.4f} | {100 * v / total if total > 0 else 0:.1f}% |")
    print(f"\n| measure | value |\n|---|---:|")
    print(f"| whole render, warm kernel cache (wall) | {wall:.3f} s |")
    if cold:
        print(f"| first render, empty caches (wall) | {cold['wall_seconds']:.3f} s |")
        print(f"| kernel build, cold | {result['kernel_build_seconds_cold']:.3f} s |")
    print(f"| kernel build, from the cache | {result['kernel_build_seconds_cached']:.3f} s |")
    print(f"| bottom_level (ray, patch) traversals/s | {result['bottom_level_pairs_per_second'] / 1e6:.2f} M |")
    print(f"| pairs, iterations | {pairs}, {result['iterations']} |")
    print(f"| peak RSS | {result['peak_rss_bytes'] / 2**20:.0f} MiB |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=2)
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
