#!/usr/bin/env python3
"""tools/bench_stages.py — the per-stage time split of whole renders (DESIGN.md §6; Hanika
et al. 2010 Table 1 and Figure 9) and their depth complexity (Table 3).

Renders teapot, teapot_displaced and forest-1 with --stats, --runs times each (interleaved),
and keeps per scene the --stats file of the run with the median wall time (a real run, not a
mix of medians) in --stats-dir. Prints tools/profile's tables for those files (seconds and
share per stage, rays/s, and R, N, pairs and rays finished per wave and iteration) and writes
JSON with tools/profile's numbers plus every run's wall time. tools/bench draws the chart.

--size: tiny = every scene at 96x54 (teapot 1 spp), one run (the ctest smoke test);
small = half the scenes' resolution (teapot 640x360, forest-1 960x384) at their own samples
per pixel, 3 runs (the default); full = the scenes' own settings (1280x720 x 16 spp,
1920x768 x 1 spp), 3 runs. --runs overrides.

    tools/bench_stages.py --size small --stats-dir out/bench/stats --json out/bench/stages.json
"""
import argparse, json, os, shutil, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# scene file, its Format (scene/teapot.rib, forest-1.rib) and PixelSamples product
SCENES = [("teapot", 1280, 720, 16), ("teapot_displaced", 1280, 720, 16), ("forest-1", 1920, 768, 1)]
SIZES = {"tiny": (None, 1), "small": (2, 3), "full": (1, 3)}  # resolution divisor, runs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--scene-dir", default=os.path.join(ROOT, "scene"))
    ap.add_argument("--size", choices=sorted(SIZES), default="small")
    ap.add_argument("--runs", type=int, default=None)
    ap.add_argument("--stats-dir", default=None, help="keep each scene's median --stats file here")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    div, runs = SIZES[a.size]
    runs = a.runs if a.runs is not None else runs
    if runs < 1:
        ap.error("--runs must be at least 1")
    tmp = tempfile.mkdtemp(prefix="tessera-bench-stages-")
    keep = a.stats_dir or tmp
    os.makedirs(keep, exist_ok=True)
    plan = []
    for name, w, h, spp in SCENES:
        args = ["--res", "96x54", "--spp", "1"] if div is None else ["--res", f"{w // div}x{h // div}"]
        plan.append({"scene": name, "args": args, "samples": [], "files": []})
    for r in range(runs):  # interleaved, so slow minutes on the shared machine hit every scene
        for p in plan:
            path = os.path.join(tmp, f"{p['scene']}-{r}.json")
            cmd = [a.binary, "render", os.path.join(a.scene_dir, p["scene"] + ".rib"), "-o",
                   os.path.join(tmp, "out.png"), "--quiet", "--stats", path] + p["args"]
            subprocess.run(cmd, check=True)
            with open(path) as f:
                p["samples"].append(json.load(f)["wall_seconds"])
            p["files"].append(path)
    kept = []
    for p in plan:
        order = sorted(range(runs), key=lambda i: p["samples"][i])
        dst = os.path.join(keep, f"{p['scene']}.json")
        shutil.copyfile(p["files"][order[(runs - 1) // 2]], dst)
        kept.append(dst)
    prof = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "profile"), "--json", "-"] + kept,
                          check=True, capture_output=True, text=True)
    profile = json.loads(prof.stdout)
    print(f"per-stage split, size {a.size}: the run with the median wall time of {runs} per scene\n", flush=True)
    subprocess.run([sys.executable, os.path.join(ROOT, "tools", "profile")] + kept, check=True)
    result = {
        "benchmark": "stages", "size": a.size, "runs": runs,
        "scenes": [{"scene": p["scene"], "options": " ".join(p["args"]),
                    "wall_seconds": p["samples"],
                    "wall_seconds_median": statistics.median(p["samples"]),
                    "stats": os.path.join(keep, f"{p['scene']}.json") if a.stats_dir else None}
                   for p in plan],
        "profile": profile,
    }
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=2)
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
