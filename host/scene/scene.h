/* scene.h — the scene as the renderer sees it after loading: bicubic Bézier patches in
 * world space, their attributes, the camera and the lights. Every patch kind the loaders
 * accept (other bases, PatchMesh, later meshes) is converted to Bézier here. */
#ifndef TS_SCENE_H
#define TS_SCENE_H

#include "base/error.h"
#include "lib/shared_types.h"
#include "lib/texture.h"

#include <stdint.h>

/* The camera as RIB describes it (RenderMan conventions: camera space is left-handed,
 * x right, y up, looking down +z; fov is the full angle of the shorter image axis). */
/* RenderMan's Clipping defaults (RI Spec: RI_EPSILON, RI_INFINITY): a camera with them clips
 * nothing (render_camera_params). */
#define TS_CLIP_NEAR_DEFAULT 1e-10
#define TS_CLIP_FAR_DEFAULT 1e30

typedef struct ts_camera {
    double world_to_camera[16]; /* row-major 4x4, column vectors: p_cam = M * p_world */
    /* A moving camera (RIB: a motion block before WorldBegin): world_to_camera is at shutter
     * open, world_to_camera1 at shutter close, and rays of time t see the camera in between
     * (ts_camera_params). world_to_camera1 is unused when moving is 0. */
    int moving;
    double world_to_camera1[16];
    double fov_deg;    /* Projection "perspective" "fov"; default 90 */
    int width, height; /* Format; 0 when the scene sets none */
    int has_format;
    /* PixelSamples xs ys: xs * ys samples per pixel; 0 when the scene sets none. The
     * command line's --spp overrides it. */
    int spp;
    /* Integrator "PxrPathTracer" "maxPathLength": the path depth when has_depth. The
     * command line's --depth overrides it. */
    int has_depth, depth;
    /* From the RIB options: Clipping near far (the camera sees camera-space depths in
     * [near, far]), Shutter open close (rib_state.c applies it to motion blocks), CropWindow
     * xmin xmax ymin ymax (the part of the frame rendered: app/render.c). rib_load sets the
     * RenderMan defaults (TS_CLIP_*_DEFAULT, 0 0, 0 1 0 1); zero in other scenes (no clipping,
     * the whole frame). */
    double clip_near, clip_far;
    double shutter[2];
    double crop[4];
    /* DepthOfField fstop focallength focaldistance (or a perspective Projection's fStop,
     * focalLength, focalDistance): a thin lens of radius focallength / (2 fstop) focused at
     * camera-space depth focaldistance, when fstop > 0 (ts_camera_params dof); 0: a pinhole. */
    double fstop, focal_length, focal_distance;
    /* Projection: TS_PROJECTION_PERSPECTIVE (0, with fov_deg) or TS_PROJECTION_ORTHOGRAPHIC
     * (lib/shared_types.h). */
    uint32_t projection;
    /* ScreenWindow left right bottom top when has_screen; else the RenderMan default
     * [-a, a] x [-1, 1] for image aspect a >= 1, [-1, 1] x [-1/a, 1/a] below. Screen units
     * are camera-space units for orthographic, tan(fov / 2) for perspective. */
    int has_screen;
    double screen[4];
    /* Exposure gain gamma when has_exposure: each output colour c becomes
     * (gain * c)^(1 / gamma); else the image is left as it is. */
    int has_exposure;
    double exposure_gain, exposure_gamma;
} ts_camera;

/* The kinds of ts_scene_light. */
typedef enum ts_scene_light_kind {
    SCENE_LIGHT_DISTANT = 0,
    SCENE_LIGHT_POINT = 1,
    SCENE_LIGHT_SPOT = 2,
    SCENE_LIGHT_AMBIENT = 3,
} ts_scene_light_kind;

/* A light of the scene (RIB LightSource, RI Spec 3.2 Appendix A), points in world space:
 *   distant: light travels from `from` to `to`; intensity * color is the irradiance it gives
 *     a surface facing it; the sun when angle (its angular diameter, degrees) > 0.
 *   point: at `from`; the irradiance on a surface facing it at distance d is intensity *
 *     color * (falloff_dist / max(d, falloff_min))^falloff (RenderMan's pointlight: falloff
 *     2, falloff_dist 1, falloff_min 0, i.e. 1 / d^2).
 *   spot: a point light at `from` shining towards `to`, times cos^beam(a)
 *     smoothstep(cos(cone_angle), cos(cone_angle - cone_delta), cos(a)) at the angle a from
 *     its axis, nothing beyond cone_angle (radians; RenderMan's spotlight).
 *   ambient: a uniform light from every direction of radiance intensity * color that eye
 *     rays do not see (RenderMan's ambientlight, as a dome; from/to unused).
 * Fields after `angle` are zero for a distant light, so {from, to, intensity, color, angle}
 * initialises one. No implicit padding (the struct is hashed). */
