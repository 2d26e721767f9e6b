/* rib_state.c — the RIB graphics state: the current transformation (RI Spec 3.2 §4.3) with
 * its two time samples, Attribute/Transform/World blocks, camera options (Format,
 * Projection), the Color, Basis and Displacement attributes and MotionBegin/MotionEnd
 * blocks. See rib_parser.h for the matrix convention. */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"

#include "lib/displace.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- transformations (RI Spec §4.3) ---------------------------------------------- */

/* Both time samples of the CTM become m (replace) or are multiplied by m. Inside a motion
 * block the matrix is a sample, applied at MotionEnd. */
static int rib_apply_transform(rib_parser *p, const double m[16], int replace)
{
    rib_motion *mo = &p->motion;
    if (mo->active) {
        memcpy(mo->m[mo->count], m, sizeof mo->m[0]);
        mo->replace = replace;
        mo->count++;
        return TS_OK;
    }
    if (replace) {
        memcpy(p->ctm, m, sizeof p->ctm);
        memcpy(p->ctm1, m, sizeof p->ctm1);
        p->ctm_moving = 0;
    } else {
        mat4_concat(p->ctm, m);
        if (p->ctm_moving)
            mat4_concat(p->ctm1, m);
        else
            memcpy(p->ctm1, p->ctm, sizeof p->ctm1);
    }
    return TS_OK;
}

int rib_req_identity(rib_parser *p)
{
    double id[16];
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    mat4_identity(id);
    return rib_apply_transform(p, id, 1);
}

int rib_req_translate(rib_parser *p)
{
    double v[3], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 3, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    mat4_identity(t);
    t[3] = v[0], t[7] = v[1], t[11] = v[2];
    return rib_apply_transform(p, t, 0);
}

int rib_req_scale(rib_parser *p)
{
    double v[3], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 3, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    mat4_identity(t);
    t[0] = v[0], t[5] = v[1], t[10] = v[2];
    return rib_apply_transform(p, t, 0);
}

int rib_req_rotate(rib_parser *p)
{
    double v[4], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 4, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    if (!mat4_rotate(v[0], v[1], v[2], v[3], t))
        return rib_error_at(p, p->req_line, p->req_col, "Rotate about a zero-length axis");
    return rib_apply_transform(p, t, 0);
}

/* Skew angle dx1 dy1 dz1 dx2 dy2 dz2 (mat4_skew). */
int rib_req_skew(rib_parser *p)
{
    double v[7], t[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 7, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    if (!mat4_skew(v[0], v + 1, v + 4, t))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Skew %g: the axes must be nonzero and not parallel, and the angle "
                            "less than theirs and more than theirs - 180 degrees",
                            v[0]);
    return rib_apply_transform(p, t, 0);
}

/* A RIB [16] matrix (row vectors) as a column-vector matrix: its transpose. Exporters
 * write affine matrices through float arithmetic, leaving noise such as -4.8e-09 where the
 * projective column holds 0 (mtor, Maya): entries there below 1e-6 of the matrix's largest
 * are taken as the 0 they stand for, so the matrix stays affine. */
static int rib_matrix(rib_parser *p, double m[16])
{
    double r[16];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 16, r);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    double big = 0.0;
    for (int k = 0; k < 16; k++) {
        m[k] = r[(k % 4) * 4 + k / 4];
        if (k < 12 || k == 15) big = fmax(big, fabs(m[k]));
    }
    for (int k = 12; k < 15; k++)
        if (fabs(m[k]) <= 1e-6 * big) m[k] = 0.0;
    return TS_OK;
}

int rib_req_concat_transform(rib_parser *p)
{
    double m[16];
    int rc = rib_matrix(p, m);
    return rc == TS_OK ? rib_apply_transform(p, m, 0) : rc;
}

/* Transform replaces the CTM: object to world inside the world block, object to camera
 * before it. */
int rib_req_transform(rib_parser *p)
{
    double m[16];
    int rc = rib_matrix(p, m);
    return rc == TS_OK ? rib_apply_transform(p, m, 1) : rc;
}

