/* bake.c — `tessera bake` (bake.h, docs/bake.md): load the scene and its camera, choose the
 * points (each patch's vertices at m: the render's lod stage over the camera's pixels, or
 * --lod, at least --points per patch), take back what --resume finds, then bake the points
 * in waves through the pipeline (pipeline/bake.h) and write the EXR (bake_file.h). */
#include "app/bake.h"
#include "app/bake_file.h"
#include "app/budget.h"
#include "app/interrupt.h"
#include "app/output.h"
#include "app/render.h"
#include "app/waves.h"
#include "base/hash.h"
#include "pipeline/bake.h"
#include "pipeline/pipeline.h"
#include "scene/scene_load.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Everything one bake holds: zeroed at the start, freed by bake_free whatever failed. */
typedef struct ts_bake {
    ts_bake_options opt;
    ts_stats *stats;
    int width, height; /* the camera's image (the footprint LOD) */
    ts_scene scene;
    ts_camera_params cam;
    ts_device cl;
    ts_pipeline pipe;
    uint64_t mb;      /* the memory budget: --memory, else budget_default's */
    uint64_t room_mb; /* how far the arenas may grow to hold the patches once */
    uint32_t max_lod; /* the plan's finest m */
    uint32_t *lod;    /* each patch's m */
    ts_bake_image img;
    ts_bake_meta meta;
    uint32_t done; /* points [0, done) are in img */
    float *coeffs; /* one wave's results */
    ts_vec4 *pos, *normal;
} ts_bake;

static void bake_free(ts_bake *b)
{
    pipeline_destroy(&b->pipe);
    dev_close(&b->cl);
    scene_free(&b->scene);
    bake_image_free(&b->img);
    free(b->lod), free(b->coeffs), free(b->pos), free(b->normal);
}

/* The scene, its image size and camera (spp 1: one footprint ray per pixel). */
static int bake_load(ts_bake *b, ts_error *err)
{
    ts_bake_options *o = &b->opt;
    const char *ext = o->output_path ? strrchr(o->output_path, '.') : NULL;
    if (!o->output_path) return ts_error_set(err, TS_E_USAGE, "no output file: give -o OUT.exr");
    if (!ext || strcmp(ext, ".exr") != 0)
        return ts_error_set(err, TS_E_USAGE, "%s: a bake is written as .exr", o->output_path);
    if (ext == o->output_path || ext[-1] == '/') /* "-o .exr": a hidden file with no name */
        return ts_error_set(err, TS_E_USAGE, "%s: the output needs a name before .exr",
                            o->output_path);
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.frame = o->frame, lo.quiet = o->quiet, lo.strict = o->strict, lo.up = o->up;
    lo.programs = !o->no_programs;
    if (output_check_paths(o->output_path, o->stats_path, o->scene_path, err) ||
        scene_load_with(o->scene_path, &lo, &b->scene, err) ||
        output_check_inputs_paths(o->output_path, o->stats_path, &b->scene, err))
        return err->code;
    if (b->scene.patch_count == 0)
        return ts_error_set(err, TS_E_USAGE, "%s: no patches to bake", o->scene_path);
    const ts_camera *c = &b->scene.camera;
    b->width = o->width ? o->width : c->has_format ? c->width : 640;
    b->height = o->height ? o->height : c->has_format ? c->height : 480;
    if (render_camera_params(c, b->width, b->height, &b->cam, err)) return err->code;
    b->cam.spp = 1;
    b->cam.seed = o->seed;
    return TS_OK;
}

static int bake_open_device(ts_bake *b, ts_error *err)
{
    if (dev_open(&b->cl, &b->opt.cl, err)) return err->code;
    if (!b->opt.quiet && b->cl.cache_note[0])
        ts_print_line("tessera: warning: %s", b->cl.cache_note);
    snprintf(b->stats->device, sizeof b->stats->device, "%.120s (%.120s)", b->cl.info.name,
             b->cl.info.platform_name);
    b->stats->kernel_build_seconds = b->cl.build_seconds;
    b->stats->kernel_cache_hit = b->cl.cache_hit;
    ts_budget_choice c;
    if (b->opt.memory_mb > 0) {
        budget_fixed((uint64_t)b->opt.memory_mb, &c);
    } else { /* as render's default (budget.h); the bake holds no films but the footprint's */
        ts_memory_room room;
        ts_memory_room_query(NULL, &room);
        uint64_t pixels = (uint64_t)b->width * (uint64_t)b->height;
        budget_default(&b->cl.info, budget_fixed_bytes(&b->scene, pixels), &room, &c);
    }
    b->mb = c.mb;
    b->room_mb = c.room_mb;
    b->stats->memory_budget_bytes = c.mb << 20;
    if (!b->opt.quiet)
        ts_print_line("tessera: bake, memory budget %llu MB (%s)", (unsigned long long)c.mb, c.why);
    return TS_OK;
}

