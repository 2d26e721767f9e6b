/* rib_rlf.c — RenderMan for Maya's look files applied where its RIB asks (RfM 20-22,
 * "RLFInjector"): the RIB holds no material of its own for an object, only comments
 * ("nuggets") that the lexer hands over as RIB_TOK_RLF tokens:
 *
 *   ##RLF ScopeBegin -name perspShape_Final -localbinding 1 -rlffilename dir/x.0001.rlf -namespace
 *   ...  Attribute "identifier" "string name" ["pCube1"]  ...  AttributeBegin
 *        Attribute "identifier" "string name" ["pCubeShape1"]
 *   ##RLF Inject SurfaceShading -attribute sets@,PxrDisney2SG,
 *   ##RLF ScopeEnd -name perspShape_Final
 *
 * At an Inject, the object's identifier path (the "identifier" names of the open attribute
 * blocks, outermost first, joined by '/': "pCube1/pCubeShape1") is looked up in the static
 * bindings (<TightBindings>) of the scope's look file (rib_look.c), and the payload bound to
 * it (Bxdf, Pattern, Displace, Attribute ... requests) runs through the request loop right
 * there, as if it were written in the RIB at the nugget: its requests are scoped by the
 * RIB's attribute blocks, and their messages name the .rlf's own lines. An object with no
 * binding keeps what the RIB gives it (RfM's default Bxdf). The look file is the one
 * -rlffilename names (beside the RIB, in the working directory, on the "archive" search
 * path), else the RIB's own name with .rlf; a missing or malformed one is rib_missing_file's
 * warning (an error when strict) and its scope injects nothing. docs/rib.md "RenderMan for
 * Maya's look files" has the rules. */
#include "scene/rib/rib_internal.h"
#include "scene/rib/rib_look.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define RLF_MAX_WORDS 32 /* words of one nugget read */
#define RLF_MAX_PATH 65536

/* An identifier name and the depth of the attribute block that set it. */
typedef struct rlf_id {
    size_t depth;
    char *name;
} rlf_id;

/* An open ScopeBegin: its look file, when it could be read. */
typedef struct rlf_scope {
    int loaded;
    rib_look look;
    char *file; /* the look file's path: payload messages name it */
} rlf_scope;

struct rib_rlf {
    rlf_id *ids;
    size_t nids, cap_ids;
    rlf_scope scopes[RIB_MAX_INCLUDE];
    size_t nscopes;
    int injecting; /* a payload runs: nuggets inside it are ignored */
};

static int rlf_state(rib_parser *p)
{
    if (p->rlf) return TS_OK;
    p->rlf = calloc(1, sizeof *p->rlf);
    return p->rlf ? TS_OK : ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
}

static void rlf_scope_free(rlf_scope *s)
{
    rib_look_free(&s->look);
    free(s->file);
    memset(s, 0, sizeof *s);
}

void rib_rlf_free(rib_parser *p)
{
    if (!p->rlf) return;
    for (size_t i = 0; i < p->rlf->nids; i++)
        free(p->rlf->ids[i].name);
    free(p->rlf->ids);
    for (size_t i = 0; i < p->rlf->nscopes; i++)
        rlf_scope_free(&p->rlf->scopes[i]);
    free(p->rlf);
    p->rlf = NULL;
}

/* ---- identifier paths ------------------------------------------------------------------- */

/* The depth of the innermost block that saves attributes (TransformBegin does not). */
static size_t rlf_attribute_depth(const rib_parser *p)
{
    size_t d = p->depth;
    while (d > 0 && p->stack[d - 1].kind == RIB_FRAME_TRANSFORM)
        d--;
    return d;
}

int rib_rlf_identifier(rib_parser *p, const char *name)
{
    int rc = rlf_state(p);
    if (rc != TS_OK) return rc;
    struct rib_rlf *r = p->rlf;
    size_t depth = rlf_attribute_depth(p);
    char *copy = strdup(name);
    if (!copy) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    if (r->nids && r->ids[r->nids - 1].depth == depth) { /* the block's name, replaced */
        free(r->ids[r->nids - 1].name);
        r->ids[r->nids - 1].name = copy;
        return TS_OK;
    }
    if (r->nids == r->cap_ids) {
        size_t cap = r->cap_ids ? 2 * r->cap_ids : 16;
        rlf_id *ids = realloc(r->ids, cap * sizeof *ids);
        if (!ids) {
            free(copy);
            return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        }
        r->ids = ids, r->cap_ids = cap;
    }
    r->ids[r->nids++] = (rlf_id){depth, copy};
    return TS_OK;
}

