/* rib_object.c — retained geometry (RI Spec 3.2 §5.10): ObjectBegin handle ... ObjectEnd
 * records the requests of an object's definition without running them, and ObjectInstance
 * handle runs them again where it stands, inside an implicit AttributeBegin/AttributeEnd:
 * the object takes the attributes and the transformation in effect at the instance ("the
 * object inherits the current set of attributes"), its own transformations are relative to
 * them, and its own attribute changes end with it.
 *
 * Every instance adds its own patches to the scene, exactly the geometry its requests make
 * written out in its place, bit for bit (its top-level leaves, attributes and shading are an
 * ordinary patch's). What instances share is the dicing: each instance in the world block
 * that adds as many patches as the object's first one is recorded as a run of patches
 * repeating that first instance's, with the rigid map between the two instances' CTMs
 * (scene.h ts_instance_run); scene_finalize (host/scene/instance.c) checks each patch and
 * lets those that match be diced once, as their master, for every instance. The patches
 * that instances add are bounded by RIB_MAX_INSTANCED_PATCHES (a few bytes of RIB can
 * instance a large object many times).
 *
 * A definition holds geometry, transformations, attributes and motion blocks: requests are
 * checked when they are recorded (unknown ones, objects inside objects, world and frame
 * blocks, camera options, unbalanced blocks are errors there), and run (with their errors)
 * at each instance. An object does not span files: it ends in the file it begins in. A
 * handle is a number or a string; defining a handle again replaces the object. */
#include "scene/rib/rib_internal.h"
#include "base/mat4.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One object: its handle and the requests of its definition. */
typedef struct rib_object {
    int named; /* the handle is the string `name`, else the number `number` */
    double number;
    char *name;
    char *file;    /* the file it was defined in: messages and relative paths when it runs */
    int line, col; /* of its ObjectBegin */
    rib_saved_list reqs;
    /* Its first instance in the world block, the master of the later ones (instance.c):
     * its first patch, how many it added, and the CTM it stood under (time 0). */
    int has_master;
    uint32_t master_first, master_count;
    double master_ctm[16];
} rib_object;

struct rib_objects {
    rib_object *list;
    size_t count, cap;
    int recording; /* inside ObjectBegin ... ObjectEnd: `open` is being recorded */
    rib_object open;
    const char *text;                      /* the text of the file its ObjectBegin is in */
    int blocks;                            /* Attribute/Transform blocks open in the definition */
    int motion_line, motion_col;           /* of a MotionBegin open in the definition, 0 if none */
    uint64_t instanced;                    /* patches instances have added so far */
    int running;                           /* an instance is running its requests (no nesting) */
    char running_shown[RIB_PRINT_MAX + 2]; /* its object's handle, for messages */
};

/* Requests an object's definition may not hold. */
static const char *const object_forbidden[] = {
    "WorldBegin",   "WorldEnd",     "FrameBegin", "FrameEnd", "Format",     "Projection",
    "ScreenWindow", "PixelSamples", "Clipping",   "Shutter",  "CropWindow", "Exposure",
};

static void object_free(rib_object *o)
{
    rib_saved_list_free(&o->reqs);
    free(o->name);
    free(o->file);
    memset(o, 0, sizeof *o);
}

void rib_object_free(rib_parser *p)
{
    if (!p->objects) return;
    for (size_t k = 0; k < p->objects->count; k++)
        object_free(&p->objects->list[k]);
    object_free(&p->objects->open);
    free(p->objects->list);
    free(p->objects);
    p->objects = NULL;
}

int rib_object_recording(const rib_parser *p)
{
    return p->objects && p->objects->recording;
}

/* The handle argument of ObjectBegin or ObjectInstance into o (named, number, name: a copy
 * made by the caller) and a printable form into shown. */
static int object_handle(rib_parser *p, rib_object *o, char shown[RIB_PRINT_MAX + 2])
{
    if (p->nargs != 1 || (p->args[0].kind != RIB_ARG_NUMBER && p->args[0].kind != RIB_ARG_STRING))
        return rib_error_at(p, p->req_line, p->req_col, "%s takes one handle, a number or a string",
                            p->req);
    o->named = p->args[0].kind == RIB_ARG_STRING;
    if (o->named) {
        char buf[RIB_PRINT_MAX];
        o->name = (char *)rib_arg_str(p, &p->args[0], 0); /* the caller copies it */
        snprintf(shown, RIB_PRINT_MAX + 2, "\"%s\"", rib_printable(o->name, buf));
    } else {
        o->number = rib_arg_nums(p, &p->args[0])[0];
        snprintf(shown, RIB_PRINT_MAX + 2, "%.17g", o->number);
    }
    return TS_OK;
}

/* Fails inside a running instance: its object's requests may read an archive, which may
 * not define or instance objects (objects do not nest; a definition replaced or added while
 * its instance runs would pull the requests from under it). */
static int object_not_running(rib_parser *p)
{
    if (!p->objects || !p->objects->running) return TS_OK;
    return rib_error_at(p, p->req_line, p->req_col,
                        "%s inside an instance of object %s (objects do not nest)", p->req,
                        p->objects->running_shown);
}

