/* rib_geom.c — RIB geometry into the scene: Patch and PatchMesh (RI Spec 3.2 §5.3) become
 * world-space bicubic Bézier patches.
 *
 * Every patch is converted when it is read: bicubic grids from the current u/v bases with
 * basis_grid_to_bezier, bilinear ones by exact degree elevation, then its control points
 * are moved by the CTM (by both of its time samples when it moves). Both steps are exact
 * for affine maps, which is why a projective CTM is rejected here. A varying "N" gives the
 * corner displacement normals, moved by the inverse transpose of the CTM; the current
 * Displacement is stored with the world-to-object transform (the inverse CTM).
 */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Geometry needs a place in the world block (or a file without one) and an affine CTM
 * (at both time samples). */
static int geom_check_state(rib_parser *p)
{
    if (p->phase == RIB_AFTER_WORLD)
        return rib_error_at(p, p->req_line, p->req_col, "%s after WorldEnd", p->req);
    const rib_frame *solid = rib_innermost_solid(p);
    if (solid && solid->solid != RIB_SOLID_PRIMITIVE)
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s directly inside the solid begun at %d:%d, which combines solids "
                            "(surfaces go in SolidBegin \"primitive\" blocks, RI Spec 3.2 §5.9)",
                            p->req, solid->line, solid->col);
    if (!mat4_is_affine(p->ctm) || !mat4_is_affine(p->ctm1))
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the current transformation is projective; patches and lights "
                            "need an affine one",
                            p->req);
    return TS_OK;
}

/* Moves 16 object-space points by m into w; fails naming the "P" values at line:col. */
static int geom_points(rib_parser *p, int line, int col, const double m[16], const double g[16][3],
                       double w[16][3])
{
    for (int k = 0; k < 16; k++)
        if (!mat4_point(m, g[k], w[k]))
            return rib_error_at(p, line, col,
                                "%s: control point %d leaves the float range after the "
                                "current transformation",
                                p->req, k);
    return TS_OK;
}

/* The index of the world-to-object transform inv (the inverse of the CTM), reusing the
 * last one while the CTM is unchanged. */
static int geom_xform(rib_parser *p, const double inv[16], uint32_t *index)
{
    if (p->xf_valid && memcmp(p->xf_ctm, p->ctm, sizeof p->xf_ctm) == 0) {
        *index = p->xf_index;
        return TS_OK;
    }
    int rc = scene_add_xform(p->scene, inv, index, p->err);
    if (rc != TS_OK) return rc;
    memcpy(p->xf_ctm, p->ctm, sizeof p->xf_ctm);
    p->xf_index = *index;
    p->xf_valid = 1;
    return TS_OK;
}

/* The attributes in effect as a patch's: colour cs (NULL: the current Color), texture
 * coordinates st at the corners (NULL: the corners' (u, v)), Displacement (xform still 0),
 * Surface, AreaLightSource. */
