/* rib_nurbs.c — NuPatch (RI Spec 3.2 §5.2, RiNuPatch):
 *
 *   NuPatch nu uorder [uknot] umin umax nv vorder [vknot] vmin vmax ...params...
 *
 * with "P" (nu nv points, polynomial) or "Pw" (homogeneous x w, y w, z w, w: rational),
 * u fastest. scene/nurbs.c turns it into Bézier patches (exact for polynomial surfaces,
 * within NURBS_TOL_REL of the size for rational ones), each emitted like a Patch with
 * corner normals averaged by scene_finalize (pieces share their corners exactly).
 * Primitive variables "Cs" and "st": constant (1 value), uniform (one per segment,
 * (nu - uorder + 1) (nv - vorder + 1)), varying (one per segment corner,
 * (nu - uorder + 2) (nv - vorder + 2), blended bilinearly within the segment). Without "st"
 * a patch's corners take their (u, v) knot values. Under a TrimCurve (rib_trim.c) each piece
 * is kept whole, dropped, or emitted with the trim segments that cross it (scene/trim.h
 * trim_piece). */
#include "scene/rib/rib_prims.h"

#include "scene/nurbs.h"
#include "scene/trim.h"
#include "scene/rib/rib_args.h"
#include "scene/rib/rib_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One direction's arguments: n order [knot] min max from args[*i]. */
static int nurbs_dir_args(rib_parser *p, size_t *i, char dir, int *n, int *order,
                          const double **knot, double range[2])
{
    char what[16];
    snprintf(what, sizeof what, "n%c", dir);
    int rc = rib_integer(p, i, what, RIB_MAX_VALUES, n);
    snprintf(what, sizeof what, "%corder", dir);
    if (rc == TS_OK) rc = rib_integer(p, i, what, RIB_MAX_VALUES, order);
    if (rc != TS_OK) return rc;
    if (*i >= p->nargs || p->args[*i].kind != RIB_ARG_NUMBERS)
        return rib_error_at(p, *i < p->nargs ? p->args[*i].line : p->req_line,
                            *i < p->nargs ? p->args[*i].col : p->req_col,
                            "NuPatch: expected the %cknot array", dir);
    const rib_arg *a = &p->args[*i];
    if (a->count != (size_t)*n + (size_t)*order)
        return rib_error_at(p, a->line, a->col,
                            "NuPatch: %cknot needs n%c + %corder = %zu values, got %zu", dir, dir,
                            dir, (size_t)*n + (size_t)*order, a->count);
    *knot = rib_arg_nums(p, a);
    (*i)++;
    return rib_numbers(p, i, 2, range);
}

typedef struct nurbs_emit_ctx {
    rib_parser *p;
    const ts_nurbs *s;
    const rib_pvars *vars;
    int line, col;
    const trim_set *trim; /* the current TrimCurve, or NULL */
    ts_vec4 *trim_buf;    /* room for its segments */
} nurbs_emit_ctx;

