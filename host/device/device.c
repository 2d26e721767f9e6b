#include "device/device.h"
#include "base/hash.h"
#include "base/memory.h"
#include "device/kernel_source.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdatomic.h>

cl_int ts_dev_inject_alloc_error = 0;

/* clang-format off */
#define TS_CL_ERRORS(X)                                                                     \
    X(CL_SUCCESS) X(CL_DEVICE_NOT_FOUND) X(CL_DEVICE_NOT_AVAILABLE)                         \
    X(CL_COMPILER_NOT_AVAILABLE) X(CL_MEM_OBJECT_ALLOCATION_FAILURE) X(CL_OUT_OF_RESOURCES) \
    X(CL_OUT_OF_HOST_MEMORY) X(CL_PROFILING_INFO_NOT_AVAILABLE) X(CL_MEM_COPY_OVERLAP)      \
    X(CL_IMAGE_FORMAT_MISMATCH) X(CL_IMAGE_FORMAT_NOT_SUPPORTED) X(CL_BUILD_PROGRAM_FAILURE) \
    X(CL_MAP_FAILURE) X(CL_MISALIGNED_SUB_BUFFER_OFFSET)                                    \
    X(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST) X(CL_COMPILE_PROGRAM_FAILURE)           \
    X(CL_LINKER_NOT_AVAILABLE) X(CL_LINK_PROGRAM_FAILURE) X(CL_DEVICE_PARTITION_FAILED)     \
    X(CL_KERNEL_ARG_INFO_NOT_AVAILABLE) X(CL_INVALID_VALUE) X(CL_INVALID_DEVICE_TYPE)       \
    X(CL_INVALID_PLATFORM) X(CL_INVALID_DEVICE) X(CL_INVALID_CONTEXT)                       \
    X(CL_INVALID_QUEUE_PROPERTIES) X(CL_INVALID_COMMAND_QUEUE) X(CL_INVALID_HOST_PTR)       \
    X(CL_INVALID_MEM_OBJECT) X(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR)                          \
    X(CL_INVALID_IMAGE_SIZE) X(CL_INVALID_SAMPLER) X(CL_INVALID_BINARY)                     \
    X(CL_INVALID_BUILD_OPTIONS) X(CL_INVALID_PROGRAM) X(CL_INVALID_PROGRAM_EXECUTABLE)      \
    X(CL_INVALID_KERNEL_NAME) X(CL_INVALID_KERNEL_DEFINITION) X(CL_INVALID_KERNEL)          \
    X(CL_INVALID_ARG_INDEX) X(CL_INVALID_ARG_VALUE) X(CL_INVALID_ARG_SIZE)                  \
    X(CL_INVALID_KERNEL_ARGS) X(CL_INVALID_WORK_DIMENSION) X(CL_INVALID_WORK_GROUP_SIZE)    \
    X(CL_INVALID_WORK_ITEM_SIZE) X(CL_INVALID_GLOBAL_OFFSET) X(CL_INVALID_EVENT_WAIT_LIST)  \
    X(CL_INVALID_EVENT) X(CL_INVALID_OPERATION) X(CL_INVALID_GL_OBJECT)                     \
    X(CL_INVALID_BUFFER_SIZE) X(CL_INVALID_MIP_LEVEL) X(CL_INVALID_GLOBAL_WORK_SIZE)        \
    X(CL_INVALID_PROPERTY) X(CL_INVALID_IMAGE_DESCRIPTOR) X(CL_INVALID_COMPILER_OPTIONS)    \
    X(CL_INVALID_LINKER_OPTIONS) X(CL_INVALID_DEVICE_PARTITION_COUNT)
/* clang-format on */

const char *dev_error_name(cl_int code)
{
    switch (code) {
#define TS_CL_ERROR_CASE(name)                                                                     \
    case name:                                                                                     \
        return #name;
        TS_CL_ERRORS(TS_CL_ERROR_CASE)
#undef TS_CL_ERROR_CASE
    case -1001:
        return "CL_PLATFORM_NOT_FOUND_KHR";
    default: {
        static _Thread_local char buf[48];
        snprintf(buf, sizeof buf, "CL_UNKNOWN_ERROR(%d)", (int)code);
        return buf;
    }
    }
}

static void device_query(ts_device_info *d, ts_error *err)
{
    clGetPlatformInfo(d->platform, CL_PLATFORM_NAME, sizeof d->platform_name, d->platform_name,
                      NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_NAME, sizeof d->name, d->name, NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_VERSION, sizeof d->version, d->version, NULL);
    clGetDeviceInfo(d->device, CL_DRIVER_VERSION, sizeof d->driver, d->driver, NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_TYPE, sizeof d->type, &d->type, NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof d->compute_units,
                    &d->compute_units, NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof d->global_mem, &d->global_mem,
                    NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_LOCAL_MEM_SIZE, sizeof d->local_mem, &d->local_mem, NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof d->max_alloc, &d->max_alloc,
                    NULL);
    /* Deprecated in OpenCL 2.0 but answered by every 1.2 driver we target. */
    clGetDeviceInfo(d->device, CL_DEVICE_HOST_UNIFIED_MEMORY, sizeof d->host_unified,
                    &d->host_unified, NULL);
    clGetDeviceInfo(d->device, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof d->max_work_group,
                    &d->max_work_group, NULL);
}

