/* rib_primvar.c — primitive variables of the quadrics, polygons, NURBS and subdivision
 * meshes (RI Spec 3.2 §5.1): each "name" value pair of the parameter list, its storage class
 * from an inline declaration ("uniform color Cs", "vertex point P", "facevarying float[2]
 * st"; varying without one), the count that class needs on the primitive, and the checks
 * every value must pass. Also the integer arrays (vertex counts and indices) of the mesh
 * requests. See rib_prims.h. */
#include "scene/rib/rib_prims.h"

#include "scene/rib/rib_args.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const rib_class_names[RIB_CLASSES] = {"constant", "uniform", "varying", "vertex",
                                                         "facevarying"};

rib_class rib_class_of(const char *decl, rib_class dflt)
{
    size_t n = strlen(decl);
    for (size_t s = 0; s < n;) {
        size_t e = s;
        while (e < n && decl[e] != ' ')
            e++;
        for (int c = 0; c < RIB_CLASSES; c++)
            if (e - s == strlen(rib_class_names[c]) &&
                strncmp(decl + s, rib_class_names[c], e - s) == 0)
                return (rib_class)c;
        if (e - s == 10 && strncmp(decl + s, "facevertex", 10) == 0) return RIB_FACEVARYING;
        s = e + 1;
    }
    return dflt;
}

/* "constant, uniform or varying": the classes the primitive accepts. */
static void rib_class_list(const size_t counts[RIB_CLASSES], char *buf, size_t n)
{
    buf[0] = '\0';
    int k = 0, total = 0;
    for (int c = 0; c < RIB_CLASSES; c++)
        total += counts[c] != 0;
    for (int c = 0; c < RIB_CLASSES; c++) {
        if (!counts[c]) continue;
        size_t len = strlen(buf);
        snprintf(buf + len, n - len, "%s%s",
                 k == 0           ? ""
                 : k == total - 1 ? " or "
                                  : ", ",
                 rib_class_names[c]);
        k++;
    }
}

/* Reads one variable of `dim` numbers per value. */
static int rib_pvar_read(rib_parser *p, const rib_param *prm, const size_t counts[RIB_CLASSES],
                         int dim, int no_vertex, int zero_n, rib_pvar *out)
{
    char shown[RIB_PRINT_MAX], classes[64];
    int position = strcmp(prm->name, "P") == 0 || strcmp(prm->name, "Pw") == 0;
    rib_class cls = position ? RIB_VERTEX : rib_class_of(rib_arg_str(p, prm->key, 0), RIB_VARYING);
    size_t count = counts[cls];
    if (count == 0 || (!position && no_vertex && cls == RIB_VERTEX)) {
        size_t allowed[RIB_CLASSES];
        memcpy(allowed, counts, sizeof allowed);
        if (no_vertex) allowed[RIB_VERTEX] = 0;
        rib_class_list(allowed, classes, sizeof classes);
        return rib_error_at(p, prm->key->line, prm->key->col,
                            "%s: \"%s\" of class %s is not supported (%s)", p->req,
                            rib_printable(prm->name, shown), rib_class_names[cls], classes);
    }
    const double *v;
    const rib_arg *val = prm->val;
    if ((val->kind == RIB_ARG_NUMBER || val->kind == RIB_ARG_NUMBERS) &&
        val->count != (size_t)dim * count) {
        if (position || p->strict)
            return rib_error_at(p, val->line, val->col,
                                "%s: parameter \"%s\" (%s) needs %zu values, got %zu", p->req,
                                rib_printable(prm->name, shown), rib_class_names[cls],
                                (size_t)dim * count, val->count);
        /* Any other variable: the primitive is drawn without it (*out stays unset). */
        char what[512];
        snprintf(what, sizeof what,
                 "%s: parameter \"%s\" (%s) needs %zu values, got %zu; drawn without it "
                 "(--strict makes this an error)",
                 p->req, rib_printable(prm->name, shown), rib_class_names[cls], (size_t)dim * count,
                 val->count);
        rib_warn_once(p, val->line, val->col, what);
        return TS_OK;
    }
    int rc = rib_param_numbers(p, prm, (size_t)dim * count, &v, NULL);
    if (rc != TS_OK) return rc;
    int is_n = strcmp(prm->name, "N") == 0;
    for (size_t k = 0; k < count; k++) {
        const double *x = v + (size_t)dim * k;
        for (int d = 0; d < dim; d++)
            if (!(fabs(x[d]) <= FLT_MAX))
                return rib_error_at(p, val->line, val->col,
                                    "%s: value %zu of \"%s\" is out of range", p->req, k,
                                    rib_printable(prm->name, shown));
        if (is_n && x[0] == 0.0 && x[1] == 0.0 && x[2] == 0.0) {
            if (!zero_n)
                return rib_error_at(p, val->line, val->col, "%s: normal %zu of \"N\" is zero",
                                    p->req, k);
            char what[RIB_WARN_KEY];
            snprintf(what, sizeof what, "%s: zero normals in \"N\" take their polygon's normal",
                     p->req); /* one warning, whichever normals they are */
            rib_warn_once(p, val->line, val->col, what);
        }
    }
    *out = (rib_pvar){v, cls, dim, count, val->line, val->col};
    return TS_OK;
}

