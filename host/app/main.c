/* main.c — the `tessera` command: `devices` lists OpenCL devices, `render` renders a scene.
 * The only place that prints errors and chooses the exit status (STYLE.md 10). */
#include "device/device.h"
#include "app/render.h"

#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Exit statuses (docs/errors.md): 0 done, 1 error, 3 interrupted by SIGINT or SIGTERM with
 * the finished samples written. */
#define TS_EXIT_INTERRUPTED 3

static const char *usage_text =
    "usage: tessera devices\n"
    "       tessera render SCENE.rib|MODEL -o OUT.{png,exr} [options]\n"
    "       (MODEL: any mesh Assimp reads, framed by an automatic camera)\n"
    "options:\n"
    "  -o, --output FILE     image to write: .png (tone-mapped sRGB) or .exr (float RGB,\n"
    "                        Z, N.x N.y N.z, albedo.R albedo.G albedo.B)\n"
    "      --res WxH         image size (default: the scene's Format, else 640x480)\n"
    "      --spp N           samples per pixel (default: the scene's PixelSamples, else 1)\n"
    "      --depth D         path depth: bounces after the eye ray, 0..64 (default 3;\n"
    "                        0: eye rays only, lights seen directly)\n"
    "      --seed S          random seed (default 0)\n"
    "      --device I        OpenCL device index from `tessera devices` (default:\n"
    "                        $TESSERA_DEVICE, else 0)\n"
    "      --max-lod M       the finest level of detail: (2^M)^2 micro-quads per patch,\n"
    "                        0..10 (default 10)\n"
    "      --lod M           dice every patch at m = M instead of by ray density\n"
    "      --intersect KIND  boxes: leaf boxes are the geometry, hole-free across levels of\n"
    "                        detail (default); triangles: exact micro-triangles\n"
    "      --leaf-mode MODE  ray: each work-item intersects its own leaves (default); group:\n"
    "                        the work-group pools them (PantaRay Fig. 8)\n"
    "      --leaf-size N     leaves of N x N micro-quads: 1 (default), 2 or 4\n"
    "      --sampling KIND   mis: light and BSDF sampling combined (default); light or\n"
    "                        bsdf: one alone (for checking the estimators)\n"
    "      --memory MB       budget for rays, candidates and diced patches (default 1024)\n"
    "      --stats FILE      write per-stage timings and counters as JSON\n"
    "      --quiet           no progress or timings on stderr\n"
    "      --resume          continue the interrupted render in OUT.exr (same command)\n"
    "      --kernel-dir DIR  build kernels from DIR instead of the embedded copy\n"
    "      --no-kernel-cache neither read nor write the kernel binary cache\n";

/* Parses a positive int in [lo, hi]; returns 0 on success. */
static int parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return -1;
    *out = (int)v;
    return 0;
}

static int cmd_devices(void)
{
    ts_error err = {0};
    ts_device_info *list;
    int n = dev_list(&list, &err);
    if (n < 0) {
        fprintf(stderr, "tessera: %s\n", err.msg);
        return 1;
    }
    if (n == 0) printf("no OpenCL devices found (install pocl-opencl-icd for the CPU)\n");
    for (int i = 0; i < n; ++i) {
        const ts_device_info *d = &list[i];
        const char *type = d->type & CL_DEVICE_TYPE_GPU           ? "GPU"
                           : d->type & CL_DEVICE_TYPE_CPU         ? "CPU"
                           : d->type & CL_DEVICE_TYPE_ACCELERATOR ? "accelerator"
                                                                  : "other";
        printf("%d: %s [%s, %s]\n   platform %s, driver %s\n"
               "   %u compute units, global memory %llu MB (max buffer %llu MB), local memory %llu "
               "KB\n",
               i, d->name, type, d->version, d->platform_name, d->driver, d->compute_units,
               (unsigned long long)(d->global_mem >> 20), (unsigned long long)(d->max_alloc >> 20),
               (unsigned long long)(d->local_mem >> 10));
    }
    free(list);
    return 0;
}

enum {
    OPT_RES = 256,
    OPT_LOD,
    OPT_INTERSECT,
    OPT_SAMPLING,
    OPT_LEAF_MODE,
    OPT_LEAF_SIZE,
    OPT_SPP,
    OPT_DEPTH,
    OPT_SEED,
    OPT_DEVICE,
    OPT_MAX_LOD,
    OPT_MEMORY,
    OPT_STATS,
    OPT_QUIET,
    OPT_KERNEL_DIR,
    OPT_NO_CACHE,
    OPT_HELP,
    OPT_RESUME
};

static const struct option render_options[] = {
    {"output", required_argument, 0, 'o'},
    {"res", required_argument, 0, OPT_RES},
    {"spp", required_argument, 0, OPT_SPP},
    {"depth", required_argument, 0, OPT_DEPTH},
    {"seed", required_argument, 0, OPT_SEED},
    {"device", required_argument, 0, OPT_DEVICE},
    {"max-lod", required_argument, 0, OPT_MAX_LOD},
    {"memory", required_argument, 0, OPT_MEMORY},
    {"lod", required_argument, 0, OPT_LOD},
    {"intersect", required_argument, 0, OPT_INTERSECT},
    {"sampling", required_argument, 0, OPT_SAMPLING},
    {"leaf-mode", required_argument, 0, OPT_LEAF_MODE},
    {"leaf-size", required_argument, 0, OPT_LEAF_SIZE},
    {"stats", required_argument, 0, OPT_STATS},
    {"quiet", no_argument, 0, OPT_QUIET},
    {"kernel-dir", required_argument, 0, OPT_KERNEL_DIR},
    {"no-kernel-cache", no_argument, 0, OPT_NO_CACHE},
    {"help", no_argument, 0, OPT_HELP},
    {"resume", no_argument, 0, OPT_RESUME},
    {0, 0, 0, 0},
};

