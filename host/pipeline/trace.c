/* trace.c — the two-level loop of one wave (Hanika §3.1-3.2, DESIGN.md §1):
 *   while rays are active:
 *     top_level   -> up to N (leaf, window) candidates per active ray, N = capacity / R
 *     sort        -> candidates by leaf, segments [begin, end) per patch
 *     per batch of segments that fit the arenas: dice -> build -> bottom_level
 *     resolve     -> closest hit per ray; rays whose traversal is finished retire
 * Host stages (sort, the compaction in resolve) are timed on the monotonic clock; kernels by
 * their profiling events (dev_launch / dev_finish). */
#include "pipeline/pipeline.h"
#include "lib/quadtree.h"
#include "lib/trim.h"

#include <stdlib.h>

#include <string.h>

/* top_level over the active rays (n_per_ray 0: the water-filled windows of window_first;
 * count_only: count[i] only, up to n_per_ray candidates; top_level.cl): one launch, or, while
 * a cancel hook is set, runs of p->top_level_run rays with the hook asked between them
 * (p->cancelled set when it says stop: the rays after are not traversed). */
static int top_level_launch(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray,
                            uint32_t count_only, uint32_t stamp, ts_error *err)
{
    /* the stash is the water-filled windows' only (n_per_ray 0 when collecting) */
    uint32_t stash_n = count_only || n_per_ray == 0u ? p->stash_n : 0u;
    if (dev_set_args(p->k_top_level, err, DEV_ARG(p->qbvh_nodes), DEV_ARG(p->cull),
                     DEV_ARG(p->cull_levels), DEV_ARG(p->patch_box), DEV_ARG(p->active),
                     DEV_ARG(active_count), DEV_ARG(n_per_ray), DEV_ARG(p->window_first),
                     DEV_ARG(count_only), DEV_ARG(p->ray_org), DEV_ARG(p->ray_dir),
                     DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry), DEV_ARG(p->ray_flags),
                     DEV_ARG(p->ray_from), DEV_ARG(p->attr), DEV_ARG(p->unseen_flags),
                     DEV_ARG(p->pairs), DEV_ARG(p->count), DEV_ARG(p->leaving), DEV_ARG(stamp),
                     DEV_ARG(p->pairs_scratch), DEV_ARG(stash_n), (size_t)0))
        return err->code;
    /* One run goes on while the host waits for the one before it. */
    ts_dev_mark before = dev_mark(p->cl);
    uint32_t run = p->cancel && p->top_level_run ? p->top_level_run : active_count;
    for (uint32_t first = 0; first < active_count; first += run) {
        uint32_t n = active_count - first < run ? active_count - first : run;
        if (dev_launch_range(p->cl, p->k_top_level, TS_STAGE_top_level, first, n, TS_LOCAL_SIZE,
                             err) ||
            dev_wait_mark(p->cl, before, err))
            return err->code;
        before = dev_mark(p->cl);
        if (first + n < active_count && p->cancel(p->cancel_ctx)) {
            p->cancelled = 1;
            break;
        }
    }
    return dev_finish(p->cl, p->stats, err);
}

static int stage_top_level(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray,
                           uint32_t stamp, ts_error *err)
{
    return top_level_launch(p, active_count, n_per_ray, 0u, stamp, err);
}

/* Water-filled windows (top_level.cl), for a frame whose patches do not fit, where each
 * iteration dices its patches again: a counting launch finds each active ray's candidates
 * (up to max_n), and ray i gets min(count_i, N) slots of the pair buffer, N <= max_n the
 * largest for which they all fit (at least capacity / active, the uniform windows' N, when
 * that is below max_n). A uniform window of N leaves the slots of rays with fewer candidates
 * empty (about half of them on forest-100's bounces) while the rays with more wait for
 * another iteration that dices their patches again; here every ray with at most N
 * candidates is done in this one. forest-100 1920x768 x 2 at --memory 512, three pairs a
 * ray: 567 K dicings and 97 s against 633 K and 107 s with uniform windows (one run each;
 * docs/benchmarks.md has today's figures).
 * Writes window_first[0 .. active]; returns N through *n_fill and the slots through *slots. */
static int water_fill(ts_pipeline *p, uint32_t active, uint32_t max_n, uint32_t *n_fill,
                      uint32_t *slots, ts_error *err)
{
    uint32_t kmax = max_n < 1u ? 1u : max_n > TS_N_MAX ? TS_N_MAX : max_n;
    /* The counting launch keeps each ray's first stash_n candidates in pairs_scratch (two
     * uints an entry, unused until sort); a ray with at most that many, fewer than kmax,
     * ended its traversal there, and where its window holds them all (top_level.cl checks
     * count <= the window) the collecting launch copies them instead of traversing again.
     * forest-100 1920x768 x 2 at --memory 512: top_level 6.9 -> 4.5 s, the same pairs. */
    uint64_t stash = active ? 2u * (uint64_t)p->plan.pair_capacity / active : 0u;
    p->stash_n = (uint32_t)(stash < kmax - 1u ? stash : kmax - 1u);
    if (top_level_launch(p, active, kmax, 1u, 0u, err)) return err->code;
    if (p->cancelled) return TS_OK;
    double t0 = stats_now();
    size_t bytes = (size_t)active * sizeof(uint32_t);
    const uint32_t *c = dev_map(p->cl, p->count, CL_MAP_READ, 0, bytes, "the pair counts", err);
    uint32_t *first = c ? dev_map(p->cl, p->window_first, CL_MAP_WRITE_INVALIDATE_REGION, 0,
                                  bytes + sizeof(uint32_t), "the candidate windows", err)
                        : NULL;
    int rc = first ? TS_OK : err->code;
    if (rc == TS_OK) {
        uint64_t hist[TS_N_MAX + 1] = {0}, below = 0, at_least = active;
        for (uint32_t i = 0; i < active; ++i)
            hist[c[i] < TS_N_MAX ? c[i] : TS_N_MAX]++;
        /* sum over rays of min(count, n) = below + n * at_least, for n = 1, 2, ... */
        uint32_t n = 1;
        if (active - hist[0] > p->plan.pair_capacity)
            rc = ts_error_set(err, TS_E_INTERNAL, "water_fill: fewer pairs (%u) than rays (%u)",
                              p->plan.pair_capacity, active);
        for (uint32_t k = 1; k <= kmax; ++k) {
            below += (uint64_t)(k - 1u) * hist[k - 1u], at_least -= hist[k - 1u];
            if (below + (uint64_t)k * at_least > p->plan.pair_capacity) break;
            n = k;
        }
        uint32_t at = 0;
        for (uint32_t i = 0; rc == TS_OK && i < active; ++i)
            first[i] = at, at += c[i] < n ? c[i] : n;
        first[active] = at;
        *n_fill = n, *slots = at;
    }
    if (first && dev_unmap(p->cl, p->window_first, first, "the candidate windows", err))
        rc = err->code;
    if (c && dev_unmap(p->cl, p->count, (void *)c, "the pair counts", err)) rc = err->code;
    p->stats->stage_seconds[TS_STAGE_top_level] += stats_now() - t0;
    return rc;
}

/* Gives each segment its patch's LOD (pipeline_patch_lod). */
static void assign_lods(ts_pipeline *p, uint32_t segs)
{
    for (uint32_t i = 0; i < segs; ++i)
        p->segments_host[i].lod = pipeline_patch_lod(p, p->segments_host[i].patch);
}

/* Starts batch k at segment i (its trees from the list's current end). */
static ts_batch *batch_open(ts_pipeline *p, uint32_t i, uint32_t ntrees)
{
    ts_batch *b = &p->batches[p->batch_count++];
    *b = (ts_batch){i, 0, ntrees, 0, 0.0, 0, 0, 0};
    return b;
}

/* Whether tree `tree` of the list dices its vertices too (plan_batches's seg_grid: the cache
 * entry's `gridded` may be gone by then, a later batch of the iteration having evicted it). */
static int tree_gridded(const ts_pipeline *p, uint32_t tree)
{
    return p->seg_grid[TS_TREE_SEGMENT(tree)];
}

/* A tree's place in its batch's order: by decreasing m, and within one m those whose
 * vertices are diced first (tree_gridded). */
static uint32_t tree_key(const ts_pipeline *p, uint32_t tree)
{
    uint32_t m = p->segments_host[TS_TREE_SEGMENT(tree)].lod;
    return 2u * (TS_LOD_LIMIT - m) + (tree_gridded(p, tree) ? 0u : 1u);
}

/* Sorts batch b's trees by tree_key (a stable counting sort), so that the trees deeper than a
 * level are a prefix of the list (stage_build) and the trees of one m to dice a prefix of
 * theirs (stage_dice). Unsorted when out of memory: build_level then visits idle trees, and
 * dice dices every tree, both still correct. */
