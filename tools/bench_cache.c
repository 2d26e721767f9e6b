/* bench_cache.c — reordering vs caching (Hanika et al. 2010, Table 2; Pharr et al. 1997):
 * how many times patches are diced to trace the same rays (issue 8 item 1, DESIGN.md §6): the
 * frame's eye rays, or with --paths every ray of its paths (eye, BSDF and shadow rays of each
 * bounce, as `tessera render` traces them), as the paper's Table 2 counts path tracing's rays.
 *
 * reordering: Tessera's wavefront loop (host/pipeline/trace.c) traces the frame's eye rays in waves
 *   of the plan's ray capacity (--memory; `tessera render` makes its waves half that, as
 *   each path also owns a shadow-ray slot), in its sample order (bands of rows of about a
 *   wave, kernels/lib/sample_order.h); the count is its `patches_diced` counter. The
 *   lod stage first sets each patch's m from the frame's ray counts (4^m >= R / spp), as
 *   `tessera render` does; without --memory the arenas then grow to the frame's patches
 *   where the machine has room, as `tessera render`'s default budget does
 *   (budget_grow_arenas), and with --memory they stay a quarter of it.
 *   With --paths the waves are `tessera render`'s (app/waves.c waves_trace_paths: half the
 *   capacity in paths, each with a BSDF and a shadow-ray slot), every bounce's rays read
 *   back before and after their trace (ts_wave_watch).
 * cache C (10, 100, 1000 diced patches, LRU): the same rays (read back from the device) are
 *   traced one at a time in the original order — scanline order of pixels, each pixel's
 *   samples in turn, each path's rays bounce by bounce (a path tracer without reordering:
 *   Pharr and Hanrahan 1996) — by a plain-C tracer (tools/cache_tracer.c): exact front-to-back
 * traversal of the same patch QBVH (host/pipeline/qbvh.c) with a priority queue on entry distance,
 * stopping when the nearest entry left is beyond the closest hit so far; each patch reached is
 * looked up in the cache (a miss is one dicing of the patch at Tessera's m for it), then
 * intersected with the plain-C bottom level (host/ref/bottom_level_ref.c, leaf boxes, leaf size 1)
 * on the grid and tree of the plain-C dice/build references (host/ref/dice_build_ref.c), with the
 *   kernels' rules for the patch a ray leaves (its triangles, org.w its tmin), for shadow rays
 *   (done at their first hit below the light's distance, not stopped by the light they aim
 *   at) and for the patches a kind of ray does not see. The three caches
 *   see the same sequence of lookups, so one pass serves all three. The host keeps the grids
 *   it really dices in a memo (cleared when it passes --memo-mb) so each patch is not
 *   recomputed on every simulated miss; that changes no count.
 * every patch: the patches the exact tracer reaches at all, which an unbounded cache dices
 *   once each: the floor of any order of the same rays that dices only what they reach.
 * every pass (--order wave, where the rays come pass by pass: a bounce of a wave): the
 *   patches each pass's rays reach, once a pass, summed: what reordering would dice if each
 *   pass diced exactly the patches its rays reach before their closest hits, once (no
 *   candidate behind a closest hit, no patch twice in a pass), with no patch kept between
 *   passes, and their micro-quads at the frame's levels (what those dicings would cost).
 *   Reordering's culling by the trees' upper levels may take it below that.
 * Both tracers find the closest hit of every ray among the same micro-geometry, so the
 * benchmark fails unless every ray gets the same answer from both (hit or not; a shadow ray's
 * first hit need not be its nearest), and it reports how many hit distances are bitwise equal.
 * Checks: dicings(reorder) <= dicings(cache 10) and cache 1000 <= cache 100
 * <= cache 10. Every check is recorded under "checks" in the JSON. The two that are
 * properties of a correct run (LRU caches are inclusive, so a larger one never dices more;
 * both tracers hit the same rays) make the exit status 1 when they fail; reordering dicing
 * more than a 10-entry cache is a finding, not an error (it happens when few rays want
 * each patch), and is printed as such. The ctest smoke test asserts it at --size tiny.
 *
 * usage: bench_cache [--size tiny|small|full] [--scene RIB]... [--res WxH] [--spp N]
 *                    [--memory MB] [--memo-mb MB] [--order pixel|pass|wave] [--paths]
 *                    [--lazy] [--json PATH]
 *   --order pass: the caches see the rays sample pass by sample pass (the order of Tessera's
 *   camera), instead of scanline order with each pixel's samples in turn (default, pixel);
 *   --order wave: as Tessera's waves list them before their sort (wave by wave, bounce by
 *   bounce, each bounce's rays in path order): a cache in place of the reordering, in the
 *   same renderer (Hanika's comparison).
 *   --lazy: each iteration of the reordering is also replayed as a trace that dices a patch
 *   only when one of its rays still needs it, in Tessera's batch order and near first
 *   (tools/lazy_sim.c): the dicings that would save, the same hits.
 *   tiny:  scene/forest-1.rib at 160x64, 1 spp
 *   small: scene/forest-100.rib and scene/forest-1000.rib at 480x192, 4 spp
 *   full:  the same at 1920x768, 4 spp (the paper: 1920x768x64 rays, with motion blur)
 * Scene paths are relative to the working directory. */