int dev_list(ts_device_info **out, ts_error *err)
{
    *out = NULL;
    cl_uint np = 0;
    cl_int rc = clGetPlatformIDs(0, NULL, &np);
    if (rc == -1001 /* CL_PLATFORM_NOT_FOUND_KHR: no ICD installed */ || np == 0) return 0;
    if (rc != CL_SUCCESS) {
        ts_error_set(err, TS_E_DEVICE, "%s in clGetPlatformIDs", dev_error_name(rc));
        return -1;
    }
    cl_platform_id platforms[16];
    if (np > 16) np = 16;
    clGetPlatformIDs(np, platforms, NULL);
    int count = 0, cap = 0;
    ts_device_info *list = NULL;
    for (cl_uint p = 0; p < np; ++p) {
        cl_uint nd = 0;
        if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 0, NULL, &nd) != CL_SUCCESS) continue;
        cl_device_id devs[64];
        if (nd > 64) nd = 64;
        clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, nd, devs, NULL);
        for (cl_uint d = 0; d < nd; ++d) {
            if (count == cap) {
                cap = cap ? 2 * cap : 8;
                ts_device_info *grown = realloc(list, (size_t)cap * sizeof *list);
                if (!grown) {
                    free(list);
                    ts_error_set(err, TS_E_MEMORY, "out of memory");
                    return -1;
                }
                list = grown;
            }
            ts_device_info *info = &list[count++];
            memset(info, 0, sizeof *info);
            info->platform = platforms[p];
            info->device = devs[d];
            device_query(info, err);
        }
    }
    *out = list;
    return count;
}

static int cache_path(const ts_device_options *opt, uint64_t key, char *out, size_t cap)
{
    const char *dir = opt->cache_dir ? opt->cache_dir : getenv("TESSERA_CACHE_DIR");
    char buf[4096];
    if (!dir || !*dir) {
        const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
        if (xdg && *xdg)
            snprintf(buf, sizeof buf, "%s/tessera", xdg);
        else if (home && *home)
            snprintf(buf, sizeof buf, "%s/.cache/tessera", home);
        else
            return -1;
        dir = buf;
    }
    /* mkdir -p of the last two levels is enough for ~/.cache/tessera. */
    char parent[4096];
    snprintf(parent, sizeof parent, "%s", dir);
    char *slash = strrchr(parent, '/');
    if (slash && slash != parent) {
        *slash = '\0';
        mkdir(parent, 0755);
    }
    mkdir(dir, 0755);
    snprintf(out, cap, "%s/%016llx.bin", dir, (unsigned long long)key);
    return 0;
}

/* A cache entry (docs/building.md "the binary cache"): a 32-byte header, then the program
 * binary. The driver is never handed bytes that were not verified: a file cut short by a
 * crash or a full disk, or damaged later, fails the length or checksum test and the
 * program is built from source again (and the entry rewritten). */
#define TS_CACHE_MAGIC "TSKCACHE" /* 8 bytes */
#define TS_CACHE_VERSION 1u
#define TS_CACHE_MAX_BYTES ((uint64_t)1 << 30) /* larger is not one of ours */

typedef struct cache_header {
    char magic[8];
    uint32_t version, reserved;
    uint64_t length;   /* bytes of the binary after the header */
    uint64_t checksum; /* ts_fnv1a of those bytes */
} cache_header;

/* Reads a cache entry and checks it. Returns the binary (malloc'd) or NULL with *why set to
 * what was wrong ("" when there is no entry at all). Only regular files are read. */
static unsigned char *cache_read(const char *path, size_t *size, const char **why)
{
    *why = "";
    *size = 0;
    struct stat st;
    if (stat(path, &st) != 0) return NULL; /* no entry yet */
    if (!S_ISREG(st.st_mode)) return *why = "not a regular file", NULL;
    if ((uint64_t)st.st_size < sizeof(cache_header)) return *why = "shorter than its header", NULL;
    FILE *f = fopen(path, "rb");
    if (!f) return *why = "unreadable", NULL;
    cache_header h;
    unsigned char *bin = NULL;
    if (fread(&h, sizeof h, 1, f) != 1)
        *why = "unreadable";
    else if (memcmp(h.magic, TS_CACHE_MAGIC, 8) != 0 || h.version != TS_CACHE_VERSION)
        *why = "not a tessera kernel-cache entry of this version";
    else if (h.length == 0 || h.length > TS_CACHE_MAX_BYTES ||
             (uint64_t)st.st_size != sizeof h + h.length)
        *why = "truncated or extended (its length does not match its header)";
    else if (!(bin = malloc((size_t)h.length)))
        *why = "too large to read";
    else if (fread(bin, 1, (size_t)h.length, f) != (size_t)h.length)
        *why = "unreadable";
    else if (ts_fnv1a(TS_FNV1A_INIT, bin, (size_t)h.length) != h.checksum)
        *why = "damaged (its checksum does not match)";
    fclose(f);
    if (**why) {
        free(bin);
        return NULL;
    }
    *size = (size_t)h.length;
    return bin;
}

