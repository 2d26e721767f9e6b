/* instance.c — instances that share their master's dicing (ObjectInstance, docs/rib.md
 * "Objects", scene.h ts_instance_run).
 *
 * Every instance keeps its own patches in the scene (control points, attributes, its own
 * top-level leaves: shading and light sampling see an ordinary patch). What it may share is
 * the dicing: the grid and quad-tree its master patch (the same patch of the object's first
 * instance) is diced into, traced by the instance's rays moved into the master's frame
 * (kernels/lib/instance.h). That gives the image of the copy only where the master's diced
 * surface, moved by the map to the instance, is the copy's diced surface:
 *   - the map is rigid (orthonormal linear part): displacement amplitudes are world units
 *     along unit normals, so a scaled instance is not a scaled master;
 *   - the master's control points are the instance's moved by the map, at both times (a
 *     moving instance whose motion differs from its master's is a copy);
 *   - the displacement normals too (a corner averaged with a neighbour outside the instance,
 *     or a mirrored instance, whose normals flip, is a copy);
 *   - the displacement attributes are equal (the noise itself is evaluated in object space,
 *     which the map keeps: world_to_object(P) is the same point for both);
 *   - the trim segments are equal (an object instanced under two TrimCurves is copied).
 * Each patch is checked on its own, to float rounding (SHARE_TOL relative to the patch's
 * size); a patch that fails is diced as itself, as before sharing existed. */
#include "scene/scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Relative tolerance of the checks: a few float roundings of points and normals. */
#define SHARE_TOL 1e-5

int scene_add_instance_run(ts_scene *s, const ts_instance_run *run, ts_error *err)
{
    if (s->inst_run_count == s->inst_run_capacity) {
        uint32_t cap = s->inst_run_capacity ? 2u * s->inst_run_capacity : 16u;
        ts_instance_run *r = realloc(s->inst_runs, (size_t)cap * sizeof *r);
        if (!r) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for instances");
        s->inst_runs = r, s->inst_run_capacity = cap;
    }
    s->inst_runs[s->inst_run_count++] = *run;
    return TS_OK;
}

/* Whether the 3x3 linear part of a (row-major 3x4) is orthonormal. */
static int share_rigid(const double a[12])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double d = 0.0;
            for (int k = 0; k < 3; k++)
                d += a[k * 4 + i] * a[k * 4 + j];
            if (!(fabs(d - (i == j ? 1.0 : 0.0)) <= SHARE_TOL)) return 0; /* NaN too */
        }
    return 1;
}

/* Whether a moves the n points (or, linear, directions) of p onto those of q within tol. */
static int share_points(const double a[12], const ts_vec4 *p, const ts_vec4 *q, int n, int linear,
                        double tol)
{
    for (int k = 0; k < n; k++) {
        const double v[3] = {p[k].x, p[k].y, p[k].z}, w[3] = {q[k].x, q[k].y, q[k].z};
        for (int r = 0; r < 3; r++) {
            double m = a[r * 4] * v[0] + a[r * 4 + 1] * v[1] + a[r * 4 + 2] * v[2];
            if (!linear) m += a[r * 4 + 3];
            if (!(fabs(m - w[r]) <= tol)) return 0;
        }
    }
    return 1;
}

/* The attributes dicing and building read (kernels/dice.cl, build.cl) are equal. */
static int share_attr(const ts_patch_attr *a, const ts_patch_attr *b)
{
    if ((a->flags & TS_PATCH_MOVING) != (b->flags & TS_PATCH_MOVING) ||
        a->disp_kind != b->disp_kind)
        return 0;
    if (a->disp_kind == TS_DISP_NONE) return 1;
    return a->disp_octaves == b->disp_octaves && a->disp_amplitude == b->disp_amplitude &&
           a->disp_frequency == b->disp_frequency && a->disp_lacunarity == b->disp_lacunarity &&
           a->disp_gain == b->disp_gain && a->disp_tex == b->disp_tex &&
           a->disp_offset == b->disp_offset && memcmp(a->st, b->st, sizeof a->st) == 0;
}

/* Patches p and q are trimmed alike (TrimCurve: the same segments in their own squares, which
 * build reads from the patch it dices), or neither is. */
