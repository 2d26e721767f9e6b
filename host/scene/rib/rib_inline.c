/* rib_inline.c — inline archives (RenderMan's RiArchiveBegin, as its Python and C APIs write
 * them): ArchiveBegin "name" ... ArchiveEnd records the requests between without running
 * them, and ReadArchive "name" runs them where it stands, as it reads a file: in place, the
 * graphics state flowing in and out. An archive may hold any request, nested ArchiveBegin
 * blocks included (recorded, so defined when the archive is read); it ends in the file it
 * begins in. Defining a name again replaces the archive; an archive that reads itself,
 * directly or not, is an error, and so is redefining one while it is being read. */
#include "scene/rib/rib_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One inline archive: its name and the requests between its ArchiveBegin and ArchiveEnd. */
typedef struct rib_inline_archive {
    char *name;
    char *file;    /* the file it was defined in: messages and relative paths when it runs */
    int line, col; /* of its ArchiveBegin */
    rib_saved_list reqs;
    int reading; /* its requests are running (ReadArchive): redefining or reading it again fails */
} rib_inline_archive;

struct rib_inlines {
    rib_inline_archive *list;
    size_t count, cap;
    int recording;           /* inside ArchiveBegin ... ArchiveEnd: `open` is being recorded */
    int depth;               /* ArchiveBegin blocks nested inside the one being recorded */
    rib_inline_archive open; /* the archive being recorded */
    const char *text;        /* the text of the file its ArchiveBegin is in */
    int reading;             /* archives being read, one inside another */
    uint64_t ran;            /* requests run by ReadArchive of inline archives so far */
    uint64_t patches;        /* patches they added, every outermost read together */
    uint32_t outer_first;    /* the patch count when the outermost read began */
};

static void archive_free(rib_inline_archive *a)
{
    rib_saved_list_free(&a->reqs);
    free(a->name);
    free(a->file);
    memset(a, 0, sizeof *a);
}

void rib_inline_free(rib_parser *p)
{
    if (!p->inlines) return;
    for (size_t k = 0; k < p->inlines->count; k++)
        archive_free(&p->inlines->list[k]);
    archive_free(&p->inlines->open);
    free(p->inlines->list);
    free(p->inlines);
    p->inlines = NULL;
}

int rib_inline_recording(const rib_parser *p)
{
    return p->inlines && p->inlines->recording;
}

static rib_inline_archive *archive_find(struct rib_inlines *in, const char *name)
{
    for (size_t k = 0; in && k < in->count; k++)
        if (strcmp(in->list[k].name, name) == 0) return &in->list[k];
    return NULL;
}

/* ArchiveBegin "name" [parameters]: starts recording (the parameters are RenderMan's
 * bookkeeping and change nothing). */
int rib_req_archive_begin(rib_parser *p)
{
    const char *name;
    char shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "an archive name", &name);
    if (rc != TS_OK) return rc;
    if (!p->inlines && !(p->inlines = calloc(1, sizeof *p->inlines)))
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    struct rib_inlines *in = p->inlines;
    const rib_inline_archive *old = archive_find(in, name);
    if (old && old->reading)
        return rib_error_at(p, p->req_line, p->req_col,
                            "ArchiveBegin \"%s\" while that archive is being read",
                            rib_printable(name, shown));
    rib_inline_archive a = {0};
    a.name = strdup(name);
    a.file = strdup(p->lx.file);
    if (!a.name || !a.file) {
        archive_free(&a);
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    }
    a.line = p->req_line, a.col = p->req_col;
    in->open = a;
    in->recording = 1, in->depth = 0;
    in->text = p->lx.text;
    return TS_OK;
}

/* The archive recorded is complete: it replaces one of the same name. */
static int archive_end(rib_parser *p)
{
    struct rib_inlines *in = p->inlines;
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    rib_inline_archive *old = archive_find(in, in->open.name);
    if (old) {
        archive_free(old);
        *old = in->open;
    } else {
        if (in->count == in->cap) {
            size_t cap = in->cap ? in->cap * 2 : 8;
            rib_inline_archive *l = realloc(in->list, cap * sizeof *l);
            if (!l) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
            in->list = l, in->cap = cap;
        }
        in->list[in->count++] = in->open;
    }
    memset(&in->open, 0, sizeof in->open);
    in->recording = 0;
    return TS_OK;
}

int rib_req_archive_end(rib_parser *p)
{
    return rib_error_at(p, p->req_line, p->req_col, "ArchiveEnd without ArchiveBegin");
}

int rib_inline_record(rib_parser *p)
{
    struct rib_inlines *in = p->inlines;
    if (strcmp(p->req, "ArchiveEnd") == 0 && in->depth == 0) return archive_end(p);
    in->depth += (strcmp(p->req, "ArchiveBegin") == 0) - (strcmp(p->req, "ArchiveEnd") == 0);
    return rib_saved_list_push(p, &in->open.reqs);
}

int rib_inline_check_file_end(rib_parser *p)
{
    struct rib_inlines *in = p->inlines;
    if (!in || !in->recording || in->text != p->lx.text) return TS_OK;
    return rib_error_at(p, in->open.line, in->open.col,
                        "ArchiveBegin is never closed (missing ArchiveEnd)");
}

int rib_inline_read(rib_parser *p, const char *name, int *found)
{
    char shown[RIB_PRINT_MAX];
    struct rib_inlines *in = p->inlines;
    const rib_inline_archive *a = archive_find(in, name);
    *found = a != NULL;
    if (!a) return TS_OK;
    if (a->reading)
        return rib_error_at(p, p->req_line, p->req_col,
                            "ReadArchive: \"%s\" is already being read (an include cycle)",
                            rib_printable(name, shown));
    if (in->reading >= RIB_MAX_INCLUDE)
        return rib_error_at(p, p->req_line, p->req_col,
                            "ReadArchive: inline archives nested deeper than %d levels",
                            RIB_MAX_INCLUDE);
    /* By index: archives its requests define may move the list (never this entry, which
     * ArchiveBegin may not replace while it is being read). */
    size_t at = (size_t)(a - in->list);
    int line = p->req_line, col = p->req_col;
    const char *file = p->lx.file;
    p->lx.file = a->file; /* messages and relative paths: where the archive was defined */
    if (in->reading == 0) in->outer_first = p->scene->patch_count;
    in->list[at].reading = 1, in->reading++;
    uint64_t requests = rib_env_bound("TESSERA_MAX_INLINE_REQUESTS", RIB_MAX_INLINE_REQUESTS),
             patches = rib_copies_budget();
    int rc = TS_OK, over = 0;
    for (size_t k = 0; rc == TS_OK && k < in->list[at].reqs.count; k++) {
        rc = rib_args_restore(p, &in->list[at].reqs.reqs[k]);
        if (rc == TS_OK) rc = rib_dispatch_request(p);
        over = ++in->ran > requests ||
               in->patches + (p->scene->patch_count - in->outer_first) > patches;
        if (rc == TS_OK && over) rc = TS_E_SCENE;
    }
    in->list[at].reading = 0, in->reading--;
    if (in->reading == 0) in->patches += p->scene->patch_count - in->outer_first;
    p->lx.file = file;
    if (over && p->err->code == TS_OK)
        return rib_error_at(p, line, col,
                            "ReadArchive: inline archives read again run more than %llu requests "
                            "or add more than %llu patches (each read is a copy)",
                            (unsigned long long)requests, (unsigned long long)patches);
    return rc;
}