/* ---- blocks: AttributeBegin/End, TransformBegin/End, WorldBegin/End ---------------- */

/* The requests that open and close each rib_frame_kind. */
static const struct {
    const char *begin, *end;
} rib_frame_names[] = {
    [RIB_FRAME_ATTRIBUTE] = {"AttributeBegin", "AttributeEnd"},
    [RIB_FRAME_TRANSFORM] = {"TransformBegin", "TransformEnd"},
    [RIB_FRAME_WORLD] = {"WorldBegin", "WorldEnd"},
    [RIB_FRAME_SOLID] = {"SolidBegin", "SolidEnd"},
};

void rib_state_save(const rib_parser *p, rib_frame *f)
{
    memcpy(f->ctm, p->ctm, sizeof f->ctm);
    memcpy(f->ctm1, p->ctm1, sizeof f->ctm1);
    f->ctm_moving = p->ctm_moving;
    memcpy(f->color, p->color, sizeof f->color);
    f->ubasis = p->ubasis;
    f->vbasis = p->vbasis;
    f->disp = p->disp;
    f->surface = p->surface;
    memcpy(f->emission, p->emission, sizeof f->emission);
    memcpy(f->opacity, p->opacity, sizeof f->opacity);
    f->no_shadow = p->no_shadow;
    f->no_camera = p->no_camera;
    f->no_indirect = p->no_indirect;
    f->trim = p->trim;
}

void rib_state_restore(rib_parser *p, const rib_frame *f, int attributes)
{
    memcpy(p->ctm, f->ctm, sizeof p->ctm);
    memcpy(p->ctm1, f->ctm1, sizeof p->ctm1);
    p->ctm_moving = f->ctm_moving;
    if (!attributes) return;
    memcpy(p->color, f->color, sizeof p->color);
    p->ubasis = f->ubasis;
    p->vbasis = f->vbasis;
    p->disp = f->disp;
    p->surface = f->surface;
    memcpy(p->emission, f->emission, sizeof p->emission);
    memcpy(p->opacity, f->opacity, sizeof p->opacity);
    p->no_shadow = f->no_shadow;
    p->no_camera = f->no_camera;
    p->no_indirect = f->no_indirect;
    p->trim = f->trim;
}

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
    rib_state_save(p, f);
    return TS_OK;
}

/* Restores the state the innermost block (of `kind`) saved and drops it: TransformEnd
 * restores the CTM (both time samples) only; AttributeEnd and WorldEnd also restore colour,
 * bases, displacement, surface, emission and opacity. */
static void rib_restore(rib_parser *p, rib_frame_kind kind)
{
    rib_state_restore(p, &p->stack[p->depth - 1], kind != RIB_FRAME_TRANSFORM);
    p->depth--;
    if (kind != RIB_FRAME_TRANSFORM) { /* what was scoped to the attribute block */
        rib_coordsys_scope_end(p);
        rib_user_scope_end(p);
        rib_rlf_scope_end(p);
    }
}

/* Pops the innermost block, which must be of `kind`. */
static int rib_pop(rib_parser *p, rib_frame_kind kind)
{
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    const rib_frame *top = p->depth ? &p->stack[p->depth - 1] : NULL;
    if (!top || (top->kind == RIB_FRAME_WORLD && kind != RIB_FRAME_WORLD))
        return rib_error_at(p, p->req_line, p->req_col, "%s without a matching %s", p->req,
                            rib_frame_names[kind].begin);
    if (top->kind != kind)
        return rib_error_at(p, p->req_line, p->req_col, "%s does not match the %s at %d:%d", p->req,
                            rib_frame_names[top->kind].begin, top->line, top->col);
    rib_restore(p, kind);
    return TS_OK;
}

int rib_attributes_push(rib_parser *p)
{
    return rib_push(p, RIB_FRAME_ATTRIBUTE);
}

