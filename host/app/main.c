/* main.c — the `tessera` command: `devices` lists OpenCL devices, `render` renders a scene,
 * `bake` bakes its spherical-harmonics occlusion (docs/bake.md).
 * The only place that prints errors and chooses the exit status (STYLE.md 10). */
#include "device/device.h"
#include "app/bake.h"
#include "app/interrupt.h"
#include "app/render.h"

#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Exit statuses (docs/errors.md): 0 done, 1 error, 3 stopped early with the finished samples
 * written (SIGINT, SIGTERM or SIGHUP, or memory ran out at the smallest budget). */
#define TS_EXIT_INTERRUPTED 3

static const char *usage_text =
    "usage: tessera devices                                  list OpenCL devices\n"
    "       tessera render SCENE.rib|MODEL -o OUT.{png,exr} [options]\n"
    "       tessera bake SCENE.rib|MODEL -o OUT.exr [bake options]       (docs/bake.md)\n"
    "       MODEL: any mesh Assimp reads, framed by an automatic camera (docs/rib.md)\n"
    "output (docs/rendering.md \"AOVs\", \"Interrupting and resuming\"):\n"
    "  -o, --output FILE       .png (tone-mapped sRGB) or .exr (float RGB, Z, N, albedo)\n"
    "      --res WxH           image size (default: the scene's Format, else 640x480)\n"
    "      --crop X0,X1,Y0,Y1  render that part of the frame, in fractions of its width and\n"
    "                          height from the top left (RIB CropWindow; default: the\n"
    "                          scene's, else all); the image is that part\n"
    "      --resume            finish the interrupted OUT.exr of the same command\n"
    "      --stats FILE        per-stage timings and counters as JSON (docs/profiling.md)\n"
    "      --quiet             no progress or timings on stderr\n"
    "scene (docs/rib.md \"Missing files\", \"Meshes\"):\n"
    "      --frame N           the RIB animation's FrameBegin N (default: the first)\n"
    "      --strict            a texture or archive that cannot be read is an error, not a\n"
    "                          warning and a fallback\n"
    "      --no-programs       skip Procedural \"RunProgram\" (with a warning) instead of\n"
    "                          running the helper program the scene names\n"
    "      --up x|y|z|-x|-y|-z a mesh's up axis (default: the file's, else its format's)\n"
    "quality (docs/rendering.md \"Samples and determinism\", \"Level of detail\"):\n"
    "      --spp N             samples per pixel (default: the scene's PixelSamples, else 1)\n"
    "      --depth D           bounces after the eye ray, 0..64 (default 3)\n"
    "      --seed S            random seed (default 0)\n"
    "      --max-lod M         finest level: (2^M)^2 micro-quads a patch, 0..10 (default 10)\n"
    "      --lod M             dice every patch at m = M instead of by ray density\n"
    "      --dicing-rate D     micro-quad size in pixels, 1/64..64 (default 1)\n"
    "      --intersect KIND    boxes (default, hole-free) or triangles (exact)\n"
    "      --occlusion BAKE    light the domes through a `tessera bake` file (docs/bake.md)\n"
    "devices (docs/rendering.md \"Several devices\", docs/building.md \"On a GPU\"):\n"
    "      --device I|I,J|all  devices of `tessera devices`; several share a frame\n"
    "                          (default: $TESSERA_DEVICE, else 0)\n"
    "      --streams N         waves in flight on each device, 1..4 (default 1): the host\n"
    "                          stages of one overlap the kernels of the others\n"
    "      --mpi-scene HOW     under mpirun: broadcast (default) or load\n"
    "memory (docs/rendering.md \"The memory budget\"):\n"
    "      --memory MB         budget for rays, candidates and diced patches (default: sized\n"
    "                          to the device and the process's limits, at most 1024)\n"
    "debugging and development (docs/building.md \"Kernels\", docs/errors.md):\n"
    "      --sampling KIND     mis (default), light or bsdf: one estimator alone, for checks\n"
    "      --leaf-mode MODE    ray (default) or group (PantaRay Fig. 8)\n"
    "      --leaf-size N       leaves of N x N micro-quads: 1 (default), 2 or 4\n"
    "      --kernel-dir DIR    build kernels from DIR instead of the embedded copy\n"
    "      --no-kernel-cache   neither read nor write the kernel binary cache\n"
    "      --help              this text\n"
    "bake options (also -o --res --frame --strict --no-programs --up --resume --stats --quiet "
    "--seed\n"
    "--max-lod --intersect --memory --kernel-dir --no-kernel-cache as for render; --device I:\n"
    "one):\n"
    "      --bands B           SH bands, 1..4: B^2 coefficients sh0.. a point (default 3)\n"
    "      --rays N            rays a point (default 512)\n"
    "      --lod M             points at the vertices of patches diced at m = M (default: by\n"
    "                          the camera's pixel footprint)\n"
    "      --points K          at least K points a patch (default 4: its corners)\n"
    "      --cosine            project V times max(0, N.w) (cosine-weighted directions)\n"
    "      --sphere            directions over the whole sphere, not the hemisphere\n"
    "      --front             the hemisphere about the patch's normal, not the camera's side\n";

