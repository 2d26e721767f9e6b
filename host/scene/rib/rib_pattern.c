/* rib_pattern.c — Pattern (RenderMan 21-26, RIS): the nodes of a shading network, by handle,
 * and the connections Bxdf and Displace parameters make to them ("reference color
 * diffuseColor" ["tex:resultRGB"]). Tessera draws two kinds of node: PxrTexture (an image,
 * through the scene's textures; RenderMan's own .tex files cannot be read, so a .tx, .exr,
 * .png, .tif or .jpg beside one is used instead) and PxrManifold2D (a scale and offset of
 * st). Any other pattern (an OSL shader) is warned about once and what it feeds keeps its
 * default value. docs/rib.md "RIS shading" has the rules. */
#include "scene/rib/rib_internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define RIB_MAX_PATTERNS 65536 /* Pattern nodes in one parse */

typedef enum pattern_kind { PATTERN_TEXTURE, PATTERN_MANIFOLD, PATTERN_OTHER } pattern_kind;

/* One Pattern request, what Tessera reads of it. */
typedef struct rib_pattern_node {
    char *handle, *type;
    pattern_kind kind;
    char *filename;             /* PxrTexture: the file, as written; NULL: none given */
    int file_line, file_col;    /* of the file name, for messages */
    int invert_t;               /* PxrTexture: t -> 1 - t (RenderMan's default 1) */
    char *manifold;             /* PxrTexture: the handle of its PxrManifold2D, or NULL */
    double scale[2], offset[2]; /* PxrManifold2D: s' = scaleS s + offsetS, likewise t */
} rib_pattern_node;

struct rib_patterns {
    rib_pattern_node *v;
    size_t count, cap;
};

void rib_pattern_free(rib_parser *p)
{
    if (!p->patterns) return;
    for (size_t k = 0; k < p->patterns->count; k++) {
        rib_pattern_node *n = &p->patterns->v[k];
        free(n->handle), free(n->type), free(n->filename), free(n->manifold);
    }
    free(p->patterns->v);
    free(p->patterns);
    p->patterns = NULL;
}

/* The latest node defined with `handle` (a later Pattern replaces an earlier one), or NULL. */
static const rib_pattern_node *pattern_find(const rib_parser *p, const char *handle, size_t len)
{
    if (!p->patterns) return NULL;
    for (size_t k = p->patterns->count; k-- > 0;) {
        const rib_pattern_node *n = &p->patterns->v[k];
        if (strlen(n->handle) == len && strncmp(n->handle, handle, len) == 0) return n;
    }
    return NULL;
}

static int pattern_oom(rib_parser *p)
{
    return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
}

/* A new zeroed node at the end of the table. */
static int pattern_append(rib_parser *p, rib_pattern_node **out)
{
    if (!p->patterns && !(p->patterns = calloc(1, sizeof *p->patterns))) return pattern_oom(p);
    struct rib_patterns *t = p->patterns;
    if (t->count == RIB_MAX_PATTERNS)
        return rib_error_at(p, p->req_line, p->req_col, "Pattern: more than %d nodes",
                            RIB_MAX_PATTERNS);
    if (t->count == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 16;
        rib_pattern_node *v = realloc(t->v, cap * sizeof *v);
        if (!v) return pattern_oom(p);
        t->v = v, t->cap = cap;
    }
    *out = &t->v[t->count++];
    memset(*out, 0, sizeof **out);
    return TS_OK;
}