int rib_attributes_pop(rib_parser *p)
{
    if (p->depth == 0 || p->stack[p->depth - 1].kind != RIB_FRAME_ATTRIBUTE)
        return ts_error_set(p->err, TS_E_INTERNAL,
                            "%s: an instance's attribute block is not on top", p->lx.file);
    rib_restore(p, RIB_FRAME_ATTRIBUTE);
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

/* ---- solids (RI Spec 3.2 §5.9) ------------------------------------------------------ */

static const char *const rib_solid_ops[] = {"primitive", "union", "intersection", "difference"};

const rib_frame *rib_innermost_solid(const rib_parser *p)
{
    for (size_t i = p->depth; i-- > 0;)
        if (p->stack[i].kind == RIB_FRAME_SOLID) return &p->stack[i];
    return NULL;
}

/* SolidBegin "primitive" | "union" | "intersection" | "difference": a block like
 * AttributeBegin. The surfaces of every solid are drawn as they are. For "primitive" and
 * "union" of closed opaque solids seen from outside that is the exact image: the first
 * surface a ray from outside meets bounds the union. "intersection" and "difference" would
 * need set operations along each ray, which Tessera does not do: as the RI Spec allows when
 * the optional Solid Modeling capability is missing, their solids are drawn as surfaces,
 * with a warning. */
int rib_req_solid_begin(rib_parser *p)
{
    const char *op;
    char shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "an operation", &op);
    if (rc == TS_OK) rc = rib_no_more(p, 1);
    if (rc != TS_OK) return rc;
    if (p->phase != RIB_IN_WORLD)
        return rib_error_at(p, p->req_line, p->req_col, "SolidBegin outside the world block");
    size_t k = 0;
    while (k < 4 && strcmp(op, rib_solid_ops[k]) != 0)
        ++k;
    if (k == 4)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "SolidBegin: unknown operation \"%s\" (primitive, union, "
                            "intersection or difference)",
                            rib_printable(op, shown));
    const rib_frame *in = rib_innermost_solid(p);
    if (in && in->solid == RIB_SOLID_PRIMITIVE)
        return rib_error_at(p, p->req_line, p->req_col,
                            "SolidBegin inside the \"primitive\" solid begun at %d:%d (a primitive "
                            "solid holds surfaces, not other solids)",
                            in->line, in->col);
    if (k >= RIB_SOLID_INTERSECTION)
        rib_warn_once(p, p->req_line, p->req_col,
                      k == RIB_SOLID_INTERSECTION
                          ? "SolidBegin \"intersection\": set operations are not implemented; its "
                            "solids are drawn whole, as surfaces (RI Spec 3.2 §5.9, without the "
                            "optional Solid Modeling capability)"
                          : "SolidBegin \"difference\": set operations are not implemented; its "
                            "solids are drawn whole, as surfaces (RI Spec 3.2 §5.9, without the "
                            "optional Solid Modeling capability)");
    rc = rib_push(p, RIB_FRAME_SOLID);
    if (rc == TS_OK) p->stack[p->depth - 1].solid = (rib_solid_op)k;
    return rc;
}

int rib_req_solid_end(rib_parser *p)
{
    return rib_pop(p, RIB_FRAME_SOLID);
}

int rib_check_closed(rib_parser *p)
{
    if (p->motion.active)
        return rib_error_at(p, p->motion.line, p->motion.col,
                            "MotionBegin is never closed (missing MotionEnd)");
    if (p->depth == 0) return TS_OK;
    const rib_frame *f = &p->stack[p->depth - 1];
    return rib_error_at(p, f->line, f->col, "%s is never closed (missing %s)",
                        rib_frame_names[f->kind].begin, rib_frame_names[f->kind].end);
}

/* Moves n control points from camera to world space. */
static int rib_camera_points_to_world(rib_parser *p, ts_vec4 *c, size_t n,
                                      const double cam_to_world[16])
{
    for (size_t k = 0; k < n; k++) {
        double a[3] = {c[k].x, c[k].y, c[k].z}, b[3];
        if (!mat4_point(cam_to_world, a, b))
            return rib_error_at(p, p->req_line, p->req_col,
                                "a patch before WorldBegin leaves the float range");
        c[k].x = (float)b[0], c[k].y = (float)b[1], c[k].z = (float)b[2];
    }
    return TS_OK;
}

