/* rib_trim.c — TrimCurve (RI Spec 3.2 §5.2, RiTrimCurve):
 *
 *   TrimCurve [ncurves] [order] [knot] [min] [max] [n] [u] [v] [w]
 *
 * one loop per value of ncurves, each of that many NURBS curves in the homogeneous parameter
 * space (u, v, w) of the NuPatch requests that follow, until the attribute block ends (the
 * trim is an attribute: AttributeBegin saves it, AttributeEnd restores it). scene/trim.c turns
 * the curves into polylines; rib_nurbs.c asks it, piece by piece, what each keeps. The trims
 * a parse makes live until its end (rib_trim_free); the state names one by index. */
#include "scene/rib/rib_internal.h"

#include "scene/rib/rib_args.h"
#include "scene/trim.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct rib_trims {
    trim_set *set;
    size_t count, cap;
} rib_trims;

/* Argument *i as numbers (an array, or one bare number), advancing *i. */
static int trim_array(rib_parser *p, size_t *i, const char *what, const double **v, size_t *n)
{
    if (*i >= p->nargs)
        return rib_error_at(p, p->req_line, p->req_col, "TrimCurve: missing [%s]", what);
    const rib_arg *a = &p->args[*i];
    if (a->kind != RIB_ARG_NUMBERS && a->kind != RIB_ARG_NUMBER)
        return rib_error_at(p, a->line, a->col, "TrimCurve: expected [%s] (numbers)", what);
    *v = rib_arg_nums(p, a);
    *n = a->count;
    (*i)++;
    return TS_OK;
}

/* The values of an array that must be `want` integers in [lo, RIB_MAX_VALUES], as ints in
 * out (malloc'd). */
static int trim_ints(rib_parser *p, size_t at, const char *what, const double *v, size_t n,
                     size_t want, int lo, int **out)
{
    const rib_arg *a = &p->args[at];
    if (n != want)
        return rib_error_at(p, a->line, a->col, "TrimCurve: [%s] needs %zu values, got %zu", what,
                            want, n);
    *out = malloc((n ? n : 1) * sizeof **out);
    if (!*out) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    for (size_t k = 0; k < n; k++) {
        if (!(v[k] >= lo && v[k] <= RIB_MAX_VALUES && v[k] == floor(v[k])))
            return rib_error_at(p, a->line, a->col,
                                "TrimCurve: %s value %zu must be an integer >= %d, got %g", what, k,
                                lo, v[k]);
        (*out)[k] = (int)v[k];
    }
    return TS_OK;
}

/* Keeps t as the parse's trim number count + 1 (the state's p->trim). */
static int trim_keep(rib_parser *p, trim_set *t)
{
    rib_trims *r = p->trims;
    if (!r && !(r = p->trims = calloc(1, sizeof *r))) goto oom;
    if (r->count == r->cap) {
        size_t cap = r->cap ? 2 * r->cap : 8;
        trim_set *s = realloc(r->set, cap * sizeof *s);
        if (!s) goto oom;
        r->set = s, r->cap = cap;
    }
    r->set[r->count++] = *t;
    p->trim = (int)r->count;
    return TS_OK;
oom:
    trim_set_free(t);
    return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
}

/* The arrays after ncurves and order: their lengths follow from ncurves, order and n. */
static int trim_read(rib_parser *p, size_t i, trim_curves *c, int **order, int **n)
{
    static const char *const names[] = {"knot", "min", "max", "n", "u", "v", "w"};
    const double *v[7];
    size_t len[7], at[7], curves = 0, knots = 0, points = 0;
    for (int l = 0; l < c->nloops; l++)
        curves += (size_t)c->ncurves[l];
    const double *ov;
    size_t on, oat = i;
    int rc = trim_array(p, &i, "order", &ov, &on);
    if (rc == TS_OK) rc = trim_ints(p, oat, "order", ov, on, curves, 1, order);
    for (int k = 0; k < 7 && rc == TS_OK; k++)
        at[k] = i, rc = trim_array(p, &i, names[k], &v[k], &len[k]);
    if (rc == TS_OK) rc = trim_ints(p, at[3], "n", v[3], len[3], curves, 1, n);
    if (rc != TS_OK) return rc;
    for (size_t k = 0; k < curves; k++)
        knots += (size_t)(*n)[k] + (size_t)(*order)[k], points += (size_t)(*n)[k];
    const size_t want[7] = {knots, curves, curves, curves, points, points, points};
    for (int k = 0; k < 7; k++)
        if (len[k] != want[k])
            return rib_error_at(p, p->args[at[k]].line, p->args[at[k]].col,
                                "TrimCurve: [%s] needs %zu values, got %zu", names[k], want[k],
                                len[k]);
    c->order = *order, c->n = *n;
    c->knot = v[0], c->min = v[1], c->max = v[2], c->u = v[4], c->v = v[5], c->w = v[6];
    return rib_no_more(p, i);
}

int rib_req_trim_curve(rib_parser *p)
{
    size_t i = 0;
    const double *nc;
    size_t nloops;
    int *ncurves = NULL, *order = NULL, *n = NULL;
    int rc = trim_array(p, &i, "ncurves", &nc, &nloops);
    if (rc == TS_OK && nloops == 0)
        rc = rib_error_at(p, p->args[0].line, p->args[0].col, "TrimCurve: no loops");
    if (rc == TS_OK) rc = trim_ints(p, 0, "ncurves", nc, nloops, nloops, 1, &ncurves);
    trim_curves c = {(int)nloops, ncurves, NULL, NULL, NULL, NULL, NULL, NULL, NULL, NULL};
    if (rc == TS_OK) rc = trim_read(p, i, &c, &order, &n);
    if (rc == TS_OK) {
        trim_set t;
        char why[256];
        rc = trim_make(&c, &t, why, sizeof why);
        if (rc == TS_OK)
            rc = trim_keep(p, &t);
        else if (rc == TS_E_MEMORY)
            rc = ts_error_set(p->err, rc, "%s: TrimCurve: %s", p->lx.file, why);
        else
            rc = rib_error_at(p, p->req_line, p->req_col, "TrimCurve: %s", why);
    }
    free(ncurves);
    free(order);
    free(n);
    return rc;
}

const trim_set *rib_trim_current(const rib_parser *p)
{
    return p->trim > 0 && p->trims ? &p->trims->set[p->trim - 1] : NULL;
}

void rib_trim_free(rib_parser *p)
{
    if (!p->trims) return;
    for (size_t k = 0; k < p->trims->count; k++)
        trim_set_free(&p->trims->set[k]);
    free(p->trims->set);
    free(p->trims);
    p->trims = NULL;
}
