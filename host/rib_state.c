/* rib_state.c — the RIB graphics state: the current transformation (RI Spec 3.2 §4.3),
 * Attribute/Transform/World blocks, camera options (Format, Projection) and the Color and
 * Basis attributes. See rib_internal.h for the matrix convention. */
#include "rib_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- matrices (row-major, column vectors) ---------------------------------------- */

void rib_mat_identity(double m[16])
{
    for (int k = 0; k < 16; k++)
        m[k] = (k % 5 == 0) ? 1.0 : 0.0;
}

/* ctm = ctm · t, so t acts on points first: RI Spec §4.3, "the new transformation is
 * applied to points before the old current transformation". */
void rib_mat_concat(double ctm[16], const double t[16])
{
    double r[16];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += ctm[i * 4 + k] * t[k * 4 + j];
            r[i * 4 + j] = s;
        }
    memcpy(ctm, r, sizeof r);
}

/* Rotate deg (degrees) about (x, y, z), RI Spec §4.3 RiRotate. RenderMan spaces are
 * left-handed, so a positive angle turns clockwise seen from the positive end of the axis
 * looking at the origin (the left-hand rule). Written in coordinates that is the ordinary
 * axis-angle (Rodrigues) matrix, the same numbers as pbrt's Rotate: only the picture of
 * "clockwise" depends on handedness, not the matrix. Rotate 90 0 0 1 takes +x to +y,
 * Rotate 90 1 0 0 takes +y to +z, Rotate 90 0 1 0 takes +z to +x. Returns 0 for a
 * zero-length axis. */
static int rib_mat_rotate(double deg, double x, double y, double z, double m[16])
{
    double len = sqrt(x * x + y * y + z * z);
    if (!(len > 0.0) || !isfinite(len)) return 0;
    x /= len, y /= len, z /= len;
    double rad = deg * (3.14159265358979323846 / 180.0);
    double c = cos(rad), s = sin(rad), t = 1.0 - c;
    /* clang-format off */
    const double r[16] = {x * x * t + c,     x * y * t - z * s, x * z * t + y * s, 0,
                          x * y * t + z * s, y * y * t + c,     y * z * t - x * s, 0,
                          x * z * t - y * s, y * z * t + x * s, z * z * t + c,     0,
                          0,                 0,                 0,                 1};
    /* clang-format on */
    memcpy(m, r, sizeof r);
    return 1;
}

/* Gauss-Jordan with partial pivoting. Returns 0 when m is singular or not finite. */
static int rib_mat_invert(const double m[16], double inv[16])
{
    double a[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 8; j++)
            a[i][j] = j < 4 ? m[i * 4 + j] : (j - 4 == i);
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[piv][c])) piv = r;
        if (!(fabs(a[piv][c]) > 1e-300) || !isfinite(a[piv][c])) return 0;
        for (int j = 0; j < 8; j++) {
            double tmp = a[c][j];
            a[c][j] = a[piv][j];
            a[piv][j] = tmp;
        }
        double d = a[c][c];
        for (int j = 0; j < 8; j++)
            a[c][j] /= d;
        for (int r = 0; r < 4; r++) {
            if (r == c) continue;
            double f = a[r][c];
            for (int j = 0; j < 8; j++)
                a[r][j] -= f * a[c][j];
        }
    }
    for (int i = 0; i < 16; i++)
        inv[i] = a[i / 4][4 + i % 4];
    for (int i = 0; i < 16; i++)
        if (!isfinite(inv[i])) return 0;
    return 1;
}

/* Affine up to the scale of w: bottom row (0 0 0 w), w != 0. Patches stay polynomial only
 * under affine maps. */
int rib_mat_is_affine(const double m[16])
{
    return m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] != 0.0 && isfinite(m[15]);
}

/* Maps a point by an affine m. Returns 0 when the result is not a finite float. */
int rib_mat_point(const double m[16], const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++) {
        double v =
            (m[i * 4] * p[0] + m[i * 4 + 1] * p[1] + m[i * 4 + 2] * p[2] + m[i * 4 + 3]) / m[15];
        if (!(fabs(v) <= FLT_MAX)) return 0;
        out[i] = v;
    }
    return 1;
}

