/* rib_internal.h — the parts of the RIB reader (host/scene/rib/) and what each offers the
 * others; private to them. The headers under it: rib_args.h (the helpers every handler
 * uses), which includes rib_parser.h (the state of one parse: bounds, argument pools,
 * graphics state), and rib_lex.h and basis.h.
 *
 *   rib.c          rib_load, rib_parse_string, the request loop and its dispatch table
 *   rib_state.c    transformations, blocks, Format, Projection, Color, Basis, Displacement,
 *                  motion blocks
 *   rib_geom.c     Patch and PatchMesh into the scene
 *   rib_light.c    LightSource (distant, point, spot, ambient, dome lights)
 *   rib_trim.c     TrimCurve (the trims of the NuPatch requests that follow; scene/trim.c)
 *   rib_quadric.c, rib_poly.c, rib_nurbs.c, rib_subdiv.c, rib_curves.c, rib_primvar.c:
 *                  quadrics, polygons, NuPatch, SubdivisionMesh, Points and Curves and their
 *                  primitive variables (rib_prims.h; they call rib_geom.c's rib_geom_emit,
 *                  which also takes the second sample of a deforming surface)
 *   rib_shading.c  Surface, AreaLightSource, Opacity
 *   rib_options.c  PixelSamples, Clipping, Shutter, CropWindow, ScreenWindow, Exposure
 *   rib_archive.c  ReadArchive, Procedural; reading a whole file
 *   rib_program.c  Procedural "RunProgram": the helper programs, their requests and answers
 *   rib_inline.c   ArchiveBegin/ArchiveEnd (inline archives recorded, ReadArchive runs them)
 *   rib_object.c   ObjectBegin, ObjectEnd, ObjectInstance (definitions recorded, instances
 *                  run them again: copies)
 *   rib_frames.c   FrameBegin/FrameEnd (the frame read, shadow-map passes left), Display,
 *                  the checks on a whole scene
 *   rib_coordsys.c CoordinateSystem, ScopedCoordinateSystem, CoordSysTransform
 *   rib_ris.c      Integrator, Option, Attribute, Camera, DisplayFilter, SampleFilter, Hider
 *                  (RenderMan 21-26), the "user" values
 *   rib_cond.c     IfBegin, ElseIf, Else, IfEnd and their expressions (reads rib_ris.c's
 *                  user values)
 *   rib_resource.c Resource "attributes" save and restore, ResourceBegin, ResourceEnd
 *   rib_pattern.c  Pattern (PxrTexture, PxrManifold2D; PxrMix, PxrToFloat folded at load) and
 *                  the connections to it
 *   rib_rlf.c      "##RLF" nuggets: RenderMan for Maya's look files (read by rib_look.c with
 *                  expat) bound to identifier paths, their payloads run in place
 *   rib_bxdf.c     Bxdf (PxrDiffuse, PxrSurface, PxrDisney, PxrConductor, PxrConstant, Lama...)
 *                  onto Surface's materials; Displace "PxrDisplace"
 *   rib_lama.c     the Lama nodes combining Bxdfs (LamaMix, LamaAdd, LamaLayer, LamaSurface),
 *                  the Bxdfs kept by handle
 *   rib_ris_light.c Light (PxrDomeLight, PxrDistantLight, PxrRectLight, PxrDiskLight,
 *                  PxrSphereLight, PxrCylinderLight, PxrEnvDayLight)
 *   rib_builtin.c  Geometry "teapot" (its patches in teapot_data.c, generated)
 *   rib_args.c     messages, a request's arguments, parameter lists, file names and textures
 *   rib_lex.c      tokens, ASCII and binary
 *   rib_text.c     a file's bytes for the lexer: gzip inflated, a byte order mark skipped
 *   basis.c        change of basis to Bézier
 *
 * Who calls whom (A -> B: A calls functions of B):
 *   rib.c         -> every handler file (the dispatch table; rib_object_record while an
 *                    object is recorded, rib_object_check_file_end at each file's end;
 *                    rib_motion_check and
 *                    rib_check_closed in rib_state.c, rib_archive_free in
 *                    rib_archive.c, rib_program_free in rib_program.c, rib_frames_skip/finish and
 * rib_scene_check in rib_frames.c) rib_frames.c  -> rib_state.c (rib_check_closed at FrameEnd)
 *   rib_builtin.c -> rib_geom.c (rib_geom_bezier)
 *   rib_archive.c -> rib_geom.c also for rib_geom_transparent (procedurals under Opacity 0)
 *   rib_archive.c -> rib.c (rib_run_requests: an archive's requests), rib_geom.c (the
 *                    attributes of procedural geometry), rib_program.c (a RunProgram answer,
 *                    read as an archive), rib_state.c (its attribute block)
 *   rib_object.c  -> rib.c (rib_dispatch_request: an instance's requests), rib_state.c (the
 *                    instance's attribute block), rib_geom.c (where instances may stand)
 *   rib_inline.c  -> rib.c (rib_dispatch_request: an inline archive's requests)
 *   rib_archive.c -> rib_inline.c (ReadArchive of an inline archive's name)
 *   rib_state.c   -> rib_geom.c (MotionEnd of a block of Patch samples)
 *   rib_options.c -> rib_state.c (rib_before_world)
 *   rib_light.c   -> rib_geom.c (rib_geom_check: where lights may stand)
 *   rib_resource.c -> rib_state.c (rib_state_save and rib_state_restore)
 *   rib_bxdf.c    -> rib_pattern.c (connections), rib_shading.c (rib_shading_limits),
 *                    rib_lama.c (the Lama nodes, rib_bxdf_keep); rib_lama.c -> rib_bxdf.c
 *                    (the default material, sheets, cutouts), rib_pattern.c, rib_shading.c
 *   rib_ris_light.c -> rib_geom.c (emissive patches), rib_light.c (rib_light_dome_map)
 *   rib_shading.c, rib_builtin.c -> rib_ris_light.c (RenderMan 20's AreaLightSource
 *                    "PxrStd...Light" and Geometry "rectlight", "envsphere", ...)
 *   rib_rlf.c     -> rib.c (rib_run_requests: a payload's requests), rib_look.c (the file)
 *   rib_state.c   -> rib_rlf.c (rib_rlf_scope_end), rib_ris.c -> rib_rlf.c (identifier names)
 *   rib_nurbs.c   -> rib_trim.c (rib_trim_current)
 *   rib_geom.c, rib_coordsys.c, rib_pattern.c, rib_trim.c -> no other handler
 *   all of these  -> rib_args.c -> rib_lex.c (and scene.c for textures); rib_args.c calls no
 *                    handler. rib.c and rib_archive.c also start lexers (on rib_text.c's bytes);
 * rib.c, rib_state.c and rib_geom.c use basis.c. The cycles are rib.c -> rib_archive.c -> rib.c:
 * ReadArchive, DelayedReadArchive and RunProgram read the archive's (the answer's) requests
 * through the same loop, nested at most RIB_MAX_INCLUDE deep; rib.c -> rib_rlf.c -> rib.c: a look
 * file's payload runs through the loop (a nugget inside a payload is ignored, so once); and rib.c
 * -> rib_object.c -> rib.c: ObjectInstance dispatches the requests of its object, which may not
 * hold another ObjectInstance (one level).
 */
