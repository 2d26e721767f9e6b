/* mesh.c — polygon meshes through Assimp's C API into PN Bézier patches (see mesh.h).
 *
 * Quads: the corners are the vertices; each boundary curve is the cubic whose inner
 * control points are the PN edge points b_ij = (2 P_i + P_j - w_ij N_i) / 3, the point a
 * third of the way along the edge projected onto the tangent plane at P_i (Vlachos et al.
 * 2001). The interior points are those of the bilinearly blended Coons patch of the four
 * boundary curves: ruled(u) + ruled(v) - bilinear(corners), which is bicubic and so exact.
 * Like the PN triangle's centre rule E + (E - V) / 2, it reproduces every quadratic
 * (and bilinear) surface from exact boundary curves, keeps a planar quad flat and
 * linearly parametrised, and leaves the corner tangent planes (set by the edge points
 * alone) untouched.
 *
 * Triangles: the cubic PN triangle with barycentric coordinates (1-u)(1-v), u(1-v), v is a
 * bicubic tensor-product patch whose v = 1 edge collapses to the third vertex; row k of
 * its control grid is the degree-(3-k) curve through the triangle points b_(3-k-j, j, k),
 * degree-elevated to a cubic. Its three edges are exactly the PN boundary curves, so a
 * triangle meets a neighbouring quad or triangle without a gap.
 */
#include "scene/mesh.h"

#include "base/file.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* ---- small vector helpers ------------------------------------------------------------ */

static void v_sub(const double a[3], const double b[3], double o[3])
{
    o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}

