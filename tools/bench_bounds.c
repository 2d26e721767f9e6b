/* bench_bounds.c — how tight, how conservative and how costly the displacement bounds of
 * stage `build` are (issue 13 item 4, docs/benchmarks.md): the production interval
 * arithmetic (IA) on the fBm noise against cheaper and tighter candidates, on the same
 * leaves, in one run.
 *
 * For each m, a deterministic sample of leaves (micro-quads) of every noise-displaced patch
 * (stratified in Morton order, `--leaves` per patch) is diced by the plain-C reference of
 * dice (host/ref/dice_build_ref.c). Each method gives an interval [d] holding the displacement
 * d over the leaf's whole parameter square; the leaf box is then finished from [d] by the
 * reference's own code (dice_build_ref_leaf: undisplaced corners, flatness, [d] x the
 * normal box, clamp to the patch box), so only [d] differs between methods. The truth:
 * S x S points over the closed square (`--samples`), each the diced vertex at (u, v)
 * (patch_vertex, w = d), giving the sampled range of d and the tight box of the points.
 * Per method: mean and median over leaves of [d]'s width / the sampled range, of the box's
 * extent / the tight box's (mean of the three axes) and of the volume ratio; every sampled
 * point outside [d] or outside the box is counted as a violation (a claimed-conservative
 * method must have none: the count is reported, never hidden); the cost of computing [d]
 * in ns per leaf (process CPU time, the median of `--repeat` passes over all sampled
 * leaves, the methods taking turns chunk by chunk in a rotating order, so the ratios to IA
 * come from one run and time other jobs take from a shared machine is not counted); and
 * the IA evaluations per leaf, a cost that does not depend on the machine.
 *
 * Methods (inputs: what build already has for a leaf: the grid's corner vertices with
 * w = d, hence the undisplaced corners and the domain box IA is taken over):
 *   ia            production: displace_interval over the leaf's domain box (the same call
 *                 the reference and kernels/build.cl make; its box is the reference's)
 *   ia_parent1/2  IA once over the node 1 / 2 levels up, reused by its 4 / 16 leaves
 *                 (domain: the node's 4 Bézier corners grown by the flatness at its level)
 *   ia_sub2/4     IA on 2x2 / 4x4 sub-squares, union (domains as for the parents)
 *   lipschitz     d within L |P - C| of its value at each corner C, intersected over the
 *                 four corners; |P - C| <= the farthest corner of the domain box;
 *                 L = |amplitude| sum_o |gain^o| f_o |W| G (x2 for ridged), G the
 *                 proven bound on |grad noise| of noise_gradient.h
 *   ia_lipschitz  the intersection of ia and lipschitz (both conservative)
 *   lipschitz_sampled, curvature_sampled: the same with G and the Hessian bound H taken
 *                 from a numerical sup (SAMPLED_GRADIENT, SAMPLED_HESSIAN): NOT proven,
 *                 never claimed conservative, for comparison only. curvature: bilinear
 *                 interpolation of the corner values +- h^2/8 (max|d_uu| + max|d_vv|),
 *                 d_uu <= |amp| sum |w_o| (f_o^2 H |W|^2 |P_u|^2 + f_o G |W| |P_uu|) (fbm only)
 * Only time 0 of a moving patch is measured (the noise is taken at time 0 for both).
 *
 * --size (tools/bench): tiny: scene/teapot_displaced.rib, m = 6, every 4th patch, 16 leaves
 * per patch, 9 x 9 samples, 3 timing passes (the ctest smoke test); small: m = 6 and 8,
 * every patch, 64 leaves, 17 x 17, 9 passes; full: m = 6, 7, 8 and 9, 256 leaves, 17 x 17,
 * 15 passes. Options given after --size override it.
 *
 * usage: bench_bounds [--size tiny|small|full] [--scene RIB] [--lod M]... [--leaves N]
 *                     [--samples S] [--repeat R] [--patch-stride K] [--json PATH]
 * Exit status 1 on an error or when a claimed-conservative method missed a sampled point. */
#include "bench_util.h"
#include "noise_gradient.h"
#include "lib/patch.h"
#include "lib/quadtree.h"
#include "lib/rng.h"
#include "ref/dice_build_ref.h"
#include "scene/scene_load.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_LODS 8
#define MAX_REPEAT 101
/* sup |grad noise3| and sup |e^T Hess noise3 e| (|e| = 1) over a lattice cell and every choice
 * of its corner gradients, found numerically on a grid of cell positions and directions
 * (the issue 13 experiments, 2026-11-23). Estimates, not bounds: only the *_sampled
 * methods use them. */
#define SAMPLED_GRADIENT 3.75
#define SAMPLED_HESSIAN 14.4
/* Sub-cubes per axis of the cell in noise_gradient_bound (noise_gradient.h). */
#define GRADIENT_SPLIT 48
/* Leaves per timed chunk: each method's turn lasts from ~10 us (lipschitz) to ~10 ms (ia_sub4). */
#define TIME_CHUNK 256u

