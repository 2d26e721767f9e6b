/* scene.c — growth, completion and bounds of the loaded scene (see scene.h for the layout).
 *
 * corner_n carries a marker in w while the scene is being loaded: w = 0 for a normal the
 * scene gave (final), w = 1 for a provisional one (the patch's own unit normal at the
 * corner) that scene_finalize replaces by the average over every patch sharing the corner
 * and then marks final (w = 0). The provisional value keeps a scene that is never
 * finalised (hand-built test scenes) usable. */
#include "scene/scene.h"

#include "lib/displace.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* First allocation, in patches (64 * 16 control points * 16 bytes = 16 KiB). */
#define SCENE_FIRST_PATCHES 64u
/* Lights carry no capacity field: the capacity is implied by the count, the next power of
 * two at or above it, at least SCENE_FIRST_LIGHTS. */
#define SCENE_FIRST_LIGHTS 4u
#define SCENE_FIRST_XFORMS 8u

/* corner_n.w while loading (see above). */
#define SCENE_N_GIVEN 0.0f
#define SCENE_N_PENDING 1.0f

/* *a (used: the first `used` bytes) moved to a new SCENE_ALIGN-aligned block of `bytes`; 0 when
 * there is no memory (*a is then unchanged). */
static int scene_grow_aligned(void **a, size_t used, size_t bytes)
{
    void *n = NULL;
    if (posix_memalign(&n, SCENE_ALIGN, bytes) != 0) return 0;
    if (*a && used) memcpy(n, *a, used);
    free(*a);
    *a = n;
    return 1;
}

/* Doubles the patch arrays when full (scene_reserve_patches). */
static int scene_reserve_patch(ts_scene *s, ts_error *err)
{
    if (s->patch_count < s->patch_capacity) return TS_OK;
    if (s->patch_capacity > UINT32_MAX / 2)
        return ts_error_set(err, TS_E_MEMORY, "scene: more than %u patches", s->patch_capacity);
    uint32_t cap = s->patch_capacity ? s->patch_capacity * 2u : SCENE_FIRST_PATCHES;
    return scene_reserve_patches(s, cap - s->patch_count, err);
}

/* The patch arrays (cp, cp1, corner_n, mid_n and attr, SCENE_ALIGN-aligned) are grown in turn,
 * each pointer kept as soon as it has moved; the capacity only moves when all succeeded, so a
 * failure leaves the scene consistent (some arrays merely larger than needed). */
int scene_reserve_patches(ts_scene *s, uint64_t more, ts_error *err)
{
    uint64_t want = (uint64_t)s->patch_count + more;
    if (want <= s->patch_capacity) return TS_OK;
    if (want > UINT32_MAX)
        return ts_error_set(err, TS_E_MEMORY, "scene: more than %u patches", UINT32_MAX);
    uint32_t cap = (uint32_t)want;
    size_t v = sizeof(ts_vec4), n = s->patch_count;
    size_t at = sizeof(ts_patch_attr);
    if (!scene_grow_aligned((void **)&s->cp, n * 16u * v, (size_t)cap * 16u * v)) goto fail;
    if (s->cp1 && !scene_grow_aligned((void **)&s->cp1, n * 16u * v, (size_t)cap * 16u * v))
        goto fail;
    if (!scene_grow_aligned((void **)&s->corner_n, n * 4u * v, (size_t)cap * 4u * v)) goto fail;
    if (!scene_grow_aligned((void **)&s->mid_n, n * 5u * v, (size_t)cap * 5u * v)) goto fail;
    if (!scene_grow_aligned((void **)&s->attr, n * at, (size_t)cap * at)) goto fail;
    s->patch_capacity = cap;
    return TS_OK;
fail:
    return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for %u patches", cap);
}

/* Creates cp1 (capacity patch_capacity) holding a copy of cp: the first moving patch. */
static int scene_start_motion(ts_scene *s, ts_error *err)
{
    if (s->cp1) return TS_OK;
    size_t n = (size_t)s->patch_capacity * 16u;
    if (!scene_grow_aligned((void **)&s->cp1, 0, (n ? n : 16u) * sizeof *s->cp1))
        return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for motion");
    if (s->patch_count) memcpy(s->cp1, s->cp, (size_t)s->patch_count * 16u * sizeof *s->cp);
    return TS_OK;
}

/* Float control points from doubles, w = 1; 0 when one leaves the float range. */
static int scene_points(ts_vec4 *dst, const double cp[16][3])
{
    for (int k = 0; k < 16; k++) {
        for (int d = 0; d < 3; d++)
            if (!(fabs(cp[k][d]) <= FLT_MAX)) return 0;
        dst[k].x = (float)cp[k][0];
        dst[k].y = (float)cp[k][1];
        dst[k].z = (float)cp[k][2];
        dst[k].w = 1.0f;
    }
    return 1;
}

/* ---- normals of a Bézier patch, in double -------------------------------------------- */

static void scene_bernstein(double t, double b[4], double d[4])
{
    double s = 1.0 - t;
    b[0] = s * s * s, b[1] = 3.0 * t * s * s, b[2] = 3.0 * t * t * s, b[3] = t * t * t;
    d[0] = -3.0 * s * s, d[1] = 3.0 * (s * s - 2.0 * t * s), d[2] = 3.0 * (2.0 * t * s - t * t);
    d[3] = 3.0 * t * t;
}