/* "s" and "t" written apart (as exporters do: "facevarying float s", "facevarying float t")
 * are the texture coordinates "st" = (s, t): joined, value by value, into the parser's
 * st_join (valid until the next request reads its variables). They must come together and
 * be of one class; otherwise they are ignored with one warning, as before. */
static int rib_pvars_join_st(rib_parser *p, rib_pvars *v)
{
    const rib_pvar *s = &v->s, *t = &v->t;
    if (!s->v || !t->v || s->cls != t->cls || s->count != t->count) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "%s: \"s\" and \"t\" are read as the texture coordinates \"st\" only together "
                 "and of one class: ignored",
                 p->req);
        rib_warn_once(p, s->v ? s->line : t->line, s->v ? s->col : t->col, what);
        return TS_OK;
    }
    if (s->count > p->st_join_cap) {
        double *j = realloc(p->st_join, 2 * s->count * sizeof *j);
        if (!j) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        p->st_join = j, p->st_join_cap = s->count;
    }
    for (size_t k = 0; k < s->count; k++)
        p->st_join[2 * k] = s->v[k], p->st_join[2 * k + 1] = t->v[k];
    v->st = (rib_pvar){p->st_join, s->cls, 2, s->count, s->line, s->col};
    return TS_OK;
}

int rib_pvars_read(rib_parser *p, size_t first, const size_t counts[RIB_CLASSES], unsigned accept,
                   rib_pvars *out)
{
    static const struct {
        const char *name;
        unsigned bit;
        int dim;
        size_t offset;
    } known[] = {
        {"P", RIB_PV_P, 3, offsetof(rib_pvars, P)},
        {"Pw", RIB_PV_PW, 4, offsetof(rib_pvars, Pw)},
        {"N", RIB_PV_N, 3, offsetof(rib_pvars, N)},
        {"Cs", RIB_PV_CS, 3, offsetof(rib_pvars, Cs)},
        {"st", RIB_PV_ST, 2, offsetof(rib_pvars, st)},
        {"s", RIB_PV_ST, 1, offsetof(rib_pvars, s)},
        {"t", RIB_PV_ST, 1, offsetof(rib_pvars, t)},
    };
    memset(out, 0, sizeof *out);
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        size_t k = 0, n = sizeof known / sizeof known[0];
        while (k < n && strcmp(prm.name, known[k].name) != 0)
            k++;
        if (k == n || !(accept & known[k].bit)) {
            rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_pvar_read(p, &prm, counts, known[k].dim, (accept & RIB_PV_NO_VERTEX) != 0,
                           (accept & RIB_PV_ZERO_N) != 0,
                           (rib_pvar *)((char *)out + known[k].offset));
        if (rc != TS_OK) return rc;
    }
    if (!out->st.v && (out->s.v || out->t.v)) {
        int rc = rib_pvars_join_st(p, out);
        if (rc != TS_OK) return rc;
    }
    if ((accept & (RIB_PV_P | RIB_PV_PW)) && !out->P.v && !out->Pw.v)
        return rib_error_at(p, p->req_line, p->req_col, "%s: missing \"P\"%s", p->req,
                            (accept & RIB_PV_PW) ? " or \"Pw\"" : "");
    return TS_OK;
}

size_t rib_pvars_count(rib_parser *p, size_t first, const char *name, size_t dim)
{
    for (size_t i = first; i + 1 < p->nargs; i += 2) {
        rib_param prm;
        if (p->args[i].kind != RIB_ARG_STRING || rib_param_at(p, i, &prm) != TS_OK) return 0;
        if (strcmp(prm.name, name) == 0 &&
            (prm.val->kind == RIB_ARG_NUMBERS || prm.val->kind == RIB_ARG_NUMBER))
            return prm.val->count / dim;
    }
    return 0;
}

const double *rib_pvar_at(const rib_pvar *v, size_t face, size_t vertex, size_t fv)
{
    size_t k = v->cls == RIB_CONSTANT      ? 0
               : v->cls == RIB_UNIFORM     ? face
               : v->cls == RIB_FACEVARYING ? fv
                                           : vertex;
    return v->v + (size_t)v->dim * k;
}

int rib_int_array(rib_parser *p, size_t i, const char *what, double lo, double hi,
                  const double **vals, size_t *count)
{
    if (i >= p->nargs)
        return rib_error_at(p, p->req_line, p->req_col, "%s: missing %s (an array of integers)",
                            p->req, what);
    const rib_arg *a = &p->args[i];
    if (a->kind != RIB_ARG_NUMBERS && a->kind != RIB_ARG_NUMBER)
        return rib_error_at(p, a->line, a->col, "%s: expected %s (an array of integers)", p->req,
                            what);
    const double *v = rib_arg_nums(p, a);
    for (size_t k = 0; k < a->count; k++)
        if (!(v[k] >= lo && v[k] <= hi && v[k] == floor(v[k])))
            return rib_error_at(p, a->line, a->col,
                                "%s: %s: value %zu is %g, not an integer in [%.0f, %.0f]", p->req,
                                what, k, v[k], lo, hi);
    *vals = v;
    *count = a->count;
    return TS_OK;
}