#include "bench_cache.h"
#include "pipeline/pipeline.h"
#include "app/budget.h"
#include "app/options.h"
#include "app/render.h"
#include "app/units.h"
#include "app/waves.h"
#include "lib/sample_order.h"
#include "scene/rib/rib.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The order the caches meet the rays in (--order). */
enum { ORDER_PIXEL, ORDER_PASS, ORDER_WAVE };
static const char *const order_names[] = {"pixel", "pass", "wave"};

typedef struct bench_options {
    const char *size, *json_path;
    const char *scenes[4];
    int scene_count, width, height, spp, memory_mb, memo_mb;
    int order; /* ORDER_PIXEL, ORDER_PASS, ORDER_WAVE */
    int paths; /* --paths: every ray of the paths, not the eye rays alone */
    int lazy;  /* --lazy: each iteration replayed as a lazy trace would dice (lazy_sim.c) */
    int grow;  /* no --memory: the arenas grow to the frame's patches, as render's do */
} bench_options;

/* --size's resolution, samples and scenes (when no --scene named any); 1: an unknown size. */
static int bench_size(bench_options *o)
{
    int big = 0;
    if (!strcmp(o->size, "tiny"))
        o->width = 160, o->height = 64, o->spp = 1;
    else if (!strcmp(o->size, "small"))
        o->width = 480, o->height = 192, o->spp = 4, big = 1;
    else if (!strcmp(o->size, "full"))
        o->width = 1920, o->height = 768, o->spp = 4, big = 1;
    else {
        fprintf(stderr, "bench_cache: --size must be tiny, small or full, not '%s'\n", o->size);
        return 1;
    }
    if (o->scene_count == 0) {
        if (big)
            o->scenes[0] = "scene/forest-100.rib", o->scenes[1] = "scene/forest-1000.rib",
            o->scene_count = 2;
        else
            o->scenes[0] = "scene/forest-1.rib", o->scene_count = 1;
    }
    return 0;
}

