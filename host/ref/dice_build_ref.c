/* dice_build_ref.c — dice_grid, build_leaves and build_level of one patch in scalar C (see
 * dice_build_ref.h). Defaults as pipeline.c gives the kernels: +z corner normals and the
 * identity transform when the scene has none; flatness from patch_flatness at m = 0. */
#include "ref/dice_build_ref.h"
#include "lib/patch.h"
#include "lib/quadtree.h"
#include "lib/trim.h"

#include <math.h>

static const ts_xform identity_xform = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
static const ts_vec4 up_normals[5] = {
    {0, 0, 1, 0}, {0, 0, 1, 0}, {0, 0, 1, 0}, {0, 0, 1, 0}, {0, 0, 1, 0}};

uint32_t dice_build_ref_times(const ts_scene *s, uint32_t p)
{
    return (s->attr[p].flags & TS_PATCH_MOVING) && s->cp1 ? 2u : 1u;
}

static void box_add(ts_box *b, float x, float y, float z)
{
    b->lo_x = fminf(b->lo_x, x), b->hi_x = fmaxf(b->hi_x, x);
    b->lo_y = fminf(b->lo_y, y), b->hi_y = fmaxf(b->hi_y, y);
    b->lo_z = fminf(b->lo_z, z), b->hi_z = fmaxf(b->hi_z, z);
}

/* Box of the undisplaced corners of micro-quad (i, j), h = 2^-m: the Bézier patch cp at the
 * four corners (build.cl's base_box). */
static ts_box base_box(const ts_vec4 *cp, uint32_t i, uint32_t j, float h)
{
    ts_box b = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (uint32_t c = 0; c < 4u; ++c) {
        uint32_t ci = i + (c & 1u), cj = j + (c >> 1);
        ts_vec4 p = bezier_eval(cp, (float)ci * h, (float)cj * h);
        box_add(&b, p.x, p.y, p.z);
    }
    return b;
}

static void interval_mul(float lo, float hi, float a, float b, float *out_lo, float *out_hi)
{
    float p0 = lo * a, p1 = lo * b, p2 = hi * a, p3 = hi * b;
    *out_lo = fminf(fminf(p0, p1), fminf(p2, p3));
    *out_hi = fmaxf(fmaxf(p0, p1), fmaxf(p2, p3));
}

static void grow(ts_box *b, float ex, float ey, float ez)
{
    b->lo_x -= ex, b->hi_x += ex, b->lo_y -= ey, b->hi_y += ey, b->lo_z -= ez, b->hi_z += ez;
}

