/* scene_load.h — loads a scene file by its kind: RenderMan RIB (docs/rib.md) or any mesh
 * format Assimp reads (host/scene/mesh.h), which is framed by an automatic camera and lit by a
 * default light. */
#ifndef TS_SCENE_LOAD_H
#define TS_SCENE_LOAD_H

#include "base/error.h"
#include "scene/scene.h"

/* Loads path into the zeroed scene s. A name ending in ".rib" or ".rib.gz" (any case) is
 * read with rib_load; anything else is a mesh (mesh_load_ex, identity transform, a light grey
 * colour, no displacement), then framed: the camera looks at the centre of the bounding
 * sphere of the patches' control points from a three-quarter view above (for a y-up model
 * from the +z side turned 35 degrees towards +x and raised 25 degrees, turned with the model
 * for another up axis; right-handed like the mesh formats, so the model is not mirrored),
 * far enough that the sphere fills the shorter image axis at fov 30; Format 960x540; one
 * distant light from the upper left of the view (intensity 2.5) and a dim dome light
 * (0.35). Same errors as rib_load / mesh_load; s is left empty on failure. */
int scene_load(const char *path, ts_scene *s, int quiet, ts_error *err);

/* How scene_load_with reads a scene; zero-initialise, then scene_load_options_defaults. */
typedef struct ts_load_options {
    int frame;    /* the RIB animation's FrameBegin number to read; -1: the first */
    int quiet;    /* 1: no warnings on stderr */
    int strict;   /* 1: a texture, environment map, archive or mesh file that cannot be read is
                     an error at its file:line:column; 0 (RenderMan's way): one warning each and
                     a fallback (docs/rib.md "Missing files") */
    int up;       /* a mesh's up axis (--up): 0 from the file (mesh_load_ex), else TS_UP_* */
    int programs; /* 1 (RenderMan's way): Procedural "RunProgram" runs its program; 0
                     (--no-programs): such a request is skipped with a warning */
} ts_load_options;

/* --up: which object axis of a mesh points up. */
enum { TS_UP_X = 1, TS_UP_Y = 2, TS_UP_Z = 3 }; /* negated for -x, -y, -z */

/* Defaults: the first frame, warnings on, not strict, the up axis from the file, programs run. */
void scene_load_options_defaults(ts_load_options *o);

/* Parses --up's value "x", "y", "z", "-x", "-y" or "-z" ("+x" ... too) into *up (TS_UP_X ...,
 * negated for a minus); returns 0, or -1 for anything else. */
int scene_parse_up(const char *s, int *up);

/* scene_load with everything in lo: a RIB file as rib_load_with reads it, a mesh with its up
 * axis from lo->up when that is not 0 (the automatic camera then stands on it). */
int scene_load_with(const char *path, const ts_load_options *lo, ts_scene *s, ts_error *err);

/* scene_load of one frame of a RIB animation (rib_load_with: FrameBegin `frame`, or the
 * first for frame < 0); a mesh has no frames (TS_E_USAGE for frame >= 0). */
int scene_load_frame(const char *path, int frame, ts_scene *s, int quiet, ts_error *err);

/* The automatic camera and light described above, for the patches already in s (used by
 * scene_load for meshes). Does nothing to an empty scene. */
void scene_frame_auto(ts_scene *s);
/* The same for a model whose up axis is up_axis (+x, +y, +z or their opposites, as
 * mesh_load_ex reports it): the view turns with the model, so a z-up model (STL, Blender,
 * an FBX that says so) stands the right way up. scene_frame_auto is the y-up case. */
void scene_frame_auto_up(ts_scene *s, const double up_axis[3]);

#endif