static ts_patch_attr geom_attr(const rib_parser *p, const double *cs, const double st[4][2])
{
    if (p->surface.has_color) cs = p->surface.color; /* a Bxdf's colour: Color and Cs unused */
    if (!cs) cs = p->color;
    ts_patch_attr attr = {.cs_r = (float)cs[0],
                          .cs_g = (float)cs[1],
                          .cs_b = (float)cs[2],
                          .flags = 0u,
                          .disp_kind = p->disp.kind,
                          .disp_octaves = p->disp.octaves,
                          .disp_amplitude = (float)p->disp.amplitude,
                          .disp_frequency = (float)p->disp.frequency,
                          .disp_lacunarity = (float)p->disp.lacunarity,
                          .disp_gain = (float)p->disp.gain,
                          .xform = 0u,
                          .material = p->surface.material,
                          .kd = (float)p->surface.kd,
                          .ks = (float)p->surface.ks,
                          .roughness = (float)p->surface.roughness,
                          .ior = p->surface.material == TS_MAT_GLASS ? (float)p->surface.ior : 0.0f,
                          .emitter = TS_INVALID,
                          .le_r = (float)p->emission[0],
                          .le_g = (float)p->emission[1],
                          .le_b = (float)p->emission[2],
                          .color_tex = p->surface.textured ? p->surface.tex : 0u,
                          .disp_tex = p->disp.kind == TS_DISP_TEXTURE ? p->disp.tex : 0u,
                          .disp_offset = (float)p->disp.offset,
                          .trim_first = p->emit_trim_first,
                          .trim_count = p->emit_trim_count,
                          .st = {0, 0, 1, 0, 0, 1, 1, 1}};
    if (p->surface.material == TS_MAT_PRINCIPLED) {
        const rib_surface *s = &p->surface;
        attr.metallic = (float)s->metallic, attr.specular = (float)s->specular;
        attr.specular_tint = (float)s->specular_tint, attr.sheen = (float)s->sheen;
        attr.sheen_tint = (float)s->sheen_tint, attr.clearcoat = (float)s->clearcoat;
        attr.clearcoat_gloss = (float)s->clearcoat_gloss;
    }
    if (p->surface.textured) attr.flags |= TS_PATCH_COLOR_TEX;
    if (p->surface.cutout) { /* the mask is the colour texture, or alone in its place */
        attr.flags |= TS_PATCH_CUTOUT | (p->surface.cutout_red ? TS_PATCH_CUTOUT_RED : 0u);
        if (!p->surface.textured) attr.color_tex = p->surface.cutout_tex;
    }
    if (p->no_shadow) attr.flags |= TS_PATCH_NO_SHADOW;
    if (p->no_camera) attr.flags |= TS_PATCH_NO_CAMERA;
    if (p->no_indirect) attr.flags |= TS_PATCH_NO_INDIRECT;
    if (p->surface.constant) /* Surface "constant": Ci = Cs, as an emitter of radiance Cs */
        attr.le_r += (float)cs[0], attr.le_g += (float)cs[1], attr.le_b += (float)cs[2];
    attr.le_r += (float)p->surface.emit[0], attr.le_g += (float)p->surface.emit[1];
    attr.le_b += (float)p->surface.emit[2];
    /* A PxrTexture's manifold (rib_pattern.c): affine in st, so exact at the corners. The
     * colour texture's wins; rib_bxdf.c warns when the displacement's differs. */
    const double *map = p->surface.has_st_map ? p->surface.st_map
                        : p->disp.has_st_map  ? p->disp.st_map
                                              : NULL;
    for (int c = 0; c < 4; c++) {
        double s = st ? st[c][0] : attr.st[2 * c], t = st ? st[c][1] : attr.st[2 * c + 1];
        if (map) s = map[0] * s + map[1], t = map[2] * t + map[3];
        attr.st[2 * c] = (float)s, attr.st[2 * c + 1] = (float)t;
    }
    return attr;
}

int rib_geom_procedural_attr(rib_parser *p, ts_patch_attr *attr)
{
    int rc = geom_check_state(p);
    if (rc != TS_OK) return rc;
    *attr = geom_attr(p, NULL, NULL);
    double inv[16];
    if (attr->disp_kind == TS_DISP_NONE || attr->disp_kind == TS_DISP_TEXTURE) return TS_OK;
    if (!mat4_invert(p->ctm, inv))
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the current transformation is singular; Displacement needs an "
                            "invertible one",
                            p->req);
    return geom_xform(p, inv, &attr->xform);
}

/* A singular CTM where the surface needs its inverse (`needs`: "N" for the normals, or
 * Displacement for the noise's object space). RenderMan draws what the transformation makes
 * of the surface: where it leaves no area (the linear part of rank 1 or 0: a line or a point,
 * as `Scale 0 0 0` makes) *skip is set; else the surface is drawn flattened, with its own
 * normals and without noise displacement. Either way with a warning; with --strict the
 * error. */
static int geom_singular(rib_parser *p, const char *needs, int *skip)
{
    if (p->strict)
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the current transformation is singular; %s needs an "
                            "invertible one",
                            p->req, needs);
    const double *m = p->ctm;
    double minor = 0.0; /* the largest 2 x 2 minor of the linear part */
    for (int r0 = 0; r0 < 3; r0++)
        for (int r1 = r0 + 1; r1 < 3; r1++)
            for (int c0 = 0; c0 < 3; c0++)
                for (int c1 = c0 + 1; c1 < 3; c1++)
                    minor = fmax(minor, fabs(m[4 * r0 + c0] * m[4 * r1 + c1] -
                                             m[4 * r0 + c1] * m[4 * r1 + c0]));
    *skip = !(minor > 1e-300);
    char what[RIB_WARN_KEY + 64];
    snprintf(what, sizeof what,
             *skip ? "%s: the current transformation is singular and leaves the surface no "
                     "area: nothing drawn (--strict makes this an error)"
                   : "%s: the current transformation is singular: the surface is drawn "
                     "flattened, with its own normals and no noise displacement (--strict makes "
                     "this an error)",
             p->req);
    rib_warn_once(p, p->req_line, p->req_col, what);
    return TS_OK;
}

/* The second sample of a deforming block whose times are not the Shutter's (a: rib_motion_shutter):
 * patch q holds the first sample's points under the CTM at shutter open (and at shutter close
 * in cp1 when the CTM moves), g are the second sample's object-space points and w1 those under
 * the CTM at shutter close. Each time sample becomes the surface at that Shutter time under
 * that time's CTM, point by point: (1 - a) first + a second. */