typedef struct bench_options {
    const char *size, *json_path, *scene;
    uint32_t lods[MAX_LODS];
    int lod_count, leaves, samples, repeat, patch_stride;
} bench_options;

/* Per patch: the reference's inputs and the constants of the Lipschitz and curvature bounds. */
typedef struct patch_info {
    dice_build_ref_patch q;
    ts_vec4 *grid;                 /* diced at the current m (time 0 first) */
    float lip_proven, lip_sampled; /* |grad d| bounds in world space */
    float curv_sampled;            /* max|d_uu| + max|d_vv| over the patch (fbm only), or inf */
} patch_info;

/* One sampled leaf: what build has for it (grid corners, the domain box of IA). */
typedef struct leaf_in {
    const patch_info *pi;
    uint32_t m, k, i, j;
    ts_box domain;     /* the box production IA is taken over (dice_build_ref_leaf) */
    ts_vec4 corner[4]; /* undisplaced time-0 corners, w = d there (the grid's w) */
} leaf_in;

typedef ts_interval (*bound_fn)(const leaf_in *l);

typedef struct method {
    const char *name, *basis;
    bound_fn fn;
    int claimed;     /* claimed conservative (proven) */
    double ia_calls; /* displace_interval calls per leaf */
    uint32_t share;  /* leaves that share one evaluation (the parent methods) */
} method;

/* ---- per-patch constants ---------------------------------------------------------- */

/* An upper bound of the operator 2-norm of the world-to-object transform's 3x3 part: the
 * smaller of its Frobenius norm and sqrt(max column sum * max row sum) (1 for a rotation
 * or the identity only through the latter). */
static double xform_norm(const ts_xform *x)
{
    const float *r[3] = {x->r0, x->r1, x->r2};
    double fro = 0, col[3] = {0, 0, 0}, row_max = 0;
    for (int a = 0; a < 3; ++a) {
        double row = 0;
        for (int b = 0; b < 3; ++b) {
            fro += (double)r[a][b] * r[a][b];
            row += fabs(r[a][b]), col[b] += fabs(r[a][b]);
        }
        row_max = fmax(row_max, row);
    }
    return fmin(sqrt(fro), sqrt(fmax(fmax(col[0], col[1]), col[2]) * row_max));
}

/* sum_o |gain^o| f_o^power over the octaves (f_o = frequency * lacunarity^o). */
static double octave_sum(const ts_patch_attr *a, int power)
{
    double f = fabs(a->disp_frequency), w = 1, s = 0;
    for (ts_u32 o = 0; o < displace_octaves(a); ++o) {
        s += fabs(w) * pow(f, power);
        f *= fabs(a->disp_lacunarity);
        w *= a->disp_gain;
    }
    return s;
}

static double len3(ts_vec4 p)
{
    return sqrt((double)p.x * p.x + (double)p.y * p.y + (double)p.z * p.z);
}

static void patch_info_init(patch_info *pi, const ts_scene *s, uint32_t p, double g_proven)
{
    pi->q = dice_build_ref_patch_of(s, p);
    const ts_patch_attr *a = pi->q.a;
    double wn = xform_norm(pi->q.x), amp = fabs(a->disp_amplitude);
    double ridged = a->disp_kind == TS_DISP_RIDGED ? 2 : 1; /* |grad (1 - 2|n|)| <= 2 |grad n| */
    double base = amp * octave_sum(a, 1) * wn * ridged;
    pi->lip_proven = (float)(base * g_proven * (1 + 1e-6));
    pi->lip_sampled = (float)(base * SAMPLED_GRADIENT);
    /* max |P_u| <= 3 max |first difference along u| of the control points, |P_uu| <= 6 max
     * |second difference| (the hodographs are convex combinations of them), likewise v. */
    const ts_vec4 *c = pi->q.cp0;
    double du = 0, dv = 0, duu = 0, dvv = 0;
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            ts_vec4 p0 = c[j * 4 + i];
            if (i < 3) {
                ts_vec4 q = c[j * 4 + i + 1];
                du = fmax(du, 3 * len3((ts_vec4){q.x - p0.x, q.y - p0.y, q.z - p0.z, 0}));
            }
            if (j < 3) {
                ts_vec4 q = c[(j + 1) * 4 + i];
                dv = fmax(dv, 3 * len3((ts_vec4){q.x - p0.x, q.y - p0.y, q.z - p0.z, 0}));
            }
            if (i < 2) {
                ts_vec4 q = c[j * 4 + i + 1], r = c[j * 4 + i + 2];
                duu = fmax(duu, 6 * len3((ts_vec4){p0.x - 2 * q.x + r.x, p0.y - 2 * q.y + r.y,
                                                   p0.z - 2 * q.z + r.z, 0}));
            }
            if (j < 2) {
                ts_vec4 q = c[(j + 1) * 4 + i], r = c[(j + 2) * 4 + i];
                dvv = fmax(dvv, 6 * len3((ts_vec4){p0.x - 2 * q.x + r.x, p0.y - 2 * q.y + r.y,
                                                   p0.z - 2 * q.z + r.z, 0}));
            }
        }
    pi->curv_sampled =
        a->disp_kind == TS_DISP_FBM
            ? (float)(amp * (octave_sum(a, 2) * SAMPLED_HESSIAN * wn * wn * (du * du + dv * dv) +
                             octave_sum(a, 1) * SAMPLED_GRADIENT * wn * (duu + dvv)))
            : INFINITY; /* ridged has a kink where n = 0: no curvature bound */
}

