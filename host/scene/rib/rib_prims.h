/* rib_prims.h — the RIB requests that turn other surfaces into Bézier patches, and what they
 * share; private to host/scene/rib/ (rib_internal.h has the map of the reader):
 *
 *   rib_quadric.c  Sphere, Cone, Cylinder, Hyperboloid, Paraboloid, Disk, Torus
 *                  (geometry: scene/quadric.c)
 *   rib_poly.c     Polygon, GeneralPolygon, PointsPolygons, PointsGeneralPolygons
 *                  (geometry: scene/polygon.c, the PN patches meshes use)
 *   rib_nurbs.c    NuPatch (geometry: scene/nurbs.c)
 *   rib_subdiv.c   SubdivisionMesh (geometry: scene/subdiv.c)
 *   rib_curves.c   Points (spheres: scene/quadric.c), Curves (ribbons facing the camera)
 *   rib_blobby.c   Blobby (geometry: scene/blobby.c, then scene/polygon.c's PN triangles)
 *   rib_primvar.c  primitive variables by storage class (RI Spec 3.2 §5.1) and integer
 *                  arrays, for all of them
 *
 * Each request reads its arguments, builds object-space patches with the geometry module
 * and hands each to rib_geom_emit (rib_geom.c), which moves it by the CTM and gives it the
 * current attributes, exactly as a Patch.
 */
#ifndef TS_RIB_PRIMS_H
#define TS_RIB_PRIMS_H

#include "scene/rib/rib_parser.h"

#include <stddef.h>

/* ---- the requests ---- */

int rib_req_sphere(rib_parser *p);
int rib_req_cone(rib_parser *p);
int rib_req_cylinder(rib_parser *p);
int rib_req_hyperboloid(rib_parser *p);
int rib_req_paraboloid(rib_parser *p);
int rib_req_disk(rib_parser *p);
int rib_req_torus(rib_parser *p);
int rib_req_polygon(rib_parser *p);
int rib_req_general_polygon(rib_parser *p);
int rib_req_points_polygons(rib_parser *p);
int rib_req_points_general_polygons(rib_parser *p);
int rib_req_nu_patch(rib_parser *p);
int rib_req_subdivision_mesh(rib_parser *p);
int rib_req_hierarchical_subdivision_mesh(rib_parser *p);
int rib_req_points(rib_parser *p);
int rib_req_curves(rib_parser *p);
int rib_req_blobby(rib_parser *p);

/* ---- rib_primvar.c: primitive variables ---- */

/* Storage classes (RI Spec §5.1); "facevertex" reads as facevarying. */
typedef enum rib_class {
    RIB_CONSTANT,
    RIB_UNIFORM,
    RIB_VARYING,
    RIB_VERTEX,
    RIB_FACEVARYING,
    RIB_CLASSES
} rib_class;

/* One primitive variable: `count` values of `dim` numbers each, of class cls. */
typedef struct rib_pvar {
    const double *v; /* NULL: not given */
    rib_class cls;
    int dim;
    size_t count;
    int line, col; /* of the values */
} rib_pvar;

/* The variables the new primitives read: "P" (3 per vertex), "Pw" (4 per vertex, homogeneous
 * x w, y w, z w, w), "N" (3), "Cs" (3), "st" (2). */
typedef struct rib_pvars {
    rib_pvar P, Pw, N, Cs, st;
    rib_pvar s, t; /* "s" and "t" as written; joined into st (rib_pvars_read) */
} rib_pvars;

/* Which variables a request reads (bits); the others are ignored with a warning. */
#define RIB_PV_P 1u
#define RIB_PV_PW 2u
#define RIB_PV_N 4u
#define RIB_PV_CS 8u
#define RIB_PV_ST 16u
/* With this bit, variables other than "P" and "Pw" may not be of class vertex. */
#define RIB_PV_NO_VERTEX 32u
/* With this bit, "N" may hold zero normals (one warning): polygons give such vertices the
 * polygon's own normal, as meshes do. */
#define RIB_PV_ZERO_N 64u

/* Reads the parameter list from args[first]: each variable must have, for its class (by an
 * inline declaration, varying when none; "P" and "Pw" are always vertex), exactly
 * counts[class] values; a class whose count is 0 is an error naming the classes allowed.
 * "N" must hold no zero normal, every value must be a finite float. Unknown parameters,
 * and those not in `accept`, are ignored with a warning. Position ("P", or "Pw" where
 * accepted) is required when `accept` has it. */
int rib_pvars_read(rib_parser *p, size_t first, const size_t counts[RIB_CLASSES], unsigned accept,
                   rib_pvars *out);

/* The class named in an inline declaration ("uniform color Cs"), else `dflt`. */
rib_class rib_class_of(const char *decl, rib_class dflt);

/* The number of values of parameter `name` in the list from args[first] (0 when absent),
 * for requests whose vertex count follows from "P" (Polygon). */
size_t rib_pvars_count(rib_parser *p, size_t first, const char *name, size_t dim);

/* The value of v for a face-vertex of a polygon mesh: face `face` (uniform), mesh vertex
 * `vertex` (varying, vertex) and face-vertex number `fv` (facevarying). */
const double *rib_pvar_at(const rib_pvar *v, size_t face, size_t vertex, size_t fv);

/* The integers of numeric argument args[i] (bare or an array), each in [lo, hi]; `what`
 * names it in messages. *vals points into the argument pool (valid until the next
 * request). */
int rib_int_array(rib_parser *p, size_t i, const char *what, double lo, double hi,
                  const double **vals, size_t *count);

#endif
