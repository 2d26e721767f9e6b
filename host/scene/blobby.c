/* blobby.c — blobby implicit surfaces as triangle meshes (blobby.h has the field and the
 * polygonization). */
#include "scene/blobby.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(char *why, size_t len, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, len, fmt, ap);
    va_end(ap);
    return -1;
}

/* ---- compiling ---- */

/* Inverts the 3x3 part of the row-vector matrix m (16 numbers) into leaf->inv with its
 * translation; 0 when m is singular or projective. */
static int leaf_matrix(blobby_leaf *l, const double *m)
{
    if (m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0) return 0;
    double a[3][3], t[3] = {m[12], m[13], m[14]};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            a[i][j] = m[4 * i + j];
    double c[3][3] = {
        {a[1][1] * a[2][2] - a[1][2] * a[2][1], a[0][2] * a[2][1] - a[0][1] * a[2][2],
         a[0][1] * a[1][2] - a[0][2] * a[1][1]},
        {a[1][2] * a[2][0] - a[1][0] * a[2][2], a[0][0] * a[2][2] - a[0][2] * a[2][0],
         a[0][2] * a[1][0] - a[0][0] * a[1][2]},
        {a[1][0] * a[2][1] - a[1][1] * a[2][0], a[0][1] * a[2][0] - a[0][0] * a[2][1],
         a[0][0] * a[1][1] - a[0][1] * a[1][0]},
    };
    double det = a[0][0] * c[0][0] + a[0][1] * c[1][0] + a[0][2] * c[2][0];
    if (!(fabs(det) > 1e-300) || !isfinite(det)) return 0;
    double frob = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            l->inv[3 * i + j] = c[i][j] / det;
            frob += l->inv[3 * i + j] * l->inv[3 * i + j];
        }
    for (int j = 0; j < 3; j++)
        l->inv[9 + j] = -(t[0] * l->inv[j] + t[1] * l->inv[3 + j] + t[2] * l->inv[6 + j]);
    /* The smallest semi-axis of the image of the unit ball is 1 / the largest singular value
     * of the inverse, at least 1 / its Frobenius norm. */
    l->size = 1.0 / sqrt(frob);
    /* The box of the image of the unit ball, centred on the translation. */
    for (int j = 0; j < 3; j++) {
        double e = sqrt(a[0][j] * a[0][j] + a[1][j] * a[1][j] + a[2][j] * a[2][j]);
        l->lo[j] = t[j] - e, l->hi[j] = t[j] + e;
    }
    return 1;
}

/* Blob space to object space: q M (the inverse of l->inv; only for segment ends). */
static void leaf_to_object(const double *m, const double q[3], double out[3])
{
    for (int j = 0; j < 3; j++)
        out[j] = q[0] * m[j] + q[1] * m[4 + j] + q[2] * m[8 + j] + m[12 + j];
}

static int leaf_segment(blobby_leaf *l, const double *f)
{
    double r = f[6];
    if (!(r > 0.0) || !isfinite(r) || !leaf_matrix(l, f + 7)) return 0;
    memcpy(l->a, f, sizeof l->a);
    memcpy(l->b, f + 3, sizeof l->b);
    l->inv_r2 = 1.0 / (r * r);
    l->size *= r;
    const double *m = f + 7;
    double ea[3], eb[3];
    leaf_to_object(m, l->a, ea);
    leaf_to_object(m, l->b, eb);
    for (int j = 0; j < 3; j++) { /* the boxes of the two end spheres hold the sausage */
        double e = r * sqrt(m[j] * m[j] + m[4 + j] * m[4 + j] + m[8 + j] * m[8 + j]);
        l->lo[j] = fmin(ea[j], eb[j]) - e, l->hi[j] = fmax(ea[j], eb[j]) + e;
    }
    return 1;
}

/* How many operands a combining opcode takes at code[c] (its count for 0-3); 0 if unknown. */
static size_t op_operands(int code, const double *c, size_t left, size_t *skip)
{
    if (code >= 0 && code <= 3) {
        if (left < 1) return 0;
        *skip = 1;
        return c[0] >= 1.0 ? (size_t)c[0] : 0; /* a count below one: none (not a size_t) */
    }
    *skip = 0;
    return code == 4 || code == 5 ? 2 : code == 6 || code == 7 ? 1 : 0;
}