/* The corner and midpoint normals and world-to-object transforms of patches read before WorldBegin:
 * normals by the inverse transpose of camera_to_world (the transpose of world_to_camera's
 * linear part), renormalised; camera-to-object transforms X become X · world_to_camera. */
static int rib_camera_attrs_to_world(rib_parser *p, const double w2c[16])
{
    ts_scene *s = p->scene;
    size_t corners = (size_t)s->patch_count * 4u, first = (size_t)p->first_patch * 4u;
    size_t mids = (size_t)s->patch_count * 5u, first_mid = (size_t)p->first_patch * 5u;
    for (size_t k = first; k < corners + (mids - first_mid); k++) {
        /* The corner normals, then the midpoint normals (scene.h mid_n). */
        ts_vec4 *c = k < corners ? &s->corner_n[k] : &s->mid_n[first_mid + (k - corners)];
        double a[3] = {c->x, c->y, c->z}, b[3];
        for (int i = 0; i < 3; i++)
            b[i] = (w2c[i] * a[0] + w2c[4 + i] * a[1] + w2c[8 + i] * a[2]) / w2c[15];
        double len = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        if (len > 0.0 && isfinite(len))
            c->x = (float)(b[0] / len), c->y = (float)(b[1] / len), c->z = (float)(b[2] / len);
    }
    uint32_t last_old = 0, last_new = 0;
    int have_last = 0;
    for (uint32_t q = p->first_patch; q < s->patch_count; q++) {
        ts_patch_attr *a = &s->attr[q];
        if (a->disp_kind == TS_DISP_NONE) continue; /* xform unused */
        if (have_last && a->xform == last_old) {
            a->xform = last_new;
            continue;
        }
        const ts_xform *x = &s->xform[a->xform];
        const float *rows[3] = {x->r0, x->r1, x->r2};
        double m[16];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++) {
                double v = 0.0;
                for (int k = 0; k < 4; k++)
                    v += (double)rows[i][k] * w2c[k * 4 + j];
                m[i * 4 + j] = v / w2c[15];
            }
        m[12] = m[13] = m[14] = 0.0, m[15] = 1.0;
        last_old = a->xform;
        int rc = scene_add_xform(s, m, &a->xform, p->err);
        if (rc != TS_OK) return rc;
        last_new = a->xform;
        have_last = 1;
    }
    return TS_OK;
}

/* Patches and lights read before WorldBegin were placed by a CTM that ends in camera
 * space; move them to world space with camera_to_world = world_to_camera^-1. */