/* ---- transformations (RI Spec §4.3) ---------------------------------------------- */

int rib_req_identity(rib_parser *p)
{
    int rc = rib_no_more(p, 0);
    if (rc == TS_OK) rib_mat_identity(p->ctm);
    return rc;
}

int rib_req_translate(rib_parser *p)
{
    double v[3], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 3, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    rib_mat_identity(t);
    t[3] = v[0], t[7] = v[1], t[11] = v[2];
    rib_mat_concat(p->ctm, t);
    return TS_OK;
}

int rib_req_scale(rib_parser *p)
{
    double v[3], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 3, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    rib_mat_identity(t);
    t[0] = v[0], t[5] = v[1], t[10] = v[2];
    rib_mat_concat(p->ctm, t);
    return TS_OK;
}

int rib_req_rotate(rib_parser *p)
{
    double v[4], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 4, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    if (!rib_mat_rotate(v[0], v[1], v[2], v[3], t))
        return rib_error_at(p, p->req_line, p->req_col, "Rotate about a zero-length axis");
    rib_mat_concat(p->ctm, t);
    return TS_OK;
}

/* A RIB [16] matrix (row vectors) as a column-vector matrix: its transpose. */
static int rib_matrix(rib_parser *p, double m[16])
{
    double r[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 16, r);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    for (int k = 0; k < 16; k++)
        m[k] = r[(k % 4) * 4 + k / 4];
    return TS_OK;
}

int rib_req_concat_transform(rib_parser *p)
{
    double m[16];
    int rc = rib_matrix(p, m);
    if (rc == TS_OK) rib_mat_concat(p->ctm, m);
    return rc;
}

/* Transform replaces the CTM: object to world inside the world block, object to camera
 * before it. */
int rib_req_transform(rib_parser *p)
{
    return rib_matrix(p, p->ctm);
}

/* ---- blocks: AttributeBegin/End, TransformBegin/End, WorldBegin/End ---------------- */

static const char *const rib_frame_begin[] = {"AttributeBegin", "TransformBegin", "WorldBegin"};

static int rib_push(rib_parser *p, rib_frame_kind kind)
{
    if (p->depth >= RIB_MAX_DEPTH)
        return rib_error_at(p, p->req_line, p->req_col, "%s nested deeper than %d levels", p->req,
                            RIB_MAX_DEPTH);
    if (p->depth == p->stack_cap) {
        size_t cap = p->stack_cap ? p->stack_cap * 2 : 16;
        rib_frame *s = realloc(p->stack, cap * sizeof *s);
        if (!s) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        p->stack = s;
        p->stack_cap = cap;
    }
    rib_frame *f = &p->stack[p->depth++];
    f->kind = kind;
    f->line = p->req_line;
    f->col = p->req_col;
    memcpy(f->ctm, p->ctm, sizeof f->ctm);
    memcpy(f->color, p->color, sizeof f->color);
    f->ubasis = p->ubasis;
    f->vbasis = p->vbasis;
    return TS_OK;
}

/* Pops the innermost block, which must be of `kind`. TransformEnd restores the CTM only;
 * AttributeEnd and WorldEnd also restore colour and bases. */
static int rib_pop(rib_parser *p, rib_frame_kind kind)
{
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    const rib_frame *top = p->depth ? &p->stack[p->depth - 1] : NULL;
    if (!top || (top->kind == RIB_FRAME_WORLD && kind != RIB_FRAME_WORLD))
        return rib_error_at(p, p->req_line, p->req_col, "%s without a matching %s", p->req,
                            rib_frame_begin[kind]);
    if (top->kind != kind)
        return rib_error_at(p, p->req_line, p->req_col, "%s does not match the %s at %d:%d", p->req,
                            rib_frame_begin[top->kind], top->line, top->col);
    memcpy(p->ctm, top->ctm, sizeof p->ctm);
    if (kind != RIB_FRAME_TRANSFORM) {
        memcpy(p->color, top->color, sizeof p->color);
        p->ubasis = top->ubasis;
        p->vbasis = top->vbasis;
    }
    p->depth--;
    return TS_OK;
}

