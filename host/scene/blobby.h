/* blobby.h — RenderMan's blobby implicit surfaces (RI Spec 3.2 §5.6 "Blobby implicit
 * surfaces", PRMan application note 31) as a triangle mesh whose vertices lie on the surface
 * and carry its exact normals, for the PN-patch path of polygons (scene/polygon.h).
 *
 * The field. A program of instructions, numbered from 0 in the order given, computes one
 * value per point; the surface is where the last instruction's value equals
 * BLOBBY_THRESHOLD, inside where it is greater. Primitive fields (leaves):
 *   1000 f          constant: floats[f]
 *   1001 f          ellipsoid: floats[f..f+16) is a matrix M (RenderMan's row-vector
 *                   convention, translation in elements 12-14) from the blob's space, where
 *                   the blob is the unit sphere, to object space
 *   1002 f          segment: floats[f..f+23) = start (3), end (3), radius (1), matrix M (16):
 *                   a sausage of that radius around the segment, in the blob space M maps
 * Each has the value (1 - r^2)^3 for r < 1 and 0 beyond (Wyvill's soft-object polynomial;
 * r: the distance from the centre, or from the segment over the radius, in blob space), so a
 * leaf is 0 outside its support box. Combining instructions take the results of earlier
 * instructions: 0 add, 1 multiply, 2 maximum, 3 minimum (a count, then that many
 * instruction numbers), 4 subtract (a, b: a - b), 5 divide (a, b: a / b, 0 where b is 0),
 * 6 negate (a), 7 identity (a).
 * BLOBBY_THRESHOLD = (3/4)^3 makes a lone unit ellipsoid the sphere of radius 1/2, as Aqsis
 * draws it; RenderMan renderers differ here (docs/rib.md "Blobby").
 *
 * The polygonization (surface nets, Gibson 1998, with vertices on the surface). The field is
 * sampled on a regular grid over the leaves' support boxes (padded, its border taken as
 * outside, so that every surface is closed). Each cube whose corners' signs differ gets one
 * vertex: the mean of its edges' linear crossings, moved onto the surface by Newton steps
 * along the gradient (or, failing that, the root on a crossing edge); its normal is the unit
 * negated gradient of the field there. Each grid edge the surface crosses gives one quad,
 * the vertices of the four cubes around it, so neighbouring quads share their edges (closed,
 * no cracks) and, unlike marching cubes or tetrahedra, there are no sliver triangles. The
 * cell size follows the smallest leaf: BLOBBY_CELLS_PER_RADIUS cells across a lone blob's
 * radius, and between BLOBBY_MIN_CELLS and BLOBBY_MAX_CELLS cells along the longest side,
 * coarser where sampling would cost more than BLOBBY_MAX_WORK leaf evaluations. */
#ifndef TS_BLOBBY_H
#define TS_BLOBBY_H

#include <stddef.h>

#define BLOBBY_THRESHOLD 0.421875
#define BLOBBY_CELLS_PER_RADIUS 2.0
#define BLOBBY_MIN_CELLS 8
#define BLOBBY_MAX_CELLS 160
/* Leaf evaluations sampling the grid may take: beyond it the grid is coarsened (about 0.3 s
 * in a release build; $TESSERA_BLOBBY_MAX_WORK may lower it, never raise it: the fuzzer,
 * under ASan 15x slower, runs with 2e6). */
#define BLOBBY_MAX_WORK 2e8

typedef struct blobby_op {
    int code;          /* the opcode */
    unsigned first, n; /* operands: b->operand[first .. first + n) (combining instructions) */
    unsigned leaf;     /* leaf number (primitive fields): in b->leaf */
} blobby_op;

typedef struct blobby_leaf {
    int code;            /* 1000, 1001 or 1002 */
    double inv[12];      /* object to blob space: q_j = sum_i p_i inv[3 i + j] + inv[9 + j] */
    double a[3], b[3];   /* segment ends (blob space) */
    double inv_r2;       /* 1 / radius^2 (segment) */
    double value;        /* the constant's value */
    double lo[3], hi[3]; /* the support box in object space (not for a constant) */
    double size;         /* a lower bound of its surface radius's scale in object space */
} blobby_leaf;

typedef struct ts_blobby {
    blobby_op *op;
    unsigned nop;
    blobby_leaf *leaf;
    unsigned nleaf;
    unsigned *operand;
    unsigned noperand;
    int sum_only;        /* every instruction is a leaf or an add: a sum over leaves */
    double lo[3], hi[3]; /* the union of the leaves' support boxes */
} ts_blobby;

/* Compiles the program code[0..ncode) (integers) over floats[0..nfloats). On an error returns
 * -1 and writes the reason into why (naming the instruction and its place in code);
 * repelling planes (1003), field plug-ins (1004) and AIR's dynamic blob ops (9000) are
 * errors that name them. */
int blobby_compile(ts_blobby *b, const double *code, size_t ncode, const double *floats,
                   size_t nfloats, char *why, size_t why_len);
void blobby_free(ts_blobby *b);

/* The field at object-space point p; leaf_values (nleaf entries, may be NULL) gets each
 * leaf's own value there. */
double blobby_field(const ts_blobby *b, const double p[3], double *leaf_values);

/* The mesh: vertex positions (object space), unit normals and colours, and quads as four
 * vertices, outward by the right-hand rule (counter-clockwise seen from outside). */
typedef struct blobby_mesh {
    double (*p)[3], (*n)[3], (*cs)[3]; /* cs: NULL without leaf colours */
    size_t nvert;
    unsigned (*quad)[4];
    size_t nquad;
    double cell; /* the grid's cell size */
    int coarse;  /* the cell is over 1.5 x the smallest blob's surface radius: the grid's limits
                    made it coarse, and the smallest blobs may be lost */
} blobby_mesh;

/* Polygonizes b into *m. leaf_cs (NULL, or 3 numbers per leaf) gives each vertex the leaves'
 * colours weighted by their field values there. Returns 0, or -1 when out of memory or the
 * mesh would pass BLOBBY_MAX_QUADS (why says so). */
#define BLOBBY_MAX_QUADS (1u << 20)
int blobby_polygonize(const ts_blobby *b, const double *leaf_cs, blobby_mesh *m, char *why,
                      size_t why_len);
void blobby_mesh_free(blobby_mesh *m);

#endif
