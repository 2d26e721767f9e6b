/* rib_look.c — reads a RenderMan Look File (.rlf; rib_look.h) with expat. The format is XML
 * (RenderMan for Maya 20-22 writes ISO-8859-1 with CDATA payloads), so it is read by a real
 * XML parser rather than by hand: expat (Debian libexpat1-dev) is small, strict, streams,
 * decodes ISO-8859-1, UTF-8 and UTF-16 itself, reports errors at line and column, loads no
 * external entity and bounds entity expansion (billion laughs) by default. What is kept:
 *
 *   <RenderManLookFile ...>
 *     <InjectablePayloads> <Payload Id="SG"><![CDATA[ RIB ]]></Payload> ... </InjectablePayloads>
 *     <TightBindings> <Binding Key="pCube1/pCubeShape1" PayloadId="SG"/> ... </TightBindings>
 *     <RuleSet> <Rule ...>XPath</Rule> ... </RuleSet>   (counted: rib_rlf.c warns)
 *   </RenderManLookFile>
 */
#include "scene/rib/rib_look.h"

#include "base/error.h"
#include "base/file.h"

#include <expat.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <limits.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Where the reader is: the elements that matter, by depth. */
typedef enum look_place {
    LOOK_OUTSIDE,  /* before the root */
    LOOK_ROOT,     /* in RenderManLookFile */
    LOOK_PAYLOADS, /* in InjectablePayloads */
    LOOK_BINDINGS, /* in TightBindings */
    LOOK_RULES,    /* in RuleSet */
    LOOK_PAYLOAD,  /* in a Payload: its text */
    LOOK_SKIP,     /* in an element not read (and anything under it) */
} look_place;

#define LOOK_MAX_DEPTH 64

/* A binding as read, before its PayloadId is resolved. */
typedef struct look_ref {
    char *payload_id;
    int line, col;
} look_ref;

typedef struct look_reader {
    XML_Parser x;
    const char *path;
    rib_look *look;
    look_place stack[LOOK_MAX_DEPTH];
    int depth;
    look_ref *refs; /* parallel to look->bindings while reading */
    size_t cap_payloads, cap_bindings, text_cap;
    int failed; /* why holds the message (or out of memory: rc) */
    int rc;
    char *why;
    size_t why_cap;
} look_reader;

/* Stops the parse with "PATH:LINE:COL: message" at expat's current position. */
static void look_fail(look_reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void look_fail(look_reader *r, const char *fmt, ...)
{
    if (r->failed) return;
    r->failed = 1;
    r->rc = TS_E_SCENE;
    int n = snprintf(r->why, r->why_cap, "%s:%lu:%lu: ", r->path,
                     (unsigned long)XML_GetCurrentLineNumber(r->x),
                     (unsigned long)XML_GetCurrentColumnNumber(r->x) + 1);
    if (n >= 0 && (size_t)n < r->why_cap) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(r->why + n, r->why_cap - (size_t)n, fmt, ap);
        va_end(ap);
    }
    XML_StopParser(r->x, XML_FALSE);
}

static void look_out_of_memory(look_reader *r)
{
    if (r->failed) return;
    r->failed = 1;
    r->rc = TS_E_MEMORY;
    snprintf(r->why, r->why_cap, "out of memory");
    XML_StopParser(r->x, XML_FALSE);
}

/* The value of attribute `name` in expat's name/value list, or NULL. */
static const char *look_attr(const XML_Char **attrs, const char *name)
{
    for (size_t i = 0; attrs[i]; i += 2)
        if (strcmp(attrs[i], name) == 0) return attrs[i + 1];
    return NULL;
}

/* Grows *buf (elements of `elem` bytes, *cap of them) to hold n + 1. */
static int look_reserve(look_reader *r, void **buf, size_t *cap, size_t n, size_t elem)
{
    if (n >= RIB_LOOK_MAX_ITEMS) {
        look_fail(r, "more than %u payloads or bindings", RIB_LOOK_MAX_ITEMS);
        return 0;
    }
    if (n < *cap) return 1;
    size_t c = *cap ? *cap * 2 : 16;
    void *b = realloc(*buf, c * elem);
    if (!b) {
        look_out_of_memory(r);
        return 0;
    }
    *buf = b;
    *cap = c;
    return 1;
}

