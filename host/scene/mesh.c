/* mesh.c — polygon meshes through Assimp's C API into PN Bézier patches (see mesh.h). Each
 * face becomes patches by scene/polygon.c (quads and triangles one patch each, larger or
 * concave polygons ear-clipped), from its vertices' world-space positions and normals. */
#include "scene/mesh.h"

#include "base/file.h"
#include "scene/polygon.h"

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

/* ---- faces --------------------------------------------------------------------------- */

typedef struct mesh_ctx {
    const char *path;
    ts_scene *s;
    ts_error *err;
    ts_patch_attr attr;
    const struct aiMesh *mesh;
    double (*pos)[3];          /* world-space vertices of the current mesh */
    double (*nrm)[3];          /* world-space unit normals (zero where the file's is unusable) */
    double (*fp)[3], (*fn)[3]; /* the current face's positions and normals */
    const unsigned *idx;       /* the current face's vertex indices */
    unsigned face_cap;
    uint32_t emitted;
} mesh_ctx;

/* One patch of the current face: its colour is the average of its corners' vertex colours
 * when the mesh has them (a triangle's three). */
static int mesh_emit(void *ctx, const double cp[16][3], const double cn[4][3],
                     const unsigned corner[4])
{
    mesh_ctx *c = ctx;
    ts_patch_attr a = c->attr;
    const struct aiColor4D *col = c->mesh->mColors[0];
    if (col) {
        unsigned n = corner[3] == corner[2] ? 3 : 4;
        double r = 0, g = 0, b = 0;
        for (unsigned k = 0; k < n; k++) {
            const struct aiColor4D *v = &col[c->idx[corner[k]]];
            r += v->r, g += v->g, b += v->b;
        }
        a.cs_r = (float)(r / n), a.cs_g = (float)(g / n), a.cs_b = (float)(b / n);
    }
    /* A mesh without normals: flat faces (their PN patches with the face's normal are
     * planar), and no corner normals, so scene_finalize averages them over the faces
     * meeting at each corner and displacement does not tear the hard edges open
     * (issue 16 item 5: a cube stays a cube). */
    int rc = scene_add_patch_ex(c->s, cp, NULL, c->mesh->mNormals ? cn : NULL, &a, c->err);
    if (rc == TS_OK) c->emitted++;
    return rc;
}

/* The face with vertex indices idx[0..n) as patches; its vertices without a usable normal
 * take the face's (every vertex of a mesh without normals: flat faces). */
static int mesh_face(mesh_ctx *c, const unsigned *idx, unsigned n)
{
    if (n > c->face_cap) {
        unsigned cap = n < 64 ? 64 : n;
        double(*fp)[3] = realloc(c->fp, (size_t)cap * sizeof *fp);
        if (fp) c->fp = fp;
        double(*fn)[3] = realloc(c->fn, (size_t)cap * sizeof *fn);
        if (fn) c->fn = fn;
        if (!fp || !fn) return ts_error_set(c->err, TS_E_MEMORY, "%s: out of memory", c->path);
        c->face_cap = cap;
    }
    for (unsigned k = 0; k < n; k++) {
        memcpy(c->fp[k], c->pos[idx[k]], sizeof c->fp[k]);
        memcpy(c->fn[k], c->nrm[idx[k]], sizeof c->fn[k]);
    }
    c->idx = idx;
    poly_face f = {.p = (const double(*)[3])c->fp, .n = (const double(*)[3])c->fn, .count = n};
    return poly_patches(&f, mesh_emit, c, NULL, c->err);
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
        double l = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
        if (l > 0.0 && isfinite(l))
            o[0] /= l, o[1] /= l, o[2] /= l;
        else
            o[0] = o[1] = o[2] = 0.0;
    }
    return TS_OK;
}

/* ---- loading ------------------------------------------------------------------------- */

/* Formats whose convention is z up: CAD and 3D printing (STL, 3MF, AMF, DXF, IFC), 3ds Max,
 * Blender (Assimp keeps its coordinates), trueSpace (COB, SCN), Valve's SMD (the Source engine)
 * and Quick3D (Q3O, Q3S). The others (OBJ, PLY, glTF, AC3D, Collada after Assimp's own
 * conversion of its <up_axis>, ...) are taken as y up. None of these files says it: a model that
 * breaks its format's convention needs --up (docs/rib.md "The automatic camera"). */
static const char *const mesh_z_up_formats[] = {"stl", "3ds", "blend", "3mf", "amf", "dxf",
                                                "ifc", "cob", "scn",   "smd", "q3o", "q3s"};

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
    if (scene_add_input(s, path, err)) return err->code;
    double nm[9];
    const double *m = object_to_world;
    if (!(m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] != 0.0) || !normal_matrix(m, nm))
        return ts_error_set(err, TS_E_SCENE, "%s: the mesh transform must be affine and invertible",
                            path);
    /* No aiProcess_Triangulate: quads stay quads. No generated normals: a mesh without them
     * has flat faces (mesh_emit). */
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
            } else if (n >= 3) {
                rc = mesh_face(&c, fc->mIndices, n);
            } /* points and lines are not surfaces */
        }
        free(c.pos);
        free(c.nrm);
        c.pos = NULL, c.nrm = NULL;
    }
    aiReleaseImport(sc);
    free(c.fp);
    free(c.fn);
    if (rc == TS_OK && c.emitted == 0)
        rc = ts_error_set(err, TS_E_SCENE, "%s: the mesh has no polygons", path);
    return rc;
}
