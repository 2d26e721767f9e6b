/* rib_subdiv.c — SubdivisionMesh (RI Spec 3.2 §5.3, RiSubdivisionMesh) and RenderMan's
 * HierarchicalSubdivisionMesh:
 *
 *   SubdivisionMesh "catmull-clark" [nvertices] [vertices]
 *       [tags] [nargs] [intargs] [floatargs] ...params...
 *   HierarchicalSubdivisionMesh "catmull-clark" [nvertices] [vertices]
 *       [tags] [nargs] [intargs] [floatargs] [stringargs] ...params...
 *
 * (SubdivisionMesh's four tag arrays may be left out; a fifth, [stringargs], is skipped when
 * nargs holds three numbers per tag, as the hierarchical form's always does; its string
 * arguments, which only its hierarchical edits use, are not read: such tags are ignored as
 * below). Tags: "crease" (a chain of vertices, one sharpness), "corner"
 * (vertices, one sharpness or one each), "hole" (faces), "interpolateboundary" (0 or 1
 * integer: 0 none, 1 edges and corners (the default), 2 edges only). Any sharpness > 0 is
 * infinitely sharp (a value below 10, RenderMan's "infinite", warns once); 0 or less
 * removes the tag. Other tags are ignored with a warning. scene/subdiv.c makes the patches.
 * Primitive variables "P" (vertex), "Cs" and "st" of any class: uniform one per face,
 * varying and vertex one per point (interpolated linearly over a face, not by
 * subdivision), facevarying one per face-vertex. */
#include "scene/rib/rib_prims.h"

#include "scene/rib/rib_args.h"
#include "scene/rib/rib_internal.h"
#include "scene/subdiv.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The tags of one request, resolved into what scene/subdiv.c takes. */
typedef struct sd_tags {
    int *creases, ncreases; /* vertex pairs */
    int *corners, ncorners;
    int *holes, nholes;
    int interp;
} sd_tags;

static void sd_tags_free(sd_tags *t)
{
    free(t->creases), free(t->corners), free(t->holes);
}

/* Warns once when a sharpness is finite (semi-sharp). */
static void sd_sharpness_warn(rib_parser *p, const rib_arg *at, double s)
{
    if (s > 0.0 && s < 10.0) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "SubdivisionMesh: sharpness %g is made infinitely sharp (semi-sharp creases "
                 "and corners are not supported)",
                 s);
        rib_warn_once(p, at->line, at->col, what);
    }
}

/* One tag: ni integers at ints, nf floats at floats. */
static int sd_tag(rib_parser *p, const char *tag, const double *ints, int ni, const double *fl,
                  int nf, int npoints, int nfaces, const rib_arg *at, sd_tags *t)
{
    char shown[RIB_PRINT_MAX];
    const int is_crease = strcmp(tag, "crease") == 0, is_corner = strcmp(tag, "corner") == 0;
    const int is_hole = strcmp(tag, "hole") == 0, is_ib = strcmp(tag, "interpolateboundary") == 0;
    if (!is_crease && !is_corner && !is_hole && !is_ib) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what, "SubdivisionMesh tag \"%s\" is ignored",
                 rib_printable(tag, shown));
        rib_warn_once(p, at->line, at->col, what);
        return TS_OK;
    }
    const int limit = is_hole ? nfaces : is_ib ? 3 : npoints;
    for (int k = 0; k < ni; k++)
        if (ints[k] < 0 || ints[k] >= limit)
            return rib_error_at(p, at->line, at->col,
                                "SubdivisionMesh: tag \"%s\": integer %g is out of range [0, %d)",
                                tag, ints[k], limit);
    if ((is_crease || is_corner) && (nf != 1 && !(is_corner && nf == ni)))
        return rib_error_at(p, at->line, at->col,
                            "SubdivisionMesh: tag \"%s\" needs one sharpness%s, got %d", tag,
                            is_corner ? " or one per vertex" : "", nf);
    if ((is_crease && ni < 2) || (is_ib && ni > 1))
        return rib_error_at(p, at->line, at->col, "SubdivisionMesh: tag \"%s\" with %d integers",
                            tag, ni);
    if (is_ib) {
        t->interp = ni ? (int)ints[0] : 1;
    } else if (is_hole) {
        for (int k = 0; k < ni; k++)
            t->holes[t->nholes++] = (int)ints[k];
    } else if (is_corner) {
        for (int k = 0; k < ni; k++) {
            double s = fl[nf == 1 ? 0 : k];
            sd_sharpness_warn(p, at, s);
            if (s > 0.0) t->corners[t->ncorners++] = (int)ints[k];
        }
    } else if (fl[0] > 0.0) {
        sd_sharpness_warn(p, at, fl[0]);
        for (int k = 0; k + 1 < ni; k++) {
            t->creases[2 * t->ncreases] = (int)ints[k];
            t->creases[2 * t->ncreases++ + 1] = (int)ints[k + 1];
        }
    }
    return TS_OK;
}