/* Compiles the leaf instruction at code[at] (opcode code_c >= 1000, its float index at
 * code[*c], which *c passes) into b's next leaf and grows b's box by it (*have_box: the box
 * holds a leaf already). 0, or -1 with why set; b is freed by the caller. */
static int compile_leaf(ts_blobby *b, blobby_op *op, unsigned k, size_t at, const double *code,
                        size_t ncode, size_t *c, const double *floats, size_t nfloats,
                        int *have_box, char *why, size_t why_len)
{
    static const size_t need[3] = {1, 16, 23};
    int code_c = op->code;
    if (code_c == 1003 || code_c == 1004 || code_c == 9000)
        return fail(why, why_len, "instruction %u (code[%zu]): %s (opcode %d) is not supported", k,
                    at,
                    code_c == 1003   ? "a repelling plane"
                    : code_c == 1004 ? "a field plug-in"
                                     : "an AIR dynamic blob op",
                    code_c);
    if (code_c > 1002 || *c >= ncode)
        return fail(why, why_len,
                    *c >= ncode ? "instruction %u (code[%zu]): opcode %d lacks its operand"
                                : "instruction %u (code[%zu]): unknown opcode %d",
                    k, at, code_c);
    double fd = code[(*c)++]; /* the first float's index: not negative, within floats */
    if (!(fd >= 0.0 && fd <= (double)nfloats))
        return fail(why, why_len,
                    "instruction %u (code[%zu]): opcode %d reads floats from %g, but there are %zu",
                    k, at, code_c, fd, nfloats);
    size_t f = (size_t)fd, n = need[code_c - 1000];
    if (f > nfloats || nfloats - f < n)
        return fail(why, why_len,
                    "instruction %u (code[%zu]): opcode %d reads floats %zu to %zu, but there are "
                    "%zu",
                    k, at, code_c, f, f + n - 1, nfloats);
    blobby_leaf *l = &b->leaf[b->nleaf];
    l->code = code_c;
    int ok = 1;
    if (code_c == 1000)
        l->value = floats[f], ok = isfinite(l->value);
    else if (code_c == 1001)
        ok = leaf_matrix(l, floats + f), l->size *= 0.5;
    else
        ok = leaf_segment(l, floats + f), l->size *= 0.5;
    if (!ok)
        return fail(why, why_len, "instruction %u (code[%zu]): %s", k, at,
                    code_c == 1000   ? "the constant is not finite"
                    : code_c == 1001 ? "the ellipsoid's matrix is singular or projective"
                                     : "the segment's radius is not positive, or its "
                                       "matrix is singular or projective");
    if (code_c != 1000) {
        for (int j = 0; j < 3; j++) {
            b->lo[j] = *have_box ? fmin(b->lo[j], l->lo[j]) : l->lo[j];
            b->hi[j] = *have_box ? fmax(b->hi[j], l->hi[j]) : l->hi[j];
        }
        *have_box = 1;
    }
    op->leaf = b->nleaf++;
    return 0;
}

/* Compiles the combining instruction k at code[at] (opcode 0-7; its count, for 0-3, and
 * operands from code[*c], which *c passes): the operands must be earlier instructions.
 * Clears b->sum_only unless it is a sum (0) or an identity (7). 0, or -1 with why set. */
static int compile_combine(ts_blobby *b, blobby_op *op, unsigned k, size_t at, const double *code,
                           size_t ncode, size_t *c, char *why, size_t why_len)
{
    int code_c = op->code;
    size_t skip = 0, n = op_operands(code_c, code + *c, ncode - *c, &skip);
    if (n == 0 || code_c < 0 || code_c > 7)
        return fail(why, why_len, "instruction %u (code[%zu]): %s %d", k, at,
                    code_c >= 0 && code_c <= 3 ? "no operands for opcode" : "unknown opcode",
                    code_c);
    *c += skip;
    if (ncode - *c < n)
        return fail(why, why_len, "instruction %u (code[%zu]): opcode %d needs %zu operands", k, at,
                    code_c, n);
    op->first = b->noperand, op->n = (unsigned)n;
    for (size_t i = 0; i < n; i++) {
        double x = code[(*c)++];
        if (!(x >= 0.0 && x < (double)k))
            return fail(why, why_len,
                        "instruction %u (code[%zu]): operand %g is not an earlier instruction "
                        "(0 to %d)",
                        k, at, x, (int)k - 1);
        b->operand[b->noperand++] = (unsigned)x;
    }
    if (code_c != 0 && code_c != 7) b->sum_only = 0;
    return 0;
}