/* The object with o's handle, or NULL. */
static rib_object *object_find(struct rib_objects *objs, const rib_object *o)
{
    for (size_t k = 0; objs && k < objs->count; k++) {
        rib_object *q = &objs->list[k];
        if (q->named == o->named &&
            (o->named ? strcmp(q->name, o->name) == 0 : q->number == o->number))
            return q;
    }
    return NULL;
}

/* ObjectBegin handle: starts recording (RI Spec: objects do not nest; rib_object_record
 * refuses an ObjectBegin while recording). */
int rib_req_object_begin(rib_parser *p)
{
    rib_object o;
    char shown[RIB_PRINT_MAX + 2];
    memset(&o, 0, sizeof o);
    int rc = object_not_running(p);
    if (rc == TS_OK) rc = object_handle(p, &o, shown);
    if (rc != TS_OK) return rc;
    if (!p->objects && !(p->objects = calloc(1, sizeof *p->objects)))
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    struct rib_objects *objs = p->objects;
    o.name = o.named ? strdup(o.name) : NULL;
    o.file = strdup(p->lx.file);
    if ((o.named && !o.name) || !o.file) {
        object_free(&o);
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    }
    o.line = p->req_line, o.col = p->req_col;
    objs->open = o;
    objs->recording = 1;
    objs->text = p->lx.text;
    objs->blocks = 0;
    objs->motion_line = objs->motion_col = 0;
    return TS_OK;
}

/* ObjectEnd: the definition is complete and balanced; it replaces an object of the same
 * handle. Outside a definition it is an error. */
static int object_end(rib_parser *p)
{
    struct rib_objects *objs = p->objects;
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    if (objs->blocks > 0)
        return rib_error_at(p, p->req_line, p->req_col,
                            "ObjectEnd: %d AttributeBegin/TransformBegin block%s of the object "
                            "begun at %d:%d %s never closed",
                            objs->blocks, objs->blocks > 1 ? "s" : "", objs->open.line,
                            objs->open.col, objs->blocks > 1 ? "are" : "is");
    if (objs->motion_line)
        return rib_error_at(p, p->req_line, p->req_col,
                            "ObjectEnd: the MotionBegin at %d:%d is never closed",
                            objs->motion_line, objs->motion_col);
    rib_object *old = object_find(objs, &objs->open);
    if (old) {
        object_free(old);
        *old = objs->open;
    } else {
        if (objs->count == objs->cap) {
            size_t cap = objs->cap ? objs->cap * 2 : 8;
            rib_object *l = realloc(objs->list, cap * sizeof *l);
            if (!l) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
            objs->list = l, objs->cap = cap;
        }
        objs->list[objs->count++] = objs->open;
    }
    memset(&objs->open, 0, sizeof objs->open);
    objs->recording = 0;
    return TS_OK;
}

int rib_req_object_end(rib_parser *p)
{
    if (!rib_object_recording(p))
        return rib_error_at(p, p->req_line, p->req_col, "ObjectEnd without ObjectBegin");
    return object_end(p);
}

/* What the definition may hold, and its blocks' balance: fails on requests it may not hold
 * and on an End without its Begin in the definition. */
static int object_check(rib_parser *p)
{
    struct rib_objects *objs = p->objects;
    const rib_object *o = &objs->open;
    if (strcmp(p->req, "ObjectBegin") == 0 || strcmp(p->req, "ObjectInstance") == 0)
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s inside the definition of the object begun at %d:%d (objects do "
                            "not nest)",
                            p->req, o->line, o->col);
    for (size_t k = 0; k < sizeof object_forbidden / sizeof object_forbidden[0]; k++)
        if (strcmp(p->req, object_forbidden[k]) == 0)
            return rib_error_at(p, p->req_line, p->req_col,
                                "%s inside the definition of the object begun at %d:%d (an "
                                "object holds geometry, transformations and attributes)",
                                p->req, o->line, o->col);
    int begin = strcmp(p->req, "AttributeBegin") == 0 || strcmp(p->req, "TransformBegin") == 0;
    int end = strcmp(p->req, "AttributeEnd") == 0 || strcmp(p->req, "TransformEnd") == 0;
    if (end && objs->blocks == 0)
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s without a matching Begin in the object begun at %d:%d", p->req,
                            o->line, o->col);
    objs->blocks += begin - end;
    if (strcmp(p->req, "MotionBegin") == 0)
        objs->motion_line = p->req_line, objs->motion_col = p->req_col;
    if (strcmp(p->req, "MotionEnd") == 0) objs->motion_line = objs->motion_col = 0;
    return TS_OK;
}

int rib_object_record(rib_parser *p)
{
    struct rib_objects *objs = p->objects;
    if (strcmp(p->req, "ObjectEnd") == 0) return object_end(p);
    int rc = object_check(p);
    if (rc != TS_OK) return rc;
    return rib_saved_list_push(p, &objs->open.reqs);
}