/* Writes the entry to a temporary in the same directory, fsyncs it and renames it into
 * place: a reader sees the old entry, no entry or the whole new one. Failures are silent
 * (the cache is an optimisation). */
static void cache_write(const char *path, const unsigned char *bin, size_t size)
{
    cache_header h;
    memcpy(h.magic, TS_CACHE_MAGIC, 8);
    h.version = TS_CACHE_VERSION, h.reserved = 0;
    h.length = size;
    h.checksum = ts_fnv1a(TS_FNV1A_INIT, bin, size);
    char tmp[4300];
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return;
    int ok = write(fd, &h, sizeof h) == (ssize_t)sizeof h &&
             write(fd, bin, size) == (ssize_t)size && fsync(fd) == 0;
    if (close(fd) != 0) ok = 0;
    if (!ok || rename(tmp, path) != 0) unlink(tmp);
}

static void cache_store(cl_program prog, const char *path)
{
    size_t size = 0;
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, NULL) != CL_SUCCESS ||
        size == 0)
        return;
    unsigned char *bin = malloc(size);
    if (!bin) return;
    unsigned char *bins[1] = {bin};
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARIES, sizeof bins, bins, NULL) == CL_SUCCESS)
        cache_write(path, bin, size);
    free(bin);
}

/* OpenCL C 1.2, and IEEE division and square root where the device offers them: OpenCL
 * lets single-precision x / y be off by 2.5 ulp and sqrt by 3 (NVIDIA's are), which would
 * break the bitwise agreement of the kernels with their plain-C references (and between
 * devices) through 1 / d in every slab test.
 * slot > 0 (several devices in one process) adds -DTS_DEVICE_SLOT=slot, which no kernel
 * reads: PoCL 3.1 keeps the work-group functions it loaded in one table for all its
 * devices, keyed by the kernel's hash, and releases an entry by hash and local size alone,
 * so two devices running the same kernel at once (with different grid sizes) decrement each
 * other's counts and abort ("pocl_release_dlhandle_cache: Assertion `found->ref_count > 0'
 * failed"). A different program text per device gives each its own hashes. */
static void dev_build_options(ts_device *cl, int slot)
{
    cl_device_fp_config fp = 0;
    clGetDeviceInfo(cl->info.device, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp, &fp, NULL);
    char define[32] = "";
    if (slot > 0) snprintf(define, sizeof define, " -DTS_DEVICE_SLOT=%d", slot);
    /* CPU devices: the kernels' SIMD forms, where a float4 or uint8 is a SIMD register
     * (-DTS_CPU_LANES: kernels/lib/bezier.h bezier_combine's float4 sums, camera.cl's eight
     * rays a work-item, which pipeline_camera launches by cpu_lanes); PoCL's also software
     * prefetches (kernels/lib/prefetch.h). */
    int cpu = (cl->info.type & CL_DEVICE_TYPE_CPU) != 0;
    int prefetch = cpu && strstr(cl->info.platform_name, "Portable Computing Language") != NULL;
    /* Not on Mesa's Rusticl (llvmpipe, a CPU device): Mesa 22.3 miscompiles bezier_combine's
     * float4 form where the control points' address varies across work-items and the kernel
     * combines them twice (bezier_cross_derivs: the second sum comes out wrong), so every
     * undisplaced shading normal was 0 and shaded surfaces black (issue 40;
     * tools/rusticl_lanes_repro.c). The scalar form gives PoCL's images there. */
    int rusticl = strcmp(cl->info.platform_name, "rusticl") == 0;
    /* A testing aid: 0, a GPU's form on a CPU; 1, the lanes on any device (Oclgrind's). */
    const char *lanes_env = getenv("TESSERA_CPU_LANES");
    int lanes = lanes_env && strcmp(lanes_env, "1") == 0   ? 1
                : lanes_env && strcmp(lanes_env, "0") == 0 ? 0
                                                           : cpu && !rusticl;
    cl->cpu_lanes = lanes;
    snprintf(cl->build_options, sizeof cl->build_options, "-cl-std=CL1.2%s%s%s%s",
             fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT ? " -cl-fp32-correctly-rounded-divide-sqrt"
                                                      : "",
             lanes ? " -DTS_CPU_LANES=1" : "", prefetch ? " -DTS_PREFETCH=1" : "", define);
}

/* The driver's own words on an error (clCreateContext's pfn_notify): NVIDIA's names what a
 * failed launch did ("an illegal memory access", "out of resources") where the API call
 * that finds it says only CL_INVALID_COMMAND_QUEUE. Written as it comes (any thread), one
 * line, before the error that ends the render. */
static void CL_CALLBACK driver_notice(const char *what, const void *info, size_t size, void *user)
{
    (void)info, (void)size, (void)user;
    if (!what) what = "(no text)";
    size_t n = strlen(what);
    while (n > 0 && (what[n - 1] == '\n' || what[n - 1] == ' ' || what[n - 1] == '.'))
        --n;
    ts_print_line("tessera: OpenCL driver: %.*s", (int)n, what);
}

