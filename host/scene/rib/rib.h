/* rib.h — loads a RenderMan RIB file (the subset in docs/rib.md) into a ts_scene.
 *
 * Conventions are RenderMan's (RI Spec 3.2 §4): camera space is left-handed, x right, y up,
 * looking down +z; each new transform applies to points before the current one
 * (CTM = CTM · T with column vectors); at WorldBegin the CTM becomes world_to_camera and
 * is reset to the identity. Patches are converted to Bézier and moved to world space as
 * they are read.
 */
#ifndef TS_RIB_H
#define TS_RIB_H

#include "base/error.h"
#include "scene/scene.h"
#include "scene/scene_load.h" /* scene_load: a RIB file or a mesh, by the file name */

#include <stddef.h>

/* Reads and parses the RIB file at path. `scene` must be zero-initialised (or freed);
 * on success it holds the patches, lights and camera; on failure it is left empty and
 * err says why: TS_E_IO ("path: No such file or directory"), TS_E_SCENE
 * ("file:line:col: error: ...") or TS_E_MEMORY. Warnings for ignored requests go to
 * stderr, one per request name, unless quiet. */
int rib_load(const char *path, ts_scene *scene, int quiet, ts_error *err);

/* rib_load with everything in lo: one frame of an animation (lo->frame: the FrameBegin
 * block numbered so, the others skipped, or the first one below 0; TS_E_SCENE naming the
 * frames the file has when it has no such frame), quiet and strict (scene_load.h
 * ts_load_options; lo->up is for meshes and not used here). As a whole scene, the file (or
 * frame) must hold a world block with geometry: an error otherwise; a scene with nothing that
 * gives light gets a warning. Not strict, a texture, environment map, archive or mesh
 * file that cannot be read gives one warning and a fallback (docs/rib.md "Missing files"):
 * an archive or mesh is skipped, a colour texture leaves Cs alone, a displacement texture
 * turns displacement off, an environment map leaves the dome its uniform colour. Strict,
 * each is an error at the file name's line and column. rib_load is not strict. */
int rib_load_with(const char *path, const ts_load_options *lo, ts_scene *scene, ts_error *err);

/* rib_parse_string with lo's quiet and strict (rib_load_with); lo->frame and lo->up are not
 * used. */
int rib_parse_string_with(const char *name, const char *text, size_t len, const ts_load_options *lo,
                          ts_scene *scene, ts_error *err);

/* Parses len bytes of RIB text (no NUL terminator needed); `name` is used in messages.
 * Safe on arbitrary bytes: never reads outside [text, text + len), bounds nesting depth,
 * token and array sizes, and frees everything on failure. Same contract as rib_load, except
 * that the text need not make a whole scene (no world block or geometry is no error). */
int rib_parse_string(const char *name, const char *text, size_t len, ts_scene *scene, int quiet,
                     ts_error *err);

#endif
