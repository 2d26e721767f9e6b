#!/usr/bin/env python3
"""tools/bench_multi.py — one frame on several devices and processes (issue 17): wall time of
the same render on one PoCL device, on two, and on two MPI processes, with each device's busy
fraction, setup seconds and units from --stats, and the seconds rank 0 and the other ranks
spend getting the scene when it is broadcast and when every rank loads it.

Configurations (POCL_DEVICES picks PoCL's devices; `basic` runs kernels on the thread that
waits for them, one core; `pthread` devices share one pool of POCL_MAX_PTHREAD_COUNT threads,
so two of them are not two one-thread devices):
  1dev     POCL_DEVICES=basic, one device of one thread: the baseline
  2dev     POCL_DEVICES="basic basic" --device all: two devices of one thread each
  2proc    mpirun -np 2, POCL_DEVICES=basic: two processes of one one-thread device each
  1pthread POCL_DEVICES=pthread: one device using every core (what a plain render does)
  2proc_pthread  mpirun -np 2, each with that device
Speed-ups are median(1dev) / median(config) over --runs interleaved runs. CPU seconds (user +
system of the render and its children) show the work each configuration adds on top of
1dev's, which the machine's load does not change much: on an idle machine the speed-up of two
devices is at most 2 / (CPU vs 1dev). Every image is
compared with 1dev's: the same bytes, else by idiff (bit for bit) when idiff is installed. The scene transfer is
measured on forest-100 (100 trees, generated when it loads) with -np 2, --mpi-scene broadcast
and load.

--size: tiny = 64x36 (teapot_displaced 2 spp), one run, no forest-100 (the ctest smoke test);
small = teapot_displaced 320x180 x 8 spp and forest-1 480x192 x 1 spp, 3 runs (the default);
full = teapot_displaced 640x360 x 16 spp and forest-1 960x384 x 4 spp, 3 runs.

    tools/bench_multi.py --size small --json out/bench/multi.json
"""
import argparse, json, os, resource, shutil, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = {  # scenes (name, resolution, spp), runs, measure the scene transfer
    "tiny": ([("teapot_displaced", "64x36", 2)], 1, False),
    "small": ([("teapot_displaced", "320x180", 8), ("forest-1", "480x192", 1)], 3, True),
    "full": ([("teapot_displaced", "640x360", 16), ("forest-1", "960x384", 4)], 3, True),
}
# name, POCL_DEVICES, MPI ranks (0: no mpirun), extra arguments
CONFIGS = [
    ("1dev", "basic", 0, ["--device", "0"]),
    ("2dev", "basic basic", 0, ["--device", "all"]),
    ("2proc", "basic", 2, ["--device", "0"]),
    ("1pthread", "pthread", 0, ["--device", "0"]),
    ("2proc_pthread", "pthread", 2, ["--device", "0"]),
]
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
if os.environ.get("ASAN_OPTIONS"):  # a sanitizer build (tools/test_sanitize.sh): as test_ranks
    MPI_ENV["ASAN_OPTIONS"] = os.environ["ASAN_OPTIONS"] + ":fast_unwind_on_malloc=0"


def cpu_of_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def render(binary, scene, out, stats, pocl, ranks, args):
    """One render; returns its --stats (rank 0's under mpirun), with "cpu_seconds": the user +
    system seconds of the process and its children (every rank, and mpirun)."""
    env = dict(os.environ, POCL_DEVICES=pocl, **MPI_ENV)
    cmd = [binary, "render", scene, "-o", out, "--quiet", "--stats", stats] + args
    if ranks:
        cmd = ["mpirun", "--oversubscribe", "-np", str(ranks)] + cmd
    cpu = cpu_of_children()
    subprocess.run(cmd, check=True, env=env)
    cpu = cpu_of_children() - cpu
    with open(stats) as f:
        st = json.load(f)
    st["cpu_seconds"] = cpu
    return st


def same_image(a, b):
    """True when the files are the same bytes (several devices and ranks write the one-device
    EXR byte for byte); else True/False by idiff (bit for bit), None without idiff."""
    with open(a, "rb") as fa, open(b, "rb") as fb:
        if fa.read() == fb.read():
            return True
    if not shutil.which("idiff"):
        return None
    r = subprocess.run(["idiff", "-fail", "0", "-failpercent", "0", "-warn", "0", a, b],
                       capture_output=True, text=True)
    return r.returncode == 0


def devices_of(stats):
    """Per-device numbers from --stats (one entry for a one-device render)."""
    devs = stats.get("devices")
    if not devs:
        return [{"name": stats["device"], "rank": 0, "units": None, "busy_fraction": None,
                 "setup_seconds": None}]
    return [{k: d[k] for k in ("name", "rank", "units", "busy_fraction", "setup_seconds")} for d in devs]


