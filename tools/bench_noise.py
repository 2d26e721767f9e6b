#!/usr/bin/env python3
"""tools/bench_noise.py — how fast Tessera's samples converge (issue 14).

For each scene, renders a reference at --ref-spp samples per pixel, then the same image at
each of --spp (default 4, 16, 64) with two seeds, and reports per spp:
  rmse:   root mean square difference from the reference over the whole image, in 8-bit
          sRGB levels (0-255) of the PNG Tessera writes (the reference's own noise is
          1/sqrt(ref_spp / spp) of it and is not subtracted);
  noise:  std(I_seed0 - I_seed1) / sqrt(2) in the same levels, inside the body region of
          tools/bench_cycles.py (--region) and over the whole image: the per-pixel Monte
          Carlo standard deviation, the measure bench_cycles.py reports for Cycles too;
  seconds: wall time of the seed-0 render (warm kernel cache).
The reference of a binary, scene, size and seed set is kept in --cache (default
out/noise-cache/), keyed by the binary's checksum, so "before" and "after" builds each
have their own and a rerun costs only the low-spp renders.

    tools/bench_noise.py --json out/noise.json                     # teapot, displaced teapot, forest-1
    tools/bench_noise.py --binary /tmp/old/tessera --json out/noise-before.json

--size tiny (the ctest smoke test): 64x36, reference 64 spp, spp 1 and 4, teapot only.
"""
import argparse
import hashlib
import importlib.util
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = {  # resolution, reference spp, spp list, scenes
    "tiny": ("64x36", 64, [1, 4], ["teapot"]),
    "small": ("320x180", 4096, [4, 16, 64], ["teapot", "teapot_displaced", "forest-1"]),
    "full": ("640x360", 4096, [4, 16, 64], ["teapot", "teapot_displaced", "forest-1"]),
}


def load_png_tools():
    spec = importlib.util.spec_from_file_location("bench_cycles", os.path.join(ROOT, "tools", "bench_cycles.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def file_hash(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:16]


def render(a, scene, out, spp, seed):
    cmd = [a.binary, "render", scene, "-o", out, "--res", a.res, "--spp", str(spp), "--seed", str(seed),
           "--depth", str(a.depth), "--quiet"] + a.tessera_args
    t0 = time.monotonic()
    subprocess.run(cmd, check=True)
    return time.monotonic() - t0


def rmse_levels(png, path_a, path_b):
    w, h, ra = png.png_read(path_a)
    w2, h2, rb = png.png_read(path_b)
    if (w, h) != (w2, h2):
        raise SystemExit("bench_noise: reference and image differ in size")
    ss = 0
    for y in range(h):
        a, b = ra[y], rb[y]
        ss += sum((a[i] - b[i]) ** 2 for i in range(3 * w))
    return math.sqrt(ss / (3 * w * h))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--size", choices=sorted(SIZES), default="small")
    ap.add_argument("--scene", action="append", help="scene name in scene/ or a path (repeat)")
    ap.add_argument("--res", default=None)
    ap.add_argument("--ref-spp", type=int, default=None)
    ap.add_argument("--spp", default=None, help="comma-separated sample counts")
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--region", default="0.36,0.50,0.52,0.66")
    ap.add_argument("--tessera-arg", dest="tessera_args", action="append", default=[])
    ap.add_argument("--cache", default=os.path.join(ROOT, "out", "noise-cache"))
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    res, ref_spp, spps, scenes = SIZES[a.size]
    a.res = a.res or res
    a.ref_spp = a.ref_spp or ref_spp
    spps = [int(v) for v in a.spp.split(",")] if a.spp else spps
    scenes = a.scene or scenes
    region = [float(v) for v in a.region.split(",")]
    png = load_png_tools()
    os.makedirs(a.cache, exist_ok=True)
    tag = file_hash(a.binary)
    results = []
    for name in scenes:
        scene = name if os.path.exists(name) else os.path.join(ROOT, "scene", name + ".rib")
        base = os.path.splitext(os.path.basename(scene))[0]
        extra = hashlib.sha256(" ".join(a.tessera_args).encode()).hexdigest()[:8]
        ref = os.path.join(a.cache, f"{base}-{a.res}-{a.ref_spp}-d{a.depth}-{tag}-{extra}.png")
        ref_seconds = None
        if not os.path.exists(ref):
            print(f"  {base}: reference at {a.ref_spp} spp ...", file=sys.stderr)
            ref_seconds = render(a, scene, ref + ".tmp.png", a.ref_spp, 1000)
            os.replace(ref + ".tmp.png", ref)
        rows = []
        for spp in spps:
            outs = [os.path.join(a.cache, f"run-{base}-{spp}-{s}.png") for s in (0, 1)]
            seconds = render(a, scene, outs[0], spp, 0)
            render(a, scene, outs[1], spp, 1)
            body, whole = png.noise_levels(outs[0], outs[1], region)
            row = {"spp": spp, "rmse": rmse_levels(png, ref, outs[0]), "noise_body": body, "noise_image": whole,
                   "seconds": seconds}
            rows.append(row)
            print(f"  {base} {spp:5d} spp: rmse {row['rmse']:.2f}, noise body {body:.2f}, image {whole:.2f}, "
                  f"{seconds:.1f} s", file=sys.stderr)
        results.append({"scene": os.path.relpath(scene, ROOT), "res": a.res, "ref_spp": a.ref_spp,
                        "reference_seconds": ref_seconds, "rows": rows})
    print("| scene | spp | RMSE vs reference (levels) | noise, body (levels) | noise, image (levels) | seconds |")
    print("|---|---:|---:|---:|---:|---:|")
    for r in results:
        for row in r["rows"]:
            print(f"| {r['scene']} {r['res']} | {row['spp']} | {row['rmse']:.2f} | {row['noise_body']:.2f} | "
                  f"{row['noise_image']:.2f} | {row['seconds']:.1f} |")
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as f:
            json.dump({"benchmark": "noise", "binary_sha": tag, "depth": a.depth, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
