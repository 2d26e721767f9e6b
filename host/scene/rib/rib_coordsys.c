/* rib_coordsys.c — named coordinate systems (RI Spec 3.2 §4.3, Named coordinate systems):
 * CoordinateSystem "name" marks the current transformation with a name, and
 * CoordSysTransform "name" makes the named system's transformation the current one again.
 * The standard names "world", "camera" and "object" (Tessera's) are understood too; the
 * projective "screen", "raster" and "NDC" are not (nothing can stand in those spaces).
 *
 * A system keeps both time samples of the CTM it was marked with. One marked before
 * WorldBegin maps to camera space; used inside the world block it is moved to world space by
 * camera_to_world (the inverse of world_to_camera), as a light given there is. */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One named system: the CTM (both samples) when it was marked, and whether that was before
 * WorldBegin (object to camera) or not (object to world). */
typedef struct rib_coordsys {
    char *name;
    double m[16], m1[16];
    int moving;
    int camera_space;
    size_t scope; /* ScopedCoordinateSystem: the block depth it was marked at; else SIZE_MAX */
} rib_coordsys;

struct rib_coordsystems {
    rib_coordsys *sys;
    size_t count, cap;
};

#define RIB_MAX_COORDSYS 65536 /* distinct names, so that a file cannot exhaust memory */

/* The system named `name`, or NULL: the latest marked (a scoped one shadows the others while
 * its block is open); only unscoped ones when `unscoped`. */
static rib_coordsys *rib_coordsys_find_in(const rib_parser *p, const char *name, int unscoped)
{
    if (!p->coordsys) return NULL;
    for (size_t k = p->coordsys->count; k-- > 0;)
        if (strcmp(p->coordsys->sys[k].name, name) == 0 &&
            (!unscoped || p->coordsys->sys[k].scope == SIZE_MAX))
            return &p->coordsys->sys[k];
    return NULL;
}

static rib_coordsys *rib_coordsys_find(const rib_parser *p, const char *name)
{
    return rib_coordsys_find_in(p, name, 0);
}

/* A new, empty entry for `name`; NULL with p->err set when out of memory or past the bound. */
static rib_coordsys *rib_coordsys_add(rib_parser *p, const char *name)
{
    if (!p->coordsys) {
        p->coordsys = calloc(1, sizeof *p->coordsys);
        if (!p->coordsys) goto oom;
    }
    struct rib_coordsystems *c = p->coordsys;
    if (c->count == RIB_MAX_COORDSYS) {
        rib_error_at(p, p->req_line, p->req_col,
                     "CoordinateSystem: more than %d named coordinate systems", RIB_MAX_COORDSYS);
        return NULL;
    }
    if (c->count == c->cap) {
        size_t cap = c->cap ? c->cap * 2 : 8;
        rib_coordsys *s = realloc(c->sys, cap * sizeof *s);
        if (!s) goto oom;
        c->sys = s;
        c->cap = cap;
    }
    rib_coordsys *e = &c->sys[c->count];
    memset(e, 0, sizeof *e);
    e->name = malloc(strlen(name) + 1);
    if (!e->name) goto oom;
    strcpy(e->name, name);
    c->count++;
    return e;
oom:
    ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    return NULL;
}

int rib_coordsys_mark(rib_parser *p, const char *name, int scoped)
{
    rib_coordsys *e = scoped ? NULL : rib_coordsys_find_in(p, name, 1);
    for (size_t k = 0; scoped && p->coordsys && k < p->coordsys->count; k++)
        if (p->coordsys->sys[k].scope == p->depth && strcmp(p->coordsys->sys[k].name, name) == 0)
            e = &p->coordsys->sys[k]; /* marked again in the same block */
    if (!e) e = rib_coordsys_add(p, name);
    if (!e) return p->err->code;
    memcpy(e->m, p->ctm, sizeof e->m);
    memcpy(e->m1, p->ctm1, sizeof e->m1);
    e->moving = p->ctm_moving;
    e->camera_space = p->phase == RIB_BEFORE_WORLD;
    e->scope = scoped ? p->depth : SIZE_MAX;
    return TS_OK;
}