/* Keeps b->sum_only only if the last instruction sums every leaf exactly once: walking down
 * from the result, each instruction is reached by one path and every leaf is reached.
 * 0, or -1 ("out of memory") with why set. */
static int compile_check_sum(ts_blobby *b, char *why, size_t why_len)
{
    unsigned *uses = calloc(b->nop, sizeof *uses);
    unsigned *stack = malloc((b->noperand + 1) * sizeof *stack), top = 0;
    if (!uses || !stack) {
        free(uses);
        free(stack);
        return fail(why, why_len, "out of memory");
    }
    stack[top++] = b->nop - 1;
    while (top > 0 && b->sum_only) {
        unsigned k = stack[--top];
        if (++uses[k] > 1) b->sum_only = 0;
        const blobby_op *op = &b->op[k];
        if (op->code < 1000)
            for (unsigned i = 0; i < op->n && top <= b->noperand; i++)
                stack[top++] = b->operand[op->first + i];
    }
    for (unsigned k = 0; k < b->nop && b->sum_only; k++)
        if (b->op[k].code >= 1000 && uses[k] != 1) b->sum_only = 0;
    free(stack);
    free(uses);
    return 0;
}

int blobby_compile(ts_blobby *b, const double *code, size_t ncode, const double *floats,
                   size_t nfloats, char *why, size_t why_len)
{
    memset(b, 0, sizeof *b);
    /* At most one instruction per two code words, one leaf per instruction, one operand per
     * code word. */
    b->op = calloc(ncode / 2 + 1, sizeof *b->op);
    b->leaf = calloc(ncode / 2 + 1, sizeof *b->leaf);
    b->operand = calloc(ncode + 1, sizeof *b->operand);
    if (!b->op || !b->leaf || !b->operand) {
        blobby_free(b);
        return fail(why, why_len, "out of memory");
    }
    b->sum_only = 1;
    int have_box = 0;
    for (size_t c = 0; c < ncode;) {
        size_t at = c;
        unsigned k = b->nop;
        blobby_op *op = &b->op[b->nop++];
        op->code = (int)code[c++];
        int rc = op->code >= 1000 ? compile_leaf(b, op, k, at, code, ncode, &c, floats, nfloats,
                                                 &have_box, why, why_len)
                                  : compile_combine(b, op, k, at, code, ncode, &c, why, why_len);
        if (rc != 0) {
            blobby_free(b);
            return -1;
        }
    }
    if (b->nop == 0 || !have_box) {
        fail(why, why_len,
             b->nop == 0 ? "the program is empty"
                         : "no ellipsoid or segment: the surface has no bounds");
        blobby_free(b);
        return -1;
    }
    if (b->sum_only && compile_check_sum(b, why, why_len) != 0) {
        blobby_free(b);
        return -1;
    }
    return 0;
}

void blobby_free(ts_blobby *b)
{
    free(b->op);
    free(b->leaf);
    free(b->operand);
    memset(b, 0, sizeof *b);
}

/* ---- the field ---- */

static double leaf_value(const blobby_leaf *l, const double p[3])
{
    if (l->code == 1000) return l->value;
    for (int j = 0; j < 3; j++)
        if (p[j] <= l->lo[j] || p[j] >= l->hi[j]) return 0.0;
    double q[3];
    for (int j = 0; j < 3; j++)
        q[j] = p[0] * l->inv[j] + p[1] * l->inv[3 + j] + p[2] * l->inv[6 + j] + l->inv[9 + j];
    double r2;
    if (l->code == 1001) {
        r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
    } else {
        double ab[3], d[3], dd = 0.0, t = 0.0;
        for (int j = 0; j < 3; j++)
            ab[j] = l->b[j] - l->a[j], d[j] = q[j] - l->a[j], dd += ab[j] * ab[j],
            t += d[j] * ab[j];
        t = dd > 0.0 ? fmin(fmax(t / dd, 0.0), 1.0) : 0.0;
        r2 = 0.0;
        for (int j = 0; j < 3; j++) {
            double e = d[j] - t * ab[j];
            r2 += e * e;
        }
        r2 *= l->inv_r2;
    }
    if (r2 >= 1.0) return 0.0;
    double s = 1.0 - r2;
    return s * s * s;
}