/* ---- the bounds ------------------------------------------------------------------- */

/* IA over the parameter rectangle [u0, u1] x [v0, v1] of level `level`: the box of its four
 * time-0 Bézier corners grown by the flatness bound at that level and a few ulps (as
 * build grows a leaf's), then displace_interval. */
static ts_interval square_interval(const leaf_in *l, float u0, float v0, float u1, float v1,
                                   uint32_t level)
{
    const dice_build_ref_patch *q = &l->pi->q;
    ts_vec4 c[4] = {bezier_eval(q->cp0, u0, v0), bezier_eval(q->cp0, u1, v0),
                    bezier_eval(q->cp0, u0, v1), bezier_eval(q->cp0, u1, v1)};
    ts_box b = {c[0].x, c[0].y, c[0].z, c[0].x, c[0].y, c[0].z};
    for (int k = 1; k < 4; ++k) {
        b.lo_x = fminf(b.lo_x, c[k].x), b.hi_x = fmaxf(b.hi_x, c[k].x);
        b.lo_y = fminf(b.lo_y, c[k].y), b.hi_y = fmaxf(b.hi_y, c[k].y);
        b.lo_z = fminf(b.lo_z, c[k].z), b.hi_z = fmaxf(b.hi_z, c[k].z);
    }
    float s = ldexpf(1.0f, -2 * (int)level);
    float mag =
        fmaxf(fmaxf(fmaxf(fabsf(b.lo_x), fabsf(b.hi_x)), fmaxf(fabsf(b.lo_y), fabsf(b.hi_y))),
              fmaxf(fabsf(b.lo_z), fabsf(b.hi_z)));
    float ex = q->e.x * s + 4e-7f * mag, ey = q->e.y * s + 4e-7f * mag,
          ez = q->e.z * s + 4e-7f * mag;
    return displace_interval(q->a, q->x, b.lo_x - ex, b.lo_y - ey, b.lo_z - ez, b.hi_x + ex,
                             b.hi_y + ey, b.hi_z + ez);
}

static ts_interval bound_ia(const leaf_in *l)
{
    const ts_box *b = &l->domain;
    return displace_interval(l->pi->q.a, l->pi->q.x, b->lo_x, b->lo_y, b->lo_z, b->hi_x, b->hi_y,
                             b->hi_z);
}

static ts_interval parent_interval(const leaf_in *l, uint32_t r)
{
    uint32_t level = l->m - r;
    float h = ldexpf(1.0f, -(int)level);
    float u0 = (float)(l->i >> r) * h, v0 = (float)(l->j >> r) * h;
    return square_interval(l, u0, v0, u0 + h, v0 + h, level);
}

static ts_interval bound_parent1(const leaf_in *l)
{
    return parent_interval(l, 1);
}

static ts_interval bound_parent2(const leaf_in *l)
{
    return parent_interval(l, 2);
}

static ts_interval sub_interval(const leaf_in *l, uint32_t log_k)
{
    uint32_t k = 1u << log_k, level = l->m + log_k;
    float h = ldexpf(1.0f, -(int)level);
    ts_interval r = {INFINITY, -INFINITY};
    for (uint32_t b = 0; b < k; ++b)
        for (uint32_t a = 0; a < k; ++a) {
            float u0 = (float)(l->i * k + a) * h, v0 = (float)(l->j * k + b) * h;
            ts_interval s = square_interval(l, u0, v0, u0 + h, v0 + h, level);
            r.lo = fminf(r.lo, s.lo), r.hi = fmaxf(r.hi, s.hi);
        }
    return r;
}

static ts_interval bound_sub2(const leaf_in *l)
{
    return sub_interval(l, 1);
}

static ts_interval bound_sub4(const leaf_in *l)
{
    return sub_interval(l, 2);
}

/* [d] from the corner values and a Lipschitz constant lip (world units): every point P of
 * the leaf's undisplaced surface lies in the domain box, so |P - C| <= the distance from C
 * to the box's farthest corner. Widened as displace_interval widens its sum, plus lip
 * times a few ulps of the corner positions. */