/* Fills o from argv; returns 0, or 1 with a message printed. */
static int parse_render_args(int argc, char **argv, ts_render_options *o)
{
    int c, bad = 0, v;
    opterr = 0;
    while (!bad && (c = getopt_long(argc, argv, "o:", render_options, NULL)) != -1) {
        switch (c) {
        case 'o':
            o->output_path = optarg;
            break;
        case OPT_RES:
            bad = sscanf(optarg, "%dx%d", &o->width, &o->height) != 2 || o->width < 1 ||
                  o->height < 1 || o->width > 65536 || o->height > 65536;
            break;
        case OPT_LEAF_MODE:
            bad = strcmp(optarg, "ray") != 0 && strcmp(optarg, "group") != 0;
            o->leaf_group = strcmp(optarg, "group") == 0;
            break;
        case OPT_LEAF_SIZE:
            bad = parse_int(optarg, 1, 4, &o->leaf_size) || o->leaf_size == 3;
            break;
        case OPT_SAMPLING:
            o->sampling = !strcmp(optarg, "mis")     ? (int)TS_SAMPLING_MIS
                          : !strcmp(optarg, "light") ? (int)TS_SAMPLING_LIGHT
                          : !strcmp(optarg, "bsdf")  ? (int)TS_SAMPLING_BSDF
                                                     : -1;
            bad = o->sampling < 0;
            break;
        case OPT_SPP:
            bad = parse_int(optarg, 1, 1 << 16, &o->spp);
            break;
        case OPT_DEPTH:
            bad = parse_int(optarg, 0, 64, &o->depth);
            break;
        case OPT_SEED:
            bad = parse_int(optarg, 0, 0x7fffffff, &v);
            o->seed = (unsigned)v;
            break;
        case OPT_DEVICE:
            bad = parse_int(optarg, 0, 1 << 20, &o->cl.device_index);
            break;
        case OPT_MAX_LOD:
            bad = parse_int(optarg, 0, TS_LOD_LIMIT, &o->max_lod);
            break;
        case OPT_LOD:
            bad = parse_int(optarg, 0, TS_LOD_LIMIT, &o->fixed_lod);
            break;
        case OPT_INTERSECT:
            bad = strcmp(optarg, "boxes") != 0 && strcmp(optarg, "triangles") != 0;
            o->exact = strcmp(optarg, "triangles") == 0;
            break;
        case OPT_MEMORY:
            bad = parse_int(optarg, 1, 1 << 24, &o->memory_mb);
            break;
        case OPT_STATS:
            o->stats_path = optarg;
            break;
        case OPT_QUIET:
            o->quiet = 1;
            break;
        case OPT_RESUME:
            o->resume = 1;
            break;
        case OPT_KERNEL_DIR:
            o->cl.kernel_dir = optarg;
            break;
        case OPT_NO_CACHE:
            o->cl.no_cache = 1;
            break;
        case OPT_HELP:
            fputs(usage_text, stdout);
            exit(0);
        case '?':
            if (optopt)
                fprintf(stderr, "tessera: option -%c needs a value or is unknown\n", optopt);
            else
                fprintf(stderr, "tessera: unknown option %s (see tessera --help)\n",
                        argv[optind - 1]);
            return 1;
        }
        if (bad) {
            fprintf(stderr, "tessera: bad value '%s' for %s\n", optarg,
                    argv[optind - 2 >= 0 ? optind - 2 : 0]);
            return 1;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "tessera: render takes exactly one scene file (see tessera --help)\n");
        return 1;
    }
    o->scene_path = argv[optind];
    return 0;
}

static int cmd_render(int argc, char **argv)
{
    ts_render_options o;
    render_options_defaults(&o);
    if (parse_render_args(argc, argv, &o)) return 1;
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_error err = {0};
    ts_render_result result;
    int rc = render_run(&o, &stats, &result, &err);
    if (!rc && o.stats_path && result.outcome != TS_RENDER_UP_TO_DATE)
        rc = stats_write_json(&stats, o.stats_path, &err);
    if (rc) {
        fprintf(stderr, "tessera: %s\n", err.msg);
        if (err.detail) fprintf(stderr, "%s\n", err.detail);
        ts_error_clear(&err);
        stats_free(&stats);
        return 1;
    }
    if (result.outcome == TS_RENDER_UP_TO_DATE) {
        fprintf(stderr, "tessera: %s is already complete (%llu samples): nothing to do\n",
                o.output_path, result.samples_total);
        stats_free(&stats);
        return 0;
    }
    if (result.outcome == TS_RENDER_INTERRUPTED) {
        const char *ext = strrchr(o.output_path, '.');
        fprintf(stderr, "tessera: interrupted by %s after %llu of %llu samples; wrote %s (%s)\n",
                result.signal == SIGINT ? "SIGINT" : "SIGTERM", result.samples_done,
                result.samples_total, o.output_path,
                ext && strcmp(ext, ".exr") == 0 ? "continue with --resume"
                                                : "a partial PNG cannot be resumed: use .exr");
        stats_free(&stats);
        return TS_EXIT_INTERRUPTED;
    }
    if (!o.quiet) {
        fprintf(stderr, "tessera: wrote %s on %s\n", o.output_path, stats.device);
        stats_print_table(&stats, stderr);
    }
    stats_free(&stats);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        fputs(usage_text, argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    if (strcmp(argv[1], "devices") == 0) return cmd_devices();
    if (strcmp(argv[1], "render") == 0) return cmd_render(argc - 1, argv + 1);
    fprintf(stderr, "tessera: unknown command '%s' (commands: devices, render)\n", argv[1]);
    return 1;
}