/* Runs the program with the leaves' values given (vals: one per instruction, scratch). */
static double run_program(const ts_blobby *b, const double *leaf_vals, double *vals)
{
    for (unsigned k = 0; k < b->nop; k++) {
        const blobby_op *op = &b->op[k];
        const unsigned *o = b->operand + op->first;
        double v;
        switch (op->code) {
        case 0:
            v = 0.0;
            for (unsigned i = 0; i < op->n; i++)
                v += vals[o[i]];
            break;
        case 1:
            v = 1.0;
            for (unsigned i = 0; i < op->n; i++)
                v *= vals[o[i]];
            break;
        case 2:
        case 3:
            v = vals[o[0]];
            for (unsigned i = 1; i < op->n; i++)
                v = op->code == 2 ? fmax(v, vals[o[i]]) : fmin(v, vals[o[i]]);
            break;
        case 4:
            v = vals[o[0]] - vals[o[1]];
            break;
        case 5:
            v = vals[o[1]] != 0.0 ? vals[o[0]] / vals[o[1]] : 0.0;
            break;
        case 6:
            v = -vals[o[0]];
            break;
        case 7:
            v = vals[o[0]];
            break;
        default:
            v = leaf_vals[op->leaf];
            break;
        }
        vals[k] = v;
    }
    return vals[b->nop - 1];
}

double blobby_field(const ts_blobby *b, const double p[3], double *leaf_values)
{
    double *lv = leaf_values ? leaf_values : malloc((b->nleaf + b->nop) * sizeof *lv);
    double *vals = malloc(b->nop * sizeof *vals);
    double f = 0.0;
    if (lv && vals) {
        for (unsigned i = 0; i < b->nleaf; i++)
            lv[i] = leaf_value(&b->leaf[i], p);
        f = run_program(b, lv, vals);
    }
    if (lv != leaf_values) free(lv);
    free(vals);
    return f;
}

/* ---- the polygonizer ---- */

/* Leaves binned on a coarse grid over the box, so that a point visits only the leaves whose
 * support may hold it (a leaf is 0 outside its box). Constants are in every bin. */
typedef struct leaf_bins {
    unsigned n[3];
    double lo[3], inv_cell[3];
    unsigned *start, *list; /* CSR: bin i's leaves are list[start[i] .. start[i + 1]) */
} leaf_bins;

static unsigned bin_coord(const leaf_bins *g, int j, double x)
{
    double c = floor((x - g->lo[j]) * g->inv_cell[j]);
    return c < 0.0 ? 0u : c >= (double)g->n[j] ? g->n[j] - 1u : (unsigned)c;
}

static int bins_make(const ts_blobby *b, leaf_bins *g)
{
    memset(g, 0, sizeof *g);
    unsigned per = (unsigned)fmin(32.0, fmax(1.0, ceil(2.0 * cbrt((double)b->nleaf))));
    for (int j = 0; j < 3; j++) {
        g->n[j] = per, g->lo[j] = b->lo[j];
        double side = b->hi[j] - b->lo[j];
        g->inv_cell[j] = side > 0.0 ? per / side : 0.0;
    }
    size_t nb = (size_t)per * per * per, total = 0;
    g->start = calloc(nb + 1, sizeof *g->start);
    if (!g->start) return -1;
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) {
            size_t run = 0;
            for (size_t i = 0; i <= nb; i++) {
                size_t c = g->start[i];
                g->start[i] = (unsigned)run;
                run += c;
            }
            total = run;
            g->list = malloc((total ? total : 1) * sizeof *g->list);
            if (!g->list) return -1;
        }
        unsigned *fill = pass == 1 ? calloc(nb, sizeof *fill) : NULL;
        if (pass == 1 && !fill) return -1;
        for (unsigned i = 0; i < b->nleaf; i++) {
            const blobby_leaf *l = &b->leaf[i];
            unsigned lo[3], hi[3];
            for (int j = 0; j < 3; j++) {
                lo[j] = l->code == 1000 ? 0u : bin_coord(g, j, l->lo[j]);
                hi[j] = l->code == 1000 ? g->n[j] - 1u : bin_coord(g, j, l->hi[j]);
            }
            for (unsigned z = lo[2]; z <= hi[2]; z++)
                for (unsigned y = lo[1]; y <= hi[1]; y++)
                    for (unsigned x = lo[0]; x <= hi[0]; x++) {
                        size_t bi = ((size_t)z * per + y) * per + x;
                        if (pass == 0)
                            g->start[bi]++;
                        else
                            g->list[g->start[bi] + fill[bi]++] = i;
                    }
        }
        free(fill);
    }
    return 0;
}