/* Builds `prog` from the program text `src`; on failure returns TS_E_DEVICE with the full
 * build log as detail. */
static int program_build(ts_device *cl, cl_program prog, const char *src, ts_error *err)
{
    cl_int rc = clBuildProgram(prog, 1, &cl->info.device, cl->build_options, NULL, NULL);
    if (rc == CL_SUCCESS) return TS_OK;
    size_t n = 0;
    clGetProgramBuildInfo(prog, cl->info.device, CL_PROGRAM_BUILD_LOG, 0, NULL, &n);
    char *log = malloc(n + 1);
    if (log) {
        clGetProgramBuildInfo(prog, cl->info.device, CL_PROGRAM_BUILD_LOG, n, log, NULL);
        log[n] = '\0';
        /* Compilers that ignore #line (NVIDIA: "<kernel>:LINE:COL") get their places
         * mapped back to the kernel files here. */
        char *mapped = kernel_source_translate_log(src, log);
        if (mapped) free(log), log = mapped;
    }
    /* The one-line message names the first error's place (kernels/FILE.cl:LINE:COL, from
     * the #line directives of kernel_source.c); the whole log follows it. */
    char first[512] = "";
    for (const char *line = log; line && *line;) {
        size_t len = strcspn(line, "\n");
        const char *e = strstr(line, "error:");
        if (e && e < line + len) {
            const char *from = strncmp(line, "error: ", 7) == 0 ? line + 7 : line;
            snprintf(first, sizeof first, " (first error: %.*s)", (int)(line + len - from), from);
            break;
        }
        line += len + (line[len] == '\n');
    }
    ts_error_set_status(err, TS_E_DEVICE, rc,
                        "%s in clBuildProgram: the kernels failed to build on %s%s",
                        dev_error_name(rc), cl->info.name, first);
    ts_error_set_detail(err, log);
    return TS_E_DEVICE;
}

/* The program from a verified cache entry, or NULL: no entry, or a damaged or foreign one
 * (then cl->cache_note says why, for the one warning the caller prints). */
static cl_program program_from_cache(ts_device *cl, const char *path)
{
    size_t size = 0;
    const char *why = "";
    unsigned char *bin = cache_read(path, &size, &why);
    if (!bin) {
        if (*why)
            snprintf(cl->cache_note, sizeof cl->cache_note,
                     "kernel cache entry %s is %s: rebuilding the kernels from source", path, why);
        return NULL;
    }
    const unsigned char *bins[1] = {bin};
    cl_int status = 0, rc = 0;
    cl_program prog =
        clCreateProgramWithBinary(cl->context, 1, &cl->info.device, &size, bins, &status, &rc);
    free(bin);
    if (rc == CL_SUCCESS && status == CL_SUCCESS &&
        clBuildProgram(prog, 1, &cl->info.device, cl->build_options, NULL, NULL) == CL_SUCCESS)
        return prog;
    if (prog) clReleaseProgram(prog);
    snprintf(cl->cache_note, sizeof cl->cache_note,
             "kernel cache entry %s was not accepted by the driver (%s): rebuilding the kernels "
             "from source",
             path,
             dev_error_name(rc != CL_SUCCESS       ? rc
                            : status != CL_SUCCESS ? status
                                                   : CL_BUILD_PROGRAM_FAILURE));
    return NULL;
}

/* Testing aids from the environment (docs/errors.md): TESSERA_FAIL_ALLOC=N makes the first
 * N buffer creations fail with CL_MEM_OBJECT_ALLOCATION_FAILURE; TESSERA_FAIL_LAUNCH=K
 * makes the K-th kernel launch (counting from 1) fail with CL_OUT_OF_RESOURCES;
 * TESSERA_FAIL_LAUNCH_DEVICE=NAME counts only launches on devices whose name contains
 * NAME; TESSERA_FAIL_BUILD=NAME fails the program build on such devices (* on every one).
 * Read once. The counters
 * are atomic: several devices launch from their own threads (app/workers.c). */
static long env_count(const char *name)
{
    const char *e = getenv(name);
    long v = e && *e ? strtol(e, NULL, 10) : 0;
    return v > 0 ? v : 0;
}

static pthread_once_t fail_once = PTHREAD_ONCE_INIT;
static _Atomic long fail_alloc_left, launch_count;
static long fail_launch_at;
static int sync_launches; /* TESSERA_SYNC_LAUNCHES=1: finish after each launch */
static const char *fail_launch_device, *fail_build_device;

static void fail_init(void)
{
    atomic_store(&fail_alloc_left, env_count("TESSERA_FAIL_ALLOC"));
    fail_launch_at = env_count("TESSERA_FAIL_LAUNCH");
    sync_launches = env_count("TESSERA_SYNC_LAUNCHES") > 0;
    const char *d = getenv("TESSERA_FAIL_LAUNCH_DEVICE");
    fail_launch_device = d && *d ? d : NULL;
    d = getenv("TESSERA_FAIL_BUILD");
    fail_build_device = d && *d ? d : NULL;
}