static int rib_camera_items_to_world(rib_parser *p, const double cam_to_world[16])
{
    ts_scene *s = p->scene;
    size_t first = (size_t)p->first_patch * 16u,
           n = (size_t)(s->patch_count - p->first_patch) * 16u;
    int rc = TS_OK; /* (no pointer arithmetic on the arrays while there are no patches) */
    if (n > 0) rc = rib_camera_points_to_world(p, s->cp + first, n, cam_to_world);
    if (rc == TS_OK && n > 0 && s->cp1)
        rc = rib_camera_points_to_world(p, s->cp1 + first, n, cam_to_world);
    if (rc == TS_OK) rc = rib_camera_attrs_to_world(p, p->ctm);
    if (rc != TS_OK) return rc;
    for (uint32_t l = p->first_light; l < s->light_count; l++) {
        ts_scene_light *d = &s->lights[l];
        double from[3], to[3];
        if (!mat4_point(cam_to_world, d->from, from) || !mat4_point(cam_to_world, d->to, to))
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
    double inv[16], inv1[16];
    if (!mat4_is_affine(p->ctm) || (p->ctm_moving && !mat4_is_affine(p->ctm1)))
        return rib_error_at(p, p->req_line, p->req_col, "the camera transform is projective");
    if (!mat4_invert(p->ctm, inv) || (p->ctm_moving && !mat4_invert(p->ctm1, inv1)))
        return rib_error_at(p, p->req_line, p->req_col, "the camera transform is singular");
    rc = rib_camera_items_to_world(p, inv);
    if (rc == TS_OK) rc = rib_push(p, RIB_FRAME_WORLD);
    if (rc != TS_OK) return rc;
    ts_camera *cam = &p->scene->camera;
    for (int k = 0; k < 16; k++) {
        cam->world_to_camera[k] = p->ctm[k] / p->ctm[15];
        cam->world_to_camera1[k] = p->ctm1[k] / p->ctm1[15];
    }
    cam->moving = p->ctm_moving; /* a motion block before WorldBegin: the camera moves */
    mat4_identity(p->ctm);
    mat4_identity(p->ctm1);
    p->ctm_moving = 0;
    p->xf_valid = 0;
    p->phase = RIB_IN_WORLD;
    p->world_line = p->req_line;
    p->world_col = p->req_col;
    p->world_seen = 1;
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

int rib_before_world(rib_parser *p)
{
    if (p->phase == RIB_BEFORE_WORLD) return TS_OK;
    return rib_error_at(p, p->req_line, p->req_col, "%s must come before WorldBegin", p->req);
}

/* One resolution of Format: nonpositive means the default (RI Spec §4.1.1: "the display
 * device's"; here 640 x 480), else an integer in [1, 65536]. */
static int rib_format_size(rib_parser *p, size_t i, const char *what, double v, int dflt, int *out)
{
    if (v <= 0.0) {
        *out = dflt;
        return TS_OK;
    }
    if (!(v <= 65536.0 && v == floor(v)))
        return rib_error_at(p, p->args[i].line, p->args[i].col,
                            "Format: %s must be an integer in [1, 65536] (or -1: the default), "
                            "got %g",
                            what, v);
    *out = (int)v;
    return TS_OK;
}

/* Format xresolution yresolution pixelaspectratio; a nonpositive value (RIB files write -1)
 * takes the default: 640, 480, 1. */
int rib_req_format(rib_parser *p)
{
    size_t i = 0;
    int w = 0, h = 0;
    double v[3];
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_numbers(p, &i, 3, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    size_t at = i == 1 ? 0 : 1; /* the yresolution's argument: [x y a] is one */
    if (rc == TS_OK) rc = rib_format_size(p, 0, "xresolution", v[0], 640, &w);
    if (rc == TS_OK) rc = rib_format_size(p, at, "yresolution", v[1], 480, &h);
    if (rc != TS_OK) return rc;
    if (v[2] > 0.0 && v[2] != 1.0)
        rib_warn_once(p, p->req_line, p->req_col, "Format pixel aspect ratio is ignored");
    p->scene->camera.width = w;
    p->scene->camera.height = h;
    p->scene->camera.has_format = 1;
    return TS_OK;
}

/* Projection "perspective" ["fov" f]: fov is the full angle across the shorter image axis.
 * Projection "orthographic": parallel rays, the screen window in camera-space units. Like
 * RiProjection, it restarts the CTM at the identity (RI Spec §4.1.1). */
int rib_req_projection(rib_parser *p)
{
    const char *name;
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_string_arg(p, 0, "a projection name", &name);
    if (rc != TS_OK) return rc;
    char shown[RIB_PRINT_MAX];
    int ortho = strcmp(name, "orthographic") == 0;
    /* RenderMan 21+: PxrPerspective (fov and lens), PxrCamera (22+: fov, lens and its
     * distortions, drawn as a pinhole of that fov) */
    int pxr = strcmp(name, "PxrPerspective") == 0 || strcmp(name, "PxrCamera") == 0;
    if (!ortho && !pxr && strcmp(name, "perspective") != 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "unknown projection \"%s\" (perspective, PxrPerspective, PxrCamera "
                            "or orthographic)",
                            rib_printable(name, shown));
    p->scene->camera.projection = ortho ? TS_PROJECTION_ORTHOGRAPHIC : TS_PROJECTION_PERSPECTIVE;
    /* A perspective projection's lens (RenderMan 21+): fStop, focalLength and focalDistance
     * together are DepthOfField's three numbers. */
    static const char *const lens_names[3] = {"fStop", "focalLength", "focalDistance"};
    double lens[3];
    int lens_given = 0, lens_line = p->req_line, lens_col = p->req_col;
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int k = 0;
        while (!ortho && k < 3 && strcmp(prm.name, lens_names[k]) != 0)
            k++;
        if (!ortho && k < 3) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            lens[k] = v[0], lens_given |= 1 << k;
            lens_line = prm.key->line, lens_col = prm.key->col;
            continue;
        }
        if (ortho || strcmp(prm.name, "fov") != 0) {
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
    if (lens_given == 7) {
        char what[64];
        snprintf(what, sizeof what, "Projection \"%s\"", name);
        rc = rib_set_lens(p, lens_line, lens_col, what, lens[0], lens[1], lens[2]);
        if (rc != TS_OK) return rc;
    } else if (lens_given) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Projection \"%s\": depth of field needs fStop, focalLength and focalDistance "
                 "together: the camera stays as it was",
                 name);
        rib_warn_once(p, lens_line, lens_col, what);
    }
    double id[16];
    mat4_identity(id);
    if (memcmp(id, p->ctm, sizeof id) != 0)
        rib_warn_once(p, p->req_line, p->req_col,
                      "transformations before Projection are discarded");
    mat4_identity(p->ctm);
    mat4_identity(p->ctm1);
    p->ctm_moving = 0;
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

/* ---- Displacement (docs/rib.md) ---------------------------------------------------- */

/* Displacement "fbm" | "ridged" ["amplitude" a] ["frequency" f] ["octaves" n]
 * ["lacunarity" l] ["gain" g]; Displacement "texture" "texturename" ["file"] ["amplitude" a]
 * ["offset" o]; Displacement "null" or "" turns it off. An attribute: it applies to the
 * patches that follow and AttributeEnd restores it. */
int rib_req_displacement(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "a displacement name", &name);
    if (rc != TS_OK) return rc;
    char shown[RIB_PRINT_MAX];
    const rib_disp none = {TS_DISP_NONE, 4, 0.1, 1.0, 2.0, 0.5, 0, 0.0, 0, {0}};
    rib_disp d = none;
    int off = name[0] == '\0' || strcmp(name, "null") == 0, has_tex = 0, missing = 0;
    if (strcmp(name, "fbm") == 0)
        d.kind = TS_DISP_FBM;
    else if (strcmp(name, "ridged") == 0)
        d.kind = TS_DISP_RIDGED;
    else if (strcmp(name, "texture") == 0)
        d.kind = TS_DISP_TEXTURE;
    else if (!off) {
        /* A shader Tessera does not have (a custom .sl name): like an unknown Surface, one
         * warning and the fallback, here no displacement; its parameters are its own. */
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Displacement \"%s\" is unknown: no displacement (fbm, ridged, texture or null)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->args[0].line, p->args[0].col, what);
        p->disp = d;
        return TS_OK;
    }
    int tex = d.kind == TS_DISP_TEXTURE;
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        /* Which parameters each function takes: noise 0-4, texture 0, 5, 6. */
        static const char *const known[] = {"amplitude", "frequency", "octaves",    "lacunarity",
                                            "gain",      "offset",    "texturename"};
        size_t k = 0;
        while (k < 7 && strcmp(prm.name, known[k]) != 0)
            k++;
        if (k == 7 || off || (tex && k >= 1 && k <= 4) || (!tex && k >= 5)) {
            rib_warn_param(p, &prm);
            continue;
        }
        if (k == 6) {
            rc = rib_texture_arg(p, i + 1, TS_TEX_MINMAX, "no displacement", &d.tex);
            if (rc != TS_OK) return rc;
            has_tex = 1;
            missing = d.tex == TS_INVALID; /* not strict: the surface stays undisplaced */
            continue;
        }
        rc = rib_param_numbers(p, &prm, 1, &v, NULL);
        if (rc != TS_OK) return rc;
        double x = v[0];
        int ok = fabs(x) <= FLT_MAX;
        const char *need = "a finite number";
        if (k == 1 || k == 3) ok = ok && x > 0.0, need = "positive";
        if (k == 2)
            ok = x >= 0.5 && x < (double)TS_DISP_MAX_OCTAVES + 0.5, need = "between 1 and 16";
        if (!ok)
            return rib_error_at(p, prm.val->line, prm.val->col,
                                "Displacement: %s must be %s, got %g", known[k], need, x);
        if (k == 0) d.amplitude = x;
        if (k == 1) d.frequency = x;
        if (k == 2) d.octaves = (uint32_t)floor(x + 0.5);
        if (k == 3) d.lacunarity = x;
        if (k == 4) d.gain = x;
        if (k == 5) d.offset = x;
    }
    if (tex && !has_tex)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Displacement \"texture\": missing \"texturename\"");
    if (missing) d = none; /* as Displacement "null" */
    if (off || d.amplitude == 0.0) d.kind = TS_DISP_NONE;
    p->disp = d;
    return TS_OK;
}