static void look_start_payload(look_reader *r, const XML_Char **attrs)
{
    rib_look *k = r->look;
    const char *id = look_attr(attrs, "Id");
    if (!id) {
        look_fail(r, "a Payload without an Id");
        return;
    }
    if (!look_reserve(r, (void **)&k->payloads, &r->cap_payloads, k->npayloads,
                      sizeof *k->payloads))
        return;
    rib_look_payload *pl = &k->payloads[k->npayloads];
    *pl = (rib_look_payload){0};
    pl->text = calloc(1, 1);
    pl->id = strdup(id);
    if (!pl->id || !pl->text) {
        free(pl->id), free(pl->text);
        look_out_of_memory(r);
        return;
    }
    pl->id_line = (int)XML_GetCurrentLineNumber(r->x);
    pl->id_col = (int)XML_GetCurrentColumnNumber(r->x) + 1;
    k->npayloads++;
    r->text_cap = 1;
}

static void look_start_binding(look_reader *r, const XML_Char **attrs)
{
    rib_look *k = r->look;
    const char *key = look_attr(attrs, "Key"), *id = look_attr(attrs, "PayloadId");
    if (!key || !id) {
        look_fail(r, "a Binding without a Key or a PayloadId");
        return;
    }
    size_t cap = r->cap_bindings;
    if (!look_reserve(r, (void **)&k->bindings, &r->cap_bindings, k->nbindings,
                      sizeof *k->bindings))
        return;
    if (r->cap_bindings != cap) { /* refs grows with bindings */
        look_ref *g = realloc(r->refs, r->cap_bindings * sizeof *g);
        if (!g) {
            look_out_of_memory(r);
            return;
        }
        r->refs = g;
    }
    rib_look_binding *b = &k->bindings[k->nbindings];
    look_ref *f = &r->refs[k->nbindings];
    b->key = strdup(key);
    f->payload_id = strdup(id);
    if (!b->key || !f->payload_id) {
        free(b->key), free(f->payload_id);
        {
            look_out_of_memory(r);
            return;
        }
    }
    b->order = k->nbindings;
    f->line = (int)XML_GetCurrentLineNumber(r->x);
    f->col = (int)XML_GetCurrentColumnNumber(r->x) + 1;
    k->nbindings++;
}

/* What an element opens, given where it stands. */
static look_place look_child(look_reader *r, look_place at, const char *name,
                             const XML_Char **attrs)
{
    switch (at) {
    case LOOK_OUTSIDE:
        if (strcmp(name, "RenderManLookFile") != 0)
            look_fail(r, "the root element is <%.100s>, not <RenderManLookFile>", name);
        return LOOK_ROOT;
    case LOOK_ROOT:
        if (strcmp(name, "InjectablePayloads") == 0) return LOOK_PAYLOADS;
        if (strcmp(name, "TightBindings") == 0) return LOOK_BINDINGS;
        if (strcmp(name, "RuleSet") == 0) return LOOK_RULES;
        break;
    case LOOK_PAYLOADS:
        if (strcmp(name, "Payload") != 0) break;
        look_start_payload(r, attrs);
        return LOOK_PAYLOAD;
    case LOOK_BINDINGS:
        if (strcmp(name, "Binding") != 0) break;
        look_start_binding(r, attrs);
        return LOOK_SKIP;
    case LOOK_RULES:
        if (strcmp(name, "Rule") == 0) r->look->nrules++;
        return LOOK_SKIP;
    case LOOK_PAYLOAD:
        look_fail(r, "an element <%.100s> inside a Payload (its RIB text)", name);
        return LOOK_SKIP;
    case LOOK_SKIP:
        return LOOK_SKIP;
    }
    if (!r->look->other[0]) snprintf(r->look->other, sizeof r->look->other, "%s", name);
    return LOOK_SKIP;
}

