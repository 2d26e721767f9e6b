#include "device/kernel_source.h"

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A growable string. */
typedef struct sbuf {
    char *p;
    size_t len, cap;
} sbuf;

static int sbuf_add(sbuf *b, const char *s, size_t n)
{
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + n + 1)
            cap *= 2;
        char *p = realloc(b->p, cap);
        if (!p) return -1;
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->len, s, n);
    b->len += n;
    b->p[b->len] = '\0';
    return 0;
}

static char *read_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    sbuf b = {0};
    char chunk[8192];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) {
        if (sbuf_add(&b, chunk, n)) {
            free(b.p);
            fclose(f);
            return NULL;
        }
    }
    fclose(f);
    if (!b.p) b.p = strdup("");
    return b.p;
}

/* Returns a malloc'd copy of file `rel` from the kernel directory or the embedded table. */
static char *load(const char *kernel_dir, const char *rel, ts_error *err)
{
    if (kernel_dir) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", kernel_dir, rel);
        char *text = read_file(path);
        if (!text) ts_error_set(err, TS_E_IO, "%s: cannot read kernel source", path);
        return text;
    }
    for (const ts_embedded_file *f = ts_embedded_kernels; f->path; ++f)
        if (strcmp(f->path, rel) == 0) return strdup(f->text);
    ts_error_set(err, TS_E_INTERNAL, "kernel source %s is not embedded", rel);
    return NULL;
}

#define MAX_FILES 64

typedef struct inliner {
    const char *kernel_dir;
    const char *seen[MAX_FILES];
    int seen_count;
    sbuf out;
} inliner;

static int inline_file(inliner *in, const char *rel, int depth, ts_error *err);

/* Returns 1 if `line` is #include "name" and copies the name. */
static int parse_include(const char *line, size_t len, char *name, size_t cap)
{
    const char *p = line, *end = line + len;
    while (p < end && (*p == ' ' || *p == '\t'))
        ++p;
    if (p == end || *p != '#') return 0;
    ++p;
    while (p < end && (*p == ' ' || *p == '\t'))
        ++p;
    if ((size_t)(end - p) < 7 || strncmp(p, "include", 7) != 0) return 0;
    p += 7;
    while (p < end && (*p == ' ' || *p == '\t'))
        ++p;
    if (p == end || *p != '"') return 0;
    const char *q = memchr(p + 1, '"', (size_t)(end - p - 1));
    if (!q || (size_t)(q - p - 1) >= cap) return 0;
    memcpy(name, p + 1, (size_t)(q - p - 1));
    name[q - p - 1] = '\0';
    return 1;
}

static int add_line_marker(inliner *in, int line, const char *rel)
{
    char mark[512];
    int n = snprintf(mark, sizeof mark, "#line %d \"kernels/%s\"\n", line, rel);
    return sbuf_add(&in->out, mark, (size_t)n);
}

static int inline_text(inliner *in, const char *rel, const char *text, int depth, ts_error *err)
{
    if (add_line_marker(in, 1, rel)) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    int line = 1;
    for (const char *p = text; *p;) {
        const char *nl = strchr(p, '\n');
        size_t len = nl ? (size_t)(nl - p) : strlen(p);
        char name[256];
        if (parse_include(p, len, name, sizeof name)) {
            /* Includes are relative to kernels/ whichever file names them. */
            if (inline_file(in, name, depth + 1, err)) return err->code;
            if (add_line_marker(in, line + 1, rel))
                return ts_error_set(err, TS_E_MEMORY, "out of memory");
        } else if (sbuf_add(&in->out, p, len) || sbuf_add(&in->out, "\n", 1)) {
            return ts_error_set(err, TS_E_MEMORY, "out of memory");
        }
        ++line;
        p = nl ? nl + 1 : p + len;
    }
    return TS_OK;
}