/* ---- motion blocks (docs/rib.md) --------------------------------------------------- */

/* Requests a motion block may hold: one kind per block, two samples. */
static const char *const rib_motion_kinds[] = {"Patch", "Translate",       "Rotate",
                                               "Scale", "ConcatTransform", "Transform"};

/* Surface requests whose two samples in a motion block deform one surface: the first sample
 * adds its patches, the second moves each of them at shutter close (rib_geom.c geom_emit).
 * Both samples must make the same patches: the same topology and counts. */
/* clang-format off */
static const char *const rib_motion_deforms[] = {
    "PatchMesh", "SubdivisionMesh", "HierarchicalSubdivisionMesh", "NuPatch", "Polygon",
    "GeneralPolygon", "PointsPolygons", "PointsGeneralPolygons", "Sphere", "Cone", "Cylinder", "Disk", "Hyperboloid", "Paraboloid",
    "Torus", "Points", "Curves",
};
/* clang-format on */

int rib_motion_check(rib_parser *p)
{
    rib_motion *m = &p->motion;
    if (strcmp(p->req, "MotionBegin") == 0)
        return rib_error_at(p, p->req_line, p->req_col,
                            "MotionBegin inside the motion block at %d:%d", m->line, m->col);
    size_t k = 0, n = sizeof rib_motion_kinds / sizeof rib_motion_kinds[0];
    size_t d = 0, nd = sizeof rib_motion_deforms / sizeof rib_motion_deforms[0];
    while (k < n && strcmp(p->req, rib_motion_kinds[k]) != 0)
        k++;
    while (k == n && d < nd && strcmp(p->req, rib_motion_deforms[d]) != 0)
        d++;
    if (k == n && d == nd)
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s is not allowed in the motion block at %d:%d (only Patch, "
                            "PatchMesh, SubdivisionMesh, NuPatch, polygons, quadrics, Points, "
                            "Curves, Translate, Rotate, Scale, ConcatTransform or Transform)",
                            p->req, m->line, m->col);
    if (m->count >= 2)
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s: the motion block at %d:%d already has its 2 samples", p->req,
                            m->line, m->col);
    if (m->count == 0) {
        memcpy(m->first, p->req, sizeof m->first);
        m->first_line = p->req_line;
        m->first_col = p->req_col;
    } else if (strcmp(p->req, m->first) != 0) {
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s does not match the %s at %d:%d in the motion block", p->req,
                            m->first, m->first_line, m->first_col);
    }
    if (k == n) { /* a deforming surface: its handler runs as sample m->count */
        m->deform = 1;
        m->sample = m->count++;
        if (m->sample == 0) m->first_patch = p->scene->patch_count;
        if (m->sample == 1) m->made = p->scene->patch_count - m->first_patch, m->set = 0;
    }
    return TS_OK;
}

