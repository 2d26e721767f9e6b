/* forest.c — the procedural forest (forest.h).
 *
 * The L-system (one per tree, parameters drawn from the tree's own random stream):
 *   axiom   A(0, l0, r0, 0)
 *   A(k, l, r, n) -> F(l, r, r')  [ /(phi_b) &(alpha_b) A(k+1, l*lat, r'*rho, 0) ]_b  /(137.5)
 *                    A(k, l*cont, r', n+1)
 * with r' = r * taper; a trunk (k = 0) apex sprouts no laterals for its first two
 * segments, apices of the highest order none at all. After the last iteration every
 * apex becomes a cluster of leaves [ /(theta_i) &(beta_i) L(size) ]. The turtle reads F as
 * a segment (a generalised cylinder with tropism bending it up a little), & as pitch about
 * the turtle's left axis, / as roll about its heading, [ ] as push/pop, L as a leaf.
 *
 * Watertightness along a branch: a segment starts from the ring (centre, frame, radius,
 * number of patches around) where the previous segment of the same branch ended, and the
 * ring frame is only ever parallel-transported (roll does not turn it), so consecutive
 * segments share their boundary control points exactly; around the ring the angles come
 * from one table indexed modulo n. Lateral branches start on their parent's axis, inside
 * it, as in the paper's trees.
 */
#include "scene/forest.h"
#include "base/parallel.h"

#include "lib/noise.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FOREST_PI 3.14159265358979323846
#define FOREST_SPACING 7.0       /* between neighbouring trees */
#define FOREST_MARGIN 20.0       /* terrain beyond the outermost trees */
#define FOREST_TERRAIN_PATCH 4.0 /* terrain patch size */
#define FOREST_SINK 0.5          /* trunk bases start below the ground */

/* ---- random numbers: a counter-based hash ---------------------------------------------- */

/* The splitmix64 finaliser: a bijective 64-bit mix. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* A stream: number i is mix64(key + i * odd), a pure function of (seed, stream, i). */
typedef struct frng {
    uint64_t key, ctr;
} frng;

static frng frng_make(uint32_t seed, uint64_t stream)
{
    frng r = {mix64(mix64((uint64_t)seed) ^ mix64(stream ^ 0x5851f42d4c957f2dull)), 0};
    return r;
}

static double frng_next(frng *r)
{
    uint64_t x = mix64(r->key + 0xd1342543de82ef95ull * ++r->ctr);
    return (double)(x >> 11) * (1.0 / 9007199254740992.0); /* [0, 1) */
}

static double frng_range(frng *r, double lo, double hi)
{
    return lo + (hi - lo) * frng_next(r);
}

/* ---- vectors ----------------------------------------------------------------------------- */

typedef struct v3 {
    double x, y, z;
} v3;

