/* bench_scene_load.c — how long a scene takes to load and how much host memory it needs
 * (issue 7: the forest's load time and memory for 1, 100 and 1000 trees, docs/benchmarks.md).
 *
 * Loads each scene R times with scene_load (RIB or mesh, host/scene_load.h: parsing,
 * procedurals, scene_finalize) and prints the patch count, micropolygons_potential
 * (patches * 4^TS_LOD_LIMIT, as --stats counts it), the median load time and the peak
 * resident set of the process (getrusage; the process holds one scene at a time, so run
 * one process per scene to compare). No OpenCL device is opened.
 *
 * usage: bench_scene_load [--repeat R] SCENE...
 */
#include "scene_load.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int repeat = 3, c;
    static const struct option opts[] = {{"repeat", required_argument, 0, 'r'}, {0, 0, 0, 0}};
    while ((c = getopt_long(argc, argv, "r:", opts, NULL)) != -1) {
        if (c == 'r' && atoi(optarg) >= 1 && atoi(optarg) <= 100) {
            repeat = atoi(optarg);
        } else {
            fprintf(stderr, "usage: bench_scene_load [--repeat R] SCENE...\n");
            return 1;
        }
    }
    if (optind >= argc) {
        fprintf(stderr, "usage: bench_scene_load [--repeat R] SCENE...\n");
        return 1;
    }
    printf("%-28s %10s %14s %10s %12s\n", "scene", "patches", "potential", "load s", "peak RSS MiB");
    for (int a = optind; a < argc; a++) {
        double t[100];
        uint32_t patches = 0;
        for (int r = 0; r < repeat; r++) {
            ts_scene s;
            ts_error e = {0};
            memset(&s, 0, sizeof s);
            double t0 = now();
            int rc = scene_load(argv[a], &s, 1, &e);
            t[r] = now() - t0;
            if (rc != TS_OK) {
                fprintf(stderr, "bench_scene_load: %s\n", e.msg);
                return 1;
            }
            patches = s.patch_count;
            scene_free(&s);
        }
        qsort(t, (size_t)repeat, sizeof t[0], cmp_double);
        struct rusage ru;
        getrusage(RUSAGE_SELF, &ru);
        double potential = (double)patches * (double)(1u << (2 * TS_LOD_LIMIT));
        printf("%-28s %10u %14.4g %10.3f %12.1f\n", argv[a], patches, potential, t[repeat / 2],
               (double)ru.ru_maxrss / 1024.0);
    }
    return 0;
}
