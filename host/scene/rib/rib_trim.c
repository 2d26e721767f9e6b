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
#include "scene/rib/rib_prims.h"
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

/* Fails unless argument `at` (`what`) holds `want` values, as `got` says. */
static int trim_length(rib_parser *p, size_t at, const char *what, size_t got, size_t want)
{
    if (got == want) return TS_OK;
    return rib_error_at(p, p->args[at].line, p->args[at].col,
                        "TrimCurve: [%s] needs %zu values, got %zu", what, want, got);
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

/* The arrays after ncurves (whole numbers, rib_int_array), their lengths following from
 * ncurves, order and n. */
static int trim_read(rib_parser *p, trim_curves *c)
{
    static const char *const names[] = {"knot", "min", "max", "n", "u", "v", "w"};
    const double *v[7];
    size_t len[7], curves = 0, knots = 0, points = 0, no;
    for (int l = 0; l < c->nloops; l++)
        curves += (size_t)c->ncurves[l];
    int rc = rib_int_array(p, 1, "order", 1, RIB_MAX_VALUES, &c->order, &no);
    if (rc == TS_OK) rc = trim_length(p, 1, "order", no, curves);
    size_t i = 2;
    for (int k = 0; k < 7 && rc == TS_OK; k++)
        rc = k == 3 ? rib_int_array(p, i++, "n", 1, RIB_MAX_VALUES, &v[k], &len[k])
                    : trim_array(p, &i, names[k], &v[k], &len[k]);
    if (rc == TS_OK) rc = trim_length(p, 5, "n", len[3], curves);
    if (rc != TS_OK) return rc;
    for (size_t k = 0; k < curves; k++)
        knots += (size_t)v[3][k] + (size_t)c->order[k], points += (size_t)v[3][k];
    const size_t want[7] = {knots, curves, curves, curves, points, points, points};
    for (int k = 0; k < 7 && rc == TS_OK; k++)
        rc = trim_length(p, 2 + (size_t)k, names[k], len[k], want[k]);
    c->n = v[3];
    c->knot = v[0], c->min = v[1], c->max = v[2], c->u = v[4], c->v = v[5], c->w = v[6];
    return rc == TS_OK ? rib_no_more(p, i) : rc;
}

int rib_req_trim_curve(rib_parser *p)
{
    trim_curves c = {0};
    size_t nloops;
    int rc = rib_int_array(p, 0, "ncurves", 1, RIB_MAX_VALUES, &c.ncurves, &nloops);
    if (rc == TS_OK && nloops == 0)
        rc = rib_error_at(p, p->args[0].line, p->args[0].col, "TrimCurve: no loops");
    c.nloops = (int)nloops;
    if (rc == TS_OK) rc = trim_read(p, &c);
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
