/* rib_quadric.c — the quadric requests (RI Spec 3.2 §5.4):
 *
 *   Sphere radius zmin zmax thetamax        Cone height radius thetamax
 *   Cylinder radius zmin zmax thetamax      Disk height radius thetamax
 *   Hyperboloid x1 y1 z1 x2 y2 z2 thetamax  Paraboloid rmax zmin zmax thetamax
 *   Torus majorradius minorradius phimin phimax thetamax
 *
 * each followed by a parameter list. The numbers may be bare or in arrays
 * (`Hyperboloid [1 0 0] [0 1 1] 360`). scene/quadric.c makes the patches (at most 16, each
 * within the tolerance stated there, with analytic corner normals); each is emitted like a
 * Patch. Primitive variables "Cs" and "st": constant or uniform (1 value), varying, vertex
 * or facevarying (4 values at the corners (u, v) = (0,0), (1,0), (0,1), (1,1) of the whole
 * quadric, interpolated bilinearly to each patch's corners). Without "st" a patch's corners
 * take the quadric's (u, v) there, so a texture spans the whole surface as in RenderMan. */
#include "scene/rib/rib_prims.h"

#include "scene/quadric.h"
#include "scene/rib/rib_args.h"
#include "scene/rib/rib_internal.h"

#include <stdio.h>
#include <string.h>

/* Reads n numbers from args[*i] on, given bare or in arrays of any split that does not run
 * past the n-th number; advances *i. */
static int quadric_numbers(rib_parser *p, size_t *i, size_t n, double *out)
{
    size_t got = 0;
    while (got < n) {
        if (*i >= p->nargs)
            return rib_error_at(p, p->req_line, p->req_col, "%s expects %zu numbers, got %zu",
                                p->req, n, got);
        const rib_arg *a = &p->args[*i];
        if (a->kind != RIB_ARG_NUMBER && a->kind != RIB_ARG_NUMBERS)
            return rib_error_at(p, a->line, a->col, "%s expects %zu numbers, got %zu", p->req, n,
                                got);
        if (got + a->count > n)
            return rib_error_at(p, a->line, a->col, "%s expects %zu numbers, got %zu", p->req, n,
                                got + a->count);
        memcpy(out + got, rib_arg_nums(p, a), a->count * sizeof *out);
        got += a->count;
        (*i)++;
    }
    return TS_OK;
}

/* What the patch callback needs: the request's variables. */
typedef struct quadric_ctx {
    rib_parser *p;
    const rib_pvars *vars;
} quadric_ctx;

/* Variable v (dim numbers) at (u, v) of the quadric: one value, or the bilinear blend of
 * four at the corners. */
static void quadric_var_at(const rib_pvar *var, double u, double v, double *out)
{
    if (var->count == 1) {
        memcpy(out, var->v, (size_t)var->dim * sizeof *out);
        return;
    }
    const double w[4] = {(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v};
    for (int d = 0; d < var->dim; d++)
        out[d] = w[0] * var->v[d] + w[1] * var->v[var->dim + d] + w[2] * var->v[2 * var->dim + d] +
                 w[3] * var->v[3 * var->dim + d];
}

static int quadric_emit(void *ctx, const double cp[16][3], const double n[4][3],
                        const double uv[4][2])
{
    const quadric_ctx *c = ctx;
    const rib_pvars *vars = c->vars;
    double cs[3] = {0, 0, 0}, st[4][2];
    for (int k = 0; k < 4; k++) {
        if (vars->st.v)
            quadric_var_at(&vars->st, uv[k][0], uv[k][1], st[k]);
        else
            st[k][0] = uv[k][0], st[k][1] = uv[k][1];
        if (vars->Cs.v) {
            double ck[3];
            quadric_var_at(&vars->Cs, uv[k][0], uv[k][1], ck);
            for (int d = 0; d < 3; d++)
                cs[d] += 0.25 * ck[d];
        }
    }
    rib_parser *p = c->p;
    return rib_geom_emit(p, p->req_line, p->req_col, cp, n, vars->Cs.v ? cs : NULL,
                         (const double(*)[2])st);
}

static int quadric_request(rib_parser *p, ts_quadric_kind kind)
{
    static const size_t counts[RIB_CLASSES] = {1, 1, 4, 4, 4};
    /* In a motion block the two samples must make the same patches, whatever their angles. */
    ts_quadric q = {kind, {0}, p->motion.active};
    size_t i = 0;
    rib_pvars vars;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = quadric_numbers(p, &i, (size_t)quadric_arg_count(kind), q.arg);
    if (rc == TS_OK) rc = rib_pvars_read(p, i, counts, RIB_PV_CS | RIB_PV_ST, &vars);
    if (rc != TS_OK) return rc;
    quadric_ctx ctx = {p, &vars};
    char why[256] = "";
    int count;
    rc = quadric_patches(&q, quadric_emit, &ctx, &count, why, sizeof why);
    if (rc == TS_E_SCENE && why[0])
        return rib_error_at(p, p->req_line, p->req_col, "%s: %s", p->req, why);
    if (rc == TS_OK && count == 0) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what, "%s of zero area is skipped", p->req);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    return rc;
}

int rib_req_sphere(rib_parser *p)
{
    return quadric_request(p, QUADRIC_SPHERE);
}

int rib_req_cone(rib_parser *p)
{
    return quadric_request(p, QUADRIC_CONE);
}

int rib_req_cylinder(rib_parser *p)
{
    return quadric_request(p, QUADRIC_CYLINDER);
}

int rib_req_hyperboloid(rib_parser *p)
{
    return quadric_request(p, QUADRIC_HYPERBOLOID);
}

int rib_req_paraboloid(rib_parser *p)
{
    return quadric_request(p, QUADRIC_PARABOLOID);
}

int rib_req_disk(rib_parser *p)
{
    return quadric_request(p, QUADRIC_DISK);
}

int rib_req_torus(rib_parser *p)
{
    return quadric_request(p, QUADRIC_TORUS);
}