/* MotionBegin [t0 t1]: exactly two increasing times. Tessera's rays have times in [0, 1) and
 * each moving point two samples, which the block's give at the Shutter's open and close
 * (rib_motion_shutter); a Shutter that reaches past the block's times warns: RenderMan holds
 * the points still outside them, Tessera spreads the motion over the whole exposure. */
int rib_req_motion_begin(rib_parser *p)
{
    double t[2];
    size_t i = 0;
    if (p->nargs > 0 && p->args[0].kind == RIB_ARG_NUMBERS && p->args[0].count != 2)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "MotionBegin: exactly 2 times are supported, got %zu",
                            p->args[0].count);
    int rc = rib_numbers(p, &i, 2, t);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    if (!(t[0] < t[1]))
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "MotionBegin: the times must increase, got %g %g", t[0], t[1]);
    const double *sh = p->scene->camera.shutter;
    if (p->shutter_given && ((sh[0] < t[0] && t[0] < sh[1]) || (sh[0] < t[1] && t[1] < sh[1]))) {
        char what[256];
        snprintf(what, sizeof what,
                 "Shutter %g %g reaches past the motion block [%g %g]: its motion is spread over "
                 "the whole exposure (RenderMan holds it still outside the block)",
                 sh[0], sh[1], t[0], t[1]);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    memset(&p->motion, 0, sizeof p->motion);
    p->motion.active = 1;
    p->motion.line = p->req_line;
    p->motion.col = p->req_col;
    p->motion.t[0] = t[0], p->motion.t[1] = t[1];
    return TS_OK;
}

