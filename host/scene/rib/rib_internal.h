/* rib_internal.h — the parts of the RIB reader (host/scene/rib/) and what each offers the
 * others; private to them.
 *   rib_lex.c      tokens (rib_lex.h)
 *   rib_parser.h   the state of one parse: bounds, argument pools, graphics state
 *   rib_args.c     messages, a request's arguments, parameter lists, file names (rib_args.h)
 *   rib.c          rib_load, rib_parse_string, the request loop and its dispatch table
 *   rib_state.c    transformations, blocks, Format, Projection, Color, Basis, Displacement,
 *                  motion blocks
 *   rib_geom.c     Patch, PatchMesh and LightSource "distantlight" into the scene
 *   rib_shading.c  Surface, AreaLightSource, LightSource "domelight"
 *   rib_options.c  PixelSamples, Clipping, Shutter, CropWindow
 *   rib_archive.c  ReadArchive, Procedural
 *   basis.c        change of basis to Bézier (basis.h)
 * rib.c and every handler file call rib_args.c, which calls only rib_lex.c and the scene.
 */
#ifndef TS_RIB_INTERNAL_H
#define TS_RIB_INTERNAL_H

#include "scene/rib/rib_args.h"
#include "scene/rib/rib_parser.h"
#include "scene/scene.h"

#include <stddef.h>
#include <stdint.h>

/* ---- rib_state.c: motion blocks, open blocks, the world phase ---- */

/* Called for every request inside an open motion block (MotionEnd excepted): fails for
 * requests a motion block may not hold, a third sample, or a kind that differs from the
 * first sample's. */
int rib_motion_check(rib_parser *p);
/* At the end of the top-level file (not of an archive, whose blocks may stay open): fails
 * on an open motion block, else on the innermost open Attribute/Transform/World block. */
int rib_check_closed(rib_parser *p);
/* Fails unless the current request comes before WorldBegin (camera and image options). */
int rib_before_world(rib_parser *p);

/* ---- request handlers: all read p->args, return TS_OK or an error code ---- */

int rib_req_identity(rib_parser *p);
int rib_req_translate(rib_parser *p);
int rib_req_rotate(rib_parser *p);
int rib_req_scale(rib_parser *p);
int rib_req_concat_transform(rib_parser *p);
int rib_req_transform(rib_parser *p);
int rib_req_attribute_begin(rib_parser *p);
int rib_req_attribute_end(rib_parser *p);
int rib_req_transform_begin(rib_parser *p);
int rib_req_transform_end(rib_parser *p);
int rib_req_world_begin(rib_parser *p);
int rib_req_world_end(rib_parser *p);
int rib_req_format(rib_parser *p);
int rib_req_projection(rib_parser *p);
int rib_req_color(rib_parser *p);
int rib_req_basis(rib_parser *p);
int rib_req_displacement(rib_parser *p);
int rib_req_motion_begin(rib_parser *p);
int rib_req_motion_end(rib_parser *p);
int rib_req_patch(rib_parser *p);
int rib_req_patch_mesh(rib_parser *p);
int rib_req_light_source(rib_parser *p);

/* ---- rib_shading.c: Surface, AreaLightSource, LightSource "domelight" ---- */

int rib_req_surface(rib_parser *p);
int rib_req_area_light_source(rib_parser *p);
/* LightSource "domelight": params from index `first`. */
int rib_dome_light(rib_parser *p, size_t first);
/* rib_geom.c: emits the moving patch of a completed motion block (MotionEnd). */
int rib_geom_motion_patch(rib_parser *p);
/* rib_geom.c: the attributes in effect (colour, displacement with its world-to-object
 * transform, surface, emission) for patches a procedural adds; fails where geometry may
 * not stand (after WorldEnd, a projective or, for displacement, singular CTM). */
int rib_geom_procedural_attr(rib_parser *p, ts_patch_attr *attr);

/* ---- rib.c: the request loop, also run on the text of an archive ---- */

/* Reads and dispatches requests from p->lx until its end of file. */
int rib_run_requests(rib_parser *p);

/* ---- rib_options.c: PixelSamples, Clipping, Shutter, CropWindow ---- */

int rib_req_pixel_samples(rib_parser *p);
int rib_req_clipping(rib_parser *p);
int rib_req_shutter(rib_parser *p);
int rib_req_crop_window(rib_parser *p);

/* ---- rib_archive.c: ReadArchive, Procedural ---- */

int rib_req_read_archive(rib_parser *p);
int rib_req_procedural(rib_parser *p);
/* Frees p->inc. */
void rib_archive_free(rib_parser *p);
/* Reads a whole file into a malloc'd buffer; TS_E_IO or TS_E_MEMORY with *errnum set. */
int rib_read_file(const char *path, char **text, size_t *len, int *errnum);

#endif