typedef struct ts_scene_light {
    double from[3], to[3];
    double intensity;
    double color[3];
    double angle;
    uint32_t kind; /* ts_scene_light_kind */
    uint32_t pad;
    double cone_angle, cone_delta, beam;
    double falloff, falloff_dist, falloff_min;
} ts_scene_light;

/* A uniform sky (LightSource "domelight"): radiance intensity * color from every direction. */
typedef struct ts_dome_light {
    int present;
    double intensity;
    double color[3];
    char mapname[4096]; /* a lat-long environment map (any OpenImageIO format), "" for none */
    /* Or a lat-long map made in memory (PxrEnvDayLight's baked sky, rib_ris_light.c): RGB
     * texels, map_width x map_height, owned by the scene (scene_free); NULL for none. */
    float *map;
    uint32_t map_width, map_height;
} ts_dome_light;

/* A baked spherical-harmonics occlusion for relighting (`tessera render --occlusion`,
 * docs/bake.md "Relighting"; read by app/bake_file.h bake_occlusion_load): patch p's
 * (2^m + 1)^2 points, point (i, j) at (u, v) = (i, j) / 2^m being point patch[2p] + j (2^m + 1)
 * + i, m = patch[2p + 1]; B^2 coefficients a point, lib/sh.h's order (kernels/lib/relight.h
 * reads them). */
typedef struct ts_occlusion {
    uint32_t bands;  /* B, 1..4 */
    uint32_t cosine; /* 1: the coefficients project V max(0, N . w) (bake --cosine) */
    uint32_t patch_count, point_count;
    uint32_t *patch; /* 2 * patch_count words */
    float *coeffs;   /* point_count * B^2 */
    float *normal;   /* point_count * 3: the unit N each point's hemisphere is about */
} ts_occlusion;

void occlusion_free(ts_occlusion *o);

/* A run of patches an ObjectInstance added that repeat, patch for patch, the run of the
 * object's first instance: patch first + k is master_first + k placed by the affine map
 * a (world of the master's instance -> world of this one, row-major 3x4 of a 4x4 acting on
 * column vectors, time 0). Recorded by the RIB reader (rib_object.c), turned into shared
 * dicing by scene_finalize (host/scene/instance.c). */
typedef struct ts_instance_run {
    uint32_t first, master_first, count;
    double to_master[12]; /* the inverse of a: this instance's world -> the master's */
} ts_instance_run;

/* The alignment of the arrays cp, cp1, corner_n, mid_n and attr as the scene makes them (bytes): a
 * device that shares host memory reads them in place (pipeline.c; PoCL uses a host pointer
 * so aligned without a copy). Scenes unpacked from a block (scene_pack.h) are not aligned. */
#define SCENE_ALIGN 4096u