/* dP/du x dP/dv at (u, v). */
static void scene_cross_derivs(const ts_vec4 *cp, double u, double v, double n[3])
{
    double bu[4], du[4], bv[4], dv[4], pu[3] = {0, 0, 0}, pv[3] = {0, 0, 0};
    scene_bernstein(u, bu, du);
    scene_bernstein(v, bv, dv);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            const ts_vec4 *c = &cp[j * 4 + i];
            double wu = du[i] * bv[j], wv = bu[i] * dv[j];
            pu[0] += wu * c->x, pu[1] += wu * c->y, pu[2] += wu * c->z;
            pv[0] += wv * c->x, pv[1] += wv * c->y, pv[2] += wv * c->z;
        }
    n[0] = pu[1] * pv[2] - pu[2] * pv[1];
    n[1] = pu[2] * pv[0] - pu[0] * pv[2];
    n[2] = pu[0] * pv[1] - pu[1] * pv[0];
}

/* The unit geometric normal of the patch at corner c (0..3: (0,0), (1,0), (0,1), (1,1)).
 * Where dP/du x dP/dv vanishes at the corner (a collapsed edge such as the teapot's lid
 * apex, or parallel derivatives) the limit from inside is taken: the normal a little
 * inside along the diagonal, with the first step small enough that its direction error,
 * O(step), is far below float precision. Returns 0 (n = 0) for a patch degenerate all the
 * way in. */
static int scene_corner_normal(const ts_vec4 *cp, int c, double n[3])
{
    static const double steps[] = {0.0, 1e-7, 1e-5, 1e-3, 1e-2, 0.1, 0.5};
    double ext = 0.0; /* size of the control polygon, for a scale-free threshold */
    for (int k = 1; k < 16; k++) {
        ext = fmax(ext, fabs((double)cp[k].x - cp[0].x));
        ext = fmax(ext, fabs((double)cp[k].y - cp[0].y));
        ext = fmax(ext, fabs((double)cp[k].z - cp[0].z));
    }
    double tiny = 1e-14 * ext * ext;
    for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++) {
        double u = (c & 1) ? 1.0 - steps[k] : steps[k], v = (c & 2) ? 1.0 - steps[k] : steps[k];
        scene_cross_derivs(cp, u, v, n);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > tiny && len > 0.0 && isfinite(len)) {
            n[0] /= len, n[1] /= len, n[2] /= len;
            return 1;
        }
    }
    n[0] = n[1] = n[2] = 0.0;
    return 0;
}

/* The parameters of midpoint normal k (0..4) and the direction a step goes inwards. */
static const double scene_mid_uv[5][4] = {
    {0.5, 0.0, 0.0, 1.0},  /* v = 0 edge: step towards +v */
    {0.0, 0.5, 1.0, 0.0},  /* u = 0 edge */
    {1.0, 0.5, -1.0, 0.0}, /* u = 1 edge */
    {0.5, 1.0, 0.0, -1.0}, /* v = 1 edge */
    {0.5, 0.5, 0.5, 0.5},  /* centre: any small step */
};

/* The unit geometric normal of the patch at midpoint k, with the limit from inside where
 * the derivatives vanish (a collapsed edge) as in scene_corner_normal. 0 (n = 0) when
 * degenerate all the way in. */
static int scene_mid_normal(const ts_vec4 *cp, int k, double n[3])
{
    static const double steps[] = {0.0, 1e-7, 1e-5, 1e-3, 1e-2, 0.1};
    double ext = 0.0;
    for (int i = 1; i < 16; i++) {
        ext = fmax(ext, fabs((double)cp[i].x - cp[0].x));
        ext = fmax(ext, fabs((double)cp[i].y - cp[0].y));
        ext = fmax(ext, fabs((double)cp[i].z - cp[0].z));
    }
    double tiny = 1e-14 * ext * ext;
    const double *m = scene_mid_uv[k];
    for (size_t i = 0; i < sizeof steps / sizeof steps[0]; i++) {
        scene_cross_derivs(cp, m[0] + steps[i] * m[2], m[1] + steps[i] * m[3], n);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > tiny && len > 0.0 && isfinite(len)) {
            n[0] /= len, n[1] /= len, n[2] /= len;
            return 1;
        }
    }
    n[0] = n[1] = n[2] = 0.0;
    return 0;
}

/* The corners (0..3) at the ends of midpoint k's edge (k < 4). */
static const int scene_mid_corners[4][2] = {{0, 1}, {0, 2}, {1, 3}, {2, 3}};

/* Writes patch p's midpoint normals: from its explicit corner normals (the normalised sum
 * of the edge's two corners, of all four for the centre; final, w = SCENE_N_GIVEN), or its
 * own geometric normals (provisional, w = SCENE_N_PENDING; scene_finalize shares them). */
