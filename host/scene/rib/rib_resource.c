/* rib_resource.c — RenderMan's attribute resources (RenderMan 21-26 RIB, docs/rib.md
 * "Resources"):
 *
 *   Resource "name" "attributes" "string operation" ["save"]
 *   Resource "name" "attributes" "string operation" ["restore"] ["string subset" ["s,..."]]
 *   ResourceBegin ... ResourceEnd
 *
 * "save" keeps the current state under the name (what AttributeBegin saves: the CTM of both
 * time samples, colour, bases, displacement, surface, emission, opacity); "restore" puts it
 * back, whole ("all", the default) or the subsets named, comma separated: "transform" (the
 * CTM), "shading" (colour, surface, emission, opacity, displacement), "geometrymodification"
 * (displacement), "geometrydefinition" (bases); "visibility" and "hiding" hold nothing
 * Tessera keeps. A save inside ResourceBegin/ResourceEnd is forgotten at ResourceEnd (an
 * earlier save of the same name shows again). Resource types other than "attributes" are
 * ignored with a warning; restoring a name never saved is an error. */
#include "scene/rib/rib_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RIB_MAX_RESOURCES 65536 /* saved at once */

typedef struct rib_saved {
    char *name;
    rib_frame state;
} rib_saved;

struct rib_resources {
    rib_saved *v;
    size_t count, cap;
    size_t *scopes; /* count at each open ResourceBegin */
    size_t nscopes, scopes_cap;
};

static struct rib_resources *resources(rib_parser *p)
{
    if (!p->resources) p->resources = calloc(1, sizeof *p->resources);
    return p->resources;
}

void rib_resource_free(rib_parser *p)
{
    if (!p->resources) return;
    for (size_t k = 0; k < p->resources->count; k++)
        free(p->resources->v[k].name);
    free(p->resources->v);
    free(p->resources->scopes);
    free(p->resources);
    p->resources = NULL;
}

int rib_req_resource_begin(rib_parser *p)
{
    int rc = rib_no_more(p, 0);
    struct rib_resources *r = rc == TS_OK ? resources(p) : NULL;
    if (rc != TS_OK) return rc;
    if (r && r->nscopes == r->scopes_cap) {
        size_t cap = r->scopes_cap ? 2 * r->scopes_cap : 8;
        size_t *s = cap <= RIB_MAX_DEPTH ? realloc(r->scopes, cap * sizeof *s) : NULL;
        if (s) r->scopes = s, r->scopes_cap = cap;
    }
    if (!r || r->nscopes == r->scopes_cap)
        return r && r->scopes_cap >= RIB_MAX_DEPTH
                   ? rib_error_at(p, p->req_line, p->req_col,
                                  "ResourceBegin nested deeper than %d levels", RIB_MAX_DEPTH)
                   : ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    r->scopes[r->nscopes++] = r->count;
    return TS_OK;
}

int rib_req_resource_end(rib_parser *p)
{
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    struct rib_resources *r = p->resources;
    if (!r || r->nscopes == 0)
        return rib_error_at(p, p->req_line, p->req_col, "ResourceEnd without a ResourceBegin");
    size_t keep = r->scopes[--r->nscopes];
    while (r->count > keep)
        free(r->v[--r->count].name);
    return TS_OK;
}

/* The saved state `name`, the latest save first; NULL when there is none. */
static const rib_saved *find(const rib_parser *p, const char *name)
{
    if (!p->resources) return NULL;
    for (size_t k = p->resources->count; k-- > 0;)
        if (strcmp(p->resources->v[k].name, name) == 0) return &p->resources->v[k];
    return NULL;
}

static int save(rib_parser *p, const char *name)
{
    struct rib_resources *r = resources(p);
    if (r && r->count == r->cap) {
        size_t cap = r->cap ? 2 * r->cap : 16;
        rib_saved *v = cap <= RIB_MAX_RESOURCES ? realloc(r->v, cap * sizeof *v) : NULL;
        if (v) r->v = v, r->cap = cap;
    }
    if (r && r->count == r->cap && r->cap >= RIB_MAX_RESOURCES)
        return rib_error_at(p, p->req_line, p->req_col, "more than %d resources saved at once",
                            RIB_MAX_RESOURCES);
    char *copy = r && r->count < r->cap ? strdup(name) : NULL;
    if (!copy) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    rib_saved *s = &r->v[r->count++];
    s->name = copy;
    rib_state_save(p, &s->state);
    return TS_OK;
}