/* 1 when the program build on cl is to fail (TESSERA_FAIL_BUILD). */
static int fail_build_now(const ts_device *cl)
{
    pthread_once(&fail_once, fail_init);
    return fail_build_device &&
           (strcmp(fail_build_device, "*") == 0 || strstr(cl->info.name, fail_build_device));
}

/* 1 when this buffer creation is to fail (TESSERA_FAIL_ALLOC). */
static int fail_alloc_now(void)
{
    pthread_once(&fail_once, fail_init);
    long left = atomic_load(&fail_alloc_left);
    while (left > 0 && !atomic_compare_exchange_weak(&fail_alloc_left, &left, left - 1))
        ;
    return left > 0;
}

/* 1 when this launch on cl is to fail (TESSERA_FAIL_LAUNCH, TESSERA_FAIL_LAUNCH_DEVICE). */
static int fail_launch_now(const ts_device *cl)
{
    pthread_once(&fail_once, fail_init);
    if (!fail_launch_at || (fail_launch_device && !strstr(cl->info.name, fail_launch_device)))
        return 0;
    return atomic_fetch_add(&launch_count, 1) + 1 == fail_launch_at;
}

static int program_open(ts_device *cl, const ts_device_options *opt, ts_error *err)
{
    double t0 = stats_now();
    dev_build_options(cl, opt->slot);
    if (fail_build_now(cl))
        return ts_error_set_status(err, TS_E_DEVICE, CL_BUILD_PROGRAM_FAILURE,
                                   "CL_BUILD_PROGRAM_FAILURE in clBuildProgram: the kernels "
                                   "failed to build on %s (injected by TESSERA_FAIL_BUILD)",
                                   cl->info.name);
    char *src = kernel_source_program(opt->kernel_dir, err);
    if (!src) return err->code;
    uint64_t key = TS_FNV1A_INIT;
    const char *parts[] = {cl->info.platform_name, cl->info.name,     cl->info.version,
                           cl->info.driver,        cl->build_options, src};
    for (size_t i = 0; i < sizeof parts / sizeof *parts; ++i)
        key = ts_fnv1a(key, parts[i], strlen(parts[i]) + 1);
    char path[4200];
    int use_cache = !opt->no_cache && cache_path(opt, key, path, sizeof path) == 0;
    if (use_cache && (cl->program = program_from_cache(cl, path))) {
        cl->cache_hit = 1;
    } else {
        cl_int rc;
        const char *srcs[1] = {src};
        cl->program = clCreateProgramWithSource(cl->context, 1, srcs, NULL, &rc);
        if (rc != CL_SUCCESS) {
            free(src);
            return dev_fail(err, rc, "clCreateProgramWithSource");
        }
        if (program_build(cl, cl->program, src, err)) {
            free(src);
            return err->code;
        }
        if (use_cache) cache_store(cl->program, path);
    }
    free(src);
    cl->build_seconds = stats_now() - t0;
    return TS_OK;
}

int dev_parse_list(const char *spec, int out[TS_DEVICE_MAX], int *count)
{
    *count = 0;
    if (!spec) return -1;
    if (strcmp(spec, "all") == 0) return 0;
    for (const char *s = spec;;) {
        if (!(*s >= '0' && *s <= '9') || *count == TS_DEVICE_MAX) return -1;
        char *end;
        errno = 0;
        long v = strtol(s, &end, 10);
        if (errno || v > (1 << 20)) return -1;
        for (int k = 0; k < *count; ++k)
            if (out[k] == (int)v) return -1; /* each device once */
        out[(*count)++] = (int)v;
        if (*end == '\0') return 0;
        if (*end != ',') return -1;
        s = end + 1;
    }
}

int dev_select(const ts_device_options *opt, int n, int out[TS_DEVICE_MAX], int *count,
               ts_error *err)
{
    const char *spec = opt->device_list, *from = "--device ";
    if (!spec) {
        const char *env = getenv("TESSERA_DEVICE");
        spec = env && *env ? env : "0";
        from = env && *env ? "TESSERA_DEVICE=" : "";
        if (env && *env && dev_parse_list(env, out, count))
            return ts_error_set(err, TS_E_USAGE,
                                "TESSERA_DEVICE=%s is not a device index (a number from tessera "
                                "devices), a list of them (0,2) or all",
                                env);
    }
    if (dev_parse_list(spec, out, count))
        return ts_error_set(err, TS_E_USAGE, "bad value '%s' for --device", spec);
    if (*count == 0) /* all */
        for (int i = 0; i < n && i < TS_DEVICE_MAX; ++i)
            out[(*count)++] = i;
    for (int k = 0; k < *count; ++k)
        if (out[k] >= n) {
            if (*count == 1)
                return ts_error_set(err, TS_E_USAGE,
                                    "unknown device index %d: there are %d devices (see tessera "
                                    "devices)",
                                    out[k], n);
            return ts_error_set(err, TS_E_USAGE,
                                "unknown device index %d in %s%s: there are %d devices (see "
                                "tessera devices)",
                                out[k], from, spec, n);
        }
    return TS_OK;
}