static void scene_mid_normals(ts_scene *s, uint32_t p, int explicit_corners)
{
    const ts_vec4 *c = &s->corner_n[(size_t)p * 4u];
    for (int k = 0; k < 5; k++) {
        double n[3] = {0, 0, 0};
        int ok = 0;
        if (explicit_corners) {
            for (int e = 0; e < 4; e++)
                if (k == 4 || e == scene_mid_corners[k][0] || e == scene_mid_corners[k][1])
                    n[0] += c[e].x, n[1] += c[e].y, n[2] += c[e].z;
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            ok = len > 1e-3;
            if (ok) n[0] /= len, n[1] /= len, n[2] /= len;
        }
        if (!ok) scene_mid_normal(s->cp + (size_t)p * 16u, k, n);
        if (n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0) n[2] = 1.0;
        ts_vec4 *o = &s->mid_n[(size_t)p * 5u + (size_t)k];
        o->x = (float)n[0], o->y = (float)n[1], o->z = (float)n[2];
        o->w = explicit_corners ? SCENE_N_GIVEN : SCENE_N_PENDING;
    }
}

/* Writes the provisional corner normals of patch p (its own, w = SCENE_N_PENDING). */
static void scene_own_normals(ts_scene *s, uint32_t p)
{
    for (int c = 0; c < 4; c++) {
        double n[3];
        scene_corner_normal(s->cp + (size_t)p * 16u, c, n);
        ts_vec4 *o = &s->corner_n[(size_t)p * 4u + (size_t)c];
        o->x = (float)n[0], o->y = (float)n[1], o->z = (float)n[2], o->w = SCENE_N_PENDING;
    }
}

/* ---- patches ------------------------------------------------------------------------- */

int scene_add_patch(ts_scene *s, const double cp[16][3], const ts_patch_attr *attr, ts_error *err)
{
    return scene_add_patch_ex(s, cp, NULL, NULL, attr, err);
}

int scene_set_patch_motion(ts_scene *s, uint32_t p, const double cp1[16][3], ts_error *err)
{
    if (p >= s->patch_count)
        return ts_error_set(err, TS_E_INTERNAL, "scene: no patch %u to move", p);
    int rc = scene_start_motion(s, err);
    if (rc != TS_OK) return rc;
    if (!scene_points(s->cp1 + (size_t)p * 16u, cp1))
        return ts_error_set(err, TS_E_SCENE, "scene: patch %u leaves the float range", p);
    s->attr[p].flags |= TS_PATCH_MOVING;
    return TS_OK;
}

int scene_set_patch_samples(ts_scene *s, uint32_t p, const double cp0[16][3],
                            const double cp1[16][3], ts_error *err)
{
    if (p >= s->patch_count)
        return ts_error_set(err, TS_E_INTERNAL, "scene: no patch %u to move", p);
    ts_vec4 a[16], b[16];
    if (!scene_points(a, cp0) || !scene_points(b, cp1))
        return ts_error_set(err, TS_E_SCENE, "scene: patch %u leaves the float range", p);
    int moving = memcmp(a, b, sizeof a) != 0;
    if (moving) {
        int rc = scene_start_motion(s, err);
        if (rc != TS_OK) return rc;
    }
    memcpy(s->cp + (size_t)p * 16u, a, sizeof a);
    if (s->cp1) memcpy(s->cp1 + (size_t)p * 16u, moving ? b : a, sizeof a);
    if (moving)
        s->attr[p].flags |= TS_PATCH_MOVING;
    else
        s->attr[p].flags &= ~TS_PATCH_MOVING;
    if (s->corner_n[(size_t)p * 4u].w != SCENE_N_GIVEN) {
        scene_own_normals(s, p);
        scene_mid_normals(s, p, 0);
    }
    return TS_OK;
}

/* The identity transform as xform[0], if there is none yet. */
static int scene_ensure_identity(ts_scene *s, ts_error *err)
{
    if (s->xform_count) return TS_OK;
    uint32_t index;
    double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    return scene_add_xform(s, id, &index, err);
}

/* Patch p's attributes as stored (*a, from attr or the defaults; moving with cp1) and its
 * corner normals made unit (nn), checked against the scene's transforms, trim segments and
 * textures. Writes nothing. */
