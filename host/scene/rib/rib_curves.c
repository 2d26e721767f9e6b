/* rib_curves.c — Points and Curves (RI Spec 3.2 §5.6 and §5.7) as bicubic patches, each handed
 * to rib_geom_emit like any other surface (docs/rib.md "Points and curves"):
 *
 *   Points "P" [...] ["width" [...] | "constantwidth" [w]]   one sphere of diameter width per
 *       point: the 8 patches of scene/quadric.c's sphere (16 in a motion block);
 *   Curves "linear" | "cubic" [nvertices] "nonperiodic" | "periodic" "P" [...]
 *       ["width" [...] | "constantwidth" [w]]   one ribbon patch per curve segment (cubic
 *       segments in the current v basis and step), width across it, turned to face the
 *       camera (RenderMan's curves without "N").
 *
 * A ribbon is bicubic along the curve and linear across it: row k of its control grid is the
 * segment's Bézier point C_k moved by (i / 3 - 1/2) w_k s_k for column i, with w_k the width
 * at t = k / 3 (exact for the linear varying width) and s_k the unit vector across the curve,
 * perpendicular to its tangent and to the direction to the eye at C_k (the camera's z axis for
 * an orthographic camera), all in object space at shutter open. */
#include "scene/rib/rib_internal.h"
#include "scene/rib/rib_prims.h"

#include "base/mat4.h"
#include "scene/quadric.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* Points and curve segments one request may add: each becomes patches, about 0.5 KB each on
 * the host (rib_parser.h RIB_MAX_INSTANCED_PATCHES is the same bound for instances). */
#define CURVES_MAX_PATCHES (1u << 20)

/* The width parameters: "width" (one value per point, or per varying position of a curve)
 * or "constantwidth" (one), default 1; "Cs" constant or uniform. */
typedef struct curves_vars {
    const double *P, *width, *cs;
    size_t np;       /* points in "P" */
    double constant; /* constantwidth, or 1 */
    int cs_each;     /* "Cs" has one colour per curve (uniform) or per point (Points) */
    int line, col;   /* of the "P" values */
} curves_vars;

/* Reads "P" (3 numbers each), "width" (varying or vertex: `nwidth` values), "constantwidth"
 * and "Cs" (constant, or `neach` values: uniform for curves, varying or vertex for points)
 * from args[first]; others are ignored with a warning. np_want: the points "P" must hold
 * (0: any multiple of 3). points: the request is Points. */
static int curves_read_vars(rib_parser *p, size_t first, size_t np_want, size_t nwidth,
                            size_t neach, int points, curves_vars *out)
{
    memset(out, 0, sizeof *out);
    out->constant = 1.0;
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        size_t n;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        rib_class cls = rib_class_of(rib_arg_str(p, prm.key, 0), RIB_VARYING);
        if (strcmp(prm.name, "P") == 0) {
            rc = rib_param_numbers(p, &prm, np_want * 3, &v, &n);
            if (rc == TS_OK && n % 3 != 0)
                return rib_error_at(p, prm.val->line, prm.val->col,
                                    "%s: \"P\" needs 3 numbers per point, got %zu", p->req, n);
            out->P = v, out->np = n / 3, out->line = prm.val->line, out->col = prm.val->col;
        } else if (strcmp(prm.name, "width") == 0 && cls != RIB_CONSTANT && cls != RIB_UNIFORM) {
            rc = rib_param_numbers(p, &prm, nwidth, &v, NULL);
            out->width = v;
        } else if (strcmp(prm.name, "constantwidth") == 0 ||
                   (strcmp(prm.name, "width") == 0 && cls == RIB_CONSTANT)) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc == TS_OK) out->constant = v[0];
        } else if (strcmp(prm.name, "Cs") == 0 &&
                   (cls == RIB_CONSTANT || (points ? cls != RIB_UNIFORM : cls == RIB_UNIFORM))) {
            out->cs_each = cls != RIB_CONSTANT;
            rc = rib_param_numbers(p, &prm, out->cs_each ? 3 * neach : 3, &v, NULL);
            out->cs = v;
        } else {
            rib_warn_param(p, &prm);
        }
        if (rc != TS_OK) return rc;
    }
    if (!out->P) return rib_error_at(p, p->req_line, p->req_col, "%s: missing \"P\"", p->req);
    if (out->np == 0) return TS_OK; /* Points "P" [] (a particle system's empty frame) */
    size_t nw = out->width ? nwidth : 1;
    for (size_t k = 0; k < nw; k++) {
        double w = out->width ? out->width[k] : out->constant;
        if (!(w >= 0.0 && w <= FLT_MAX))
            return rib_error_at(p, p->req_line, p->req_col,
                                "%s: widths must be >= 0 and finite, got %g", p->req, w);
    }
    for (size_t k = 0; k < 3 * out->np; k++)
        if (!(fabs(out->P[k]) <= FLT_MAX))
            return rib_error_at(p, out->line, out->col, "%s: \"P\" value %zu is out of range",
                                p->req, k);
    return TS_OK;
}