static int geom_deform_shutter(rib_parser *p, int line, int col, uint32_t q, const double g[16][3],
                               const double w1[16][3], const double a[2])
{
    ts_scene *s = p->scene;
    double c0[16][3], x0[16][3], x1[16][3];
    int rc = geom_points(p, line, col, p->ctm, g, c0); /* the second sample at shutter open */
    if (rc != TS_OK) return rc;
    const ts_vec4 *f0 = s->cp + (size_t)q * 16u;
    const ts_vec4 *f1 = s->attr[q].flags & TS_PATCH_MOVING ? s->cp1 + (size_t)q * 16u : f0;
    for (int k = 0; k < 16; k++) { /* the first sample's points, as stored */
        x0[k][0] = f0[k].x, x0[k][1] = f0[k].y, x0[k][2] = f0[k].z;
        x1[k][0] = f1[k].x, x1[k][1] = f1[k].y, x1[k][2] = f1[k].z;
    }
    rib_motion_lerp(&x0[0][0], &c0[0][0], a[0], 48, &x0[0][0]);
    rib_motion_lerp(&x1[0][0], &w1[0][0], a[1], 48, &x1[0][0]);
    return scene_set_patch_samples(s, q, (const double(*)[3])x0, (const double(*)[3])x1, p->err);
}

/* Appends a patch: g0 (and g1, the points at shutter close, or NULL) in object space are
 * moved by the CTM — by its two samples when it moves, which makes the patch move too —
 * with the current attributes, colour cs (NULL: the current Color) and corner texture
 * coordinates st (NULL: the corners' (u, v)). n: the four
 * object-space corner normals from "N" (moved by the inverse transpose of the CTM at
 * shutter open), or NULL. (line, col): the "P" values, (nline, ncol): the "N" values, for
 * messages. */
static int geom_emit(rib_parser *p, int line, int col, const double g0[16][3],
                     const double g1[16][3], const double n[4][3], int nline, int ncol,
                     const double *cs, const double st[4][2])
{
    double w0[16][3], w1[16][3], wn[4][3], inv[16], s0[16][3], s1[16][3], a[2];
    if (rib_geom_transparent(p)) return TS_OK; /* Opacity 0 0 0: not geometry */
    rib_motion *m = &p->motion;
    if (m->active && m->deform && m->sample == 1) { /* shutter close of a patch already made */
        if (m->set == m->made)
            return rib_error_at(p, p->req_line, p->req_col,
                                "%s: the second sample makes more patches than the first at "
                                "%d:%d, %u (the samples must have the same topology)",
                                p->req, m->first_line, m->first_col, m->made);
        uint32_t q = m->first_patch + m->set++;
        int rc = geom_points(p, line, col, p->ctm1, g0, w1);
        if (rc != TS_OK) return rc;
        if (rib_motion_shutter(p, a))
            return geom_deform_shutter(p, line, col, q, g0, (const double(*)[3])w1, a);
        return scene_set_patch_motion(p->scene, q, (const double(*)[3])w1, p->err);
    }
    if (g1 && rib_motion_shutter(p, a)) { /* a Patch block: its points at the Shutter's times */
        rib_motion_lerp(&g0[0][0], &g1[0][0], a[0], 48, &s0[0][0]);
        rib_motion_lerp(&g0[0][0], &g1[0][0], a[1], 48, &s1[0][0]);
        g0 = (const double(*)[3])s0;
        g1 = a[0] == a[1] ? NULL : (const double(*)[3])s1; /* an instant: it does not move */
    }
    int moving = g1 != NULL || p->ctm_moving;
    int rc = geom_points(p, line, col, p->ctm, g0, w0);
    if (rc == TS_OK && moving) rc = geom_points(p, line, col, p->ctm1, g1 ? g1 : g0, w1);
    if (rc != TS_OK) return rc;
    ts_patch_attr attr = geom_attr(p, cs, st);
    int noise = attr.disp_kind == TS_DISP_FBM || attr.disp_kind == TS_DISP_RIDGED;
    if ((noise || n) && !mat4_invert(p->ctm, inv)) {
        int skip = 0;
        rc = geom_singular(p, n ? "\"N\"" : "Displacement", &skip);
        if (rc != TS_OK || skip) return rc;
        if (noise) attr.disp_kind = TS_DISP_NONE, noise = 0;
        n = NULL;
    }
    if (noise) {
        rc = geom_xform(p, inv, &attr.xform);
        if (rc != TS_OK) return rc;
    }
    if (n)
        for (int c = 0; c < 4; c++) {
            mat4_normal(inv, n[c], wn[c]);
            double len = sqrt(wn[c][0] * wn[c][0] + wn[c][1] * wn[c][1] + wn[c][2] * wn[c][2]);
            if (!(len > 0.0) || !isfinite(len))
                return rib_error_at(p, nline, ncol,
                                    "%s: normal %d of \"N\" %s after the current transformation",
                                    p->req, c, len > 0.0 ? "is not finite" : "is zero");
        }
    return scene_add_patch_ex(p->scene, (const double(*)[3])w0,
                              moving ? (const double(*)[3])w1 : NULL,
                              n ? (const double(*)[3])wn : NULL, &attr, p->err);
}

