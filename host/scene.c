/* scene.c — growth and bounds of the loaded scene (see scene.h for the layout). */
#include "scene.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* First allocation, in patches (64 * 16 control points * 16 bytes = 16 KiB). */
#define SCENE_FIRST_PATCHES 64u
/* Lights carry no capacity field: the capacity is implied by the count, the next power of
 * two at or above it, at least SCENE_FIRST_LIGHTS. */
#define SCENE_FIRST_LIGHTS 4u

/* Doubles the patch arrays when full. cp and attr are grown one after the other; the
 * capacity only moves when both succeeded, so a failure leaves the scene consistent. */
static int scene_reserve_patch(ts_scene *s, ts_error *err)
{
    if (s->patch_count < s->patch_capacity) return TS_OK;
    if (s->patch_capacity > UINT32_MAX / 2)
        return ts_error_set(err, TS_E_MEMORY, "scene: more than %u patches", s->patch_capacity);
    uint32_t cap = s->patch_capacity ? s->patch_capacity * 2u : SCENE_FIRST_PATCHES;
    ts_vec4 *cp = realloc(s->cp, (size_t)cap * 16u * sizeof *cp);
    if (!cp) goto fail;
    s->cp = cp;
    ts_patch_attr *attr = realloc(s->attr, (size_t)cap * sizeof *attr);
    if (!attr) goto fail;
    s->attr = attr;
    s->patch_capacity = cap;
    return TS_OK;
fail:
    return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for %u patches", cap);
}

int scene_add_patch(ts_scene *s, const double cp[16][3], const ts_patch_attr *attr, ts_error *err)
{
    int rc = scene_reserve_patch(s, err);
    if (rc != TS_OK) return rc;
    ts_vec4 *dst = s->cp + (size_t)s->patch_count * 16u;
    for (int k = 0; k < 16; k++) {
        dst[k].x = (float)cp[k][0];
        dst[k].y = (float)cp[k][1];
        dst[k].z = (float)cp[k][2];
        dst[k].w = 1.0f;
    }
    if (attr) {
        s->attr[s->patch_count] = *attr;
    } else {
        const ts_patch_attr white = {1.0f, 1.0f, 1.0f, 0u};
        s->attr[s->patch_count] = white;
    }
    s->patch_count++;
    return TS_OK;
}

int scene_add_light(ts_scene *s, const ts_distant_light *light, ts_error *err)
{
    uint32_t n = s->light_count;
    int full = (n == 0) || (n >= SCENE_FIRST_LIGHTS && (n & (n - 1u)) == 0);
    if (full) {
        if (n > UINT32_MAX / 2)
            return ts_error_set(err, TS_E_MEMORY, "scene: more than %u lights", n);
        uint32_t cap = n ? n * 2u : SCENE_FIRST_LIGHTS;
        ts_distant_light *l = realloc(s->lights, (size_t)cap * sizeof *l);
        if (!l) return ts_error_set(err, TS_E_MEMORY, "scene: out of memory for %u lights", cap);
        s->lights = l;
    }
    s->lights[n] = *light;
    s->light_count = n + 1u;
    return TS_OK;
}

ts_box scene_patch_box(const ts_scene *s, uint32_t p)
{
    ts_box b = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    if (!s || p >= s->patch_count) return b; /* empty: lo > hi */
    const ts_vec4 *c = s->cp + (size_t)p * 16u;
    for (int k = 0; k < 16; k++) {
        b.lo_x = fminf(b.lo_x, c[k].x);
        b.lo_y = fminf(b.lo_y, c[k].y);
        b.lo_z = fminf(b.lo_z, c[k].z);
        b.hi_x = fmaxf(b.hi_x, c[k].x);
        b.hi_y = fmaxf(b.hi_y, c[k].y);
        b.hi_z = fmaxf(b.hi_z, c[k].z);
    }
    return b;
}

void scene_free(ts_scene *s)
{
    if (!s) return;
    free(s->cp);
    free(s->attr);
    free(s->lights);
    memset(s, 0, sizeof *s);
}
