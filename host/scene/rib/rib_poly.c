/* rib_poly.c — the polygon requests (RI Spec 3.2 §5.1):
 *
 *   Polygon ...params...                                  one convex polygon
 *   GeneralPolygon [nvertices] ...params...               an outline and holes
 *   PointsPolygons [nvertices] [vertices] ...params...    polygons sharing points
 *   PointsGeneralPolygons [nloops] [nvertices] [vertices] ...params...
 *
 * Every polygon goes through scene/polygon.c, the PN patches Assimp meshes use: with "N"
 * the patches curve to meet the normals' tangent planes; without, every vertex of a
 * polygon takes that polygon's own normal, so polygons stay flat and a mesh keeps its hard
 * edges (a cube stays a cube; nothing is averaged across polygons). Corner displacement
 * normals are those normals. The patches are built in object space and emitted like a
 * Patch (rib_geom_emit). Primitive variables "P" (vertex), "N", "Cs" and "st" of any class:
 * uniform one per polygon, varying and vertex one per point, facevarying one per polygon
 * vertex; a patch's colour is the average of its corners', its "st" those of its corners. */
#include "scene/rib/rib_prims.h"

#include "scene/polygon.h"
#include "scene/rib/rib_args.h"
#include "scene/rib/rib_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The polygons of one request: nfaces polygons of nloops[f] loops (NULL: one each) of
 * nverts[l] vertices each, indexing points verts[k] (NULL: 0, 1, 2, ...). */
typedef struct poly_mesh {
    size_t nfaces;
    const double *nloops, *nverts, *verts;
    size_t npoints, nfv; /* points in "P", face-vertices (the sum of nverts) */
} poly_mesh;

/* What the patch callback needs about the current polygon. */
typedef struct poly_emit_ctx {
    rib_parser *p;
    const poly_mesh *m;
    const rib_pvars *vars;
    size_t face, fv0; /* the polygon and its first face-vertex */
} poly_emit_ctx;

static size_t poly_point(const poly_mesh *m, size_t fv)
{
    return m->verts ? (size_t)m->verts[fv] : fv;
}

static int poly_emit(void *ctx, const double cp[16][3], const double cn[4][3],
                     const unsigned corner[4])
{
    const poly_emit_ctx *c = ctx;
    const rib_pvars *vars = c->vars;
    double cs[3] = {0, 0, 0}, st[4][2];
    unsigned distinct = corner[3] == corner[2] ? 3 : 4;
    for (unsigned k = 0; k < 4; k++) {
        size_t fv = c->fv0 + corner[k], pt = poly_point(c->m, fv);
        if (vars->st.v) memcpy(st[k], rib_pvar_at(&vars->st, c->face, pt, fv), sizeof st[k]);
        if (vars->Cs.v && k < distinct) {
            const double *x = rib_pvar_at(&vars->Cs, c->face, pt, fv);
            for (int d = 0; d < 3; d++)
                cs[d] += x[d] / distinct;
        }
    }
    return rib_geom_emit(c->p, vars->P.line, vars->P.col, cp, cn, vars->Cs.v ? cs : NULL,
                         vars->st.v ? (const double(*)[2])st : NULL);
}

/* Gathers polygon `face` (loops from nloops, face-vertices from fv0) into the scratch
 * arrays and emits its patches. */