static int bench_parse(int argc, char **argv, bench_options *o)
{
    static const struct option longopts[] = {
        {"size", required_argument, NULL, 's'},   {"scene", required_argument, NULL, 'S'},
        {"res", required_argument, NULL, 'r'},    {"spp", required_argument, NULL, 'p'},
        {"memory", required_argument, NULL, 'm'}, {"memo-mb", required_argument, NULL, 'M'},
        {"json", required_argument, NULL, 'j'},   {"order", required_argument, NULL, 'o'},
        {"paths", no_argument, NULL, 'P'},        {"lazy", no_argument, NULL, 'L'},
        {"help", no_argument, NULL, 'h'},         {NULL, 0, NULL, 0},
    };
    *o = (bench_options){.size = "small", .memory_mb = 1024, .memo_mb = 2048, .grow = 1};
    int c, w = 0, h = 0, spp = 0;
    while ((c = getopt_long(argc, argv, "s:S:r:p:m:M:j:o:PLh", longopts, NULL)) != -1) {
        switch (c) {
        case 's':
            o->size = optarg;
            break;
        case 'S':
            if (o->scene_count == 4) {
                fprintf(stderr, "bench_cache: at most 4 --scene\n");
                return 1;
            }
            o->scenes[o->scene_count++] = optarg;
            break;
        case 'r':
            if (sscanf(optarg, "%dx%d", &w, &h) != 2 || w < 1 || h < 1) {
                fprintf(stderr, "bench_cache: --res wants WxH, not '%s'\n", optarg);
                return 1;
            }
            break;
        case 'p':
            spp = atoi(optarg);
            break;
        case 'm':
            o->memory_mb = atoi(optarg);
            o->grow = 0;
            break;
        case 'M':
            o->memo_mb = atoi(optarg);
            break;
        case 'j':
            o->json_path = optarg;
            break;
        case 'o':
            o->order = !strcmp(optarg, "pixel")  ? ORDER_PIXEL
                       : !strcmp(optarg, "pass") ? ORDER_PASS
                       : !strcmp(optarg, "wave") ? ORDER_WAVE
                                                 : -1;
            if (o->order < 0) {
                fprintf(stderr, "bench_cache: --order must be pixel, pass or wave, not '%s'\n",
                        optarg);
                return 1;
            }
            break;
        case 'P':
            o->paths = 1;
            break;
        case 'L':
            o->lazy = 1;
            break;
        default:
            fprintf(stderr,
                    "usage: %s [--size tiny|small|full] [--scene RIB]... [--res WxH] [--spp N] "
                    "[--memory MB] [--memo-mb MB] [--order pixel|pass|wave] [--paths] [--lazy] "
                    "[--json PATH]\n",
                    argv[0]);
            return c == 'h' ? 0 : 1;
        }
    }
    if (bench_size(o)) return 1;
    if (w) o->width = w, o->height = h;
    if (spp) o->spp = spp;
    if (o->spp < 1 || o->memory_mb < 16 || o->memo_mb < 1) {
        fprintf(stderr,
                "bench_cache: --spp must be positive, --memory at least 16, --memo-mb positive\n");
        return 1;
    }
    return -1;
}

/* The frame's rays, their hits by Tessera's wavefront loop, and each patch's m. */
typedef struct frame {
    bench_ray *r;
    uint64_t count, cap;
    uint64_t eye, bsdf, shadow; /* rays by kind */
    uint8_t *lod;
    /* the wave being recorded */
    uint32_t first, wave_size, slots, *active;
    uint64_t *at; /* per listed ray: its record */
    ts_vec4 *org, *dir;
    ts_hit *hit;
    uint32_t *flags, *from;
    ts_sample_order order;
    int order_of; /* bench_options.order */
} frame;

/* Reads `count` entries of buffer m, one a ray slot at most, into *host (made f->slots long). */
static int read_slots(ts_pipeline *p, const frame *f, cl_mem m, size_t size, uint32_t count,
                      void **host, ts_error *err)
{
    if (!*host && !(*host = malloc((size_t)f->slots * size)))
        return ts_error_set(err, TS_E_MEMORY, "out of memory for the rays");
    return dev_read(p->cl, m, 0, (size_t)count * size, *host, "the rays", err);
}

/* ts_wave_watch (app/waves.h): before bounce b is traced, a record for each of its rays;
 * after, their hits. Eye rays are bounce 0 (read before any shade in the eye-ray mode). */