static void batch_sort_trees(ts_pipeline *p, ts_batch *b)
{
    enum { KEYS = 2 * (TS_LOD_LIMIT + 1) };
    uint32_t *list = &p->trees_host[b->tree_first], count[KEYS] = {0};
    uint32_t tmp[2 * 64],
        *scratch = b->tree_count <= 128 ? tmp : malloc(b->tree_count * sizeof *scratch);
    b->sorted = scratch != NULL;
    if (!scratch) return;
    for (uint32_t t = 0; t < b->tree_count; ++t)
        count[tree_key(p, list[t])]++;
    uint32_t start[KEYS], at = 0;
    for (int k = 0; k < KEYS; ++k)
        start[k] = at, at += count[k];
    for (uint32_t t = 0; t < b->tree_count; ++t)
        scratch[start[tree_key(p, list[t])]++] = list[t];
    memcpy(list, scratch, b->tree_count * sizeof *list);
    if (scratch != tmp) free(scratch);
}

/* The patch whose dicing segment s uses (its shape): an instance patch shares its master's
 * (scene.h instancing) when both are at the same m this frame (pipeline_lod_finish gives a
 * master and its instances one m; a fixed --lod gives every patch one), else it is diced
 * as itself, as a copy. Sets s->shape. */
static uint32_t segment_shape(const ts_pipeline *p, ts_segment *s)
{
    uint32_t q = scene_shape(p->scene, s->patch);
    if (q != s->patch && pipeline_patch_lod(p, q) != s->lod) q = s->patch;
    return s->shape = q;
}

/* Segment s's shape and flags as the dice, build and bottom_level kernels read them: moving
 * (a shape moves as its instances do), rough, trimmed, and in triangle mode the edges towards
 * coarser neighbours, which take their vertices (dice.cl). */
static void segment_prepare(const ts_pipeline *p, ts_segment *s)
{
    s->flags = p->scene->attr[s->patch].flags & TS_PATCH_MOVING;
    uint32_t q = segment_shape(p, s);
    if (s->lod >= p->rough_lod[q]) s->flags |= TS_PATCH_ROUGH;
    if (patch_has_holes(&p->scene->attr[q])) s->flags |= TS_SEG_TRIMMED;
    s->flags |= pipeline_stitch_edges(p, q, s->lod) << TS_SEG_EDGE_SHIFT;
}

/* The largest share of a tree's leaves a segment may ask for through its skeleton: each of
 * its pairs costs about one 4 x 4 block of leaves made in bottom_level (--leaf-size 4 on
 * forest-100 at --memory 192: 66 M micro-quads tested for 4.2 M pairs), the tree all of its
 * leaves, and a pair's block costs a little more than 16 leaves of build_leaves. So a segment
 * goes through its skeleton where pairs x TS_SKELETON_PAIR_LEAVES <= 4^m (env
 * TESSERA_SKELETON_PAIR_LEAVES, for measurements: 0 turns skeletons off). */
#define TS_SKELETON_PAIR_LEAVES 32u

static uint32_t skeleton_pair_leaves(void)
{
    const char *env = getenv("TESSERA_SKELETON_PAIR_LEAVES");
    if (!env || !*env) return TS_SKELETON_PAIR_LEAVES;
    char *end;
    unsigned long v = strtoul(env, &end, 10);
    return *end || v > (1ul << 24) ? TS_SKELETON_PAIR_LEAVES : (uint32_t)v;
}

/* Whether patch i's tree may keep a skeleton: static, noise-displaced or undisplaced
 * (bl_skeleton makes its leaves with block_leaf_boxes, and its vertices with patch_vertex_x8),
 * untrimmed, at m >= TS_SKELETON_MIN_LOD. */
static int skeleton_patch(const ts_pipeline *p, uint32_t i)
{
    const ts_patch_attr *a = &p->scene->attr[i];
    return pipeline_patch_lod(p, i) >= TS_SKELETON_MIN_LOD && !(a->flags & TS_PATCH_MOVING) &&
           (a->disp_kind == TS_DISP_FBM || a->disp_kind == TS_DISP_RIDGED ||
            a->disp_kind == TS_DISP_NONE) &&
           !patch_has_holes(a);
}

/* Whether this device and mode trace skeletons: a device built with the CPU lanes (bl_skeleton
 * makes its leaves in them), box mode with leaves of one micro-quad and the per-ray leaf kernel,
 * each device dicing for itself, textures resident. */
static int skeleton_mode(const ts_pipeline *p)
{
    return p->cl->cpu_lanes && !p->mode.exact && p->mode.leaf_b == 0 && !p->mode.leaf_group &&
           !p->share && !p->tex.paged && skeleton_pair_leaves() > 0;
}

uint64_t pipeline_skeleton_bytes(const ts_pipeline *p)
{
    uint64_t groups = 0;
    if (!skeleton_mode(p)) return 0;
    for (uint32_t i = 0; i < p->scene->patch_count; ++i)
        if (skeleton_patch(p, i)) groups += TS_SKELETON_GROUPS(pipeline_patch_lod(p, i));
    return groups * sizeof(ts_tight4);
}

/* Before a trace: whether its segments may go through skeletons (p->skel_on): in
 * skeleton_mode, when the frame's patches do not fit and the budget made room for them
 * (skel_room). Where they may, the room is laid out afresh for the frame's levels of detail:
 * no patch has a place yet; skeleton_lists gives each tree kept the next one, as long as the
 * room lasts. The skel buffer always exists (bottom_level binds it). */
static int skeleton_prepare(ts_pipeline *p, ts_error *err)
{
    uint32_t n = p->scene->patch_count;
    p->skel_on = skeleton_mode(p) && p->cache.short_of_room && p->skel_room > 0;
    uint64_t want = p->skel_on && !p->skel_planned /* laid out: the buffer holds it */
                        ? pipeline_skeleton_bytes(p) / sizeof(ts_tight4)
                        : 0u;
    uint64_t cap = p->skel_room / sizeof(ts_tight4); /* groups: up to 96 GB of skeletons */
    if (want > cap) want = cap;
    if (!p->skel || want > p->skel_groups) {
        uint64_t groups = want > p->skel_groups ? want : p->skel_groups;
        if (groups == 0) groups = 1;
        cl_mem m =
            dev_buffer_create(p->cl, CL_MEM_READ_WRITE, groups * sizeof(ts_tight4), NULL, err);
        if (!m) {
            if (!p->skel) return err->code;
            ts_error_clear(err); /* no room: the patches are diced as before */
            p->skel_on = 0;
            return TS_OK;
        }
        /* the first buffer's one entry beside the budget; the rest within skel_room */
        if (!p->skel) p->stats->counters[TS_COUNTER_device_bytes_fixed] += sizeof(ts_tight4);
        if (p->skel) dev_buffer_release(p->cl, p->skel);
        p->skel = m, p->skel_groups = groups;
        pipeline_note_device_bytes(p);
    }
    if (!p->skel_on || p->skel_planned) return TS_OK;
    for (uint32_t i = 0; i < n; ++i)
        p->skel_first_host[i] = TS_INVALID;
    memset(p->skel_key, 0, n);
    p->skel_used = 0, p->skel_cap = want;
    p->skel_planned = 1;
    return TS_OK;
}

/* Whether segment s's tree may keep its skeleton once built: its shape may (skeleton_patch:
 * static, noise-displaced or undisplaced, untrimmed, m >= TS_SKELETON_MIN_LOD at the shape's m,
 * which is the segment's; a place is given in skeleton_lists) and the segment does not move (an
 * instance may where its master does not). A rough tree's too: its tight boxes only cull the rays
 * that leave it, which bl_skeleton traces through the skeleton's boxes, which hold them. No
 * stitched edges: skeleton_mode is box mode. */
static int skeleton_tree(const ts_pipeline *p, const ts_segment *s)
{
    return !(s->flags & TS_PATCH_MOVING) && skeleton_patch(p, s->shape);
}

/* Lists after the batches' trees (from ntrees on) each batch's trees whose skeleton is to be
 * kept and is not yet (skel_key), in the batch's order (by decreasing m): a tree kept already
 * would be copied the same again. A tree's shape gets its place in skel the first time, the
 * next TS_SKELETON_GROUPS(m) groups while the room lasts (none after: not kept); the places
 * given are written to the device's skel_first. The tree list holds two entries a patch, and
 * a static patch's tree is listed at most twice. */