static int poly_face_emit(poly_emit_ctx *c, size_t loop0, unsigned loops, unsigned count,
                          double (*pos)[3], double (*nrm)[3], unsigned *loop_len)
{
    const poly_mesh *m = c->m;
    const rib_pvars *vars = c->vars;
    if (c->p->motion.active && (loops > 1 || count > 4)) /* rib_state.c rib_motion_deforms */
        return rib_error_at(c->p, c->p->req_line, c->p->req_col,
                            "%s in a motion block: polygon %zu has %s; only triangles and quads "
                            "without holes move (the two samples could be triangulated "
                            "differently)",
                            c->p->req, c->face, loops > 1 ? "holes" : "more than 4 vertices");
    for (unsigned l = 0; l < loops; l++)
        loop_len[l] = (unsigned)m->nverts[loop0 + l];
    for (unsigned k = 0; k < count; k++) {
        size_t fv = c->fv0 + k, pt = poly_point(m, fv);
        memcpy(pos[k], vars->P.v + 3 * pt, sizeof pos[k]);
        if (!vars->N.v) continue;
        const double *n = rib_pvar_at(&vars->N, c->face, pt, fv);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int d = 0; d < 3; d++) /* a zero normal stays zero: poly_patches takes the polygon's */
            nrm[k][d] = len > 0.0 ? n[d] / len : 0.0;
    }
    poly_face f = {(const double(*)[3])pos, vars->N.v ? (const double(*)[3])nrm : NULL, loop_len,
                   loops, count};
    return poly_patches(&f, poly_emit, c, NULL, c->p->err);
}

/* Reads the primitive variables and emits every polygon of m. */
static int poly_mesh_emit(rib_parser *p, poly_mesh *m, size_t first)
{
    size_t counts[RIB_CLASSES] = {1, m->nfaces, m->npoints, m->npoints, m->nfv};
    rib_pvars vars;
    int rc = rib_pvars_read(p, first, counts,
                            RIB_PV_P | RIB_PV_N | RIB_PV_CS | RIB_PV_ST | RIB_PV_ZERO_N, &vars);
    if (rc != TS_OK) return rc;
    size_t maxn = 0, maxl = 1, loop = 0, fv = 0;
    for (size_t f = 0; f < m->nfaces; f++) { /* the largest polygon, for the scratch arrays */
        size_t loops = m->nloops ? (size_t)m->nloops[f] : 1, n = 0;
        for (size_t l = 0; l < loops; l++)
            n += (size_t)m->nverts[loop + l];
        maxn = n > maxn ? n : maxn, maxl = loops > maxl ? loops : maxl;
        loop += loops;
    }
    double(*pos)[3] = malloc((maxn ? maxn : 1) * sizeof *pos);
    double(*nrm)[3] = malloc((maxn ? maxn : 1) * sizeof *nrm);
    unsigned *loop_len = malloc(maxl * sizeof *loop_len);
    if (!pos || !nrm || !loop_len)
        rc = ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    poly_emit_ctx c = {p, m, &vars, 0, 0};
    loop = 0;
    for (size_t f = 0; rc == TS_OK && f < m->nfaces; f++) {
        unsigned loops = m->nloops ? (unsigned)m->nloops[f] : 1u, n = 0;
        for (unsigned l = 0; l < loops; l++)
            n += (unsigned)m->nverts[loop + l];
        c.face = f, c.fv0 = fv;
        rc = poly_face_emit(&c, loop, loops, n, pos, nrm, loop_len);
        loop += loops, fv += n;
    }
    free(pos);
    free(nrm);
    free(loop_len);
    return rc;
}

/* Checks that `counts` (n values, each at least `least`) add up to `want`, the number of
 * values of `of`, and returns their sum in *sum. */
static int poly_sum(rib_parser *p, size_t i, const double *counts, size_t n, double least,
                    const char *what, size_t want, const char *of, size_t *sum)
{
    const rib_arg *a = &p->args[i];
    size_t s = 0;
    for (size_t k = 0; k < n; k++) {
        if (counts[k] < least)
            return rib_error_at(p, a->line, a->col, "%s: %s %zu is %.0f (at least %.0f)", p->req,
                                what, k, counts[k], least);
        s += (size_t)counts[k];
    }
    if (s != want)
        return rib_error_at(p, a->line, a->col, "%s: the %s add up to %zu, but %s has %zu", p->req,
                            what, s, of, want);
    *sum = s;
    return TS_OK;
}

