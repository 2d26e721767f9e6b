/* rib_archive.c — RIB requests that bring in geometry from elsewhere: ReadArchive (another
 * RIB file, read as if it stood in place of the request), Procedural "DelayedReadArchive"
 * (the same, read at once), Procedural "RunProgram" (a helper program's answer, rib_program.c,
 * read in place inside an attribute block), Procedural "DynamicLoad" ["mesh" "file"]
 * (host/scene/mesh.c) and ["forest" "trees=.. seed=.. detail=.."] (host/scene/forest.c). Relative
 * paths are relative to the directory of the file that holds the request. Nesting is bounded and a
 * file that includes itself, directly or not, is an error. A file that cannot be read is skipped
 * with a warning, or an error when strict (rib_missing_file). docs/rib.md has the details. */
#include "scene/rib/rib_internal.h"
#include "scene/rib/rib_text.h"

#include "base/file.h"

#include "scene/forest.h"
#include "scene/mesh.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <unzip.h>

/* The files being read, outermost first: their canonical paths (realpath), for the cycle
 * check; NULL where the name is not a file (rib_parse_string's name). */
struct rib_include {
    int depth; /* archives open below the top-level file */
    char *real[RIB_MAX_INCLUDE + 1];
};

void rib_archive_free(rib_parser *p)
{
    if (!p->inc) return;
    for (int k = 0; k <= RIB_MAX_INCLUDE; k++)
        free(p->inc->real[k]);
    free(p->inc);
    p->inc = NULL;
}

/* Reads the RIB file `name` (argument `at` of the current request) in place. */
#define RIB_ZIP_MEMBER_MAX ((size_t)1 << 30) /* the largest archive read out of a zip */

/* RenderMan for Maya's "archive.zip!member.rib": where name names a member of a zip file,
 * *zip is the zip's name (malloc'd) and *member points into name; else *zip is NULL. */
static int zip_split(const char *name, char **zip, const char **member)
{
    const char *bang = strstr(name, ".zip!");
    *zip = NULL;
    if (!bang) return TS_OK;
    size_t n = (size_t)(bang - name) + 4;
    if (!(*zip = malloc(n + 1))) return TS_E_MEMORY;
    memcpy(*zip, name, n), (*zip)[n] = '\0';
    *member = bang + 5;
    return TS_OK;
}

/* Reads member out of the zip file at path into *text (malloc'd, *len bytes). TS_E_IO with
 * why when it cannot: *absent 1 when the zip is missing or has no such member (the caller's
 * missing-file rule), 0 when it is not a zip or is damaged; TS_E_MEMORY. */
static int zip_read(const char *path, const char *member, char **text, size_t *len, int *absent,
                    char *why, size_t cap)
{
    *text = NULL;
    *absent = access(path, R_OK) != 0;
    unzFile z = unzOpen64(path);
    if (!z) {
        snprintf(why, cap, "%s", access(path, R_OK) == 0 ? "not a zip file" : strerror(errno));
        return TS_E_IO;
    }
    int rc = TS_E_IO;
    unz_file_info64 info;
    if (unzLocateFile(z, member, 1) != UNZ_OK) {
        snprintf(why, cap, "the zip has no member \"%.200s\"", member);
        *absent = 1;
    } else if (unzGetCurrentFileInfo64(z, &info, NULL, 0, NULL, 0, NULL, 0) != UNZ_OK ||
               unzOpenCurrentFile(z) != UNZ_OK) {
        snprintf(why, cap, "cannot open its member \"%.200s\"", member);
    } else {
        size_t n = (size_t)info.uncompressed_size;
        if (info.uncompressed_size > RIB_ZIP_MEMBER_MAX) {
            snprintf(why, cap, "its member \"%.200s\" is larger than %zu MB", member,
                     RIB_ZIP_MEMBER_MAX >> 20);
        } else if (!(*text = malloc(n + 1))) {
            rc = TS_E_MEMORY;
        } else {
            int got = n ? unzReadCurrentFile(z, *text, (unsigned)n) : 0;
            if (got == (int)n && unzCloseCurrentFile(z) == UNZ_OK) { /* the CRC checked */
                (*text)[n] = '\0';
                *len = n;
                rc = TS_OK;
            } else {
                snprintf(why, cap, "its member \"%.200s\" is damaged", member);
                free(*text);
                *text = NULL;
            }
        }
    }
    unzClose(z);
    return rc;
}

