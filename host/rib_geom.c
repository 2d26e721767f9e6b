/* rib_geom.c — RIB geometry and lights into the scene: Patch and PatchMesh (RI Spec 3.2
 * §5.3) become world-space bicubic Bézier patches, LightSource "distantlight" becomes a
 * ts_distant_light.
 *
 * Every patch is converted when it is read: bicubic grids from the current u/v bases with
 * basis_grid_to_bezier, bilinear ones by exact degree elevation, then its control points
 * are moved by the CTM (by both of its time samples when it moves). Both steps are exact
 * for affine maps, which is why a projective CTM is rejected here. A varying "N" gives the
 * corner displacement normals, moved by the inverse transpose of the CTM; the current
 * Displacement is stored with the world-to-object transform (the inverse CTM).
 */
#include "rib_internal.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

/* Geometry needs a place in the world block (or a file without one) and an affine CTM
 * (at both time samples). */
static int geom_check_state(rib_parser *p)
{
    if (p->phase == RIB_AFTER_WORLD)
        return rib_error_at(p, p->req_line, p->req_col, "%s after WorldEnd", p->req);
    if (!rib_mat_is_affine(p->ctm) || !rib_mat_is_affine(p->ctm1))
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the current transformation is projective; patches and lights "
                            "need an affine one",
                            p->req);
    return TS_OK;
}

/* Moves 16 object-space points by m into w; fails naming the "P" values at line:col. */
static int geom_points(rib_parser *p, int line, int col, const double m[16],
                       const double g[16][3], double w[16][3])
{
    for (int k = 0; k < 16; k++)
        if (!rib_mat_point(m, g[k], w[k]))
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

/* Appends a patch: g0 (and g1, the points at shutter close, or NULL) in object space are
 * moved by the CTM — by its two samples when it moves, which makes the patch move too —
 * with the current colour and displacement. n: the four object-space corner normals of a
 * varying "N" (moved by the inverse transpose of the CTM at shutter open), or NULL.
 * (line, col): the "P" values, (nline, ncol): the "N" values, for messages. */
static int geom_emit(rib_parser *p, int line, int col, const double g0[16][3],
                     const double g1[16][3], const double n[4][3], int nline, int ncol)
{
    double w0[16][3], w1[16][3], wn[4][3], inv[16];
    int moving = g1 != NULL || p->ctm_moving;
    int rc = geom_points(p, line, col, p->ctm, g0, w0);
    if (rc == TS_OK && moving) rc = geom_points(p, line, col, p->ctm1, g1 ? g1 : g0, w1);
    if (rc != TS_OK) return rc;
    ts_patch_attr attr = {.cs_r = (float)p->color[0],
                          .cs_g = (float)p->color[1],
                          .cs_b = (float)p->color[2],
                          .flags = 0u,
                          .disp_kind = p->disp.kind,
                          .disp_octaves = p->disp.octaves,
                          .disp_amplitude = (float)p->disp.amplitude,
                          .disp_frequency = (float)p->disp.frequency,
                          .disp_lacunarity = (float)p->disp.lacunarity,
                          .disp_gain = (float)p->disp.gain,
                          .xform = 0u,
                          .pad = 0u};
    if ((attr.disp_kind != TS_DISP_NONE || n) && !rib_mat_invert(p->ctm, inv))
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the current transformation is singular; %s needs an "
                            "invertible one",
                            p->req, n ? "\"N\"" : "Displacement");
    if (attr.disp_kind != TS_DISP_NONE) {
        rc = geom_xform(p, inv, &attr.xform);
        if (rc != TS_OK) return rc;
    }
    if (n)
        for (int c = 0; c < 4; c++) {
            rib_mat_normal(inv, n[c], wn[c]);
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

/* Finds "P" with exactly `need` numbers and "N" (varying normals) with exactly `need_n`
 * among the parameters from args[first]; *nrm stays NULL without "N". "Pw" and "Pz" are
 * errors (rational and height-field patches are not supported); any other parameter
 * ("Cs", "st", ...) is ignored with a warning. A normal of zero length is an error. */
static int geom_find_p(rib_parser *p, size_t first, size_t need, const double **pts,
                       const rib_arg **at, size_t need_n, const double **nrm,
                       const rib_arg **nat)
{
    *pts = NULL;
    *nrm = NULL;
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "P") == 0) {
            rc = rib_param_numbers(p, &prm, need, pts, NULL);
            if (rc != TS_OK) return rc;
            *at = prm.val;
        } else if (strcmp(prm.name, "N") == 0) {
            rc = rib_param_numbers(p, &prm, need_n, nrm, NULL);
            if (rc != TS_OK) return rc;
            *nat = prm.val;
            for (size_t k = 0; k < need_n / 3; k++) {
                const double *v = *nrm + 3 * k;
                if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0)
                    return rib_error_at(p, prm.val->line, prm.val->col,
                                        "%s: normal %zu of \"N\" is zero", p->req, k);
            }
        } else if (strcmp(prm.name, "Pw") == 0) {
            return rib_error_at(p, prm.key->line, prm.key->col,
                                "%s: rational patches (\"Pw\") are not supported; give \"P\"",
                                p->req);
        } else if (strcmp(prm.name, "Pz") == 0) {
            return rib_error_at(p, prm.key->line, prm.key->col,
                                "%s: height-field patches (\"Pz\") are not supported; give \"P\"",
                                p->req);
        } else {
            rib_warn_param(p, &prm);
        }
    }
    if (!*pts) return rib_error_at(p, p->req_line, p->req_col, "%s: missing \"P\"", p->req);
    return TS_OK;
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