static ts_interval lipschitz_interval(const leaf_in *l, float lip)
{
    const ts_box *b = &l->domain;
    const ts_patch_attr *a = l->pi->q.a;
    ts_interval r = {-INFINITY, INFINITY};
    for (int c = 0; c < 4; ++c) {
        ts_vec4 p = l->corner[c];
        float fx = fmaxf(p.x - b->lo_x, b->hi_x - p.x), fy = fmaxf(p.y - b->lo_y, b->hi_y - p.y),
              fz = fmaxf(p.z - b->lo_z, b->hi_z - p.z);
        float reach = lip * sqrtf(fx * fx + fy * fy + fz * fz);
        r.lo = fmaxf(r.lo, p.w - reach), r.hi = fminf(r.hi, p.w + reach);
    }
    ts_vec4 p = l->corner[0];
    float mag = fmaxf(fmaxf(fabsf(p.x), fabsf(p.y)), fabsf(p.z));
    float slack = 1e-5f * fabsf(a->disp_amplitude) * (float)displace_octaves(a) + lip * 1e-6f * mag;
    r.lo -= slack, r.hi += slack;
    return r;
}

static ts_interval bound_lipschitz(const leaf_in *l)
{
    return lipschitz_interval(l, l->pi->lip_proven);
}

static ts_interval bound_lipschitz_sampled(const leaf_in *l)
{
    return lipschitz_interval(l, l->pi->lip_sampled);
}

static ts_interval bound_ia_lipschitz(const leaf_in *l)
{
    ts_interval a = bound_ia(l), b = lipschitz_interval(l, l->pi->lip_proven);
    ts_interval r = {fmaxf(a.lo, b.lo), fminf(a.hi, b.hi)};
    return r;
}

/* Bilinear interpolation of the corner values lies between their min and max; d strays
 * from it by at most h^2/8 (max|d_uu| + max|d_vv|) (as patch_flatness argues for P). */
static ts_interval bound_curvature_sampled(const leaf_in *l)
{
    float h = ldexpf(1.0f, -(int)l->m), e = 0.125f * h * h * l->pi->curv_sampled;
    float lo = fminf(fminf(l->corner[0].w, l->corner[1].w), fminf(l->corner[2].w, l->corner[3].w));
    float hi = fmaxf(fmaxf(l->corner[0].w, l->corner[1].w), fmaxf(l->corner[2].w, l->corner[3].w));
    ts_interval r = {lo - e, hi + e};
    return r;
}

static const method methods[] = {
    {"ia", "interval arithmetic on the noise over the leaf's domain box (production)", bound_ia, 1,
     1, 1},
    {"ia_parent1", "IA over the node one level up, shared by its 4 leaves", bound_parent1, 1, 0.25,
     4},
    {"ia_parent2", "IA over the node two levels up, shared by its 16 leaves", bound_parent2, 1,
     0.0625, 16},
    {"ia_sub2", "IA on 2x2 sub-squares, union", bound_sub2, 1, 4, 1},
    {"ia_sub4", "IA on 4x4 sub-squares, union", bound_sub4, 1, 16, 1},
    {"lipschitz", "corner values +- L |P - C|, proven gradient bound", bound_lipschitz, 1, 0, 1},
    {"ia_lipschitz", "ia intersected with lipschitz", bound_ia_lipschitz, 1, 1, 1},
    {"lipschitz_sampled", "lipschitz with the sampled gradient sup (not proven)",
     bound_lipschitz_sampled, 0, 0, 1},
    {"curvature_sampled", "corner range +- h^2/8 curvature, sampled constants (not proven)",
     bound_curvature_sampled, 0, 0, 1},
};
#define METHODS ((int)(sizeof methods / sizeof methods[0]))

/* ---- measurement ------------------------------------------------------------------ */

typedef struct method_stats {
    double *range, *extent, *volume; /* per leaf with a non-zero sampled range / tight box */
    int n_range, n_box;
    uint64_t viol_range, viol_box; /* sampled points outside [d] / outside the box */
    double worst_range, worst_box; /* largest miss, in units of |amplitude| */
    double seconds[MAX_REPEAT];    /* one timed pass over every sampled leaf */
} method_stats;

typedef struct lod_result {
    uint32_t m, patches, leaves;
    uint64_t points;
    int zero_range, flat_box; /* leaves left out of the range / box ratios */
    method_stats st[METHODS];
    double leaf_box_seconds[MAX_REPEAT]; /* the whole reference leaf box, for scale */
} lod_result;

static volatile float bench_sink;

static double mean_of(const double *v, int n)
{
    double s = 0;
    for (int k = 0; k < n; ++k)
        s += v[k];
    return n ? s / n : NAN;
}

static double median_of(double *v, int n)
{
    return n ? bench_median(v, n) : NAN;
}

/* The sampled points of leaf l: S x S diced vertices over its closed square (w = d). */
static void sample_leaf(const leaf_in *l, int S, ts_vec4 *pts)
{
    const dice_build_ref_patch *q = &l->pi->q;
    for (int b = 0; b < S; ++b)
        for (int a = 0; a < S; ++a) {
            float u = ldexpf((float)l->i + (float)a / (float)(S - 1), -(int)l->m);
            float v = ldexpf((float)l->j + (float)b / (float)(S - 1), -(int)l->m);
            pts[b * S + a] = patch_vertex(q->cp0, q->cp0, q->cn, q->mn, q->a, q->x, q->tex, u, v);
        }
}