static int scene_patch_checked(const ts_scene *s, uint32_t p, const double cp1[16][3],
                               const double normals[4][3], const ts_patch_attr *attr,
                               ts_patch_attr *out, double nn[4][3], ts_error *err)
{
    ts_patch_attr a = {.cs_r = 1.0f,
                       .cs_g = 1.0f,
                       .cs_b = 1.0f,
                       .disp_kind = TS_DISP_NONE,
                       .disp_octaves = 1u,
                       .disp_lacunarity = 2.0f,
                       .disp_gain = 0.5f,
                       .xform = 0u,
                       .material = TS_MAT_MATTE,
                       .kd = 1.0f,
                       .emitter = TS_INVALID,
                       .st = {0, 0, 1, 0, 0, 1, 1, 1}};
    if (attr) a = *attr;
    a.flags = cp1 ? (a.flags | TS_PATCH_MOVING) : (a.flags & ~TS_PATCH_MOVING);
    if (a.xform >= s->xform_count)
        return ts_error_set(err, TS_E_INTERNAL, "scene: patch refers to transform %u of %u",
                            a.xform, s->xform_count);
    if (a.trim_count &&
        (a.trim_first > s->trim_seg_count || a.trim_count > s->trim_seg_count - a.trim_first))
        return ts_error_set(err, TS_E_INTERNAL,
                            "scene: patch refers to trim segments %u + %u of %u", a.trim_first,
                            a.trim_count, s->trim_seg_count);
    if ((a.disp_kind == TS_DISP_TEXTURE &&
         (a.disp_tex >= s->texture_count || s->textures[a.disp_tex].kind != TS_TEX_MINMAX)) ||
        ((a.flags & TS_PATCH_COLOR_TEX) &&
         (a.color_tex >= s->texture_count || s->textures[a.color_tex].kind != TS_TEX_RGB)))
        return ts_error_set(err, TS_E_INTERNAL, "scene: patch refers to a texture it cannot use");
    if (normals)
        for (int c = 0; c < 4; c++) {
            double len = sqrt(normals[c][0] * normals[c][0] + normals[c][1] * normals[c][1] +
                              normals[c][2] * normals[c][2]);
            if (!(len > 0.0) || !isfinite(len))
                return ts_error_set(err, TS_E_SCENE, "scene: corner normal %d of patch %u has %s",
                                    c, p, len > 0.0 ? "no finite length" : "zero length");
            for (int d = 0; d < 3; d++)
                nn[c][d] = normals[c][d] / len;
        }
    *out = a;
    return TS_OK;
}

/* Writes checked patch p (scene_patch_checked) into its slot (p < patch_capacity; with cp1,
 * s->cp1 made): slot p alone, so patches in distinct slots may be written at once. */
static int scene_patch_store(ts_scene *s, uint32_t p, const double cp[16][3],
                             const double cp1[16][3], const ts_patch_attr *a, int given,
                             const double nn[4][3], ts_error *err)
{
    ts_vec4 *dst = s->cp + (size_t)p * 16u;
    if (!scene_points(dst, cp) || (cp1 && !scene_points(s->cp1 + (size_t)p * 16u, cp1)))
        return ts_error_set(err, TS_E_SCENE, "scene: patch %u leaves the float range", p);
    if (s->cp1 && !cp1) memcpy(s->cp1 + (size_t)p * 16u, dst, 16u * sizeof *dst);
    s->attr[p] = *a;
    if (given) {
        for (int c = 0; c < 4; c++) {
            ts_vec4 *o = &s->corner_n[(size_t)p * 4u + (size_t)c];
            o->x = (float)nn[c][0], o->y = (float)nn[c][1], o->z = (float)nn[c][2];
            o->w = SCENE_N_GIVEN;
        }
    } else {
        scene_own_normals(s, p);
    }
    scene_mid_normals(s, p, given);
    return TS_OK;
}

int scene_add_patch_ex(ts_scene *s, const double cp[16][3], const double cp1[16][3],
                       const double normals[4][3], const ts_patch_attr *attr, ts_error *err)
{
    ts_patch_attr a;
    double nn[4][3];
    int rc = scene_ensure_identity(s, err);
    if (rc == TS_OK) rc = scene_patch_checked(s, s->patch_count, cp1, normals, attr, &a, nn, err);
    if (rc == TS_OK) rc = scene_reserve_patch(s, err);
    if (rc == TS_OK && cp1) rc = scene_start_motion(s, err);
    if (rc == TS_OK)
        rc = scene_patch_store(s, s->patch_count, cp, cp1, &a, normals != NULL, nn, err);
    if (rc == TS_OK) s->patch_count++;
    return rc;
}

int scene_put_patch(ts_scene *s, uint32_t p, const double cp[16][3], const double normals[4][3],
                    const ts_patch_attr *attr, ts_error *err)
{
    ts_patch_attr a;
    double nn[4][3];
    if (s->xform_count == 0 || p >= s->patch_capacity)
        return ts_error_set(err, TS_E_INTERNAL, "scene: no slot for patch %u", p);
    int rc = scene_patch_checked(s, p, NULL, normals, attr, &a, nn, err);
    if (rc == TS_OK) rc = scene_patch_store(s, p, cp, NULL, &a, normals != NULL, nn, err);
    return rc;
}

/* ---- transforms ---------------------------------------------------------------------- */

static int scene_xform_equal(const ts_xform *a, const ts_xform *b)
{
    for (int k = 0; k < 4; k++)
        if (a->r0[k] != b->r0[k] || a->r1[k] != b->r1[k] || a->r2[k] != b->r2[k]) return 0;
    return 1;
}