/* A pipeline for waves of up to `rays` rays. */
static int bake_pipeline(ts_bake *b, uint64_t rays, ts_error *err)
{
    ts_pipeline_plan plan;
    if (pipeline_plan(b->mb << 20, rays, (uint32_t)b->opt.max_lod, b->cl.info.max_alloc, &plan,
                      err) ||
        pipeline_create(&b->pipe, &b->cl, &b->scene, &plan, 1, b->stats, err) ||
        dev_finish(&b->cl, b->stats, err))
        return err->code;
    b->max_lod = plan.max_lod;
    b->pipe.mode =
        (ts_trace_mode){1u, -1, b->opt.exact, 0, 0u, waves_tight_leaves(b->opt.exact), 1.0};
    if (!b->opt.quiet && plan.max_lod < (uint32_t)b->opt.max_lod && b->opt.fixed_lod != 0)
        ts_print_line("tessera: the memory budget of %llu MB holds patches up to m = %u; "
                      "baking at most that finely",
                      (unsigned long long)b->mb, plan.max_lod);
    return TS_OK;
}

/* The render's lod stage (its default rule, TS_LOD_RULE_CROSSED) over the camera's width x
 * height pixels, one ray each: patch p at the smallest m with 4^m >= the pixels whose rays
 * cross its box. Leaves them in patch_lod. */
static int bake_footprint(ts_bake *b, ts_error *err)
{
    uint64_t total = (uint64_t)b->width * b->height;
    if (bake_pipeline(b, total, err)) return err->code;
    return pipeline_lod(&b->pipe, &b->cam, TS_LOD_RULE_CROSSED, err);
}

/* Each patch's m: the footprint's (or --lod), raised to hold --points, at most the plan's. */
static int bake_levels(ts_bake *b, ts_error *err)
{
    uint32_t n = b->scene.patch_count;
    if (b->opt.fixed_lod < 0 && bake_footprint(b, err)) return err->code;
    if (b->opt.fixed_lod >= 0) {
        ts_pipeline_plan plan; /* only for its max_lod: the same budget dices the same */
        if (pipeline_plan(b->mb << 20, 1u << 20, (uint32_t)b->opt.max_lod, b->cl.info.max_alloc,
                          &plan, err))
            return err->code;
        b->max_lod = plan.max_lod;
    }
    uint32_t floor_m = 0;
    while (floor_m < TS_LOD_LIMIT &&
           ((1u << floor_m) + 1u) * ((1u << floor_m) + 1u) < (uint32_t)b->opt.min_points)
        ++floor_m;
    if (!(b->lod = malloc(n * sizeof *b->lod)))
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    for (uint32_t p = 0; p < n; ++p) {
        uint32_t m = b->opt.fixed_lod >= 0 ? (uint32_t)b->opt.fixed_lod : b->pipe.patch_lod[p];
        m = m < floor_m ? floor_m : m;
        b->lod[p] = m < b->max_lod ? m : b->max_lod;
    }
    pipeline_destroy(&b->pipe); /* the bake's own is planned for its rays */
    return TS_OK;
}

/* The job hash (what the result depends on) and the rest of the metadata. */
static void bake_job(ts_bake *b)
{
    const ts_bake_options *o = &b->opt;
    ts_bake_meta *m = &b->meta;
    uint64_t h = TS_FNV1A_INIT;
    int32_t geometry = bake_geometry_hash(&b->scene);
    int32_t opts[] = {o->bands,      o->rays,    o->flags, (int32_t)o->seed, o->fixed_lod,
                      o->min_points, o->max_lod, o->exact, geometry};
    h = ts_fnv1a(h, opts, sizeof opts);
    h = ts_fnv1a(h, &b->cam, sizeof b->cam);
    uint64_t l = ts_fnv1a(TS_FNV1A_INIT, b->lod, b->scene.patch_count * sizeof *b->lod);
    *m = (ts_bake_meta){.bands = o->bands,
                        .rays = o->rays,
                        .flags = o->flags,
                        .seed = (int32_t)o->seed,
                        .max_lod = (int32_t)b->max_lod,
                        .job = (int32_t)(uint32_t)(h ^ (h >> 32)),
                        .lod = (int32_t)(uint32_t)(l ^ (l >> 32)),
                        .geometry = geometry,
                        .points = b->img.layout.point_first[b->scene.patch_count],
                        .patches = b->scene.patch_count};
}

/* --resume: the points an earlier run of this command finished (none without a file). */
static int bake_resume(ts_bake *b, int *complete, ts_error *err)
{
    struct stat st;
    if (stat(b->opt.output_path, &st) != 0 && errno == ENOENT) {
        if (!b->opt.quiet)
            ts_print_line("tessera: %s does not exist yet: baking from the start",
                          b->opt.output_path);
        return TS_OK;
    }
    if (bake_image_resume(&b->img, b->opt.output_path, &b->meta, &b->done, err)) return err->code;
    *complete = b->done == b->meta.points;
    if (!b->opt.quiet && !*complete)
        ts_print_line("tessera: resuming %s at point %u of %u", b->opt.output_path, b->done,
                      b->meta.points);
    return TS_OK;
}