static int frame_watch(void *ctx, ts_pipeline *p, uint32_t bounce, uint32_t rays, int after,
                       ts_error *err)
{
    frame *f = ctx;
    if (after) {
        if (dev_read(p->cl, p->ray_hit, 0, (size_t)f->slots * sizeof *f->hit, f->hit, "the hits",
                     err))
            return err->code;
        for (uint32_t i = 0; i < rays; ++i)
            f->r[f->at[i]].hit = f->hit[f->active[i]];
        return TS_OK;
    }
    if (f->count + rays > f->cap) {
        uint64_t cap = f->cap ? 2 * f->cap : 1u << 20;
        while (cap < f->count + rays)
            cap *= 2;
        bench_ray *r = realloc(f->r, cap * sizeof *r);
        if (!r)
            return ts_error_set(err, TS_E_MEMORY, "out of memory for %llu rays",
                                (unsigned long long)cap);
        f->r = r, f->cap = cap;
    }
    if (read_slots(p, f, p->active, sizeof *f->active, rays, (void **)&f->active, err) ||
        read_slots(p, f, p->ray_org, sizeof *f->org, f->slots, (void **)&f->org, err) ||
        read_slots(p, f, p->ray_dir, sizeof *f->dir, f->slots, (void **)&f->dir, err) ||
        read_slots(p, f, p->ray_hit, sizeof *f->hit, f->slots, (void **)&f->hit, err) ||
        read_slots(p, f, p->ray_flags, sizeof *f->flags, f->slots, (void **)&f->flags, err) ||
        read_slots(p, f, p->ray_from, sizeof *f->from, f->slots, (void **)&f->from, err))
        return err->code;
    for (uint32_t i = 0; i < rays; ++i) {
        uint32_t slot = f->active[i], shadow = slot >= f->wave_size;
        uint32_t path = shadow ? slot - f->wave_size : slot, px, sample;
        sample_order_at(f->first + path, f->order.pixels, f->order.spp, f->order.band, &px,
                        &sample);
        uint64_t g = f->order_of == ORDER_PASS ? (uint64_t)sample * f->order.pixels + px
                                               : (uint64_t)px * f->order.spp + sample;
        f->at[i] = f->count;
        f->r[f->count] =
            (bench_ray){f->order_of == ORDER_WAVE ? f->count : (g << 5) | (bounce << 1) | !shadow,
                        f->org[slot],
                        f->dir[slot],
                        f->hit[slot].t,
                        f->flags[slot],
                        f->from[slot],
                        ((uint64_t)f->first << 5) | bounce,
                        {TS_NO_HIT, 0, 0, TS_INVALID, TS_INVALID}};
        f->count++;
        f->eye += !shadow && bounce == 0, f->bsdf += !shadow && bounce > 0, f->shadow += shadow;
    }
    return TS_OK;
}

static int key_cmp(const void *a, const void *b)
{
    uint64_t x = ((const bench_ray *)a)->key, y = ((const bench_ray *)b)->key;
    return (x > y) - (x < y);
}

/* The waves: the eye rays alone (pipeline_trace, `per` a wave), or, with --paths, whole paths
 * as `tessera render` traces them (waves_trace_paths: per / 2 paths a wave, each with a
 * BSDF and a shadow-ray slot), each wave recorded by frame_watch. */
static int trace_waves(const bench_options *o, ts_pipeline *p, ts_camera_params *cam,
                       uint64_t total, uint32_t per, frame *f, bench_result *res, ts_error *err)
{
    ts_render_options ro;
    render_options_defaults(&ro);
    ro.spp = o->spp;
    int rc = TS_OK;
    f->slots = per;
    if (!(f->at = malloc((size_t)per * sizeof *f->at)))
        return ts_error_set(err, TS_E_MEMORY, "out of memory");
    if (o->paths) per /= 2;
    res->waves = 0;
    for (uint64_t first = 0; !rc && first < total; first += per, res->waves++) {
        cam->first_sample = (uint32_t)first;
        cam->ray_count = (uint32_t)(total - first < per ? total - first : per);
        f->first = (uint32_t)first, f->wave_size = o->paths ? cam->ray_count : per;
        rc = pipeline_camera(p, cam, err);
        if (!rc && o->paths) rc = waves_trace_paths_watched(&ro, p, cam, frame_watch, f, err);
        if (!rc && !o->paths)
            rc = frame_watch(f, p, 0, cam->ray_count, 0, err) ||
                 pipeline_trace(p, cam->ray_count, err) ||
                 frame_watch(f, p, 0, cam->ray_count, 1, err);
    }
    free(f->active), free(f->at), free(f->org), free(f->dir), free(f->hit), free(f->flags),
        free(f->from);
    f->active = NULL, f->at = NULL, f->org = f->dir = NULL, f->hit = NULL;
    f->flags = f->from = NULL;
    if (!rc) qsort(f->r, f->count, sizeof *f->r, key_cmp);
    return rc ? err->code : TS_OK;
}