int scene_add_xform(ts_scene *s, const double world_to_object[16], uint32_t *index, ts_error *err)
{
    const double *m = world_to_object;
    if (!(m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] != 0.0 && isfinite(m[15])))
        return ts_error_set(err, TS_E_INTERNAL, "scene: transform is not affine");
    ts_xform x;
    float *rows[3] = {x.r0, x.r1, x.r2};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++) {
            double v = m[r * 4 + c] / m[15];
            if (!(fabs(v) <= FLT_MAX))
                return ts_error_set(err, TS_E_SCENE, "scene: transform leaves the float range");
            rows[r][c] = (float)v;
        }
    if (s->xform_count == 0) {
        /* xform[0] is the identity: add it first (unless this is it). */
        static const ts_xform id = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
        s->xform = malloc(SCENE_FIRST_XFORMS * sizeof *s->xform);
        if (!s->xform) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for transforms");
        s->xform_capacity = SCENE_FIRST_XFORMS;
        s->xform[0] = id;
        s->xform_count = 1;
    }
    /* Newest first: consecutive patches mostly share their transform. */
    for (uint32_t k = s->xform_count; k-- > 0;)
        if (scene_xform_equal(&s->xform[k], &x)) {
            *index = k;
            return TS_OK;
        }
    if (s->xform_count == s->xform_capacity) {
        if (s->xform_capacity > UINT32_MAX / 2)
            return ts_error_set(err, TS_E_MEMORY, "scene: more than %u transforms",
                                s->xform_capacity);
        uint32_t cap = s->xform_capacity * 2u;
        ts_xform *t = realloc(s->xform, (size_t)cap * sizeof *t);
        if (!t) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for transforms");
        s->xform = t;
        s->xform_capacity = cap;
    }
    s->xform[s->xform_count] = x;
    *index = s->xform_count++;
    return TS_OK;
}

/* ---- trim curves -------------------------------------------------------------------- */

int scene_add_trim(ts_scene *s, const ts_vec4 *seg, uint32_t n, uint32_t *first, ts_error *err)
{
    if (n > UINT32_MAX - s->trim_seg_count)
        return ts_error_set(err, TS_E_MEMORY, "scene: more than %u trim segments", UINT32_MAX);
    uint32_t need = s->trim_seg_count + n;
    if (need > s->trim_seg_capacity) {
        uint64_t cap = s->trim_seg_capacity ? (uint64_t)s->trim_seg_capacity * 2u : 1024u;
        if (cap < need) cap = need;
        if (cap > UINT32_MAX) cap = UINT32_MAX;
        ts_vec4 *t = realloc(s->trim_seg, (size_t)cap * sizeof *t);
        if (!t) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for trim curves");
        s->trim_seg = t;
        s->trim_seg_capacity = (uint32_t)cap;
    }
    if (n) memcpy(s->trim_seg + s->trim_seg_count, seg, (size_t)n * sizeof *seg);
    *first = s->trim_seg_count;
    s->trim_seg_count = need;
    return TS_OK;
}

/* ---- finalize: shared corner normals ----------------------------------------------- */

/* A corner position as a hash key; -0 and +0 are the same position. */
typedef struct scene_key {
    float x, y, z;
} scene_key;

static uint32_t scene_bits(float f)
{
    uint32_t u;
    f += 0.0f; /* -0 -> +0 */
    memcpy(&u, &f, sizeof u);
    return u;
}

static uint32_t scene_hash(const scene_key *k)
{
    uint32_t h = 2166136261u;
    uint32_t w[3] = {scene_bits(k->x), scene_bits(k->y), scene_bits(k->z)};
    for (int i = 0; i < 3; i++) {
        h = (h ^ w[i]) * 16777619u;
        h ^= h >> 15;
        h *= 0x2c1b3c6du;
        h ^= h >> 12;
    }
    return h;
}

static int scene_key_equal(const scene_key *a, const scene_key *b)
{
    return a->x == b->x && a->y == b->y && a->z == b->z;
}

/* Replaces every pending corner normal by the renormalised sum of the unit normals of all
 * pending corners at exactly the same position. A sum that nearly cancels (patches of
 * opposite orientation meeting) keeps the patch's own normal. */
static int scene_average_normals(ts_scene *s, ts_error *err)
{
    size_t corners = (size_t)s->patch_count * 4u, pending = 0;
    for (size_t k = 0; k < corners; k++)
        pending += s->corner_n[k].w != SCENE_N_GIVEN;
    if (pending == 0) return TS_OK;
    size_t slots = 16;
    while (slots < 2 * pending)
        slots *= 2;
    uint32_t *table = malloc(slots * sizeof *table);
    uint32_t *id = malloc(corners * sizeof *id);      /* corner -> unique position */
    scene_key *keys = malloc(pending * sizeof *keys); /* unique positions */
    double(*sum)[3] = malloc(pending * sizeof *sum);  /* sums of unit normals */
    int rc = TS_OK;
    if (!table || !id || !keys || !sum) {
        rc = ts_error_set(err, TS_E_MEMORY, "scene: out of memory for corner normals");
        goto done;
    }
    memset(table, 0xff, slots * sizeof *table);
    static const int corner_cp[4] = {0, 3, 12, 15};
    uint32_t unique = 0;
    for (uint32_t p = 0; p < s->patch_count; p++) {
        const ts_vec4 *cp = s->cp + (size_t)p * 16u;
        for (int c = 0; c < 4; c++) {
            size_t k = (size_t)p * 4u + (size_t)c;
            if (s->corner_n[k].w == SCENE_N_GIVEN) continue;
            double n[3];
            scene_corner_normal(cp, c, n); /* from the current points (cp may have moved) */
            ts_vec4 *o = &s->corner_n[k];
            o->x = (float)n[0], o->y = (float)n[1], o->z = (float)n[2];
            const ts_vec4 *pt = &cp[corner_cp[c]];
            scene_key key = {pt->x, pt->y, pt->z};
            size_t h = scene_hash(&key) & (slots - 1);
            while (table[h] != UINT32_MAX && !scene_key_equal(&keys[table[h]], &key))
                h = (h + 1) & (slots - 1);
            if (table[h] == UINT32_MAX) {
                table[h] = unique;
                keys[unique] = key;
                sum[unique][0] = sum[unique][1] = sum[unique][2] = 0.0;
                unique++;
            }
            id[k] = table[h];
            for (int d = 0; d < 3; d++)
                sum[id[k]][d] += n[d];
        }
    }
    for (size_t k = 0; k < corners; k++) {
        ts_vec4 *o = &s->corner_n[k];
        if (o->w == SCENE_N_GIVEN) continue;
        const double *a = sum[id[k]];
        double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        if (len > 1e-3) {
            o->x = (float)(a[0] / len), o->y = (float)(a[1] / len), o->z = (float)(a[2] / len);
        } else if (o->x == 0.0f && o->y == 0.0f && o->z == 0.0f) {
            o->z = 1.0f; /* no direction anywhere near this corner: any unit vector */
        }
        o->w = SCENE_N_GIVEN;
    }
done:
    free(table);
    free(id);
    free(keys);
    free(sum);
    return rc;
}