/* Patch "bicubic" "P" [48] in the current bases, or Patch "bilinear" "P" [12]; optional
 * varying "N" [12] at the corners (0,0), (1,0), (0,1), (1,1). Inside a motion block the
 * patch is a sample, emitted at MotionEnd. */
int rib_req_patch(rib_parser *p)
{
    int bicubic;
    const double *pts, *nrm;
    const rib_arg *at = NULL, *nat = NULL;
    int rc = geom_patch_type(p, &bicubic);
    if (rc == TS_OK) rc = geom_check_state(p);
    if (rc == TS_OK) rc = geom_find_p(p, 1, bicubic ? 48 : 12, &pts, &at, 12, &nrm, &nat);
    if (rc != TS_OK) return rc;
    double g[16][3], n[4][3];
    if (bicubic) {
        double in[16][3];
        memcpy(in, pts, sizeof in);
        basis_grid_to_bezier(&p->ubasis, &p->vbasis, (const double(*)[3])in, g);
    } else {
        geom_bilinear_to_bezier(pts, pts + 3, pts + 6, pts + 9, g);
    }
    if (nrm) memcpy(n, nrm, sizeof n);
    rib_motion *m = &p->motion;
    if (m->active) {
        if (m->count == 0) {
            m->bicubic = bicubic;
            m->has_n = nrm != NULL;
            if (nrm) memcpy(m->n, n, sizeof n), m->n_line = nat->line, m->n_col = nat->col;
            m->p_line = at->line, m->p_col = at->col;
        } else if (bicubic != m->bicubic) {
            return rib_error_at(p, p->args[0].line, p->args[0].col,
                                "Patch: type %s does not match the %s Patch at %d:%d in the "
                                "motion block",
                                bicubic ? "bicubic" : "bilinear",
                                m->bicubic ? "bicubic" : "bilinear", m->first_line, m->first_col);
        }
        memcpy(m->g[m->count++], g, sizeof g);
        return TS_OK;
    }
    return geom_emit(p, at->line, at->col, (const double(*)[3])g, NULL,
                     nrm ? (const double(*)[3])n : NULL, nat ? nat->line : 0,
                     nat ? nat->col : 0);
}