void rib_rlf_scope_end(rib_parser *p)
{
    struct rib_rlf *r = p->rlf;
    while (r && r->nids && r->ids[r->nids - 1].depth > p->depth)
        free(r->ids[--r->nids].name);
}

/* The identifier path of the current object into buf (cap bytes): 0 when it does not fit. */
static int rlf_path(const struct rib_rlf *r, char *buf, size_t cap)
{
    size_t n = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < r->nids; i++) {
        size_t k = strlen(r->ids[i].name);
        if (n + k + 2 > cap) return 0;
        if (i) buf[n++] = '/';
        memcpy(buf + n, r->ids[i].name, k + 1);
        n += k;
    }
    return 1;
}

/* ---- the nuggets ------------------------------------------------------------------------ */

/* The value after option `flag` ("-rlffilename") among the words, "" when it has none, NULL
 * when the flag is absent. */
static const char *rlf_option(char **w, int n, const char *flag)
{
    for (int i = 1; i < n; i++)
        if (strcmp(w[i], flag) == 0) return i + 1 < n && w[i + 1][0] != '-' ? w[i + 1] : "";
    return NULL;
}

/* The RIB file's own name with its extension replaced by .rlf (malloc'd), or NULL. */
static char *rlf_sibling(const rib_parser *p)
{
    const char *file = p->lx.file, *slash = strrchr(file, '/'), *dot = strrchr(file, '.');
    size_t n = dot && (!slash || dot > slash) ? (size_t)(dot - file) : strlen(file);
    char *s = malloc(n + 5);
    if (s) memcpy(s, file, n), memcpy(s + n, ".rlf", 5);
    return s;
}

/* Reads the scope's look file: -rlffilename `name` found as archives are (rib_resolve_in),
 * else the RIB's sibling .rlf; missing or malformed: rib_missing_file's warning or error. */
static int rlf_load(rib_parser *p, rlf_scope *s, const char *name, int line, int col)
{
    char *path = name && name[0] ? rib_resolve_in(p, name, 0) : rlf_sibling(p);
    if (!path) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    if (access(path, F_OK) != 0 && name && name[0]) { /* not there: the RIB's own .rlf */
        char *sib = rlf_sibling(p);
        if (sib && access(sib, F_OK) == 0)
            free(path), path = sib;
        else
            free(sib);
    }
    char why[1024];
    int absent;
    int rc = rib_look_read(path, &s->look, &absent, why, sizeof why);
    if (rc == TS_OK) {
        s->loaded = 1;
        s->file = path;
        return TS_OK;
    }
    if (rc == TS_E_MEMORY) {
        free(path);
        return ts_error_set(p->err, rc, "%s: out of memory", p->lx.file);
    }
    rc = rib_missing_file(p, line, col, "look file ", path, why,
                          "the objects of its scope keep the shading the RIB gives them");
    free(path);
    return rc;
}

/* Warnings about what a look file holds that is not applied. */
static void rlf_warn_unread(rib_parser *p, const rlf_scope *s, int line, int col)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    if (s->look.nrules) {
        snprintf(what, sizeof what,
                 "look file \"%s\": its %zu dynamic rules (RuleSet, XPath) are not applied, "
                 "only its static bindings",
                 rib_printable(s->file, shown), s->look.nrules);
        rib_warn_once(p, line, col, what);
    }
    if (s->look.other[0]) {
        snprintf(what, sizeof what, "look file \"%s\": <%s> is not read",
                 rib_printable(s->file, shown), s->look.other);
        rib_warn_once(p, line, col, what);
    }
}

static int rlf_scope_begin(rib_parser *p, char **w, int n, int line, int col)
{
    struct rib_rlf *r = p->rlf;
    if (r->nscopes == RIB_MAX_INCLUDE)
        return rib_error_at(p, line, col, "##RLF ScopeBegin: scopes nested deeper than %d",
                            RIB_MAX_INCLUDE);
    rlf_scope *s = &r->scopes[r->nscopes++];
    memset(s, 0, sizeof *s);
    const char *ns = rlf_option(w, n, "-namespace");
    if (ns && ns[0]) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what,
                 "##RLF ScopeBegin: -namespace \"%s\" is not applied (keys are matched without it)",
                 rib_printable(ns, shown));
        rib_warn_once(p, line, col, what);
    }
    int rc = rlf_load(p, s, rlf_option(w, n, "-rlffilename"), line, col);
    if (rc == TS_OK && s->loaded) rlf_warn_unread(p, s, line, col);
    return rc;
}

