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

/* scene_load of one frame of a RIB animation (rib_load_frame: FrameBegin `frame`, or the
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
