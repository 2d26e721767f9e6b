#!/usr/bin/env python3
"""tools/bench_cycles.py — Tessera against Blender Cycles on the same scene (issues 13, 14).

Builds the scene Tessera renders in Cycles (CPU) — same camera, lights, surface colour,
samples, path depth and thread count — and runs both renderers in alternation. Reports for
each renderer: wall seconds (median), peak RSS, and pixel noise at equal samples, with the
Tessera / Cycles ratios.

Needs Blender's Python module `bpy`; it installs nothing. Set it up once, outside the
repository, then run this script with that interpreter (it imports bpy only in the Cycles
worker process):

    python3 -m venv ~/bpy-venv && ~/bpy-venv/bin/pip install bpy     # bpy 5.0.1: Python 3.11
    ~/bpy-venv/bin/python tools/bench_cycles.py --json out/cycles.json

How the scene is rebuilt (build/bench_export writes the loaded scene as JSON):
  geometry:  every Bézier patch evaluated on a 16 x 16 grid (--grid), welded into one mesh
             with smooth normals, Catmull-Clark adaptive subdivision at 1 px (--dicing-rate)
             and true displacement (material displacement method "Displacement only");
             Tessera's fBm is its own gradient noise, so Cycles gets its Noise Texture with
             the same frequency (Scale), octaves (Detail = octaves - 1), gain (Roughness)
             and lacunarity, in object space, height = amplitude * 2 * (noise - 0.5): the
             same kind and size of roughness, not the same pattern;
  material:  Diffuse BSDF of albedo Kd * Cs (matte; plastic gets Diffuse + GGX Glossy);
  lights:    a Sun of the same angular diameter and irradiance, a World background of the
             dome's radiance; no other lights, no denoising, no adaptive sampling;
  camera:    the same position and fov (of the shorter axis), Box pixel filter of 1 px like
             Tessera's jittered box; Standard view transform, exposure 0, 8-bit sRGB PNG.
Cycles: max bounces = --depth (Tessera's depth counts bounces after the eye ray), threads =
--threads, seed = the run's seed.

Measures:
  wall:   Tessera: the whole `tessera render` process (scene load, warm kernel cache, render,
          PNG). Cycles: the bpy.ops.render.render() call (scene sync, subdivision,
          displacement, BVH, render, no Blender start-up or Python scene construction);
          the worker's total is reported too.
  memory: peak RSS of the Tessera process; peak RSS of the Cycles worker (Blender included).
  noise:  two renders per renderer with seeds 0 and 1: noise = std(I0 - I1) / sqrt(2) in
          8-bit sRGB levels (0-255), the per-pixel Monte Carlo standard deviation at these
          samples; inside the "body" rectangle (--region, fractions of the image; the
          default lies on the teapot's sunlit body) and over the whole image.
Runs alternate Tessera and Cycles (--runs each, seeds 0, 1, 0, 1, ...); medians reported.
--intersect boxes,triangles runs Tessera in both geometry modes (a row each, alternated too).
"""
import argparse
import json
import math
import os
import statistics
import struct
import subprocess
import sys
import tempfile
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_REGION = "0.36,0.50,0.52,0.66"  # x0,y0,x1,y1 fractions: the sunlit body of the teapot


# ---- PNG reading (8-bit RGB/RGBA, non-interlaced: what both renderers write) -------------