static void bins_free(leaf_bins *g)
{
    free(g->start);
    free(g->list);
}

/* What evaluating the field at many points needs. */
typedef struct field_eval {
    const ts_blobby *b;
    leaf_bins bins;
    double *leaf_vals, *vals; /* scratch: nleaf and nop entries */
} field_eval;

/* The field at p; with weights, also each leaf's value (only those in p's bin are set,
 * the rest are 0). */
static double eval_at(field_eval *e, const double p[3], int weights)
{
    const ts_blobby *b = e->b;
    const leaf_bins *g = &e->bins;
    size_t bi = ((size_t)bin_coord(g, 2, p[2]) * g->n[1] + bin_coord(g, 1, p[1])) * g->n[0] +
                bin_coord(g, 0, p[0]);
    const unsigned *l = g->list + g->start[bi], n = g->start[bi + 1] - g->start[bi];
    if (b->sum_only && !weights) {
        double f = 0.0;
        for (unsigned i = 0; i < n; i++)
            f += leaf_value(&b->leaf[l[i]], p);
        return f;
    }
    memset(e->leaf_vals, 0, b->nleaf * sizeof *e->leaf_vals);
    for (unsigned i = 0; i < n; i++)
        e->leaf_vals[l[i]] = leaf_value(&b->leaf[l[i]], p);
    return run_program(b, e->leaf_vals, e->vals);
}

/* The polygonizer's state. */
typedef struct net_ctx {
    field_eval e;
    const double *leaf_cs;
    double origin[3], h;
    size_t n[3];    /* grid points per axis */
    double *val;    /* field - threshold per grid point; the border is -1 (outside) */
    unsigned *vert; /* per cube: its vertex + 1, 0 for none */
    blobby_mesh *m;
    size_t vcap, qcap;
} net_ctx;

static size_t point_index(const net_ctx *c, size_t x, size_t y, size_t z)
{
    return (z * c->n[1] + y) * c->n[0] + x;
}

static size_t cube_index(const net_ctx *c, size_t x, size_t y, size_t z)
{
    return (z * (c->n[1] - 1) + y) * (c->n[0] - 1) + x;
}

static void grid_point(const net_ctx *c, size_t x, size_t y, size_t z, double p[3])
{
    p[0] = c->origin[0] + (double)x * c->h;
    p[1] = c->origin[1] + (double)y * c->h;
    p[2] = c->origin[2] + (double)z * c->h;
}

/* The field minus the threshold at p and its gradient (central differences). */
static double field_grad(net_ctx *c, const double p[3], double g[3])
{
    double eps = 1e-4 * c->h;
    for (int j = 0; j < 3; j++) {
        double q[3] = {p[0], p[1], p[2]};
        q[j] = p[j] + eps;
        double fp = eval_at(&c->e, q, 0);
        q[j] = p[j] - eps;
        g[j] = (fp - eval_at(&c->e, q, 0)) / (2.0 * eps);
    }
    return eval_at(&c->e, p, 0) - BLOBBY_THRESHOLD;
}

/* The root of the field on the segment from a (inside, value fa > 0) to b (outside,
 * fb <= 0), by false position with the Illinois rule. */