/* MotionEnd of a block of two Patch requests: one moving patch, "N" from the first. */
int rib_geom_motion_patch(rib_parser *p)
{
    const rib_motion *m = &p->motion;
    int rc = geom_check_state(p);
    if (rc != TS_OK) return rc;
    return geom_emit(p, m->p_line, m->p_col, (const double(*)[3])m->g[0],
                     (const double(*)[3])m->g[1], m->has_n ? (const double(*)[3])m->n : NULL,
                     m->n_line, m->n_col);
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
    *periodic = strcmp(wrap, "periodic") == 0;
    if (!*periodic && strcmp(wrap, "nonperiodic") != 0)
        return rib_error_at(p, p->args[i + 1].line, p->args[i + 1].col,
                            "PatchMesh: %cwrap must be \"periodic\" or \"nonperiodic\"", dir);
    return geom_mesh_count(p, bicubic, *n, step, *periodic, &p->args[i], dir, count);
}

/* The varying "N" of a PatchMesh: one normal per corner of the patch grid, nuv x nvv of
 * them (u fastest), nuv = patches in u + 1 (nonperiodic) or patches in u (periodic,
 * wrapping), likewise in v (RI Spec §5.3, varying variables). */
typedef struct geom_mesh_n {
    const double *n; /* NULL: no "N" */
    int nuv, nvv;
    int line, col;
} geom_mesh_n;

/* Copies the 4x4 (bicubic) or 2x2 (bilinear) window of patch (pu, pv) out of the mesh,
 * wrapping around periodic directions, and emits it. */
static int geom_mesh_patch(rib_parser *p, const rib_arg *at, const double *pts, int bicubic, int nu,
                           int nv, int pu, int pv, const geom_mesh_n *mn)
{
    const int su = bicubic ? p->ubasis.step : 1, sv = bicubic ? p->vbasis.step : 1;
    const int size = bicubic ? 4 : 2;
    double win[16][3], g[16][3];
    for (int j = 0; j < size; j++)
        for (int i = 0; i < size; i++) {
            size_t iu = ((size_t)pu * (size_t)su + (size_t)i) % (size_t)nu;
            size_t iv = ((size_t)pv * (size_t)sv + (size_t)j) % (size_t)nv;
            memcpy(win[j * size + i], pts + 3 * (iv * (size_t)nu + iu), sizeof win[0]);
        }
    if (bicubic)
        basis_grid_to_bezier(&p->ubasis, &p->vbasis, (const double(*)[3])win, g);
    else
        geom_bilinear_to_bezier(win[0], win[1], win[2], win[3], g);
    double n[4][3];
    if (mn->n)
        for (int c = 0; c < 4; c++) {
            size_t iu = (size_t)(pu + (c & 1)) % (size_t)mn->nuv;
            size_t iv = (size_t)(pv + (c >> 1)) % (size_t)mn->nvv;
            memcpy(n[c], mn->n + 3 * (iv * (size_t)mn->nuv + iu), sizeof n[c]);
        }
    return geom_emit(p, at->line, at->col, (const double(*)[3])g, NULL,
                     mn->n ? (const double(*)[3])n : NULL, mn->line, mn->col);
}

