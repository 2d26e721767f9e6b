/* memory.h — how much memory this process may still allocate, from the limits the system
 * puts on it (issue 15, item 2): the render's default budget is sized from it on devices
 * that share host memory, where the device's buffers are the process's own memory. */
#ifndef TS_MEMORY_H
#define TS_MEMORY_H

#include <stddef.h>
#include <stdint.h>

/* Host memory of at least `bytes` that begins on a 4096-byte page (aligned_alloc, the size
 * rounded up to whole pages): what a device sharing host memory (PoCL) binds with
 * CL_MEM_USE_HOST_PTR without a copy. NULL when there is none; free() it. */
void *ts_page_alloc(size_t bytes);

/* Where the system keeps what ts_memory_room reads: "/proc" and "/sys/fs/cgroup" (tests
 * point them at a fake tree). */
typedef struct ts_memory_sources {
    const char *proc;   /* holds self/status, self/cgroup and meminfo */
    const char *cgroup; /* the cgroup file system: memory.max (v2) or memory/... (v1) */
} ts_memory_sources;

/* The room left under the tightest limit, in bytes, and which limit that is. */
typedef struct ts_memory_room {
    uint64_t bytes;    /* UINT64_MAX when no limit is known */
    uint64_t limit;    /* that limit's own size (RLIMIT_AS: the cap on the address space) */
    const char *which; /* "RLIMIT_AS", "RLIMIT_DATA", "cgroup memory.max", "cgroup
                          memory.limit_in_bytes", "MemAvailable", or "" for none */
} ts_memory_room;

/* The smallest of: RLIMIT_AS minus the address space in use (VmSize), RLIMIT_DATA minus the
 * data segment in use (VmData), each enclosing cgroup's memory.max minus memory.current
 * (cgroup v2) or memory.limit_in_bytes minus memory.usage_in_bytes (v1), and the
 * machine's MemAvailable. A file that is missing or unreadable just drops its limit;
 * nothing here fails. src NULL: the real /proc and /sys/fs/cgroup. */
void ts_memory_room_query(const ts_memory_sources *src, ts_memory_room *out);

/* RLIMIT_AS (the `ulimit -v` cap on the address space) in bytes; UINT64_MAX when there is
 * none. */
uint64_t ts_memory_address_space_limit(void);

#endif