static int rlf_scope_end(rib_parser *p, int line, int col)
{
    struct rib_rlf *r = p->rlf;
    if (r->nscopes == 0) {
        rib_warn_once(p, line, col, "##RLF ScopeEnd without ##RLF ScopeBegin is ignored");
        return TS_OK;
    }
    rlf_scope_free(&r->scopes[--r->nscopes]);
    return TS_OK;
}

/* Runs the payload's requests at the nugget, on a lexer over its text positioned at the
 * look file's line and column of it. */
static int rlf_run_payload(rib_parser *p, const rlf_scope *s, const rib_look_payload *pl)
{
    rib_lexer saved = p->lx;
    rib_lex_init(&p->lx, s->file, pl->text, pl->len, p->err);
    p->lx.line = pl->line, p->lx.col = pl->col;
    p->rlf->injecting = 1;
    int rc = rib_run_requests(p);
    p->rlf->injecting = 0;
    rib_lex_free(&p->lx);
    p->lx = saved;
    return rc;
}

static int rlf_inject(rib_parser *p, char **w, int n, int line, int col)
{
    struct rib_rlf *r = p->rlf;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    if (n < 2 || strcmp(w[1], "SurfaceShading") != 0) {
        snprintf(what, sizeof what, "##RLF Inject %s is not applied (SurfaceShading is)",
                 n < 2 ? "without a kind" : rib_printable(w[1], shown));
        rib_warn_once(p, line, col, what);
        return TS_OK;
    }
    if (r->nscopes == 0) {
        rib_warn_once(p, line, col,
                      "##RLF Inject outside ##RLF ScopeBegin ... ScopeEnd: no look file, nothing "
                      "injected");
        return TS_OK;
    }
    const rlf_scope *s = &r->scopes[r->nscopes - 1];
    if (!s->loaded) return TS_OK; /* warned at ScopeBegin */
    char *path = malloc(RLF_MAX_PATH);
    if (!path) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    int rc = TS_OK;
    if (!rlf_path(r, path, RLF_MAX_PATH)) {
        rc = rib_error_at(p, line, col, "##RLF Inject: the identifier path is longer than %d bytes",
                          RLF_MAX_PATH - 1);
    } else {
        const rib_look_payload *pl = rib_look_bound(&s->look, path);
        if (pl) rc = rlf_run_payload(p, s, pl); /* unbound: the RIB's own shading */
    }
    free(path);
    return rc;
}

/* Splits text (modified) at blanks into at most RLF_MAX_WORDS words. */
static int rlf_words(char *text, char **w)
{
    int n = 0;
    char *save = NULL;
    for (char *t = strtok_r(text, " \t", &save); t && n < RLF_MAX_WORDS;
         t = strtok_r(NULL, " \t", &save))
        w[n++] = t;
    return n;
}

int rib_rlf_nugget(rib_parser *p, const rib_token *t)
{
    if (rib_frames_skip(p) || rib_cond_skip(p)) return TS_OK; /* as a request there would be */
    int rc = rlf_state(p);
    if (rc != TS_OK) return rc;
    if (p->rlf->injecting) {
        rib_warn_once(p, t->line, t->col, "##RLF nuggets inside a look file's payload are ignored");
        return TS_OK;
    }
    char *text = malloc(t->len + 1), *w[RLF_MAX_WORDS];
    if (!text) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    memcpy(text, t->str, t->len + 1);
    int n = rlf_words(text, w);
    int line = t->line, col = t->col;
    snprintf(p->req, sizeof p->req, "##RLF %.32s", n ? w[0] : "");
    p->req_line = line, p->req_col = col;
    if (rib_object_recording(p)) {
        rib_warn_once(p, line, col, "##RLF nuggets inside ObjectBegin ... ObjectEnd are ignored");
    } else if (n && strcmp(w[0], "ScopeBegin") == 0) {
        rc = rlf_scope_begin(p, w, n, line, col);
    } else if (n && strcmp(w[0], "ScopeEnd") == 0) {
        rc = rlf_scope_end(p, line, col);
    } else if (n && strcmp(w[0], "Inject") == 0) {
        rc = rlf_inject(p, w, n, line, col);
    } else {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what, "##RLF %s is ignored (ScopeBegin, ScopeEnd, Inject)",
                 rib_printable(n ? w[0] : "", shown));
        rib_warn_once(p, line, col, what);
    }
    free(text);
    return rc;
}
