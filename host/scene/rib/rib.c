/* rib.c — the RIB reader's entry points and request loop: reads each request name and its
 * arguments (rib_args.c) and hands them to its handler through the dispatch table
 * (rib_state.c, rib_geom.c, rib_shading.c, rib_light.c, rib_options.c, rib_archive.c,
 * rib_object.c, ...). Requests the renderer does not need are accepted with one warning per
 * name; others are scene errors. Inside ObjectBegin ... ObjectEnd requests are recorded
 * (rib_object.c), not run.
 * The subset is listed in docs/rib.md. */
#include "scene/rib/rib.h"

#include "base/mat4.h"
#include "scene/rib/rib_internal.h"
#include "scene/rib/rib_prims.h"
#include "scene/rib/rib_text.h"

#include "base/file.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- dispatch ---------------------------------------------------------------------- */

static const struct {
    const char *name;
    int (*fn)(rib_parser *p);
} rib_handlers[] = {
    {"AttributeBegin", rib_req_attribute_begin},
    {"AttributeEnd", rib_req_attribute_end},
    {"Basis", rib_req_basis},
    {"AreaLightSource", rib_req_area_light_source},
    {"Clipping", rib_req_clipping},
    {"Color", rib_req_color},
    {"ConcatTransform", rib_req_concat_transform},
    {"CoordSysTransform", rib_req_coord_sys_transform},
    {"CoordinateSystem", rib_req_coordinate_system},
    {"CropWindow", rib_req_crop_window},
    {"DepthOfField", rib_req_depth_of_field},
    {"Displacement", rib_req_displacement},
    {"Display", rib_req_display},
    {"Exposure", rib_req_exposure},
    {"Format", rib_req_format},
    {"FrameBegin", rib_req_frame_begin},
    {"FrameEnd", rib_req_frame_end},
    {"Geometry", rib_req_geometry},
    {"Hider", rib_req_ris_ignored},
    {"IfBegin", rib_req_if_begin},
    {"IfEnd", rib_req_if_end},
    {"ElseIf", rib_req_else_if},
    {"Else", rib_req_else},
    {"Integrator", rib_req_integrator},
    {"Bxdf", rib_req_bxdf},
    {"Pattern", rib_req_pattern},
    {"Light", rib_req_light},
    {"LightFilter", rib_req_ris_ignored},
    {"Displace", rib_req_displace},
    {"Camera", rib_req_camera},
    {"DisplayFilter", rib_req_ris_ignored},
    {"SampleFilter", rib_req_ris_ignored},
    {"Option", rib_req_option},
    {"Attribute", rib_req_attribute},
    {"ScopedCoordinateSystem", rib_req_scoped_coordinate_system},
    {"Procedural2", rib_req_procedural2},
    {"Identity", rib_req_identity},
    {"LightSource", rib_req_light_source},
    {"MotionBegin", rib_req_motion_begin},
    {"MotionEnd", rib_req_motion_end},
    {"ObjectBegin", rib_req_object_begin},
    {"ObjectEnd", rib_req_object_end},
    {"ObjectInstance", rib_req_object_instance},
    {"Opacity", rib_req_opacity},
    {"Patch", rib_req_patch},
    {"PatchMesh", rib_req_patch_mesh},
    {"PixelSamples", rib_req_pixel_samples},
    {"Procedural", rib_req_procedural},
    {"Projection", rib_req_projection},
    {"ReadArchive", rib_req_read_archive},
    {"ArchiveBegin", rib_req_archive_begin},
    {"ArchiveEnd", rib_req_archive_end},
    {"Rotate", rib_req_rotate},
    {"Skew", rib_req_skew},
    {"Scale", rib_req_scale},
    {"ScreenWindow", rib_req_screen_window},
    {"SolidBegin", rib_req_solid_begin},
    {"SolidEnd", rib_req_solid_end},
    {"Shutter", rib_req_shutter},
    {"Surface", rib_req_surface},
    {"ShaderLayer", rib_req_shader_layer},
    {"ConnectShaderLayers", rib_req_connect_shader_layers},
    {"Transform", rib_req_transform},
    {"TransformBegin", rib_req_transform_begin},
    {"TransformEnd", rib_req_transform_end},
    {"Translate", rib_req_translate},
    {"WorldBegin", rib_req_world_begin},
    {"WorldEnd", rib_req_world_end},
    /* Surfaces turned into Bézier patches (rib_prims.h). */
    {"Blobby", rib_req_blobby},
    {"Cone", rib_req_cone},
    {"Curves", rib_req_curves},
    {"Cylinder", rib_req_cylinder},
    {"Disk", rib_req_disk},
    {"GeneralPolygon", rib_req_general_polygon},
    {"Hyperboloid", rib_req_hyperboloid},
    {"NuPatch", rib_req_nu_patch},
    {"TrimCurve", rib_req_trim_curve},
    {"Paraboloid", rib_req_paraboloid},
    {"Points", rib_req_points},
    {"PointsGeneralPolygons", rib_req_points_general_polygons},
    {"PointsPolygons", rib_req_points_polygons},
    {"Polygon", rib_req_polygon},
    {"Sphere", rib_req_sphere},
    {"SubdivisionMesh", rib_req_subdivision_mesh},
    {"HierarchicalSubdivisionMesh", rib_req_hierarchical_subdivision_mesh},
    {"Resource", rib_req_resource},
    {"ResourceBegin", rib_req_resource_begin},
    {"ResourceEnd", rib_req_resource_end},
    {"Torus", rib_req_torus},
};