/* Checks every method on leaf l against its sampled points; 1 if the production box of the
 * reference differs from the one finished from bound_ia (they must be the same call). */
static int check_leaf(const leaf_in *l, const ts_vec4 *pts, int np, lod_result *res)
{
    ts_box tb = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    float tlo = INFINITY, thi = -INFINITY;
    for (int k = 0; k < np; ++k) {
        ts_vec4 p = pts[k];
        tlo = fminf(tlo, p.w), thi = fmaxf(thi, p.w);
        tb.lo_x = fminf(tb.lo_x, p.x), tb.hi_x = fmaxf(tb.hi_x, p.x);
        tb.lo_y = fminf(tb.lo_y, p.y), tb.hi_y = fmaxf(tb.hi_y, p.y);
        tb.lo_z = fminf(tb.lo_z, p.z), tb.hi_z = fmaxf(tb.hi_z, p.z);
    }
    double tx = (double)tb.hi_x - tb.lo_x, ty = (double)tb.hi_y - tb.lo_y,
           tz = (double)tb.hi_z - tb.lo_z, trange = (double)thi - tlo;
    int use_range = trange > 0, use_box = tx > 0 && ty > 0 && tz > 0;
    res->zero_range += !use_range, res->flat_box += !use_box;
    const dice_build_ref_patch *q = &l->pi->q;
    double amp = fabs(q->a->disp_amplitude);
    for (int mi = 0; mi < METHODS; ++mi) {
        method_stats *st = &res->st[mi];
        ts_interval d = methods[mi].fn(l);
        ts_box b = dice_build_ref_leaf(q, 0, l->m, l->k, &d, NULL);
        if (mi == 0) {
            ts_box ref = dice_build_ref_leaf(q, 0, l->m, l->k, NULL, NULL);
            if (memcmp(&ref, &b, sizeof b) != 0) return 1;
        }
        for (int k = 0; k < np; ++k) {
            ts_vec4 p = pts[k];
            double miss = fmax((double)d.lo - p.w, (double)p.w - d.hi);
            if (miss > 0) st->viol_range++, st->worst_range = fmax(st->worst_range, miss / amp);
            double bm = fmax(fmax(fmax((double)b.lo_x - p.x, (double)p.x - b.hi_x),
                                  fmax((double)b.lo_y - p.y, (double)p.y - b.hi_y)),
                             fmax((double)b.lo_z - p.z, (double)p.z - b.hi_z));
            if (bm > 0) st->viol_box++, st->worst_box = fmax(st->worst_box, bm / amp);
        }
        if (use_range) st->range[st->n_range++] = ((double)d.hi - d.lo) / trange;
        if (use_box) {
            double bx = (double)b.hi_x - b.lo_x, by = (double)b.hi_y - b.lo_y,
                   bz = (double)b.hi_z - b.lo_z;
            st->extent[st->n_box] = (bx / tx + by / ty + bz / tz) / 3;
            st->volume[st->n_box++] = bx * by * bz / (tx * ty * tz);
        }
    }
    return 0;
}

/* Times every method (and the whole reference leaf box) on leaves [l0, l1) once; adds the
 * process CPU seconds of each to slot r (the process is one thread: time the machine's other
 * jobs take from it is not counted). */
static void time_chunk(const leaf_in *leaves, uint32_t l0, uint32_t l1, int r, ts_interval *out,
                       lod_result *res)
{
    for (int s = 0; s <= METHODS; ++s) {
        int mi = (s + r + (int)(l0 / TIME_CHUNK)) % (METHODS + 1);
        float sum = 0;
        double t0 = bench_cpu();
        if (mi == METHODS) {
            for (uint32_t l = l0; l < l1; ++l) {
                ts_box b =
                    dice_build_ref_leaf(&leaves[l].pi->q, 0, leaves[l].m, leaves[l].k, NULL, NULL);
                sum += b.hi_x;
            }
        } else {
            bound_fn fn = methods[mi].fn;
            for (uint32_t l = l0; l < l1; ++l)
                out[l] = fn(&leaves[l]);
        }
        double dt = bench_cpu() - t0;
        for (uint32_t l = l0; mi < METHODS && l < l1; ++l)
            sum += out[l].hi;
        bench_sink = sum;
        if (mi == METHODS)
            res->leaf_box_seconds[r] += dt;
        else
            res->st[mi].seconds[r] += dt;
    }
}

/* `repeat` timed passes over all leaves; within a pass the methods take turns chunk by
 * chunk, in an order that rotates, so slow phases of a shared machine hit them alike. */
static void time_methods(const leaf_in *leaves, uint32_t n, int repeat, ts_interval *out,
                         lod_result *res)
{
    for (int r = 0; r < repeat; ++r)
        for (uint32_t l0 = 0; l0 < n; l0 += TIME_CHUNK)
            time_chunk(leaves, l0, l0 + TIME_CHUNK < n ? l0 + TIME_CHUNK : n, r, out, res);
}