#ifndef TS_RIB_INTERNAL_H
#define TS_RIB_INTERNAL_H

#include "scene/rib/rib_args.h"
#include "scene/rib/rib_parser.h"
#include "scene/scene.h"

#include <stddef.h>

/* Request handlers (int rib_req_*(rib_parser *p)) read p->args and return TS_OK or an
 * error code with p->err set. */

/* ---- rib.c: the request loop, also run on the text of an archive ---- */

/* Reads and dispatches requests from p->lx until its end of file. */
int rib_run_requests(rib_parser *p);
/* Runs the current request (p->req with its arguments in the pools) as the loop does. */
int rib_dispatch_request(rib_parser *p);

/* ---- rib_state.c: transformations, blocks, camera options, attributes, motion ---- */

int rib_req_identity(rib_parser *p);
int rib_req_translate(rib_parser *p);
int rib_req_rotate(rib_parser *p);
int rib_req_skew(rib_parser *p);
int rib_req_scale(rib_parser *p);
int rib_req_concat_transform(rib_parser *p);
int rib_req_transform(rib_parser *p);
int rib_req_attribute_begin(rib_parser *p);
int rib_req_attribute_end(rib_parser *p);
int rib_req_transform_begin(rib_parser *p);
int rib_req_transform_end(rib_parser *p);
int rib_req_world_begin(rib_parser *p);
int rib_req_world_end(rib_parser *p);
/* The graphics state a block saves (CTM at both times, colour, bases, displacement, surface,
 * emission, opacity) into f, and back from f: the CTM only unless `attributes`. */