/* Before reading something in place of the current request (argument `at`): p->inc made, and
 * the nesting bound checked. */
static int include_begin(rib_parser *p, const rib_arg *at)
{
    if (!p->inc) {
        p->inc = calloc(1, sizeof *p->inc);
        if (!p->inc) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        p->inc->real[0] = realpath(p->lx.file, NULL);
    }
    if (p->inc->depth >= RIB_MAX_INCLUDE)
        return rib_error_at(p, at->line, at->col, "%s: archives nested deeper than %d levels",
                            p->req, RIB_MAX_INCLUDE);
    return TS_OK;
}

/* Runs the requests of text (len bytes; gzip inflated), named `name` in messages, one level
 * deeper; real: its canonical path for the cycle check (taken), or NULL. */
static int include_run(rib_parser *p, const char *name, const char *text, size_t len, char *real)
{
    struct rib_include *inc = p->inc;
    rib_text t = {0}; /* a gzip archive (.rib.gz or not) is inflated here */
    int rc = rib_text_open(&t, name, text, len, p->err);
    inc->real[++inc->depth] = real;
    rib_lexer saved = p->lx;
    if (rc == TS_OK) {
        rib_lex_init(&p->lx, name, t.text, t.len, p->err);
        rc = rib_run_requests(p);
        rib_lex_free(&p->lx);
        p->lx = saved;
    }
    rib_text_free(&t);
    free(inc->real[inc->depth]);
    inc->real[inc->depth--] = NULL;
    return rc;
}

static int rib_include_file(rib_parser *p, const char *name, const rib_arg *at)
{
    char shown[RIB_PRINT_MAX];
    int rc = include_begin(p, at);
    if (rc != TS_OK) return rc;
    struct rib_include *inc = p->inc;
    char *zip = NULL, *path = NULL;
    const char *member = NULL;
    if (zip_split(name, &zip, &member) == TS_OK) path = rib_resolve_in(p, zip ? zip : name, 0);
    free(zip);
    if (!path) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    char *text;
    size_t len;
    char why[256];
    int absent = 0;
    rc = member ? zip_read(path, member, &text, &len, &absent, why, sizeof why)
                : ts_file_read_all(path, &text, &len, why, sizeof why);
    if (rc != TS_OK) { /* missing: skipped with a warning unless strict; a FIFO, a device, a
                          directory: an error either way */
        if (rc == TS_E_MEMORY)
            rc = ts_error_set(p->err, rc, "%s: out of memory", p->lx.file);
        else if (absent || (!member && access(path, R_OK) != 0))
            rc = rib_missing_file(p, at->line, at->col, "", path, why, "skipped");
        else
            rc = rib_error_at(p, at->line, at->col, "%s: cannot read \"%s\": %s", p->req,
                              rib_printable(path, shown), why);
        free(path);
        return rc;
    }
    char *real = realpath(path, NULL);
    if (real && member) { /* the member's own name, "real.zip!member", for the cycle check */
        size_t a = strlen(real), b = strlen(member);
        char *both = realloc(real, a + b + 2);
        if (both) both[a] = '!', memcpy(both + a + 1, member, b + 1), real = both;
    }
    for (int k = 0; real && k <= inc->depth; k++)
        if (inc->real[k] && strcmp(inc->real[k], real) == 0) {
            rc = rib_error_at(p, at->line, at->col,
                              "%s: \"%s\" is already being read (an include cycle)", p->req,
                              rib_printable(name, shown));
            break;
        }
    if (rc != TS_OK) {
        free(real);
        free(text);
        free(path);
        return rc;
    }
    rc = scene_add_input(p->scene, path, p->err);
    /* messages name "dir/a.zip!member.rib" */
    char *shown_name = member ? malloc(strlen(path) + strlen(member) + 2) : path;
    if (member && shown_name) sprintf(shown_name, "%s!%s", path, member);
    if (!shown_name && rc == TS_OK)
        rc = ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    if (rc == TS_OK)
        rc = include_run(p, shown_name, text, len, real);
    else
        free(real);
    free(text);
    if (shown_name != path) free(shown_name);
    free(path);
    return rc;
}