int rib_req_attribute_begin(rib_parser *p)
{
    int rc = rib_no_more(p, 0);
    return rc == TS_OK ? rib_push(p, RIB_FRAME_ATTRIBUTE) : rc;
}

int rib_req_transform_begin(rib_parser *p)
{
    int rc = rib_no_more(p, 0);
    return rc == TS_OK ? rib_push(p, RIB_FRAME_TRANSFORM) : rc;
}

int rib_req_attribute_end(rib_parser *p)
{
    return rib_pop(p, RIB_FRAME_ATTRIBUTE);
}
int rib_req_transform_end(rib_parser *p)
{
    return rib_pop(p, RIB_FRAME_TRANSFORM);
}

/* Patches and lights read before WorldBegin were placed by a CTM that ends in camera
 * space; move them to world space with camera_to_world = world_to_camera^-1. */
static int rib_camera_items_to_world(rib_parser *p, const double cam_to_world[16])
{
    ts_scene *s = p->scene;
    for (size_t k = (size_t)p->first_patch * 16u; k < (size_t)s->patch_count * 16u; k++) {
        ts_vec4 *c = &s->cp[k];
        double a[3] = {c->x, c->y, c->z}, b[3];
        if (!rib_mat_point(cam_to_world, a, b))
            return rib_error_at(p, p->req_line, p->req_col,
                                "a patch before WorldBegin leaves the float range");
        c->x = (float)b[0], c->y = (float)b[1], c->z = (float)b[2];
    }
    for (uint32_t l = p->first_light; l < s->light_count; l++) {
        ts_distant_light *d = &s->lights[l];
        double from[3], to[3];
        if (!rib_mat_point(cam_to_world, d->from, from) || !rib_mat_point(cam_to_world, d->to, to))
            return rib_error_at(p, p->req_line, p->req_col,
                                "a light before WorldBegin leaves the float range");
        memcpy(d->from, from, sizeof from);
        memcpy(d->to, to, sizeof to);
    }
    return TS_OK;
}

/* The CTM becomes world_to_camera (normalised to w = 1) and the CTM restarts at the
 * identity (RI Spec §4.1.1). */
int rib_req_world_begin(rib_parser *p)
{
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    if (p->phase == RIB_IN_WORLD)
        return rib_error_at(p, p->req_line, p->req_col, "WorldBegin inside the world block");
    if (p->phase == RIB_AFTER_WORLD)
        return rib_error_at(p, p->req_line, p->req_col,
                            "a second WorldBegin: only one world block per file is supported");
    double inv[16];
    if (!rib_mat_is_affine(p->ctm))
        return rib_error_at(p, p->req_line, p->req_col, "the camera transform is projective");
    if (!rib_mat_invert(p->ctm, inv))
        return rib_error_at(p, p->req_line, p->req_col, "the camera transform is singular");
    rc = rib_camera_items_to_world(p, inv);
    if (rc == TS_OK) rc = rib_push(p, RIB_FRAME_WORLD);
    if (rc != TS_OK) return rc;
    for (int k = 0; k < 16; k++)
        p->scene->camera.world_to_camera[k] = p->ctm[k] / p->ctm[15];
    rib_mat_identity(p->ctm);
    p->phase = RIB_IN_WORLD;
    return TS_OK;
}

int rib_req_world_end(rib_parser *p)
{
    if (p->phase != RIB_IN_WORLD)
        return rib_error_at(p, p->req_line, p->req_col, "WorldEnd without WorldBegin");
    int rc = rib_pop(p, RIB_FRAME_WORLD);
    if (rc == TS_OK) p->phase = RIB_AFTER_WORLD;
    return rc;
}

/* ---- camera options and attributes ---------------------------------------------- */

static int rib_before_world(rib_parser *p)
{
    if (p->phase == RIB_BEFORE_WORLD) return TS_OK;
    return rib_error_at(p, p->req_line, p->req_col, "%s must come before WorldBegin", p->req);
}