int rib_object_check_file_end(rib_parser *p)
{
    struct rib_objects *objs = p->objects;
    if (!objs || !objs->recording || objs->text != p->lx.text) return TS_OK;
    return rib_error_at(p, objs->open.line, objs->open.col,
                        "ObjectBegin is never closed (missing ObjectEnd)");
}

uint64_t rib_env_bound(const char *name, uint64_t max)
{
    const char *env = getenv(name);
    char *end;
    unsigned long long v = env && *env ? strtoull(env, &end, 10) : 0;
    if (!env || !*env || *end || v >= max) return max;
    return v;
}

uint64_t rib_copies_budget(void)
{
    return rib_env_bound("TESSERA_MAX_INSTANCED_PATCHES", RIB_MAX_INSTANCED_PATCHES);
}

/* Runs the requests of object o where the ObjectInstance stands; *over is set when the
 * patches instances add pass the budget (TS_E_SCENE, no message yet). */
static int object_run(rib_parser *p, const rib_object *o, uint64_t budget, int *over)
{
    const char *file = p->lx.file;
    uint64_t before = p->scene->patch_count;
    int rc = TS_OK;
    p->lx.file = o->file; /* messages and relative paths: where the object was defined */
    for (size_t k = 0; rc == TS_OK && k < o->reqs.count; k++) {
        rc = rib_args_restore(p, &o->reqs.reqs[k]);
        if (rc == TS_OK) rc = rib_dispatch_request(p);
        *over = p->objects->instanced + (p->scene->patch_count - before) > budget;
        if (rc == TS_OK && *over) rc = TS_E_SCENE;
    }
    p->lx.file = file;
    p->objects->instanced += p->scene->patch_count - before;
    return rc;
}

/* Records the patches [first, patch_count) that an instance of o under ctm added: the first
 * instance in the world block becomes o's master; a later one that added as many patches is
 * a run repeating the master's (scene.h ts_instance_run). Instances before WorldBegin are
 * moved to world space afterwards and stay copies. */
static int object_record_run(rib_parser *p, rib_object *o, uint32_t first, const double ctm[16])
{
    uint32_t added = p->scene->patch_count - first;
    if (p->phase != RIB_IN_WORLD || added == 0) return TS_OK;
    if (!o->has_master) {
        o->has_master = 1, o->master_first = first, o->master_count = added;
        memcpy(o->master_ctm, ctm, sizeof o->master_ctm);
        return TS_OK;
    }
    double inv[16], m[16];
    if (added != o->master_count || !mat4_invert(ctm, inv)) return TS_OK;
    memcpy(m, o->master_ctm, sizeof m);
    mat4_concat(m, inv); /* this instance's world -> the object -> the master's world */
    ts_instance_run run = {.first = first, .master_first = o->master_first, .count = added};
    for (int k = 0; k < 12; k++)
        run.to_master[k] = m[k] / m[15];
    return scene_add_instance_run(p->scene, &run, p->err);
}

/* ObjectInstance handle: the object's requests, inside an implicit attribute block. */
int rib_req_object_instance(rib_parser *p)
{
    rib_object key;
    char shown[RIB_PRINT_MAX + 2];
    memset(&key, 0, sizeof key);
    int rc = object_not_running(p);
    if (rc == TS_OK) rc = object_handle(p, &key, shown);
    if (rc != TS_OK) return rc;
    rib_object *o = object_find(p->objects, &key);
    if (!o && p->strict)
        return rib_error_at(p, p->req_line, p->req_col,
                            "ObjectInstance: object %s is not defined (ObjectBegin %s ... "
                            "ObjectEnd must come before)",
                            shown, shown);
    if (!o) { /* RenderMan reports it and goes on: nothing is drawn */
        char what[512];
        snprintf(what, sizeof what,
                 "ObjectInstance: object %s is not defined (ObjectBegin %s ... ObjectEnd must "
                 "come before); nothing drawn (--strict makes this an error)",
                 shown, shown);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    rc = rib_geom_check(p);
    if (rc == TS_OK) rc = rib_attributes_push(p);
    if (rc != TS_OK) return rc;
    int line = p->req_line, col = p->req_col, over = 0;
    const char *file = p->lx.file;
    uint64_t budget = rib_copies_budget();
    uint32_t first = p->scene->patch_count;
    double ctm[16];
    memcpy(ctm, p->ctm, sizeof ctm);
    p->objects->running = 1;
    memcpy(p->objects->running_shown, shown, sizeof shown);
    rc = object_run(p, o, budget, &over);
    p->objects->running = 0;
    if (rc == TS_OK) rc = object_record_run(p, o, first, ctm);
    if (rc == TS_OK) return rib_attributes_pop(p);
    if (over && p->err->code == TS_OK)
        return rib_error_at(p, line, col,
                            "ObjectInstance: instances add more than %llu patches (each instance "
                            "is a copy of its object's patches)",
                            (unsigned long long)budget);
    if (rc == TS_E_SCENE) { /* say which instance ran the request that failed */
        size_t n = strlen(p->err->msg);
        snprintf(p->err->msg + n, sizeof p->err->msg - n, " (in object %s, instanced at %s:%d:%d)",
                 shown, file, line, col);
    }
    return rc;
}