/* ReadArchive "file.rib" */
int rib_req_read_archive(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "a file name", &name);
    if (rc == TS_OK) rc = rib_no_more(p, 1);
    if (rc != TS_OK) return rc;
    const rib_arg *at = &p->args[0];
    /* The arguments live in the parser's pools, which the archive's requests reuse. */
    char *copy = strdup(name);
    if (!copy) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    rib_arg where = *at;
    int inline_archive = 0; /* ArchiveBegin "name" before: its requests, not a file */
    rc = rib_inline_read(p, copy, &inline_archive);
    if (rc == TS_OK && !inline_archive) rc = rib_include_file(p, copy, &where);
    free(copy);
    return rc;
}

/* DynamicLoad "mesh": the file through Assimp, moved by the CTM, with the current
 * attributes. Errors of the loader become scene errors at the request. */
static int rib_proc_mesh(rib_parser *p, const char *file, const rib_arg *at)
{
    ts_patch_attr attr;
    int rc = rib_geom_procedural_attr(p, &attr);
    if (rc != TS_OK) return rc;
    char *path = rib_resolve(p, file);
    if (!path) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    ts_error e = {0};
    rc = mesh_load(path, p->ctm, &attr, p->scene, &e);
    if (rc == TS_E_IO && !p->strict && access(path, R_OK) != 0) { /* missing: a warning */
        char what[1024];
        snprintf(what, sizeof what,
                 "Procedural \"mesh\": %.900s; skipped (--strict makes this an error)", e.msg);
        rib_warn_once(p, at->line, at->col, what);
        rc = TS_OK;
    } else if (rc == TS_E_IO || rc == TS_E_SCENE)
        rc = rib_error_at(p, at->line, at->col, "Procedural \"mesh\": %s", e.msg);
    else if (rc != TS_OK)
        rc = ts_error_set(p->err, rc, "%s", e.msg);
    ts_error_clear(&e);
    free(path);
    return rc;
}

/* DynamicLoad "forest": the procedural forest, placed by the CTM. */
static int rib_proc_forest(rib_parser *p, const char *params, const rib_arg *at)
{
    forest_params fp;
    forest_params_default(&fp);
    char why[160];
    if (forest_parse_params(params, &fp, why, sizeof why) != 0)
        return rib_error_at(p, at->line, at->col, "Procedural \"forest\": %s", why);
    ts_patch_attr attr;
    int rc = rib_geom_procedural_attr(p, &attr);
    if (rc != TS_OK) return rc;
    ts_error e = {0};
    rc = forest_generate(&fp, p->ctm, &attr, p->scene, NULL, &e);
    if (rc == TS_E_SCENE)
        rc = rib_error_at(p, at->line, at->col, "Procedural \"forest\": %s", e.msg);
    else if (rc != TS_OK)
        rc = ts_error_set(p->err, rc, "%s", e.msg);
    ts_error_clear(&e);
    return rc;
}

/* RunProgram: the answer of the helper program `command` to request `data` (rib_program.c),
 * read in place inside an attribute block of its own, which it must leave as it found it. */
static int rib_proc_program(rib_parser *p, const char *command, const char *data,
                            const double bound[6], const rib_arg *at)
{
    char shown[RIB_PRINT_MAX], *text, *name;
    size_t len, depth = p->depth;
    int rc = include_begin(p, at);
    if (rc == TS_OK) rc = rib_program_run(p, command, data, bound, at, &text, &len, &name);
    if (rc != TS_OK || !text) return rc;
    rc = rib_attributes_push(p);
    if (rc == TS_OK) rc = include_run(p, name, text, len, NULL);
    if (rc == TS_OK && p->depth > depth + 1) {
        const rib_frame *f = &p->stack[p->depth - 1];
        rc = rib_error_at(p, at->line, at->col,
                          "Procedural \"RunProgram\": the answer of \"%s\" leaves the block "
                          "begun at %d:%d open",
                          rib_printable(command, shown), f->line, f->col);
    } else if (rc == TS_OK &&
               (p->depth != depth + 1 || p->stack[depth].kind != RIB_FRAME_ATTRIBUTE)) {
        rc = rib_error_at(p, at->line, at->col,
                          "Procedural \"RunProgram\": the answer of \"%s\" ends a block it did "
                          "not begin",
                          rib_printable(command, shown));
    }
    if (rc == TS_OK) rc = rib_attributes_pop(p);
    free(text);
    free(name);
    return rc;
}

