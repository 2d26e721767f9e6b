/* scene.h — the scene as the renderer sees it after loading: bicubic Bézier patches in
 * world space, their attributes, the camera and the lights. Every patch kind the loaders
 * accept (other bases, PatchMesh, later meshes) is converted to Bézier here. */
#ifndef TS_SCENE_H
#define TS_SCENE_H

#include "error.h"
#include "lib/shared_types.h"

#include <stdint.h>

/* The camera as RIB describes it (RenderMan conventions: camera space is left-handed,
 * x right, y up, looking down +z; fov is the full angle of the shorter image axis). */
typedef struct ts_camera {
    double world_to_camera[16]; /* row-major 4x4, column vectors: p_cam = M * p_world */
    double fov_deg;             /* Projection "perspective" "fov"; default 90 */
    int width, height;          /* Format; 0 when the scene sets none */
    int has_format;
} ts_camera;

/* A distant light (LightSource "distantlight"): light travels from `from` to `to`. */
typedef struct ts_distant_light {
    double from[3], to[3];
    double intensity;
    double color[3];
} ts_distant_light;

typedef struct ts_scene {
    uint32_t patch_count;
    uint32_t patch_capacity;
    /* patch_count * 16 control points, world space, Bézier basis, row by row with u
     * fastest: point (i, j) of patch p is cp[p * 16 + j * 4 + i], w = 1. */
    ts_vec4 *cp;
    ts_patch_attr *attr; /* patch_count entries */
    ts_camera camera;
    ts_distant_light *lights;
    uint32_t light_count;
} ts_scene;

/* Appends one Bézier patch (16 world-space points, u fastest). Returns TS_OK or
 * TS_E_MEMORY. */
int scene_add_patch(ts_scene *s, const double cp[16][3], const ts_patch_attr *attr,
                    ts_error *err);
/* Appends a distant light. */
int scene_add_light(ts_scene *s, const ts_distant_light *light, ts_error *err);
/* Conservative world-space box of patch p: the box of its control points, which holds the
 * surface by the convex hull property of Bézier patches (Hanika §3.3). */
ts_box scene_patch_box(const ts_scene *s, uint32_t p);
void scene_free(ts_scene *s);

#endif