/* reordering: lod stage over the frame, then its rays wave by wave as `tessera render` traces
 * them (the eye rays alone: one wave = the plan's ray capacity, no shadow-ray slots). Keeps
 * every ray and its hit, in the order the caches meet them. */
static int run_reorder(const bench_options *o, ts_device *cl, const ts_scene *s, frame *f,
                       bench_result *res, ts_error *err)
{
    uint64_t total = (uint64_t)o->width * o->height * o->spp;
    ts_pipeline_plan plan;
    if (pipeline_plan((uint64_t)o->memory_mb << 20, o->paths ? 2 * total : total, 10,
                      cl->info.max_alloc, &plan, err))
        return err->code;
    ts_stats st;
    memset(&st, 0, sizeof st);
    ts_pipeline p;
    int rc = pipeline_create(&p, cl, s, &plan, (uint32_t)(o->width * o->height), &st, err);
    ts_camera_params cam;
    if (!rc) rc = render_camera_params(&s->camera, o->width, o->height, &cam, err);
    f->lod = malloc(s->patch_count ? s->patch_count : 1);
    if (!rc && !f->lod) rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
    double t0 = stats_now();
    uint32_t per = plan.ray_capacity;
    cam.spp = (uint32_t)o->spp;
    /* Bands of rows of about a wave: the rows each of tessera render's waves covers (one device
     * traces them pixel after pixel, app/done.h: the same patches a wave). */
    cam.band = sample_order_band(cam.width, cam.height, cam.spp, o->paths ? per / 2 : per);
    f->order = sample_order_of(&cam);
    f->order_of = o->order;
    res->band_rows = cam.band ? cam.band / cam.width : cam.height;
    p.mode = (ts_trace_mode){(uint32_t)o->spp, -1, 0, 0, 0u, 0, 1.0};
    if (!rc && o->lazy) p.iteration_watch = lazy_watch, p.iteration_ctx = &res->lazy_dicings;
    res->lazy = o->lazy;
    if (!rc)
        rc =
            pipeline_lod(&p, &cam, TS_LOD_RULE_CROSSED, err); /* the lod stage, as tessera render */
    /* The default budget's arenas grow to the frame's patches, as tessera render's do. */
    if (!rc && o->grow) {
        ts_budget_choice c;
        ts_memory_room room;
        ts_memory_room_query(NULL, &room);
        budget_default(&cl->info, budget_fixed_bytes(s, (uint64_t)o->width * o->height), &room, &c);
        st.memory_budget_bytes = (uint64_t)o->memory_mb << 20; /* what the plan was made for */
        rc = budget_grow_arenas(&p, c.room_mb, 0, 1, err);
    }
    res->arena_bytes = pipeline_arena_bytes(&p.plan);
    if (!rc) rc = trace_waves(o, &p, &cam, total, per, f, res, err);
    res->reorder_seconds = stats_now() - t0;
    if (!rc) {
        memcpy(f->lod, p.patch_lod, s->patch_count);
        res->max_lod = p.plan.max_lod;
        res->reorder_dicings = st.counters[TS_COUNTER_patches_diced];
        res->reorder_micropolygons = st.counters[TS_COUNTER_micropolygons_created];
        res->reorder_iterations = st.counters[TS_COUNTER_iterations];
        res->reorder_pairs = st.counters[TS_COUNTER_pairs];
    }
    if (p.cl) pipeline_destroy(&p);
    stats_free(&st);
    return rc ? err->code : TS_OK;
}

static int bench_scene(const bench_options *o, ts_device *cl, const char *path, bench_result *res,
                       ts_error *err)
{
    ts_scene s;
    memset(&s, 0, sizeof s);
    memset(res, 0, sizeof *res);
    res->scene = path;
    if (rib_load(path, &s, 1, err)) return err->code;
    res->patches = s.patch_count;
    frame f = {0};
    fprintf(stderr, "bench_cache: %s: reordering (Tessera's wavefront loop)...\n", path);
    int rc = run_reorder(o, cl, &s, &f, res, err);
    res->rays = f.count;
    res->eye_rays = f.eye, res->bsdf_rays = f.bsdf, res->shadow_rays = f.shadow;
    if (!rc) fprintf(stderr, "bench_cache: %s: caches, one ray at a time...\n", path);
    res->by_pass = o->order == ORDER_WAVE; /* the rays come pass by pass */
    if (!rc) rc = cache_trace(&s, f.lod, f.r, f.count, (uint64_t)o->memo_mb, res, err);
    free(f.r), free(f.lod);
    scene_free(&s);
    return rc;
}