int dev_open(ts_device *cl, const ts_device_options *opt, ts_error *err)
{
    memset(cl, 0, sizeof *cl);
    ts_device_info *list = NULL;
    int n = dev_list(&list, err);
    if (n < 0) return err->code;
    if (n == 0) {
        free(list);
        /* A driver that cannot map its compiler under `ulimit -v` reports no platform. */
        uint64_t as = ts_memory_address_space_limit();
        if (as != UINT64_MAX)
            return ts_error_set(err, TS_E_DEVICE,
                                "no OpenCL device found; the address space is limited to %llu MB "
                                "(ulimit -v), which may be too little for the OpenCL driver to "
                                "start: raise the limit (or install pocl-opencl-icd for the CPU)",
                                (unsigned long long)(as >> 20));
        return ts_error_set(err, TS_E_DEVICE,
                            "no OpenCL device found (install pocl-opencl-icd for the CPU)");
    }
    int index = opt->device_index, chosen[TS_DEVICE_MAX], count = 0;
    if (index < 0) {
        if (dev_select(opt, n, chosen, &count, err)) {
            free(list);
            return err->code;
        }
        index = chosen[0];
    }
    if (index >= n) {
        free(list);
        return ts_error_set(err, TS_E_USAGE,
                            "unknown device index %d: there are %d devices (see tessera devices)",
                            index, n);
    }
    cl->info = list[index];
    free(list);
    cl_int rc;
    if (opt->host_cores > 0 && (cl->info.type & CL_DEVICE_TYPE_CPU) &&
        opt->host_cores < cl->info.compute_units) {
        cl_uint units = cl->info.compute_units - opt->host_cores, made = 0;
        cl_device_partition_property by[] = {CL_DEVICE_PARTITION_BY_COUNTS,
                                             (cl_device_partition_property)units,
                                             CL_DEVICE_PARTITION_BY_COUNTS_LIST_END, 0};
        rc = clCreateSubDevices(cl->info.device, by, 1, &cl->sub_device, &made);
        if (rc != CL_SUCCESS || made != 1)
            return dev_fail(err, rc != CL_SUCCESS ? rc : CL_DEVICE_PARTITION_FAILED,
                            "clCreateSubDevices(%u of the %u compute units of %s)", units,
                            cl->info.compute_units, cl->info.name);
        cl->info.device = cl->sub_device;
        cl->info.compute_units = units;
    }
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)cl->info.platform,
                                     0};
    cl->context = clCreateContext(props, 1, &cl->info.device, driver_notice, NULL, &rc);
    CL_CHECK(rc, err);
    cl->queue = clCreateCommandQueue(cl->context, cl->info.device, CL_QUEUE_PROFILING_ENABLE, &rc);
    CL_CHECK(rc, err);
    return program_open(cl, opt, err);
}

void dev_close(ts_device *cl)
{
    for (size_t i = 0; i < cl->pending_count; ++i)
        clReleaseEvent(cl->pending[i].event);
    free(cl->pending);
    if (cl->program) clReleaseProgram(cl->program);
    if (cl->queue) clReleaseCommandQueue(cl->queue);
    if (cl->context) clReleaseContext(cl->context);
    if (cl->sub_device) clReleaseDevice(cl->sub_device);
    memset(cl, 0, sizeof *cl);
}

cl_kernel dev_kernel_create(ts_device *cl, const char *name, ts_error *err)
{
    cl_int rc;
    cl_kernel k = clCreateKernel(cl->program, name, &rc);
    if (rc != CL_SUCCESS) {
        dev_fail(err, rc, "clCreateKernel(%s)", name);
        return NULL;
    }
    return k;
}

cl_mem dev_buffer_create(ts_device *cl, cl_mem_flags flags, size_t size, void *host, ts_error *err)
{
    cl_int rc = ts_dev_inject_alloc_error;
    cl_mem m = NULL;
    if (rc == CL_SUCCESS && fail_alloc_now()) rc = CL_MEM_OBJECT_ALLOCATION_FAILURE;
    /* On devices that share host memory (PoCL's CPU device), a buffer without host data
     * is otherwise allocated at its first use, inside an enqueue that cannot report the
     * failure (PoCL 3.1 asserts, exit 134, issue 15). CL_MEM_ALLOC_HOST_PTR makes
     * clCreateBuffer allocate it, where running out is an error we can retry. */
    if (!host && cl->info.host_unified) flags |= CL_MEM_ALLOC_HOST_PTR;
    if (rc == CL_SUCCESS) m = clCreateBuffer(cl->context, flags, size ? size : 1, host, &rc);
    if (rc != CL_SUCCESS) {
        dev_fail(err, rc, "clCreateBuffer(%zu bytes)", size);
        return NULL;
    }
    cl->mem_bytes += size ? size : 1;
    if (cl->mem_bytes > cl->mem_peak) cl->mem_peak = cl->mem_bytes;
    return m;
}

void dev_buffer_release(ts_device *cl, cl_mem m)
{
    if (!m) return;
    size_t size = 0;
    if (clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof size, &size, NULL) == CL_SUCCESS)
        cl->mem_bytes -= size < cl->mem_bytes ? size : cl->mem_bytes;
    clReleaseMemObject(m);
}