static void segment_root(net_ctx *c, const double a[3], const double b[3], double fa, double fb,
                         double x[3])
{
    double ta = 0.0, tb = 1.0;
    int side = 0;
    for (int it = 0; it < 80; it++) {
        double t = ta + (tb - ta) * fa / (fa - fb);
        for (int j = 0; j < 3; j++)
            x[j] = a[j] + t * (b[j] - a[j]);
        double f = eval_at(&c->e, x, 0) - BLOBBY_THRESHOLD;
        if (f == 0.0 || tb - ta < 1e-13) break;
        if (f > 0.0) {
            ta = t, fa = f;
            if (side == 1) fb *= 0.5;
            side = 1;
        } else {
            tb = t, fb = f;
            if (side == -1) fa *= 0.5;
            side = -1;
        }
    }
}

/* The vertex of cube (x, y, z), whose corners' signs differ: the mean of the points where
 * the surface crosses its edges (linearly interpolated), moved onto the surface by Newton
 * steps along the gradient; if those leave the cube's neighbourhood, the root on the first
 * crossing edge instead. Its normal is the unit negated gradient (the field falls
 * outwards), its colour the leaves' weighted by their values. */
static int cube_vertex(net_ctx *c, size_t x, size_t y, size_t z)
{
    blobby_mesh *m = c->m;
    if (m->nvert == c->vcap) {
        size_t cap = c->vcap ? 2 * c->vcap : 1024;
        double(*p)[3] = realloc(m->p, cap * sizeof *p);
        if (p) m->p = p;
        double(*n)[3] = p ? realloc(m->n, cap * sizeof *n) : NULL;
        if (n) m->n = n;
        double(*cs)[3] = n && c->leaf_cs ? realloc(m->cs, cap * sizeof *cs) : NULL;
        if (cs) m->cs = cs;
        if (!p || !n || (c->leaf_cs && !cs)) return -1;
        c->vcap = cap;
    }
    double mean[3] = {0, 0, 0}, first_a[3] = {0}, first_b[3] = {0}, fa0 = 0.0, fb0 = 0.0;
    int count = 0;
    for (int k = 0; k < 8; k++) /* the 12 edges: from each corner to a higher neighbour */
        for (int axis = 0; axis < 3; axis++) {
            if (k >> axis & 1) continue;
            int k2 = k | 1 << axis;
            size_t ax = x + (size_t)(k & 1), ay = y + (size_t)(k >> 1 & 1),
                   az = z + (size_t)(k >> 2 & 1);
            size_t bx = x + (size_t)(k2 & 1), by = y + (size_t)(k2 >> 1 & 1),
                   bz = z + (size_t)(k2 >> 2 & 1);
            double va = c->val[point_index(c, ax, ay, az)], vb = c->val[point_index(c, bx, by, bz)];
            if ((va > 0.0) == (vb > 0.0)) continue;
            double pa[3], pb[3], t = va / (va - vb);
            grid_point(c, ax, ay, az, pa);
            grid_point(c, bx, by, bz, pb);
            for (int j = 0; j < 3; j++)
                mean[j] += pa[j] + t * (pb[j] - pa[j]);
            if (count++ == 0) {
                int a_in = va > 0.0;
                memcpy(first_a, a_in ? pa : pb, sizeof first_a);
                memcpy(first_b, a_in ? pb : pa, sizeof first_b);
                fa0 = a_in ? va : vb, fb0 = a_in ? vb : va;
            }
        }
    double *p = m->p[m->nvert], *n = m->n[m->nvert], g[3];
    for (int j = 0; j < 3; j++)
        p[j] = mean[j] / count;
    double centre[3];
    grid_point(c, x, y, z, centre);
    int ok = 0;
    for (int it = 0; it < 20; it++) {
        double f = field_grad(c, p, g), g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if (fabs(f) < 1e-13) {
            ok = 1;
            break;
        }
        if (!(g2 > 0.0) || !isfinite(g2)) break;
        for (int j = 0; j < 3; j++)
            p[j] -= f * g[j] / g2;
    }
    for (int j = 0; j < 3; j++) /* within the cube and its neighbours */
        if (!(p[j] > centre[j] - c->h && p[j] < centre[j] + 2.0 * c->h)) ok = 0;
    if (!ok) segment_root(c, first_a, first_b, fa0, fb0, p);
    (void)field_grad(c, p, g);
    double len = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    for (int j = 0; j < 3; j++) /* zero where the gradient vanishes: the polygon's own */
        n[j] = len > 0.0 && isfinite(len) ? -g[j] / len : 0.0;
    if (c->leaf_cs) {
        double w = 0.0, *cs = m->cs[m->nvert];
        (void)eval_at(&c->e, p, 1);
        cs[0] = cs[1] = cs[2] = 0.0;
        for (unsigned i = 0; i < c->e.b->nleaf; i++) {
            double v = c->e.b->leaf[i].code == 1000 ? 0.0 : c->e.leaf_vals[i];
            if (v <= 0.0) continue;
            w += v;
            for (int j = 0; j < 3; j++)
                cs[j] += v * c->leaf_cs[3 * i + (unsigned)j];
        }
        for (int j = 0; j < 3; j++)
            cs[j] = w > 0.0 ? cs[j] / w : c->leaf_cs[j];
    }
    c->vert[cube_index(c, x, y, z)] = (unsigned)++m->nvert;
    return 0;
}