/* Reads PxrTexture's and PxrManifold2D's parameters into n; others are warned about. */
static int pattern_params(rib_parser *p, rib_pattern_node *n)
{
    char shown[RIB_PRINT_MAX], what[RIB_WARN_KEY];
    for (size_t i = 2; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        const char *str;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int tex = n->kind == PATTERN_TEXTURE, man = n->kind == PATTERN_MANIFOLD;
        if (tex && strcmp(prm.name, "filename") == 0) {
            rc = rib_string_arg(p, i + 1, "a file name", &str);
            if (rc == TS_OK && !(n->filename = strdup(str))) rc = pattern_oom(p);
            n->file_line = prm.val->line, n->file_col = prm.val->col;
        } else if (tex && strcmp(prm.name, "manifold") == 0) {
            rc = rib_string_arg(p, i + 1, "a manifold connection", &str);
            size_t len = rc == TS_OK ? strcspn(str, ":") : 0;
            if (rc == TS_OK && !(n->manifold = malloc(len + 1))) rc = pattern_oom(p);
            if (rc == TS_OK) memcpy(n->manifold, str, len), n->manifold[len] = '\0';
        } else if ((tex && strcmp(prm.name, "invertT") == 0) ||
                   (tex && strcmp(prm.name, "linearize") == 0) ||
                   (tex && strcmp(prm.name, "atlasStyle") == 0)) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            if (prm.name[0] == 'i') n->invert_t = v[0] != 0.0;
            if (prm.name[0] == 'l' && v[0] != 0.0)
                rib_warn_once(p, prm.key->line, prm.key->col,
                              "PxrTexture: \"linearize\" is ignored (texels are used as stored, "
                              "as linear values)");
            if (prm.name[0] == 'a' && v[0] != 0.0)
                rib_warn_once(p, prm.key->line, prm.key->col,
                              "PxrTexture: \"atlasStyle\" (UDIM and other atlases) is not "
                              "supported: the file name is read as one image");
        } else if (man && (strcmp(prm.name, "scaleS") == 0 || strcmp(prm.name, "scaleT") == 0 ||
                           strcmp(prm.name, "offsetS") == 0 || strcmp(prm.name, "offsetT") == 0)) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            if (!(fabs(v[0]) <= 1e30))
                return rib_error_at(p, prm.val->line, prm.val->col,
                                    "PxrManifold2D: %s must be finite, got %g", prm.name, v[0]);
            int t = prm.name[strlen(prm.name) - 1] == 'T';
            if (prm.name[0] == 's')
                n->scale[t] = v[0];
            else
                n->offset[t] = v[0];
        } else {
            snprintf(what, sizeof what, "Pattern \"%s\" parameter \"%s\" is ignored",
                     rib_printable(n->type, shown), prm.name);
            rib_warn_once(p, prm.key->line, prm.key->col, what);
        }
        if (rc != TS_OK) return rc;
    }
    return TS_OK;
}

/* Pattern "type" "handle" params: defines a node of the shading network. PxrTexture and
 * PxrManifold2D are read; other types are kept by handle so that what is connected to them
 * is warned about (once per type) and takes its default. */
int rib_req_pattern(rib_parser *p)
{
    const char *type, *handle;
    int rc = rib_string_arg(p, 0, "a pattern name", &type);
    if (rc == TS_OK) rc = rib_string_arg(p, 1, "a pattern handle", &handle);
    if (rc != TS_OK) return rc;
    if (p->nargs % 2 != 0)
        return rib_error_at(p, p->args[p->nargs - 1].line, p->args[p->nargs - 1].col,
                            "Pattern: a parameter without a value");
    rib_pattern_node *n = NULL;
    rc = pattern_append(p, &n);
    if (rc != TS_OK) return rc;
    n->kind = strcmp(type, "PxrTexture") == 0      ? PATTERN_TEXTURE
              : strcmp(type, "PxrManifold2D") == 0 ? PATTERN_MANIFOLD
                                                   : PATTERN_OTHER;
    n->invert_t = 1;
    n->scale[0] = n->scale[1] = 1.0;
    if (!(n->handle = strdup(handle)) || !(n->type = strdup(type))) return pattern_oom(p);
    if (n->kind == PATTERN_OTHER) return TS_OK; /* warned about where it is connected */
    return pattern_params(p, n);
}

/* Whether the parameter's declaration says "reference" (a connection). */
static int pattern_is_reference(const rib_parser *p, const rib_param *prm)
{
    const char *key = rib_arg_str(p, prm->key, 0);
    for (const char *s = strstr(key, "reference"); s; s = strstr(s + 1, "reference"))
        if ((s == key || s[-1] == ' ') && s[9] == ' ') return 1;
    return 0;
}

