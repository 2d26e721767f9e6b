/* mesh.h — polygon meshes (anything Assimp reads: OBJ, PLY, glTF, STL, ...) as curved
 * bicubic Bézier patches built from their vertex normals (PN patches, Vlachos et al. 2001).
 *
 * Each quad becomes one bicubic patch, each triangle one bicubic patch with a collapsed
 * edge, larger polygons are split into triangles (ear clipping): scene/polygon.c, shared
 * with the RIB polygon requests. The patches interpolate
 * the mesh vertices, their tangent planes there are perpendicular to the vertex normals,
 * and a patch edge depends only on its two end vertices and their normals, so patches that
 * share an edge meet without a gap. The vertex normals are also the corner displacement
 * normals (scene.h), so neighbouring patches displace a shared corner identically.
 * docs/rib.md ("Meshes") has the construction.
 */
#ifndef TS_MESH_H
#define TS_MESH_H

#include "base/error.h"
#include "scene/scene.h"

/* Reads the mesh file at path with Assimp (node transforms baked in, identical vertices
 * joined) and appends one patch per triangle or quad to s (flat faces for a mesh without
 * normals, so its hard edges stay hard: a cube stays a cube), moved by object_to_world (row-major,
 * column vectors, affine; normals by its inverse transpose). attr gives colour and displacement
 * (its xform must already be in s); a mesh with vertex colours gives each patch the average of its
 * corner colours instead. Faces with fewer than three vertices (points, lines) and faces of zero
 * area are skipped. Errors: TS_E_IO (cannot read the file), TS_E_SCENE ("path: ..." when
 * Assimp cannot parse it or it holds no polygons), TS_E_MEMORY. Does not call
 * scene_finalize. */
int mesh_load(const char *path, const double object_to_world[16], const ts_patch_attr *attr,
              ts_scene *s, ts_error *err);

/* mesh_load that also says which way is up in the file (object space): up[] gets +x, +y,
 * +z or their opposites, from Assimp's "UpAxis"/"UpAxisSign" metadata where the format has
 * it (FBX), else by the format's convention: +z for STL, 3DS, Blender, 3MF, AMF, DXF, IFC,
 * trueSpace (COB, SCN), SMD and Quick3D (Q3O, Q3S) files, +y for the others (Assimp turns a
 * Collada file's <up_axis> into y up itself). up may be NULL. */
int mesh_load_ex(const char *path, const double object_to_world[16], const ts_patch_attr *attr,
                 ts_scene *s, double up[3], ts_error *err);

#endif
