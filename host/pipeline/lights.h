/* lights.h — the light tables the shade kernel samples (kernels/lib/lights.h), built from
 * the scene on the host in plain C, without OpenCL (DESIGN.md §3): the ts_light list (every
 * distant, point and spot light, the dome, the ambient lights as one dome, one area light over
 * all emissive patches), the area light's
 * emitter table, and the dome's environment map with the CDFs that sample it by luminance
 * times sin(theta). pipeline_create uploads them; tests/test_lights.c checks the numbers. */
#ifndef TS_PIPELINE_LIGHTS_H
#define TS_PIPELINE_LIGHTS_H

#include "base/error.h"
#include "image/image.h"
#include "lib/shared_types.h"
#include "scene/scene.h"

#include <stdint.h>

/* A scene may have at most this many distant, point and spot lights (lights_build fails with
 * TS_E_SCENE beyond it; its ambient lights add up into one); the light list adds the dome,
 * the ambient dome and the area light. light_select scans the list at every path vertex. */
#define TS_MAX_SCENE_LIGHTS 256u
#define TS_MAX_LIGHTS (TS_MAX_SCENE_LIGHTS + 3u)

/* A dome's lat-long map as the kernels read it (lib/lights.h env_lookup / env_sample):
 * row 0 looks along +z; sampled by a marginal CDF over rows and a conditional CDF within
 * each row, weights luminance (Rec. 709) times sin(theta) of the row's centre. A map whose
 * weights are all 0 (or a row whose weights are) gets uniform CDFs. */
typedef struct ts_env_map {
    ts_vec4 *texels;        /* width * height, row-major; rgb, w = 0; negative or
                               non-finite texels are black */
    float *marginal;        /* height: cumulative over rows, ends at exactly 1 */
    float *conditional;     /* width * height: cumulative within each row, each row ends at
                               exactly 1 */
    uint32_t width, height; /* 0 x 0 and NULL arrays: no map */
} ts_env_map;

/* Builds the map from an image's first three channels (grey from the first when it has
 * fewer than three). On failure *e is zeroed (TS_E_MEMORY). */
int env_map_from_image(const ts_image *img, ts_env_map *e, ts_error *err);
/* Reads `path` (any format OpenImageIO reads) and builds the map from it. */
int env_map_load(const char *path, ts_env_map *e, ts_error *err);
void env_map_free(ts_env_map *e);

/* The lights of a scene as the kernels read them. One light is chosen per light sample with
 * probability proportional to its weight (lib/lights.h light_select), scanning the list in
 * order, so the order is part of the image: distant, point and spot lights in scene order,
 * then the dome, then the ambient lights as one uniform dome eye rays do not see, then the
 * area light. Weights (luminances): distant E / pi, point and spot I falloff(d) / pi for a
 * typical distance d (the light's distance to the centre of the scene's box, or half its
 * diagonal if larger), dome L (times the map's mean luminance), ambient L, area light the
 * emitters' power / (pi d^2) for a typical distance d (half the box's diagonal). */
typedef struct ts_light_table {
    ts_light lights[TS_MAX_LIGHTS];
    uint32_t light_count;
    /* The area light's emissive patches, chosen with probability prob proportional to
     * power (area times brightest channel of le); cdf ends at exactly 1. Always allocated
     * (one zeroed entry when there is no emitter), so it can be uploaded as is. */
    ts_emitter *emitters;
    uint32_t emitter_count;
} ts_light_table;

/* Builds the light table of scene s. A distant light of angular diameter a > 0 becomes a
 * cone of half angle a / 2: radiance E / (pi sin^2(a / 2)), solid angle 2 pi (1 - cos(a / 2));
 * a = 0 is a delta light of irradiance E = intensity * color. Point and spot lights keep
 * intensity * color, their falloff and cone (shared_types.h ts_light). The dome has radiance
 * intensity * color and env's size (NULL: uniform). attr (s->patch_count entries, the
 * caller's copy of s->attr) gets each patch's emitter index, TS_INVALID where it does not
 * emit; it may be NULL when no patch emits (nothing is written then). TS_E_SCENE with more than
 * TS_MAX_SCENE_LIGHTS distant, point and spot lights. Free with lights_free (also after a failure).
 */
int lights_build(const ts_scene *s, const ts_env_map *env, ts_patch_attr *attr, ts_light_table *t,
                 ts_error *err);
void lights_free(ts_light_table *t);

#endif