void rib_state_save(const rib_parser *p, rib_frame *f);
void rib_state_restore(rib_parser *p, const rib_frame *f, int attributes);
int rib_req_solid_begin(rib_parser *p);
int rib_req_solid_end(rib_parser *p);
/* The innermost open SolidBegin block, or NULL. */
const rib_frame *rib_innermost_solid(const rib_parser *p);
int rib_req_format(rib_parser *p);
int rib_req_projection(rib_parser *p);
int rib_req_color(rib_parser *p);
int rib_req_basis(rib_parser *p);
int rib_req_displacement(rib_parser *p);
int rib_req_motion_begin(rib_parser *p);
int rib_req_motion_end(rib_parser *p);
/* Called for every request inside an open motion block (MotionEnd excepted): fails for
 * requests a motion block may not hold, a third sample, or a kind that differs from the
 * first sample's. */
int rib_motion_check(rib_parser *p);
/* Where Tessera's two time samples stand in the current motion block: the fractions a[0], a[1]
 * of its times [t0, t1] at shutter open and close, clamped into [0, 1]; (0, 1) without a
 * Shutter request (the block spans the exposure). Returns whether they are not (0, 1). */
int rib_motion_shutter(const rib_parser *p, double a[2]);
/* out[i] = (1 - a) x0[i] + a x1[i] for i < n (out may be x0 or x1): a motion block's values at
 * fraction a of the way from its first sample to its second. */
void rib_motion_lerp(const double *x0, const double *x1, double a, size_t n, double *out);
/* At the end of the top-level file (not of an archive, whose blocks may stay open): fails
 * on an open motion block, else on the innermost open Attribute/Transform/World block. */
int rib_check_closed(rib_parser *p);
/* Fails unless the current request comes before WorldBegin (camera and image options). */
int rib_before_world(rib_parser *p);
/* Saves the attributes as AttributeBegin does (an ObjectInstance's block), at the current
 * request's position, and restores them as AttributeEnd does, whatever its arguments. */
int rib_attributes_push(rib_parser *p);
int rib_attributes_pop(rib_parser *p);

/* ---- rib_geom.c: Patch, PatchMesh ---- */

int rib_req_patch(rib_parser *p);
int rib_req_patch_mesh(rib_parser *p);
/* Emits the moving patch of a completed motion block (MotionEnd). */
int rib_geom_motion_patch(rib_parser *p);
/* The attributes in effect (colour, displacement with its world-to-object transform,
 * surface, emission) for patches a procedural adds; fails where geometry may not stand
 * (after WorldEnd, a projective or, for displacement, singular CTM). */
int rib_geom_procedural_attr(rib_parser *p, ts_patch_attr *attr);
/* Fails where geometry may not stand: after WorldEnd, under a projective CTM. */
int rib_geom_check(rib_parser *p);
/* Appends one object-space Bézier patch g (16 points, u fastest) as Patch does: moved by
 * the CTM (both samples when it moves), with the current attributes, object-space corner
 * normals n (NULL: scene_finalize averages them), colour cs (NULL: the current Color) and
 * corner texture coordinates st (NULL: the corners' (u, v)). (line, col): the position
 * values, for messages. */