/* The sampled leaves of patch pi at m: `want` strata of the Morton order, one leaf at a
 * hashed position in each. */
static uint32_t pick_leaves(const patch_info *pi, uint32_t p, uint32_t m, uint32_t want,
                            leaf_in *out)
{
    uint32_t nl = 1u << (2u * m), count = want < nl ? want : nl, stride = nl / count;
    uint32_t n = (1u << m) + 1u;
    for (uint32_t s = 0; s < count; ++s) {
        leaf_in *l = &out[s];
        l->pi = pi, l->m = m;
        l->k = s * stride + rng_mix(rng_mix(p * 0x9e3779b9u + m) ^ s) % stride;
        l->i = morton_i(l->k), l->j = morton_j(l->k);
        dice_build_ref_leaf(&pi->q, 0, m, l->k, NULL, &l->domain);
        for (uint32_t c = 0; c < 4u; ++c) {
            uint32_t ci = l->i + (c & 1u), cj = l->j + (c >> 1);
            l->corner[c] =
                bezier_eval(pi->q.cp0, ldexpf((float)ci, -(int)m), ldexpf((float)cj, -(int)m));
            l->corner[c].w = pi->grid[cj * n + ci].w; /* d, as dice computed it there */
        }
    }
    return count;
}

/* Everything for one m: dice the patches, pick and check the leaves, time the methods. */
static int bench_lod(const ts_scene *s, patch_info *pis, const uint32_t *ids, uint32_t np,
                     uint32_t m, const bench_options *o, lod_result *res)
{
    memset(res, 0, sizeof *res);
    res->m = m, res->patches = np;
    uint32_t n = (1u << m) + 1u, per = (uint32_t)o->leaves, cap = np * per;
    leaf_in *leaves = calloc(cap, sizeof *leaves);
    ts_interval *out = calloc(cap, sizeof *out);
    ts_vec4 *pts = calloc((size_t)o->samples * o->samples, sizeof *pts);
    int rc = !leaves || !out || !pts;
    for (int mi = 0; mi < METHODS && !rc; ++mi) {
        method_stats *st = &res->st[mi];
        st->range = calloc(cap, sizeof(double)), st->extent = calloc(cap, sizeof(double));
        st->volume = calloc(cap, sizeof(double));
        rc = !st->range || !st->extent || !st->volume;
    }
    for (uint32_t t = 0; t < np && !rc; ++t) {
        patch_info *pi = &pis[t];
        pi->grid = malloc((size_t)dice_build_ref_times(s, ids[t]) * n * n * sizeof *pi->grid);
        if (!pi->grid) {
            rc = 1;
            break;
        }
        dice_build_ref_grid(s, ids[t], m, pi->grid);
        res->leaves += pick_leaves(pi, ids[t], m, per, leaves + res->leaves);
    }
    int np2 = o->samples * o->samples;
    for (uint32_t l = 0; l < res->leaves && !rc; ++l) {
        sample_leaf(&leaves[l], o->samples, pts);
        res->points += (uint64_t)np2;
        if (check_leaf(&leaves[l], pts, np2, res)) {
            fprintf(stderr, "bench_bounds: m = %u leaf %u: the reference box differs from ia's\n",
                    m, leaves[l].k);
            rc = 1;
        }
    }
    if (!rc) time_methods(leaves, res->leaves, o->repeat, out, res);
    if (rc && (!leaves || !out || !pts)) fprintf(stderr, "bench_bounds: out of memory\n");
    for (uint32_t t = 0; t < np; ++t) {
        free(pis[t].grid);
        pis[t].grid = NULL;
    }
    free(leaves), free(out), free(pts);
    return rc;
}

static void lod_result_free(lod_result *res)
{
    for (int mi = 0; mi < METHODS; ++mi)
        free(res->st[mi].range), free(res->st[mi].extent), free(res->st[mi].volume);
}

/* Prints the table of one m and appends its JSON object; returns the number of
 * claimed-conservative methods that missed a sampled point. */
