/* basis.h — RenderMan cubic basis matrices and their conversion to Bézier form.
 *
 * A cubic curve in basis M with control points G0..G3 is (RenderMan Interface Spec 3.2,
 * RiBasis)   P(t) = [t^3 t^2 t 1] · M · [G0 G1 G2 G3]^T,
 * so basis function i is b_i(t) = sum_r t^(3-r) M[r][i]. Matrices are stored row-major as
 * RtBasis is (m[r * 4 + i]), which is also the order of a RIB "Basis [16 floats]" array.
 * The renderer only handles Bézier patches: every other basis is converted on load by
 * B = Mbez^-1 · M · G per parametric direction, which is exact (both span the cubics).
 */
#ifndef TS_BASIS_H
#define TS_BASIS_H

/* A basis matrix plus its step: how many control points to advance between successive
 * patches of a PatchMesh (bezier 3, b-spline 1, catmull-rom 1, hermite 2, power 4). */
typedef struct ts_basis {
    double m[16];
    int step;
} ts_basis;

/* The five standard bases, with their standard steps. */
extern const ts_basis basis_bezier;
extern const ts_basis basis_bspline;
extern const ts_basis basis_catmull_rom;
extern const ts_basis basis_hermite;
extern const ts_basis basis_power;

/* Looks up a standard basis by its RIB name: "bezier", "b-spline" (also "bspline"),
 * "catmull-rom", "hermite", "power". Returns NULL for any other name. */
const ts_basis *basis_by_name(const char *name);

/* Makes a basis from an explicit row-major matrix (a RIB [16] array) and a step. */
ts_basis basis_from_matrix(const double m[16], int step);

/* Non-zero when the matrix equals the Bézier matrix exactly (conversion is the identity). */
int basis_is_bezier(const ts_basis *b);

/* The four basis functions b_0..b_3 of matrix m at parameter t (see the formula above). */
void basis_weights(const double m[16], double t, double w[4]);

/* Converts a 4x4 control grid given in basis u (along rows) and basis v (along columns) to
 * the Bézier grid describing the same surface. Grids are row by row with u fastest: point
 * (i, j) is grid[j * 4 + i]. In matrix form, with G indexed [v][u]:
 *   G_bez = Mb^-1 · Mv · G · Mu^T · Mb^-T      (double precision throughout).
 * `in` and `out` may not alias. */
void basis_grid_to_bezier(const ts_basis *u, const ts_basis *v, const double in[16][3],
                          double out[16][3]);

#endif
