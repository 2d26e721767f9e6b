/* oclgrind_host_writes.c — an LD_PRELOAD shim used by tools/check_kernels.sh, loaded in front
 * of Oclgrind's runtime (liboclgrind-rt.so). It works around how Oclgrind 21.10 (Debian 12)
 * tracks host writes for --uninitialized: every host store into a buffer (a write, a fill, a
 * copy, a mapping for writing) *replaces* that buffer's shadow with one the size of the
 * store, so a partial write (an offset, a size smaller than the buffer, a fill pattern
 * smaller than the buffer) makes the rest of the buffer, including what kernels wrote there,
 * look uninitialised; and a mapping with CL_MAP_READ | CL_MAP_WRITE is taken as a read only,
 * so what the host wrote through it looks uninitialised. Both give false reports
 * ("Uninitialized value written to ...", "Uninitialized address used to ...") in kernels
 * that are correct.
 *
 * After each such host store the shim reads the whole buffer back and writes it again in
 * one full-size clEnqueueWriteBuffer, which Oclgrind records correctly: the buffer's shadow
 * becomes "initialised" everywhere. Precision lost: in a buffer the host has written, a
 * kernel reading bytes nobody wrote is not reported. Buffers that only kernels write (rays,
 * hits, grids, trees, radiance) keep exact tracking. It changes no data, and does nothing
 * to the --data-races and --check-api checks.
 *
 * It also records what ran, for the coverage check: when $TESSERA_LAUNCH_LOG names a file,
 * every successful clBuildProgram appends "program<TAB>k1;k2;..." (CL_PROGRAM_KERNEL_NAMES)
 * and every successful clEnqueueNDRangeKernel appends "launch<TAB>kernel<TAB>device name".
 *
 * A third problem of the same checker: clReleaseMemObject frees a buffer's index, the next
 * clCreateBuffer reuses it, and the new buffer inherits the old one's shadow (its contents'
 * "initialised" state and its size: stores past the old size are dropped, loads past it
 * read as uninitialised). So the shim keeps the last reference of every buffer until the
 * process ends: no index is reused. Tests and tiny renders allocate little.
 *
 * Build: cc -shared -fPIC -o liboclgrind_host_writes.so tools/oclgrind_host_writes.c -ldl */