/* Leaf k of the tree of time `time` (build_leaves for one work-item), before the clamp. */
static ts_box leaf_box(uint32_t time, uint32_t m, uint32_t k, const dice_build_ref_patch *q,
                       const ts_interval *d_given, ts_box *domain)
{
    uint32_t i = morton_i(k), j = morton_j(k);
    float h = ldexpf(1.0f, -(int)m);
    const ts_vec4 *cn = q->cn, *mn = q->mn;
    ts_box b = base_box(time ? q->cp1 : q->cp0, i, j, h);
    float s = ldexpf(1.0f, -2 * (int)m);
    float mag = box_magnitude(b);
    ts_vec4 e = q->e;
    float ex = e.x * s + 4e-7f * mag, ey = e.y * s + 4e-7f * mag, ez = e.z * s + 4e-7f * mag;
    grow(&b, ex, ey, ez);
    ts_box b0 = b; /* the noise is evaluated on the time-0 undisplaced surface */
    if (time == 1u && (domain || (!d_given && q->a->disp_kind != TS_DISP_TEXTURE))) {
        b0 = base_box(q->cp0, i, j, h);
        grow(&b0, ex, ey, ez);
    }
    if (domain) *domain = b0;
    if (q->a->disp_kind == TS_DISP_NONE) return b;
    ts_interval d;
    if (d_given)
        d = *d_given;
    else if (q->a->disp_kind == TS_DISP_TEXTURE)
        d = displace_texture_interval(q->a, q->tex, (float)i * h, (float)j * h, (float)(i + 1u) * h,
                                      (float)(j + 1u) * h);
    else
        d = displace_interval(q->a, q->x, b0.lo_x, b0.lo_y, b0.lo_z, b0.hi_x, b0.hi_y, b0.hi_z);
    ts_box nb = displace_normal_box(cn, mn, (float)i * h, (float)j * h, (float)(i + 1u) * h,
                                    (float)(j + 1u) * h);
    float ox0, ox1, oy0, oy1, oz0, oz1;
    interval_mul(d.lo, d.hi, nb.lo_x, nb.hi_x, &ox0, &ox1);
    interval_mul(d.lo, d.hi, nb.lo_y, nb.hi_y, &oy0, &oy1);
    interval_mul(d.lo, d.hi, nb.lo_z, nb.hi_z, &oz0, &oz1);
    float slack = 4e-7f * (mag + fmaxf(fabsf(d.lo), fabsf(d.hi)));
    b.lo_x += ox0 - slack, b.hi_x += ox1 + slack;
    b.lo_y += oy0 - slack, b.hi_y += oy1 + slack;
    b.lo_z += oz0 - slack, b.hi_z += oz1 + slack;
    return b;
}

/* build.cl's leaf_clamp. */
static ts_box leaf_clamp(ts_box b, ts_box p)
{
    b.lo_x = fmaxf(b.lo_x, p.lo_x), b.lo_y = fmaxf(b.lo_y, p.lo_y), b.lo_z = fmaxf(b.lo_z, p.lo_z);
    b.hi_x = fminf(b.hi_x, p.hi_x), b.hi_y = fminf(b.hi_y, p.hi_y), b.hi_z = fminf(b.hi_z, p.hi_z);
    return b;
}

dice_build_ref_patch dice_build_ref_patch_of(const ts_scene *s, uint32_t p)
{
    dice_build_ref_patch q;
    q.cp0 = &s->cp[p * 16u];
    q.cp1 = dice_build_ref_times(s, p) == 2u ? &s->cp1[p * 16u] : q.cp0;
    q.cn = s->corner_n ? &s->corner_n[p * 4u] : up_normals;
    q.mn = s->mid_n ? &s->mid_n[p * 5u] : up_normals;
    q.a = &s->attr[p];
    q.x = s->xform_count ? &s->xform[q.a->xform] : &identity_xform;
    q.e = patch_flatness(q.cp0, s->cp1 ? &s->cp1[p * 16u] : q.cp0, 0);
    q.tex = scene_tex_ctx(s);
    q.pb = scene_patch_box(s, p);
    return q;
}

ts_box dice_build_ref_leaf(const dice_build_ref_patch *q, uint32_t time, uint32_t m, uint32_t k,
                           const ts_interval *d, ts_box *domain)
{
    return leaf_clamp(leaf_box(time, m, k, q, d, domain), q->pb);
}

void dice_build_ref_grid_stitched(const ts_scene *s, uint32_t p, uint32_t m, uint32_t edges,
                                  ts_vec4 *grid)
{
    uint32_t times = dice_build_ref_times(s, p), n = (1u << m) + 1u, nv = n * n;
    dice_build_ref_patch q = dice_build_ref_patch_of(s, p);
    for (uint32_t t = 0; t < times; ++t) {
        const ts_vec4 *c = t ? q.cp1 : q.cp0;
        for (uint32_t v = 0; v < nv; ++v) {
            uint32_t i = v % n, j = v / n;
            quadtree_stitch(edges, m, &i, &j); /* dice.cl */
            grid[t * nv + v] =
                patch_vertex(c, q.cp0, q.cn, q.mn, q.a, q.x, q.tex, quadtree_vertex_param(i, m),
                             quadtree_vertex_param(j, m));
        }
    }
}