/* ---- Points ------------------------------------------------------------------------ */

typedef struct points_ctx {
    rib_parser *p;
    const double *centre, *cs;
    int line, col;
} points_ctx;

static int points_emit(void *ctx, const double cp[16][3], const double n[4][3],
                       const double uv[4][2])
{
    points_ctx *c = ctx;
    double g[16][3];
    for (int k = 0; k < 16; k++)
        for (int d = 0; d < 3; d++)
            g[k][d] = cp[k][d] + c->centre[d];
    return rib_geom_emit(c->p, c->line, c->col, (const double(*)[3])g, n, c->cs, uv);
}

/* Points "P" [...] ["width" [one per point]] ["constantwidth" [w]] ["Cs" constant, or one
 * per point]: one sphere of diameter width around each point. A zero width adds nothing. */
int rib_req_points(rib_parser *p)
{
    curves_vars v;
    size_t np = rib_pvars_count(p, 0, "P", 3);
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = curves_read_vars(p, 0, np, np, np, 1, &v);
    if (rc != TS_OK) return rc;
    if (v.np == 0) { /* "P" [] (a particle system's empty frame): nothing to draw */
        rib_warn_once(p, p->req_line, p->req_col, "Points without points is skipped");
        return TS_OK;
    }
    int fixed = p->motion.active; /* the two samples must make the same patches */
    size_t per = fixed ? 16 : 8;
    if (v.np > CURVES_MAX_PATCHES / per)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Points: %zu points would make more than %u patches (each point is a "
                            "sphere of %zu patches)",
                            v.np, CURVES_MAX_PATCHES, per);
    for (size_t k = 0; rc == TS_OK && k < v.np; k++) {
        double r = 0.5 * (v.width ? v.width[k] : v.constant);
        ts_quadric q = {QUADRIC_SPHERE, {r, -r, r, 360.0}, fixed};
        const double *cs = v.cs ? v.cs + (v.cs_each ? 3 * k : 0) : NULL;
        points_ctx c = {p, v.P + 3 * k, cs, v.line, v.col};
        char why[128];
        int count;
        rc = quadric_patches(&q, points_emit, &c, &count, why, sizeof why);
    }
    return rc;
}

/* ---- Curves ------------------------------------------------------------------------ */

/* One curve request: the shape of its curves and where the camera is in object space. */
typedef struct curves_req {
    int cubic, periodic, step;
    const double *nvert; /* vertices of each curve */
    size_t ncurves;
    int ortho;      /* the eye is at infinity along -view */
    double eye[3];  /* object space: the eye (perspective) */
    double view[3]; /* object space: the camera's z axis (orthographic) */
} curves_req;

/* Segments of a curve of n vertices (RI Spec §5.6), or 0 when n does not fit the type. */
static size_t curves_segments(const curves_req *c, size_t n)
{
    if (!c->cubic) return c->periodic ? (n >= 2 ? n : 0) : (n >= 2 ? n - 1 : 0);
    size_t s = (size_t)c->step;
    if (c->periodic) return n >= 4 && n % s == 0 ? n / s : 0;
    return n >= 4 && (n - 4) % s == 0 ? (n - 4) / s + 1 : 0;
}