int rib_geom_check(rib_parser *p)
{
    return geom_check_state(p);
}

int rib_geom_emit(rib_parser *p, int line, int col, const double g[16][3], const double n[4][3],
                  const double *cs, const double st[4][2])
{
    return geom_emit(p, line, col, g, NULL, n, line, col, cs, st);
}

/* Degree elevation of the bilinear patch with corners c00, c10, c01, c11 (u fastest) to a
 * bicubic Bézier: for a (bi)linear map the Bézier points are its values at the Greville
 * abscissae (i/3, j/3), so the surface is unchanged. */
static void geom_bilinear_to_bezier(const double *c00, const double *c10, const double *c01,
                                    const double *c11, double g[16][3])
{
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++)
                g[j * 4 + i][d] = ((3 - i) * (3 - j) * c00[d] + i * (3 - j) * c10[d] +
                                   (3 - i) * j * c01[d] + i * j * c11[d]) /
                                  9.0;
}

/* ---- primitive variables ------------------------------------------------------------ */

/* Storage classes of primitive variables (RI Spec 3.2 §5.1). */
enum { GEOM_CONSTANT, GEOM_UNIFORM, GEOM_VARYING, GEOM_VERTEX, GEOM_FACEVARYING, GEOM_CLASSES };
static const char *const geom_class_names[GEOM_CLASSES] = {"constant", "uniform", "varying",
                                                           "vertex", "facevarying"};

/* The patch grid of a Patch (one patch) or PatchMesh: nu x nv control points (u fastest),
 * cu x cv patches, wrapping in periodic directions. */
typedef struct geom_grid {
    int bicubic, nu, nv, cu, cv, uper, vper;
} geom_grid;

/* A primitive variable of dim numbers per value ("N", "Cs": 3, "st": 2): its values and
 * class. */
typedef struct geom_var {
    const double *v; /* NULL: not given */
    int cls, dim;
    int line, col; /* of the values */
} geom_var;

typedef struct geom_vars {
    const double *P;
    double *P_height; /* "Pz": the points made from the heights (geom_vars_free) */
    const rib_arg *P_at;
    geom_var N, Cs, st;
} geom_vars;

/* How many values a variable of class cls has on the grid (RI Spec §5.3): uniform one per
 * patch, varying one per patch corner (shared, wrapping), vertex one per control point,
 * facevarying four per patch. */
static size_t geom_class_count(const geom_grid *g, int cls)
{
    size_t patches = (size_t)g->cu * (size_t)g->cv;
    size_t nuv = (size_t)(g->uper ? g->cu : g->cu + 1), nvv = (size_t)(g->vper ? g->cv : g->cv + 1);
    switch (cls) {
    case GEOM_CONSTANT:
        return 1;
    case GEOM_UNIFORM:
        return patches;
    case GEOM_VARYING:
        return nuv * nvv;
    case GEOM_VERTEX:
        return (size_t)g->nu * (size_t)g->nv;
    default:
        return 4 * patches;
    }
}

/* The class named in an inline declaration ("uniform color Cs"), else `dflt`. */
static int geom_class_of(const char *decl, int dflt)
{
    size_t n = strlen(decl);
    for (size_t s = 0; s < n;) {
        size_t e = s;
        while (e < n && decl[e] != ' ')
            e++;
        for (int c = 0; c < GEOM_CLASSES; c++)
            if (e - s == strlen(geom_class_names[c]) &&
                strncmp(decl + s, geom_class_names[c], e - s) == 0)
                return c;
        if (e - s == 10 && strncmp(decl + s, "facevertex", 10) == 0) return GEOM_FACEVARYING;
        s = e + 1;
    }
    return dflt;
}