int rib_req_format(rib_parser *p)
{
    size_t i = 0;
    int w, h;
    double aspect;
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_integer(p, &i, "xresolution", 65536, &w);
    if (rc == TS_OK) rc = rib_integer(p, &i, "yresolution", 65536, &h);
    if (rc == TS_OK) rc = rib_numbers(p, &i, 1, &aspect);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    if (!(aspect > 0.0))
        return rib_error_at(p, p->args[i - 1].line, p->args[i - 1].col,
                            "Format: the pixel aspect ratio must be positive, got %g", aspect);
    if (aspect != 1.0)
        rib_warn_once(p, p->req_line, p->req_col, "Format pixel aspect ratio is ignored");
    p->scene->camera.width = w;
    p->scene->camera.height = h;
    p->scene->camera.has_format = 1;
    return TS_OK;
}

/* Projection "perspective" ["fov" f]: fov is the full angle across the shorter image axis.
 * Like RiProjection, it restarts the CTM at the identity (RI Spec §4.1.1). */
int rib_req_projection(rib_parser *p)
{
    const char *name;
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_string_arg(p, 0, "a projection name", &name);
    if (rc != TS_OK) return rc;
    if (strcmp(name, "orthographic") == 0)
        return rib_error_at(
            p, p->args[0].line, p->args[0].col,
            "Projection \"orthographic\" is not supported yet (only \"perspective\")");
    char shown[RIB_PRINT_MAX];
    if (strcmp(name, "perspective") != 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col, "unknown projection \"%s\"",
                            rib_printable(name, shown));
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "fov") != 0) {
            rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_param_numbers(p, &prm, 1, &v, NULL);
        if (rc != TS_OK) return rc;
        if (!(v[0] > 0.0 && v[0] < 180.0))
            return rib_error_at(p, prm.val->line, prm.val->col,
                                "fov must be between 0 and 180 degrees, got %g", v[0]);
        p->scene->camera.fov_deg = v[0];
    }
    double id[16];
    rib_mat_identity(id);
    if (memcmp(id, p->ctm, sizeof id) != 0)
        rib_warn_once(p, p->req_line, p->req_col,
                      "transformations before Projection are discarded");
    rib_mat_identity(p->ctm);
    return TS_OK;
}

int rib_req_color(rib_parser *p)
{
    size_t i = 0;
    double c[3];
    int rc = rib_numbers(p, &i, 3, c);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    for (int k = 0; k < 3; k++)
        if (!(fabs(c[k]) <= FLT_MAX))
            return rib_error_at(p, p->req_line, p->req_col, "Color: %g is out of range", c[k]);
    memcpy(p->color, c, sizeof c);
    return TS_OK;
}

/* A basis given by name or as a [16] array (RI Spec §5.4, RiBasis). */
static int rib_basis_arg(rib_parser *p, size_t i, const char *what, ts_basis *out)
{
    if (i >= p->nargs)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Basis expects ubasis ustep vbasis vstep, %s is missing", what);
    const rib_arg *a = &p->args[i];
    if (a->kind == RIB_ARG_STRING) {
        const ts_basis *b = basis_by_name(rib_arg_str(p, a, 0));
        char shown[RIB_PRINT_MAX];
        if (!b)
            return rib_error_at(p, a->line, a->col,
                                "unknown basis \"%s\" (bezier, b-spline, catmull-rom, "
                                "hermite, power or a [16] matrix)",
                                rib_printable(rib_arg_str(p, a, 0), shown));
        *out = *b;
        return TS_OK;
    }
    if (a->kind == RIB_ARG_NUMBERS && a->count == 16) {
        *out = basis_from_matrix(rib_arg_nums(p, a), 1);
        return TS_OK;
    }
    return rib_error_at(p, a->line, a->col, "Basis: %s must be a basis name or a [16] matrix",
                        what);
}

int rib_req_basis(rib_parser *p)
{
    ts_basis u, v;
    size_t i = 1, j = 3;
    int rc = rib_basis_arg(p, 0, "ubasis", &u);
    if (rc == TS_OK) rc = rib_integer(p, &i, "ustep", 65536, &u.step);
    if (rc == TS_OK) rc = rib_basis_arg(p, 2, "vbasis", &v);
    if (rc == TS_OK) rc = rib_integer(p, &j, "vstep", 65536, &v.step);
    if (rc == TS_OK) rc = rib_no_more(p, 4);
    if (rc != TS_OK) return rc;
    p->ubasis = u;
    p->vbasis = v;
    return TS_OK;
}