/* Reads the tag arrays from args[3] (sd_params_first has found where they end). */
static int sd_read_tags(rib_parser *p, int npoints, int nfaces, int hier, sd_tags *t)
{
    memset(t, 0, sizeof *t);
    if (p->nargs <= 3 || p->args[3].kind == RIB_ARG_STRING) return TS_OK; /* no tags */
    const rib_arg *tags = &p->args[3];
    if (tags->kind != RIB_ARG_STRINGS && !(tags->kind == RIB_ARG_NUMBERS && tags->count == 0))
        return rib_error_at(p, tags->line, tags->col, "SubdivisionMesh: expected the tags array");
    const size_t ntags = tags->kind == RIB_ARG_STRINGS ? tags->count : 0;
    const double *nargs, *ints, *fl;
    size_t nn, ni, nf;
    int rc = rib_int_array(p, 4, "nargs", 0, RIB_MAX_VALUES, &nargs, &nn);
    if (rc == TS_OK && (hier ? nn != 3 * ntags : nn != 2 * ntags && nn != 3 * ntags))
        rc = rib_error_at(p, p->args[4].line, p->args[4].col,
                          "%s: nargs needs %d numbers per tag (%zu), got %zu", p->req, hier ? 3 : 2,
                          (hier ? 3 : 2) * ntags, nn);
    if (rc == TS_OK)
        rc = rib_int_array(p, 5, "intargs", -(double)RIB_MAX_VALUES, RIB_MAX_VALUES, &ints, &ni);
    if (rc == TS_OK &&
        (6 >= p->nargs || p->args[6].kind == RIB_ARG_STRING || p->args[6].kind == RIB_ARG_STRINGS))
        rc = rib_error_at(p, p->req_line, p->req_col, "SubdivisionMesh: missing floatargs");
    if (rc == TS_OK) fl = rib_arg_nums(p, &p->args[6]), nf = p->args[6].count;
    if (rc != TS_OK) return rc;
    const size_t per = nn == 3 * ntags && ntags ? 3 : 2; /* then [stringargs] follows */
    size_t si = 0, sf = 0;
    for (size_t k = 0; k < ntags; k++)
        si += (size_t)nargs[per * k], sf += (size_t)nargs[per * k + 1];
    if (si != ni || sf != nf)
        return rib_error_at(p, p->args[4].line, p->args[4].col,
                            "SubdivisionMesh: nargs asks for %zu integers and %zu floats, intargs "
                            "has %zu and floatargs %zu",
                            si, sf, ni, nf);
    t->creases = malloc((ni + 1) * 2 * sizeof *t->creases);
    t->corners = malloc((ni + 1) * sizeof *t->corners);
    t->holes = malloc((ni + 1) * sizeof *t->holes);
    if (!t->creases || !t->corners || !t->holes)
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    t->interp = 0;
    for (size_t k = 0, io = 0, fo = 0; rc == TS_OK && k < ntags; k++) {
        int a = (int)nargs[per * k], b = (int)nargs[per * k + 1];
        rc = sd_tag(p, rib_arg_str(p, tags, k), ints + io, a, fl + fo, b, npoints, nfaces, tags, t);
        io += (size_t)a, fo += (size_t)b;
    }
    return rc;
}