/* Reads one 3-number variable ("N" or "Cs") with its class and count. */
static int geom_read_var(rib_parser *p, const rib_param *prm, const geom_grid *g, geom_var *out)
{
    int cls = geom_class_of(rib_arg_str(p, prm->key, 0), GEOM_VARYING);
    size_t count = geom_class_count(g, cls);
    const double *v;
    const rib_arg *val = prm->val;
    char shown[RIB_PRINT_MAX];
    if (cls != GEOM_VARYING && (val->kind == RIB_ARG_NUMBER || val->kind == RIB_ARG_NUMBERS) &&
        val->count != 3 * count)
        return rib_error_at(
            p, val->line, val->col, "%s: parameter \"%s\" (%s) needs %zu values, got %zu", p->req,
            rib_printable(prm->name, shown), geom_class_names[cls], 3 * count, val->count);
    int rc = rib_param_numbers(p, prm, 3 * count, &v, NULL);
    if (rc != TS_OK) return rc;
    int is_n = strcmp(prm->name, "N") == 0;
    for (size_t k = 0; k < count; k++) {
        const double *x = v + 3 * k;
        if (is_n && x[0] == 0.0 && x[1] == 0.0 && x[2] == 0.0)
            return rib_error_at(p, prm->val->line, prm->val->col, "%s: normal %zu of \"N\" is zero",
                                p->req, k);
        if (!is_n && !(fabs(x[0]) <= FLT_MAX && fabs(x[1]) <= FLT_MAX && fabs(x[2]) <= FLT_MAX))
            return rib_error_at(p, prm->val->line, prm->val->col,
                                "%s: colour %zu of \"Cs\" is out of range", p->req, k);
    }
    out->v = v;
    out->cls = cls;
    out->dim = 3;
    out->line = prm->val->line;
    out->col = prm->val->col;
    return TS_OK;
}

/* Reads "st" (2 numbers per value, varying unless declared; not vertex) with its class. */
static int geom_read_st(rib_parser *p, const rib_param *prm, const geom_grid *g, geom_var *out)
{
    int cls = geom_class_of(rib_arg_str(p, prm->key, 0), GEOM_VARYING);
    if (cls == GEOM_VERTEX)
        return rib_error_at(p, prm->key->line, prm->key->col,
                            "%s: \"st\" of class vertex is not supported (varying, uniform, "
                            "facevarying or constant)",
                            p->req);
    size_t count = geom_class_count(g, cls);
    const double *v;
    int rc = rib_param_numbers(p, prm, 2 * count, &v, NULL);
    if (rc != TS_OK) return rc;
    for (size_t k = 0; k < 2 * count; k++)
        if (!(fabs(v[k]) <= FLT_MAX))
            return rib_error_at(p, prm->val->line, prm->val->col,
                                "%s: value %zu of \"st\" is out of range", p->req, k);
    *out = (geom_var){v, cls, 2, prm->val->line, prm->val->col};
    return TS_OK;
}

/* A height field (RI Spec 3.2 §5: "Pz", one z a control point, whose x and y are the mesh's
 * surface parameters): point (i, j) of the nu x nv grid is (i / (nu - 1), j / (nv - 1), z),
 * or i / nu along a periodic direction (whose points wrap around). Into out->P_height. */
static int geom_height_field(rib_parser *p, const rib_param *prm, const geom_grid *g,
                             geom_vars *out)
{
    const double *z;
    size_t n = (size_t)g->nu * (size_t)g->nv;
    int rc = rib_param_numbers(p, prm, n, &z, NULL);
    if (rc != TS_OK) return rc;
    if (!(out->P_height = malloc(3 * n * sizeof *out->P_height)))
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->req);
    double du = g->uper ? g->nu : g->nu - 1, dv = g->vper ? g->nv : g->nv - 1;
    for (size_t j = 0, k = 0; j < (size_t)g->nv; j++)
        for (size_t i = 0; i < (size_t)g->nu; i++, k++) {
            out->P_height[3 * k] = (double)i / du;
            out->P_height[3 * k + 1] = (double)j / dv;
            out->P_height[3 * k + 2] = z[k];
        }
    out->P = out->P_height;
    return TS_OK;
}

static void geom_vars_free(geom_vars *v)
{
    free(v->P_height);
    v->P_height = NULL;
}

/* Finds "P" (3 nu nv numbers) or "Pz" (nu nv heights: geom_height_field), "N" and "Cs" (any
 * class, 3 numbers per value), "st" (2 per value) among the parameters from args[first].
 * "Pw" is an error (rational patches are not supported); any other parameter ("s", "t",
 * "Os", ...) is ignored with a warning. On success the caller frees *out (geom_vars_free). */