static int skeleton_lists(ts_pipeline *p, uint32_t ntrees, ts_error *err)
{
    uint32_t lo = UINT32_MAX, hi = 0; /* the places given, [lo, hi] */
    for (uint32_t k = 0; k < p->batch_count; ++k) {
        ts_batch *b = &p->batches[k];
        b->skel_tree_first = ntrees, b->skel_tree_count = 0;
        for (uint32_t t = 0; p->skel_on && t < b->tree_count; ++t) {
            uint32_t tree = p->trees_host[b->tree_first + t];
            const ts_segment *s = &p->segments_host[TS_TREE_SEGMENT(tree)];
            uint32_t q = s->shape;
            if (TS_TREE_TIME(tree) != 0u || !skeleton_tree(p, s) || p->skel_key[q] == s->lod)
                continue;
            if (p->skel_first_host[q] == TS_INVALID) {
                uint64_t groups = TS_SKELETON_GROUPS(s->lod);
                if (p->skel_used + groups > p->skel_cap) continue; /* the room is taken */
                p->skel_first_host[q] = (uint32_t)p->skel_used, p->skel_used += groups;
                lo = q < lo ? q : lo, hi = q > hi ? q : hi;
            }
            p->trees_host[ntrees++] = tree, b->skel_tree_count++;
        }
    }
    uint64_t *kept = &p->stats->counters[TS_COUNTER_skeleton_bytes];
    if (p->skel_used * sizeof(ts_tight4) > *kept) *kept = p->skel_used * sizeof(ts_tight4);
    if (lo > hi) return TS_OK;
    return dev_write(p->cl, p->skel_first, lo * sizeof(uint32_t), (hi - lo + 1u) * sizeof(uint32_t),
                     &p->skel_first_host[lo], "the skeletons' places", err);
}

/* Gives each segment (its LOD set) its place in the arenas through the patch cache and
 * cuts the segments into batches whose patches are resident together, walking the segments
 * forwards in one iteration and backwards in the next (p->sweep): when the frame's patches
 * do not fit, what the last walk left resident is what the next one meets first, so those
 * are hits before the misses evict them (Pharr et al. 1997 §5: geometry already in the cache
 * first; a walk in one direction only would evict each patch just before it is wanted,
 * which is least-recently-used caching's worst case). Batches are contiguous ranges of
 * segments either way, and the order batches run in changes no hit: a segment whose
 * patch is resident at its m is a hit (traced, not diced); a miss gets space (the cache
 * evicts unpinned patches, least recently used first) and its trees go on the batch's list
 * to be diced and built; when even evicting everything unpinned leaves no room, the batch
 * ends there. Batches run in order on the in-order queue, so a later batch may overwrite
 * space an earlier one used only after that one's bottom_level. Paged textures also end a
 * batch when its misses' tiles would not fit the pool together.
 * With `leaving` (top_level's marks, pipeline.h leave_stamp) a miss is diced whole only where
 * a ray of the iteration leaves its patch (leaving[patch] == stamp: bottom_level reads those
 * vertices, the origin-patch rule) or the patch is rough (build reads its vertices for the
 * tight boxes); the others are built without their vertices (seg_grid 0), which box mode's
 * other rays never read, and shade then evaluates their normals (pipeline_grid_publish). A
 * resident patch built so whose vertices a ray leaving it now needs is diced and built again
 * in its place, as a miss. What is decided is the shape's (the patch diced): its vertices are
 * diced when any segment of the iteration that shares it needs them (grid_mark, marked
 * before the walk), so that an instance and its master in one batch ask once. Without
 * `leaving`, every miss is diced whole. */
static int plan_batches(ts_pipeline *p, uint32_t segs, const uint32_t *leaving, uint32_t stamp,
                        ts_error *err)
{
    uint32_t tused = 0, ntrees = 0;
    uint64_t hits = 0, misses = 0, evicted = p->cache.evictions, examined = p->cache.examined;
    p->batch_count = 0;
    ts_batch *b = NULL;
    if (p->cache_off) patch_cache_clear(&p->cache);
    for (uint32_t i = 0; i < segs; ++i) { /* shapes and flags, and the shapes that need vertices */
        ts_segment *s = &p->segments_host[i];
        segment_prepare(p, s);
        if (leaving && ((s->flags & TS_PATCH_ROUGH) || leaving[s->patch] == stamp))
            p->grid_mark[s->shape] = stamp;
    }
    int backward = p->sweep++ & 1u;
    /* skeletons only where the vertices are marked (box mode, frame over the room) */
    uint32_t skel_leaves = p->skel_on && leaving ? skeleton_pair_leaves() : 0u, skeletons = 0;
    for (uint32_t j = 0; j < segs; ++j) {
        uint32_t i = backward ? segs - 1u - j : j;
        ts_segment *s = &p->segments_host[i];
        uint32_t q = s->shape, times = s->flags & TS_PATCH_MOVING ? 2u : 1u;
        /* Texture tiles: the batch's misses' needs add up to at most the pool (an over-count
         * where they share tiles; each alone fits, tex_cache_create sized the pool so). */
        uint32_t nt = p->tex.paged ? p->tex.patch_tiles[q] : 0u;
        if (b && tused + nt > p->tex.slots &&
            !(p->cache.entry[q].resident && p->cache.entry[q].lod == s->lod)) {
            patch_cache_end_batch(&p->cache);
            b = NULL;
        }
        if (!b) b = batch_open(p, i, ntrees), tused = 0;
        /* A patch that is not resident and has few pairs goes through its kept skeleton
         * (bottom_level makes the leaves its rays enter, and the vertices around the origins
         * of those that leave it) instead of a dicing. */
        if (skel_leaves && p->skel_key[q] == s->lod && skeleton_tree(p, s) &&
            (uint64_t)(s->end - s->begin) * skel_leaves <= (uint64_t)1 << (2u * s->lod) &&
            !(p->cache.entry[q].resident && p->cache.entry[q].lod == s->lod)) {
            s->flags |= TS_SEG_SKELETON;
            p->seg_grid[i] = 0;
            if (backward) b->seg_first = i;
            b->seg_count++;
            b->work += s->end - s->begin;
            ++skeletons;
            continue;
        }
        ts_cache_result r =
            patch_cache_acquire(&p->cache, q, s->lod, times, &s->vert_first, &s->group_first);
        if (r == TS_CACHE_FULL) { /* the batch is as full as it gets: start the next */
            patch_cache_end_batch(&p->cache);
            if (p->cache_off) patch_cache_clear(&p->cache);
            b = batch_open(p, i, ntrees), tused = 0;
            r = patch_cache_acquire(&p->cache, q, s->lod, times, &s->vert_first,
                                    &s->group_first); /* the plan holds any one patch */
        }
        if (backward) b->seg_first = i; /* the batch grows downwards */
        b->seg_count++;
        b->work += s->end - s->begin;
        ts_cache_entry *e = &p->cache.entry[q];
        int grid = !leaving || p->grid_mark[q] == stamp;
        p->seg_grid[i] = (uint8_t)grid;
        if (r == TS_CACHE_HIT && (!grid || e->gridded)) {
            ++hits;
            continue;
        }
        e->gridded = (uint8_t)grid;
        ++misses;
        tused += nt;
        for (uint32_t t = 0; t < times; ++t)
            p->trees_host[ntrees++] = (i << 1) | t, b->tree_count++;
        b->work += (double)times * (double)((uint64_t)1 << (2u * s->lod));
    }
    patch_cache_end_batch(&p->cache);
    for (uint32_t k = 0; k < p->batch_count; ++k)
        batch_sort_trees(p, &p->batches[k]);
    p->stats->counters[TS_COUNTER_skeleton_segments] += skeletons;
    p->stats->counters[TS_COUNTER_patch_cache_hits] += hits;
    p->stats->counters[TS_COUNTER_patch_cache_misses] += misses;
    p->stats->counters[TS_COUNTER_patch_cache_evictions] += p->cache.evictions - evicted;
    p->stats->counters[TS_COUNTER_patch_cache_examined] += p->cache.examined - examined;
    p->stats->counters[TS_COUNTER_batches] += p->batch_count;
    uint64_t *peak = &p->stats->counters[TS_COUNTER_patch_cache_peak_bytes];
    if (p->cache.peak_bytes > *peak) *peak = p->cache.peak_bytes;
    return skeleton_lists(p, ntrees, err);
}

/* Discrete devices: reads the windows' counts and the windows into host memory, sorts them
 * there and writes back only the valid pairs, sorted, into pairs: one window read and one
 * write of the valid part over the bus instead of reading and writing both mapped buffers
 * whole. */
static int sort_via_copy(ts_pipeline *p, uint32_t windows, uint32_t width, uint32_t *sorted_buffer,
                         uint32_t *valid, uint32_t *segs, ts_error *err)
{
    ts_pair *a = p->sort_host[0], *b = p->sort_host[1];
    uint32_t *counts = p->sort_counts;
    const ts_pair *sorted = NULL;
    if (width == 0) { /* dense: `windows` pairs (water-filled windows) */
        if (dev_read(p->cl, p->pairs, 0, (size_t)windows * sizeof(ts_pair), a,
                     "the candidate pairs", err) ||
            radix_sort_pairs(p->sorter, a, b, windows, p->scene->patch_count, &sorted, valid, err))
            return err->code;
    } else if (dev_read(p->cl, p->count, 0, (size_t)windows * sizeof *counts, counts,
                        "the pair counts", err) ||
               dev_read(p->cl, p->pairs, 0, (size_t)windows * width * sizeof(ts_pair), a,
                        "the candidate pairs", err) ||
               radix_sort_windows(p->sorter, a, b, counts, windows, width, p->scene->patch_count,
                                  &sorted, valid, err))
        return err->code;
    *segs = sort_segments(sorted, *valid, p->segments_host, p->scene->patch_count);
    if (*segs == UINT32_MAX)
        return ts_error_set(err, TS_E_INTERNAL, "sort: more segments than patches");
    *sorted_buffer = 0;
    return dev_write(p->cl, p->pairs, 0, (size_t)*valid * sizeof(ts_pair), sorted,
                     "the sorted pairs", err);
}