typedef struct sd_emit_ctx {
    rib_parser *p;
    const rib_pvars *vars;
    int line, col;
} sd_emit_ctx;

/* fv per corner: Cs (3) then st (2). */
static int sd_emit_patch(void *ctx, const double cp[16][3], const double *fv, int face)
{
    const sd_emit_ctx *c = ctx;
    (void)face;
    double cs[3] = {0, 0, 0}, st[4][2];
    for (int k = 0; k < 4; k++) {
        for (int d = 0; d < 3; d++)
            cs[d] += 0.25 * fv[5 * k + d];
        st[k][0] = fv[5 * k + 3], st[k][1] = fv[5 * k + 4];
    }
    return rib_geom_emit(c->p, c->line, c->col, cp, NULL, c->vars->Cs.v ? cs : NULL,
                         c->vars->st.v ? (const double(*)[2])st : NULL);
}

/* The face-vertex values (Cs, st) of every face corner; without them the corners of each
 * face take st (0,0) (1,0) (1,1) (0,1) for its first four (only quads keep them). */
static double *sd_face_values(const rib_pvars *vars, const double *nverts, size_t nfaces,
                              const double *verts)
{
    size_t nfv = 0;
    for (size_t f = 0; f < nfaces; f++)
        nfv += (size_t)nverts[f];
    double *fv = calloc(nfv + 1, 5 * sizeof *fv);
    if (!fv) return NULL;
    static const double corner_st[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (size_t f = 0, k = 0; f < nfaces; f++)
        for (size_t j = 0; j < (size_t)nverts[f]; j++, k++) {
            double *o = fv + 5 * k;
            size_t pt = (size_t)verts[k];
            if (vars->Cs.v) memcpy(o, rib_pvar_at(&vars->Cs, f, pt, k), 3 * sizeof *o);
            if (vars->st.v)
                memcpy(o + 3, rib_pvar_at(&vars->st, f, pt, k), 2 * sizeof *o);
            else if (j < 4)
                o[3] = corner_st[j][0], o[4] = corner_st[j][1];
        }
    return fv;
}

/* Where the parameter list starts: after the vertices without tags, after floatargs with
 * them (and after stringargs when nargs has three numbers per tag). */
static size_t sd_params_first(const rib_parser *p, int hier)
{
    if (p->nargs <= 3 || p->args[3].kind == RIB_ARG_STRING) return 3;
    size_t ntags = p->args[3].kind == RIB_ARG_STRINGS ? p->args[3].count : 0;
    int three = hier || (p->nargs > 4 && ntags && p->args[4].count == 3 * ntags);
    return three ? 8 : 7;
}

/* The request's integer arrays as ints. */
static int *sd_ints(const double *v, size_t n)
{
    int *o = malloc((n + 1) * sizeof *o);
    for (size_t k = 0; o && k < n; k++)
        o[k] = (int)v[k];
    return o;
}

/* Hands the mesh to scene/subdiv.c and reports what it says. */
static int sd_run(rib_parser *p, subdiv_input *in, const rib_pvars *vars)
{
    sd_emit_ctx c = {p, vars, vars->P.line, vars->P.col};
    subdiv_result res;
    char why[256];
    int rc = subdiv_patches(in, sd_emit_patch, &c, &res, why, sizeof why);
    if (rc == TS_E_SCENE && p->err->code == TS_OK)
        return rib_error_at(p, p->req_line, p->req_col, "SubdivisionMesh: %s", why);
    if (rc == TS_E_MEMORY && p->err->code == TS_OK)
        return ts_error_set(p->err, rc, "%s: SubdivisionMesh: %s", p->lx.file, why);
    if (rc == TS_OK && res.split) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "SubdivisionMesh: %d vertex(es) where faces meet only at the point (not "
                 "manifold) are drawn as sharp corners",
                 res.split);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    if (rc == TS_OK && res.creases_unused) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "SubdivisionMesh: %d crease edge(s) are not edges of the mesh and are ignored",
                 res.creases_unused);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    return rc;
}