static int geom_find_vars(rib_parser *p, size_t first, const geom_grid *g, geom_vars *out)
{
    memset(out, 0, sizeof *out);
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc == TS_OK && out->P && (strcmp(prm.name, "P") == 0 || strcmp(prm.name, "Pz") == 0))
            rc = rib_error_at(p, prm.key->line, prm.key->col,
                              "%s: \"%s\" after the points were given (one of \"P\" or \"Pz\")",
                              p->req, prm.name);
        if (rc != TS_OK) return geom_vars_free(out), rc;
        if (strcmp(prm.name, "P") == 0) {
            rc = rib_param_numbers(p, &prm, 3 * (size_t)g->nu * (size_t)g->nv, &out->P, NULL);
            out->P_at = prm.val;
        } else if (strcmp(prm.name, "Pz") == 0) {
            rc = geom_height_field(p, &prm, g, out);
            out->P_at = prm.val;
        } else if (strcmp(prm.name, "N") == 0) {
            rc = geom_read_var(p, &prm, g, &out->N);
        } else if (strcmp(prm.name, "Cs") == 0) {
            rc = geom_read_var(p, &prm, g, &out->Cs);
        } else if (strcmp(prm.name, "st") == 0) {
            rc = geom_read_st(p, &prm, g, &out->st);
        } else if (strcmp(prm.name, "Pw") == 0) {
            geom_vars_free(out);
            return rib_error_at(p, prm.key->line, prm.key->col,
                                "%s: rational patches (\"Pw\") are not supported; give \"P\"",
                                p->req);
        } else {
            rib_warn_param(p, &prm);
        }
        if (rc != TS_OK) return geom_vars_free(out), rc;
    }
    if (!out->P)
        return rib_error_at(p, p->req_line, p->req_col, "%s: missing \"P\" (or \"Pz\")", p->req);
    return TS_OK;
}

/* The 4x4 (bicubic) or 2x2 (bilinear) window of per-control-point values (3 numbers each)
 * of patch (pu, pv), wrapping around periodic directions. */
static void geom_window(const rib_parser *p, const geom_grid *g, const double *vals, int pu, int pv,
                        double win[16][3])
{
    const int su = g->bicubic ? p->ubasis.step : 1, sv = g->bicubic ? p->vbasis.step : 1;
    const int size = g->bicubic ? 4 : 2;
    for (int j = 0; j < size; j++)
        for (int i = 0; i < size; i++) {
            size_t iu = ((size_t)pu * (size_t)su + (size_t)i) % (size_t)g->nu;
            size_t iv = ((size_t)pv * (size_t)sv + (size_t)j) % (size_t)g->nv;
            memcpy(win[j * size + i], vals + 3 * (iv * (size_t)g->nu + iu), sizeof win[0]);
        }
}

/* The control window of patch (pu, pv) as a Bézier grid: bicubic windows through the
 * current bases, bilinear ones degree-elevated. */
static void geom_to_bezier(const rib_parser *p, const geom_grid *g, const double *vals, int pu,
                           int pv, double out[16][3])
{
    double win[16][3];
    geom_window(p, g, vals, pu, pv, win);
    if (g->bicubic)
        basis_grid_to_bezier(&p->ubasis, &p->vbasis, (const double(*)[3])win, out);
    else
        geom_bilinear_to_bezier(win[0], win[1], win[2], win[3], out);
}

/* The values of a variable at the four corners (0,0), (1,0), (0,1), (1,1) of patch
 * (pu, pv). Vertex-class values are control values like "P": the corners of their Bézier
 * form are the values the surface takes there. */
static void geom_var_corners(const rib_parser *p, const geom_grid *g, const geom_var *var, int pu,
                             int pv, double out[4][3])
{
    size_t patch = (size_t)pv * (size_t)g->cu + (size_t)pu;
    size_t nuv = (size_t)(g->uper ? g->cu : g->cu + 1), nvv = (size_t)(g->vper ? g->cv : g->cv + 1);
    if (var->cls == GEOM_VERTEX) {
        double bez[16][3];
        geom_to_bezier(p, g, var->v, pu, pv, bez);
        static const int corner[4] = {0, 3, 12, 15};
        for (int c = 0; c < 4; c++)
            memcpy(out[c], bez[corner[c]], sizeof out[c]);
        return;
    }
    for (int c = 0; c < 4; c++) {
        size_t k = 0;
        if (var->cls == GEOM_UNIFORM) k = patch;
        if (var->cls == GEOM_FACEVARYING) k = 4 * patch + (size_t)c;
        if (var->cls == GEOM_VARYING)
            k = ((size_t)(pv + (c >> 1)) % nvv) * nuv + (size_t)(pu + (c & 1)) % nuv;
        memcpy(out[c], var->v + (size_t)var->dim * k, (size_t)var->dim * sizeof out[c][0]);
    }
}

/* The patch's "st" at its four corners. */
static void geom_st_corners(const rib_parser *p, const geom_grid *g, const geom_var *var, int pu,
                            int pv, double st[4][2])
{
    double c4[4][3];
    geom_var_corners(p, g, var, pu, pv, c4);
    for (int c = 0; c < 4; c++)
        st[c][0] = c4[c][0], st[c][1] = c4[c][1];
}

/* The patch's colour from "Cs": the average of its four corner colours (the renderer keeps
 * one colour per patch). */