int rib_geom_emit(rib_parser *p, int line, int col, const double g[16][3], const double n[4][3],
                  const double *cs, const double st[4][2]);
/* Whether the current Opacity is 0 0 0: geometry is then not added (rib_shading.c). */
int rib_geom_transparent(const rib_parser *p);
/* Adds one bicubic Bézier patch given by 16 object-space points (u fastest), whatever the
 * current Basis, with the current transformation and attributes, as Patch does. */
int rib_geom_bezier(rib_parser *p, const double g[16][3]);

/* ---- rib_shading.c: Surface, AreaLightSource, Opacity ---- */

int rib_req_surface(rib_parser *p);
int rib_req_shader_layer(rib_parser *p);
int rib_req_connect_shader_layers(rib_parser *p);
int rib_req_area_light_source(rib_parser *p);
/* Kd, Ks >= 0 and finite (else an error naming `name`); Kd + Ks above 1 scaled down to 1 and
 * roughness clamped into [0.01, 1], each with one warning. */
int rib_shading_limits(rib_parser *p, const char *name, rib_surface *s);
int rib_req_opacity(rib_parser *p);

/* ---- rib_light.c: LightSource ---- */

int rib_req_light_source(rib_parser *p);
/* A dome's "mapname" (or a RIS light's "lightColorMap") `name`, written at (line, col): into
 * d->mapname when the file is there (a RenderMan .tex: its sibling, rib_texture_sibling), else
 * rib_missing_file's warning (a uniform sky) or error. */
int rib_light_dome_map(rib_parser *p, const char *name, int line, int col, ts_dome_light *d);
/* rib_ris_light.c, RenderMan 20's lights: AreaLightSource "PxrStdAreaLight",
 * "PxrStdEnvMapLight" or "PxrStdEnvDayLight" (its parameters from args[first]) and Geometry
 * "rectlight", "disklight", "spherelight", "cylinderlight", "distantlight", "envsphere";
 * -1 when `name` is not one of them. */
int rib_rm20_area_light(rib_parser *p, const char *name, size_t first);
int rib_rm20_geometry_light(rib_parser *p, const char *name);

/* ---- rib_options.c: PixelSamples, Clipping, Shutter, CropWindow, ScreenWindow, Exposure ---- */

int rib_req_pixel_samples(rib_parser *p);
int rib_req_clipping(rib_parser *p);
int rib_req_shutter(rib_parser *p);
int rib_req_crop_window(rib_parser *p);
int rib_req_depth_of_field(rib_parser *p);
/* A thin lens for the camera (DepthOfField, a Projection's fStop, focalLength and
 * focalDistance): fstop at or above 1e30 (RI_INFINITY) is a pinhole; otherwise each must be
 * above 0 and finite, else an error at (line, col) naming `what`. */
int rib_set_lens(rib_parser *p, int line, int col, const char *what, double fstop,
                 double focal_length, double focal_distance);
int rib_req_screen_window(rib_parser *p);
int rib_req_exposure(rib_parser *p);

/* ---- rib_ris.c: Integrator, Option, Attribute, Camera, DisplayFilter, SampleFilter, Hider ---- */

int rib_req_integrator(rib_parser *p);
int rib_req_option(rib_parser *p);
int rib_req_attribute(rib_parser *p);
int rib_req_camera(rib_parser *p);
int rib_req_ris_ignored(rib_parser *p);
/* The value of user variable `name` (Option "user", Attribute "user" of the open blocks,
 * the innermost first): 1 with *str (NULL for a number) and *num, 0 when undefined. */
int rib_user_get(const rib_parser *p, const char *name, const char **str, double *num);
/* At the end of an attribute block (p->depth already popped): drops its "user" attributes. */
void rib_user_scope_end(rib_parser *p);
/* Frees p->user. */
void rib_user_free(rib_parser *p);

