/* quadric.h — the RenderMan quadrics (RI Spec 3.2 §5.4: Sphere, Cone, Cylinder, Hyperboloid,
 * Paraboloid, Disk, Torus) as bicubic Bézier patches in object space.
 *
 * Every quadric is a surface of revolution about z: a profile curve Q(v) swept by the angle
 * theta = u * thetamax, P(u, v) = R_z(theta) Q(v) (RI Spec parametrisations, angles in
 * degrees). The sweep is split into pieces of at most 90 degrees, each the standard cubic
 * circle arc (inner points along the tangents at k = 4/3 tan(delta / 4)), whose radius lies
 * in [1, 1 + 2.73e-4] of the true one. The profile is a line (cylinder, cone, disk,
 * hyperboloid: exact), a parabola (paraboloid: an exact quadratic, degree-elevated) or a
 * circle arc (sphere, torus: split into pieces of at most 90 degrees, the same cubic arc).
 * Each patch is the tensor product of one sweep piece and one profile piece, so it is
 * bicubic and the control points' convex hull holds it. Distance from the analytic surface:
 *   cylinder, cone, disk, hyperboloid, paraboloid: at most 2.73e-4 * rho_max (the largest
 *     distance of the surface from the z axis);
 *   sphere: at most 5.5e-4 * |radius|;  torus: at most 2.73e-4 * (|major| + 2 |minor|).
 * Patch corners lie exactly on the surface. Patches share their common edges bit for bit
 * (angles that are multiples of 90 degrees use exact sines and cosines), so a closed
 * quadric is watertight.
 *
 * Orientation: the corner normals are dP/du x dP/dv of the analytic parametrisation (RI Spec
 * §5: the geometric normal), normalised: they point outward for the default arguments
 * (away from the axis, the disk towards +z) and flip with a negative thetamax or radius as
 * the parametrisation does. Where dP/du vanishes on the z axis (poles, apices, the disk's
 * centre) the normal is the axis direction on the side the surface next to it faces, the
 * same for every patch meeting there.
 */
#ifndef TS_QUADRIC_H
#define TS_QUADRIC_H

#include <stddef.h>

typedef enum ts_quadric_kind {
    QUADRIC_SPHERE,      /* radius zmin zmax thetamax */
    QUADRIC_CONE,        /* height radius thetamax */
    QUADRIC_CYLINDER,    /* radius zmin zmax thetamax */
    QUADRIC_HYPERBOLOID, /* x1 y1 z1 x2 y2 z2 thetamax */
    QUADRIC_PARABOLOID,  /* rmax zmin zmax thetamax */
    QUADRIC_DISK,        /* height radius thetamax */
    QUADRIC_TORUS,       /* majorradius minorradius phimin phimax thetamax */
    QUADRIC_KINDS
} ts_quadric_kind;

/* A quadric as the RI Spec gives it: arg[] holds the request's numbers in order (lengths,
 * angles in degrees), thetamax always last. */
typedef struct ts_quadric {
    ts_quadric_kind kind;
    double arg[7];
    /* 0: the sweep and a circle profile in as few pieces of at most 90 degrees as they need;
     * 1: always in 4 equal pieces each, so that the patches' number does not depend on the
     * angles (the two samples of a quadric in a motion block must make the same patches). */
    int fixed_pieces;
} ts_quadric;

/* The request name and its number of arguments (4, 3, 4, 7, 4, 3, 5). */
const char *quadric_name(ts_quadric_kind kind);
int quadric_arg_count(ts_quadric_kind kind);

/* Receives one patch: 16 object-space Bézier points (u fastest), the four unit corner
 * normals and the RenderMan (u, v) of the corners, both in the corner order (0,0), (1,0),
 * (0,1), (1,1). A non-zero return stops quadric_patches, which returns it. */
typedef int (*quadric_patch_fn)(void *ctx, const double cp[16][3], const double n[4][3],
                                const double uv[4][2]);

/* Emits the quadric's patches through fn, sweep pieces outer, profile pieces inner (at most
 * 4 x 4 patches). thetamax (and a torus' phimax - phimin) is clamped to [-360, 360]. A
 * quadric of zero area (a zero radius or height range, thetamax 0) emits nothing and sets
 * *count to 0. Returns TS_OK, fn's code, or TS_E_SCENE with `why` set for arguments that
 * define no surface (a Paraboloid whose zmin lies on the other side of 0 from zmax). */
int quadric_patches(const ts_quadric *q, quadric_patch_fn fn, void *ctx, int *count, char *why,
                    size_t why_len);

#endif