/* The quad across the grid edge from point (x, y, z) along `axis`, whose ends' signs
 * differ: the vertices of the four cubes around it, counter-clockwise seen from outside. */
static int edge_quad(net_ctx *c, size_t x, size_t y, size_t z, int axis)
{
    blobby_mesh *m = c->m;
    if (m->nquad >= BLOBBY_MAX_QUADS) return -2;
    if (m->nquad == c->qcap) {
        size_t cap = c->qcap ? 2 * c->qcap : 2048;
        unsigned(*q)[4] = realloc(m->quad, cap * sizeof *q);
        if (!q) return -1;
        m->quad = q, c->qcap = cap;
    }
    /* The two other axes (u, v) with u x v = axis; the cubes at (u-1, v-1), (u, v-1),
     * (u, v), (u-1, v) in that plane go counter-clockwise about +axis. */
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    static const int du[4] = {-1, 0, 0, -1}, dv[4] = {-1, -1, 0, 0};
    size_t at[3] = {x, y, z};
    unsigned q[4];
    for (int k = 0; k < 4; k++) {
        size_t cc[3] = {at[0], at[1], at[2]};
        cc[u] = (size_t)((ptrdiff_t)cc[u] + du[k]);
        cc[v] = (size_t)((ptrdiff_t)cc[v] + dv[k]);
        size_t ci = cube_index(c, cc[0], cc[1], cc[2]);
        if (!c->vert[ci] && cube_vertex(c, cc[0], cc[1], cc[2])) return -1;
        q[k] = c->vert[ci] - 1u;
    }
    int inside_low = c->val[point_index(c, x, y, z)] > 0.0; /* outwards is +axis */
    unsigned *out = m->quad[m->nquad++];
    for (int k = 0; k < 4; k++)
        out[k] = inside_low ? q[k] : q[3 - k];
    return 0;
}

/* BLOBBY_MAX_WORK, or less when $TESSERA_BLOBBY_MAX_WORK says so. */
static double blobby_max_work(void)
{
    const char *env = getenv("TESSERA_BLOBBY_MAX_WORK");
    char *end;
    double v = env && *env ? strtod(env, &end) : 0.0;
    return env && *env && !*end && v >= 1.0 && v < BLOBBY_MAX_WORK ? v : BLOBBY_MAX_WORK;
}