/* An edge as a hash key: its four boundary control points, in the order that puts the
 * lexicographically smaller end first, so both patches sharing the edge (in either
 * direction) make the same key. -0 and +0 are the same. */
typedef struct scene_edge_key {
    uint32_t w[12];
} scene_edge_key;

static const int scene_edge_cp[4][4] = {
    {0, 1, 2, 3}, {0, 4, 8, 12}, {3, 7, 11, 15}, {12, 13, 14, 15}};

static scene_edge_key scene_edge_key_of(const ts_vec4 *cp, int k)
{
    uint32_t a[12];
    for (int i = 0; i < 4; i++) {
        const ts_vec4 *c = &cp[scene_edge_cp[k][i]];
        a[3 * i] = scene_bits(c->x), a[3 * i + 1] = scene_bits(c->y),
              a[3 * i + 2] = scene_bits(c->z);
    }
    int reverse = memcmp(&a[9], &a[0], 3 * sizeof *a) < 0;
    scene_edge_key key;
    for (int i = 0; i < 4; i++)
        memcpy(&key.w[3 * i], &a[3 * (reverse ? 3 - i : i)], 3 * sizeof *a);
    return key;
}

static uint32_t scene_edge_hash(const scene_edge_key *k)
{
    uint32_t h = 2166136261u;
    for (int i = 0; i < 12; i++) {
        h = (h ^ k->w[i]) * 16777619u;
        h ^= h >> 15;
    }
    return h;
}

/* Replaces every pending edge-midpoint normal by the renormalised sum of the unit normals
 * of all pending midpoints on the same boundary curve (the displacement direction along a
 * shared edge is then the same on both sides: no crack opens); the centres keep the patch's
 * own normal. A sum that nearly cancels keeps the patch's own. */
static int scene_average_mid_normals(ts_scene *s, ts_error *err)
{
    size_t edges = (size_t)s->patch_count * 4u, slots = 16;
    while (slots < 2 * edges)
        slots *= 2;
    uint32_t *table = malloc(slots * sizeof *table), *id = malloc(edges * sizeof *id);
    scene_edge_key *keys = malloc(edges * sizeof *keys);
    double(*sum)[3] = malloc(edges * sizeof *sum);
    int rc = TS_OK;
    if (edges && (!table || !id || !keys || !sum)) {
        rc = ts_error_set(err, TS_E_MEMORY, "scene: out of memory for edge normals");
        goto done;
    }
    if (edges) memset(table, 0xff, slots * sizeof *table);
    uint32_t unique = 0;
    for (uint32_t p = 0; p < s->patch_count; p++)
        for (int k = 0; k < 4; k++) {
            size_t e = (size_t)p * 4u + (size_t)k;
            ts_vec4 *o = &s->mid_n[(size_t)p * 5u + (size_t)k];
            id[e] = UINT32_MAX;
            if (o->w == SCENE_N_GIVEN) continue;
            double n[3];
            scene_mid_normal(s->cp + (size_t)p * 16u, k, n); /* from the current points */
            o->x = (float)n[0], o->y = (float)n[1], o->z = (float)n[2];
            scene_edge_key key = scene_edge_key_of(s->cp + (size_t)p * 16u, k);
            size_t h = scene_edge_hash(&key) & (slots - 1);
            while (table[h] != UINT32_MAX && memcmp(&keys[table[h]], &key, sizeof key) != 0)
                h = (h + 1) & (slots - 1);
            if (table[h] == UINT32_MAX) {
                table[h] = unique;
                keys[unique] = key;
                sum[unique][0] = sum[unique][1] = sum[unique][2] = 0.0;
                unique++;
            }
            id[e] = table[h];
            for (int d = 0; d < 3; d++)
                sum[id[e]][d] += n[d];
        }
    for (uint32_t p = 0; p < s->patch_count; p++)
        for (int k = 0; k < 5; k++) {
            ts_vec4 *o = &s->mid_n[(size_t)p * 5u + (size_t)k];
            if (o->w == SCENE_N_GIVEN) continue;
            if (k == 4) { /* the centre: the patch's own, from the current points */
                double n[3];
                scene_mid_normal(s->cp + (size_t)p * 16u, 4, n);
                o->x = (float)n[0], o->y = (float)n[1], o->z = (float)n[2];
            } else {
                const double *a = sum[id[(size_t)p * 4u + (size_t)k]];
                double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
                if (len > 1e-3)
                    o->x = (float)(a[0] / len), o->y = (float)(a[1] / len),
                    o->z = (float)(a[2] / len);
            }
            if (o->x == 0.0f && o->y == 0.0f && o->z == 0.0f) o->z = 1.0f;
            o->w = SCENE_N_GIVEN;
        }
done:
    free(table), free(id), free(keys), free(sum);
    return rc;
}