/* ---- rib_pattern.c: Pattern, and the connections Bxdf and Displace make to it ---- */

int rib_req_pattern(rib_parser *p);
/* What a parameter of a Bxdf or Displace is connected to. */
typedef struct rib_link {
    int linked;       /* a "reference" parameter: its value names a pattern's output */
    int textured;     /* to a PxrTexture whose image was read: */
    uint32_t tex;     /*   the scene texture (of the kind asked for) */
    double st_map[4]; /*  s' = st_map[0] s + st_map[1], t' = st_map[2] t + st_map[3] */
    int folded;       /* to a maths node (PxrMix, ...) folded to one finite value: */
    int scalar;       /*   1: a float output (in all three channels of value), 0: a colour */
    double value[3];
    int mask_red; /* kind RIB_LINK_MASK: the texture's first channel (resultR), not its alpha */
} rib_link;
/* rib_pattern_link's kind for a cutout mask (presence): a PxrTexture's resultA (its alpha) or
 * resultR, read as a TS_TEX_RGB texture (ts_patch_attr TS_PATCH_CUTOUT). */
#define RIB_LINK_MASK 0x100u
/* Reads parameter prm's connection into *out: not linked (a literal value: the caller reads
 * it); linked to a PxrTexture, whose image is read as kind (TS_TEX_RGB or TS_TEX_MINMAX; a
 * missing file: rib_missing_file's warning ending in `fallback`, or its error when strict);
 * linked to a network of maths nodes folded to one value (folded: the caller uses it as the
 * literal value; a value that is not finite is an error); or linked to something else
 * (undefined, another pattern, a network that does not fold: one warning; the caller keeps
 * the parameter's default). */
int rib_pattern_link(rib_parser *p, const rib_param *prm, uint32_t kind, const char *fallback,
                     rib_link *out);
/* Frees p->bxdfs. */
void rib_bxdf_free(rib_parser *p);
/* Frees p->patterns. */
void rib_pattern_free(rib_parser *p);

/* ---- rib_rlf.c: RenderMan for Maya's look files (.rlf), applied at "##RLF" nuggets ---- */

/* A "##RLF ScopeBegin", "ScopeEnd" or "Inject" nugget (the lexer's RIB_TOK_RLF token t), run
 * where the request loop finds it: an Inject runs the payload the scope's look file binds to
 * the current identifier path through rib_run_requests. */
int rib_rlf_nugget(rib_parser *p, const rib_token *t);
/* Attribute "identifier" "name": the current attribute block's name in identifier paths. */
int rib_rlf_identifier(rib_parser *p, const char *name);
/* At the end of an attribute block (p->depth already popped): drops the names set in it. */
void rib_rlf_scope_end(rib_parser *p);
/* Frees p->rlf. */
void rib_rlf_free(rib_parser *p);

/* ---- rib_trim.c: TrimCurve ---- */

int rib_req_trim_curve(rib_parser *p);
/* The trim of the NuPatch requests that follow, NULL for none. */
const struct trim_set *rib_trim_current(const rib_parser *p);
/* Frees p->trims. */
void rib_trim_free(rib_parser *p);

/* ---- rib_bxdf.c: Bxdf, Displace (RIS materials onto Surface's, textured displacement) ---- */

int rib_req_bxdf(rib_parser *p);
int rib_req_displace(rib_parser *p);
/* PxrDiffuse's default material into *s. */
void rib_bxdf_default(rib_parser *p, rib_surface *s);
/* The hemispherical average of Schlick's Fresnel from face colour f0 to edge colour f90. */
double rib_schlick_mean(double f0, double f90);
/* Whether a Bxdf parameter is silent at any value (AOV names, bookkeeping). */
int rib_bxdf_silent(const char *name);
/* A thin sheet reflecting albedo refl and transmitting trans as one material into *s
 * (TS_MAT_TRANSLUCENT; matte without transmission); `what` names the request in warnings. */
void rib_bxdf_sheet(rib_parser *p, const char *what, const double refl[3], const double trans[3],
                    rib_surface *s);