typedef struct ts_scene {
    uint32_t patch_count;
    uint32_t patch_capacity;
    /* patch_count * 16 control points, world space, Bézier basis, row by row with u
     * fastest: point (i, j) of patch p is cp[p * 16 + j * 4 + i], w = 1. For a moving patch
     * (attr.flags & TS_PATCH_MOVING) these are the points at shutter open (time 0). */
    ts_vec4 *cp;
    /* Points at shutter close (time 1), same layout; NULL while no patch moves. Static
     * patches hold a copy of cp here once any patch moves (Hanika §3.4). */
    ts_vec4 *cp1;
    /* patch_count * 4 displacement normals at the corners (u, v) = (0,0), (1,0), (0,1),
     * (1,1), unit length, w = 0 (DESIGN.md §2). From a varying "N" when the scene gives one,
     * else set by scene_finalize to the average over every patch sharing the corner. */
    ts_vec4 *corner_n;
    /* patch_count * 5 more displacement normals, unit length: at the edge midpoints
     * (u, v) = (1/2, 0), (0, 1/2), (1, 1/2), (1/2, 1) and the centre (1/2, 1/2). With the
     * corners they are the nine nodes the displacement direction is interpolated between
     * (lib/displace.h displace_normal, DESIGN.md §2): an edge's midpoint normal is shared
     * by every patch with that boundary curve (the average of their unit normals there)
     * unless the patch has explicit corner normals, when it is the normalised sum of the
     * edge's two corner normals; the centre is the patch's own normal. Set by
     * scene_finalize like corner_n (provisionally the patch's own normals until then). */
    ts_vec4 *mid_n;
    ts_patch_attr *attr; /* patch_count entries */
    /* World-to-object transforms referenced by attr.xform (noise is evaluated in object
     * space); xform[0] is the identity. */
    ts_xform *xform;
    uint32_t xform_count, xform_capacity;
    /* The trim curves of trimmed NURBS pieces (RiTrimCurve; lib/trim.h, host/scene/trim.h):
     * segments (x0, y0, x1, y1) in each piece's own (u, v) square, patch p's from
     * attr[p].trim_first, attr[p].trim_count of them (0: untrimmed). NULL while none. */
    ts_vec4 *trim_seg;
    uint32_t trim_seg_count, trim_seg_capacity;
    /* Instancing (ObjectInstance, host/scene/instance.c, docs/rib.md "Objects"): candidate
     * runs from the reader, then after scene_finalize, when some instance patch shares the
     * dicing of its master (NULL otherwise, and every patch is diced as itself):
     * shape[p] the patch whose diced grid and tree p uses (p itself when p is not shared), and
     * instance[p] the index in inst_xform of the map from p's world to its master's (rigid;
     * TS_INVALID when p is not shared). */
    ts_instance_run *inst_runs;
    uint32_t inst_run_count, inst_run_capacity;
    uint32_t *shape;
    uint32_t *instance;
    ts_xform *inst_xform;
    uint32_t inst_xform_count;
    /* Image textures (lib/texture.h, host/scene/texture.c), referenced by attr.disp_tex and
     * attr.color_tex: texture_count descriptors, every tile of every level in tex_pool
     * (tex_tile_count tiles of TS_TEX_TILE^2 texels) and the identity page table
     * tex_pages[i] = i; tex_source[i] is the file texture i was read from. */
    ts_texture *textures;
    char **tex_source;
    uint32_t texture_count;
    ts_vec4 *tex_pool;
    uint32_t *tex_pages;
    uint32_t tex_tile_count;
    /* Every other file the scene was read from (RIB archives, meshes; textures are in
     * tex_source): outputs must not name one (host/app/output.c). */
    char **input_source;
    uint32_t input_count;
    ts_camera camera;
    ts_scene_light *lights; /* distant, point, spot and ambient lights, in scene order */
    uint32_t light_count;
    ts_dome_light dome;
    /* The baked occlusion `render --occlusion` relights with (NULL: none); not the scene's:
     * whoever attaches it frees it, scene_free does not. */
    const ts_occlusion *occlusion;
} ts_scene;

/* Appends one Bézier patch (16 world-space points, u fastest). Returns TS_OK or
 * TS_E_MEMORY. */
int scene_add_patch(ts_scene *s, const double cp[16][3], const ts_patch_attr *attr, ts_error *err);
/* The general form: cp1 (points at time 1) NULL for a static patch, else the patch moves
 * (sets TS_PATCH_MOVING); normals (corner displacement normals in the corner order above,
 * world space, any length) NULL to have scene_finalize average them. */
int scene_add_patch_ex(ts_scene *s, const double cp[16][3], const double cp1[16][3],
                       const double normals[4][3], const ts_patch_attr *attr, ts_error *err);
/* scene_add_patch_ex without motion into slot p below patch_capacity (made by
 * scene_reserve_patches), patch_count left as it is, the scene's transforms made: it writes
 * slot p alone, so threads may fill distinct slots at once (the forest's trees); the caller
 * sets patch_count once every slot below it is filled. */
int scene_put_patch(ts_scene *s, uint32_t p, const double cp[16][3], const double normals[4][3],
                    const ts_patch_attr *attr, ts_error *err);
/* Makes room for `more` patches beyond patch_count at once: a generator that knows how many it
 * adds (the forest) saves the doublings, each of which copies the arrays into new memory that
 * is touched again (forest-1000: loaded in 1.2-1.5 s instead of 1.9-2.0 s, 680 MiB peak instead
 * of 950). TS_E_MEMORY. */
int scene_reserve_patches(ts_scene *s, uint64_t more, ts_error *err);
/* Makes patch p move: cp1 (world space) becomes its control points at shutter close. Its
 * corner normals stay those of shutter open. */
int scene_set_patch_motion(ts_scene *s, uint32_t p, const double cp1[16][3], ts_error *err);
/* Gives patch p new points at shutter open (cp0) and close (cp1), world space (the RIB
 * Shutter's part of a motion block, rib_geom.c): it moves when they differ after rounding to
 * float, else it is static (TS_PATCH_MOVING cleared); corner normals it did not get from
 * "N" are its own again, from cp0. */
int scene_set_patch_samples(ts_scene *s, uint32_t p, const double cp0[16][3],
                            const double cp1[16][3], ts_error *err);
/* Adds a world-to-object transform (row-major 4x4, affine) and returns its index for
 * ts_patch_attr.xform; an identical transform already added is reused. */
int scene_add_xform(ts_scene *s, const double world_to_object[16], uint32_t *index, ts_error *err);
/* Appends n trim segments (lib/trim.h) and returns the index of the first in *first, for
 * ts_patch_attr.trim_first. TS_E_MEMORY past UINT32_MAX segments or memory. */