/* Sorts the candidate windows on the host through mapped buffers (zero copy on CPU
 * devices); only each window's first count[i] pairs are read. */
static int sort_mapped(ts_pipeline *p, uint32_t windows, uint32_t width, uint32_t *sorted_buffer,
                       uint32_t *valid, uint32_t *segment_count, ts_error *err)
{
    const cl_map_flags rw = CL_MAP_READ | CL_MAP_WRITE;
    size_t bytes = (size_t)windows * (width ? width : 1u) * sizeof(ts_pair);
    uint32_t *counts = width ? dev_map(p->cl, p->count, CL_MAP_READ, 0, windows * sizeof *counts,
                                       "the pair counts", err)
                             : NULL;
    ts_pair *a = counts || !width ? dev_map(p->cl, p->pairs, rw, 0, bytes ? bytes : 1,
                                            "the candidate pairs", err)
                                  : NULL;
    ts_pair *b = a ? dev_map(p->cl, p->pairs_scratch, rw, 0, bytes ? bytes : 1,
                             "the second pair buffer", err)
                   : NULL;
    const ts_pair *sorted = NULL;
    int rc = b ? TS_OK : err->code;
    if (rc == TS_OK && width == 0) /* dense: `windows` pairs (water-filled windows) */
        rc = radix_sort_pairs(p->sorter, a, b, windows, p->scene->patch_count, &sorted, valid, err);
    else if (rc == TS_OK)
        rc = radix_sort_windows(p->sorter, a, b, counts, windows, width, p->scene->patch_count,
                                &sorted, valid, err);
    uint32_t segs = 0;
    if (rc == TS_OK) {
        segs = sort_segments(sorted, *valid, p->segments_host, p->scene->patch_count);
        if (segs == UINT32_MAX)
            rc = ts_error_set(err, TS_E_INTERNAL, "sort: more segments than patches");
    }
    *sorted_buffer = sorted == b ? 1u : 0u;
    /* Every map is undone; err keeps the first failure. */
    if (counts && dev_unmap(p->cl, p->count, counts, "the pair counts", err)) rc = err->code;
    if (a && dev_unmap(p->cl, p->pairs, a, "the candidate pairs", err)) rc = err->code;
    if (b && dev_unmap(p->cl, p->pairs_scratch, b, "the second pair buffer", err)) rc = err->code;
    *segment_count = segs;
    return rc;
}

/* Writes the segment table (segs entries) and the batches' tree lists for the kernels. */
static int upload_batches(ts_pipeline *p, uint32_t segs, ts_error *err)
{
    if (segs == 0) return TS_OK;
    const ts_batch *last = &p->batches[p->batch_count - 1];
    /* the trees, then the skeletons' lists (skeleton_lists); 0 when every segment hit */
    uint32_t trees = last->tree_first + last->tree_count;
    if (last->skel_tree_first + last->skel_tree_count > trees)
        trees = last->skel_tree_first + last->skel_tree_count;
    if (dev_write(p->cl, p->segments, 0, segs * sizeof(ts_segment), p->segments_host,
                  "the segments", err) ||
        dev_write(p->cl, p->trees, 0, trees * sizeof(uint32_t), p->trees_host, "the tree lists",
                  err))
        return err->code;
    return TS_OK;
}

/* Sorts the candidate windows on the host (radix_sort.c), by mapping the buffers or, on
 * discrete devices, by copying (pipeline.h sort_host): `windows` windows of `width` pairs,
 * or with width 0 `windows` pairs one after the other (water_fill's windows). Sets *sorted_buffer
 * (which buffer holds the result: 0 pairs, 1 pairs_scratch), and the segment table; returns the
 * segment count through *segment_count. */
static int stage_sort(ts_pipeline *p, uint32_t windows, uint32_t width, uint32_t stamp,
                      uint32_t *sorted_buffer, uint32_t *valid, uint32_t *segment_count,
                      ts_error *err)
{
    double t0 = stats_now();
    uint32_t segs = 0;
    int rc = p->sort_host[0] ? sort_via_copy(p, windows, width, sorted_buffer, valid, &segs, err)
                             : sort_mapped(p, windows, width, sorted_buffer, valid, &segs, err);
    size_t bytes = (size_t)p->scene->patch_count * sizeof(uint32_t);
    const uint32_t *leaving =
        rc == TS_OK && stamp && bytes
            ? dev_map(p->cl, p->leaving, CL_MAP_READ, 0, bytes, "the leaving rays' patches", err)
            : NULL;
    if (rc == TS_OK && stamp && bytes && !leaving) rc = err->code;
    if (rc == TS_OK) {
        assign_lods(p, segs);
        rc = plan_batches(p, segs, leaving, stamp, err);
        if (rc == TS_OK) rc = upload_batches(p, segs, err);
    }
    if (leaving && dev_unmap(p->cl, p->leaving, (void *)leaving, "the leaving rays' patches", err))
        rc = err->code;
    *segment_count = segs;
    p->stats->stage_seconds[TS_STAGE_sort] += stats_now() - t0;
    return rc;
}

/* The LOD of tree t of batch b. */
static uint32_t tree_lod(const ts_pipeline *p, const ts_batch *b, uint32_t t)
{
    return p->segments_host[TS_TREE_SEGMENT(p->trees_host[b->tree_first + t])].lod;
}

/* How many trees from t on share tree t's LOD (*m): one launch of dice or build_leaves
 * each (trees are listed by decreasing m). */
static uint32_t tree_run(const ts_pipeline *p, const ts_batch *b, uint32_t t, uint32_t *m)
{
    uint32_t run = 0;
    *m = tree_lod(p, b, t);
    while (t + run < b->tree_count && tree_lod(p, b, t + run) == *m)
        ++run;
    return run;
}

/* Of the run of trees [t, t + run) of one m, how many dice their vertices: a prefix of the
 * run (batch_sort_trees), or all of it when the batch is not sorted. */
static uint32_t tree_run_gridded(const ts_pipeline *p, const ts_batch *b, uint32_t t, uint32_t run)
{
    if (!b->sorted) return run;
    uint32_t g = 0;
    while (g < run && tree_gridded(p, p->trees_host[b->tree_first + t + g]))
        ++g;
    return g;
}

/* Makes the texture tiles the batch's dice and build read resident (tex_cache.h). */
static int batch_textures(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (!p->tex.paged) return TS_OK;
    tex_cache_begin(&p->tex);
    for (uint32_t t = 0; t < b->tree_count; ++t) /* the patches diced: the misses */
        tex_cache_mark_patch(
            &p->tex, p->scene,
            p->segments_host[TS_TREE_SEGMENT(p->trees_host[b->tree_first + t])].shape);
    return tex_cache_commit(&p->tex, p->cl, p->tex_pool, p->tex_pages, p->scene, p->stats, err);
}

/* Dices the trees of each LOD that need their vertices (the first of the LOD's run,
 * tree_run_gridded) with one launch; counts every tree of the batch as a patch diced. */
static int stage_dice(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (batch_textures(p, b, err)) return err->code;
    for (uint32_t t = 0; t < b->tree_count;) {
        uint32_t m, all = tree_run(p, b, t, &m), run = tree_run_gridded(p, b, t, all);
        uint32_t first = b->tree_first + t;
        t += all;
        if (run == 0) continue;
        if (dev_set_args(p->k_dice, err, DEV_ARG(p->trees), DEV_ARG(first), DEV_ARG(run),
                         DEV_ARG(m), DEV_ARG(p->segments), DEV_ARG(p->cp), DEV_ARG(p->cp1),
                         DEV_ARG(p->corner_n), DEV_ARG(p->mid_n), DEV_ARG(p->attr),
                         DEV_ARG(p->xform), DEV_ARG(p->textures), DEV_ARG(p->tex_pages),
                         DEV_ARG(p->tex_pool), DEV_ARG(p->grid), (size_t)0) ||
            dev_launch(p->cl, p->k_dice, TS_STAGE_dice,
                       (size_t)run *
                           ((quadtree_vertex_count(m) + TS_DICE_VERTICES - 1u) / TS_DICE_VERTICES),
                       TS_LOCAL_SIZE, err))
            return err->code;
    }
    for (uint32_t t = 0; t < b->tree_count; ++t) {
        uint32_t tree = p->trees_host[b->tree_first + t], lod = tree_lod(p, b, t);
        if (TS_TREE_TIME(tree) != 0u) continue; /* one dicing per patch, not per time */
        p->stats->counters[TS_COUNTER_patches_diced] += 1;
        if (b->sorted && !tree_gridded(p, tree)) p->stats->counters[TS_COUNTER_grids_skipped] += 1;
        p->stats->counters[TS_COUNTER_micropolygons_created] += 1ull << (2u * lod);
        p->stats->lod_histogram[lod] += 1;
    }
    return TS_OK;
}