void dev_mem_peak_reset(ts_device *cl)
{
    cl->mem_peak = cl->mem_bytes;
}

int dev_set_arg(cl_kernel k, cl_uint index, size_t size, const void *value, ts_error *err)
{
    cl_int rc = clSetKernelArg(k, index, size, value);
    if (rc == CL_SUCCESS) return TS_OK;
    char name[128] = "?";
    clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof name, name, NULL);
    return dev_fail(err, rc, "clSetKernelArg(%s, %u)", name, index);
}

int dev_set_args(cl_kernel k, ts_error *err, ...)
{
    va_list ap;
    va_start(ap, err);
    int rc = TS_OK;
    for (cl_uint i = 0; rc == TS_OK; ++i) {
        size_t size = va_arg(ap, size_t);
        if (size == 0) break;
        const void *value = va_arg(ap, const void *);
        rc = dev_set_arg(k, i, size, value, err);
    }
    va_end(ap);
    return rc;
}

static int finish_failed(ts_device *cl, cl_int rc, ts_error *err);

int dev_launch(ts_device *cl, cl_kernel k, ts_stage stage, size_t global, size_t local,
               ts_error *err)
{
    return dev_launch_range(cl, k, stage, 0, global, local, err);
}

int dev_launch_range(ts_device *cl, cl_kernel k, ts_stage stage, size_t offset, size_t global,
                     size_t local, ts_error *err)
{
    if (global == 0) return TS_OK;
    size_t rounded = (global + local - 1) / local * local;
    if (cl->pending_count == cl->pending_capacity) {
        size_t cap = cl->pending_capacity ? 2 * cl->pending_capacity : 64;
        ts_kernel_event *p = realloc(cl->pending, cap * sizeof *p);
        if (!p) return ts_error_set(err, TS_E_MEMORY, "out of memory");
        cl->pending = p;
        cl->pending_capacity = cap;
    }
    cl_event ev;
    cl_int rc = CL_OUT_OF_RESOURCES;
    if (!fail_launch_now(cl))
        rc = clEnqueueNDRangeKernel(cl->queue, k, 1, offset ? &offset : NULL, &rounded, &local, 0,
                                    NULL, &ev);
    if (rc != CL_SUCCESS) {
        char name[128] = "?";
        clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof name, name, NULL);
        return dev_fail(err, rc, "clEnqueueNDRangeKernel(%s, %zu items)", name, rounded);
    }
    cl->pending[cl->pending_count++] = (ts_kernel_event){ev, stage, k, 0, 0};
    if (sync_launches) { /* the times stay pending for dev_finish */
        cl_int f = clFinish(cl->queue);
        if (f != CL_SUCCESS) return finish_failed(cl, f, err);
    }
    return TS_OK;
}

/* After a failed clFinish: names the first launch in flight whose command failed (a kernel
 * that faulted on a GPU reports here, asynchronously), else the stages in flight. */
static int finish_failed(ts_device *cl, cl_int rc, ts_error *err)
{
    char stages[256] = "";
    size_t used = 0;
    for (size_t i = 0; i < cl->pending_count; ++i) {
        const ts_kernel_event *e = &cl->pending[i];
        cl_int status = CL_COMPLETE;
        clGetEventInfo(e->event, CL_EVENT_COMMAND_EXECUTION_STATUS, sizeof status, &status, NULL);
        if (status < 0) {
            char name[128] = "?";
            clGetKernelInfo(e->kernel, CL_KERNEL_FUNCTION_NAME, sizeof name, name, NULL);
            return dev_fail(err, rc, "clFinish: kernel %s (stage %s) ended with %s", name,
                            ts_stage_names[e->stage], dev_error_name(status));
        }
        const char *s = ts_stage_names[e->stage];
        if (used < sizeof stages && !strstr(stages, s))
            used +=
                (size_t)snprintf(stages + used, sizeof stages - used, "%s%s", used ? ", " : "", s);
    }
    return dev_fail(err, rc, "clFinish (%zu launches in flight%s%s)", cl->pending_count,
                    used ? ": " : "", stages);
}

int dev_finish(ts_device *cl, ts_stats *stats, ts_error *err)
{
    cl_int rc = clFinish(cl->queue);
    if (rc != CL_SUCCESS) return finish_failed(cl, rc, err);
    double now = stats_now();
    cl_ulong last = 0;
    for (size_t i = 0; i < cl->pending_count; ++i) {
        ts_kernel_event *e = &cl->pending[i];
        e->start = e->end = 0;
        clGetEventProfilingInfo(e->event, CL_PROFILING_COMMAND_START, sizeof e->start, &e->start,
                                NULL);
        clGetEventProfilingInfo(e->event, CL_PROFILING_COMMAND_END, sizeof e->end, &e->end, NULL);
        if (e->end > last) last = e->end;
        clReleaseEvent(e->event);
    }
    if (last > 0 && (!cl->clock_known || now - 1e-9 * (double)last < cl->clock_offset)) {
        cl->clock_offset = now - 1e-9 * (double)last;
        cl->clock_known = 1;
    }
    int out = TS_OK;
    for (size_t i = 0; i < cl->pending_count && stats; ++i) {
        const ts_kernel_event *e = &cl->pending[i];
        if (e->end <= e->start) continue;
        stats->stage_seconds[e->stage] += 1e-9 * (double)(e->end - e->start);
        if (!out)
            out = stats_add_busy(stats, 1e-9 * (double)e->start + cl->clock_offset,
                                 1e-9 * (double)e->end + cl->clock_offset, err);
    }
    cl->pending_count = 0;
    cl->finishes++;
    return out;
}