static int report_lod(lod_result *res, int repeat, cJSON *rows)
{
    double ia_ns = 0, per_leaf = 1e9 / (res->leaves ? res->leaves : 1);
    int bad = 0;
    cJSON *o = cJSON_CreateObject(), *ms = cJSON_CreateArray();
    double box_ns = median_of(res->leaf_box_seconds, repeat) * per_leaf;
    printf("\nm = %u: %u patches, %u leaves, %llu sampled points (%d leaves with a zero sampled "
           "range, %d with a flat tight box left out of those ratios); whole reference leaf "
           "box: %.0f ns per leaf\n\n",
           res->m, res->patches, res->leaves, (unsigned long long)res->points, res->zero_range,
           res->flat_box, box_ns);
    printf("| method | proven | [d] / sampled range, mean | median | box extent ratio, median | "
           "box volume ratio, median | points outside [d] / box | IA calls per leaf | ns per "
           "leaf | cost / ia |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int mi = 0; mi < METHODS; ++mi) {
        const method *me = &methods[mi];
        method_stats *st = &res->st[mi];
        double ns = median_of(st->seconds, repeat) * per_leaf / me->share;
        if (mi == 0) ia_ns = ns;
        double rmean = mean_of(st->range, st->n_range), emean = mean_of(st->extent, st->n_box),
               vmean = mean_of(st->volume, st->n_box);
        double rmed = median_of(st->range, st->n_range), emed = median_of(st->extent, st->n_box),
               vmed = median_of(st->volume, st->n_box);
        bad += me->claimed && (st->viol_range || st->viol_box);
        printf("| %s | %s | %.2f | %.2f | %.2f | %.1f | %llu / %llu | %g | %.0f | %.2f |\n",
               me->name, me->claimed ? "yes" : "no (sampled)", rmean, rmed, emed, vmed,
               (unsigned long long)st->viol_range, (unsigned long long)st->viol_box, me->ia_calls,
               ns, ns / ia_ns);
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "name", me->name);
        cJSON_AddStringToObject(j, "basis", me->basis);
        cJSON_AddBoolToObject(j, "claimed_conservative", me->claimed);
        cJSON_AddNumberToObject(j, "range_ratio_mean", rmean);
        cJSON_AddNumberToObject(j, "range_ratio_median", rmed);
        cJSON_AddNumberToObject(j, "box_extent_ratio_mean", emean);
        cJSON_AddNumberToObject(j, "box_extent_ratio_median", emed);
        cJSON_AddNumberToObject(j, "box_volume_ratio_mean", vmean);
        cJSON_AddNumberToObject(j, "box_volume_ratio_median", vmed);
        cJSON_AddNumberToObject(j, "range_violations", (double)st->viol_range);
        cJSON_AddNumberToObject(j, "box_violations", (double)st->viol_box);
        cJSON_AddNumberToObject(j, "worst_range_miss_over_amplitude", st->worst_range);
        cJSON_AddNumberToObject(j, "worst_box_miss_over_amplitude", st->worst_box);
        cJSON_AddBoolToObject(j, "conservative_on_samples", !st->viol_range && !st->viol_box);
        cJSON_AddNumberToObject(j, "ia_calls_per_leaf", me->ia_calls);
        cJSON_AddNumberToObject(j, "leaves_sharing_one_evaluation", me->share);
        cJSON_AddNumberToObject(j, "ns_per_leaf", ns);
        cJSON_AddNumberToObject(j, "cost_ratio_to_ia", ns / ia_ns);
        cJSON_AddItemToArray(ms, j);
    }
    cJSON_AddNumberToObject(o, "m", res->m);
    cJSON_AddNumberToObject(o, "patches", res->patches);
    cJSON_AddNumberToObject(o, "leaves", res->leaves);
    cJSON_AddNumberToObject(o, "points", (double)res->points);
    cJSON_AddNumberToObject(o, "leaves_zero_range", res->zero_range);
    cJSON_AddNumberToObject(o, "leaves_flat_box", res->flat_box);
    cJSON_AddNumberToObject(o, "leaf_box_ns", box_ns);
    cJSON_AddItemToObject(o, "methods", ms);
    cJSON_AddItemToArray(rows, o);
    return bad;
}

static int write_json(const char *path, cJSON *root)
{
    char *text = cJSON_Print(root);
    FILE *f = text ? fopen(path, "w") : NULL;
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0) ok = 0;
    free(text);
    if (!ok) fprintf(stderr, "bench_bounds: cannot write %s\n", path);
    return ok ? 0 : 1;
}

static int usage(void)
{
    fprintf(stderr, "usage: bench_bounds [--size tiny|small|full] [--scene RIB] [--lod M]... "
                    "[--leaves N] [--samples S] [--repeat R] [--patch-stride K] [--json PATH]\n");
    return 1;
}

/* --size: the defaults of each size, in one place. */
static int set_size(bench_options *o, const char *size)
{
    static const uint32_t tiny[] = {6}, small[] = {6, 8}, full[] = {6, 7, 8, 9};
    const uint32_t *l;
    if (strcmp(size, "tiny") == 0)
        l = tiny, o->lod_count = 1, o->leaves = 16, o->samples = 9, o->repeat = 3,
        o->patch_stride = 4;
    else if (strcmp(size, "small") == 0)
        l = small, o->lod_count = 2, o->leaves = 64, o->samples = 17, o->repeat = 9,
        o->patch_stride = 1;
    else if (strcmp(size, "full") == 0)
        l = full, o->lod_count = 4, o->leaves = 256, o->samples = 17, o->repeat = 15,
        o->patch_stride = 1;
    else
        return 1;
    o->size = size;
    memcpy(o->lods, l, (size_t)o->lod_count * sizeof *l);
    return 0;
}