static v3 v3_make(double x, double y, double z)
{
    v3 v = {x, y, z};
    return v;
}
static v3 v3_add(v3 a, v3 b)
{
    return v3_make(a.x + b.x, a.y + b.y, a.z + b.z);
}
static v3 v3_sub(v3 a, v3 b)
{
    return v3_make(a.x - b.x, a.y - b.y, a.z - b.z);
}
static v3 v3_scale(v3 a, double s)
{
    return v3_make(a.x * s, a.y * s, a.z * s);
}
static double v3_dot(v3 a, v3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static v3 v3_cross(v3 a, v3 b)
{
    return v3_make(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static v3 v3_norm(v3 a)
{
    double l = sqrt(v3_dot(a, a));
    return l > 0.0 ? v3_scale(a, 1.0 / l) : a;
}

/* Rotates v about the unit axis k by angle a (radians), Rodrigues' formula. */
static v3 v3_rotate(v3 v, v3 k, double a)
{
    double c = cos(a), s = sin(a);
    v3 r = v3_add(v3_scale(v, c), v3_scale(v3_cross(k, v), s));
    return v3_add(r, v3_scale(k, v3_dot(k, v) * (1.0 - c)));
}

/* ---- output: patches moved to world space ---------------------------------------------- */

typedef struct forest_out {
    ts_scene *s;
    ts_error *err;
    double m[16]; /* object to world */
    double nm[9]; /* normal matrix: inverse transpose of m's linear part */
    double scale; /* |det|^(1/3): object units to world units, for amplitudes */
    uint32_t xform;
    ts_patch_attr base;
    /* put: write patch slots next, next + 1, ... (scene_put_patch) instead of appending */
    int put;
    uint32_t next;
} forest_out;

static int out_patch(forest_out *o, const v3 cp[16], const v3 n[4], const ts_patch_attr *a)
{
    if (!o->s) return TS_OK; /* counting only */
    double w[16][3], wn[4][3];
    const double *m = o->m;
    for (int k = 0; k < 16; k++) {
        const double q[3] = {cp[k].x, cp[k].y, cp[k].z};
        for (int r = 0; r < 3; r++) {
            w[k][r] = m[r * 4] * q[0] + m[r * 4 + 1] * q[1] + m[r * 4 + 2] * q[2] + m[r * 4 + 3];
            if (!(fabs(w[k][r]) <= FLT_MAX))
                return ts_error_set(o->err, TS_E_SCENE,
                                    "forest: a control point leaves the float range");
        }
    }
    for (int c = 0; c < 4; c++) {
        const double q[3] = {n[c].x, n[c].y, n[c].z};
        for (int r = 0; r < 3; r++)
            wn[c][r] = o->nm[r * 3] * q[0] + o->nm[r * 3 + 1] * q[1] + o->nm[r * 3 + 2] * q[2];
    }
    if (o->put) return scene_put_patch(o->s, o->next++, w, wn, a, o->err);
    return scene_add_patch_ex(o->s, (const double(*)[3])w, NULL, (const double(*)[3])wn, a, o->err);
}

static ts_patch_attr attr_make(const forest_out *o, double r, double g, double b)
{
    ts_patch_attr a = o->base;
    a.cs_r = (float)r, a.cs_g = (float)g, a.cs_b = (float)b;
    a.flags = 0u;
    a.disp_kind = TS_DISP_NONE;
    a.disp_octaves = 1u;
    a.disp_amplitude = 0.0f;
    a.disp_frequency = 1.0f;
    a.disp_lacunarity = 2.0f;
    a.disp_gain = 0.5f;
    a.xform = 0u;
    return a;
}

static void attr_displace(const forest_out *o, ts_patch_attr *a, uint32_t kind, double amp,
                          double freq, uint32_t octaves)
{
    a->disp_kind = kind;
    a->disp_amplitude = (float)(amp * o->scale);
    a->disp_frequency = (float)freq;
    a->disp_octaves = octaves;
    a->disp_lacunarity = 2.0f;
    a->disp_gain = 0.5f;
    a->xform = o->xform;
}

/* ---- terrain ------------------------------------------------------------------------------ */

typedef struct terrain {
    double ox, oz; /* noise offsets from the seed */
} terrain;

/* Height of the rolling hills at (x, z), object units. */
static double terrain_height(const terrain *t, double x, double z)
{
    double a = noise3((float)(x * 0.021 + t->ox), 0.37f, (float)(z * 0.021 + t->oz));
    double b = noise3((float)(x * 0.067 + t->oz), 1.61f, (float)(z * 0.067 + t->ox));
    return 3.0 * a + 0.8 * b;
}

static v3 terrain_normal(const terrain *t, double x, double z)
{
    const double h = 0.05;
    double dx = (terrain_height(t, x + h, z) - terrain_height(t, x - h, z)) / (2.0 * h);
    double dz = (terrain_height(t, x, z + h) - terrain_height(t, x, z - h)) / (2.0 * h);
    return v3_norm(v3_make(-dx, 1.0, -dz));
}

/* An n x n grid of bicubic patches over [-side/2, side/2]^2 whose control points sample
 * the hills on the (3n+1)^2 grid: neighbours share their boundary rows exactly. u runs
 * along z and v along x, so dP/du x dP/dv points up. */
static int terrain_emit(forest_out *o, const terrain *t, double side, int n, uint64_t *count)
{
    ts_patch_attr a = attr_make(o, 0.30, 0.34, 0.19);
    attr_displace(o, &a, TS_DISP_FBM, 0.12, 0.6, 5u);
    double step = side / (3.0 * n);
    for (int pv = 0; pv < n; pv++)
        for (int pu = 0; pu < n; pu++) {
            v3 cp[16], nn[4];
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++) {
                    double x = -0.5 * side + (3 * pv + j) * step;
                    double z = -0.5 * side + (3 * pu + i) * step;
                    cp[j * 4 + i] = v3_make(x, terrain_height(t, x, z), z);
                }
            static const int corner[4] = {0, 3, 12, 15};
            for (int c = 0; c < 4; c++)
                nn[c] = terrain_normal(t, cp[corner[c]].x, cp[corner[c]].z);
            int rc = out_patch(o, cp, nn, &a);
            if (rc != TS_OK) return rc;
            (*count)++;
        }
    return TS_OK;
}

/* ---- the L-system ------------------------------------------------------------------------- */

enum {
    SYM_A = 'A',
    SYM_F = 'F',
    SYM_PUSH = '[',
    SYM_POP = ']',
    SYM_PITCH = '&',
    SYM_ROLL = '/',
    SYM_LEAF = 'L'
};

/* A module: A(order, a = length, b = radius, n = segments so far), F(a = length,
 * b = start radius, c = end radius), & / (a = degrees), L(a = size). */
typedef struct lmod {
    uint8_t sym, order;
    uint16_t n;
    float a, b, c;
} lmod;

typedef struct lstr {
    lmod *m;
    size_t len, cap;
} lstr;

static int lstr_push(lstr *s, lmod m)
{
    if (s->len == s->cap) {
        size_t cap = s->cap ? s->cap * 2 : 256;
        lmod *p = realloc(s->m, cap * sizeof *p);
        if (!p) return -1;
        s->m = p;
        s->cap = cap;
    }
    s->m[s->len++] = m;
    return 0;
}

static lmod mod(int sym, int order, int n, double a, double b, double c)
{
    lmod m = {(uint8_t)sym, (uint8_t)order, (uint16_t)n, (float)a, (float)b, (float)c};
    return m;
}

/* The shape of one tree, drawn from its stream. */
typedef struct tree_shape {
    int iterations, max_order, leaves_per_tip;
    double taper, cont, lat_len, lat_rad, angle, tropism, leaf_size;
} tree_shape;

/* One derivation step: every A is rewritten, everything else copied. */
static int lsys_step(const lstr *in, lstr *out, frng *r, const tree_shape *t)
{
    out->len = 0;
    int bad = 0;
    for (size_t k = 0; k < in->len && !bad; k++) {
        lmod m = in->m[k];
        if (m.sym != SYM_A) {
            bad |= lstr_push(out, m);
            continue;
        }
        double l = m.a, rad = m.b, r1 = rad * t->taper * frng_range(r, 0.97, 1.03);
        bad |= lstr_push(out, mod(SYM_F, m.order, 0, l, rad, r1));
        int laterals = 0;
        if (m.order < t->max_order && !(m.order == 0 && m.n < 2))
            laterals = m.order == 0 ? 3 : (frng_next(r) < 0.45 ? 2 : 1);
        double phi0 = frng_range(r, 0.0, 360.0);
        for (int b = 0; b < laterals; b++) {
            double phi = phi0 + b * 360.0 / laterals + frng_range(r, -20.0, 20.0);
            double alpha = t->angle + frng_range(r, -10.0, 10.0);
            double ll = l * t->lat_len * frng_range(r, 0.85, 1.1);
            bad |= lstr_push(out, mod(SYM_PUSH, 0, 0, 0, 0, 0));
            bad |= lstr_push(out, mod(SYM_ROLL, 0, 0, phi, 0, 0));
            bad |= lstr_push(out, mod(SYM_PITCH, 0, 0, alpha, 0, 0));
            bad |= lstr_push(out, mod(SYM_A, m.order + 1, 0, ll, r1 * t->lat_rad, 0));
            bad |= lstr_push(out, mod(SYM_POP, 0, 0, 0, 0, 0));
        }
        bad |= lstr_push(out, mod(SYM_ROLL, 0, 0, 137.5 + frng_range(r, -10.0, 10.0), 0, 0));
        bad |= lstr_push(out, mod(SYM_A, m.order, m.n + 1, l * t->cont, r1, 0));
    }
    return bad ? -1 : 0;
}

/* The last step: apices become leaf clusters. */
static int lsys_leaves(const lstr *in, lstr *out, frng *r, const tree_shape *t)
{
    out->len = 0;
    int bad = 0;
    for (size_t k = 0; k < in->len && !bad; k++) {
        lmod m = in->m[k];
        if (m.sym != SYM_A) {
            bad |= lstr_push(out, m);
            continue;
        }
        double phi0 = frng_range(r, 0.0, 360.0);
        for (int i = 0; i < t->leaves_per_tip; i++) {
            bad |= lstr_push(out, mod(SYM_PUSH, 0, 0, 0, 0, 0));
            bad |= lstr_push(out, mod(SYM_ROLL, 0, 0, phi0 + i * 360.0 / t->leaves_per_tip, 0, 0));
            bad |= lstr_push(out, mod(SYM_PITCH, 0, 0, frng_range(r, 25.0, 70.0), 0, 0));
            bad |=
                lstr_push(out, mod(SYM_LEAF, 0, 0, t->leaf_size * frng_range(r, 0.8, 1.2), 0, 0));
            bad |= lstr_push(out, mod(SYM_POP, 0, 0, 0, 0, 0));
        }
    }
    return bad ? -1 : 0;
}

/* ---- the turtle ----------------------------------------------------------------------------- */

typedef struct turtle {
    v3 pos, h, l, u; /* position, heading, left, up (orthonormal) */
    v3 e1, e2;       /* ring frame, e1 x e2 = h; only parallel-transported */
    double rr;       /* ring radius */
    int ring;        /* 0: the next segment starts a new ring (after a pitch) */
    int around;      /* patches around this branch */
} turtle;

typedef struct tree_ctx {
    forest_out *o;
    ts_patch_attr bark[2]; /* trunk, branches */
    ts_patch_attr leaf;
    frng *r;
    const tree_shape *t;
    uint64_t bark_count, leaf_count;
} tree_ctx;

/* A segment: the generalised cylinder from the turtle's ring along a spine bent by
 * tropism towards +y, ending in a ring of radius r1. */
static int turtle_segment(tree_ctx *c, turtle *t, const lmod *m)
{
    if (!t->ring) {
        t->rr = m->b;
        t->around = t->rr > 0.12 ? 8 : t->rr > 0.045 ? 6 : 4;
        t->e1 = t->l;
        t->e2 = v3_cross(t->h, t->e1);
        t->ring = 1;
    }
    double len = m->a, r0 = t->rr, r1 = m->c;
    /* Tropism (Prusinkiewicz & Lindenmayer): turn H towards T by e |H x T|. */
    v3 h0 = t->h, axis = v3_cross(h0, v3_make(0, 1, 0));
    double al = sqrt(v3_dot(axis, axis)), ang = c->t->tropism * al;
    v3 h1 = h0, f1e1 = t->e1, f1e2 = t->e2, l1 = t->l, u1 = t->u;
    if (al > 1e-9) {
        v3 k = v3_scale(axis, 1.0 / al);
        h1 = v3_rotate(h0, k, ang);
        f1e1 = v3_rotate(t->e1, k, ang), f1e2 = v3_rotate(t->e2, k, ang);
        l1 = v3_rotate(t->l, k, ang), u1 = v3_rotate(t->u, k, ang);
    }
    v3 p3 = v3_add(t->pos, v3_scale(v3_norm(v3_add(h0, h1)), len));
    v3 spine[4] = {t->pos, v3_add(t->pos, v3_scale(h0, len / 3.0)),
                   v3_sub(p3, v3_scale(h1, len / 3.0)), p3};
    v3 fe1[4] = {t->e1, t->e1, f1e1, f1e1}, fe2[4] = {t->e2, t->e2, f1e2, f1e2};
    double rad[4] = {r0, r0 + (r1 - r0) / 3.0, r0 + 2.0 * (r1 - r0) / 3.0, r1};
    int n = t->around;
    double cs[8], sn[8];
    for (int s = 0; s < n; s++)
        cs[s] = cos(2.0 * FOREST_PI * s / n), sn[s] = sin(2.0 * FOREST_PI * s / n);
    double kk = 4.0 / 3.0 * tan(FOREST_PI / (2.0 * n)); /* cubic arc of 2 pi / n */
    const ts_patch_attr *a = &c->bark[m->order == 0 ? 0 : 1];
    for (int s = 0; s < n; s++) {
        int sa = s, sb = (s + 1) % n;
        v3 cp[16], nn[4];
        for (int j = 0; j < 4; j++) {
            v3 ca = v3_add(v3_scale(fe1[j], cs[sa]), v3_scale(fe2[j], sn[sa]));
            v3 cb = v3_add(v3_scale(fe1[j], cs[sb]), v3_scale(fe2[j], sn[sb]));
            v3 ta = v3_sub(v3_scale(fe2[j], cs[sa]), v3_scale(fe1[j], sn[sa]));
            v3 tb = v3_sub(v3_scale(fe2[j], cs[sb]), v3_scale(fe1[j], sn[sb]));
            v3 q[4] = {ca, v3_add(ca, v3_scale(ta, kk)), v3_sub(cb, v3_scale(tb, kk)), cb};
            for (int i = 0; i < 4; i++)
                cp[j * 4 + i] = v3_add(spine[j], v3_scale(q[i], rad[j]));
            if (j == 0) nn[0] = ca, nn[1] = cb;
            if (j == 3) nn[2] = ca, nn[3] = cb;
        }
        int rc = out_patch(c->o, cp, nn, a);
        if (rc != TS_OK) return rc;
        c->bark_count++;
    }
    t->pos = p3, t->h = h1, t->l = l1, t->u = u1;
    t->e1 = f1e1, t->e2 = f1e2, t->rr = r1;
    return TS_OK;
}

/* A leaf: a cupped, drooping blade along the heading, its tip collapsed to a point. */
static int turtle_leaf(tree_ctx *c, const turtle *t, double size)
{
    static const double width[4] = {0.12, 0.62, 0.52, 0.0};
    static const double across[4] = {-0.5, -1.0 / 6.0, 1.0 / 6.0, 0.5};
    double w = 0.55 * size, cup = 0.12 * size, droop = 0.25 * size;
    v3 cp[16], nn[4];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            double x = across[i] * w * width[j] * 2.0;
            double y =
                (fabs(across[i]) > 0.3 ? cup : 0.0) * width[j] - droop * (j / 3.0) * (j / 3.0);
            cp[j * 4 + i] = v3_add(t->pos, v3_add(v3_scale(t->h, size * j / 3.0),
                                                  v3_add(v3_scale(t->l, x), v3_scale(t->u, y))));
        }
    nn[0] = nn[1] = nn[2] = nn[3] = t->u;
    ts_patch_attr a = c->leaf;
    double g = frng_range(c->r, 0.85, 1.15);
    a.cs_r = (float)(a.cs_r * g), a.cs_g = (float)(a.cs_g * g), a.cs_b = (float)(a.cs_b * g);
    int rc = out_patch(c->o, cp, nn, &a);
    if (rc == TS_OK) c->leaf_count++;
    return rc;
}

static int turtle_run(tree_ctx *c, const lstr *s, turtle start)
{
    size_t depth = 0, cap = 0;
    for (size_t k = 0; k < s->len; k++)
        cap += s->m[k].sym == SYM_PUSH;
    turtle *stack = malloc((cap + 1) * sizeof *stack);
    if (!stack) return ts_error_set(c->o->err, TS_E_MEMORY, "forest: out of memory");
    turtle t = start;
    int rc = TS_OK;
    const double deg = FOREST_PI / 180.0;
    for (size_t k = 0; k < s->len && rc == TS_OK; k++) {
        const lmod *m = &s->m[k];
        switch (m->sym) {
        case SYM_F:
            rc = turtle_segment(c, &t, m);
            break;
        case SYM_PUSH:
            stack[depth++] = t;
            break;
        case SYM_POP:
            if (depth) t = stack[--depth];
            break;
        case SYM_PITCH:
            t.h = v3_rotate(t.h, t.l, m->a * deg);
            t.u = v3_rotate(t.u, t.l, m->a * deg);
            t.ring = 0;
            break;
        case SYM_ROLL:
            t.l = v3_rotate(t.l, t.h, m->a * deg);
            t.u = v3_rotate(t.u, t.h, m->a * deg);
            break;
        case SYM_LEAF:
            rc = turtle_leaf(c, &t, m->a);
            break;
        default:
            break;
        }
    }
    free(stack);
    return rc;
}

/* One tree at (x, z): its shape, derivation and interpretation from stream (seed, i). */
static int tree_emit(forest_out *o, const forest_params *fp, int index, v3 base, uint64_t *bark,
                     uint64_t *leaves)
{
    frng r = frng_make(fp->seed, 0x1000000ull + (uint64_t)index);
    double scale = frng_range(&r, 0.85, 1.15);
    tree_shape t = {
        .iterations = 6 + fp->detail,
        .max_order = 4,
        .leaves_per_tip = 3,
        .taper = frng_range(&r, 0.80, 0.86),
        .cont = frng_range(&r, 0.86, 0.94),
        .lat_len = frng_range(&r, 0.80, 0.92),
        .lat_rad = 0.62,
        .angle = frng_range(&r, 48.0, 65.0),
        .tropism = frng_range(&r, 0.04, 0.10),
        .leaf_size = 0.42,
    };
    tree_ctx c = {.o = o, .r = &r, .t = &t};
    double bark_tint = frng_range(&r, 0.85, 1.15);
    c.bark[0] = attr_make(o, 0.34 * bark_tint, 0.26 * bark_tint, 0.19 * bark_tint);
    attr_displace(o, &c.bark[0], TS_DISP_RIDGED, 0.03, 7.0, 3u);
    c.bark[1] = c.bark[0];
    attr_displace(o, &c.bark[1], TS_DISP_RIDGED, 0.008, 12.0, 2u);
    double hue = frng_range(&r, -0.06, 0.06);
    c.leaf = attr_make(o, 0.20 + hue, 0.42, 0.11 - 0.5 * hue);

    lstr a = {0}, b = {0};
    int rc = TS_OK;
    if (lstr_push(&a, mod(SYM_A, 0, 0, 1.45 * scale, 0.26 * scale, 0)) != 0) rc = TS_E_MEMORY;
    for (int it = 0; rc == TS_OK && it < t.iterations; it++) {
        if (lsys_step(&a, &b, &r, &t) != 0) rc = TS_E_MEMORY;
        lstr tmp = a;
        a = b, b = tmp;
    }
    if (rc == TS_OK && lsys_leaves(&a, &b, &r, &t) != 0) rc = TS_E_MEMORY;
    if (rc != TS_OK) {
        rc = ts_error_set(o->err, TS_E_MEMORY, "forest: out of memory");
    } else {
        /* Upright with a slight lean, a random turn about the vertical. */
        double turn = frng_range(&r, 0.0, 2.0 * FOREST_PI);
        v3 h = v3_norm(v3_make(frng_range(&r, -0.05, 0.05), 1.0, frng_range(&r, -0.05, 0.05)));
        v3 l = v3_norm(v3_cross(v3_make(cos(turn), 0.0, sin(turn)), h));
        turtle start = {.pos = base, .h = h, .l = l, .u = v3_cross(h, l), .ring = 0};
        rc = turtle_run(&c, &b, start);
    }
    free(a.m);
    free(b.m);
    *bark += c.bark_count;
    *leaves += c.leaf_count;
    return rc;
}

/* ---- counting the trees' patches first ---------------------------------------------------- */

/* Where tree i of a g x g grid of cells `side` wide stands, on the terrain. */
static v3 tree_base(const forest_params *fp, const terrain *ter, int g, double side, int i)
{
    frng pr = frng_make(fp->seed, 0x2000000ull + (uint64_t)i);
    double x = -0.5 * side + ((i % g) + 0.5 + frng_range(&pr, -0.35, 0.35)) * FOREST_SPACING;
    double z = -0.5 * side + ((i / g) + 0.5 + frng_range(&pr, -0.35, 0.35)) * FOREST_SPACING;
    return v3_make(x, terrain_height(ter, x, z) - FOREST_SINK, z);
}

/* The forest's trees: tree i of a g x g grid of cells `side` wide on terrain ter, made by
 * forest_tree into an output like o. */
typedef struct forest_trees {
    const forest_params *fp;
    const forest_out *o;
    const terrain *ter;
    int g;
    double side;
} forest_trees;

/* Tree i into o (tree_emit where tree_base stands it); its bark and leaves added. */
static int forest_tree(const forest_trees *t, forest_out *o, size_t i, uint64_t *bark,
                       uint64_t *leaves)
{
    return tree_emit(o, t->fp, (int)i, tree_base(t->fp, t->ter, t->g, t->side, (int)i), bark,
                     leaves);
}

/* Threads for the trees: forest_params.threads, else every processor (ts_parallel_threads). */
static unsigned forest_threads(const forest_params *fp)
{
    return ts_parallel_threads(fp->threads > 0 ? (unsigned)fp->threads : 0u);
}

/* Trees [begin, end) derived and interpreted without output (out_patch only counts without
 * a scene), on a thread of ts_parallel_for: how many patches each makes (per_tree). */
typedef struct tree_count {
    const forest_trees *t;
    uint32_t *per_tree;
    atomic_int failed;
} tree_count;

static void tree_count_run(void *ctx, size_t begin, size_t end)
{
    tree_count *c = ctx;
    ts_error e = {0};
    forest_out o = *c->t->o;
    o.s = NULL, o.err = &e;
    for (size_t i = begin; i < end && !atomic_load(&c->failed); ++i) {
        uint64_t bark = 0, leaves = 0;
        if (forest_tree(c->t, &o, i, &bark, &leaves) != TS_OK || bark + leaves > UINT32_MAX)
            atomic_store(&c->failed, 1);
        c->per_tree[i] = (uint32_t)(bark + leaves);
    }
    ts_error_clear(&e);
}

/* Each tree's patch count, counted on threads (a tenth of the time it takes to add them to
 * the scene), so that the scene's arrays are made that large at once (scene_reserve_patches)
 * instead of doubling while the trees are added, and each tree knows its slots; *total: their
 * sum. NULL when a tree fails (adding the trees one after the other says why) or there is no
 * memory for the table. */
static uint32_t *trees_counted(const forest_trees *t, uint64_t *total)
{
    tree_count c = {t, calloc((size_t)t->fp->trees, sizeof(uint32_t)), 0};
    *total = 0;
    if (!c.per_tree) return NULL;
    ts_parallel_for((size_t)t->fp->trees, 1, forest_threads(t->fp), tree_count_run, &c);
    if (atomic_load(&c.failed)) {
        free(c.per_tree);
        return NULL;
    }
    for (int i = 0; i < t->fp->trees; ++i)
        *total += c.per_tree[i];
    return c.per_tree;
}

/* The trees cut into `chunks` runs of consecutive trees (one a thread), each written into
 * its slots (first[i], from trees_counted) on a thread of ts_parallel_for, with its own
 * forest_out and error, and the bark and leaves it made. */

typedef struct trees_chunk {
    ts_error err;
    int rc;
    uint64_t bark, leaves;
} trees_chunk;

typedef struct trees_put {
    const forest_trees *t;
    const uint64_t *first; /* tree i's first slot; first[trees]: the end */
    size_t chunks;
    trees_chunk *out;
} trees_put;

static void trees_put_run(void *ctx, size_t begin, size_t end)
{
    const trees_put *t = ctx;
    size_t n = (size_t)t->t->fp->trees;
    for (size_t c = begin; c < end; ++c) {
        trees_chunk *r = &t->out[c];
        forest_out o = *t->t->o;
        o.err = &r->err, o.put = 1;
        r->rc = TS_OK;
        for (size_t i = n * c / t->chunks; r->rc == TS_OK && i < n * (c + 1) / t->chunks; ++i) {
            o.next = (uint32_t)t->first[i];
            r->rc = forest_tree(t->t, &o, i, &r->bark, &r->leaves);
            if (r->rc == TS_OK && o.next != t->first[i + 1])
                r->rc = ts_error_set(o.err, TS_E_INTERNAL,
                                     "forest: tree %zu made %llu patches, not %llu", i,
                                     (unsigned long long)(o.next - t->first[i]),
                                     (unsigned long long)(t->first[i + 1] - t->first[i]));
        }
    }
}

/* The trees added to s (t->o's scene) on threads, tree i into the per_tree[i] slots after
 * those of the trees before it: the same patches in the same slots as added one after the
 * other (tree_emit depends on the tree's index alone); s has room for them. Returns TS_OK, or
 * the error of the first chunk of trees that failed. */
static int trees_put_all(const forest_trees *t, const uint32_t *per_tree, forest_counts *cnt,
                         ts_error *err)
{
    ts_scene *s = t->o->s;
    size_t n = (size_t)t->fp->trees;
    unsigned threads = forest_threads(t->fp);
    size_t chunks = threads < n ? threads : n;
    uint64_t *first = malloc((n + 1) * sizeof *first);
    trees_chunk *out = calloc(chunks, sizeof *out);
    int rc = first && out ? TS_OK : ts_error_set(err, TS_E_MEMORY, "forest: out of memory");
    if (rc == TS_OK) {
        first[0] = s->patch_count;
        for (size_t i = 0; i < n; ++i)
            first[i + 1] = first[i] + per_tree[i];
        if (first[n] > s->patch_capacity)
            rc = ts_error_set(err, TS_E_INTERNAL, "forest: no room for the trees' patches");
    }
    if (rc == TS_OK) {
        trees_put p = {t, first, chunks, out};
        ts_parallel_for(chunks, 1, threads, trees_put_run, &p);
        for (size_t c = 0; c < chunks && rc == TS_OK; ++c) /* in tree order */
            if (out[c].rc != TS_OK) rc = ts_error_set(err, out[c].err.code, "%s", out[c].err.msg);
        for (size_t c = 0; c < chunks; ++c)
            cnt->bark += out[c].bark, cnt->leaves += out[c].leaves;
        if (rc == TS_OK) s->patch_count = (uint32_t)first[n];
    }
    for (size_t c = 0; out && c < chunks; ++c)
        ts_error_clear(&out[c].err);
    free(first), free(out);
    return rc;
}

/* ---- parameters and the whole forest ------------------------------------------------------ */

void forest_params_default(forest_params *fp)
{
    fp->trees = 100;
    fp->seed = 1u;
    fp->detail = 1;
}

int forest_parse_params(const char *text, forest_params *fp, char *why, size_t why_size)
{
    const char *p = text;
    for (;;) {
        while (*p == ' ' || *p == '\t' || *p == ',' || *p == '\n')
            p++;
        if (!*p) return 0;
        const char *key = p;
        while (*p && *p != '=' && *p != ' ' && *p != ',')
            p++;
        size_t klen = (size_t)(p - key);
        if (*p != '=') {
            snprintf(why, why_size, "expected key=value, got \"%.*s\"",
                     (int)(klen > 32 ? 32 : klen), key);
            return -1;
        }
        p++;
        errno = 0;
        char *end;
        long long v = strtoll(p, &end, 10);
        if (end == p || errno || (*end && *end != ' ' && *end != ',' && *end != '\t')) {
            snprintf(why, why_size, "%.*s needs an integer", (int)(klen > 32 ? 32 : klen), key);
            return -1;
        }
        p = end;
        if (klen == 5 && strncmp(key, "trees", 5) == 0) {
            if (v < 1 || v > FOREST_MAX_TREES) {
                snprintf(why, why_size, "trees must be in [1, %d], got %lld", FOREST_MAX_TREES, v);
                return -1;
            }
            fp->trees = (int)v;
        } else if (klen == 4 && strncmp(key, "seed", 4) == 0) {
            if (v < 0 || v > 0xffffffffll) {
                snprintf(why, why_size, "seed must be in [0, 4294967295], got %lld", v);
                return -1;
            }
            fp->seed = (uint32_t)v;
        } else if (klen == 6 && strncmp(key, "detail", 6) == 0) {
            if (v < 0 || v > FOREST_MAX_DETAIL) {
                snprintf(why, why_size, "detail must be in [0, %d], got %lld", FOREST_MAX_DETAIL,
                         v);
                return -1;
            }
            fp->detail = (int)v;
        } else {
            snprintf(why, why_size, "unknown parameter \"%.*s\" (trees, seed, detail)",
                     (int)(klen > 32 ? 32 : klen), key);
            return -1;
        }
    }
}

/* The inverse of the affine m (row-major 4x4); 0 when singular. */
static int affine_invert(const double m[16], double inv[16])
{
    double a = m[0] / m[15], b = m[1] / m[15], c = m[2] / m[15], d = m[4] / m[15], e = m[5] / m[15],
           f = m[6] / m[15], g = m[8] / m[15], h = m[9] / m[15], i = m[10] / m[15];
    double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    double det = a * A + b * B + c * C;
    if (!(fabs(det) > 1e-300) || !isfinite(det)) return 0;
    double r[9] = {A / det, -(b * i - c * h) / det, (b * f - c * e) / det,
                   B / det, (a * i - c * g) / det,  -(a * f - c * d) / det,
                   C / det, -(a * h - b * g) / det, (a * e - b * d) / det};
    double t[3] = {m[3] / m[15], m[7] / m[15], m[11] / m[15]};
    for (int row = 0; row < 3; row++) {
        inv[row * 4 + 0] = r[row * 3 + 0];
        inv[row * 4 + 1] = r[row * 3 + 1];
        inv[row * 4 + 2] = r[row * 3 + 2];
        inv[row * 4 + 3] = -(r[row * 3] * t[0] + r[row * 3 + 1] * t[1] + r[row * 3 + 2] * t[2]);
    }
    inv[12] = inv[13] = inv[14] = 0.0, inv[15] = 1.0;
    return 1;
}

int forest_generate(const forest_params *fp, const double object_to_world[16],
                    const ts_patch_attr *base, ts_scene *s, forest_counts *counts, ts_error *err)
{
    if (fp->trees < 1 || fp->trees > FOREST_MAX_TREES || fp->detail < 0 ||
        fp->detail > FOREST_MAX_DETAIL)
        return ts_error_set(err, TS_E_SCENE, "forest: parameters out of range");
    forest_out o = {.s = s, .err = err};
    const double *m = object_to_world;
    double inv[16];
    if (!(m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] != 0.0) || !affine_invert(m, inv))
        return ts_error_set(err, TS_E_SCENE,
                            "forest: the transformation must be affine and invertible");
    for (int k = 0; k < 16; k++)
        o.m[k] = m[k] / m[15];
    for (int r = 0; r < 3; r++) /* (L^-1)^T: row r of it is column r of L^-1 */
        for (int c = 0; c < 3; c++)
            o.nm[r * 3 + c] = inv[c * 4 + r];
    double det = o.m[0] * (o.m[5] * o.m[10] - o.m[6] * o.m[9]) -
                 o.m[1] * (o.m[4] * o.m[10] - o.m[6] * o.m[8]) +
                 o.m[2] * (o.m[4] * o.m[9] - o.m[5] * o.m[8]);
    o.scale = cbrt(fabs(det));
    if (base) {
        o.base = *base;
    } else {
        memset(&o.base, 0, sizeof o.base);
        ts_patch_attr d = {0};
        d.material = TS_MAT_MATTE;
        d.kd = 1.0f;
        d.emitter = TS_INVALID;
        o.base = d;
    }
    int rc = s ? scene_add_xform(s, inv, &o.xform, err) : TS_OK;
    if (rc != TS_OK) return rc;

    forest_counts cnt = {0, 0, 0, 0.0};
    int g = 1;
    while ((long)g * g < fp->trees)
        g++;
    double side = g * FOREST_SPACING;
    cnt.extent = side;
    frng tr = frng_make(fp->seed, 7u);
    terrain ter = {frng_range(&tr, 0.0, 500.0), frng_range(&tr, 0.0, 500.0)};
    double tside = side + 2.0 * FOREST_MARGIN;
    int tn = (int)ceil(tside / FOREST_TERRAIN_PATCH);
    /* The trees counted first, then added on threads, each into its slots; where they cannot
     * be counted (a tree that fails, or no memory for the table), one after the other, which
     * says why. */
    forest_trees trees = {fp, &o, &ter, g, side};
    uint32_t *per_tree = NULL;
    if (s) {
        uint64_t total = 0;
        per_tree = trees_counted(&trees, &total);
        if (per_tree) rc = scene_reserve_patches(s, (uint64_t)tn * tn + total, err);
    }
    if (rc == TS_OK) rc = terrain_emit(&o, &ter, tside, tn, &cnt.terrain);
    if (rc == TS_OK && per_tree) rc = trees_put_all(&trees, per_tree, &cnt, err);
    for (int i = 0; !per_tree && rc == TS_OK && i < fp->trees; i++)
        rc = forest_tree(&trees, &o, (size_t)i, &cnt.bark, &cnt.leaves);
    free(per_tree);
    if (counts) *counts = cnt;
    return rc;
}