/* Prints "tessera: " and the formatted text as one line on stderr (ts_print_line: control
 * characters escaped). */
static void say(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void say(const char *fmt, ...)
{
    char text[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    ts_print_line("tessera: %s", text);
}

/* Prints err (and its detail, a build log) and gives the exit status of a failure. */
static int report_error(ts_error *err)
{
    say("%s", err->msg);
    if (err->detail) fprintf(stderr, "%s\n", err->detail);
    ts_error_clear(err);
    return 1;
}

static int cmd_devices(void)
{
    ts_error err = {0};
    ts_device_info *list;
    int n = dev_list(&list, &err);
    if (n < 0) return report_error(&err);
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

/* What a render that did not fail tells the user, and its exit status. */
static int report_outcome(const ts_render_options *o, const ts_stats *stats,
                          const ts_render_result *result)
{
    if (result->outcome == TS_RENDER_UP_TO_DATE) {
        say("%s is already complete (%llu samples): nothing to do", o->output_path,
            result->samples_total);
        return 0;
    }
    const char *ext = strrchr(o->output_path, '.');
    const char *how = ext && strcmp(ext, ".exr") == 0 ? "continue with --resume"
                                                      : "a partial PNG cannot be resumed: use .exr";
    if (result->outcome == TS_RENDER_INTERRUPTED) {
        say("interrupted by %s after %llu of %llu samples; wrote %s (%s)",
            result->signal == SIGINT   ? "SIGINT"
            : result->signal == SIGHUP ? "SIGHUP"
                                       : "SIGTERM",
            result->samples_done, result->samples_total, o->output_path, how);
        return TS_EXIT_INTERRUPTED;
    }
    if (result->outcome == TS_RENDER_DEVICES_FAILED) {
        say("%s; wrote the %llu of %llu samples finished to %s (%s)", result->reason,
            result->samples_done, result->samples_total, o->output_path, how);
        return TS_EXIT_INTERRUPTED;
    }
    if (result->outcome == TS_RENDER_OUT_OF_MEMORY) {
        say("%s; wrote the %llu of %llu samples finished to %s (%s%s)", result->reason,
            result->samples_done, result->samples_total, o->output_path, how,
            ext && strcmp(ext, ".exr") == 0 ? " once more memory is free" : "");
        return TS_EXIT_INTERRUPTED;
    }
    if (!o->quiet) {
        say("wrote %s on %s", o->output_path, stats->device);
        stats_print_table(stats, stderr);
    }
    return 0;
}

/* `tessera render`. Under mpirun with several ranks (app/ranks.h) rank 0 renders and
 * reports; the other ranks follow it and say nothing but their own failures (an option
 * error, the same on every rank, is printed by rank 0 alone). */
static int cmd_render(int argc, char **argv)
{
    ts_render_options o;
    render_options_defaults(&o);
    ts_error err = {0};
    ts_ranks ranks;
    if (ranks_init(&argc, &argv, &ranks, &err)) return report_error(&err);
    int help, status;
    if (render_options_parse(argc, argv, &o, &help, &err)) {
        status = ranks.rank == 0 ? report_error(&err) : (ts_error_clear(&err), 1);
        ranks_finalize(&ranks, status);
        return status;
    }
    if (help) {
        if (ranks.rank == 0) fputs(usage_text, stdout);
        ranks_finalize(&ranks, 0);
        return 0;
    }
#ifdef TESSERA_HAVE_MPI
    if (ranks.rank > 0) {
        int rc = ranks_follow(&ranks, &o, &err);
        if (rc && !interrupt_signal()) say("rank %d (%s): %s", ranks.rank, ranks.host, err.msg);
        status = rc ? 1 : 0;
        ts_error_clear(&err);
        ranks_finalize(&ranks, status);
        return status;
    }
#endif
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_render_result result;
    int rc = render_run(&o, &ranks, &stats, &result, &err);
    if (!rc && o.stats_path && result.outcome != TS_RENDER_UP_TO_DATE)
        rc = stats_write_json(&stats, o.stats_path, &err);
    status = rc ? report_error(&err) : report_outcome(&o, &stats, &result);
    stats_free(&stats);
    ranks_finalize(&ranks, status);
    return status;
}

/* What a bake that did not fail tells the user, and its exit status. */
static int report_bake(const ts_bake_options *o, const ts_stats *stats, const ts_bake_result *r)
{
    if (r->outcome == TS_BAKE_UP_TO_DATE) {
        say("%s is already complete (%llu points): nothing to do", o->output_path,
            (unsigned long long)r->points_total);
        return 0;
    }
    if (r->outcome == TS_BAKE_INTERRUPTED) {
        say("interrupted by %s after %llu of %llu points; wrote %s (continue with --resume)",
            r->signal == SIGINT   ? "SIGINT"
            : r->signal == SIGHUP ? "SIGHUP"
                                  : "SIGTERM",
            (unsigned long long)r->points_done, (unsigned long long)r->points_total,
            o->output_path);
        return TS_EXIT_INTERRUPTED;
    }
    if (!o->quiet) {
        say("baked %llu points (%llu rays) into %s on %s", (unsigned long long)r->points_total,
            (unsigned long long)r->rays, o->output_path, stats->device);
        stats_print_table(stats, stderr);
    }
    return 0;
}

static int cmd_bake(int argc, char **argv)
{
    ts_bake_options o;
    bake_options_defaults(&o);
    ts_error err = {0};
    int help;
    if (bake_options_parse(argc, argv, &o, &help, &err)) return report_error(&err);
    if (help) {
        fputs(usage_text, stdout);
        return 0;
    }
    ts_stats stats;
    memset(&stats, 0, sizeof stats);
    ts_bake_result result;
    int rc = bake_run(&o, &stats, &result, &err);
    if (!rc && o.stats_path && result.outcome != TS_BAKE_UP_TO_DATE)
        rc = stats_write_json(&stats, o.stats_path, &err);
    int status = rc ? report_error(&err) : report_bake(&o, &stats, &result);
    stats_free(&stats);
    return status;
}

int main(int argc, char **argv)
{
    /* A closed stdout or stderr (`tessera render ... 2>&1 | head`) must not kill a render
     * and lose its samples: writes to it fail with EPIPE instead, and the progress line
     * stops (render.c). */
    signal(SIGPIPE, SIG_IGN);
    interrupt_note_ignored(); /* nohup's SIGHUP stays ignored (interrupt.h) */
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        fputs(usage_text, argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    if (strcmp(argv[1], "devices") == 0) return cmd_devices();
    if (strcmp(argv[1], "render") == 0) return cmd_render(argc - 1, argv + 1);
    if (strcmp(argv[1], "bake") == 0) return cmd_bake(argc - 1, argv + 1);
    say("unknown command '%s' (commands: devices, render, bake)", argv[1]);
    return 1;
}