int scene_edge_neighbours(const ts_scene *s, uint32_t *nb, ts_error *err)
{
    /* An open-addressing table of edge indices, keys recomputed from the points on probing:
     * 8 bytes an edge. nb holds edge indices until the end; MULTI marks a curve on more than
     * two edges. */
    const uint32_t MULTI = TS_INVALID - 1u;
    size_t edges = (size_t)s->patch_count * 4u, slots = 16;
    while (slots < 2 * edges)
        slots *= 2;
    uint32_t *table = edges ? malloc(slots * sizeof *table) : NULL;
    if (edges && !table) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for edges");
    if (edges) memset(table, 0xff, slots * sizeof *table);
    for (size_t e = 0; e < edges; e++) {
        scene_edge_key key = scene_edge_key_of(s->cp + (e / 4u) * 16u, (int)(e % 4u));
        size_t h = scene_edge_hash(&key) & (slots - 1);
        nb[e] = TS_INVALID;
        for (; table[h] != UINT32_MAX; h = (h + 1) & (slots - 1)) {
            uint32_t f = table[h];
            scene_edge_key other = scene_edge_key_of(s->cp + (f / 4u) * 16u, (int)(f % 4u));
            if (memcmp(&other, &key, sizeof key) != 0) continue;
            if (nb[f] == TS_INVALID) { /* the curve's second edge */
                nb[f] = (uint32_t)e, nb[e] = f;
            } else { /* a third: the curve joins no pair */
                if (nb[f] != MULTI) nb[nb[f]] = MULTI;
                nb[f] = nb[e] = MULTI;
            }
            break;
        }
        if (table[h] == UINT32_MAX) table[h] = (uint32_t)e; /* the curve's first edge */
    }
    free(table);
    for (size_t e = 0; e < edges; e++) /* edges to patches; a patch's own two edges: none */
        nb[e] = nb[e] >= MULTI || nb[e] / 4u == e / 4u ? TS_INVALID : nb[e] / 4u;
    return TS_OK;
}

int scene_finalize(ts_scene *s, ts_error *err)
{
    int rc = scene_ensure_identity(s, err);
    if (rc != TS_OK) return rc;
    int moving = 0;
    for (uint32_t p = 0; p < s->patch_count; p++) {
        if (s->attr[p].xform >= s->xform_count)
            return ts_error_set(err, TS_E_INTERNAL, "scene: patch %u refers to transform %u of %u",
                                p, s->attr[p].xform, s->xform_count);
        moving |= (s->attr[p].flags & TS_PATCH_MOVING) != 0;
    }
    if (moving) {
        rc = scene_start_motion(s, err);
        if (rc != TS_OK) return rc;
        for (uint32_t p = 0; p < s->patch_count; p++)
            if (!(s->attr[p].flags & TS_PATCH_MOVING))
                memcpy(s->cp1 + (size_t)p * 16u, s->cp + (size_t)p * 16u, 16u * sizeof *s->cp);
    }
    rc = scene_average_normals(s, err);
    if (rc == TS_OK) rc = scene_average_mid_normals(s, err);
    return rc == TS_OK ? scene_share_instances(s, err) : rc;
}

/* ---- lights, boxes, free --------------------------------------------------------- */

int scene_add_light(ts_scene *s, const ts_scene_light *light, ts_error *err)
{
    uint32_t n = s->light_count;
    int full = (n == 0) || (n >= SCENE_FIRST_LIGHTS && (n & (n - 1u)) == 0);
    if (full) {
        if (n > UINT32_MAX / 2)
            return ts_error_set(err, TS_E_MEMORY, "scene: more than %u lights", n);
        uint32_t cap = n ? n * 2u : SCENE_FIRST_LIGHTS;
        ts_scene_light *l = realloc(s->lights, (size_t)cap * sizeof *l);
        if (!l) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for %u lights", cap);
        s->lights = l;
    }
    s->lights[n] = *light;
    s->light_count = n + 1u;
    return TS_OK;
}

/* fminf and fmaxf as glibc computes them on x86-64 (minss / maxss: y when equal or x is NaN,
 * x when y is NaN), the same bits, but as selects the compiler inlines: GCC calls libm for
 * fminf and fmaxf, and forest-1000's 1.1 M patch boxes spent 7% of its load there. */
static inline float box_minf(float x, float y)
{
    return (x < y || y != y) ? x : y;
}

static inline float box_maxf(float x, float y)
{
    return (x > y || y != y) ? x : y;
}

