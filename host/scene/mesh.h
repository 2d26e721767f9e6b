/* mesh.h — polygon meshes (anything Assimp reads: OBJ, PLY, glTF, STL, ...) as curved
 * bicubic Bézier patches built from their vertex normals (PN patches, Vlachos et al. 2001).
 *
 * Each quad becomes one bicubic patch, each triangle one bicubic patch with a collapsed
 * edge, larger polygons are split into triangles (ear clipping). The patches interpolate
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
 * it (FBX), else by the format's convention: +z for STL, 3DS, Blender, 3MF, AMF, DXF and
 * IFC files, +y for the others. up may be NULL. */
int mesh_load_ex(const char *path, const double object_to_world[16], const ts_patch_attr *attr,
                 ts_scene *s, double up[3], ts_error *err);

/* The PN patch of a quad: p and n are its four vertices and unit normals in polygon order
 * (v0, v1, v2, v3), which become the corners (u, v) = (0,0), (1,0), (1,1), (0,1).
 * Boundary control points by the PN edge rule b_ij = (2 P_i + P_j - w_ij N_i) / 3 with
 * w_ij = (P_j - P_i) . N_i; interior points from the bilinearly blended Coons patch of the
 * four boundary curves. cp: 16 points, u fastest. */
void mesh_pn_quad(const double p[4][3], const double n[4][3], double cp[16][3]);

/* The PN triangle of Vlachos et al. (vertices p, unit normals n, edge points as above,
 * centre point E + (E - V) / 2) written exactly as a bicubic patch with its v = 1 edge
 * collapsed: corners (0,0) = p[0], (1,0) = p[1], (0,1) = (1,1) = p[2]. */
void mesh_pn_triangle(const double p[3][3], const double n[3][3], double cp[16][3]);

#endif