/* presence from a texture (`mask`, a RIB_LINK_MASK link) on material *s: a cutout, or one
 * warning when it cannot be drawn (another texture than the colour's, an emitter). */
void rib_bxdf_cutout(rib_parser *p, const char *bxdf, const rib_link *mask, rib_surface *s);

/* ---- rib_lama.c: the Lama nodes that combine Bxdfs, the Bxdfs kept by handle ---- */

/* Bxdf request `name`, its parameters from args[first], when it is a Lama node that combines
 * Bxdfs (LamaMix, LamaAdd, LamaLayer, LamaSurface; *is_lama 1): the material it makes of the
 * Bxdfs it names becomes the current surface, kept under its handle. *is_lama 0 (and TS_OK)
 * for any other name. */
int rib_lama_node(rib_parser *p, const char *name, size_t first, int *is_lama);
/* Keeps material *s under the request's handle (args[1], when first is 2), for the Lama
 * nodes; an error past 65536 handles. */
int rib_bxdf_keep(rib_parser *p, size_t first, const rib_surface *s);

/* ---- rib_ris_light.c: Light (RIS lights onto LightSource's, emissive geometry) ---- */

int rib_req_light(rib_parser *p);
/* The colour of a black body at `kelvin` (clamped to [1000, 40000]) in linear Rec. 709 RGB
 * with luminance 1. */
void rib_blackbody(double kelvin, double rgb[3]);

/* ---- rib_cond.c: IfBegin, ElseIf, Else, IfEnd ---- */

int rib_req_if_begin(rib_parser *p);
int rib_req_else_if(rib_parser *p);
int rib_req_else(rib_parser *p);
int rib_req_if_end(rib_parser *p);
/* Whether the current request lies in a branch not taken: it is then not dispatched
 * (IfBegin ... IfEnd are, to keep count of nesting). */
int rib_cond_skip(const rib_parser *p);
/* At the end of the top-level file: fails on an IfBegin without IfEnd. */
int rib_cond_check_closed(rib_parser *p);
/* Frees p->cond. */
void rib_cond_free(rib_parser *p);

/* ---- rib_builtin.c and teapot_data.c: Geometry "teapot" ---- */

int rib_req_geometry(rib_parser *p);
#define RIB_TEAPOT_VERTICES 306
#define RIB_TEAPOT_PATCHES 32
extern const double rib_teapot_vertices[RIB_TEAPOT_VERTICES][3];
extern const unsigned short rib_teapot_patches[RIB_TEAPOT_PATCHES][16];

/* ---- rib_resource.c: Resource, ResourceBegin, ResourceEnd ---- */

int rib_req_resource(rib_parser *p);
int rib_req_resource_begin(rib_parser *p);
int rib_req_resource_end(rib_parser *p);
void rib_resource_free(rib_parser *p);

/* ---- rib_coordsys.c: CoordinateSystem, CoordSysTransform ---- */

int rib_req_coordinate_system(rib_parser *p);
int rib_req_coord_sys_transform(rib_parser *p);
int rib_req_scoped_coordinate_system(rib_parser *p);
/* Marks the current transformation as the system `name`; scoped: only until the current
 * attribute block ends (ScopedCoordinateSystem; shadows an unscoped one meanwhile). */
int rib_coordsys_mark(rib_parser *p, const char *name, int scoped);
/* At the end of an attribute block (p->depth already popped): drops the scoped systems
 * marked inside it. */
void rib_coordsys_scope_end(rib_parser *p);
/* Frees p->coordsys. */
void rib_coordsys_free(rib_parser *p);

/* ---- rib_frames.c: FrameBegin/FrameEnd, the checks on a whole scene ---- */

int rib_req_frame_begin(rib_parser *p);
int rib_req_frame_end(rib_parser *p);
/* Display: ignored with a warning, except that a frame read by default whose image is a
 * depth map (a shadow-map pass) is left for the next frame. */