/* Accepted with a warning: they change neither geometry nor camera placement. */
static const char *const rib_ignored[] = {
    "Atmosphere",
    "Bound",
    "ClippingPlane",
    "ColorSamples",
    "Declare",
    "Detail",
    "DetailRange",
    "DisplayChannel",
    "Exterior",
    "FrameAspectRatio",
    "GeometricApproximation",
    "GeometricRepresentation",
    "Illuminate",
    "Imager",
    "Interior",
    "MakeBump",
    "MakeCubeFaceEnvironment",
    "MakeLatLongEnvironment",
    "MakeShadow",
    "MakeTexture",
    "Matte",
    "Orientation",
    "PixelFilter",
    "PixelVariance",
    "Quantize",
    "RelativeDetail",
    "ReverseOrientation",
    "ShadingInterpolation",
    "ShadingRate",
    "Sides",
    "TextureCoordinates",
    "VPAtmosphere", /* RenderMan 20's volume-primitive shaders (look-file payloads write */
    "VPInterior",   /* VPInterior "null") */
    "VPSurface",
};

/* Known RenderMan requests this loader cannot honour: ignoring them would misplace or
 * drop geometry, so they are errors. */
/* One name a line (clang-format off), so that changes to the list stay local. */
/* clang-format off */
static const char *const rib_unsupported[] = {
    "ArchiveRecord",
    "Perspective",
};
/* clang-format on */

/* The handler of the current request, or NULL. */
static int (*rib_handler(const rib_parser *p))(rib_parser *)
{
    for (size_t i = 0; i < RIB_COUNT(rib_handlers); i++)
        if (strcmp(p->req, rib_handlers[i].name) == 0) return rib_handlers[i].fn;
    return NULL;
}

/* TS_OK for a request the reader runs or ignores, else its error (not supported, unknown). */
static int rib_known(rib_parser *p)
{
    if (rib_handler(p) || strcmp(p->req, "version") == 0 ||
        rib_in_list(p->req, rib_ignored, RIB_COUNT(rib_ignored)))
        return TS_OK;
    if (rib_in_list(p->req, rib_unsupported, RIB_COUNT(rib_unsupported)))
        return rib_error_at(p, p->req_line, p->req_col, "%s is not supported", p->req);
    return rib_error_at(p, p->req_line, p->req_col, "unknown request %s", p->req);
}

int rib_dispatch_request(rib_parser *p)
{
    if (rib_frames_skip(p)) return TS_OK; /* a frame that is not rendered */
    if (rib_inline_recording(p)) {        /* an inline archive: kept, not run */
        int rc = rib_known(p);
        return rc == TS_OK ? rib_inline_record(p) : rc;
    }
    if (rib_cond_skip(p)) return TS_OK; /* a branch of IfBegin not taken */
    if (rib_object_recording(p)) {      /* an object's definition: kept, not run */
        int rc = rib_known(p);
        return rc == TS_OK ? rib_object_record(p) : rc;
    }
    if (p->motion.active && strcmp(p->req, "MotionEnd") != 0) {
        int rc = rib_motion_check(p);
        if (rc != TS_OK) return rc;
    }
    int (*fn)(rib_parser *) = rib_handler(p);
    if (fn) return fn(p);
    if (strcmp(p->req, "version") == 0) return TS_OK; /* RIB header line */
    if (rib_in_list(p->req, rib_ignored, RIB_COUNT(rib_ignored))) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what, "%s is ignored", p->req);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    return rib_known(p);
}