static void geom_var_colour(const rib_parser *p, const geom_grid *g, const geom_var *var, int pu,
                            int pv, double cs[3])
{
    double c4[4][3];
    geom_var_corners(p, g, var, pu, pv, c4);
    for (int d = 0; d < 3; d++)
        cs[d] = 0.25 * (c4[0][d] + c4[1][d] + c4[2][d] + c4[3][d]);
}

/* The patch type argument: 1 for "bicubic", 0 for "bilinear". */
static int geom_patch_type(rib_parser *p, int *bicubic)
{
    const char *type;
    int rc = rib_string_arg(p, 0, "a patch type", &type);
    if (rc != TS_OK) return rc;
    *bicubic = strcmp(type, "bicubic") == 0;
    char shown[RIB_PRINT_MAX];
    if (!*bicubic && strcmp(type, "bilinear") != 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "%s: unknown patch type \"%s\" (bicubic or bilinear)", p->req,
                            rib_printable(type, shown));
    return TS_OK;
}

/* Patch "bicubic" "P" [48] in the current bases, or Patch "bilinear" "P" [12] ("Pz": 16 or 4
 * heights, geom_height_field); optional
 * "N" (corner normals) and "Cs" (colour) of any class. Inside a motion block the patch is
 * a sample, emitted at MotionEnd. */
int rib_req_patch(rib_parser *p)
{
    int bicubic;
    geom_vars vars;
    int rc = geom_patch_type(p, &bicubic);
    if (rc == TS_OK) rc = geom_check_state(p);
    if (rc != TS_OK) return rc;
    geom_grid g = {bicubic, bicubic ? 4 : 2, bicubic ? 4 : 2, 1, 1, 0, 0};
    rc = geom_find_vars(p, 1, &g, &vars);
    if (rc != TS_OK) return rc;
    double bez[16][3], n[4][3], cs[3], st[4][2];
    geom_to_bezier(p, &g, vars.P, 0, 0, bez);
    geom_vars_free(&vars);
    if (vars.N.v) geom_var_corners(p, &g, &vars.N, 0, 0, n);
    if (vars.Cs.v) geom_var_colour(p, &g, &vars.Cs, 0, 0, cs);
    if (vars.st.v) geom_st_corners(p, &g, &vars.st, 0, 0, st);
    rib_motion *m = &p->motion;
    if (m->active) {
        if (m->count == 0) {
            m->bicubic = bicubic;
            m->has_n = vars.N.v != NULL;
            if (vars.N.v) memcpy(m->n, n, sizeof n), m->n_line = vars.N.line, m->n_col = vars.N.col;
            m->has_cs = vars.Cs.v != NULL;
            if (vars.Cs.v) memcpy(m->cs, cs, sizeof cs);
            m->has_st = vars.st.v != NULL;
            if (vars.st.v) memcpy(m->st, st, sizeof st);
            m->p_line = vars.P_at->line, m->p_col = vars.P_at->col;
        } else if (bicubic != m->bicubic) {
            return rib_error_at(p, p->args[0].line, p->args[0].col,
                                "Patch: type %s does not match the %s Patch at %d:%d in the "
                                "motion block",
                                bicubic ? "bicubic" : "bilinear",
                                m->bicubic ? "bicubic" : "bilinear", m->first_line, m->first_col);
        }
        memcpy(m->g[m->count++], bez, sizeof bez);
        return TS_OK;
    }
    return geom_emit(p, vars.P_at->line, vars.P_at->col, (const double(*)[3])bez, NULL,
                     vars.N.v ? (const double(*)[3])n : NULL, vars.N.line, vars.N.col,
                     vars.Cs.v ? cs : NULL, vars.st.v ? (const double(*)[2])st : NULL);
}

/* MotionEnd of a block of two Patch requests: one moving patch, "N", "Cs" and "st" from
 * the first. */
int rib_geom_motion_patch(rib_parser *p)
{
    const rib_motion *m = &p->motion;
    int rc = geom_check_state(p);
    if (rc != TS_OK) return rc;
    return geom_emit(p, m->p_line, m->p_col, (const double(*)[3])m->g[0],
                     (const double(*)[3])m->g[1], m->has_n ? (const double(*)[3])m->n : NULL,
                     m->n_line, m->n_col, m->has_cs ? m->cs : NULL,
                     m->has_st ? (const double(*)[2])m->st : NULL);
}

/* Patches along one direction of a PatchMesh (RI Spec §5.3, RiPatchMesh): bicubic
 * nonperiodic (n - 4) / step + 1 with n = 4 + k step, periodic n / step with n = k step;
 * bilinear nonperiodic n - 1, periodic n. */