int rib_motion_shutter(const rib_parser *p, double a[2])
{
    a[0] = 0.0, a[1] = 1.0;
    if (!p->shutter_given) return 0;
    const double *t = p->motion.t, *sh = p->scene->camera.shutter;
    for (int k = 0; k < 2; k++) {
        double f = (sh[k] - t[0]) / (t[1] - t[0]);
        a[k] = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
    }
    return a[0] != 0.0 || a[1] != 1.0;
}

void rib_motion_lerp(const double *x0, const double *x1, double a, size_t n, double *out)
{
    for (size_t i = 0; i < n; i++)
        out[i] = (1.0 - a) * x0[i] + a * x1[i];
}

/* MotionEnd: applies the two samples: a moving patch, or a CTM with two time samples. */
int rib_req_motion_end(rib_parser *p)
{
    rib_motion *m = &p->motion;
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    if (!m->active)
        return rib_error_at(p, p->req_line, p->req_col, "MotionEnd without MotionBegin");
    if (m->count != 2)
        return rib_error_at(p, p->req_line, p->req_col,
                            "MotionEnd: the motion block at %d:%d has %d sample%s for 2 times",
                            m->line, m->col, m->count, m->count == 1 ? "" : "s");
    m->active = 0;
    if (strcmp(m->first, "Patch") == 0) return rib_geom_motion_patch(p);
    if (m->deform) {
        if (m->set != m->made)
            return rib_error_at(p, m->first_line, m->first_col,
                                "MotionEnd: the second %s of the motion block at %d:%d makes %u "
                                "patches, the first %u (the samples must have the same topology)",
                                m->first, m->line, m->col, m->set, m->made);
        return TS_OK;
    }
    double a[2];
    if (rib_motion_shutter(p, a)) { /* the transformation at the Shutter's open and close */
        double m0[16];
        memcpy(m0, m->m[0], sizeof m0);
        rib_motion_lerp(m0, m->m[1], a[0], 16, m->m[0]);
        rib_motion_lerp(m0, m->m[1], a[1], 16, m->m[1]);
    }
    if (m->replace) {
        memcpy(p->ctm, m->m[0], sizeof p->ctm);
        memcpy(p->ctm1, m->m[1], sizeof p->ctm1);
    } else {
        mat4_concat(p->ctm, m->m[0]);
        mat4_concat(p->ctm1, m->m[1]);
    }
    p->ctm_moving = memcmp(p->ctm, p->ctm1, sizeof p->ctm) != 0;
    return TS_OK;
}
