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
    "usage: tessera devices\n"
    "       tessera render SCENE.rib|MODEL -o OUT.{png,exr} [options]\n"
    "       tessera bake SCENE.rib|MODEL -o OUT.exr [bake options]\n"
    "       (MODEL: any mesh Assimp reads, framed by an automatic camera)\n"
    "options:\n"
    "  -o, --output FILE     image to write: .png (tone-mapped sRGB) or .exr (float RGB,\n"
    "                        Z, N.x N.y N.z, albedo.R albedo.G albedo.B)\n"
    "      --res WxH         image size (default: the scene's Format, else 640x480)\n"
    "      --spp N           samples per pixel (default: the scene's PixelSamples, else 1)\n"
    "      --depth D         path depth: bounces after the eye ray, 0..64 (default 3;\n"
    "                        0: eye rays only, lights seen directly)\n"
    "      --seed S          random seed (default 0)\n"
    "      --device I|I,J|all OpenCL devices from `tessera devices`: one index, a list,\n"
    "                        or every device; several share the frame and give the\n"
    "                        image of the first alone (default: $TESSERA_DEVICE, else 0)\n"
    "      --max-lod M       the finest level of detail: (2^M)^2 micro-quads per patch,\n"
    "                        0..10 (default 10)\n"
    "      --lod M           dice every patch at m = M instead of by ray density\n"
    "      --dicing-rate D   the ray-density rule's micro-quad size in pixels across, like\n"
    "                        Cycles' dicing rate, 1/64..64: a patch crossed by R eye rays of\n"
    "                        the first sample pass is diced at the smallest m with\n"
    "                        4^m >= R / D^2 (default 1, Hanika's rule; 2: one level coarser)\n"
    "      --intersect KIND  boxes: leaf boxes are the geometry, hole-free across levels of\n"
    "                        detail (default); triangles: exact micro-triangles, stitched\n"
    "                        where patches diced at different levels share an edge\n"
    "                        (faster on displaced surfaces, nearer the true surface)\n"
    "      --leaf-mode MODE  ray: each work-item intersects its own leaves (default); group:\n"
    "                        the work-group pools them (PantaRay Fig. 8)\n"
    "      --leaf-size N     leaves of N x N micro-quads: 1 (default), 2 or 4\n"
    "      --sampling KIND   mis: light and BSDF sampling combined (default); light or\n"
    "                        bsdf: one alone (for checking the estimators)\n"
    "      --memory MB       budget for rays, candidates and diced patches (default: sized\n"
    "                        to the device and the process's memory limits, at most 1024)\n"
    "      --stats FILE      write per-stage timings and counters as JSON\n"
    "      --quiet           no progress or timings on stderr\n"
    "      --resume          continue the interrupted render in OUT.exr (same command)\n"
    "      --occlusion BAKE.exr  relight with the SH occlusion `tessera bake` made for\n"
    "                        this scene: at the eye rays' hits the domes (domelight,\n"
    "                        ambientlight) light the diffuse lobe through the baked\n"
    "                        visibility instead of rays; other lights and later bounces\n"
    "                        are traced as usual (docs/bake.md \"Relighting\")\n"
    "      --frame N         the frame of a RIB animation to render: FrameBegin N\n"
    "                        (default: the first)\n"
    "      --mpi-scene HOW   under mpirun: broadcast (default): rank 0 loads the scene\n"
    "                        and sends it; load: every rank loads the same files\n"
    "      --kernel-dir DIR  build kernels from DIR instead of the embedded copy\n"
    "      --no-kernel-cache neither read nor write the kernel binary cache\n"
    "bake options (spherical-harmonics occlusion at the vertices of every patch diced at m,\n"
    "docs/bake.md; also -o --memory --max-lod --res --seed --intersect --frame --stats\n"
    "--quiet --resume --kernel-dir --no-kernel-cache as for render, and --device I: one\n"
    "device):\n"
    "      --bands B         SH bands, 1..4: B^2 coefficients sh0.. per point (default 3)\n"
    "      --rays N          rays per point (default 512)\n"
    "      --lod M           points at every patch's vertices diced at m = M (default: m from\n"
    "                        the camera's pixel footprint, as render's level of detail)\n"
    "      --points K        at least K points per patch (default 4: its corners)\n"
    "      --cosine          project V times max(0, N.w) (cosine-weighted directions)\n"
    "      --sphere          directions uniform over the sphere, not the hemisphere\n"
    "      --front           the hemisphere about the patch's own normal, not the side the\n"
    "                        camera sees\n";

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
