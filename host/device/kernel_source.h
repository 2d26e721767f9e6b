/* kernel_source.h — the OpenCL C program text: kernels/ *.cl and kernels/lib/ *.h, embedded
 * at build time (cmake/embed_kernels.cmake) or read from --kernel-dir for development.
 * Includes of the form #include "x" are resolved here, each file once (the headers carry
 * guards), with #line markers so compiler messages name the .cl file and line. */
#ifndef TS_KERNEL_SOURCE_H
#define TS_KERNEL_SOURCE_H

#include <stddef.h>

#include "base/error.h"

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

/* Maps line `line` (1-based) of the program text to the kernel file and line its last
 * #line marker names. Returns the file line, or 0 (and file "") if the line is outside
 * the text. For compilers that report places in the program text itself instead of
 * honouring #line (NVIDIA's says `<kernel>:LINE:COL`). */
int kernel_source_locate(const char *program, int line, char *file, size_t cap);

/* Returns a malloc'd copy of a compiler log in which every `<kernel>:LINE:` and
 * `<source>:LINE:` place is rewritten as `kernels/FILE:LINE:` by kernel_source_locate;
 * NULL if out of memory. Logs that already name files pass through unchanged. */
char *kernel_source_translate_log(const char *program, const char *log);

#endif