int rib_req_display(rib_parser *p);
/* Whether the current request lies in a frame that is not read (or after the one read):
 * it is then not dispatched. FrameBegin and FrameEnd are always dispatched. */
int rib_frames_skip(const rib_parser *p);
/* At the end of the top-level file: fails on an open FrameBegin, or when the frame asked
 * for (p->frames.wanted) is not in the file, listing those that are. */
int rib_frames_finish(rib_parser *p);
/* At the end of a file read as a whole scene (rib_load): fails when there is no geometry
 * (naming a missing world block); warns when nothing gives light. */
int rib_scene_check(rib_parser *p);

/* ---- rib_archive.c: ReadArchive, Procedural ---- */

int rib_req_read_archive(rib_parser *p);
int rib_req_procedural(rib_parser *p);
int rib_req_procedural2(rib_parser *p);
/* Option "searchpath" "archive" [paths] "texture" [paths]. */
int rib_searchpath_option(rib_parser *p);
/* Frees p->inc. */
void rib_archive_free(rib_parser *p);

/* ---- rib_inline.c: ArchiveBegin ... ArchiveEnd, read by ReadArchive ---- */

int rib_req_archive_begin(rib_parser *p);
int rib_req_archive_end(rib_parser *p); /* outside a recording: an error */
/* Whether an inline archive is being recorded: rib.c then hands it every request (known ones
 * only) to rib_inline_record instead of running it. */
int rib_inline_recording(const rib_parser *p);
int rib_inline_record(rib_parser *p);
/* At the end of each file: fails if an ArchiveBegin of this file is still open. */
int rib_inline_check_file_end(rib_parser *p);
/* ReadArchive "name": runs the inline archive of that name in place when there is one
 * (*found 1), else leaves it to the file of that name (*found 0). */
int rib_inline_read(rib_parser *p, const char *name, int *found);
/* Frees p->inlines. */
void rib_inline_free(rib_parser *p);
/* RIB_MAX_INSTANCED_PATCHES, or less when $TESSERA_MAX_INSTANCED_PATCHES says so (tests and
 * the fuzzer: the bound without gigabytes of copies; it never raises it): the patches that
 * ObjectInstance copies may add, and those inline archives read again may (rib_object.c). */
uint64_t rib_copies_budget(void);
/* The value of environment variable `name` when it is a whole number below max, else max (the
 * testing aids that lower a bound: tests and the fuzzer). */
uint64_t rib_env_bound(const char *name, uint64_t max);

/* ---- rib_program.c: Procedural "RunProgram" helpers ---- */

/* Asks the helper program `command` (started on first use) for the RIB of request `data`
 * over the object-space bound [6] (argument `at` of the current request): TS_OK with *text
 * (malloc'd, *len bytes, NUL-ended, without the \377) and *name (malloc'd, "command[k]" for
 * its k-th answer) to read in place; or TS_OK with *text NULL when it was not run (programs
 * off, or a program that cannot be started and is not strict: a warning each). */
int rib_program_run(rib_parser *p, const char *command, const char *data, const double *bound,
                    const rib_arg *at, char **text, size_t *len, char **name);
/* Closes every helper's input and reaps it (killed when it has not exited within a second). */
void rib_program_free(rib_parser *p);

/* ---- rib_object.c: ObjectBegin, ObjectEnd, ObjectInstance ---- */

int rib_req_object_begin(rib_parser *p);
int rib_req_object_end(rib_parser *p);
int rib_req_object_instance(rib_parser *p);
/* Whether an object's definition is being recorded: rib.c then hands every request (known
 * ones only) to rib_object_record instead of running it. */
int rib_object_recording(const rib_parser *p);
/* Records the current request in the definition, or ends it at ObjectEnd; fails on
 * requests a definition may not hold. */
int rib_object_record(rib_parser *p);
/* At the end of each file (p->lx still reading it): fails when an object begun in it is
 * still open. */
int rib_object_check_file_end(rib_parser *p);
/* Frees p->objects. */
void rib_object_free(rib_parser *p);

#endif