/* ---- driver ------------------------------------------------------------------------ */

int rib_run_requests(rib_parser *p)
{
    rib_token t;
    int rc = rib_lex_next(&p->lx, &t);
    while (rc == TS_OK && t.kind != RIB_TOK_EOF) {
        if (t.kind == RIB_TOK_RLF) { /* a look-file nugget between requests (rib_rlf.c) */
            rc = rib_rlf_nugget(p, &t);
            if (rc == TS_OK) rc = rib_lex_next(&p->lx, &t);
            continue;
        }
        if (t.kind != RIB_TOK_NAME)
            return rib_error_at(p, t.line, t.col, "expected a request name, found %s",
                                t.kind == RIB_TOK_NUMBER   ? "a number"
                                : t.kind == RIB_TOK_STRING ? "a string"
                                                           : "a bracket");
        memcpy(p->req, t.str, t.len + 1); /* t.len <= RIB_MAX_NAME */
        p->req_line = t.line;
        p->req_col = t.col;
        rc = rib_read_args(p, &t);
        if (rc == TS_OK) rc = rib_dispatch_request(p);
    }
    if (rc == TS_OK) rc = rib_object_check_file_end(p);
    return rc == TS_OK ? rib_inline_check_file_end(p) : rc;
}

/* The whole file: its requests, then every block must be closed, the frame asked for must
 * have been read, and a file read as a scene must make one. */
static int rib_run(rib_parser *p)
{
    int rc = rib_run_requests(p);
    if (rc == TS_OK) rc = rib_cond_check_closed(p);
    if (rc == TS_OK) rc = rib_frames_finish(p);
    if (rc == TS_OK) rc = rib_check_closed(p);
    if (rc == TS_OK && p->whole_scene) rc = rib_scene_check(p);
    return rc;
}

static void rib_parser_init(rib_parser *p, const char *name, const char *text, size_t len,
                            ts_scene *scene, unsigned flags, ts_error *err)
{
    rib_lex_init(&p->lx, name ? name : "<string>", text, len, err);
    p->scene = scene;
    p->err = err;
    p->quiet = (flags & RIB_QUIET) != 0;
    p->strict = (flags & RIB_STRICT) != 0;
    p->run_programs = (flags & RIB_PROGRAMS) != 0;
    mat4_identity(p->ctm);
    mat4_identity(p->ctm1);
    p->disp = (rib_disp){TS_DISP_NONE, 4, 0.1, 1.0, 2.0, 0.5, 0, 0.0, 0, {0}};
    p->color[0] = p->color[1] = p->color[2] = 1.0;
    p->opacity[0] = p->opacity[1] = p->opacity[2] = 1.0;
    p->surface = (rib_surface){.material = TS_MAT_MATTE, .kd = 1.0, .roughness = 0.1};
    p->ubasis = basis_bezier;
    p->vbasis = basis_bezier;
    p->phase = RIB_BEFORE_WORLD;
    p->first_patch = scene->patch_count;
    p->first_light = scene->light_count;
    mat4_identity(scene->camera.world_to_camera);
    scene->camera.moving = 0;
    scene->camera.fov_deg = 90.0;
    scene->camera.width = scene->camera.height = 0;
    scene->camera.has_format = 0;
    scene->camera.spp = 0;
    scene->camera.has_depth = 0, scene->camera.depth = 0;
    scene->camera.clip_near = TS_CLIP_NEAR_DEFAULT, scene->camera.clip_far = TS_CLIP_FAR_DEFAULT;
    scene->camera.shutter[0] = scene->camera.shutter[1] = 0.0;
    scene->camera.crop[0] = scene->camera.crop[2] = 0.0;
    scene->camera.crop[1] = scene->camera.crop[3] = 1.0;
    scene->camera.projection = TS_PROJECTION_PERSPECTIVE;
    scene->camera.has_screen = 0;
    scene->camera.has_exposure = 0;
}

