/* memory.c — the room the system's limits leave this process (base/memory.h). Everything is
 * read from text files under /proc and /sys/fs/cgroup, so a fake tree can stand in for
 * them in tests. */
#include "base/memory.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

/* cgroup v1 writes "no limit" as the largest multiple of the page size below 2^63. */
#define TS_NO_LIMIT_ABOVE ((uint64_t)1 << 62)

static void consider(ts_memory_room *out, uint64_t limit, uint64_t used, const char *which)
{
    if (limit == UINT64_MAX || limit >= TS_NO_LIMIT_ABOVE) return;
    uint64_t room = used < limit ? limit - used : 0;
    if (room < out->bytes) *out = (ts_memory_room){room, limit, which};
}

/* The number in the file at path (cgroup files: one decimal number, or "max" for none);
 * UINT64_MAX when it is missing, "max" or not a number. */
static uint64_t read_number(const char *path)
{
    FILE *f = fopen(path, "r");
    char buf[64] = "";
    if (!f) return UINT64_MAX;
    int ok = fgets(buf, sizeof buf, f) != NULL;
    fclose(f);
    char *end;
    unsigned long long v = strtoull(buf, &end, 10);
    return ok && end != buf ? (uint64_t)v : UINT64_MAX;
}

/* The value of "key:   N kB" in a /proc text file, in bytes; UINT64_MAX when absent. */
static uint64_t read_kib_field(const char *path, const char *key)
{
    FILE *f = fopen(path, "r");
    if (!f) return UINT64_MAX;
    char line[256];
    size_t klen = strlen(key);
    uint64_t v = UINT64_MAX;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, key, klen) == 0 && line[klen] == ':') {
            v = (uint64_t)strtoull(line + klen + 1, NULL, 10) * 1024u;
            break;
        }
    fclose(f);
    return v;
}

/* Every cgroup from dir/rel up to dir: its limit minus its use (files limit_name and
 * used_name), as the tightest so far. A parent's limit binds its children too. */
static void cgroup_walk(ts_memory_room *out, const char *dir, const char *rel,
                        const char *limit_name, const char *used_name, const char *which)
{
    char path[4096], sub[4096];
    snprintf(sub, sizeof sub, "%s", rel);
    for (;;) {
        size_t len = strlen(sub);
        while (len > 0 && sub[len - 1] == '/')
            sub[--len] = '\0';
        snprintf(path, sizeof path, "%s%s/%s", dir, sub, limit_name);
        uint64_t limit = read_number(path);
        snprintf(path, sizeof path, "%s%s/%s", dir, sub, used_name);
        uint64_t used = read_number(path);
        consider(out, limit, used == UINT64_MAX ? 0 : used, which);
        char *slash = strrchr(sub, '/');
        if (!slash) break;
        *slash = '\0';
    }
}

/* The memory cgroups this process is in (src->proc/self/cgroup): a v2 line "0::/path", or
 * a v1 line "N:...memory...:/path". */
static void cgroup_room(const ts_memory_sources *src, ts_memory_room *out)
{
    char path[4096], line[4096], dir[4096];
    snprintf(path, sizeof path, "%s/self/cgroup", src->proc);
    FILE *f = fopen(path, "r");
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\n")] = '\0';
        char *c1 = strchr(line, ':'), *c2 = c1 ? strchr(c1 + 1, ':') : NULL;
        if (!c2) continue;
        *c1 = *c2 = '\0';
        const char *controllers = c1 + 1, *rel = c2 + 1;
        if (strcmp(line, "0") == 0 && *controllers == '\0') {
            cgroup_walk(out, src->cgroup, rel, "memory.max", "memory.current", "cgroup memory.max");
        } else if (strstr(controllers, "memory")) {
            snprintf(dir, sizeof dir, "%s/memory", src->cgroup);
            cgroup_walk(out, dir, rel, "memory.limit_in_bytes", "memory.usage_in_bytes",
                        "cgroup memory.limit_in_bytes");
        }
    }
    fclose(f);
}

uint64_t ts_memory_address_space_limit(void)
{
    struct rlimit rl;
    if (getrlimit(RLIMIT_AS, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY) return UINT64_MAX;
    return (uint64_t)rl.rlim_cur;
}

void ts_memory_room_query(const ts_memory_sources *src, ts_memory_room *out)
{
    static const ts_memory_sources real = {"/proc", "/sys/fs/cgroup"};
    if (!src) src = &real;
    *out = (ts_memory_room){UINT64_MAX, UINT64_MAX, ""};
    char status[4200], meminfo[4200];
    snprintf(status, sizeof status, "%s/self/status", src->proc);
    snprintf(meminfo, sizeof meminfo, "%s/meminfo", src->proc);
    struct rlimit rl;
    uint64_t vm = read_kib_field(status, "VmSize"), data = read_kib_field(status, "VmData");
    if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && vm != UINT64_MAX)
        consider(out, (uint64_t)rl.rlim_cur, vm, "RLIMIT_AS");
    if (getrlimit(RLIMIT_DATA, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && data != UINT64_MAX)
        consider(out, (uint64_t)rl.rlim_cur, data, "RLIMIT_DATA");
    cgroup_room(src, out);
    uint64_t avail = read_kib_field(meminfo, "MemAvailable");
    if (avail != UINT64_MAX) consider(out, avail, 0, "MemAvailable");
}

void *ts_page_alloc(size_t bytes)
{
    return aligned_alloc(4096u, (bytes + 4095u) / 4096u * 4096u);
}