#define _GNU_SOURCE
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include <dlfcn.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define NEXT(name) ((name##_fn)next_symbol(#name))

typedef cl_int (*clEnqueueWriteBuffer_fn)(cl_command_queue, cl_mem, cl_bool, size_t, size_t,
                                          const void *, cl_uint, const cl_event *, cl_event *);
typedef cl_int (*clEnqueueReadBuffer_fn)(cl_command_queue, cl_mem, cl_bool, size_t, size_t, void *,
                                         cl_uint, const cl_event *, cl_event *);
typedef cl_int (*clEnqueueFillBuffer_fn)(cl_command_queue, cl_mem, const void *, size_t, size_t,
                                         size_t, cl_uint, const cl_event *, cl_event *);
typedef cl_int (*clEnqueueCopyBuffer_fn)(cl_command_queue, cl_mem, cl_mem, size_t, size_t, size_t,
                                         cl_uint, const cl_event *, cl_event *);
typedef void *(*clEnqueueMapBuffer_fn)(cl_command_queue, cl_mem, cl_bool, cl_map_flags, size_t,
                                       size_t, cl_uint, const cl_event *, cl_event *, cl_int *);
typedef cl_int (*clEnqueueUnmapMemObject_fn)(cl_command_queue, cl_mem, void *, cl_uint,
                                             const cl_event *, cl_event *);
typedef cl_int (*clFinish_fn)(cl_command_queue);
typedef cl_int (*clReleaseMemObject_fn)(cl_mem);
typedef cl_int (*clGetMemObjectInfo_fn)(cl_mem, cl_mem_info, size_t, void *, size_t *);
typedef cl_int (*clBuildProgram_fn)(cl_program, cl_uint, const cl_device_id *, const char *,
                                    void(CL_CALLBACK *)(cl_program, void *), void *);
typedef cl_int (*clEnqueueNDRangeKernel_fn)(cl_command_queue, cl_kernel, cl_uint, const size_t *,
                                            const size_t *, const size_t *, cl_uint,
                                            const cl_event *, cl_event *);
typedef cl_int (*clGetProgramInfo_fn)(cl_program, cl_program_info, size_t, void *, size_t *);
typedef cl_int (*clGetKernelInfo_fn)(cl_kernel, cl_kernel_info, size_t, void *, size_t *);
typedef cl_int (*clGetCommandQueueInfo_fn)(cl_command_queue, cl_command_queue_info, size_t, void *,
                                           size_t *);
typedef cl_int (*clGetDeviceInfo_fn)(cl_device_id, cl_device_info, size_t, void *, size_t *);

static void *next_symbol(const char *name)
{
    void *f = dlsym(RTLD_NEXT, name);
    if (!f) {
        fprintf(stderr, "oclgrind_host_writes: %s not found after the shim\n", name);
        abort();
    }
    return f;
}

/* Rewrites the whole of buf with its own contents so that Oclgrind's shadow covers it. */
static void normalize(cl_command_queue q, cl_mem buf)
{
    size_t size = 0;
    if (NEXT(clGetMemObjectInfo)(buf, CL_MEM_SIZE, sizeof size, &size, NULL) != CL_SUCCESS ||
        size == 0)
        return;
    NEXT(clFinish)(q);
    void *tmp = malloc(size);
    if (!tmp) return;
    if (NEXT(clEnqueueReadBuffer)(q, buf, CL_TRUE, 0, size, tmp, 0, NULL, NULL) == CL_SUCCESS)
        NEXT(clEnqueueWriteBuffer)(q, buf, CL_TRUE, 0, size, tmp, 0, NULL, NULL);
    free(tmp);
}

/* Mappings for writing that are not unmapped yet. */
#define MAX_MAPS 256
static struct {
    cl_mem buf;
    void *ptr;
} maps[MAX_MAPS];
static pthread_mutex_t maps_lock = PTHREAD_MUTEX_INITIALIZER;

cl_int clEnqueueWriteBuffer(cl_command_queue q, cl_mem buf, cl_bool blocking, size_t offset,
                            size_t size, const void *ptr, cl_uint n, const cl_event *wait,
                            cl_event *ev)
{
    cl_int rc = NEXT(clEnqueueWriteBuffer)(q, buf, blocking, offset, size, ptr, n, wait, ev);
    size_t full = 0;
    NEXT(clGetMemObjectInfo)(buf, CL_MEM_SIZE, sizeof full, &full, NULL);
    if (rc == CL_SUCCESS && (offset != 0 || size != full)) normalize(q, buf);
    return rc;
}

cl_int clEnqueueFillBuffer(cl_command_queue q, cl_mem buf, const void *pattern, size_t psize,
                           size_t offset, size_t size, cl_uint n, const cl_event *wait,
                           cl_event *ev)
{
    cl_int rc = NEXT(clEnqueueFillBuffer)(q, buf, pattern, psize, offset, size, n, wait, ev);
    if (rc == CL_SUCCESS) normalize(q, buf);
    return rc;
}

cl_int clEnqueueCopyBuffer(cl_command_queue q, cl_mem src, cl_mem dst, size_t src_offset,
                           size_t dst_offset, size_t size, cl_uint n, const cl_event *wait,
                           cl_event *ev)
{
    cl_int rc = NEXT(clEnqueueCopyBuffer)(q, src, dst, src_offset, dst_offset, size, n, wait, ev);
    if (rc == CL_SUCCESS) normalize(q, dst);
    return rc;
}

void *clEnqueueMapBuffer(cl_command_queue q, cl_mem buf, cl_bool blocking, cl_map_flags flags,
                         size_t offset, size_t size, cl_uint n, const cl_event *wait, cl_event *ev,
                         cl_int *rc)
{
    void *p = NEXT(clEnqueueMapBuffer)(q, buf, blocking, flags, offset, size, n, wait, ev, rc);
    if (p && (flags & (CL_MAP_WRITE | CL_MAP_WRITE_INVALIDATE_REGION))) {
        pthread_mutex_lock(&maps_lock);
        for (int i = 0; i < MAX_MAPS; ++i)
            if (!maps[i].ptr) {
                maps[i].buf = buf;
                maps[i].ptr = p;
                break;
            }
        pthread_mutex_unlock(&maps_lock);
    }
    return p;
}

cl_int clEnqueueUnmapMemObject(cl_command_queue q, cl_mem mem, void *ptr, cl_uint n,
                               const cl_event *wait, cl_event *ev)
{
    int written = 0;
    pthread_mutex_lock(&maps_lock);
    for (int i = 0; i < MAX_MAPS; ++i)
        if (maps[i].ptr == ptr && maps[i].buf == mem) {
            maps[i].ptr = NULL;
            written = 1;
            break;
        }
    pthread_mutex_unlock(&maps_lock);
    cl_int rc = NEXT(clEnqueueUnmapMemObject)(q, mem, ptr, n, wait, ev);
    if (rc == CL_SUCCESS && written) normalize(q, mem);
    return rc;
}

/* Appends one line to $TESSERA_LAUNCH_LOG (one write(2) with O_APPEND, so lines from several
 * processes do not interleave). */
static void log_line(const char *a, const char *b, const char *c)
{
    const char *path = getenv("TESSERA_LAUNCH_LOG");
    if (!path || !*path) return;
    size_t n = strlen(a) + strlen(b) + strlen(c) + 4; /* 2 tabs, newline, NUL */
    char *line = malloc(n);
    if (!line) return;
    snprintf(line, n, "%s\t%s%s%s\n", a, b, *c ? "\t" : "", c);
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) {
        ssize_t w = write(fd, line, strlen(line));
        (void)w;
        close(fd);
    }
    free(line);
}

cl_int clBuildProgram(cl_program prog, cl_uint ndev, const cl_device_id *devs, const char *opt,
                      void(CL_CALLBACK *notify)(cl_program, void *), void *user)
{
    cl_int rc = NEXT(clBuildProgram)(prog, ndev, devs, opt, notify, user);
    size_t size = 0;
    if (rc == CL_SUCCESS &&
        NEXT(clGetProgramInfo)(prog, CL_PROGRAM_KERNEL_NAMES, 0, NULL, &size) == CL_SUCCESS) {
        char *names = calloc(size + 1, 1);
        if (names &&
            NEXT(clGetProgramInfo)(prog, CL_PROGRAM_KERNEL_NAMES, size, names, NULL) == CL_SUCCESS)
            log_line("program", names, "");
        free(names);
    }
    return rc;
}

cl_int clEnqueueNDRangeKernel(cl_command_queue q, cl_kernel k, cl_uint dim, const size_t *offset,
                              const size_t *global, const size_t *local, cl_uint n,
                              const cl_event *wait, cl_event *ev)
{
    cl_int rc = NEXT(clEnqueueNDRangeKernel)(q, k, dim, offset, global, local, n, wait, ev);
    if (rc == CL_SUCCESS) {
        char name[256] = "?", device[256] = "?";
        cl_device_id d = NULL;
        NEXT(clGetKernelInfo)(k, CL_KERNEL_FUNCTION_NAME, sizeof name - 1, name, NULL);
        if (NEXT(clGetCommandQueueInfo)(q, CL_QUEUE_DEVICE, sizeof d, &d, NULL) == CL_SUCCESS)
            NEXT(clGetDeviceInfo)(d, CL_DEVICE_NAME, sizeof device - 1, device, NULL);
        log_line("launch", name, device);
    }
    return rc;
}

/* Keeps the last reference of a buffer (see the top of the file); sub-buffers and images
 * are released as usual. */
cl_int clReleaseMemObject(cl_mem mem)
{
    cl_mem_object_type type = 0;
    cl_uint refs = 0;
    cl_mem parent = NULL;
    if (NEXT(clGetMemObjectInfo)(mem, CL_MEM_TYPE, sizeof type, &type, NULL) == CL_SUCCESS &&
        type == CL_MEM_OBJECT_BUFFER &&
        NEXT(clGetMemObjectInfo)(mem, CL_MEM_ASSOCIATED_MEMOBJECT, sizeof parent, &parent, NULL) ==
            CL_SUCCESS &&
        parent == NULL &&
        NEXT(clGetMemObjectInfo)(mem, CL_MEM_REFERENCE_COUNT, sizeof refs, &refs, NULL) ==
            CL_SUCCESS &&
        refs == 1)
        return CL_SUCCESS;
    return NEXT(clReleaseMemObject)(mem);
}