/* Whether a procedural that generates geometry (DynamicLoad, RunProgram) stops at the current
 * request: under a moving CTM (*rc the error), or under Opacity 0 0 0 (*rc TS_OK: what it
 * would generate would not be there). */
static int procedural_stops(rib_parser *p, int *rc)
{
    *rc = TS_OK;
    if (p->ctm_moving)
        *rc = rib_error_at(p, p->req_line, p->req_col,
                           "Procedural under a moving transformation is not supported");
    return p->ctm_moving || rib_geom_transparent(p);
}

/* Procedural "DelayedReadArchive" ["file.rib"] [bound]
 * Procedural "RunProgram" ["program args" "datablock"] [bound]
 * Procedural "DynamicLoad" ["mesh" "model.obj"] [bound]
 * Procedural "DynamicLoad" ["forest" "trees=1000 seed=1 detail=1"] [bound]
 * The bound (six numbers, xmin xmax ymin ymax zmin zmax) is checked, and gives RunProgram's
 * detail; the patches' own boxes are exact. */
int rib_req_procedural(rib_parser *p)
{
    const char *kind;
    char shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a procedural name", &kind);
    if (rc != TS_OK) return rc;
    if (p->nargs < 2 || p->args[1].kind != RIB_ARG_STRINGS || p->args[1].count == 0)
        return rib_error_at(p, p->nargs < 2 ? p->req_line : p->args[1].line,
                            p->nargs < 2 ? p->req_col : p->args[1].col,
                            "Procedural: expected an array of strings after \"%s\"",
                            rib_printable(kind, shown));
    if (p->nargs < 3 || p->args[2].kind != RIB_ARG_NUMBERS || p->args[2].count != 6)
        return rib_error_at(p, p->nargs < 3 ? p->req_line : p->args[2].line,
                            p->nargs < 3 ? p->req_col : p->args[2].col,
                            "Procedural: expected a bound [xmin xmax ymin ymax zmin zmax]");
    rc = rib_no_more(p, 3);
    if (rc != TS_OK) return rc;
    const rib_arg *data = &p->args[1];
    /* Copies: the arguments live in pools that the procedural's own requests reuse. */
    char *a0 = strdup(rib_arg_str(p, data, 0));
    char *a1 = data->count > 1 ? strdup(rib_arg_str(p, data, 1)) : NULL;
    rib_arg where = *data;
    double bound[6];
    memcpy(bound, rib_arg_nums(p, &p->args[2]), sizeof bound);
    if (!a0 || (data->count > 1 && !a1)) {
        free(a0);
        free(a1);
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    }
    if (strcmp(kind, "DelayedReadArchive") == 0) {
        rc = data->count == 1
                 ? rib_include_file(p, a0, &where)
                 : rib_error_at(p, where.line, where.col,
                                "Procedural \"DelayedReadArchive\" takes one file name");
    } else if (strcmp(kind, "DynamicLoad") == 0) {
        int mesh = strcmp(a0, "mesh") == 0, forest = strcmp(a0, "forest") == 0;
        if (!mesh && !forest) /* anything else names a plug-in (RI Spec 3.2 §5.7) */
            rc = rib_error_at(p, where.line, where.col,
                              "Procedural \"DynamicLoad\": \"%s\" is a DSO procedural (compiled "
                              "plug-in code), which Tessera cannot run (built-in generators: "
                              "mesh, forest)",
                              rib_printable(a0, shown));
        else if (mesh && data->count != 2)
            rc =
                rib_error_at(p, where.line, where.col,
                             "Procedural \"DynamicLoad\": [\"mesh\" \"file\"] takes one file name");
        else if (forest && data->count > 2)
            rc = rib_error_at(p, where.line, where.col,
                              "Procedural \"DynamicLoad\": [\"forest\" \"parameters\"] takes one "
                              "parameter string");
        else if (!procedural_stops(p, &rc))
            rc = mesh ? rib_proc_mesh(p, a1, &where) : rib_proc_forest(p, a1 ? a1 : "", &where);
    } else if (strcmp(kind, "RunProgram") == 0) {
        if (data->count != 2)
            rc = rib_error_at(p, where.line, where.col,
                              "Procedural \"RunProgram\" takes a program and a data block: "
                              "[\"program\" \"data\"]");
        else if (!procedural_stops(p, &rc))
            rc = rib_proc_program(p, a0, a1, bound, &where);
    } else {
        rc = rib_error_at(p, p->args[0].line, p->args[0].col,
                          "unknown procedural \"%s\" (DelayedReadArchive, RunProgram or "
                          "DynamicLoad)",
                          rib_printable(kind, shown));
    }
    free(a0);
    free(a1);
    return rc;
}