/* What an entry of cull holds: levels 1 and 2 of a tree of depth m traced in blocks of
 * 2^leaf_b x 2^leaf_b (0: nothing). */
static uint16_t cull_key(uint32_t m, uint32_t leaf_b)
{
    return (uint16_t)(0x8000u | (leaf_b << 8) | m);
}

/* Copies levels 1 and 2 of the batch's static trees into cull for top_level (build.cl
 * build_cull), and notes what each entry was built for. */
static int stage_build_cull(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (b->tree_count == 0) return TS_OK;
    uint32_t leaf_b = p->mode.leaf_b;
    if (dev_set_args(p->k_build_cull, err, DEV_ARG(p->trees), DEV_ARG(b->tree_first),
                     DEV_ARG(b->tree_count), DEV_ARG(leaf_b), DEV_ARG(p->segments),
                     DEV_ARG(p->groups), DEV_ARG(p->patch_box), DEV_ARG(p->cull),
                     DEV_ARG(p->cull_levels), (size_t)0) ||
        dev_launch(p->cl, p->k_build_cull, TS_STAGE_build, (size_t)b->tree_count * TS_CULL_GROUPS,
                   TS_LOCAL_SIZE, err))
        return err->code;
    for (uint32_t t = 0; t < b->tree_count; ++t) {
        const ts_segment *s = &p->segments_host[TS_TREE_SEGMENT(p->trees_host[b->tree_first + t])];
        if (!(s->flags & TS_PATCH_MOVING)) p->cull_key[s->shape] = cull_key(s->lod, leaf_b);
    }
    return TS_OK;
}

/* Before a trace: an entry of cull built for another m or leaf size than the patch has now
 * (the lod stage, bake or a test changed them) is switched off until the patch is built
 * again; a stale entry could cull candidates that hit. */
static int cull_reset_stale(ts_pipeline *p, ts_error *err)
{
    const cl_uint off = 0;
    for (uint32_t i = 0; i < p->scene->patch_count; ++i) {
        if (!p->cull_key[i] || p->cull_key[i] == cull_key(pipeline_patch_lod(p, i), p->mode.leaf_b))
            continue;
        if (dev_write(p->cl, p->cull_levels, i * sizeof off, sizeof off, &off, "the culling levels",
                      err))
            return err->code;
        p->cull_key[i] = 0;
    }
    return TS_OK;
}

/* Work-items of build_leaves a tree at level m: TS_BUILD_LEAF_RUN leaves each on a device
 * built with the CPU lanes, else one (build.cl BUILD_LEAF_RUN). */
static size_t build_leaf_items(const ts_pipeline *p, uint32_t m)
{
    size_t leaves = (size_t)1 << (2u * m), run = p->cl->cpu_lanes ? TS_BUILD_LEAF_RUN : 1u;
    return leaves < run ? 1 : leaves / run;
}

/* Keeps the skeletons of the batch's list of trees to keep (skeleton_lists; build.cl
 * build_skeleton, one launch per m), and notes their m. */
static int stage_build_skeleton(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (!p->skel_on) return TS_OK;
    ts_batch list = *b; /* tree_run over the batch's skeleton list */
    list.tree_first = b->skel_tree_first, list.tree_count = b->skel_tree_count;
    for (uint32_t t = 0; t < list.tree_count;) {
        uint32_t m, run = tree_run(p, &list, t, &m), first = list.tree_first + t;
        t += run;
        if (dev_set_args(p->k_build_skeleton, err, DEV_ARG(p->trees), DEV_ARG(first), DEV_ARG(run),
                         DEV_ARG(m), DEV_ARG(p->segments), DEV_ARG(p->groups),
                         DEV_ARG(p->patch_box), DEV_ARG(p->skel), DEV_ARG(p->skel_first),
                         (size_t)0) ||
            dev_launch(p->cl, p->k_build_skeleton, TS_STAGE_build,
                       (size_t)run * TS_SKELETON_GROUPS(m), TS_LOCAL_SIZE, err))
            return err->code;
        for (uint32_t k = first; k < first + run; ++k)
            p->skel_key[p->segments_host[TS_TREE_SEGMENT(p->trees_host[k])].shape] = (uint8_t)m;
    }
    return TS_OK;
}

/* Leaves per LOD run, then one launch per level over the trees deeper than it, then the
 * culling copy. On a device built with the CPU lanes build_leaves also makes each tree's level
 * m - 1 (build.cl build_parents), so build_level starts a level higher for every tree. */
static int stage_build(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    uint32_t top = 0;
    cl_uint tight = p->mode.exact && p->mode.tight ? 1u : 0u;
    for (uint32_t t = 0; t < b->tree_count;) {
        uint32_t m, run = tree_run(p, b, t, &m);
        if (t == 0) top = m;
        uint32_t first = b->tree_first + t;
        if (dev_set_args(p->k_build_leaves, err, DEV_ARG(p->trees), DEV_ARG(first), DEV_ARG(run),
                         DEV_ARG(m), DEV_ARG(p->segments), DEV_ARG(p->cp), DEV_ARG(p->cp1),
                         DEV_ARG(p->grid), DEV_ARG(p->corner_n), DEV_ARG(p->mid_n),
                         DEV_ARG(p->attr), DEV_ARG(p->xform), DEV_ARG(p->flatness),
                         DEV_ARG(p->patch_box), DEV_ARG(p->textures), DEV_ARG(p->tex_pages),
                         DEV_ARG(p->tex_pool), DEV_ARG(p->trim_seg), DEV_ARG(tight),
                         DEV_ARG(p->groups), DEV_ARG(p->tight), (size_t)0) ||
            dev_launch(p->cl, p->k_build_leaves, TS_STAGE_build,
                       (size_t)run * build_leaf_items(p, m), TS_LOCAL_SIZE, err))
            return err->code;
        t += run;
    }
    uint32_t made = p->cl->cpu_lanes ? 1u : 0u; /* levels below m build_leaves made */
    for (uint32_t level = top; level-- > 0;) {
        uint32_t deeper = 0; /* trees with m > level + made: a prefix of the list */
        while (deeper < b->tree_count && tree_lod(p, b, deeper) > level + made)
            ++deeper;
        if (deeper == 0) continue;
        if (dev_set_args(p->k_build_level, err, DEV_ARG(p->trees), DEV_ARG(b->tree_first),
                         DEV_ARG(deeper), DEV_ARG(level), DEV_ARG(tight), DEV_ARG(p->segments),
                         DEV_ARG(p->groups), DEV_ARG(p->tight), (size_t)0) ||
            dev_launch(p->cl, p->k_build_level, TS_STAGE_build, (size_t)deeper << (2u * level),
                       TS_LOCAL_SIZE, err))
            return err->code;
    }
    if (stage_build_skeleton(p, b, err)) return err->code;
    return stage_build_cull(p, b, err);
}

/* ---- dice and build with patches shared between devices (patch_share.h) --------------- */

/* Moves the trees of [first, first + count) of the list whose segment's kind (kind[segment -
 * seg_first]) is in `front` before the others, both parts in their order (so each stays
 * sorted by decreasing m); returns the front's size. tmp holds count entries. */
static uint32_t trees_partition(ts_pipeline *p, const ts_batch *b, uint32_t first, uint32_t count,
                                const uint8_t *kind, unsigned front, uint32_t *tmp)
{
    uint32_t *list = &p->trees_host[first], n = 0, back = 0;
    for (uint32_t t = 0; t < count; ++t)
        if (front >> kind[TS_TREE_SEGMENT(list[t]) - b->seg_first] & 1u)
            list[n++] = list[t];
        else
            tmp[back++] = list[t];
    memcpy(list + n, tmp, back * sizeof *list);
    return n;
}

/* Dices and builds the trees [first, first + count) of batch b's list, after writing that
 * range of the list to the device again (trees_partition reordered it). */
static int trees_make(ts_pipeline *p, const ts_batch *b, uint32_t first, uint32_t count,
                      ts_error *err)
{
    if (count == 0) return TS_OK;
    ts_batch view = *b;
    view.tree_first = first, view.tree_count = count;
    if (dev_write(p->cl, p->trees, first * sizeof(uint32_t), count * sizeof(uint32_t),
                  &p->trees_host[first], "the tree lists", err) ||
        stage_dice(p, &view, err) || stage_build(p, &view, err))
        return err->code;
    return TS_OK;
}

/* Copies segment i's blocks between the arenas and host memory at data (vertices, then
 * sibling groups, then their tight codes): to the host (read) or from it. Not blocking (dev_finish
 * completes it). */