/* The eye (or view direction) in object space at shutter open: the CTM maps object space
 * to world space in the world block, to camera space before it. */
static int curves_camera(rib_parser *p, curves_req *c)
{
    double inv[16], c2w[16], o[3] = {0, 0, 0}, z[3] = {0, 0, 1}, eye[3], dir[3];
    int in_world = p->phase != RIB_BEFORE_WORLD;
    if (!mat4_invert(p->ctm, inv) ||
        (in_world && !mat4_invert(p->scene->camera.world_to_camera, c2w)))
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the current transformation is singular; curves turned to face "
                            "the camera need an invertible one",
                            p->req);
    if (in_world) {
        if (!mat4_point(c2w, o, eye))
            return rib_error_at(p, p->req_line, p->req_col, "%s: the eye leaves the float range",
                                p->req);
        mat4_dir(c2w, z, dir);
    } else {
        memcpy(eye, o, sizeof eye), memcpy(dir, z, sizeof dir);
    }
    c->ortho = p->scene->camera.projection == TS_PROJECTION_ORTHOGRAPHIC;
    if (!mat4_point(inv, eye, c->eye))
        return rib_error_at(p, p->req_line, p->req_col, "%s: the eye leaves the float range",
                            p->req);
    mat4_dir(inv, dir, c->view);
    return TS_OK;
}

static void curves_cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* The unit vector across the ribbon at point x with tangent t: perpendicular to t and to the
 * direction to the eye; any perpendicular of t where those are parallel. */
static void curves_side(const curves_req *c, const double x[3], const double t[3], double s[3])
{
    double v[3];
    for (int d = 0; d < 3; d++)
        v[d] = c->ortho ? c->view[d] : c->eye[d] - x[d];
    curves_cross(t, v, s);
    double len = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    double tl = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    double vl = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 1e-9 * tl * vl)) { /* t along the view (or no tangent): any perpendicular */
        const double ax[3] = {fabs(t[0]) < 0.5 * tl ? 1.0 : 0.0, fabs(t[0]) < 0.5 * tl ? 0.0 : 1.0,
                              0.0};
        curves_cross(t, ax, s);
        len = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        if (!(len > 0.0)) s[0] = 1.0, s[1] = s[2] = 0.0, len = 1.0;
    }
    for (int d = 0; d < 3; d++)
        s[d] /= len;
}

/* The ribbon of one segment: Bézier points b of the centre line, widths w0, w1 at its ends. */
static int curves_ribbon(rib_parser *p, const curves_req *c, const curves_vars *v,
                         const double b[4][3], double w0, double w1, const double *cs)
{
    /* The tangent at row k: the control polygon's difference around b[k] (the curve's own
     * tangent at the ends). */
    static const int before[4] = {0, 0, 1, 2}, after[4] = {1, 2, 3, 3};
    double g[16][3];
    for (int k = 0; k < 4; k++) {
        double t[3], s[3], w = w0 + (w1 - w0) * k / 3.0;
        for (int d = 0; d < 3; d++)
            t[d] = b[after[k]][d] - b[before[k]][d];
        if (t[0] == 0.0 && t[1] == 0.0 && t[2] == 0.0)
            for (int d = 0; d < 3; d++)
                t[d] = b[3][d] - b[0][d];
        curves_side(c, b[k], t, s);
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++)
                g[k * 4 + i][d] = b[k][d] + (i / 3.0 - 0.5) * w * s[d];
    }
    return rib_geom_emit(p, v->line, v->col, (const double(*)[3])g, NULL, cs, NULL);
}