def bench_scene(a, tmp, scene, res, spp, runs):
    path = os.path.join(a.scene_dir, scene + ".rib")
    base = ["--res", res, "--spp", str(spp)]
    rows = {c[0]: {"config": c[0], "wall_seconds": [], "cpu_seconds": [], "stats": []}
            for c in CONFIGS}
    for r in range(runs):  # interleaved: a slow minute on the shared machine hits every config
        for name, pocl, ranks, extra in CONFIGS:
            out = os.path.join(tmp, f"{scene}-{name}-{r}.exr")
            st = render(a.binary, path, out, out + ".json", pocl, ranks, base + extra)
            rows[name]["wall_seconds"].append(st["wall_seconds"])
            rows[name]["cpu_seconds"].append(st["cpu_seconds"])
            rows[name]["stats"].append(st)
            rows[name].setdefault("images", []).append(out)
    ref = statistics.median(rows["1dev"]["wall_seconds"])
    ref_cpu = statistics.median(rows["1dev"]["cpu_seconds"])
    result = []
    for name, _, _, _ in CONFIGS:
        row = rows[name]
        med = statistics.median(row["wall_seconds"])
        k = sorted(range(runs), key=lambda i: row["wall_seconds"][i])[(runs - 1) // 2]
        st = row["stats"][k]
        result.append({
            "config": name, "wall_seconds": row["wall_seconds"], "wall_seconds_median": med,
            "speedup_vs_1dev": ref / med, "cpu_seconds": row["cpu_seconds"],
            "cpu_seconds_median": statistics.median(row["cpu_seconds"]),
            "cpu_ratio_vs_1dev": statistics.median(row["cpu_seconds"]) / ref_cpu,
            "sum_of_stages": sum(st["stages"].values()),
            "sort_seconds": st["stages"]["sort"], "devices": devices_of(st),
            "identical_to_1dev": same_image(rows["1dev"]["images"][0], row["images"][0]),
        })
    return {"scene": scene, "resolution": res, "spp": spp, "runs": runs, "configs": result}


def bench_transfer(a, tmp, runs):
    """forest-100 at 64x36 on two ranks: the scene's seconds per rank, broadcast vs load."""
    path = os.path.join(a.scene_dir, "forest-100.rib")
    out = {}
    for mode in ("broadcast", "load"):
        walls, scenes = [], []
        for r in range(runs):
            st = render(a.binary, path, os.path.join(tmp, f"f100-{mode}.exr"),
                        os.path.join(tmp, f"f100-{mode}-{r}.json"), "pthread", 2,
                        ["--res", "64x36", "--spp", "1", "--mpi-scene", mode])
            walls.append(st["wall_seconds"])
            scenes.append([rk["scene_seconds"] for rk in st["ranks"]])
        k = sorted(range(runs), key=lambda i: walls[i])[(runs - 1) // 2]
        out[mode] = {"wall_seconds": walls, "wall_seconds_median": statistics.median(walls),
                     "scene_seconds_by_rank": scenes[k]}
    return out


def print_tables(res):
    for s in res["scenes"]:
        print(f"\n{s['scene']} {s['resolution']} x {s['spp']} spp, median of {s['runs']}")
        print("| config | wall s | speed-up vs 1dev | CPU s | CPU vs 1dev | sort s "
              "| devices: units / busy / setup s | same bits |")
        print("|---|---|---|---|---|---|---|---|")
        for c in s["configs"]:
            devs = ", ".join(
                f"r{d['rank']} {d['units']} / {d['busy_fraction']:.2f} / {d['setup_seconds']:.2f}"
                if d["units"] is not None else "-" for d in c["devices"])
            same = {True: "yes", False: "NO", None: "unchecked"}[c["identical_to_1dev"]]
            print(f"| {c['config']} | {c['wall_seconds_median']:.2f} | {c['speedup_vs_1dev']:.2f}x "
                  f"| {c['cpu_seconds_median']:.2f} | {c['cpu_ratio_vs_1dev']:.2f} "
                  f"| {c['sort_seconds']:.2f} | {devs} | {same} |")
    if res.get("transfer"):
        print("\nforest-100 64x36 on 2 ranks: seconds to get the scene, rank 0 / rank 1")
        for mode, t in res["transfer"].items():
            sec = " / ".join(f"{x:.2f}" for x in t["scene_seconds_by_rank"])
            print(f"| {mode} | {sec} | wall {t['wall_seconds_median']:.2f} s |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "tessera"))
    ap.add_argument("--scene-dir", default=os.path.join(ROOT, "scene"))
    ap.add_argument("--size", choices=sorted(SIZES), default="small")
    ap.add_argument("--runs", type=int, default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    scenes, runs, transfer = SIZES[a.size]
    runs = a.runs if a.runs is not None else runs
    if not shutil.which("mpirun"):  # the devices still compare; the processes cannot
        print("bench_multi: mpirun not found (Debian: openmpi-bin): one process only",
              file=sys.stderr)
        CONFIGS[:] = [c for c in CONFIGS if not c[2]]
        transfer = False
    tmp = tempfile.mkdtemp(prefix="tessera-bench-multi-")
    with open("/proc/loadavg") as f:
        load_before = f.read().split()[:3]
    res = {"benchmark": "multi", "size": a.size, "runs": runs, "cpus": os.cpu_count(),
           "load_average_before": load_before,
           "scenes": [bench_scene(a, tmp, *s, runs) for s in scenes]}
    if transfer:
        res["transfer"] = bench_transfer(a, tmp, runs)
    with open("/proc/loadavg") as f:
        res["load_average_after"] = f.read().split()[:3]
    print_tables(res)
    print(f"\nload average before {' '.join(load_before)}, after {' '.join(res['load_average_after'])}"
          f" on {res['cpus']} CPUs")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=2)
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