/* PatchMesh type nu uwrap nv vwrap "P" [3 nu nv] ["N" [3 nuv nvv]]. */
int rib_req_patch_mesh(rib_parser *p)
{
    int bicubic, nu, nv, uper, vper, cu, cv;
    const double *pts;
    const rib_arg *at = NULL, *nat = NULL;
    geom_mesh_n mn = {NULL, 0, 0, 0, 0};
    int rc = geom_patch_type(p, &bicubic);
    if (rc == TS_OK) rc = geom_check_state(p);
    if (rc == TS_OK) rc = geom_mesh_direction(p, 1, bicubic, p->ubasis.step, 'u', &nu, &uper, &cu);
    if (rc == TS_OK) rc = geom_mesh_direction(p, 3, bicubic, p->vbasis.step, 'v', &nv, &vper, &cv);
    if (rc != TS_OK) return rc;
    if ((size_t)nu > RIB_MAX_VALUES / (size_t)nv)
        return rib_error_at(p, p->req_line, p->req_col, "PatchMesh: nu * nv is too large");
    mn.nuv = uper ? cu : cu + 1;
    mn.nvv = vper ? cv : cv + 1;
    rc = geom_find_p(p, 5, 3 * (size_t)nu * (size_t)nv, &pts, &at,
                     3 * (size_t)mn.nuv * (size_t)mn.nvv, &mn.n, &nat);
    if (nat) mn.line = nat->line, mn.col = nat->col;
    for (int pv = 0; rc == TS_OK && pv < cv; pv++)
        for (int pu = 0; rc == TS_OK && pu < cu; pu++)
            rc = geom_mesh_patch(p, at, pts, bicubic, nu, nv, pu, pv, &mn);
    return rc;
}

/* The parameters of "distantlight" (RI Spec §9.1.1): intensity, lightcolor, from, to,
 * with or without inline types. */
static int geom_distant_params(rib_parser *p, size_t first, ts_distant_light *l)
{
    static const struct {
        const char *name;
        size_t n;
        size_t offset;
    } known[] = {
        {"intensity", 1, offsetof(ts_distant_light, intensity)},
        {"lightcolor", 3, offsetof(ts_distant_light, color)},
        {"from", 3, offsetof(ts_distant_light, from)},
        {"to", 3, offsetof(ts_distant_light, to)},
    };
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        size_t k = 0;
        while (k < 4 && strcmp(prm.name, known[k].name) != 0)
            k++;
        if (k == 4) {
            rib_warn_param(p, &prm);
            continue;
        }
        const double *v;
        rc = rib_param_numbers(p, &prm, known[k].n, &v, NULL);
        if (rc != TS_OK) return rc;
        memcpy((char *)l + known[k].offset, v, known[k].n * sizeof(double));
    }
    return TS_OK;
}

/* LightSource "distantlight" [handle] params. The handle (a number or a string) is
 * optional and unused. from/to are points in the current space, moved by the CTM; before
 * WorldBegin that is camera space and rib_state.c moves them to world at WorldBegin. */
int rib_req_light_source(rib_parser *p)
{
    const char *shader;
    int rc = rib_string_arg(p, 0, "a light shader name", &shader);
    if (rc == TS_OK) rc = geom_check_state(p);
    if (rc != TS_OK) return rc;
    size_t first = (p->nargs % 2 == 0) ? 2 : 1; /* a handle makes the count even */
    if (first == 2 && p->args[1].kind != RIB_ARG_NUMBER && p->args[1].kind != RIB_ARG_STRING)
        return rib_error_at(p, p->args[1].line, p->args[1].col,
                            "LightSource: the light handle must be a number or a string");
    if (strcmp(shader, "distantlight") != 0) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what, "LightSource \"%s\" is ignored (only distantlight)",
                 rib_printable(shader, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    if (p->ctm_moving)
        rib_warn_once(p, p->req_line, p->req_col,
                      "LightSource under a moving transformation is placed at shutter open");
    ts_distant_light l = {{0, 0, 0}, {0, 0, 1}, 1.0, {1, 1, 1}};
    rc = geom_distant_params(p, first, &l);
    if (rc != TS_OK) return rc;
    double from[3], to[3];
    if (!rib_mat_point(p->ctm, l.from, from) || !rib_mat_point(p->ctm, l.to, to))
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource: from/to leave the float range after the current "
                            "transformation");
    if (from[0] == to[0] && from[1] == to[1] && from[2] == to[2])
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource: distantlight \"from\" and \"to\" are the same point");
    memcpy(l.from, from, sizeof from);
    memcpy(l.to, to, sizeof to);
    return scene_add_light(p->scene, &l, p->err);
}