static int geom_mesh_count(rib_parser *p, int bicubic, int n, int step, int periodic,
                           const rib_arg *at, char dir, int *count)
{
    if (!bicubic) {
        if (n < 2)
            return rib_error_at(p, at->line, at->col, "PatchMesh: bilinear n%c must be at least 2",
                                dir);
        *count = periodic ? n : n - 1;
    } else if (periodic) {
        if (n % step != 0)
            return rib_error_at(p, at->line, at->col,
                                "PatchMesh: periodic n%c = %d is not a multiple of the %c step %d",
                                dir, n, dir, step);
        *count = n / step;
    } else {
        if (n < 4 || (n - 4) % step != 0)
            return rib_error_at(p, at->line, at->col,
                                "PatchMesh: nonperiodic n%c = %d is not 4 + k * %d (the %c step)",
                                dir, n, step, dir);
        *count = (n - 4) / step + 1;
    }
    return TS_OK;
}

/* Reads n<dir> (args[i]) and its wrap mode (args[i + 1]) and counts the patches. */
static int geom_mesh_direction(rib_parser *p, size_t i, int bicubic, int step, char dir, int *n,
                               int *periodic, int *count)
{
    const char *wrap;
    char what[4] = {'n', dir, '\0', '\0'};
    size_t k = i;
    int rc = rib_integer(p, &k, what, RIB_MAX_VALUES, n);
    if (rc == TS_OK) rc = rib_string_arg(p, i + 1, "\"periodic\" or \"nonperiodic\"", &wrap);
    if (rc != TS_OK) return rc;
    /* "wrap" and "nowrap": how older exporters spell the two modes. */
    *periodic = strcmp(wrap, "periodic") == 0 || strcmp(wrap, "wrap") == 0;
    if (!*periodic && strcmp(wrap, "nonperiodic") != 0 && strcmp(wrap, "nowrap") != 0)
        return rib_error_at(p, p->args[i + 1].line, p->args[i + 1].col,
                            "PatchMesh: %cwrap must be \"periodic\" or \"nonperiodic\" (or "
                            "\"wrap\", \"nowrap\")",
                            dir);
    return geom_mesh_count(p, bicubic, *n, step, *periodic, &p->args[i], dir, count);
}

/* PatchMesh type nu uwrap nv vwrap "P" [3 nu nv] (or "Pz" [nu nv]) ["N" ...] ["Cs" ...] ["st" ...]:
 * "N" and "Cs" of any class, "st" of any but vertex, counted on the grid of patches
 * (geom_class_count). */
int rib_req_patch_mesh(rib_parser *p)
{
    geom_grid g;
    geom_vars vars;
    int rc = geom_patch_type(p, &g.bicubic);
    if (rc == TS_OK) rc = geom_check_state(p);
    if (rc == TS_OK)
        rc = geom_mesh_direction(p, 1, g.bicubic, p->ubasis.step, 'u', &g.nu, &g.uper, &g.cu);
    if (rc == TS_OK)
        rc = geom_mesh_direction(p, 3, g.bicubic, p->vbasis.step, 'v', &g.nv, &g.vper, &g.cv);
    if (rc != TS_OK) return rc;
    if ((size_t)g.nu > RIB_MAX_VALUES / (size_t)g.nv)
        return rib_error_at(p, p->req_line, p->req_col, "PatchMesh: nu * nv is too large");
    rc = geom_find_vars(p, 5, &g, &vars);
    for (int pv = 0; rc == TS_OK && pv < g.cv; pv++)
        for (int pu = 0; rc == TS_OK && pu < g.cu; pu++) {
            double bez[16][3], n[4][3], cs[3], st[4][2];
            geom_to_bezier(p, &g, vars.P, pu, pv, bez);
            if (vars.N.v) geom_var_corners(p, &g, &vars.N, pu, pv, n);
            if (vars.Cs.v) geom_var_colour(p, &g, &vars.Cs, pu, pv, cs);
            if (vars.st.v) geom_st_corners(p, &g, &vars.st, pu, pv, st);
            rc = geom_emit(p, vars.P_at->line, vars.P_at->col, (const double(*)[3])bez, NULL,
                           vars.N.v ? (const double(*)[3])n : NULL, vars.N.line, vars.N.col,
                           vars.Cs.v ? cs : NULL, vars.st.v ? (const double(*)[2])st : NULL);
        }
    geom_vars_free(&vars);
    return rc;
}

int rib_geom_transparent(const rib_parser *p)
{
    return p->opacity[0] == 0.0 && p->opacity[1] == 0.0 && p->opacity[2] == 0.0;
}

int rib_geom_bezier(rib_parser *p, const double g[16][3])
{
    int rc = geom_check_state(p);
    if (rc != TS_OK) return rc;
    return geom_emit(p, p->req_line, p->req_col, g, NULL, NULL, 0, 0, NULL, NULL);
}