/* Restores the subsets named in `subset` (comma separated) of the saved state f. */
static int restore(rib_parser *p, const rib_frame *f, const char *subset, const rib_arg *at)
{
    char shown[RIB_PRINT_MAX];
    const char *s = subset;
    while (*s) {
        size_t n = strcspn(s, ",");
        char word[64] = "";
        if (n < sizeof word) memcpy(word, s, n), word[n] = '\0';
        if (strcmp(word, "all") == 0) {
            rib_state_restore(p, f, 1);
        } else if (strcmp(word, "transform") == 0) {
            rib_state_restore(p, f, 0);
        } else if (strcmp(word, "shading") == 0) {
            memcpy(p->color, f->color, sizeof p->color);
            p->surface = f->surface;
            memcpy(p->emission, f->emission, sizeof p->emission);
            memcpy(p->opacity, f->opacity, sizeof p->opacity);
            p->disp = f->disp;
        } else if (strcmp(word, "geometrymodification") == 0) {
            p->disp = f->disp;
        } else if (strcmp(word, "geometrydefinition") == 0) {
            p->ubasis = f->ubasis;
            p->vbasis = f->vbasis;
        } else if (strcmp(word, "visibility") != 0 && strcmp(word, "hiding") != 0) {
            char what[RIB_WARN_KEY];
            snprintf(what, sizeof what, "Resource: subset \"%s\" is not known and restores nothing",
                     rib_printable(word, shown));
            rib_warn_once(p, at->line, at->col, what);
        }
        s += n + (s[n] == ',');
    }
    return TS_OK;
}

int rib_req_resource(rib_parser *p)
{
    const char *name, *type;
    char shown[RIB_PRINT_MAX], what[RIB_WARN_KEY];
    int rc = rib_string_arg(p, 0, "a resource name", &name);
    if (rc == TS_OK) rc = rib_string_arg(p, 1, "a resource type", &type);
    if (rc != TS_OK) return rc;
    if (strcmp(type, "attributes") != 0) {
        snprintf(what, sizeof what, "Resource type \"%s\" is ignored (only \"attributes\")",
                 rib_printable(type, shown));
        rib_warn_once(p, p->args[1].line, p->args[1].col, what);
        return TS_OK;
    }
    const char *operation = NULL, *subset = "all";
    const rib_arg *op_at = &p->args[1], *subset_at = &p->args[1];
    for (size_t i = 2; i < p->nargs; i += 2) {
        rib_param prm;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int is_op = strcmp(prm.name, "operation") == 0, is_subset = strcmp(prm.name, "subset") == 0;
        if (!is_op && !is_subset) {
            rib_warn_param(p, &prm);
            continue;
        }
        if (prm.val->kind != RIB_ARG_STRINGS && prm.val->kind != RIB_ARG_STRING)
            return rib_error_at(p, prm.val->line, prm.val->col, "Resource: \"%s\" takes a string",
                                prm.name);
        if (is_op) operation = rib_arg_str(p, prm.val, 0), op_at = prm.val;
        if (is_subset) subset = rib_arg_str(p, prm.val, 0), subset_at = prm.val;
    }
    if (!operation)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Resource \"%s\": missing \"string operation\" (save or restore)",
                            rib_printable(name, shown));
    if (strcmp(operation, "save") == 0) return save(p, name);
    if (strcmp(operation, "restore") != 0)
        return rib_error_at(p, op_at->line, op_at->col,
                            "Resource: operation \"%s\" is not save or restore",
                            rib_printable(operation, shown));
    const rib_saved *s = find(p, name);
    if (!s)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "Resource \"%s\" is restored but was never saved (or its "
                            "ResourceBegin block has ended)",
                            rib_printable(name, shown));
    return restore(p, &s->state, subset, subset_at);
}