static void XMLCALL look_on_start(void *data, const XML_Char *name, const XML_Char **attrs)
{
    look_reader *r = data;
    if (r->failed) return;
    if (r->depth >= LOOK_MAX_DEPTH) {
        look_fail(r, "elements nested deeper than %d levels", LOOK_MAX_DEPTH);
        return;
    }
    look_place at = r->depth ? r->stack[r->depth - 1] : LOOK_OUTSIDE;
    r->stack[r->depth++] = look_child(r, at, name, attrs);
}

static void XMLCALL look_on_end(void *data, const XML_Char *name)
{
    look_reader *r = data;
    if (r->depth > 0) r->depth--;
}

/* Character data: appended to the open Payload's text; elsewhere ignored (indentation). */
static void XMLCALL look_on_text(void *data, const XML_Char *s, int n)
{
    look_reader *r = data;
    if (r->failed || r->depth == 0 || r->stack[r->depth - 1] != LOOK_PAYLOAD) return;
    rib_look_payload *pl = &r->look->payloads[r->look->npayloads - 1];
    if (pl->line == 0) { /* where the text starts: its first requests' positions */
        pl->line = (int)XML_GetCurrentLineNumber(r->x);
        pl->col = (int)XML_GetCurrentColumnNumber(r->x) + 1;
    }
    if (pl->len + (size_t)n + 1 > r->text_cap) {
        size_t c = r->text_cap * 2;
        while (c < pl->len + (size_t)n + 1)
            c *= 2;
        char *t = realloc(pl->text, c);
        if (!t) {
            look_out_of_memory(r);
            return;
        }
        pl->text = t;
        r->text_cap = c;
    }
    memcpy(pl->text + pl->len, s, (size_t)n);
    pl->len += (size_t)n;
    pl->text[pl->len] = '\0';
}

static int look_cmp_binding(const void *a, const void *b)
{
    const rib_look_binding *x = a, *y = b;
    int c = strcmp(x->key, y->key);
    return c ? c : (x->order > y->order) - (x->order < y->order);
}

/* Payload indices ordered by Id (qsort_r over the payloads `base`). */
static int look_cmp_index(const void *a, const void *b, void *base)
{
    const size_t *x = a, *y = b;
    const rib_look_payload *pl = base;
    int c = strcmp(pl[*x].id, pl[*y].id);
    return c ? c : (*x > *y) - (*x < *y);
}