static int inline_file(inliner *in, const char *rel, int depth, ts_error *err)
{
    if (depth > 16)
        return ts_error_set(err, TS_E_INTERNAL, "kernels/%s: includes nested too deep", rel);
    for (int i = 0; i < in->seen_count; ++i)
        if (strcmp(in->seen[i], rel) == 0) return TS_OK; /* each file once */
    if (in->seen_count == MAX_FILES)
        return ts_error_set(err, TS_E_INTERNAL, "too many kernel source files");
    char *text = load(in->kernel_dir, rel, err);
    if (!text) return err->code;
    in->seen[in->seen_count++] = strdup(rel);
    int rc = inline_text(in, rel, text, depth, err);
    free(text);
    return rc;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Lists the top-level *.cl names, sorted. Returns the count or -1. */
static int list_programs(const char *kernel_dir, char **names, int cap, ts_error *err)
{
    int n = 0;
    if (!kernel_dir) {
        for (const ts_embedded_file *f = ts_embedded_kernels; f->path && n < cap; ++f) {
            size_t len = strlen(f->path);
            if (len > 3 && strcmp(f->path + len - 3, ".cl") == 0 && !strchr(f->path, '/'))
                names[n++] = strdup(f->path);
        }
    } else {
        DIR *d = opendir(kernel_dir);
        if (!d) {
            ts_error_set(err, TS_E_IO, "%s: cannot open kernel directory", kernel_dir);
            return -1;
        }
        struct dirent *e;
        while ((e = readdir(d)) && n < cap) {
            size_t len = strlen(e->d_name);
            if (len > 3 && strcmp(e->d_name + len - 3, ".cl") == 0) names[n++] = strdup(e->d_name);
        }
        closedir(d);
    }
    qsort(names, (size_t)n, sizeof *names, cmp_str);
    return n;
}

char *kernel_source_program(const char *kernel_dir, ts_error *err)
{
    char *names[MAX_FILES];
    int n = list_programs(kernel_dir, names, MAX_FILES, err);
    if (n < 0) return NULL;
    inliner in = {.kernel_dir = kernel_dir};
    /* Kernels must round exactly like the host references (no contraction into FMA). */
    const char *prologue = "#pragma OPENCL FP_CONTRACT OFF\n";
    int rc = sbuf_add(&in.out, prologue, strlen(prologue)) ? TS_E_MEMORY : TS_OK;
    for (int i = 0; i < n && rc == TS_OK; ++i)
        rc = inline_file(&in, names[i], 0, err);
    for (int i = 0; i < n; ++i)
        free(names[i]);
    for (int i = 0; i < in.seen_count; ++i)
        free((char *)in.seen[i]);
    if (rc != TS_OK) {
        if (rc == TS_E_MEMORY) ts_error_set(err, TS_E_MEMORY, "out of memory");
        free(in.out.p);
        return NULL;
    }
    return in.out.p;
}

int kernel_source_locate(const char *program, int line, char *file, size_t cap)
{
    int file_line = 0, physical = 1;
    if (cap) file[0] = '\0';
    for (const char *p = program; p && *p && physical <= line; ++physical) {
        size_t len = strcspn(p, "\n");
        int n = 0;
        char name[256];
        if (physical == line) return file_line;
        if (sscanf(p, "#line %d \"%255[^\"]\"", &n, name) == 2) {
            file_line = n;
            snprintf(file, cap, "%s", name);
        } else if (file_line) {
            ++file_line;
        }
        p += len + (p[len] == '\n');
    }
    if (physical == line && file_line) return file_line; /* the text's last, unterminated line */
    if (cap) file[0] = '\0';
    return 0;
}

char *kernel_source_translate_log(const char *program, const char *log)
{
    static const char *const tags[] = {"<kernel>:", "<source>:"};
    sbuf out = {0};
    if (sbuf_add(&out, "", 0)) return NULL;
    for (const char *p = log; *p;) {
        const char *hit = NULL;
        size_t tag_len = 0;
        for (size_t i = 0; i < sizeof tags / sizeof *tags; ++i) {
            const char *h = strstr(p, tags[i]);
            if (h && (!hit || h < hit)) hit = h, tag_len = strlen(tags[i]);
        }
        char *end = NULL;
        long line = hit ? strtol(hit + tag_len, &end, 10) : 0;
        if (!hit) {
            if (sbuf_add(&out, p, strlen(p))) goto oom;
            break;
        }
        char file[256], place[320];
        int file_line = line > 0 && line < INT_MAX && end && *end == ':'
                            ? kernel_source_locate(program, (int)line, file, sizeof file)
                            : 0;
        if (sbuf_add(&out, p, (size_t)(hit - p))) goto oom;
        if (file_line) {
            int n = snprintf(place, sizeof place, "%s:%d", file, file_line);
            if (sbuf_add(&out, place, (size_t)n)) goto oom;
            p = end;
        } else {
            if (sbuf_add(&out, hit, tag_len)) goto oom;
            p = hit + tag_len;
        }
    }
    return out.p;
oom:
    free(out.p);
    return NULL;
}
