#!/usr/bin/env python3
"""tools/bench_render.py — the foundation benchmark (issue: teapot at 1280x720, 1 spp, m = 8).

Runs `tessera render` repeatedly with --stats and reports medians: whole-render wall time
with a warm kernel cache, the per-stage split, bottom_level (ray, patch) traversals per
second, and the kernel build time cold (empty Tessera and PoCL caches) and from the cache.
Prints a Markdown table and writes JSON (--json). Timings are medians of --runs runs; the
machine is noisy, so compare ratios measured in the same run, never single numbers.

    tools/bench_render.py --runs 7 --json out/bench_render.json
"""
import argparse, json, os, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


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
    ap.add_argument("--res", default="1280x720")
    ap.add_argument("--max-lod", default="8")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    args = ["--res", a.res, "--spp", "1", "--max-lod", a.max_lod]
    tmp = tempfile.mkdtemp(prefix="tessera-bench-")
    stats = os.path.join(tmp, "stats.json")
    env = dict(os.environ, TESSERA_CACHE_DIR=os.path.join(tmp, "tcache"),
               POCL_CACHE_DIR=os.path.join(tmp, "pcache"))
    cold = render(a.binary, a.scene, args, env, stats)  # empty caches: compiles everything
    runs = [render(a.binary, a.scene, args, env, stats) for _ in range(a.runs)]
    med = lambda xs: statistics.median(xs)
    stages = {k: med([r["stages"][k] for r in runs]) for k in runs[0]["stages"]}
    wall = med([r["wall_seconds"] for r in runs])
    pairs = runs[0]["counters"]["pairs"]
    result = {
        "device": runs[0]["device"], "runs": a.runs, "resolution": a.res, "max_lod": int(a.max_lod),
        "wall_seconds_median": wall,
        "wall_seconds_cold": cold["wall_seconds"],
        "kernel_build_seconds_cold": cold["kernel_build_seconds"],
        "kernel_build_seconds_cached": med([r["kernel_build_seconds"] for r in runs]),
        "stages_median": stages,
        "pairs": pairs,
        "bottom_level_pairs_per_second": med([r["counters"]["pairs"] / r["stages"]["bottom_level"] for r in runs]),
        "iterations": runs[0]["counters"]["iterations"],
        "peak_rss_bytes": med([r["peak_rss_bytes"] for r in runs]),
    }
    total = sum(stages.values())
    print(f"device: {result['device']}; teapot {a.res}, 1 spp, m = {a.max_lod}; medians of {a.runs} runs\n")
    print("| stage | seconds | share |\n|---|---:|---:|")
    for k, v in stages.items():
        print(f"| {k} | {v:.4f} | {100 * v / total:.1f}% |")
    print(f"\n| measure | value |\n|---|---:|")
    print(f"| whole render, warm kernel cache (wall) | {wall:.3f} s |")
    print(f"| first render, empty caches (wall) | {cold['wall_seconds']:.3f} s |")
    print(f"| kernel build, cold | {result['kernel_build_seconds_cold']:.3f} s |")
    print(f"| kernel build, from the cache | {result['kernel_build_seconds_cached']:.3f} s |")
    print(f"| bottom_level (ray, patch) traversals/s | {result['bottom_level_pairs_per_second'] / 1e6:.2f} M |")
    print(f"| pairs, iterations | {pairs}, {result['iterations']} |")
    print(f"| peak RSS | {result['peak_rss_bytes'] / 2**20:.0f} MiB |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