/* The texture of PxrTexture node n as kind; *index TS_INVALID when the file is missing
 * (warned, or an error when strict). A RenderMan .tex is replaced by its sibling
 * (rib_texture_sibling). */
static int pattern_texture(rib_parser *p, const rib_pattern_node *n, uint32_t kind,
                           const char *fallback, uint32_t *index)
{
    *index = TS_INVALID;
    if (!n->filename || !n->filename[0]) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what, "PxrTexture \"%s\" has no \"filename\": %s",
                 rib_printable(n->handle, shown), fallback);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    char *use = rib_texture_sibling(p, n->filename);
    if (!use)
        return rib_missing_file(p, n->file_line, n->file_col, "texture ", n->filename,
                                RIB_TEX_NO_SIBLING, fallback);
    int rc = rib_texture_named(p, use, n->file_line, n->file_col, kind, fallback, index);
    free(use);
    return rc;
}

/* The st map of PxrTexture node n: its manifold's scale and offset, then invertT. */
static void pattern_st_map(rib_parser *p, const rib_pattern_node *n, double map[4])
{
    map[0] = 1, map[1] = 0, map[2] = 1, map[3] = 0;
    if (n->manifold) {
        const rib_pattern_node *m = pattern_find(p, n->manifold, strlen(n->manifold));
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        if (m && m->kind == PATTERN_MANIFOLD) {
            map[0] = m->scale[0], map[1] = m->offset[0];
            map[2] = m->scale[1], map[3] = m->offset[1];
        } else {
            snprintf(what, sizeof what,
                     "PxrTexture: manifold \"%s\" is not a PxrManifold2D: the patch's st is used",
                     rib_printable(n->manifold, shown));
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
    }
    if (n->invert_t) map[2] = -map[2], map[3] = 1.0 - map[3];
}

int rib_pattern_link(rib_parser *p, const rib_param *prm, uint32_t kind, const char *fallback,
                     rib_link *out)
{
    memset(out, 0, sizeof *out);
    if (!pattern_is_reference(p, prm)) return TS_OK;
    out->linked = 1;
    const char *to;
    int rc = rib_string_arg(p, (size_t)(prm->val - p->args), "a connection", &to);
    if (rc != TS_OK) return rc;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX], shown2[RIB_PRINT_MAX];
    size_t len = strcspn(to, ":");
    const rib_pattern_node *n = pattern_find(p, to, len);
    if (!n) {
        snprintf(what, sizeof what,
                 "%s: \"%s\" is connected to \"%s\", which no Pattern defines: it keeps its "
                 "default",
                 p->req, rib_printable(prm->name, shown), rib_printable(to, shown2));
        rib_warn_once(p, prm->val->line, prm->val->col, what);
        return TS_OK;
    }
    if (n->kind != PATTERN_TEXTURE) {
        snprintf(what, sizeof what,
                 "Pattern \"%s\" is not supported: the parameters connected to it keep their "
                 "defaults (PxrTexture, PxrManifold2D)",
                 rib_printable(n->type, shown));
        rib_warn_once(p, prm->val->line, prm->val->col, what);
        return TS_OK;
    }
    const char *output = to[len] == ':' ? to + len + 1 : "";
    int wanted = kind == TS_TEX_RGB ? strcmp(output, "resultRGB") == 0
                                    : strcmp(output, "resultR") == 0 || !output[0];
    if (!wanted) {
        snprintf(what, sizeof what, "%s: \"%s\" reads PxrTexture output \"%s\" as %s", p->req,
                 rib_printable(prm->name, shown), rib_printable(output, shown2),
                 kind == TS_TEX_RGB ? "resultRGB" : "resultR (the first channel)");
        rib_warn_once(p, prm->val->line, prm->val->col, what);
    }
    rc = pattern_texture(p, n, kind, fallback, &out->tex);
    if (rc != TS_OK || out->tex == TS_INVALID) return rc;
    out->textured = 1;
    pattern_st_map(p, n, out->st_map);
    return TS_OK;
}