/* The bake's pipeline and stage, and the host's copy of one wave's results. */
static int bake_prepare(ts_bake *b, ts_error *err)
{
    const ts_bake_options *o = &b->opt;
    uint64_t rays = (uint64_t)(b->meta.points - b->done) * (uint64_t)o->rays;
    if (bake_pipeline(b, rays, err)) return err->code;
    ts_bake_setup setup = {.bands = (uint32_t)o->bands,
                           .rays = (uint32_t)o->rays,
                           .flags = (uint32_t)o->flags,
                           .seed = o->seed,
                           .orthographic = b->cam.projection == TS_PROJECTION_ORTHOGRAPHIC,
                           .lod = b->lod,
                           .point_first = b->img.layout.point_first};
    const float *eye = setup.orthographic ? b->cam.forward : b->cam.origin;
    memcpy(setup.eye, eye, sizeof setup.eye);
    if (bake_stage_create(&b->pipe, &setup, err)) return err->code;
    /* Dice once when it fits, as a render's default budget does (budget_grow_arenas): a
     * bake's rays reach most of the scene in every wave. */
    if (budget_grow_arenas(&b->pipe, b->room_mb, 0, o->quiet, err)) return err->code;
    size_t n = b->pipe.bake->points_per_wave;
    b->coeffs = malloc(n * (size_t)o->bands * o->bands * sizeof *b->coeffs);
    b->pos = malloc(n * sizeof *b->pos);
    b->normal = malloc(n * sizeof *b->normal);
    if (!b->coeffs || !b->pos || !b->normal) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    return TS_OK;
}

/* The waves, from point done on, until every point is baked or a signal stops them. */
static int bake_waves(ts_bake *b, ts_error *err)
{
    uint32_t total = b->meta.points, start = b->done, per = b->pipe.bake->points_per_wave;
    double t0 = stats_now();
    interrupt_install();
    for (uint32_t first = start; first < total; first += per) {
        uint32_t n = total - first < per ? total - first : per;
        if (bake_stage_wave(&b->pipe, first, n, b->coeffs, b->pos, b->normal, err)) {
            if (!b->opt.quiet && first > start) fputc('\n', stderr);
            return err->code;
        }
        bake_image_store(&b->img, first, n, b->coeffs, b->pos, b->normal);
        b->done = first + n;
        double dt = stats_now() - t0, done = (double)(b->done - start);
        if (!b->opt.quiet)
            fprintf(stderr, "\rtessera: %u / %u points, %.2f Mrays/s, ETA %.0f s   ", b->done,
                    total, dt > 0 ? done * b->opt.rays / dt / 1e6 : 0.0,
                    dt * (double)(total - b->done) / done);
        if (interrupt_signal()) break;
    }
    if (!b->opt.quiet && b->done > start) fputc('\n', stderr);
    b->stats->bake.seconds += stats_now() - t0;
    return TS_OK;
}

static int bake_write(ts_bake *b, ts_error *err)
{
    double t0 = stats_now();
    b->meta.done = b->done;
    int rc = bake_image_write(&b->img, b->opt.output_path, &b->meta, err);
    b->stats->stage_seconds[TS_STAGE_film] += stats_now() - t0;
    return rc;
}

int bake_run(const ts_bake_options *o, ts_stats *stats, ts_bake_result *result, ts_error *err)
{
    double t0 = stats_now();
    memset(result, 0, sizeof *result);
    ts_bake b;
    memset(&b, 0, sizeof b);
    b.opt = *o;
    b.stats = stats;
    stats->bake.bands = (uint32_t)o->bands;
    stats->bake.rays_per_point = (uint32_t)o->rays;
    int complete = 0;
    int rc = bake_load(&b, err);
    if (!rc) rc = bake_open_device(&b, err);
    if (!rc) rc = bake_levels(&b, err);
    if (!rc) rc = bake_image_create(&b.img, b.lod, b.scene.patch_count, (uint32_t)o->bands, err);
    if (!rc) bake_job(&b);
    if (!rc && o->resume) rc = bake_resume(&b, &complete, err);
    if (!rc && !complete) rc = bake_prepare(&b, err);
    if (!rc && !complete) rc = bake_waves(&b, err);
    if (!rc && !complete) rc = bake_write(&b, err);
    interrupt_restore(); /* after the write: until then a signal only stops the waves */
    if (!rc) {
        result->outcome = complete                 ? TS_BAKE_UP_TO_DATE
                          : b.done < b.meta.points ? TS_BAKE_INTERRUPTED
                                                   : TS_BAKE_COMPLETE;
        result->points_done = b.done;
        result->points_total = b.meta.points;
        result->rays = stats->counters[TS_COUNTER_rays];
        result->seconds = stats->bake.seconds;
        result->signal = interrupt_signal();
    }
    bake_free(&b);
    stats->wall_seconds = stats_now() - t0;
    return rc;
}