ts_dev_mark dev_mark(const ts_device *cl)
{
    return (ts_dev_mark){cl->finishes, cl->pending_count};
}

int dev_wait_mark(ts_device *cl, ts_dev_mark m, ts_error *err)
{
    if (m.finishes != cl->finishes || m.count == 0 || m.count > cl->pending_count) return TS_OK;
    cl_int rc = clWaitForEvents(1, &cl->pending[m.count - 1].event);
    return rc == CL_SUCCESS ? TS_OK : finish_failed(cl, rc, err);
}

int dev_fail(ts_error *err, cl_int rc, const char *fmt, ...)
{
    char what[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return ts_error_set_status(err, TS_E_DEVICE, rc, "%s in %s", dev_error_name(rc), what);
}

int dev_is_out_of_memory(const ts_error *err)
{
    return err->code == TS_E_DEVICE &&
           (err->status == CL_MEM_OBJECT_ALLOCATION_FAILURE || err->status == CL_OUT_OF_RESOURCES ||
            err->status == CL_OUT_OF_HOST_MEMORY);
}

/* One read or write of bytes at offset between m and host, blocking or not. */
static int dev_transfer(ts_device *cl, cl_mem m, int write, cl_bool blocking, size_t offset,
                        size_t bytes, void *host, const char *what, ts_error *err)
{
    if (bytes == 0) return TS_OK;
    cl_int rc =
        write ? clEnqueueWriteBuffer(cl->queue, m, blocking, offset, bytes, host, 0, NULL, NULL)
              : clEnqueueReadBuffer(cl->queue, m, blocking, offset, bytes, host, 0, NULL, NULL);
    if (rc == CL_SUCCESS) return TS_OK;
    return write ? dev_fail(err, rc, "clEnqueueWriteBuffer (writing %s)", what)
                 : dev_fail(err, rc, "clEnqueueReadBuffer (reading %s)", what);
}

int dev_read(ts_device *cl, cl_mem m, size_t offset, size_t bytes, void *host, const char *what,
             ts_error *err)
{
    return dev_transfer(cl, m, 0, CL_TRUE, offset, bytes, host, what, err);
}

int dev_write(ts_device *cl, cl_mem m, size_t offset, size_t bytes, const void *host,
              const char *what, ts_error *err)
{
    return dev_transfer(cl, m, 1, CL_TRUE, offset, bytes, (void *)host, what, err);
}

int dev_read_async(ts_device *cl, cl_mem m, size_t offset, size_t bytes, void *host,
                   const char *what, ts_error *err)
{
    return dev_transfer(cl, m, 0, CL_FALSE, offset, bytes, host, what, err);
}

int dev_write_async(ts_device *cl, cl_mem m, size_t offset, size_t bytes, const void *host,
                    const char *what, ts_error *err)
{
    return dev_transfer(cl, m, 1, CL_FALSE, offset, bytes, (void *)host, what, err);
}

int dev_fill(ts_device *cl, cl_mem m, const void *pattern, size_t pattern_size, size_t offset,
             size_t bytes, const char *what, ts_error *err)
{
    if (bytes == 0) return TS_OK;
    cl_int rc =
        clEnqueueFillBuffer(cl->queue, m, pattern, pattern_size, offset, bytes, 0, NULL, NULL);
    return rc == CL_SUCCESS ? TS_OK : dev_fail(err, rc, "clEnqueueFillBuffer (clearing %s)", what);
}

void *dev_map(ts_device *cl, cl_mem m, cl_map_flags flags, size_t offset, size_t bytes,
              const char *what, ts_error *err)
{
    cl_int rc = CL_SUCCESS;
    void *ptr = clEnqueueMapBuffer(cl->queue, m, CL_TRUE, flags, offset, bytes ? bytes : 1, 0, NULL,
                                   NULL, &rc);
    if (rc != CL_SUCCESS || !ptr) {
        dev_fail(err, rc != CL_SUCCESS ? rc : CL_MAP_FAILURE, "clEnqueueMapBuffer (mapping %s)",
                 what);
        return NULL;
    }
    return ptr;
}

int dev_unmap(ts_device *cl, cl_mem m, void *ptr, const char *what, ts_error *err)
{
    cl_int rc = clEnqueueUnmapMemObject(cl->queue, m, ptr, 0, NULL, NULL);
    return rc == CL_SUCCESS ? TS_OK
                            : dev_fail(err, rc, "clEnqueueUnmapMemObject (unmapping %s)", what);
}