/* The checks of issue 8 item 1; returns how many of the correctness checks failed (see the
 * file's comment: reorder <= cache 10 is reported, not counted). */
static int bench_check(bench_result *r)
{
    const lru *c = r->cache;
    r->check_reorder_le_cache10 = r->reorder_dicings <= c[0].dicings;
    r->check_caches_monotone = c[2].dicings <= c[1].dicings && c[1].dicings <= c[0].dicings;
    r->check_same_hits = r->hits_cache == r->hits_reorder && r->answers_equal == r->rays;
    if (!r->check_reorder_le_cache10)
        fprintf(stderr, "bench_cache: note: %s: reordering dices more than a 10-entry cache here\n",
                r->scene);
    if (!r->check_caches_monotone)
        fprintf(stderr, "bench_cache: CHECK FAILED: %s: larger caches dice more\n", r->scene);
    if (!r->check_same_hits)
        fprintf(stderr,
                "bench_cache: CHECK FAILED: %s: %llu rays hit in the cache tracer, %llu in Tessera "
                "(%llu of %llu answers alike)\n",
                r->scene, (unsigned long long)r->hits_cache, (unsigned long long)r->hits_reorder,
                (unsigned long long)r->answers_equal, (unsigned long long)r->rays);
    return !r->check_caches_monotone + !r->check_same_hits;
}

static void bench_print(const bench_options *o, const bench_result *r)
{
    char kinds[160] = "";
    if (o->paths)
        snprintf(kinds, sizeof kinds, " (eye %llu, BSDF %llu, shadow %llu; each path's in turn)",
                 (unsigned long long)r->eye_rays, (unsigned long long)r->bsdf_rays,
                 (unsigned long long)r->shadow_rays);
    printf("%s: %u patches, %dx%d x %d spp = %llu %s%s, %s %d MB (%llu MB of patch "
           "arenas): %u waves in bands of %u rows, %llu iterations, max m %u; caches see the "
           "rays %s\n",
           r->scene, r->patches, o->width, o->height, o->spp, (unsigned long long)r->rays,
           o->paths ? "rays of paths" : "eye rays", kinds, o->grow ? "default budget" : "--memory",
           o->memory_mb, (unsigned long long)(r->arena_bytes >> 20), r->waves, r->band_rows,
           (unsigned long long)r->reorder_iterations, r->max_lod,
           o->order == ORDER_PASS   ? "sample pass by pass"
           : o->order == ORDER_WAVE ? "as the waves list them (bounce by bounce, unsorted)"
                                    : "in scanline order, each pixel's samples in turn");
    printf("  %-12s %12s %16s %14s\n", "method", "dicings", "micro-polygons", "vs cache 1000");
    for (int c = 0; c < BENCH_CACHES; ++c)
        printf("  cache %-6u %12llu %16llu %14.2f\n", r->cache[c].cap,
               (unsigned long long)r->cache[c].dicings,
               (unsigned long long)r->cache[c].micropolygons,
               (double)r->cache[c].dicings / (double)r->cache[2].dicings);
    printf("  %-12s %12llu %16s %14.2f   (each patch the rays reach, once: the floor)\n",
           "every patch", (unsigned long long)r->reached, "",
           (double)r->reached / (double)r->cache[2].dicings);
    if (r->by_pass)
        printf("  %-12s %12llu %16llu %14.2f   (each patch a pass reaches, once a pass)\n",
               "every pass", (unsigned long long)r->pass_reached,
               (unsigned long long)r->pass_reached_mp,
               (double)r->pass_reached / (double)r->cache[2].dicings);
    printf("  %-12s %12llu %16llu %14.2f\n", "reordering", (unsigned long long)r->reorder_dicings,
           (unsigned long long)r->reorder_micropolygons,
           (double)r->reorder_dicings / (double)r->cache[2].dicings);
    if (r->lazy) {
        const lazy_counts *z = &r->lazy_dicings;
        printf(
            "  lazy dicing (replayed): of the %llu diced, %llu in Tessera's batch order (%.2f), "
            "%llu near first (%.2f); of their %llu micro-polygons, %llu (%.2f) and %llu "
            "(%.2f)\n",
            (unsigned long long)z->misses, (unsigned long long)z->batch_order,
            (double)z->batch_order / (double)z->misses, (unsigned long long)z->near_first,
            (double)z->near_first / (double)z->misses, (unsigned long long)z->misses_mp,
            (unsigned long long)z->batch_order_mp, (double)z->batch_order_mp / (double)z->misses_mp,
            (unsigned long long)z->near_first_mp, (double)z->near_first_mp / (double)z->misses_mp);
    }
    printf("  rays hit: %llu (Tessera) / %llu (cache tracer); of %llu hits compared (not shadow "
           "rays') distances equal %llu, nearer in Tessera %llu, nearer in the cache tracer "
           "%llu\n",
           (unsigned long long)r->hits_reorder, (unsigned long long)r->hits_cache,
           (unsigned long long)r->hits_compared, (unsigned long long)r->hit_t_equal,
           (unsigned long long)r->t_reorder_nearer, (unsigned long long)r->t_cache_nearer);
    printf("  patch lookups %llu (%.2f per ray); %.1f s wavefront, %.1f s cache tracer\n",
           (unsigned long long)r->lookups, (double)r->lookups / (double)r->rays, r->reorder_seconds,
           r->cache_seconds);
}