static void scene_box_points(ts_box *b, const ts_vec4 *c)
{
    for (int k = 0; k < 16; k++) {
        b->lo_x = box_minf(b->lo_x, c[k].x);
        b->lo_y = box_minf(b->lo_y, c[k].y);
        b->lo_z = box_minf(b->lo_z, c[k].z);
        b->hi_x = box_maxf(b->hi_x, c[k].x);
        b->hi_y = box_maxf(b->hi_y, c[k].y);
        b->hi_z = box_maxf(b->hi_z, c[k].z);
    }
}

float scene_displace_bound(const ts_scene *s, uint32_t p)
{
    if (s->attr[p].disp_kind == TS_DISP_TEXTURE) {
        ts_interval d =
            displace_texture_interval(&s->attr[p], scene_tex_ctx(s), 0.0f, 0.0f, 1.0f, 1.0f);
        return fmaxf(fabsf(d.lo), fabsf(d.hi));
    }
    return displace_bound(&s->attr[p]);
}

/* Whether a displacement bound is at least TS_ROUGH_MICROQUADS micro-quads of a patch with
 * box b diced at m. */
static int rough_at(float bound, ts_box b, uint32_t m)
{
    float side = fmaxf(fmaxf(b.hi_x - b.lo_x, b.hi_y - b.lo_y), b.hi_z - b.lo_z);
    return bound >= TS_ROUGH_MICROQUADS * ldexpf(side, -(int)m);
}

int scene_patch_rough(const ts_scene *s, uint32_t p, uint32_t m)
{
    if (s->attr[p].disp_kind == TS_DISP_NONE) return 0;
    return rough_at(scene_displace_bound(s, p), scene_patch_box(s, p), m);
}

uint32_t scene_patch_rough_lod(const ts_scene *s, uint32_t p, ts_box box, uint32_t limit)
{
    if (s->attr[p].disp_kind == TS_DISP_NONE) return limit + 1u;
    float bound = scene_displace_bound(s, p);
    uint32_t m = 0;
    while (m <= limit && !rough_at(bound, box, m))
        ++m;
    return m;
}

ts_box scene_patch_box(const ts_scene *s, uint32_t p)
{
    ts_box b = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    if (!s || p >= s->patch_count) return b; /* empty: lo > hi */
    scene_box_points(&b, s->cp + (size_t)p * 16u);
    if (s->cp1 && (s->attr[p].flags & TS_PATCH_MOVING))
        scene_box_points(&b, s->cp1 + (size_t)p * 16u);
    /* The displacement normal interpolates unit corner normals: each of its components is
     * at most 1 in magnitude, so d * n moves a point by at most |d| per axis. Rounded
     * outwards so the float box stays conservative. */
    float g = scene_displace_bound(s, p);
    /* A few ulps of |P| as well: the diced vertices are rounded, and build clamps every leaf
     * box to this box (build.cl), so it must hold them. */
    float mag =
        fmaxf(fmaxf(fmaxf(fabsf(b.lo_x), fabsf(b.hi_x)), fmaxf(fabsf(b.lo_y), fabsf(b.hi_y))),
              fmaxf(fabsf(b.lo_z), fabsf(b.hi_z)));
    g += 1e-6f * (mag + g);
    if (g > 0.0f) {
        b.lo_x = nextafterf(b.lo_x - g, -INFINITY);
        b.lo_y = nextafterf(b.lo_y - g, -INFINITY);
        b.lo_z = nextafterf(b.lo_z - g, -INFINITY);
        b.hi_x = nextafterf(b.hi_x + g, INFINITY);
        b.hi_y = nextafterf(b.hi_y + g, INFINITY);
        b.hi_z = nextafterf(b.hi_z + g, INFINITY);
    }
    return b;
}

int scene_add_input(ts_scene *s, const char *path, ts_error *err)
{
    char **grown = realloc(s->input_source, (s->input_count + 1) * sizeof *grown);
    if (!grown) return ts_error_set(err, TS_E_MEMORY, "out of memory (scene inputs)");
    s->input_source = grown;
    if (!(grown[s->input_count] = strdup(path)))
        return ts_error_set(err, TS_E_MEMORY, "out of memory (scene inputs)");
    s->input_count++;
    return TS_OK;
}

void occlusion_free(ts_occlusion *o)
{
    if (!o) return;
    free(o->patch);
    free(o->coeffs);
    free(o->normal);
    memset(o, 0, sizeof *o);
}

void scene_free(ts_scene *s)
{
    if (!s) return;
    free(s->cp);
    free(s->cp1);
    free(s->corner_n);
    free(s->mid_n);
    free(s->attr);
    free(s->xform);
    free(s->trim_seg);
    free(s->inst_runs);
    free(s->shape);
    free(s->instance);
    free(s->inst_xform);
    free(s->dome.map);
    free(s->lights);
    for (uint32_t i = 0; i < s->texture_count; i++)
        free(s->tex_source[i]);
    free(s->tex_source);
    for (uint32_t i = 0; i < s->input_count; i++)
        free(s->input_source[i]);
    free(s->input_source);
    free(s->textures);
    free(s->tex_pool);
    free(s->tex_pages);
    memset(s, 0, sizeof *s);
}
