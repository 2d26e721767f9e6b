/* mat4.h — 4x4 matrices of doubles, row-major, acting on column vectors: x' = M x, so
 * m[r * 4 + c] is row r, column c and the translation is m[3], m[7], m[11]. Used by the
 * RIB reader's current transformation (RI Spec §4.3) and the camera. */
#ifndef TS_MAT4_H
#define TS_MAT4_H

void mat4_identity(double m[16]);
/* ctm = ctm · t: t acts on points first (RI Spec §4.3). */
void mat4_concat(double ctm[16], const double t[16]);
/* Rotation by deg degrees about the axis (x, y, z) (RiRotate); 0 for a zero-length axis. */
int mat4_rotate(double deg, double x, double y, double z, double m[16]);
/* RiSkew (RI Spec 3.2 §4.3): the shear that moves points along d2 in proportion to their
 * distance from d2 in the plane of d1 and d2, so that d1 turns by deg degrees towards d2 (d1
 * itself goes to a vector at deg from it): m = I + k d2^ n^T, n^ the unit part of d1^ normal
 * to d2^, k = cot(phi - deg) - cot(phi), phi the angle from d1 to d2. 0 when an axis is zero
 * or the two are parallel, or deg is not in (phi - 180, phi) (the spec's error). */
int mat4_skew(double deg, const double d1[3], const double d2[3], double m[16]);
/* Gauss-Jordan inverse with partial pivoting; 0 when m is singular or not finite. */
int mat4_invert(const double m[16], double inv[16]);
/* Bottom row (0 0 0 w), w != 0: the maps under which Bézier patches stay polynomial. */
int mat4_is_affine(const double m[16]);
/* Maps a point by an affine m; 0 when the result is not a finite float. */
int mat4_point(const double m[16], const double p[3], double out[3]);
/* Maps a normal by the inverse transpose of the linear part of the affine map whose
 * inverse is inv (n' = (L^-1)^T n, inv normalised to w = 1); not renormalised. */
void mat4_normal(const double inv[16], const double n[3], double out[3]);
/* Maps a direction by the linear part of m (no translation, no division by w). */
void mat4_dir(const double m[16], const double d[3], double out[3]);

#endif