static int segment_blocks(ts_pipeline *p, uint32_t i, void *data, int read, ts_error *err)
{
    const ts_segment *s = &p->segments_host[i];
    uint32_t times = s->flags & TS_PATCH_MOVING ? 2u : 1u;
    size_t vb = (size_t)patch_cache_vert_count(s->lod, times) * sizeof(ts_vec4);
    size_t ng = patch_cache_group_count(s->lod, times);
    size_t gb = ng * sizeof(ts_box4), cb = ng * sizeof(ts_tight4);
    size_t vo = (size_t)s->vert_first * sizeof(ts_vec4),
           go = (size_t)s->group_first * sizeof(ts_box4),
           co = (size_t)s->group_first * sizeof(ts_tight4);
    char *d = data;
    if (read)
        return dev_read_async(p->cl, p->grid, vo, vb, d, "a patch's grid", err) ||
                       dev_read_async(p->cl, p->groups, go, gb, d + vb, "a patch's tree", err) ||
                       dev_read_async(p->cl, p->tight, co, cb, d + vb + gb, "a patch's tight codes",
                                      err)
                   ? err->code
                   : TS_OK;
    return dev_write_async(p->cl, p->grid, vo, vb, d, "a shared patch's grid", err) ||
                   dev_write_async(p->cl, p->groups, go, gb, d + vb, "a shared patch's tree",
                                   err) ||
                   dev_write_async(p->cl, p->tight, co, cb, d + vb + gb,
                                   "a shared patch's tight codes", err)
               ? err->code
               : TS_OK;
}

/* Kinds of a batch's misses besides ts_share_take's: not looked up yet, and diced here in an
 * earlier round (published when it was a claim). */
enum { SHARE_OPEN = 4, SHARE_DONE = 5 };

/* One round of batch_make_shared: claims open misses, in the list's order, until the claims
 * reach 1/devices of the open misses' bytes (at least one), so that devices meeting the same
 * patches at once split them; dices and builds this round's claims and the misses the store
 * has no room for (trees [*done, ...) reordered, *done advanced past them), reads the claims'
 * blocks back and publishes them, or abandons them on an error. */
static int share_round(ts_pipeline *p, const ts_batch *b, uint8_t *kind, void **data, uint32_t *tmp,
                       uint32_t *done, ts_error *err)
{
    const unsigned dice = 1u << TS_TAKE_MINE | 1u << TS_TAKE_LOCAL;
    uint32_t *list = p->trees_host, end = b->tree_first + b->tree_count, mine = 0;
    uint64_t open = 0, claimed = 0;
    for (uint32_t t = *done; t < end; ++t) {
        const ts_segment *s = &p->segments_host[TS_TREE_SEGMENT(list[t])];
        if (TS_TREE_TIME(list[t]) == 0u &&
            kind[TS_TREE_SEGMENT(list[t]) - b->seg_first] == SHARE_OPEN)
            open += patch_share_bytes(s->lod, s->flags & TS_PATCH_MOVING ? 2u : 1u);
    }
    for (uint32_t t = *done; t < end && claimed * p->share->devices < open; ++t) {
        uint32_t i = TS_TREE_SEGMENT(list[t]), k = i - b->seg_first;
        const ts_segment *s = &p->segments_host[i];
        if (TS_TREE_TIME(list[t]) != 0u || kind[k] != SHARE_OPEN) continue;
        uint32_t times = s->flags & TS_PATCH_MOVING ? 2u : 1u;
        uint64_t bytes = patch_share_bytes(s->lod, times);
        kind[k] = (uint8_t)patch_share_take(p->share, s->shape, s->lod, times, bytes,
                                            p->share_owner, &data[k]);
        if (kind[k] == TS_TAKE_MINE) claimed += bytes, ++mine;
    }
    uint32_t n = trees_partition(p, b, *done, end - *done, kind, dice, tmp);
    int rc = trees_make(p, b, *done, n, err);
    for (uint32_t t = *done; !rc && mine && !p->share->in_place && t < *done + n;
         ++t) { /* the claims' blocks, copied into the store (in place: they are there) */
        uint32_t i = TS_TREE_SEGMENT(list[t]);
        if (TS_TREE_TIME(list[t]) == 0u && kind[i - b->seg_first] == TS_TAKE_MINE)
            rc = segment_blocks(p, i, data[i - b->seg_first], 1, err);
    }
    if (!rc && mine) rc = dev_finish(p->cl, p->stats, err);
    for (uint32_t t = *done; t < *done + n; ++t) {
        uint32_t i = TS_TREE_SEGMENT(list[t]), k = i - b->seg_first;
        if (TS_TREE_TIME(list[t]) == 0u && kind[k] == TS_TAKE_MINE) {
            if (rc)
                patch_share_abandon(p->share, p->segments_host[i].shape);
            else
                patch_share_publish(p->share, p->segments_host[i].shape);
        }
        if (TS_TREE_TIME(list[t]) == 0u) kind[k] = SHARE_DONE;
    }
    *done += n;
    return rc;
}

/* A patch of m <= TS_SHARE_DICE_OWN_LOD (at most 4,096 micro-quads) that another device
 * claimed but has not published yet is diced here instead of waited for: two one-thread
 * devices on forest-1 1920x768x4 (1,178 patches, m 0-7) waited 0.6 s of a 6.3 s frame for
 * such claims; dicing them again cost 3.5% more dicings and made the frame 5% shorter.
 * Larger patches are worth the wait (teapot_displaced, m 6-8: dicing them all again cost
 * 4% more CPU and saved nothing). docs/benchmarks.md "Not waiting for small patches".
 * With shared arenas (patch_share_in_place) the patch is diced again at its one place, where
 * the claimant writes it too: the same bytes (the devices compute alike, and dice and build
 * store each entry's final value once, with no read-modify-write), so whoever reads the patch
 * after either dicing ends sees those bytes whichever write lands last. Waiting instead
 * (TESSERA_SHARE_WAIT=1) made forest-1 on two devices 2.83 s instead of 2.69 s. */
#define TS_SHARE_DICE_OWN_LOD 6u

/* Whether to take patch `shape` (m = lod) claimed by another device: 1 with *got once it is
 * published (waiting for it when it is large), 0 to dice it here (small and not ready yet,
 * or abandoned). TESSERA_SHARE_WAIT=1 waits for every claim (exact dice-once counts). */
static int share_await(ts_pipeline *p, uint32_t shape, uint32_t lod, const void **got)
{
    static _Atomic int wait_all = -1; /* read once: the environment does not change mid-frame */
    if (wait_all < 0) {
        const char *e = getenv("TESSERA_SHARE_WAIT");
        wait_all = e && strcmp(e, "1") == 0;
    }
    int st = patch_share_poll(p->share, shape, got);
    if (st >= 0) return st;
    if (!wait_all && lod <= TS_SHARE_DICE_OWN_LOD) return 0;
    return patch_share_wait(p->share, shape, got);
}

/* Batch b's misses through the store: each is taken from it (published by another device),
 * waited for (claimed by another; or diced here when small, share_await), or diced and built here
 * (claimed here in one of the rounds, then published; or, without room in the store, kept here
 * alone). Every claim is published, or abandoned on an error, before the first wait (patch_share.h:
 * no deadlock). kind and data: one entry per segment of b; tmp: tree_count entries. */
static int batch_make_shared(ts_pipeline *p, const ts_batch *b, uint8_t *kind, void **data,
                             uint32_t *tmp, ts_error *err)
{
    const unsigned dice = 1u << TS_TAKE_MINE | 1u << TS_TAKE_LOCAL;
    uint32_t *list = p->trees_host, end = b->tree_first + b->tree_count, done = b->tree_first;
    uint32_t shared = 0;
    memset(kind, SHARE_OPEN, b->seg_count);
    int rc = TS_OK, open = 1;
    while (!rc && open) {
        rc = share_round(p, b, kind, data, tmp, &done, err);
        open = 0;
        for (uint32_t t = done; t < end && !open; ++t)
            open = kind[TS_TREE_SEGMENT(list[t]) - b->seg_first] == SHARE_OPEN;
    }
    for (uint32_t t = done; !rc && t < end; ++t) { /* the others' blocks */
        uint32_t i = TS_TREE_SEGMENT(list[t]), k = i - b->seg_first;
        if (TS_TREE_TIME(list[t]) != 0u) continue;
        const void *got = data[k];
        double t0 = stats_now();
        int ready = kind[k] != TS_TAKE_WAIT ||
                    share_await(p, p->segments_host[i].shape, p->segments_host[i].lod, &got);
        p->share_wait_seconds += stats_now() - t0;
        if (!ready) {
            kind[k] = TS_TAKE_LOCAL; /* small, or abandoned by a failed device: diced here */
            continue;
        }
        if (!p->share->in_place) rc = segment_blocks(p, i, (void *)got, 0, err);
        ++shared;
    }
    if (!rc)
        rc = trees_make(p, b, done, trees_partition(p, b, done, end - done, kind, dice, tmp), err);
    p->stats->counters[TS_COUNTER_patches_shared] += shared;
    return rc;
}