void dice_build_ref_grid(const ts_scene *s, uint32_t p, uint32_t m, ts_vec4 *grid)
{
    dice_build_ref_grid_stitched(s, p, m, 0, grid);
}

void dice_build_ref(const ts_scene *s, uint32_t p, uint32_t m, int tight, ts_vec4 *grid,
                    ts_box4 *groups, ts_tight4 *codes)
{
    dice_build_ref_stitched(s, p, m, tight, 0, grid, groups, codes);
}

void dice_build_ref_stitched(const ts_scene *s, uint32_t p, uint32_t m, int tight, uint32_t edges,
                             ts_vec4 *grid, ts_box4 *groups, ts_tight4 *codes)
{
    uint32_t n = (1u << m) + 1u;
    uint32_t times = dice_build_ref_times(s, p);
    dice_build_ref_patch q = dice_build_ref_patch_of(s, p);
    dice_build_ref_grid_stitched(s, p, m, edges, grid);
    uint32_t ng = quadtree_group_count(m);
    /* build.cl: tight codes for a rough patch in box mode (TS_PATCH_ROUGH), else 0 */
    uint32_t coded = !tight && scene_patch_rough(s, p, m);
    const ts_patch_attr *a = &s->attr[p];
    for (uint32_t t = 0; t < times; ++t) {
        ts_box4 *tree = groups + t * ng;
        ts_tight4 *ct = codes + t * ng;
        for (uint32_t k = 0; k < (1u << (2u * m)); ++k) {
            /* build.cl build_leaves: a micro-quad its trim or its cutout removes gets an empty
             * box */
            if (!patch_keeps(a, s->trim_seg, q.tex, quadtree_centre(morton_i(k), m),
                             quadtree_centre(morton_j(k), m))) {
                ts_box e = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
                quadtree_store(tree, ct, m, k, e, e, coded);
                continue;
            }
            /* build.cl build_leaves: the leaf box and the tight box of the diced vertices */
            ts_box vb = tight_leaf_box(grid + t * n * n, n, morton_i(k), morton_j(k));
            ts_box tb = leaf_clamp(vb, q.pb), lb = tb;
            if (!tight) {
                lb = leaf_box(t, m, k, &q, NULL, NULL);
                if (edges) lb = box_union(lb, vb); /* build.cl: stitched vertices move */
                lb = leaf_clamp(lb, q.pb);
            }
            quadtree_store(tree, ct, m, k, lb, tb, coded);
        }
        for (uint32_t level = m; level-- > 0;) /* bottom-up min-max reduction */
            for (uint32_t k = 0; k < (1u << (2u * level)); ++k) {
                const ts_box4 *c = tree + quadtree_group_offset(level + 1u) + k;
                ts_box b;
                b.lo_x = fminf(fminf(c->lo_x[0], c->lo_x[1]), fminf(c->lo_x[2], c->lo_x[3]));
                b.lo_y = fminf(fminf(c->lo_y[0], c->lo_y[1]), fminf(c->lo_y[2], c->lo_y[3]));
                b.lo_z = fminf(fminf(c->lo_z[0], c->lo_z[1]), fminf(c->lo_z[2], c->lo_z[3]));
                b.hi_x = fmaxf(fmaxf(c->hi_x[0], c->hi_x[1]), fmaxf(c->hi_x[2], c->hi_x[3]));
                b.hi_y = fmaxf(fmaxf(c->hi_y[0], c->hi_y[1]), fmaxf(c->hi_y[2], c->hi_y[3]));
                b.hi_z = fmaxf(fmaxf(c->hi_z[0], c->hi_z[1]), fmaxf(c->hi_z[2], c->hi_z[3]));
                ts_box u = coded ? quadtree_tight_union(tree, ct, level, k) : b;
                quadtree_store(tree, ct, level, k, b, u, coded);
            }
    }
}
