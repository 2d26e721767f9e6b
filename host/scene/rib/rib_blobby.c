/* rib_blobby.c — Blobby (RI Spec 3.2 §5.6, blobby implicit surfaces):
 *
 *   Blobby nleaf [code] [floats] [strings] ...params...
 *
 * scene/blobby.c compiles the program and polygonizes the surface into quads whose
 * vertices lie on it with its exact normals; each quad becomes a PN patch (two for a concave
 * one) through scene/polygon.c, as the polygon requests' quads do, and is emitted like a Patch
 * (rib_geom_emit). "Cs" of class vertex or varying (one colour per leaf) blends the leaves'
 * colours by their field values at each vertex, a patch taking the mean of its corners';
 * constant or uniform "Cs" colours the whole surface. The strings are only used by
 * repelling planes and plug-ins, which are errors naming them. docs/rib.md "Blobby". */
#include "scene/rib/rib_prims.h"

#include "scene/blobby.h"
#include "scene/polygon.h"
#include "scene/rib/rib_args.h"
#include "scene/rib/rib_internal.h"

#include <stdio.h>
#include <string.h>

typedef struct blobby_emit_ctx {
    rib_parser *p;
    const blobby_mesh *m;
    const unsigned *quad; /* the quad being emitted */
    const double *cs;     /* a constant colour, or NULL */
    int line, col;
} blobby_emit_ctx;

static int blobby_emit(void *ctx, const double cp[16][3], const double cn[4][3],
                       const unsigned corner[4])
{
    const blobby_emit_ctx *c = ctx;
    double cs[3] = {0, 0, 0};
    const double *colour = c->cs;
    (void)corner;
    if (c->m->cs) { /* the mean of the quad's four vertices */
        for (unsigned k = 0; k < 4; k++)
            for (int d = 0; d < 3; d++)
                cs[d] += c->m->cs[c->quad[k]][d] / 4.0;
        colour = cs;
    }
    return rib_geom_emit(c->p, c->line, c->col, cp, cn, colour, NULL);
}

int rib_req_blobby(rib_parser *p)
{
    int rc = rib_geom_check(p);
    if (rc != TS_OK) return rc;
    const double *nleaf_v, *code, *floats;
    size_t one, ncode, nfloats;
    rc = rib_int_array(p, 0, "nleaf", 1, RIB_MAX_VALUES, &nleaf_v, &one);
    if (rc == TS_OK && one != 1)
        rc = rib_error_at(p, p->args[0].line, p->args[0].col, "Blobby: nleaf must be one integer");
    if (rc == TS_OK) rc = rib_int_array(p, 1, "code", -1e9, 1e9, &code, &ncode);
    if (rc != TS_OK) return rc;
    if (p->nargs < 4 || p->args[2].kind != RIB_ARG_NUMBERS ||
        (p->args[3].kind != RIB_ARG_STRINGS && p->args[3].kind != RIB_ARG_NUMBERS))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Blobby: expected nleaf [code] [floats] [strings]");
    floats = rib_arg_nums(p, &p->args[2]);
    nfloats = p->args[2].count;
    size_t nleaf = (size_t)nleaf_v[0];
    rib_pvars vars;
    const size_t counts[RIB_CLASSES] = {1, 1, nleaf, nleaf, 0};
    rc = rib_pvars_read(p, 4, counts, RIB_PV_CS, &vars);
    if (rc != TS_OK) return rc;
    ts_blobby b;
    char why[256];
    if (blobby_compile(&b, code, ncode, floats, nfloats, why, sizeof why))
        return rib_error_at(p, p->args[1].line, p->args[1].col, "Blobby: %s", why);
    const double *leaf_cs = NULL, *cs = NULL;
    if (vars.Cs.v && (vars.Cs.cls == RIB_VARYING || vars.Cs.cls == RIB_VERTEX)) {
        if (b.nleaf == nleaf)
            leaf_cs = vars.Cs.v;
        else
            rib_warn_once(p, vars.Cs.line, vars.Cs.col,
                          "Blobby: \"Cs\" has one colour per leaf of nleaf, but the code has a "
                          "different number of leaves; ignored");
    } else if (vars.Cs.v) {
        cs = vars.Cs.v;
    }
    if (b.nleaf != nleaf && !leaf_cs)
        rib_warn_once(p, p->args[0].line, p->args[0].col,
                      "Blobby: nleaf differs from the number of primitive fields in the code");
    blobby_mesh m;
    if (blobby_polygonize(&b, leaf_cs, &m, why, sizeof why)) {
        blobby_free(&b);
        return rib_error_at(p, p->req_line, p->req_col, "Blobby: %s", why);
    }
    blobby_free(&b);
    if (m.coarse) {
        char what[160];
        snprintf(what, sizeof what,
                 "Blobby: polygonized on cells of %.3g, coarser than its smallest blobs (the grid "
                 "is limited): small blobs may be lost",
                 m.cell);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    blobby_emit_ctx c = {p, &m, NULL, cs, p->req_line, p->req_col};
    for (size_t t = 0; rc == TS_OK && t < m.nquad; t++) {
        double pos[4][3], nrm[4][3];
        for (int k = 0; k < 4; k++) {
            memcpy(pos[k], m.p[m.quad[t][k]], sizeof pos[k]);
            memcpy(nrm[k], m.n[m.quad[t][k]], sizeof nrm[k]);
        }
        c.quad = m.quad[t];
        poly_face f = {(const double(*)[3])pos, (const double(*)[3])nrm, NULL, 1, 4};
        rc = poly_patches(&f, blobby_emit, &c, NULL, p->err);
    }
    blobby_mesh_free(&m);
    return rc;
}