static int bench_json(const bench_options *o, const bench_result *rs, int n, const char *device)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "benchmark", "cache");
    cJSON_AddStringToObject(root, "size", o->size);
    cJSON_AddStringToObject(root, "device", device);
    cJSON_AddNumberToObject(root, "width", o->width);
    cJSON_AddNumberToObject(root, "height", o->height);
    cJSON_AddNumberToObject(root, "spp", o->spp);
    cJSON_AddNumberToObject(root, "memory_mb", o->memory_mb);
    cJSON_AddBoolToObject(root, "arenas_grow", o->grow);
    cJSON_AddStringToObject(root, "ray_order", order_names[o->order]);
    cJSON_AddStringToObject(root, "rays", o->paths ? "paths" : "eye");
    cJSON *arr = cJSON_AddArrayToObject(root, "scenes");
    for (int i = 0; i < n; ++i) {
        const bench_result *r = &rs[i];
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "scene", r->scene);
        cJSON_AddNumberToObject(j, "patches", r->patches);
        cJSON_AddNumberToObject(j, "rays", (double)r->rays);
        cJSON_AddNumberToObject(j, "eye_rays", (double)r->eye_rays);
        cJSON_AddNumberToObject(j, "bsdf_rays", (double)r->bsdf_rays);
        cJSON_AddNumberToObject(j, "shadow_rays", (double)r->shadow_rays);
        cJSON_AddNumberToObject(j, "max_lod", r->max_lod);
        cJSON *ro = cJSON_AddObjectToObject(j, "reorder");
        cJSON_AddNumberToObject(ro, "dicings", (double)r->reorder_dicings);
        cJSON_AddNumberToObject(ro, "micropolygons", (double)r->reorder_micropolygons);
        cJSON_AddNumberToObject(ro, "waves", r->waves);
        cJSON_AddNumberToObject(ro, "band_rows", r->band_rows);
        cJSON_AddNumberToObject(ro, "arena_bytes", (double)r->arena_bytes);
        cJSON_AddNumberToObject(ro, "iterations", (double)r->reorder_iterations);
        cJSON_AddNumberToObject(ro, "pairs", (double)r->reorder_pairs);
        cJSON_AddNumberToObject(ro, "hits", (double)r->hits_reorder);
        cJSON_AddNumberToObject(ro, "seconds", r->reorder_seconds);
        if (r->lazy) {
            cJSON *lz = cJSON_AddObjectToObject(ro, "lazy");
            cJSON_AddNumberToObject(lz, "diced", (double)r->lazy_dicings.misses);
            cJSON_AddNumberToObject(lz, "batch_order", (double)r->lazy_dicings.batch_order);
            cJSON_AddNumberToObject(lz, "near_first", (double)r->lazy_dicings.near_first);
            cJSON_AddNumberToObject(lz, "diced_micropolygons", (double)r->lazy_dicings.misses_mp);
            cJSON_AddNumberToObject(lz, "batch_order_micropolygons",
                                    (double)r->lazy_dicings.batch_order_mp);
            cJSON_AddNumberToObject(lz, "near_first_micropolygons",
                                    (double)r->lazy_dicings.near_first_mp);
        }
        cJSON *ca = cJSON_AddArrayToObject(j, "cache");
        for (int c = 0; c < BENCH_CACHES; ++c) {
            cJSON *e = cJSON_CreateObject();
            cJSON_AddNumberToObject(e, "entries", r->cache[c].cap);
            cJSON_AddNumberToObject(e, "dicings", (double)r->cache[c].dicings);
            cJSON_AddNumberToObject(e, "micropolygons", (double)r->cache[c].micropolygons);
            cJSON_AddItemToArray(ca, e);
        }
        cJSON_AddNumberToObject(j, "cache_lookups", (double)r->lookups);
        cJSON_AddNumberToObject(j, "patches_reached", (double)r->reached);
        if (r->by_pass) {
            cJSON_AddNumberToObject(j, "patches_reached_per_pass", (double)r->pass_reached);
            cJSON_AddNumberToObject(j, "micropolygons_reached_per_pass",
                                    (double)r->pass_reached_mp);
        }
        cJSON_AddNumberToObject(j, "cache_hits", (double)r->hits_cache);
        cJSON_AddNumberToObject(j, "answers_equal", (double)r->answers_equal);
        cJSON_AddNumberToObject(j, "hits_compared", (double)r->hits_compared);
        cJSON_AddNumberToObject(j, "hit_t_equal", (double)r->hit_t_equal);
        cJSON_AddNumberToObject(j, "hit_t_nearer_reorder", (double)r->t_reorder_nearer);
        cJSON_AddNumberToObject(j, "hit_t_nearer_cache", (double)r->t_cache_nearer);
        cJSON *ck = cJSON_AddObjectToObject(j, "checks");
        cJSON_AddBoolToObject(ck, "reorder_le_cache_10", r->check_reorder_le_cache10);
        cJSON_AddBoolToObject(ck, "cache_1000_le_100_le_10", r->check_caches_monotone);
        cJSON_AddBoolToObject(ck, "same_rays_hit", r->check_same_hits);
        cJSON_AddNumberToObject(j, "cache_seconds", r->cache_seconds);
        cJSON_AddNumberToObject(j, "ratio_reorder_to_cache_1000",
                                (double)r->reorder_dicings / (double)r->cache[2].dicings);
        cJSON_AddNumberToObject(j, "ratio_reorder_to_cache_10",
                                (double)r->reorder_dicings / (double)r->cache[0].dicings);
        cJSON_AddItemToArray(arr, j);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    FILE *f = text ? fopen(o->json_path, "w") : NULL;
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0) ok = 0;
    free(text);
    if (!ok) fprintf(stderr, "bench_cache: cannot write %s\n", o->json_path);
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    bench_options o;
    int rc = bench_parse(argc, argv, &o);
    if (rc >= 0) return rc;
    ts_error err = {0};
    ts_device cl;
    memset(&cl, 0, sizeof cl);
    ts_device_options clo = {.device_index = -1};
    bench_result res[4];
    int n = 0, bad = 0;
    if (dev_open(&cl, &clo, &err) == TS_OK)
        for (; n < o.scene_count; ++n) {
            if (bench_scene(&o, &cl, o.scenes[n], &res[n], &err)) break;
            bad += bench_check(&res[n]);
            bench_print(&o, &res[n]);
            fflush(stdout);
        }
    rc = err.code != TS_OK;
    if (rc) fprintf(stderr, "bench_cache: %s\n", err.msg);
    if (!rc && o.json_path) rc = bench_json(&o, res, n, cl.info.name);
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < BENCH_CACHES; ++c)
            lru_free(&res[i].cache[c]);
    if (cl.context) dev_close(&cl);
    return rc || bad ? 1 : 0;
}
