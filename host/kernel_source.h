/* kernel_source.h — the OpenCL C program text: kernels/ *.cl and kernels/lib/ *.h, embedded
 * at build time (cmake/embed_kernels.cmake) or read from --kernel-dir for development.
 * Includes of the form #include "x" are resolved here, each file once (the headers carry
 * guards), with #line markers so compiler messages name the .cl file and line. */
#ifndef TS_KERNEL_SOURCE_H
#define TS_KERNEL_SOURCE_H

#include "error.h"

typedef struct ts_embedded_file {
    const char *path; /* relative to kernels/, e.g. "dice.cl", "lib/bezier.h" */
    const char *text;
} ts_embedded_file;

/* Null-terminated table generated at build time. */
extern const ts_embedded_file ts_embedded_kernels[];

/* Builds the whole program text: every top-level *.cl file in name order, includes
 * resolved. kernel_dir NULL = the embedded copy. Returns a malloc'd string or NULL with
 * err set. */
char *kernel_source_program(const char *kernel_dir, ts_error *err);

#endif