/* The payload named id, by binary search over the indices sorted by Id; npayloads if none. */
static size_t look_find(const rib_look *k, const size_t *by_id, const char *id)
{
    size_t lo = 0, hi = k->npayloads;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        int c = strcmp(k->payloads[by_id[mid]].id, id);
        if (c == 0) return by_id[mid];
        if (c < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return k->npayloads;
}

/* Payload Ids must be unique; each binding's PayloadId is resolved to its payload; then the
 * bindings are sorted for rib_look_bound. O((payloads + bindings) log payloads). */
static int look_resolve(look_reader *r)
{
    rib_look *k = r->look;
    size_t *by_id = malloc((k->npayloads + 1) * sizeof *by_id);
    if (!by_id) {
        snprintf(r->why, r->why_cap, "out of memory");
        return TS_E_MEMORY;
    }
    for (size_t i = 0; i < k->npayloads; i++)
        by_id[i] = i;
    qsort_r(by_id, k->npayloads, sizeof *by_id, look_cmp_index, k->payloads);
    int rc = TS_OK;
    for (size_t i = 1; rc == TS_OK && i < k->npayloads; i++) {
        const rib_look_payload *a = &k->payloads[by_id[i - 1]], *b = &k->payloads[by_id[i]];
        if (strcmp(a->id, b->id) == 0) {
            snprintf(r->why, r->why_cap,
                     "%s:%d:%d: Payload \"%.200s\" is defined twice (first at %d:%d)", r->path,
                     b->id_line, b->id_col, b->id, a->id_line, a->id_col);
            rc = TS_E_SCENE;
        }
    }
    for (size_t b = 0; rc == TS_OK && b < k->nbindings; b++) {
        size_t i = look_find(k, by_id, r->refs[b].payload_id);
        if (i == k->npayloads) {
            snprintf(r->why, r->why_cap,
                     "%s:%d:%d: Binding \"%.200s\" names payload \"%.200s\", which the file "
                     "does not define",
                     r->path, r->refs[b].line, r->refs[b].col, k->bindings[b].key,
                     r->refs[b].payload_id);
            rc = TS_E_SCENE;
        }
        k->bindings[b].payload = i;
    }
    free(by_id);
    if (rc == TS_OK && k->nbindings)
        qsort(k->bindings, k->nbindings, sizeof *k->bindings, look_cmp_binding);
    return rc;
}

/* Parses text (len bytes) into r->look. */
static int look_parse(look_reader *r, const char *text, size_t len)
{
    r->x = XML_ParserCreate(NULL);
    if (!r->x) {
        snprintf(r->why, r->why_cap, "out of memory");
        return TS_E_MEMORY;
    }
    XML_SetUserData(r->x, r);
    XML_SetElementHandler(r->x, look_on_start, look_on_end);
    XML_SetCharacterDataHandler(r->x, look_on_text);
    int rc = TS_OK;
    if (len > (size_t)INT_MAX || XML_Parse(r->x, text, (int)len, 1) == XML_STATUS_ERROR) {
        if (r->failed) {
            rc = r->rc;
        } else {
            snprintf(r->why, r->why_cap, "%s:%lu:%lu: XML: %s", r->path,
                     (unsigned long)XML_GetCurrentLineNumber(r->x),
                     (unsigned long)XML_GetCurrentColumnNumber(r->x) + 1,
                     XML_ErrorString(XML_GetErrorCode(r->x)));
            rc = TS_E_SCENE;
        }
    }
    XML_ParserFree(r->x);
    return rc == TS_OK ? look_resolve(r) : rc;
}

int rib_look_read(const char *path, rib_look *look, int *absent, char *why, size_t cap)
{
    memset(look, 0, sizeof *look);
    *absent = 0;
    struct stat st; /* the size before reading: a huge file is refused, not read */
    if (stat(path, &st) == 0 && S_ISREG(st.st_mode) && (uint64_t)st.st_size > RIB_LOOK_MAX_BYTES) {
        snprintf(why, cap, "%s: larger than %zu MiB", path, RIB_LOOK_MAX_BYTES >> 20);
        return TS_E_SCENE;
    }
    char *text;
    size_t len;
    int rc = ts_file_read_all(path, &text, &len, why, cap);
    if (rc != TS_OK) {
        *absent = rc == TS_E_IO && access(path, F_OK) != 0;
        return rc;
    }
    if (len > RIB_LOOK_MAX_BYTES) { /* grown since the stat */
        free(text);
        snprintf(why, cap, "%s: larger than %zu MiB", path, RIB_LOOK_MAX_BYTES >> 20);
        return TS_E_SCENE;
    }
    look_reader r = {.path = path, .look = look, .why = why, .why_cap = cap};
    rc = look_parse(&r, text, len);
    for (size_t b = 0; r.refs && b < look->nbindings; b++)
        free(r.refs[b].payload_id);
    free(r.refs);
    free(text);
    if (rc != TS_OK) rib_look_free(look);
    return rc;
}

const rib_look_payload *rib_look_bound(const rib_look *look, const char *key)
{
    size_t lo = 0, hi = look->nbindings; /* the last of the equal keys: the later binding */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (strcmp(look->bindings[mid].key, key) <= 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo == 0 || strcmp(look->bindings[lo - 1].key, key) != 0) return NULL;
    return &look->payloads[look->bindings[lo - 1].payload];
}

void rib_look_free(rib_look *look)
{
    for (size_t i = 0; i < look->npayloads; i++)
        free(look->payloads[i].id), free(look->payloads[i].text);
    for (size_t b = 0; b < look->nbindings; b++)
        free(look->bindings[b].key);
    free(look->payloads);
    free(look->bindings);
    memset(look, 0, sizeof *look);
}