static int parse_options(int argc, char **argv, bench_options *o)
{
    static const struct option opts[] = {{"size", required_argument, 0, 's'},
                                         {"scene", required_argument, 0, 'f'},
                                         {"lod", required_argument, 0, 'm'},
                                         {"leaves", required_argument, 0, 'l'},
                                         {"samples", required_argument, 0, 'S'},
                                         {"repeat", required_argument, 0, 'r'},
                                         {"patch-stride", required_argument, 0, 'p'},
                                         {"json", required_argument, 0, 'j'},
                                         {0, 0, 0, 0}};
    int c, lods_given = 0;
    *o = (bench_options){.scene = "scene/teapot_displaced.rib"};
    set_size(o, "small");
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        int v = optarg ? atoi(optarg) : 0;
        if (c == 's') {
            if (set_size(o, optarg)) {
                fprintf(stderr, "bench_bounds: --size is tiny, small or full\n");
                return 1;
            }
            lods_given = 0;
        } else if (c == 'f') {
            o->scene = optarg;
        } else if (c == 'm' && v >= 2 && v <= 12) {
            if (!lods_given) o->lod_count = 0;
            lods_given = 1;
            if (o->lod_count < MAX_LODS) o->lods[o->lod_count++] = (uint32_t)v;
        } else if (c == 'l' && v >= 1) {
            o->leaves = v;
        } else if (c == 'S' && v >= 2 && v <= 1025) {
            o->samples = v;
        } else if (c == 'r' && v >= 1 && v <= MAX_REPEAT) {
            o->repeat = v;
        } else if (c == 'p' && v >= 1) {
            o->patch_stride = v;
        } else if (c == 'j') {
            o->json_path = optarg;
        } else {
            return usage();
        }
    }
    return optind < argc ? usage() : 0;
}

int main(int argc, char **argv)
{
    bench_options o;
    if (parse_options(argc, argv, &o)) return 1;
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (scene_load(o.scene, &s, 1, &e) != TS_OK) {
        fprintf(stderr, "bench_bounds: %s\n", e.msg);
        ts_error_clear(&e);
        return 1;
    }
    double comp[3], g = noise_gradient_bound(GRADIENT_SPLIT, comp);
    patch_info *pis = calloc(s.patch_count ? s.patch_count : 1, sizeof *pis);
    uint32_t *ids = calloc(s.patch_count ? s.patch_count : 1, sizeof *ids), np = 0;
    int rc = !pis || !ids;
    for (uint32_t p = 0; !rc && p < s.patch_count; p += (uint32_t)o.patch_stride)
        if (displace_is_noise(&s.attr[p])) patch_info_init(&pis[np], &s, p, g), ids[np++] = p;
    if (!rc && np == 0) {
        fprintf(stderr, "bench_bounds: %s has no noise-displaced patch\n", o.scene);
        rc = 1;
    }
    printf("bench_bounds: %s, %u patches (every %d%s), %d leaves per patch, %d x %d samples "
           "per leaf, %d timing passes\n",
           o.scene, np, o.patch_stride, o.patch_stride == 1 ? "" : "th", o.leaves, o.samples,
           o.samples, o.repeat);
    printf("gradient bound of noise3: proven %.4f (per axis %.4f %.4f %.4f, interval arithmetic "
           "on %d^3 sub-cubes); sampled sup %.2f, sampled Hessian sup %.1f (not proven)\n",
           g, comp[0], comp[1], comp[2], GRADIENT_SPLIT, SAMPLED_GRADIENT, SAMPLED_HESSIAN);
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "benchmark", "bounds");
    cJSON_AddStringToObject(root, "size", o.size);
    cJSON_AddStringToObject(root, "scene", o.scene);
    cJSON_AddNumberToObject(root, "patches", np);
    cJSON_AddNumberToObject(root, "leaves_per_patch", o.leaves);
    cJSON_AddNumberToObject(root, "samples_per_side", o.samples);
    cJSON_AddNumberToObject(root, "repeat", o.repeat);
    cJSON *gb = cJSON_AddObjectToObject(root, "gradient_bound");
    cJSON_AddNumberToObject(gb, "proven", g);
    cJSON_AddItemToObject(gb, "proven_per_axis", cJSON_CreateDoubleArray(comp, 3));
    cJSON_AddNumberToObject(gb, "sub_cubes_per_axis", GRADIENT_SPLIT);
    cJSON_AddNumberToObject(gb, "sampled", SAMPLED_GRADIENT);
    cJSON_AddNumberToObject(gb, "hessian_sampled", SAMPLED_HESSIAN);
    cJSON *rows = cJSON_AddArrayToObject(root, "results");
    int bad = 0;
    for (int k = 0; k < o.lod_count && !rc; ++k) {
        lod_result res;
        rc = bench_lod(&s, pis, ids, np, o.lods[k], &o, &res);
        if (!rc) bad += report_lod(&res, o.repeat, rows);
        lod_result_free(&res);
    }
    if (bad) fprintf(stderr, "bench_bounds: a method claimed conservative missed sampled points\n");
    if (!rc && o.json_path) rc = write_json(o.json_path, root);
    cJSON_Delete(root);
    free(pis), free(ids);
    scene_free(&s);
    return rc || bad;
}