/* Procedural2 "DelayedReadArchive2" ["SimpleBound"] "string filename" ["file.rib"]
 * ["float[6] bound" [...]] (RenderMan 21+): reads the file in place, as ReadArchive does.
 * The bound is not used (the patches' own boxes are exact). Other Procedural2 kinds name
 * compiled plug-ins, which Tessera cannot run: an error. */
int rib_req_procedural2(rib_parser *p)
{
    const char *kind, *file = NULL;
    char shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a procedural name", &kind);
    if (rc != TS_OK) return rc;
    if (strcmp(kind, "DelayedReadArchive2") != 0)
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "Procedural2 \"%s\" is not supported (a compiled plug-in; "
                            "DelayedReadArchive2 is read)",
                            rib_printable(kind, shown));
    size_t i = p->nargs % 2 == 0 ? 2 : 1; /* an even count: a bound function name first */
    const rib_arg *at = &p->args[0];
    for (; i < p->nargs; i += 2) {
        rib_param prm;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "filename") == 0) {
            rc = rib_string_arg(p, i + 1, "a file name", &file);
            if (rc != TS_OK) return rc;
            at = prm.val;
        } else if (strcmp(prm.name, "bound") != 0) {
            rib_warn_param(p, &prm);
        }
    }
    if (!file)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Procedural2 \"DelayedReadArchive2\" without \"string filename\"");
    char *copy = strdup(file); /* the pools are reused by the archive's requests */
    if (!copy) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    rib_arg where = *at;
    rc = rib_include_file(p, copy, &where);
    free(copy);
    return rc;
}

/* Option "searchpath" "archive" ["dir:dir"] "texture" ["dir:dir"] "procedural" ["dir:dir"]:
 * where relative archive and texture names are looked for when they are not beside the file
 * that names them (rib_resolve_in), and RunProgram's programs (rib_program.c). "&" stands for
 * the previous path; "@" (RenderMan's default places) adds nothing. The places of what
 * Tessera never loads (shader, rixplugin, rifilter, display, resource, dirmap) are ignored
 * silently, any other path with a warning. */
int rib_searchpath_option(rib_parser *p)
{
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        const char *val;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int which = strcmp(prm.name, "archive") == 0      ? 0
                    : strcmp(prm.name, "texture") == 0    ? 1
                    : strcmp(prm.name, "procedural") == 0 ? 2
                                                          : -1;
        if (which < 0) {
            /* the places of what Tessera never loads (shaders, plug-ins, display drivers):
             * RenderMan for Maya writes them in every frame; a name not RenderMan's warns */
            static const char *const unused[] = {"shader",  "rixplugin", "rifilter",
                                                 "display", "resource",  "dirmap"};
            if (!rib_in_list(prm.name, unused, RIB_COUNT(unused))) rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_string_arg(p, i + 1, "a search path", &val);
        if (rc != TS_OK) return rc;
        const char *old = p->searchpath[which] ? p->searchpath[which] : "";
        size_t n = 1, ol = strlen(old);
        for (const char *s = val; *s; s++)
            n += *s == '&' ? ol : 1;
        char *path = malloc(n);
        if (!path) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        char *o = path;
        for (const char *s = val; *s; s++)
            if (*s == '&')
                memcpy(o, old, ol), o += ol;
            else
                *o++ = *s;
        *o = '\0';
        free(p->searchpath[which]);
        p->searchpath[which] = path;
    }
    return TS_OK;
}