/* Variable var at knot-space (u, v) inside segment (su, sv). */
static void nurbs_var_at(const nurbs_emit_ctx *c, const rib_pvar *var, int su, int sv, double u,
                         double v, double *out)
{
    const ts_nurbs *s = c->s;
    const int nsu = s->nu - s->uorder + 1;
    if (var->cls == RIB_CONSTANT || var->cls == RIB_UNIFORM) {
        size_t k = var->cls == RIB_CONSTANT ? 0 : (size_t)sv * (size_t)nsu + (size_t)su;
        memcpy(out, var->v + (size_t)var->dim * k, (size_t)var->dim * sizeof *out);
        return;
    }
    const double *ku = s->uknot + su + s->uorder - 1, *kv = s->vknot + sv + s->vorder - 1;
    double fu = (u - ku[0]) / (ku[1] - ku[0]), fv = (v - kv[0]) / (kv[1] - kv[0]);
    const double w[4] = {(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv};
    for (int d = 0; d < var->dim; d++) {
        out[d] = 0.0;
        for (int c4 = 0; c4 < 4; c4++) {
            size_t k = (size_t)(sv + (c4 >> 1)) * (size_t)(nsu + 1) + (size_t)(su + (c4 & 1));
            out[d] += w[c4] * var->v[(size_t)var->dim * k + (size_t)d];
        }
    }
}

static int nurbs_emit(void *ctx, const double cp[16][3], const double uv[4][2], int su, int sv)
{
    const nurbs_emit_ctx *c = ctx;
    const rib_pvars *vars = c->vars;
    double cs[3] = {0, 0, 0}, st[4][2];
    for (int k = 0; k < 4; k++) {
        if (vars->st.v)
            nurbs_var_at(c, &vars->st, su, sv, uv[k][0], uv[k][1], st[k]);
        else
            st[k][0] = uv[k][0], st[k][1] = uv[k][1];
        if (vars->Cs.v) {
            double x[3];
            nurbs_var_at(c, &vars->Cs, su, sv, uv[k][0], uv[k][1], x);
            for (int d = 0; d < 3; d++)
                cs[d] += 0.25 * x[d];
        }
    }
    rib_parser *p = c->p;
    if (c->trim) { /* corners (0,0), (1,0), (0,1), (1,1): the piece is a knot-space rectangle */
        uint32_t n = 0;
        int kind = trim_piece(c->trim, uv[0][0], uv[0][1], uv[3][0], uv[3][1], c->trim_buf, &n);
        if (kind == TRIM_DROP) return TS_OK; /* in both samples of a deforming surface alike */
        const rib_motion *m = &p->motion;
        int second = m->active && m->deform && m->sample == 1; /* the first's attributes hold */
        if (kind == TRIM_PARTIAL && !second) {
            int rc = scene_add_trim(p->scene, c->trim_buf, n, &p->emit_trim_first, p->err);
            if (rc != TS_OK) return rc;
            p->emit_trim_count = n;
        }
    }
    int rc =
        rib_geom_emit(p, c->line, c->col, cp, NULL, vars->Cs.v ? cs : NULL, (const double(*)[2])st);
    p->emit_trim_first = p->emit_trim_count = 0;
    return rc;
}

/* The control points as homogeneous (x w, y w, z w, w): "Pw" as given, "P" with w = 1; a
 * malloc'd copy. */
static int nurbs_points(rib_parser *p, const rib_pvars *vars, size_t n, double **pw)
{
    *pw = malloc(n * 4 * sizeof **pw);
    if (!*pw) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    for (size_t k = 0; k < n; k++)
        for (int d = 0; d < 4; d++)
            (*pw)[4 * k + d] = vars->Pw.v ? vars->Pw.v[4 * k + d]
                               : d < 3    ? vars->P.v[3 * k + d]
                                          : 1.0;
    return TS_OK;
}

int rib_req_nu_patch(rib_parser *p)
{
    ts_nurbs s;
    double ur[2], vr[2];
    size_t i = 0;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = nurbs_dir_args(p, &i, 'u', &s.nu, &s.uorder, &s.uknot, ur);
    if (rc == TS_OK) rc = nurbs_dir_args(p, &i, 'v', &s.nv, &s.vorder, &s.vknot, vr);
    if (rc != TS_OK) return rc;
    if ((size_t)s.nu > RIB_MAX_VALUES / (size_t)s.nv)
        return rib_error_at(p, p->req_line, p->req_col, "NuPatch: nu * nv is too large");
    s.umin = ur[0], s.umax = ur[1], s.vmin = vr[0], s.vmax = vr[1];
    char why[256];
    if (s.uorder <= s.nu && s.vorder <= s.nv) {
        size_t segs = (size_t)(s.nu - s.uorder + 1) * (size_t)(s.nv - s.vorder + 1);
        size_t corners = (size_t)(s.nu - s.uorder + 2) * (size_t)(s.nv - s.vorder + 2);
        size_t counts[RIB_CLASSES] = {1, segs, corners, (size_t)s.nu * (size_t)s.nv, 0};
        rib_pvars vars;
        rc = rib_pvars_read(p, i, counts,
                            RIB_PV_P | RIB_PV_PW | RIB_PV_CS | RIB_PV_ST | RIB_PV_NO_VERTEX, &vars);
        double *pw = NULL;
        if (rc == TS_OK) rc = nurbs_points(p, &vars, counts[RIB_VERTEX], &pw);
        s.pw = pw;
        if (rc == TS_OK && nurbs_check(&s, why, sizeof why) != TS_OK)
            rc = rib_error_at(p, p->req_line, p->req_col, "NuPatch: %s", why);
        const rib_pvar *pos = vars.Pw.v ? &vars.Pw : &vars.P;
        nurbs_emit_ctx c = {
            p, &s, &vars, rc == TS_OK ? pos->line : 0, rc == TS_OK ? pos->col : 0, NULL, NULL};
        c.trim = rib_trim_current(p);
        if (rc == TS_OK && c.trim &&
            !(c.trim_buf = malloc((c.trim->count ? c.trim->count : 1) * sizeof *c.trim_buf)))
            rc = ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        nurbs_result res;
        if (rc == TS_OK) rc = nurbs_patches(&s, nurbs_emit, &c, &res, why, sizeof why);
        if (rc == TS_E_MEMORY && !p->err->msg[0])
            rc = ts_error_set(p->err, rc, "%s: NuPatch: %s", p->lx.file, why);
        free(c.trim_buf);
        free(pw);
        if (rc == TS_OK && res.rational && res.bound > NURBS_TOL_REL) {
            char what[RIB_WARN_KEY];
            snprintf(what, sizeof what,
                     "NuPatch: a rational surface is approximated within %.2g of its size, more "
                     "than %g, at %d x %d patches per piece",
                     res.bound, NURBS_TOL_REL, 1 << res.level_u, 1 << res.level_v);
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
        return rc;
    }
    s.pw = NULL;
    nurbs_check(&s, why, sizeof why); /* fewer points than the order: says which */
    return rib_error_at(p, p->req_line, p->req_col, "NuPatch: %s", why);
}