/* The points of "P" and the check that every vertex index names one. */
static int poly_points(rib_parser *p, size_t first, poly_mesh *m, size_t verts_arg)
{
    m->npoints = rib_pvars_count(p, first, "P", 3);
    if (m->npoints == 0)
        return rib_error_at(p, p->req_line, p->req_col, "%s: missing \"P\"", p->req);
    for (size_t k = 0; m->verts && k < m->nfv; k++)
        if (m->verts[k] >= (double)m->npoints)
            return rib_error_at(p, p->args[verts_arg].line, p->args[verts_arg].col,
                                "%s: vertex %zu is point %.0f, but \"P\" has %zu points", p->req, k,
                                m->verts[k], m->npoints);
    return TS_OK;
}

int rib_req_polygon(rib_parser *p)
{
    int rc = rib_geom_check(p);
    if (rc != TS_OK) return rc;
    poly_mesh m = {.nfaces = 1};
    rc = poly_points(p, 0, &m, 0);
    if (rc != TS_OK) return rc;
    double n = (double)m.npoints;
    m.nverts = &n, m.nfv = m.npoints;
    if (m.npoints < 3)
        return rib_error_at(p, p->req_line, p->req_col, "%s: %zu points (at least 3)", p->req,
                            m.npoints);
    return poly_mesh_emit(p, &m, 0);
}

int rib_req_general_polygon(rib_parser *p)
{
    poly_mesh m = {.nfaces = 1};
    size_t loops;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = rib_int_array(p, 0, "nvertices", 0, RIB_MAX_VALUES, &m.nverts, &loops);
    if (rc == TS_OK && loops == 0)
        rc = rib_error_at(p, p->args[0].line, p->args[0].col, "%s: no loops", p->req);
    if (rc == TS_OK) rc = poly_points(p, 1, &m, 0);
    if (rc == TS_OK)
        rc = poly_sum(p, 0, m.nverts, loops, 3, "nvertices", m.npoints, "\"P\"", &m.nfv);
    if (rc != TS_OK) return rc;
    double nl = (double)loops;
    m.nloops = &nl;
    return poly_mesh_emit(p, &m, 1);
}

int rib_req_points_polygons(rib_parser *p)
{
    poly_mesh m = {0};
    size_t nv;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = rib_int_array(p, 0, "nvertices", 0, RIB_MAX_VALUES, &m.nverts, &m.nfaces);
    if (rc == TS_OK) rc = rib_int_array(p, 1, "vertices", 0, RIB_MAX_VALUES, &m.verts, &nv);
    if (rc == TS_OK)
        rc = poly_sum(p, 0, m.nverts, m.nfaces, 3, "nvertices", nv, "vertices", &m.nfv);
    if (rc == TS_OK) rc = poly_points(p, 2, &m, 1);
    return rc == TS_OK ? poly_mesh_emit(p, &m, 2) : rc;
}

int rib_req_points_general_polygons(rib_parser *p)
{
    poly_mesh m = {0};
    size_t nl, nv, loops;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = rib_int_array(p, 0, "nloops", 0, RIB_MAX_VALUES, &m.nloops, &m.nfaces);
    if (rc == TS_OK) rc = rib_int_array(p, 1, "nvertices", 0, RIB_MAX_VALUES, &m.nverts, &nl);
    if (rc == TS_OK) rc = rib_int_array(p, 2, "vertices", 0, RIB_MAX_VALUES, &m.verts, &nv);
    if (rc == TS_OK) rc = poly_sum(p, 0, m.nloops, m.nfaces, 1, "nloops", nl, "nvertices", &loops);
    if (rc == TS_OK) rc = poly_sum(p, 1, m.nverts, nl, 3, "nvertices", nv, "vertices", &m.nfv);
    if (rc == TS_OK) rc = poly_points(p, 3, &m, 2);
    return rc == TS_OK ? poly_mesh_emit(p, &m, 3) : rc;
}