static int share_trim(const ts_scene *s, uint32_t p, uint32_t q)
{
    const ts_patch_attr *a = &s->attr[p], *b = &s->attr[q];
    if (a->trim_count != b->trim_count) return 0;
    return a->trim_count == 0 || memcmp(s->trim_seg + a->trim_first, s->trim_seg + b->trim_first,
                                        (size_t)a->trim_count * sizeof *s->trim_seg) == 0;
}

/* Whether patch p may share the dicing of patch q through the map a (p's world -> q's). */
static int share_patch(const ts_scene *s, uint32_t p, uint32_t q, const double a[12])
{
    if (!share_attr(&s->attr[p], &s->attr[q]) || !share_trim(s, p, q)) return 0;
    const ts_vec4 *cp = s->cp + (size_t)p * 16u, *cq = s->cp + (size_t)q * 16u;
    double size = 0.0;
    for (int k = 0; k < 16; k++)
        size = fmax(size, fmax(fabs(cq[k].x), fmax(fabs(cq[k].y), fabs(cq[k].z))));
    double tol = SHARE_TOL * (1.0 + size);
    if (!share_points(a, cp, cq, 16, 0, tol)) return 0;
    if (s->cp1 && !share_points(a, s->cp1 + (size_t)p * 16u, s->cp1 + (size_t)q * 16u, 16, 0, tol))
        return 0;
    if (!s->corner_n || !s->mid_n) return 1; /* no normals: +z everywhere (pipeline.c) */
    return share_points(a, s->corner_n + (size_t)p * 4u, s->corner_n + (size_t)q * 4u, 4, 1,
                        1e-4) &&
           share_points(a, s->mid_n + (size_t)p * 5u, s->mid_n + (size_t)q * 5u, 5, 1, 1e-4);
}

/* The tables of a scene that shares something: shape (identity), instance (none). */
static int share_alloc(ts_scene *s, ts_error *err)
{
    s->shape = malloc((size_t)s->patch_count * sizeof *s->shape);
    s->instance = malloc((size_t)s->patch_count * sizeof *s->instance);
    s->inst_xform = malloc((size_t)s->inst_run_count * sizeof *s->inst_xform);
    if (!s->shape || !s->instance || !s->inst_xform)
        return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for instances");
    for (uint32_t p = 0; p < s->patch_count; p++)
        s->shape[p] = p, s->instance[p] = TS_INVALID;
    return TS_OK;
}

static void share_free(ts_scene *s)
{
    free(s->shape), free(s->instance), free(s->inst_xform);
    s->shape = s->instance = NULL, s->inst_xform = NULL;
    s->inst_xform_count = 0;
}

int scene_share_instances(ts_scene *s, ts_error *err)
{
    int rc = TS_OK;
    uint32_t shared = 0;
    if (s->inst_run_count == 0 || s->shape) { /* nothing recorded, or shared already */
        free(s->inst_runs);
        s->inst_runs = NULL, s->inst_run_count = s->inst_run_capacity = 0;
        return TS_OK;
    }
    rc = share_alloc(s, err);
    for (uint32_t r = 0; rc == TS_OK && r < s->inst_run_count; r++) {
        const ts_instance_run *run = &s->inst_runs[r];
        if (!share_rigid(run->to_master) || run->first + run->count > s->patch_count ||
            run->master_first + run->count > s->patch_count)
            continue;
        uint32_t x = s->inst_xform_count, used = 0;
        for (uint32_t k = 0; k < run->count; k++) {
            uint32_t p = run->first + k, q = run->master_first + k;
            if (s->shape[q] != q || !share_patch(s, p, q, run->to_master)) continue;
            s->shape[p] = q, s->instance[p] = x, used = 1, shared++;
        }
        if (!used) continue;
        float *rows[3] = {s->inst_xform[x].r0, s->inst_xform[x].r1, s->inst_xform[x].r2};
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++)
                rows[i][j] = (float)run->to_master[i * 4 + j];
        s->inst_xform_count++;
    }
    if (rc != TS_OK || shared == 0) share_free(s);
    free(s->inst_runs);
    s->inst_runs = NULL, s->inst_run_count = s->inst_run_capacity = 0;
    return rc;
}
