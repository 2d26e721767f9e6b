/* bake.h — `tessera bake SCENE -o OUT.exr`: spherical-harmonics directional occlusion at the
 * points of every patch (PantaRay §3, §4.4; docs/bake.md), traced by the render's pipeline.
 * Options in a zero-initialised struct with defaults set in one place (STYLE.md 16). */
#ifndef TS_BAKE_H
#define TS_BAKE_H

#include "base/stats.h"
#include "device/device.h"

#include <stdint.h>

typedef struct ts_bake_options {
    const char *scene_path;
    const char *output_path;
    const char *stats_path; /* NULL: no --stats */
    int width, height;      /* the camera image whose pixel footprint sets the default m:
                               --res, else the scene's Format, else 640x480 */
    int bands;              /* B: B^2 coefficients (1..4, default 3) */
    int rays;               /* N per point (default 512, as PantaRay) */
    int fixed_lod;          /* --lod M: every patch at m = M; -1: from the footprint */
    int min_points;         /* --points K: at least K points per patch (default 4: corners) */
    int max_lod;            /* the finest m (default 10) */
    int flags;              /* TS_BAKE_COSINE (--cosine), _SPHERE (--sphere), _FRONT (--front) */
    unsigned seed;
    int exact;     /* --intersect triangles */
    int memory_mb; /* --memory; 0: the default budget (budget.h), as render's */
    int quiet;
    int resume;
    int frame;
    int strict;      /* --strict, as render's */
    int no_programs; /* --no-programs, as render's */
    int up;          /* --up, as render's */
    ts_device_options cl;
} ts_bake_options;

void bake_options_defaults(ts_bake_options *o);
/* Reads `bake`'s arguments (argv[0] is "bake") with getopt_long over the defaults; o keeps
 * pointers into argv. TS_E_USAGE with the message main() prints; --help sets *help. */
int bake_options_parse(int argc, char **argv, ts_bake_options *o, int *help, ts_error *err);

typedef enum ts_bake_outcome {
    TS_BAKE_COMPLETE,    /* every point baked and written */
    TS_BAKE_INTERRUPTED, /* SIGINT or SIGTERM: the points finished so far are written */
    TS_BAKE_UP_TO_DATE,  /* --resume of a finished bake: nothing done */
} ts_bake_outcome;

typedef struct ts_bake_result {
    ts_bake_outcome outcome;
    uint64_t points_done, points_total, rays;
    double seconds; /* the waves' wall time */
    int signal;
} ts_bake_result;

/* Bakes options->scene_path into options->output_path; fills stats (bake_points, rays,
 * stages, the "bake" summary) and result. While points are baked, SIGINT, SIGTERM and SIGHUP stop
 * the bake after the current wave and write what is finished; --resume continues it. */
int bake_run(const ts_bake_options *options, ts_stats *stats, ts_bake_result *result,
             ts_error *err);

#endif