static double v_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void v_cross(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static double v_len(const double a[3])
{
    return sqrt(v_dot(a, a));
}

/* ---- PN construction ----------------------------------------------------------------- */

/* The PN edge point near pi on the edge pi -> pj: a third of the way along the edge,
 * projected onto the tangent plane at pi (ni unit). */
static void pn_edge(const double pi[3], const double pj[3], const double ni[3], double o[3])
{
    double d[3];
    v_sub(pj, pi, d);
    double w = v_dot(d, ni);
    for (int k = 0; k < 3; k++)
        o[k] = (2.0 * pi[k] + pj[k] - w * ni[k]) / 3.0;
}

void mesh_pn_quad(const double p[4][3], const double n[4][3], double cp[16][3])
{
    /* Polygon order v0 v1 v2 v3 -> corners (0,0) (1,0) (1,1) (0,1). */
    memcpy(cp[0], p[0], sizeof cp[0]);
    memcpy(cp[3], p[1], sizeof cp[0]);
    memcpy(cp[15], p[2], sizeof cp[0]);
    memcpy(cp[12], p[3], sizeof cp[0]);
    pn_edge(p[0], p[1], n[0], cp[1]); /* v = 0: v0 -> v1 */
    pn_edge(p[1], p[0], n[1], cp[2]);
    pn_edge(p[3], p[2], n[3], cp[13]); /* v = 1: v3 -> v2 */
    pn_edge(p[2], p[3], n[2], cp[14]);
    pn_edge(p[0], p[3], n[0], cp[4]); /* u = 0: v0 -> v3 */
    pn_edge(p[3], p[0], n[3], cp[8]);
    pn_edge(p[1], p[2], n[1], cp[7]); /* u = 1: v1 -> v2 */
    pn_edge(p[2], p[1], n[2], cp[11]);
    for (int j = 1; j <= 2; j++)
        for (int i = 1; i <= 2; i++) {
            double s = i / 3.0, t = j / 3.0;
            for (int k = 0; k < 3; k++) {
                double ruled_v = (1.0 - t) * cp[i][k] + t * cp[12 + i][k];
                double ruled_u = (1.0 - s) * cp[4 * j][k] + s * cp[4 * j + 3][k];
                double bilin = (1.0 - s) * (1.0 - t) * cp[0][k] + s * (1.0 - t) * cp[3][k] +
                               (1.0 - s) * t * cp[12][k] + s * t * cp[15][k];
                cp[j * 4 + i][k] = ruled_v + ruled_u - bilin;
            }
        }
}

void mesh_pn_triangle(const double p[3][3], const double n[3][3], double cp[16][3])
{
    /* Triangle points b_ijk (i: p0, j: p1, k: p2), Vlachos et al. 2001. */
    double b210[3], b120[3], b021[3], b012[3], b102[3], b201[3], b111[3];
    pn_edge(p[0], p[1], n[0], b210);
    pn_edge(p[1], p[0], n[1], b120);
    pn_edge(p[1], p[2], n[1], b021);
    pn_edge(p[2], p[1], n[2], b012);
    pn_edge(p[2], p[0], n[2], b102);
    pn_edge(p[0], p[2], n[0], b201);
    for (int k = 0; k < 3; k++) {
        double e = (b210[k] + b120[k] + b021[k] + b012[k] + b102[k] + b201[k]) / 6.0;
        double v = (p[0][k] + p[1][k] + p[2][k]) / 3.0;
        b111[k] = e + (e - v) / 2.0;
    }
    for (int k = 0; k < 3; k++) {
        /* Row 0 (v = 0): the cubic edge p0 -> p1. */
        cp[0][k] = p[0][k], cp[1][k] = b210[k], cp[2][k] = b120[k], cp[3][k] = p[1][k];
        /* Row 1: the quadratic b201 b111 b021, elevated. */
        cp[4][k] = b201[k];
        cp[5][k] = (b201[k] + 2.0 * b111[k]) / 3.0;
        cp[6][k] = (2.0 * b111[k] + b021[k]) / 3.0;
        cp[7][k] = b021[k];
        /* Row 2: the line b102 b012, elevated. */
        cp[8][k] = b102[k];
        cp[9][k] = (2.0 * b102[k] + b012[k]) / 3.0;
        cp[10][k] = (b102[k] + 2.0 * b012[k]) / 3.0;
        cp[11][k] = b012[k];
        /* Row 3 (v = 1): collapsed to p2. */
        cp[12][k] = cp[13][k] = cp[14][k] = cp[15][k] = p[2][k];
    }
}

/* ---- polygons ------------------------------------------------------------------------ */

typedef struct mesh_ctx {
    const char *path;
    ts_scene *s;
    ts_error *err;
    ts_patch_attr attr;
    const struct aiMesh *mesh;
    double (*pos)[3]; /* world-space vertices of the current mesh */
    double (*nrm)[3]; /* world-space unit normals (zero where the file's is unusable) */
    uint32_t emitted, skipped;
} mesh_ctx;

/* Newell normal of the polygon idx[0..n): robust for non-planar and concave polygons. */
static void polygon_normal(const mesh_ctx *c, const unsigned *idx, unsigned n, double o[3])
{
    o[0] = o[1] = o[2] = 0.0;
    for (unsigned k = 0; k < n; k++) {
        const double *a = c->pos[idx[k]], *b = c->pos[idx[(k + 1) % n]];
        o[0] += (a[1] - b[1]) * (a[2] + b[2]);
        o[1] += (a[2] - b[2]) * (a[0] + b[0]);
        o[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
}

/* A face of a mesh without normals: flat, as the file describes it (issue 16 item 5: a cube
 * stays a cube). The bilinear patch through its corners (a triangle's third corner taken
 * twice, so its v = 1 edge collapses as in mesh_pn_triangle), degree-elevated to an equal
 * bicubic: planar faces stay planar, every edge is the straight segment between its two
 * vertices, so faces meet without a gap. No corner normals: scene_finalize averages them
 * over the faces sharing the corner, so displacement does not tear the hard edges open. */
static int emit_flat_face(mesh_ctx *c, const unsigned *idx, unsigned n, ts_patch_attr *a)
{
    const double *q00 = c->pos[idx[0]], *q10 = c->pos[idx[1]], *q11 = c->pos[idx[2]];
    const double *q01 = n == 4 ? c->pos[idx[3]] : q11;
    double cp[16][3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++)
                cp[j * 4 + i][d] = ((3 - i) * (3 - j) * q00[d] + i * (3 - j) * q10[d] +
                                    (3 - i) * j * q01[d] + i * j * q11[d]) /
                                   9.0;
    int rc = scene_add_patch_ex(c->s, (const double(*)[3])cp, NULL, NULL, a, c->err);
    if (rc == TS_OK) c->emitted++;
    return rc;
}

/* Emits the triangle (n = 3) or quad (n = 4) with vertex indices idx. A vertex whose
 * normal is unusable takes the face's normal; a face of zero area is skipped; a mesh
 * without normals gives flat faces. */
static int emit_face(mesh_ctx *c, const unsigned *idx, unsigned n)
{
    double fn[3];
    polygon_normal(c, idx, n, fn);
    double fl = v_len(fn);
    double ext = 0.0;
    for (unsigned k = 1; k < n; k++) {
        double d[3];
        v_sub(c->pos[idx[k]], c->pos[idx[0]], d);
        ext = fmax(ext, v_len(d));
    }
    if (!(fl > 1e-12 * ext * ext) || !isfinite(fl)) {
        c->skipped++;
        return TS_OK;
    }
    ts_patch_attr a = c->attr;
    const struct aiColor4D *col = c->mesh->mColors[0];
    if (col) {
        double r = 0, g = 0, b = 0;
        for (unsigned k = 0; k < n; k++)
            r += col[idx[k]].r, g += col[idx[k]].g, b += col[idx[k]].b;
        a.cs_r = (float)(r / n), a.cs_g = (float)(g / n), a.cs_b = (float)(b / n);
    }
    if (!c->mesh->mNormals) return emit_flat_face(c, idx, n, &a);
    double p[4][3], nn[4][3];
    for (unsigned k = 0; k < n; k++) {
        memcpy(p[k], c->pos[idx[k]], sizeof p[k]);
        const double *v = c->nrm[idx[k]];
        if (v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0)
            for (int d = 0; d < 3; d++)
                nn[k][d] = fn[d] / fl;
        else
            memcpy(nn[k], v, sizeof nn[k]);
    }
    double cp[16][3], cn[4][3];
    if (n == 4) {
        mesh_pn_quad((const double(*)[3])p, (const double(*)[3])nn, cp);
        /* Corner order (0,0) (1,0) (0,1) (1,1) = v0 v1 v3 v2. */
        memcpy(cn[0], nn[0], sizeof cn[0]);
        memcpy(cn[1], nn[1], sizeof cn[0]);
        memcpy(cn[2], nn[3], sizeof cn[0]);
        memcpy(cn[3], nn[2], sizeof cn[0]);
    } else {
        mesh_pn_triangle((const double(*)[3])p, (const double(*)[3])nn, cp);
        memcpy(cn[0], nn[0], sizeof cn[0]);
        memcpy(cn[1], nn[1], sizeof cn[0]);
        memcpy(cn[2], nn[2], sizeof cn[0]);
        memcpy(cn[3], nn[2], sizeof cn[0]);
    }
    int rc =
        scene_add_patch_ex(c->s, (const double(*)[3])cp, NULL, (const double(*)[3])cn, &a, c->err);
    if (rc == TS_OK) c->emitted++;
    return rc;
}

/* Twice the signed area of triangle (a, b, c) projected onto the plane with normal n. */
static double ear_area(const double *a, const double *b, const double *cc, const double n[3])
{
    double e1[3], e2[3], x[3];
    v_sub(b, a, e1);
    v_sub(cc, a, e2);
    v_cross(e1, e2, x);
    return v_dot(x, n);
}

/* Whether p lies inside or on triangle (a, b, c) (counter-clockwise about n). */
static int ear_contains(const double *a, const double *b, const double *cc, const double *pt,
                        const double n[3])
{
    return ear_area(a, b, pt, n) >= 0.0 && ear_area(b, cc, pt, n) >= 0.0 &&
           ear_area(cc, a, pt, n) >= 0.0;
}

/* Splits a polygon of more than four vertices into triangles by ear clipping in the plane
 * of its Newell normal (a fan when no ear is found, e.g. for a self-intersecting one). */
static int emit_polygon(mesh_ctx *c, const unsigned *idx, unsigned n)
{
    unsigned *ring = malloc(n * sizeof *ring);
    if (!ring) return ts_error_set(c->err, TS_E_MEMORY, "%s: out of memory", c->path);
    memcpy(ring, idx, n * sizeof *ring);
    double nrm[3];
    polygon_normal(c, idx, n, nrm);
    int rc = TS_OK;
    unsigned m = n, guard = 0;
    while (rc == TS_OK && m > 3 && guard < 2 * n * n) {
        int clipped = 0;
        for (unsigned k = 0; k < m && !clipped; k++, guard++) {
            unsigned ia = ring[(k + m - 1) % m], ib = ring[k], ic = ring[(k + 1) % m];
            const double *a = c->pos[ia], *b = c->pos[ib], *cc = c->pos[ic];
            if (!(ear_area(a, b, cc, nrm) > 0.0)) continue; /* reflex or flat */
            int ear = 1;
            for (unsigned q = 0; q < m && ear; q++) {
                unsigned iq = ring[q];
                if (iq == ia || iq == ib || iq == ic) continue;
                ear = !ear_contains(a, b, cc, c->pos[iq], nrm);
            }
            if (!ear) continue;
            unsigned tri[3] = {ia, ib, ic};
            rc = emit_face(c, tri, 3);
            memmove(ring + k, ring + k + 1, (m - k - 1) * sizeof *ring);
            m--;
            clipped = 1;
        }
        if (!clipped) break;
    }
    for (unsigned k = 1; rc == TS_OK && k + 1 < m; k++) { /* the rest as a fan */
        unsigned tri[3] = {ring[0], ring[k], ring[k + 1]};
        rc = emit_face(c, tri, 3);
    }
    free(ring);
    return rc;
}

/* ---- transforms ---------------------------------------------------------------------- */

/* Inverse of the 3x3 linear part of m (row-major 4x4), transposed: the normal matrix.
 * Returns 0 when singular. */
static int normal_matrix(const double m[16], double nm[9])
{
    double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9],
           i = m[10];
    double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    double det = a * A + b * B + c * C;
    if (!(fabs(det) > 1e-300) || !isfinite(det)) return 0;
    /* inverse = adj / det; its transpose has the cofactors in place. */
    nm[0] = A / det, nm[1] = B / det, nm[2] = C / det;
    nm[3] = -(b * i - c * h) / det, nm[4] = (a * i - c * g) / det, nm[5] = -(a * h - b * g) / det;
    nm[6] = (b * f - c * e) / det, nm[7] = -(a * f - c * d) / det, nm[8] = (a * e - b * d) / det;
    return 1;
}

/* Moves the current mesh's vertices and normals to world space. */
static int transform_mesh(mesh_ctx *c, const double m[16], const double nm[9])
{
    const struct aiMesh *me = c->mesh;
    for (unsigned v = 0; v < me->mNumVertices; v++) {
        const double q[3] = {me->mVertices[v].x, me->mVertices[v].y, me->mVertices[v].z};
        for (int r = 0; r < 3; r++) {
            double x =
                (m[r * 4] * q[0] + m[r * 4 + 1] * q[1] + m[r * 4 + 2] * q[2] + m[r * 4 + 3]) /
                m[15];
            if (!(fabs(x) <= FLT_MAX))
                return ts_error_set(c->err, TS_E_SCENE,
                                    "%s: vertex %u leaves the float range after the transform",
                                    c->path, v);
            c->pos[v][r] = x;
        }
        double *o = c->nrm[v];
        o[0] = o[1] = o[2] = 0.0;
        if (!me->mNormals) continue;
        const double nn[3] = {me->mNormals[v].x, me->mNormals[v].y, me->mNormals[v].z};
        for (int r = 0; r < 3; r++)
            o[r] = nm[r * 3] * nn[0] + nm[r * 3 + 1] * nn[1] + nm[r * 3 + 2] * nn[2];
        double l = v_len(o);
        if (l > 0.0 && isfinite(l))
            o[0] /= l, o[1] /= l, o[2] /= l;
        else
            o[0] = o[1] = o[2] = 0.0;
    }
    return TS_OK;
}

/* ---- loading ------------------------------------------------------------------------- */

/* Formats whose convention is z up (CAD, 3D printing, 3ds Max, Blender); the others (OBJ,
 * PLY, glTF, Collada after Assimp's own conversion, ...) are taken as y up. */
static const char *const mesh_z_up_formats[] = {"stl", "3ds", "blend", "3mf", "amf", "dxf", "ifc"};

/* The file's up axis: Assimp's "UpAxis" (0, 1, 2) and "UpAxisSign" metadata where the format
 * records them (FBX), else the format's convention by the file name's extension. */
static void mesh_up_axis(const char *path, const struct aiScene *sc, double up[3])
{
    int axis = -1, sign = 1;
    const struct aiMetadata *md = sc->mMetaData;
    for (unsigned k = 0; md && k < md->mNumProperties; k++) {
        if (md->mValues[k].mType != AI_INT32 || !md->mValues[k].mData) continue;
        int32_t v;
        memcpy(&v, md->mValues[k].mData, sizeof v);
        if (strcmp(md->mKeys[k].data, "UpAxis") == 0 && v >= 0 && v <= 2) axis = v;
        if (strcmp(md->mKeys[k].data, "UpAxisSign") == 0 && (v == 1 || v == -1)) sign = v;
    }
    if (axis < 0) {
        const char *dot = strrchr(path, '.');
        axis = 1;
        for (size_t k = 0; dot && k < sizeof mesh_z_up_formats / sizeof mesh_z_up_formats[0]; k++)
            if (strcasecmp(dot + 1, mesh_z_up_formats[k]) == 0) axis = 2;
        sign = 1;
    }
    up[0] = up[1] = up[2] = 0.0;
    up[axis] = sign;
}

int mesh_load(const char *path, const double object_to_world[16], const ts_patch_attr *attr,
              ts_scene *s, ts_error *err)
{
    return mesh_load_ex(path, object_to_world, attr, s, NULL, err);
}

int mesh_load_ex(const char *path, const double object_to_world[16], const ts_patch_attr *attr,
                 ts_scene *s, double up[3], ts_error *err)
{
    FILE *f = ts_file_open_regular(path, err); /* a FIFO or device would hang Assimp */
    if (!f) return err->code;
    fclose(f);
    double nm[9];
    const double *m = object_to_world;
    if (!(m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] != 0.0) || !normal_matrix(m, nm))
        return ts_error_set(err, TS_E_SCENE, "%s: the mesh transform must be affine and invertible",
                            path);
    /* No aiProcess_Triangulate: quads stay quads. No generated normals: a mesh without them
     * has flat faces (emit_flat_face). */
    const struct aiScene *sc =
        aiImportFile(path, aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices |
                               aiProcess_ValidateDataStructure);
    if (!sc)
        return ts_error_set(err, TS_E_SCENE, "%s: cannot read the mesh: %s", path,
                            aiGetErrorString());
    if (up) mesh_up_axis(path, sc, up);
    mesh_ctx c = {.path = path, .s = s, .err = err};
    c.attr = *attr;
    int rc = TS_OK;
    if (sc->mFlags & AI_SCENE_FLAGS_INCOMPLETE)
        rc = ts_error_set(err, TS_E_SCENE, "%s: the file holds no complete mesh", path);
    for (unsigned mi = 0; rc == TS_OK && mi < sc->mNumMeshes; mi++) {
        const struct aiMesh *me = sc->mMeshes[mi];
        if (!me->mNumVertices || !me->mNumFaces) continue;
        c.mesh = me;
        c.pos = malloc((size_t)me->mNumVertices * sizeof *c.pos);
        c.nrm = malloc((size_t)me->mNumVertices * sizeof *c.nrm);
        if (!c.pos || !c.nrm) rc = ts_error_set(err, TS_E_MEMORY, "%s: out of memory", path);
        if (rc == TS_OK) rc = transform_mesh(&c, m, nm);
        for (unsigned fi = 0; rc == TS_OK && fi < me->mNumFaces; fi++) {
            const struct aiFace *fc = &me->mFaces[fi];
            unsigned n = fc->mNumIndices;
            int bad = 0;
            for (unsigned k = 0; k < n; k++)
                bad |= fc->mIndices[k] >= me->mNumVertices;
            if (bad) {
                rc = ts_error_set(err, TS_E_SCENE, "%s: face %u refers to a missing vertex", path,
                                  fi);
            } else if (n == 3 || n == 4) {
                rc = emit_face(&c, fc->mIndices, n);
            } else if (n > 4) {
                rc = emit_polygon(&c, fc->mIndices, n);
            } /* points and lines are not surfaces */
        }
        free(c.pos);
        free(c.nrm);
        c.pos = NULL, c.nrm = NULL;
    }
    aiReleaseImport(sc);
    if (rc == TS_OK && c.emitted == 0)
        rc = ts_error_set(err, TS_E_SCENE, "%s: the mesh has no polygons", path);
    return rc;
}