/* dice then build for batch b's misses: on this device alone, or through the store when it
 * shares patches with others. */
static int batch_make(ts_pipeline *p, const ts_batch *b, ts_error *err)
{
    if (!p->share || b->tree_count == 0)
        return stage_dice(p, b, err) || stage_build(p, b, err) ? err->code : TS_OK;
    uint8_t *kind = calloc(b->seg_count, 1);
    void **data = calloc(b->seg_count, sizeof *data);
    uint32_t *tmp = malloc(b->tree_count * sizeof *tmp);
    int rc = kind && data && tmp
                 ? batch_make_shared(p, b, kind, data, tmp, err)
                 : ts_error_set(err, TS_E_MEMORY, "out of memory (a batch's shares)");
    /* The culling copy of every tree of the batch, those from the store included: the list
     * is written whole again first (batch_make_shared reordered parts of it). */
    if (!rc && (dev_write(p->cl, p->trees, (size_t)b->tree_first * sizeof(uint32_t),
                          (size_t)b->tree_count * sizeof(uint32_t), &p->trees_host[b->tree_first],
                          "the tree lists", err) ||
                stage_build_cull(p, b, err)))
        rc = err->code;
    free(kind), free(data), free(tmp);
    return rc;
}

/* Adds the leaf counters of the work-groups since the last fold (entries [0, util_used) of
 * `utilisation`: micro-quad tests, and work-item slots in units of TS_GROUP_SIZE) to the
 * stats and zeroes them. Reading waits for the launches that wrote them. */
static int fold_utilisation(ts_pipeline *p, ts_error *err)
{
    if (p->util_used == 0) return TS_OK;
    size_t bytes = (size_t)p->util_used * 2u * sizeof(cl_uint);
    cl_uint *u = dev_map(p->cl, p->utilisation, CL_MAP_READ, 0, bytes, "the leaf utilisation", err);
    if (!u) return err->code;
    uint64_t tests = 0, slots = 0;
    for (uint32_t g = 0; g < p->util_used; ++g)
        tests += u[2u * g], slots += u[2u * g + 1u];
    const cl_uint zero = 0;
    if (dev_unmap(p->cl, p->utilisation, u, "the leaf utilisation", err) ||
        dev_fill(p->cl, p->utilisation, &zero, sizeof zero, 0, bytes, "the leaf utilisation", err))
        return err->code;
    p->stats->counters[TS_COUNTER_leaf_tests] += tests;
    p->stats->counters[TS_COUNTER_leaf_slots] += slots * TS_GROUP_SIZE;
    p->util_used = 0;
    return TS_OK;
}

/* One bottom_level launch over pairs [pair_first, pair_first + pair_count) of the batch;
 * each work-group counts its leaf tests in its own entry of `utilisation`. */
static int bottom_level_launch(ts_pipeline *p, cl_mem pairs, const ts_batch *b, uint32_t pair_first,
                               uint32_t pair_count, uint32_t n_per_ray, uint32_t active_count,
                               ts_error *err)
{
    uint32_t first = b->seg_first, count = b->seg_count, exact = p->mode.exact ? 1u : 0u;
    uint32_t leaf_b = p->mode.leaf_b;
    cl_kernel k = p->mode.leaf_group ? p->k_bottom_group : p->k_bottom_level;
    uint32_t groups = (pair_count + TS_GROUP_SIZE - 1u) / TS_GROUP_SIZE;
    if (p->util_used + groups > p->util_groups && fold_utilisation(p, err)) return err->code;
    uint32_t group_base = p->util_used;
    p->util_used += groups;
    if (dev_set_args(k, err, DEV_ARG(pairs), DEV_ARG(pair_first), DEV_ARG(pair_count),
                     DEV_ARG(p->segments), DEV_ARG(first), DEV_ARG(count), DEV_ARG(n_per_ray),
                     DEV_ARG(p->window_first), DEV_ARG(active_count), DEV_ARG(exact),
                     DEV_ARG(leaf_b), DEV_ARG(p->active), DEV_ARG(p->ray_org), DEV_ARG(p->ray_dir),
                     DEV_ARG(p->ray_hit), DEV_ARG(p->ray_flags), DEV_ARG(p->ray_from),
                     DEV_ARG(p->grid), DEV_ARG(p->groups), DEV_ARG(p->tight), DEV_ARG(p->instance),
                     DEV_ARG(p->inst_xform), DEV_ARG(p->pair_hit), DEV_ARG(p->utilisation),
                     DEV_ARG(group_base), DEV_ARG(p->skel), DEV_ARG(p->skel_first), DEV_ARG(p->cp),
                     DEV_ARG(p->corner_n), DEV_ARG(p->mid_n), DEV_ARG(p->attr), DEV_ARG(p->xform),
                     DEV_ARG(p->flatness), DEV_ARG(p->patch_box), (size_t)0))
        return err->code;
    return dev_launch(p->cl, k, TS_STAGE_bottom_level, pair_count, TS_LOCAL_SIZE, err);
}

/* bottom_level over the batch's pairs: in launches of at most util_groups work-groups (the
 * counters' buffer keeps its size when the waves grow, pipeline_resize_rays), cut at whole
 * work-groups from the batch's first pair, so that every work-group holds the pairs it would
 * in one launch (bottom_level_group shares leaves within one). */
static int stage_bottom_level(ts_pipeline *p, uint32_t sorted_buffer, const ts_batch *b,
                              uint32_t n_per_ray, uint32_t active_count, ts_error *err)
{
    const ts_segment *s = p->segments_host;
    uint32_t pair_first = s[b->seg_first].begin;
    uint32_t pair_count = s[b->seg_first + b->seg_count - 1].end - pair_first;
    cl_mem pairs = sorted_buffer ? p->pairs_scratch : p->pairs;
    uint32_t most = p->util_groups * TS_GROUP_SIZE;
    for (uint32_t done = 0; done < pair_count; done += most) {
        uint32_t n = pair_count - done < most ? pair_count - done : most;
        if (bottom_level_launch(p, pairs, b, pair_first + done, n, n_per_ray, active_count, err))
            return err->code;
    }
    return TS_OK;
}

/* Keeps the rays of active[0..active_count) whose alive flag is set, in order; returns
 * their count through *still_active. */
static int compact_active(ts_pipeline *p, uint32_t active_count, uint32_t *still_active,
                          ts_error *err)
{
    size_t bytes = (size_t)active_count * sizeof(uint32_t);
    uint32_t *act =
        dev_map(p->cl, p->active, CL_MAP_READ | CL_MAP_WRITE, 0, bytes, "the active rays", err);
    uint32_t *alive =
        act ? dev_map(p->cl, p->alive, CL_MAP_READ, 0, bytes, "the alive flags", err) : NULL;
    int rc = alive ? TS_OK : err->code;
    uint32_t n = 0;
    for (uint32_t i = 0; rc == TS_OK && i < active_count; ++i)
        if (alive[i]) act[n++] = act[i];
    /* Every map is undone; err keeps the first failure. */
    if (act && dev_unmap(p->cl, p->active, act, "the active rays", err)) rc = err->code;
    if (alive && dev_unmap(p->cl, p->alive, alive, "the alive flags", err)) rc = err->code;
    *still_active = n;
    return rc;
}

/* Folds candidate hits into each ray's closest hit, then compacts the active list on the
 * host (kept in order, so results never depend on timing). Returns the new active count. */
static int stage_resolve(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray,
                         uint32_t *still_active, ts_error *err)
{
    if (dev_set_args(p->k_resolve, err, DEV_ARG(p->active), DEV_ARG(active_count),
                     DEV_ARG(n_per_ray), DEV_ARG(p->window_first), DEV_ARG(p->count),
                     DEV_ARG(p->pair_hit), DEV_ARG(p->ray_hit), DEV_ARG(p->ray_entry),
                     DEV_ARG(p->ray_flags), DEV_ARG(p->alive), (size_t)0) ||
        dev_launch(p->cl, p->k_resolve, TS_STAGE_resolve, active_count, TS_LOCAL_SIZE, err) ||
        dev_finish(p->cl, p->stats, err))
        return err->code;
    double t0 = stats_now();
    int rc = compact_active(p, active_count, still_active, err);
    /* Leaf utilisation of this iteration's bottom_level launches. */
    if (rc == TS_OK && fold_utilisation(p, err)) rc = err->code;
    p->stats->stage_seconds[TS_STAGE_resolve] += stats_now() - t0;
    return rc;
}

int pipeline_top_level(ts_pipeline *p, uint32_t active_count, uint32_t n_per_ray, ts_error *err)
{
    return stage_top_level(p, active_count, n_per_ray, 0u, err);
}

int pipeline_water_fill(ts_pipeline *p, uint32_t active_count, uint32_t max_n, uint32_t *n_fill,
                        uint32_t *slots, ts_error *err)
{
    return water_fill(p, active_count, max_n, n_fill, slots, err);
}

