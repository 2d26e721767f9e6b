/* device.h — the OpenCL layer: device listing and selection, the program build (with
 * the build log on failure and an on-disk binary cache), and the one launch wrapper through
 * which every kernel runs, named by its stage and timed by profiling events (STYLE.md 5). */
#ifndef TS_CL_RUNTIME_H
#define TS_CL_RUNTIME_H

#include "base/error.h"
#include "base/stages.h"
#include "base/stats.h"

#include <CL/cl.h>
#include <stddef.h>

/* The name of an OpenCL error code ("CL_OUT_OF_RESOURCES"), or "CL_UNKNOWN_ERROR(-N)". */
const char *dev_error_name(cl_int code);

/* Checks an OpenCL call; on failure fills err with the error name, the call and the place,
 * and returns TS_E_DEVICE from the enclosing function (STYLE.md 10). */
#define CL_CHECK(call, err)                                                                        \
    do {                                                                                           \
        cl_int cl_check_rc_ = (call);                                                              \
        if (cl_check_rc_ != CL_SUCCESS)                                                            \
            return ts_error_set_status((err), TS_E_DEVICE, cl_check_rc_, "%s in %s (%s:%d)",       \
                                       dev_error_name(cl_check_rc_), #call, __FILE__, __LINE__);   \
    } while (0)

/* Fills err with TS_E_DEVICE, status rc and "NAME in <what>" (what: printf format); returns
 * TS_E_DEVICE. For OpenCL calls the helpers below do not wrap. */
int dev_fail(ts_error *err, cl_int rc, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* 1 when err is a device error that means memory ran out (CL_MEM_OBJECT_ALLOCATION_FAILURE,
 * CL_OUT_OF_RESOURCES, CL_OUT_OF_HOST_MEMORY): a smaller budget may succeed. Decided by
 * the status the failing call returned, never by the message. */
int dev_is_out_of_memory(const ts_error *err);

/* One OpenCL device as `tessera devices` lists it. */
typedef struct ts_device_info {
    cl_platform_id platform;
    cl_device_id device;
    char platform_name[128];
    char name[128];
    char version[128];
    char driver[128];
    cl_device_type type;
    cl_uint compute_units;
    cl_ulong global_mem, local_mem, max_alloc;
    cl_bool host_unified; /* shares memory with the host (CPU devices): maps are zero copy */
    size_t max_work_group;
} ts_device_info;

/* Lists every device of every platform in a stable order (platform, then device).
 * *out is malloc'd; returns the count (0 when there is no OpenCL platform) or -1. */
int dev_list(ts_device_info **out, ts_error *err);

/* Test hook: when non-zero, clCreateBuffer calls made through dev_buffer_create fail with
 * this error code (for tests of the failure paths). From the command line, the environment
 * does the same: TESSERA_FAIL_ALLOC=N fails the first N buffer creations with
 * CL_MEM_OBJECT_ALLOCATION_FAILURE, TESSERA_FAIL_LAUNCH=K the K-th launch through dev_launch
 * with CL_OUT_OF_RESOURCES (docs/errors.md). */
extern cl_int ts_dev_inject_alloc_error;

typedef struct ts_kernel_event {
    cl_event event;
    ts_stage stage;
    cl_kernel kernel;    /* to name it when its command fails */
    cl_ulong start, end; /* its profiling times, read by dev_finish */
} ts_kernel_event;

/* A selected device with its context, in-order profiling queue and built program. */
typedef struct ts_device {
    ts_device_info info;
    cl_context context;
    cl_command_queue queue;
    cl_program program;
    ts_kernel_event *pending; /* launches whose times are not yet collected */
    size_t pending_count, pending_capacity;
    uint64_t finishes; /* dev_finish calls so far: each empties pending (dev_mark) */
    /* The host's clock (stats_now) less the device's profiling clock, in seconds: the least
     * of (the host's time when clFinish returned) - (the last launch's end) seen so far, so
     * a kernel's span lands on the host's clock at most the latency of one finish late. */
    double clock_offset;
    int clock_known;
    double build_seconds;
    int cache_hit;
    char build_options[192]; /* dev_build_options() for this device */
    /* Bytes of the buffers made by dev_buffer_create and not yet released by
     * dev_buffer_release, and the most they came to at once since dev_mem_peak_reset (what
     * --stats reports as device_bytes_peak, pipeline.h). A buffer released any other way
     * stays counted. */
    uint64_t mem_bytes, mem_peak;
    int cpu_lanes; /* built with -DTS_CPU_LANES: camera_generate makes 8 rays a work-item */
    /* Non-empty when the binary cache held a damaged or foreign entry for this program: what
     * was wrong (the program was built from source and the entry rewritten). The caller
     * prints it once as a warning. */
    char cache_note[4400];
    cl_device_id sub_device; /* the sub-device made for ts_device_options.host_cores, or NULL */
} ts_device;

typedef struct ts_device_options {
    int device_index;        /* >= 0: this device; -1: the first of device_list */
    const char *device_list; /* --device: "I", "I,J,..." or "all"; NULL: $TESSERA_DEVICE,
                                else "0" (dev_select) */
    const char *kernel_dir;  /* NULL: embedded kernels */
    const char *cache_dir; /* NULL: $TESSERA_CACHE_DIR, $XDG_CACHE_HOME/tessera, ~/.cache/tessera */
    int no_cache;          /* 1: never read or write the binary cache */
    /* > 0: the program of the slot-th device of a process that renders on several is built
     * with -DTS_DEVICE_SLOT=slot (dev_build_options says why). */
    int slot;
    /* > 0 and below a CPU device's compute units: the device is a sub-device of the others
     * (clCreateSubDevices by counts), leaving these cores to the host (app/workers.h
     * workers_host_cores: a CPU beside a GPU). 0: the whole device. */
    unsigned host_cores;
} ts_device_options;

/* The most devices one process renders with (--device all takes the first ones). */
#define TS_DEVICE_MAX 16

/* Parses a device list: "I" (one index), "I,J,..." (indices 0..2^20 in the order given, each
 * once, at most TS_DEVICE_MAX) or "all" (*count = 0: every device). Returns 0, or -1 for
 * anything else (nothing around the numbers, no empty item, no repeat). */
int dev_parse_list(const char *spec, int out[TS_DEVICE_MAX], int *count);

/* The devices a render uses, of the n that dev_list finds: opt->device_list, else
 * $TESSERA_DEVICE, else device 0; "all" is every device (the first TS_DEVICE_MAX). Fills
 * out[0..*count) in the order given. TS_E_USAGE for an index out of range or a
 * TESSERA_DEVICE that is not a list, naming it. */
int dev_select(const ts_device_options *opt, int n, int out[TS_DEVICE_MAX], int *count,
               ts_error *err);

/* Opens the device (opt->device_index, else the first that dev_select names), builds (or
 * loads from the cache) the program. */
int dev_open(ts_device *cl, const ts_device_options *opt, ts_error *err);
void dev_close(ts_device *cl);

cl_kernel dev_kernel_create(ts_device *cl, const char *name, ts_error *err);
/* clCreateBuffer with the error named; size 0 is rounded up to 1 byte. On devices with
 * host-unified memory the memory is allocated here (CL_MEM_ALLOC_HOST_PTR), so running out
 * fails this call (CL_OUT_OF_HOST_MEMORY) rather than a later enqueue. */
cl_mem dev_buffer_create(ts_device *cl, cl_mem_flags flags, size_t size, void *host, ts_error *err);
/* Releases a buffer made by dev_buffer_create (NULL: nothing) and takes its bytes
 * (CL_MEM_SIZE) off cl->mem_bytes. */
void dev_buffer_release(ts_device *cl, cl_mem m);
/* Starts a new peak: cl->mem_peak = cl->mem_bytes (a pipeline's own, pipeline_create). */
void dev_mem_peak_reset(ts_device *cl);

/* Sets arguments in order from (size, pointer) pairs; ends at size 0. DEV_ARG(x) is the
 * pair of an lvalue: dev_set_args(k, err, DEV_ARG(a), DEV_ARG(b), (size_t)0). */
int dev_set_args(cl_kernel k, ts_error *err, ...);
#define DEV_ARG(x) sizeof(x), &(x)
/* Sets argument `index` alone (a launch that changes one argument of those already set). */
int dev_set_arg(cl_kernel k, cl_uint index, size_t size, const void *value, ts_error *err);

/* The launch wrapper: enqueues `k` over `global` items (rounded up to a multiple of
 * `local`; the kernels guard their range) and records a profiling event for `stage`. */
int dev_launch(ts_device *cl, cl_kernel k, ts_stage stage, size_t global, size_t local,
               ts_error *err);
/* The same over items [offset, offset + global) (global rounded up; get_global_id counts
 * from offset). */
int dev_launch_range(ts_device *cl, cl_kernel k, ts_stage stage, size_t offset, size_t global,
                     size_t local, ts_error *err);
/* Blocking transfers on the device's queue; `what` names the data in the error message
 * ("NAME in clEnqueueReadBuffer (reading <what>)"). */
int dev_read(ts_device *cl, cl_mem m, size_t offset, size_t bytes, void *host, const char *what,
             ts_error *err);
int dev_write(ts_device *cl, cl_mem m, size_t offset, size_t bytes, const void *host,
              const char *what, ts_error *err);
/* The same, not blocking: ordered by the in-order queue, done by the next dev_finish (or
 * blocking call). The host memory must stay as it is (write) or unread (read) until then. */
int dev_read_async(ts_device *cl, cl_mem m, size_t offset, size_t bytes, void *host,
                   const char *what, ts_error *err);
int dev_write_async(ts_device *cl, cl_mem m, size_t offset, size_t bytes, const void *host,
                    const char *what, ts_error *err);
/* Fills bytes [offset, offset + bytes) with copies of the pattern (not blocking: ordered by
 * the in-order queue before any later command). */
int dev_fill(ts_device *cl, cl_mem m, const void *pattern, size_t pattern_size, size_t offset,
             size_t bytes, const char *what, ts_error *err);
/* Maps bytes [offset, offset + bytes) of m (blocking); NULL with err set on failure. Every
 * successful map is undone by dev_unmap before the next launch that uses m. */
void *dev_map(ts_device *cl, cl_mem m, cl_map_flags flags, size_t offset, size_t bytes,
              const char *what, ts_error *err);
int dev_unmap(ts_device *cl, cl_mem m, void *ptr, const char *what, ts_error *err);

/* Waits for the queue and adds every pending launch's (end - start) to stats. */
int dev_finish(ts_device *cl, ts_stats *stats, ts_error *err);

/* A point in the queue: the launches enqueued before it (dev_mark). dev_wait_mark waits until
 * they have ended (the queue is in order), without waiting for those enqueued since, so that
 * a caller may keep the device a step ahead of it and still stop within one step (a stop
 * signal cannot take back what is enqueued: trace.c's batches). At once when a dev_finish
 * has waited for them already. */
typedef struct ts_dev_mark {
    uint64_t finishes;
    size_t count;
} ts_dev_mark;
ts_dev_mark dev_mark(const ts_device *cl);
int dev_wait_mark(ts_device *cl, ts_dev_mark m, ts_error *err);

#endif