int blobby_polygonize(const ts_blobby *b, const double *leaf_cs, blobby_mesh *m, char *why,
                      size_t why_len)
{
    memset(m, 0, sizeof *m);
    net_ctx c;
    memset(&c, 0, sizeof c);
    c.e.b = b, c.leaf_cs = leaf_cs, c.m = m;
    /* The cell: BLOBBY_CELLS_PER_RADIUS across the smallest leaf, within the bounds. */
    double longest = 0.0, smallest = INFINITY;
    for (int j = 0; j < 3; j++)
        longest = fmax(longest, b->hi[j] - b->lo[j]);
    for (unsigned i = 0; i < b->nleaf; i++)
        if (b->leaf[i].code != 1000) smallest = fmin(smallest, b->leaf[i].size);
    double h = smallest / BLOBBY_CELLS_PER_RADIUS;
    h = fmin(fmax(h, longest / BLOBBY_MAX_CELLS), longest / BLOBBY_MIN_CELLS);
    int rc = bins_make(b, &c.e.bins);
    /* Leaf evaluations per field value: the leaves of a bin on average, and every leaf's
     * value cleared for a general program. The grid is coarsened until sampling it costs at
     * most BLOBBY_MAX_WORK of them, so that no file makes reading it take minutes. */
    const leaf_bins *g = &c.e.bins;
    double per_eval = 1.0, max_work = blobby_max_work();
    if (rc == 0) {
        size_t nb = (size_t)g->n[0] * g->n[1] * g->n[2];
        per_eval += (double)g->start[nb] / (double)nb + (b->sum_only ? 0.0 : (double)b->nleaf);
    }
    for (;;) {
        double points = 1.0;
        for (int j = 0; j < 3; j++)
            points *= ceil((b->hi[j] - b->lo[j]) / h) + 3.0;
        if (points * per_eval <= max_work) break;
        h *= 1.25;
    }
    c.h = h;
    m->coarse = h > 1.5 * smallest; /* under 2 cells across the smallest blob's radius */
    for (int j = 0; j < 3; j++) {
        c.n[j] = (size_t)ceil((b->hi[j] - b->lo[j]) / h) + 3; /* a border point each side */
        c.origin[j] = 0.5 * (b->lo[j] + b->hi[j]) - 0.5 * (double)(c.n[j] - 1) * h;
    }
    m->cell = h;
    size_t points = c.n[0] * c.n[1] * c.n[2], cubes = (c.n[0] - 1) * (c.n[1] - 1) * (c.n[2] - 1);
    c.val = rc == 0 ? malloc(points * sizeof *c.val) : NULL;
    c.vert = rc == 0 ? calloc(cubes, sizeof *c.vert) : NULL;
    c.e.leaf_vals = malloc((b->nleaf + 1) * sizeof *c.e.leaf_vals);
    c.e.vals = malloc(b->nop * sizeof *c.e.vals);
    if (rc == 0 && !(c.val && c.vert && c.e.leaf_vals && c.e.vals)) rc = -1;
    for (size_t z = 0; rc == 0 && z < c.n[2]; z++) /* the field; the border stays outside */
        for (size_t y = 0; y < c.n[1]; y++)
            for (size_t x = 0; x < c.n[0]; x++) {
                int border = x == 0 || y == 0 || z == 0 || x == c.n[0] - 1 || y == c.n[1] - 1 ||
                             z == c.n[2] - 1;
                double p[3];
                grid_point(&c, x, y, z, p);
                c.val[point_index(&c, x, y, z)] =
                    border ? -1.0 : eval_at(&c.e, p, 0) - BLOBBY_THRESHOLD;
            }
    /* One quad per grid edge the surface crosses. An inside point is never on the border,
     * so the four cubes around such an edge exist. */
    for (size_t z = 0; rc == 0 && z < c.n[2]; z++)
        for (size_t y = 0; rc == 0 && y < c.n[1]; y++)
            for (size_t x = 0; rc == 0 && x < c.n[0]; x++) {
                size_t at[3] = {x, y, z};
                int in = c.val[point_index(&c, x, y, z)] > 0.0;
                for (int axis = 0; rc == 0 && axis < 3; axis++) {
                    if (at[axis] + 1 >= c.n[axis]) continue;
                    size_t nb[3] = {x, y, z};
                    nb[axis]++;
                    if (in != (c.val[point_index(&c, nb[0], nb[1], nb[2])] > 0.0))
                        rc = edge_quad(&c, x, y, z, axis);
                }
            }
    free(c.val);
    free(c.vert);
    free(c.e.leaf_vals);
    free(c.e.vals);
    bins_free(&c.e.bins);
    if (rc != 0) {
        blobby_mesh_free(m);
        return fail(why, why_len,
                    rc == -2 ? "the surface needs more than %u quads" : "out of memory",
                    BLOBBY_MAX_QUADS);
    }
    return 0;
}

void blobby_mesh_free(blobby_mesh *m)
{
    free(m->p);
    free(m->n);
    free(m->cs);
    free(m->quad);
    memset(m, 0, sizeof *m);
}