int scene_add_trim(ts_scene *s, const ts_vec4 *seg, uint32_t n, uint32_t *first, ts_error *err);
/* Completes a loaded scene: corner normals for patches without explicit ones (the
 * geometric normal of each patch at each corner, averaged over all patches whose corner
 * has exactly the same position, then normalised; where a patch's derivatives vanish at a
 * corner the limit from inside the patch is used), and cp1 copies for static patches when
 * any patch moves. Loaders call it once at the end. */
int scene_finalize(ts_scene *s, ts_error *err);
/* The patch across each edge: nb[4 p + k] is the other patch whose boundary curve k (0: v = 0,
 * 1: u = 0, 2: u = 1, 3: v = 1; the midpoint order of mid_n) has the same four control points
 * as patch p's, in either direction, when exactly two edges of two patches share it, else
 * TS_INVALID. nb holds 4 patch_count entries. TS_E_MEMORY when the table cannot be had. */
int scene_edge_neighbours(const ts_scene *s, uint32_t *nb, ts_error *err);
/* Records a run of instance patches (rib_object.c); see ts_instance_run. */
int scene_add_instance_run(ts_scene *s, const ts_instance_run *run, ts_error *err);
/* Turns the recorded runs into shared dicing (host/scene/instance.c): patch p of a run
 * shares its master's dicing when the map to the master is rigid (orthonormal linear part)
 * and takes the master's control points (both times), displacement normals and
 * displacement attributes to p's within float rounding; other patches stay copies. Sets
 * shape, instance and inst_xform (all NULL when nothing is shared) and frees the runs.
 * scene_finalize calls it last. */
int scene_share_instances(ts_scene *s, ts_error *err);
/* The patch whose dicing patch p uses: p, or its master. */
static inline uint32_t scene_shape(const ts_scene *s, uint32_t p)
{
    return s->shape ? s->shape[p] : p;
}
/* Appends a light. */
int scene_add_light(ts_scene *s, const ts_scene_light *light, ts_error *err);
/* Conservative world-space box of patch p over the whole shutter interval: the box of its
 * control points at both times (convex hull property of Bézier patches, Hanika §3.3) grown
 * by the largest displacement the patch's function can produce (displace_bound in
 * lib/displace.h; for a texture its min-max pyramid over the patch's st rectangle,
 * displace_texture_interval) in every axis. */
ts_box scene_patch_box(const ts_scene *s, uint32_t p);

/* The largest |displacement| of patch p: the noise's global bound, or the texture's over the
 * patch's st rectangle (0 when undisplaced). scene_patch_box grows the hull by it. */
float scene_displace_bound(const ts_scene *s, uint32_t p);

/* Micro-quads of displacement from which a patch's trees get tight codes. */
#define TS_ROUGH_MICROQUADS 4.0f

/* Whether patch p diced at m is displaced by at least TS_ROUGH_MICROQUADS micro-quads (the
 * longest side of its box over 2^m): then box mode's boxes, which bound every finer dicing,
 * are far larger than its vertices' and build gives it tight codes (TS_PATCH_ROUGH; trace.c
 * and host/ref/dice_build_ref.c). Below that the codes would barely shrink them: forest-1's
 * bark is displaced by a median 1.4 micro-quads, teapot_displaced by 8.5 to 19 at m = 8. */
int scene_patch_rough(const ts_scene *s, uint32_t p, uint32_t m);

/* The least m <= limit at which patch p is rough (scene_patch_rough grows with m), limit + 1
 * if none, with box = scene_patch_box(s, p) already made: one displacement bound and no
 * patch box per m (the pipeline's rough_lod for every patch). */
uint32_t scene_patch_rough_lod(const ts_scene *s, uint32_t p, ts_box box, uint32_t limit);
void scene_free(ts_scene *s);

/* Reads an image (any format OpenImageIO reads) as texture kind TS_TEX_MINMAX (the first
 * channel, with its min-max pyramid) or TS_TEX_RGB (grey for one or two channels, else the
 * first three) and returns its index; a file already read as that kind is reused.
 * Non-finite texels are an error (TS_E_IO "PATH: ..."), as is a side over 32768. */
/* Records path as a file the scene was read from (input_source). */
int scene_add_input(ts_scene *s, const char *path, ts_error *err);
int scene_add_texture(ts_scene *s, const char *path, uint32_t kind, uint32_t *index, ts_error *err);
/* The textures as lib/texture.h reads them on the host (every tile resident). */
ts_tex_ctx scene_tex_ctx(const ts_scene *s);
/* The range of texture `index`'s first channel (its coarsest min-max level), TS_TEX_MINMAX. */
ts_interval scene_texture_range(const ts_scene *s, uint32_t index);

#endif