def png_read(path):
    """Returns (width, height, rows) with rows a list of bytes of RGB triples."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, width = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            width, height, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or ctype not in (2, 6) or interlace:
                raise ValueError(f"{path}: want 8-bit RGB(A) non-interlaced")
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + ((a + b) >> 1)) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line) if bpp == 3 else bytes(v for k, v in enumerate(line) if k % 4 != 3))
        prev = line
    return width, height, rows


def noise_levels(path0, path1, region):
    """std(I0 - I1) / sqrt(2) over the region (fractions) and over the image, in 8-bit levels."""
    w, h, r0 = png_read(path0)
    w1, h1, r1 = png_read(path1)
    if (w, h) != (w1, h1):
        raise ValueError("noise: images differ in size")
    x0, y0, x1, y1 = (int(round(f * s)) for f, s in zip(region, (w, h, w, h)))

    def std_of(ys, xs):
        n = s = ss = 0
        for y in ys:
            a, b = r0[y], r1[y]
            for x in xs:
                for c in range(3):
                    d = a[3 * x + c] - b[3 * x + c]
                    n += 1
                    s += d
                    ss += d * d
        mean = s / n
        return math.sqrt(max(ss / n - mean * mean, 0.0) / 2.0)

    return std_of(range(y0, y1), range(x0, x1)), std_of(range(h), range(w))


def mean_level(path, region):
    w, h, rows = png_read(path)
    x0, y0, x1, y1 = (int(round(f * s)) for f, s in zip(region, (w, h, w, h)))
    vals = [rows[y][3 * x + c] for y in range(y0, y1) for x in range(x0, x1) for c in range(3)]
    return sum(vals) / len(vals)


# ---- Cycles worker (runs under the bpy interpreter) --------------------------------------

def cycles_worker(a):
    import resource
    t_start = time.monotonic()
    import bpy  # noqa: E402 (only the worker needs Blender)
    with open(a.worker_scene) as f:
        s = json.load(f)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cam = s["camera"]
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.render.resolution_x, scene.render.resolution_y = cam["width"], cam["height"]
    scene.render.resolution_percentage = 100
    scene.render.threads_mode = "FIXED"
    scene.render.threads = a.threads
    c = scene.cycles
    c.samples = a.spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = a.seed
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = a.depth
    c.transparent_max_bounces = c.transmission_bounces = c.volume_bounces = 0
    c.caustics_reflective = c.caustics_refractive = True
    c.dicing_rate = a.dicing_rate
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "8"
    scene.render.film_transparent = False

    # Camera: Tessera looks along forward with right/up spanning the screen. Blender's camera
    # looks down its local -Z with +X right and +Y up; RenderMan's camera space is
    # left-handed, so the frame (right, up, -forward) is a mirror: the camera gets -right and
    # the image is flipped back horizontally by the caller.
    import mathutils
    r = mathutils.Vector(cam["right"]).normalized()
    u = mathutils.Vector(cam["up"]).normalized()
    fwd = mathutils.Vector(cam["forward"]).normalized()
    cam_data = bpy.data.cameras.new("cam")
    cam_data.sensor_fit = "VERTICAL" if cam["width"] >= cam["height"] else "HORIZONTAL"
    cam_data.angle = math.radians(cam["fov_deg"])
    cam_data.clip_start, cam_data.clip_end = 1e-3, 1e4
    cam_obj = bpy.data.objects.new("cam", cam_data)
    rot = mathutils.Matrix((-r, u, -fwd)).transposed()
    if rot.determinant() < 0:  # a right-handed camera frame already: no mirror needed
        rot = mathutils.Matrix((r, u, -fwd)).transposed()
        s["mirrored"] = False
    else:
        s["mirrored"] = True
    m = rot.to_4x4()
    m.translation = mathutils.Vector(cam["origin"])
    cam_obj.matrix_world = m
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj

    lights = s["lights"]
    for k, d in enumerate(lights["distant"]):
        irr = d["irradiance"]
        strength = max(irr)
        sun = bpy.data.lights.new(f"sun{k}", "SUN")
        sun.energy = strength
        sun.color = [v / strength for v in irr] if strength > 0 else (1, 1, 1)
        sun.angle = math.radians(d["angle_deg"])
        obj = bpy.data.objects.new(f"sun{k}", sun)
        # The sun shines along its local -Z: local +Z points towards the light.
        obj.matrix_world = mathutils.Vector(d["to_light"]).to_track_quat("Z", "Y").to_matrix().to_4x4()
        scene.collection.objects.link(obj)
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    dome = lights.get("dome_radiance", [0, 0, 0])
    bg.inputs["Color"].default_value = (dome[0], dome[1], dome[2], 1)
    bg.inputs["Strength"].default_value = 1.0
    scene.world = world

    build_mesh(bpy, s, a)
    t0 = time.monotonic()
    scene.render.filepath = a.worker_out
    bpy.ops.render.render(write_still=True)
    t1 = time.monotonic()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(json.dumps({"render_seconds": t1 - t0, "worker_seconds": t1 - t_start,
                      "peak_rss_bytes": rss, "mirrored": s["mirrored"]}))


def build_mesh(bpy, s, a):
    """One mesh per (material, displacement) group of patches: grids welded, smooth."""
    import bmesh
    groups = {}
    for p in s["patches"]:
        key = json.dumps({k: p.get(k) for k in ("albedo", "material", "ks", "roughness", "displacement",
                                                "amplitude", "frequency", "octaves", "lacunarity", "gain")},
                         sort_keys=True)
        groups.setdefault(key, []).append(p)
    n = s["grid"] + 1
    for gi, (key, patches) in enumerate(groups.items()):
        bm = bmesh.new()
        for p in patches:
            pts = p["points"]
            verts = [bm.verts.new((pts[3 * k], pts[3 * k + 1], pts[3 * k + 2])) for k in range(n * n)]
            for j in range(n - 1):
                for i in range(n - 1):
                    q = [verts[j * n + i], verts[j * n + i + 1], verts[(j + 1) * n + i + 1], verts[(j + 1) * n + i]]
                    try:
                        bm.faces.new(q)
                    except ValueError:
                        pass  # a face twice (degenerate patch corners)
        bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=1e-5)
        bmesh.ops.dissolve_degenerate(bm, edges=bm.edges, dist=1e-7)
        bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
        me = bpy.data.meshes.new(f"patches{gi}")
        bm.to_mesh(me)
        bm.free()
        for poly in me.polygons:
            poly.use_smooth = True
        obj = bpy.data.objects.new(f"patches{gi}", me)
        bpy.context.scene.collection.objects.link(obj)
        mod = obj.modifiers.new("subdiv", "SUBSURF")
        mod.subdivision_type = "CATMULL_CLARK"
        mod.levels = 0
        mod.render_levels = 2
        mod.use_adaptive_subdivision = True
        mod.adaptive_space = "PIXEL"
        mod.adaptive_pixel_size = a.dicing_rate
        obj.data.materials.append(make_material(bpy, json.loads(key), gi))


def make_material(bpy, m, gi):
    mat = bpy.data.materials.new(f"mat{gi}")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*m["albedo"], 1)
    diffuse.inputs["Roughness"].default_value = 0.0
    shader = diffuse.outputs["BSDF"]
    if m["material"] == "plastic" and m["ks"] > 0:
        gloss = nt.nodes.new("ShaderNodeBsdfGlossy")
        gloss.distribution = "GGX"
        gloss.inputs["Roughness"].default_value = math.sqrt(max(m["roughness"], 0.0))
        gloss.inputs["Color"].default_value = (m["ks"], m["ks"], m["ks"], 1)
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(diffuse.outputs["BSDF"], add.inputs[0])
        nt.links.new(gloss.outputs["BSDF"], add.inputs[1])
        shader = add.outputs["Shader"]
    nt.links.new(shader, out.inputs["Surface"])
    if m["displacement"] in ("fbm", "ridged"):
        mat.displacement_method = "DISPLACEMENT"
        coord = nt.nodes.new("ShaderNodeTexCoord")
        noise = nt.nodes.new("ShaderNodeTexNoise")
        noise.noise_dimensions = "3D"
        noise.noise_type = "FBM" if m["displacement"] == "fbm" else "RIDGED_MULTIFRACTAL"
        noise.normalize = False
        noise.inputs["Scale"].default_value = m["frequency"]
        noise.inputs["Detail"].default_value = max(m["octaves"] - 1, 0)
        noise.inputs["Roughness"].default_value = m["gain"]
        noise.inputs["Lacunarity"].default_value = m["lacunarity"]
        nt.links.new(coord.outputs["Object"], noise.inputs["Vector"])
        disp = nt.nodes.new("ShaderNodeDisplacement")
        disp.inputs["Midlevel"].default_value = 0.5
        disp.inputs["Scale"].default_value = 2.0 * m["amplitude"]
        nt.links.new(noise.outputs["Fac"], disp.inputs["Height"])
        nt.links.new(disp.outputs["Displacement"], out.inputs["Displacement"])
    return mat


# ---- the benchmark -----------------------------------------------------------------------

def run_timed(cmd, env=None):
    """Runs cmd; returns (wall seconds, peak RSS bytes, stdout)."""
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    out = proc.stdout.read()
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.monotonic() - t0
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        sys.stderr.write(err.decode(errors="replace"))
        raise SystemExit(f"bench_cycles: {' '.join(cmd[:3])} ... failed with status {code}")
    return wall, usage.ru_maxrss * 1024, out.decode()


def png_write(path, width, height, rows):
    """Writes 8-bit RGB rows (bytes of width * 3) as a PNG without filtering."""
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def flip_png(src, dst):
    """Mirrors a PNG horizontally (Cycles' mirrored camera, see cycles_worker)."""
    w, h, rows = png_read(src)
    png_write(dst, w, h, [b"".join(r[3 * x:3 * x + 3] for x in range(w - 1, -1, -1)) for r in rows])


def bench_scene(a, scene, tmp, region):
    name = os.path.splitext(os.path.basename(scene))[0]
    scene_json = os.path.join(tmp, f"{name}.json")
    with open(scene_json, "w") as f:
        subprocess.run([a.export, scene, "--res", a.res, "--grid", str(a.grid)], stdout=f, check=True)
    # One Tessera renderer per --intersect mode: "tessera" for the first, "tessera_MODE" after.
    modes = {("tessera" if i == 0 else f"tessera_{m}"): m for i, m in enumerate(a.modes)}
    rec = {"scene": os.path.relpath(scene, ROOT), "cycles": {"wall": [], "worker": [], "rss": []}}
    for who in modes:
        rec[who] = {"wall": [], "rss": [], "stats": []}
    images = {who: {} for who in list(modes) + ["cycles"]}
    order = list(modes) + ["cycles"]
    for run in range(a.runs):
        seed = run % 2
        for who in (order if run % 2 == 0 else order[::-1]):
            png = os.path.join(tmp, f"{name}-{who}-{run}.png")
            if who in modes:
                stats = os.path.join(tmp, f"{name}-stats-{run}.json")
                cmd = [a.tessera, "render", scene, "-o", png, "--res", a.res, "--spp", str(a.spp),
                       "--depth", str(a.depth), "--seed", str(seed), "--quiet", "--stats", stats,
                       "--intersect", modes[who]] + a.tessera_args
                wall, rss, _ = run_timed(cmd)
                rec[who]["wall"].append(wall)
                rec[who]["rss"].append(rss)
                with open(stats) as f:
                    st = json.load(f)
                rec[who]["stats"].append({"stages": st["stages"], "counters": st["counters"]})
            else:
                raw = png + ".raw.png"
                cmd = [a.python, os.path.abspath(__file__), "--worker-scene", scene_json, "--worker-out", raw,
                       "--spp", str(a.spp), "--depth", str(a.depth), "--seed", str(seed),
                       "--threads", str(a.threads), "--dicing-rate", str(a.dicing_rate)]
                _, _, out = run_timed(cmd)
                w = json.loads(out.strip().splitlines()[-1])
                rec["cycles"]["wall"].append(w["render_seconds"])
                rec["cycles"]["worker"].append(w["worker_seconds"])
                rec["cycles"]["rss"].append(w["peak_rss_bytes"])
                if w["mirrored"]:
                    flip_png(raw, png)
                else:
                    os.replace(raw, png)
            images[who].setdefault(seed, png)
            print(f"  {name} run {run} {who}: {rec[who]['wall'][-1]:.2f} s", file=sys.stderr)
    summary = {"scene": rec["scene"], "res": a.res, "spp": a.spp, "depth": a.depth, "threads": a.threads}
    for who in order:
        r = rec[who]
        summary[who] = {"wall_seconds": statistics.median(r["wall"]), "walls": r["wall"],
                        "peak_rss_bytes": max(r["rss"]),
                        "body_mean_level": mean_level(images[who][0], region)}
        if who == "cycles":
            summary[who]["worker_seconds"] = statistics.median(r["worker"])
        if 1 in images[who]:
            body, whole = noise_levels(images[who][0], images[who][1], region)
            summary[who]["noise_body"] = body
            summary[who]["noise_image"] = whole
    c = summary["cycles"]
    for who in modes: # each mode's ratios to Cycles in its own record; the first's also on top
        t = summary[who]
        t["intersect"] = modes[who]
        if rec[who]["stats"]:
            t["stats_median_run"] = rec[who]["stats"][0]
        t["ratio_wall"] = t["wall_seconds"] / c["wall_seconds"]
        t["ratio_rss"] = t["peak_rss_bytes"] / c["peak_rss_bytes"]
        if "noise_body" in t and "noise_body" in c and c["noise_body"] > 0:
            t["ratio_noise_body"] = t["noise_body"] / c["noise_body"]
    for key in ("ratio_wall", "ratio_rss", "ratio_noise_body"):
        if key in summary["tessera"]:
            summary[key] = summary["tessera"][key]
    if a.keep:
        os.makedirs(a.keep, exist_ok=True)
        for who in images:
            for seed, png in images[who].items():
                os.replace(png, os.path.join(a.keep, f"{name}-{who}-seed{seed}.png"))
    return summary


def print_table(results):
    print("| scene | Tessera wall | Cycles wall | Tessera / Cycles | Tessera RSS | Cycles RSS | "
          "noise Tessera | noise Cycles | noise ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in results:
        c = r["cycles"]
        for who in [k for k in r if k == "tessera" or k.startswith("tessera_")]:
            t = r[who]
            nt = f"{t['noise_body']:.2f}" if "noise_body" in t else "-"
            nc = f"{c['noise_body']:.2f}" if "noise_body" in c else "-"
            nr = f"{t['ratio_noise_body']:.1f}x" if "ratio_noise_body" in t else "-"
            print(f"| {r['scene']} {r['res']}x{r['spp']} spp, {t['intersect']} | {t['wall_seconds']:.2f} s | "
                  f"{c['wall_seconds']:.2f} s | {t['ratio_wall']:.2f}x | {t['peak_rss_bytes'] / 2**30:.2f} GiB | "
                  f"{c['peak_rss_bytes'] / 2**30:.2f} GiB | {nt} | {nc} | {nr} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tessera", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--export", default=os.path.join(ROOT, "build", "bench_export"))
    ap.add_argument("--scene", action="append", help="RIB scenes (default: teapot, teapot_displaced)")
    ap.add_argument("--size", choices=["tiny", "small", "full"], default="small",
                    help="tiny: 160x90, 4 spp, 2 runs; small: 1280x720, 16 spp, 3 runs; full: 5 runs")
    ap.add_argument("--res", default=None)
    ap.add_argument("--spp", type=int, default=None)
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=None, help="runs per renderer (>= 2 for noise)")
    ap.add_argument("--grid", type=int, default=16, help="Cycles base mesh: N x N quads per patch")
    ap.add_argument("--dicing-rate", type=float, default=1.0, help="Cycles adaptive subdivision, pixels")
    ap.add_argument("--region", default=DEFAULT_REGION, help="x0,y0,x1,y1 fractions for the body noise")
    ap.add_argument("--python", default=sys.executable, help="interpreter with bpy for the Cycles worker")
    ap.add_argument("--intersect", default="boxes",
                    help="Tessera's --intersect modes, comma-separated (boxes,triangles: a row each)")
    ap.add_argument("--tessera-arg", dest="tessera_args", action="append", default=[],
                    help="extra argument for tessera render (repeat)")
    ap.add_argument("--keep", default=None, help="keep the seed-0/1 images of both renderers here")
    ap.add_argument("--json", default=None)
    ap.add_argument("--worker-scene", help=argparse.SUPPRESS)
    ap.add_argument("--worker-out", help=argparse.SUPPRESS)
    ap.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    a = ap.parse_args()
    size = {"tiny": ("160x90", 4, 2), "small": ("1280x720", 16, 3), "full": ("1280x720", 16, 5)}[a.size]
    a.res = a.res or size[0]
    a.spp = a.spp or size[1]
    a.runs = a.runs or size[2]
    a.modes = [m for m in a.intersect.split(",") if m]
    if not a.modes or any(m not in ("boxes", "triangles") for m in a.modes) or len(set(a.modes)) < len(a.modes):
        ap.error(f"--intersect {a.intersect}: expected boxes and/or triangles, comma-separated")
    if a.worker_scene:
        return cycles_worker(a)
    probe = subprocess.run([a.python, "-c", "import bpy"], capture_output=True)
    if probe.returncode != 0:
        print(f"bench_cycles: {a.python} cannot import bpy; create a venv with `pip install bpy` "
              "and run this script with its python (see the top of this file)", file=sys.stderr)
        return 77
    region = [float(v) for v in a.region.split(",")]
    scenes = a.scene or [os.path.join(ROOT, "scene", "teapot.rib"), os.path.join(ROOT, "scene", "teapot_displaced.rib")]
    results = []
    with tempfile.TemporaryDirectory(prefix="tessera-cycles-") as tmp:
        for scene in scenes:
            results.append(bench_scene(a, scene, tmp, region))
    print_table(results)
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as f:
            json.dump({"results": results, "args": vars(a)}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