static int sd_request(rib_parser *p, int hier)
{
    const char *scheme;
    char shown[RIB_PRINT_MAX];
    const double *nverts, *verts;
    size_t nfaces, nv, nfv = 0;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = rib_string_arg(p, 0, "a subdivision scheme", &scheme);
    if (rc == TS_OK && strcmp(scheme, "catmull-clark") != 0)
        rc = rib_error_at(p, p->args[0].line, p->args[0].col,
                          "SubdivisionMesh: scheme \"%s\" is not supported (catmull-clark)",
                          rib_printable(scheme, shown));
    if (rc == TS_OK) rc = rib_int_array(p, 1, "nvertices", 3, RIB_MAX_VALUES, &nverts, &nfaces);
    if (rc == TS_OK) rc = rib_int_array(p, 2, "vertices", 0, RIB_MAX_VALUES, &verts, &nv);
    for (size_t f = 0; rc == TS_OK && f < nfaces; f++)
        nfv += (size_t)nverts[f];
    if (rc == TS_OK && nfv != nv)
        rc = rib_error_at(p, p->args[1].line, p->args[1].col,
                          "SubdivisionMesh: the nvertices add up to %zu, but vertices has %zu", nfv,
                          nv);
    if (rc != TS_OK) return rc;
    const size_t first = sd_params_first(p, hier), npoints = rib_pvars_count(p, first, "P", 3);
    if (npoints == 0)
        return rib_error_at(p, p->req_line, p->req_col, "SubdivisionMesh: missing \"P\"");
    for (size_t k = 0; k < nv; k++)
        if (verts[k] >= (double)npoints)
            return rib_error_at(p, p->args[2].line, p->args[2].col,
                                "SubdivisionMesh: vertex %zu is point %.0f, but \"P\" has %zu "
                                "points",
                                k, verts[k], npoints);
    sd_tags tags;
    rc = sd_read_tags(p, (int)npoints, (int)nfaces, hier, &tags);
    rib_pvars vars;
    const size_t counts[RIB_CLASSES] = {1, nfaces, npoints, npoints, nv};
    if (rc == TS_OK) rc = rib_pvars_read(p, first, counts, RIB_PV_P | RIB_PV_CS | RIB_PV_ST, &vars);
    double *fv = rc == TS_OK ? sd_face_values(&vars, nverts, nfaces, verts) : NULL;
    int *nvi = rc == TS_OK ? sd_ints(nverts, nfaces) : NULL,
        *vi = rc == TS_OK ? sd_ints(verts, nv) : NULL;
    if (rc == TS_OK && (!fv || !nvi || !vi))
        rc = ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    if (rc == TS_OK) {
        subdiv_input in = {(int)nfaces,
                           nvi,
                           vi,
                           (int)npoints,
                           (const double(*)[3])vars.P.v,
                           tags.creases,
                           tags.ncreases,
                           tags.corners,
                           tags.ncorners,
                           tags.holes,
                           tags.nholes,
                           tags.interp,
                           fv,
                           5};
        rc = sd_run(p, &in, &vars);
    }
    free(fv), free(nvi), free(vi);
    sd_tags_free(&tags);
    return rc;
}

int rib_req_subdivision_mesh(rib_parser *p)
{
    return sd_request(p, 0);
}

int rib_req_hierarchical_subdivision_mesh(rib_parser *p)
{
    return sd_request(p, 1);
}