/* The segments of curve `curve` (its points from vertex v0, its varying widths from w0). */
static int curves_one(rib_parser *p, const curves_req *c, const curves_vars *v, size_t curve,
                      size_t v0, size_t wv0)
{
    size_t n = (size_t)c->nvert[curve], segs = curves_segments(c, n);
    size_t nvary = c->periodic ? segs : segs + 1;
    const double *cs = v->cs ? v->cs + (v->cs_each ? 3 * curve : 0) : NULL;
    for (size_t s = 0; s < segs; s++) {
        double b[4][3];
        if (c->cubic) {
            double grid[16][3], bez[16][3];
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++)
                    memcpy(grid[j * 4 + i], v->P + 3 * (v0 + (s * (size_t)c->step + (size_t)j) % n),
                           sizeof grid[0]);
            basis_grid_to_bezier(&basis_bezier, &p->vbasis, (const double(*)[3])grid, bez);
            for (int k = 0; k < 4; k++)
                memcpy(b[k], bez[k * 4], sizeof b[k]);
        } else {
            const double *a = v->P + 3 * (v0 + s), *e = v->P + 3 * (v0 + (s + 1) % n);
            for (int k = 0; k < 4; k++)
                for (int d = 0; d < 3; d++)
                    b[k][d] = a[d] + (e[d] - a[d]) * k / 3.0;
        }
        double w0 = v->width ? v->width[wv0 + s] : v->constant;
        double w1 = v->width ? v->width[wv0 + (s + 1) % nvary] : v->constant;
        int rc = curves_ribbon(p, c, v, (const double(*)[3])b, w0, w1, cs);
        if (rc != TS_OK) return rc;
    }
    return TS_OK;
}

/* Curves type [nvertices] wrap "P" [...] ["width" [varying] | "constantwidth" [w]] ["Cs"
 * constant or uniform]: ribbons facing the camera. */
int rib_req_curves(rib_parser *p)
{
    curves_req c = {0};
    const char *type, *wrap;
    int rc = rib_geom_check(p);
    if (rc == TS_OK) rc = rib_string_arg(p, 0, "a curve type", &type);
    if (rc == TS_OK) rc = rib_int_array(p, 1, "nvertices", 1, RIB_MAX_VALUES, &c.nvert, &c.ncurves);
    if (rc == TS_OK) rc = rib_string_arg(p, 2, "a wrap mode", &wrap);
    if (rc != TS_OK) return rc;
    char shown[RIB_PRINT_MAX];
    c.cubic = strcmp(type, "cubic") == 0;
    c.periodic = strcmp(wrap, "periodic") == 0;
    c.step = p->vbasis.step;
    if (!c.cubic && strcmp(type, "linear") != 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "Curves: unknown type \"%s\" (linear or cubic)",
                            rib_printable(type, shown));
    if (!c.periodic && strcmp(wrap, "nonperiodic") != 0)
        return rib_error_at(p, p->args[2].line, p->args[2].col,
                            "Curves: wrap must be \"periodic\" or \"nonperiodic\"");
    size_t nv = 0, nvary = 0, segs = 0;
    for (size_t k = 0; k < c.ncurves; k++) {
        size_t n = (size_t)c.nvert[k], s = curves_segments(&c, n);
        if (s == 0)
            return rib_error_at(
                p, p->args[1].line, p->args[1].col,
                "Curves: curve %zu has %zu vertices, which do not make %s %s "
                "segments (%s)",
                k, n, c.periodic ? "periodic" : "nonperiodic", c.cubic ? "cubic" : "linear",
                c.cubic
                    ? (c.periodic ? "a multiple of the v step, at least 4" : "4 + k * the v step")
                    : "at least 2");
        nv += n, segs += s, nvary += c.periodic ? s : s + 1;
    }
    if (segs > CURVES_MAX_PATCHES)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Curves: %zu segments would make more than %u patches", segs,
                            CURVES_MAX_PATCHES);
    curves_vars v;
    rc = curves_read_vars(p, 3, nv, nvary, c.ncurves, 0, &v);
    if (rc == TS_OK) rc = curves_camera(p, &c);
    size_t v0 = 0, wv0 = 0;
    for (size_t k = 0; rc == TS_OK && k < c.ncurves; k++) {
        size_t n = (size_t)c.nvert[k], s = curves_segments(&c, n);
        rc = curves_one(p, &c, &v, k, v0, wv0);
        v0 += n, wv0 += c.periodic ? s : s + 1;
    }
    return rc;
}