void rib_coordsys_scope_end(rib_parser *p)
{
    if (!p->coordsys) return;
    size_t n = 0;
    for (size_t k = 0; k < p->coordsys->count; k++) {
        rib_coordsys *e = &p->coordsys->sys[k];
        if (e->scope != SIZE_MAX && e->scope > p->depth)
            free(e->name);
        else
            p->coordsys->sys[n++] = *e;
    }
    p->coordsys->count = n;
}

/* CoordinateSystem "name": marks the current transformation (both samples) with name; a
 * name marked again takes the new transformation. ScopedCoordinateSystem "name" (RenderMan
 * 21+) does the same for the rest of the current attribute block only. */
static int rib_coordsys_request(rib_parser *p, int scoped)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "a coordinate system name", &name);
    if (rc == TS_OK) rc = rib_no_more(p, 1);
    if (rc != TS_OK) return rc;
    return rib_coordsys_mark(p, name, scoped);
}

int rib_req_coordinate_system(rib_parser *p)
{
    return rib_coordsys_request(p, 0);
}

int rib_req_scoped_coordinate_system(rib_parser *p)
{
    return rib_coordsys_request(p, 1);
}

/* The CTM becomes m (and m1 at shutter close). */
static void rib_coordsys_set(rib_parser *p, const double m[16], const double m1[16], int moving)
{
    memcpy(p->ctm, m, sizeof p->ctm);
    memcpy(p->ctm1, moving ? m1 : m, sizeof p->ctm1);
    p->ctm_moving = moving;
}

/* CoordSysTransform "name": the CTM becomes the transformation of the named system (RI
 * Spec: "replaces the current transformation matrix with the matrix that forms the name
 * coordinate system"). "object" leaves it as it is; "world" is the identity in the world
 * block (undefined before it); "camera" is the camera's placement: camera_to_world in the
 * world block, the identity before it. */
int rib_req_coord_sys_transform(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "a coordinate system name", &name);
    if (rc == TS_OK) rc = rib_no_more(p, 1);
    if (rc != TS_OK) return rc;
    char shown[RIB_PRINT_MAX];
    int in_world = p->phase != RIB_BEFORE_WORLD;
    const rib_coordsys *e = rib_coordsys_find(p, name);
    double m[16], c2w[16];
    if (e && (!e->camera_space || !in_world)) {
        rib_coordsys_set(p, e->m, e->m1, e->moving);
        return TS_OK;
    }
    if (in_world && !mat4_invert(p->scene->camera.world_to_camera, c2w))
        return rib_error_at(p, p->req_line, p->req_col,
                            "CoordSysTransform: the camera transform is singular");
    if (e) { /* marked before WorldBegin: camera space, moved to world space */
        double m1[16];
        memcpy(m, c2w, sizeof m);
        mat4_concat(m, e->m);
        memcpy(m1, c2w, sizeof m1);
        mat4_concat(m1, e->m1);
        rib_coordsys_set(p, m, m1, e->moving);
        return TS_OK;
    }
    if (strcmp(name, "object") == 0) return TS_OK;
    if (strcmp(name, "camera") == 0) {
        if (in_world)
            memcpy(m, c2w, sizeof m);
        else
            mat4_identity(m);
        rib_coordsys_set(p, m, m, 0);
        return TS_OK;
    }
    if (strcmp(name, "world") == 0 && in_world) {
        mat4_identity(m);
        rib_coordsys_set(p, m, m, 0);
        return TS_OK;
    }
    if (strcmp(name, "world") == 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "CoordSysTransform \"world\" before WorldBegin (world space is "
                            "defined at WorldBegin)");
    if (strcmp(name, "screen") == 0 || strcmp(name, "raster") == 0 || strcmp(name, "NDC") == 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "CoordSysTransform \"%s\": a projective space is not supported "
                            "(world, camera, object or a CoordinateSystem name)",
                            rib_printable(name, shown));
    return rib_error_at(p, p->args[0].line, p->args[0].col,
                        "CoordSysTransform: no coordinate system \"%s\" (CoordinateSystem "
                        "\"%s\" must come before; or world, camera, object)",
                        rib_printable(name, shown), shown);
}

void rib_coordsys_free(rib_parser *p)
{
    if (!p->coordsys) return;
    for (size_t k = 0; k < p->coordsys->count; k++)
        free(p->coordsys->sys[k].name);
    free(p->coordsys->sys);
    free(p->coordsys);
    p->coordsys = NULL;
}