int pipeline_dice_build(ts_pipeline *p, uint32_t count, ts_error *err)
{
    if (pipeline_stitch_prepare(p, err)) return err->code;
    uint64_t need[TS_CACHE_CLASSES] = {0}; /* quotas for these segments' levels */
    for (uint32_t i = 0; i < count; ++i) {
        const ts_segment *s = &p->segments_host[i];
        need[TS_CACHE_CLASS(s->lod, p->scene->attr[s->patch].flags & TS_PATCH_MOVING ? 2u : 1u)]++;
    }
    patch_cache_plan(&p->cache, need);
    p->cache_planned = 0;         /* the next trace plans for the frame's levels again */
    patch_cache_clear(&p->cache); /* dice every segment, whatever was resident */
    if (plan_batches(p, count, NULL, 0u, err)) /* the caller set each segment's LOD */
        return err->code;
    if (p->batch_count != 1)
        return ts_error_set(err, TS_E_INTERNAL,
                            "pipeline_dice_build: the segments do not fit one batch");
    if (upload_batches(p, count, err) || stage_dice(p, &p->batches[0], err) ||
        stage_build(p, &p->batches[0], err))
        return err->code;
    return dev_finish(p->cl, p->stats, err);
}

int pipeline_bottom_level(ts_pipeline *p, uint32_t n_per_ray, ts_error *err)
{
    if (p->batch_count != 1)
        return ts_error_set(err, TS_E_INTERNAL, "pipeline_bottom_level: no single batch diced");
    if (stage_bottom_level(p, 0u, &p->batches[0], n_per_ray, 0u, err)) return err->code;
    return dev_finish(p->cl, p->stats, err);
}

/* N per ray for R active rays at iteration it: capacity / R, clipped to [1, 100] (Hanika §3.1,
 * Table 3), and at most first_n * 2^it (first_n 0: 1). Hanika fills the pair buffer so that
 * each patch is diced once per iteration for as many rays as possible; with the patch cache a
 * patch is diced once per frame whatever N is, so what a large N still buys is fewer
 * iterations, and what it costs is pairs behind the ray's closest hit: a ray's candidates
 * come front to back, and the later ones of one iteration are traced without the tmax the
 * earlier ones find. Starting at one candidate per ray and doubling, each iteration's hits
 * cull the next candidates in top_level (boxes beyond tmax are not emitted) and in
 * bottom_level. teapot_displaced at 640x360: 25% fewer pairs, bottom_level 30% faster
 * (docs/benchmarks.md). The hits do not depend on N: resolve keeps the earlier of equal
 * hits (test_trace compares budgets). */
static uint32_t pairs_per_ray(uint32_t capacity, uint32_t active, uint32_t first_n, uint32_t it)
{
    uint32_t n = capacity / (active ? active : 1);
    n = n < 1 ? 1 : n > TS_N_MAX ? TS_N_MAX : n;
    uint64_t ramp = (uint64_t)(first_n ? first_n : 1u) << (it < 8u ? it : 8u);
    return n < ramp ? n : (uint32_t)ramp;
}

/* The stamp top_level marks the patches that rays leave with in this iteration (pipeline.h
 * leave_stamp), or 0 where every miss is diced whole: when the frame's patches fit (each is
 * diced once anyway, and shade reads the resident vertices), in triangle mode (bottom_level
 * reads every patch's vertices), on devices that share their dicings (a shared patch is
 * whole) and with paged textures (a resident patch diced again would need tiles the batch
 * has not counted). */
static uint32_t leave_stamp(ts_pipeline *p)
{
    int squeezed =
        p->cache.short_of_room || p->stats->counters[TS_COUNTER_patch_cache_evictions] > 0;
    if (!squeezed || p->mode.exact || p->share || p->tex.paged) return 0u;
    if (++p->leave_stamp == 0u) p->leave_stamp = 1u; /* 0 marks nothing */
    return p->leave_stamp;
}

/* How many batches of an iteration the device may run behind the host while a cancel hook
 * is set: enough that a device whose batches are short (a GPU's, a fraction of a millisecond)
 * always has the next ones queued while the host makes more, few enough that a stop waits
 * for no more than those (on PoCL about 15 ms a batch in a squeezed forest-100). */
#define TS_BATCHES_AHEAD 4u

int pipeline_trace(ts_pipeline *p, uint32_t ray_count, ts_error *err)
{
    uint32_t active = ray_count;
    p->trace_progress.work = p->trace_progress.done = p->trace_progress.t0 = 0.0;
    if (pipeline_stitch_prepare(p, err) || cull_reset_stale(p, err)) return err->code;
    pipeline_cache_plan(p);
    if (skeleton_prepare(p, err)) return err->code;
    for (uint32_t it = 0; active > 0; ++it) {
        /* Once the patch cache has had to evict, or its plan says the frame's patches do not all
         * fit, they come back diced again: then each iteration may dice them again, and Hanika's N
         * (fill the pair buffer, fewer iterations) dices less than the ramp (teapot_displaced at
         * --memory 192: half the dicings; docs/benchmarks.md). */
        uint32_t first_n = p->plan.first_n;
        if (!first_n &&
            (p->cache.short_of_room || p->stats->counters[TS_COUNTER_patch_cache_evictions] > 0))
            first_n = TS_N_MAX;
        uint32_t n_per_ray = pairs_per_ray(p->plan.pair_capacity, active, first_n, it);
        /* The kernels' N: 0 for water-filled windows, whose N (the cap) the stats record. */
        uint32_t kernel_n = n_per_ray, windows = active, width = n_per_ray;
        if (p->plan.fill_windows || (!p->plan.first_n && first_n == TS_N_MAX)) {
            if (water_fill(p, active, TS_FILL_MAX, &n_per_ray, &windows, err)) return err->code;
            if (p->cancelled) return TS_OK;
            kernel_n = 0, width = 0;
        }
        uint32_t sorted_buffer = 0, valid = 0, segs = 0, stamp = leave_stamp(p);
        if (stage_top_level(p, active, kernel_n, stamp, err)) return err->code;
        if (p->cancelled) return TS_OK;
        if (stage_sort(p, windows, width, stamp, &sorted_buffer, &valid, &segs, err))
            return err->code;
        /* The queue as each of the last TS_BATCHES_AHEAD batches was enqueued (a ring). */
        ts_dev_mark ahead[TS_BATCHES_AHEAD];
        for (uint32_t a = 0; a < TS_BATCHES_AHEAD; ++a)
            ahead[a] = dev_mark(p->cl);
        if (it == 0) p->trace_progress.t0 = stats_now();
        for (uint32_t k = 0; k < (segs ? p->batch_count : 0); ++k)
            p->trace_progress.work += p->batches[k].work;
        for (uint32_t k = 0; k < (segs ? p->batch_count : 0); ++k) {
            const ts_batch *b = &p->batches[k];
            if (batch_make(p, b, err) ||
                stage_bottom_level(p, sorted_buffer, b, kernel_n, active, err))
                return err->code;
            /* A frame whose patches do not fit dices for seconds an iteration: a stop is
             * honoured between its batches too (the wave's results are dropped), with at
             * most TS_BATCHES_AHEAD batches enqueued and not yet run: what is enqueued must
             * run before the stop, and thousands of batches enqueued at once kept a
             * squeezed forest-100 at 1920x768 five seconds after SIGINT. */
            if (k + 1 < p->batch_count && p->cancel) {
                uint32_t a = k % TS_BATCHES_AHEAD;
                if (dev_wait_mark(p->cl, ahead[a], err)) return err->code;
                ahead[a] = dev_mark(p->cl);
                /* ahead[a] was marked after batch k - TS_BATCHES_AHEAD: it has run */
                if (k >= TS_BATCHES_AHEAD)
                    p->trace_progress.done += p->batches[k - TS_BATCHES_AHEAD].work;
                if (p->cancel(p->cancel_ctx)) {
                    p->cancelled = 1;
                    return dev_finish(p->cl, p->stats, err);
                }
            }
        }
        p->trace_progress.done = p->trace_progress.work; /* run, or before resolve's */
        if (segs && p->iteration_watch &&
            (dev_finish(p->cl, p->stats, err) ||
             p->iteration_watch(p->iteration_ctx, p, active, kernel_n,
                                sorted_buffer ? p->pairs_scratch : p->pairs, valid, segs, err)))
            return err->code;
        ts_iteration rec = {p->wave, it, active, n_per_ray, valid, segs, p->in_lod};
        if (stats_add_iteration(p->stats, &rec, err)) return err->code;
        p->stats->counters[TS_COUNTER_pairs] += valid;
        p->stats->counters[TS_COUNTER_iterations] += 1;
        if (stage_resolve(p, active, kernel_n, &active, err)) return err->code;
        if (active && p->cancel && p->cancel(p->cancel_ctx)) {
            p->cancelled = 1;
            break;
        }
    }
    return TS_OK;
}