/* One parse of the text (rib_parse); *depth_skipped: whether frames were left as depth-map
 * passes (rib_frames.c rib_req_display). */
static int rib_parse_once(const char *name, const rib_text *t, int frame, int keep_depth,
                          int whole_scene, ts_scene *scene, unsigned flags, ts_error *err,
                          int *depth_skipped)
{
    rib_parser *p = calloc(1, sizeof *p);
    if (!p) return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", name ? name : "<string>");
    rib_parser_init(p, name, t->text, t->len, scene, flags, err);
    p->frames.wanted = frame < 0 ? -1 : frame;
    p->frames.keep_depth = keep_depth;
    p->whole_scene = whole_scene;
    int rc = rib_run(p);
    if (rc == TS_OK) rc = scene_finalize(scene, err);
    *depth_skipped = p->frames.depth_skipped > 0;
    rib_lex_free(&p->lx);
    rib_archive_free(p);
    rib_program_free(p);
    rib_inline_free(p);
    rib_object_free(p);
    rib_coordsys_free(p);
    rib_user_free(p);
    rib_cond_free(p);
    rib_resource_free(p);
    free(p->rm20_map);
    rib_pattern_free(p);
    rib_bxdf_free(p);
    rib_rlf_free(p);
    rib_trim_free(p);
    free(p->searchpath[0]);
    free(p->searchpath[1]);
    free(p->searchpath[2]);
    rib_args_free(p);
    free(p->stack);
    free(p);
    return rc;
}

/* rib_parse_string, with the frame to read (-1: the first) and whether the text must make a
 * whole scene (rib_load). Read by default, frames that render a depth map are left for the
 * next; if what follows them does not make a scene, the text is read again from its first
 * frame. */
static int rib_parse(const char *name, const char *text, size_t len, int frame, int whole_scene,
                     ts_scene *scene, unsigned flags, ts_error *err)
{
    if (!scene) return ts_error_set(err, TS_E_INTERNAL, "rib_parse_string: no scene");
    rib_text t;
    int rc = rib_text_open(&t, name ? name : "<string>", text, len, err);
    if (rc != TS_OK) {
        scene_free(scene);
        return rc;
    }
    int depth_skipped = 0;
    rc = rib_parse_once(name, &t, frame, 0, whole_scene, scene, flags, err, &depth_skipped);
    if (rc != TS_OK && depth_skipped && rc != TS_E_MEMORY) {
        scene_free(scene);
        ts_error_clear(err);
        rc = rib_parse_once(name, &t, frame, 1, whole_scene, scene, flags, err, &depth_skipped);
    }
    rib_text_free(&t);
    if (rc != TS_OK) scene_free(scene);
    return rc;
}

int rib_parse_string(const char *name, const char *text, size_t len, ts_scene *scene, int quiet,
                     ts_error *err)
{
    return rib_parse(name, text, len, -1, 0, scene, quiet ? RIB_QUIET : 0u, err);
}

/* The parse flags (RIB_QUIET, ...) of lo's quiet, strict and programs. */
static unsigned load_flags(const ts_load_options *lo)
{
    return (lo->quiet ? RIB_QUIET : 0u) | (lo->strict ? RIB_STRICT : 0u) |
           (lo->programs ? RIB_PROGRAMS : 0u);
}

int rib_parse_string_with(const char *name, const char *text, size_t len, const ts_load_options *lo,
                          ts_scene *scene, ts_error *err)
{
    unsigned flags = load_flags(lo);
    return rib_parse(name, text, len, -1, 0, scene, flags, err);
}

int rib_load_with(const char *path, const ts_load_options *lo, ts_scene *scene, ts_error *err)
{
    char *text;
    size_t len;
    char why[256];
    int rc = ts_file_read_all(path, &text, &len, why, sizeof why);
    if (rc != TS_OK) return ts_error_set(err, rc, "%s: %s", path, why);
    unsigned flags = load_flags(lo);
    rc = rib_parse(path, text, len, lo->frame, 1, scene, flags, err);
    free(text);
    return rc;
}

int rib_load(const char *path, ts_scene *scene, int quiet, ts_error *err)
{
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.quiet = quiet;
    return rib_load_with(path, &lo, scene, err);
}
