#!/usr/bin/env python3
"""tools/bench_lod.py — which level-of-detail rule to dice by (issue 13, item 3).

For each scene, renders a reference with every patch diced at a fixed --lod (finer than
any rule picks at this size; seed 1000; none for forest-100, whose reference would take an
hour here), then the image under each rule of the lod stage
(TESSERA_LOD_RULE: crossed = every eye-ray crossing of a patch's box, the default;
visible = only crossings before each ray's closest hit, m = max(m_visible, m_crossed - 2);
seen = m_crossed for a patch some eye ray reaches, m_crossed - 2 for one none does) with
seed 0, plus `crossed` with seed 1, and reports per rule:
  diced, micropolygons: counters.patches_diced and counters.micropolygons_created;
  rmse:    root mean square difference from the reference in 8-bit sRGB levels (0-255) of
           the PNG Tessera writes: geometric error plus the Monte Carlo noise of both images;
  seconds: wall time (warm kernel cache);
  frame_lod_histogram: --stats' patches per level m at the frame's levels of detail.
`noise floor` is the RMSE between the crossed images of seeds 0 and 1 divided by sqrt(2):
the part of every rmse that is noise, not level of detail.

    tools/bench_lod.py --json out/lod.json                 # forest-1 320x200x64, forest-100 960x384x1
    tools/bench_lod.py --size tiny                         # seconds: forest-1 96x64x4

Reference images are kept in --cache (default out/lod-cache/), keyed by the binary's checksum.
"""
import argparse
import importlib.util
import json
import math
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RULES = ["crossed", "visible", "seen"]
SIZES = {  # (scene, resolution, spp, reference lod or None: no reference) per scene
    "tiny": [("forest-1", "96x64", 4, 5)],
    "small": [("forest-1", "320x200", 64, 6), ("forest-100", "960x384", 1, None)],
    "full": [("forest-1", "640x400", 64, 7), ("forest-100", "1920x768", 1, None)],
}


def bench_noise():
    """tools/bench_noise.py as a module: its PNG reader, RMSE and file checksum."""
    spec = importlib.util.spec_from_file_location("bench_noise", os.path.join(ROOT, "tools", "bench_noise.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def render(a, scene, res, spp, out, seed, rule=None, lod=None, stats=None):
    cmd = [a.binary, "render", scene, "-o", out, "--res", res, "--spp", str(spp), "--seed", str(seed), "--quiet"]
    if lod is not None:
        cmd += ["--lod", str(lod)]
    if stats:
        cmd += ["--stats", stats]
    env = dict(os.environ)
    env.pop("TESSERA_LOD_RULE", None)
    if rule:
        env["TESSERA_LOD_RULE"] = rule
    t0 = time.monotonic()
    subprocess.run(cmd, check=True, env=env)
    return time.monotonic() - t0


def fmt(v):
    return "-" if v is None else f"{v:.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--size", choices=sorted(SIZES), default="small")
    ap.add_argument("--cache", default=os.path.join(ROOT, "out", "lod-cache"))
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    noise = bench_noise()
    png = noise.load_png_tools()
    os.makedirs(a.cache, exist_ok=True)
    tag = noise.file_hash(a.binary)
    results = []
    with tempfile.TemporaryDirectory(prefix="tessera-bench-lod-") as tmp:
        for name, res, spp, ref_lod in SIZES[a.size]:
            scene = os.path.join(ROOT, "scene", name + ".rib")
            ref = os.path.join(a.cache, f"{name}-{res}-{spp}-lod{ref_lod}-{tag}.png") if ref_lod else None
            if ref and not os.path.exists(ref):
                print(f"  {name}: reference at --lod {ref_lod} ...", file=sys.stderr)
                render(a, scene, res, spp, ref + ".tmp.png", 1000, lod=ref_lod)
                os.replace(ref + ".tmp.png", ref)
            rows = []
            for rule in RULES:
                out, stats = os.path.join(tmp, f"{name}-{rule}.png"), os.path.join(tmp, f"{name}-{rule}.json")
                seconds = render(a, scene, res, spp, out, 0, rule=rule, stats=stats)
                with open(stats) as f:
                    j = json.load(f)
                c = j["counters"]
                row = {"rule": rule, "diced": c["patches_diced"], "micropolygons": c["micropolygons_created"],
                       "frame_lod_histogram": j["frame_lod_histogram"],
                       "rmse": noise.rmse_levels(png, ref, out) if ref else None, "seconds": seconds}
                rows.append(row)
                print(f"  {name} {rule}: {row['diced']} dicings, {row['micropolygons']} micro-polygons, "
                      f"rmse {fmt(row['rmse'])}, {seconds:.1f} s", file=sys.stderr)
            other = os.path.join(tmp, f"{name}-crossed-seed1.png")
            render(a, scene, res, spp, other, 1, rule="crossed")
            floor = noise.rmse_levels(png, os.path.join(tmp, f"{name}-crossed.png"), other) / math.sqrt(2)
            results.append({"scene": f"scene/{name}.rib", "res": res, "spp": spp, "ref_lod": ref_lod,
                            "noise_floor": floor, "rows": rows})
    print("| scene | rule | dicings | micro-polygons | RMSE vs reference (levels) | noise floor (levels) | seconds |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for r in results:
        for row in r["rows"]:
            print(f"| {r['scene']} {r['res']}x{r['spp']} | {row['rule']} | {row['diced']} | {row['micropolygons']} | "
                  f"{fmt(row['rmse'])} | {r['noise_floor']:.3f} | {row['seconds']:.1f} |")
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as f:
            json.dump({"benchmark": "lod", "binary_sha": tag, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
