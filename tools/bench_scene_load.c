/* bench_scene_load.c — how long a scene takes to load and how much host memory it needs
 * (issue 7: the forest's load time and memory for 1, 100 and 1000 trees, docs/benchmarks.md).
 *
 * Loads each scene R times with scene_load (RIB or mesh, host/scene/scene_load.h: parsing,
 * procedurals, scene_finalize) and prints the patch count, micropolygons_potential
 * (patches * 4^TS_LOD_LIMIT, as --stats counts it), the median load time and the peak
 * resident set of the process after that scene (getrusage). The process holds one scene at
 * a time, so with the scenes in ascending size each peak is that scene's; for exact figures
 * run one process per scene. No OpenCL device is opened.
 *
 * --size tiny|small|full (tools/bench, issue 8) picks the scenes when none are named, under
 * --scene-dir (default: scene): tiny = teapot and forest-1 once; small = forest-1, -100 and
 * -1000, 3 times each (default); full = the same 9 times. --repeat given after it overrides.
 *
 * usage: bench_scene_load [--size tiny|small|full] [--repeat R] [--scene-dir DIR]
 *                         [--json PATH] [SCENE...]
 */
#include "bench_util.h"
#include "scene/scene_load.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#define MAX_REPEAT 100

static const char *const tiny_scenes[] = {"teapot.rib", "forest-1.rib", NULL};
static const char *const forest_scenes[] = {"forest-1.rib", "forest-100.rib", "forest-1000.rib",
                                            NULL};

static int usage(void)
{
    fprintf(stderr, "usage: bench_scene_load [--size tiny|small|full] [--repeat R] "
                    "[--scene-dir DIR] [--json PATH] [SCENE...]\n");
    return 1;
}

/* Loads `path` repeat times; fills the JSON row and prints the table row. */
static int bench_scene(const char *path, int repeat, cJSON *rows)
{
    double t[MAX_REPEAT];
    uint32_t patches = 0;
    for (int r = 0; r < repeat; r++) {
        ts_scene s;
        ts_error e = {0};
        memset(&s, 0, sizeof s);
        double t0 = bench_now();
        int rc = scene_load(path, &s, 1, &e);
        t[r] = bench_now() - t0;
        if (rc != TS_OK) {
            fprintf(stderr, "bench_scene_load: %s\n", e.msg);
            ts_error_clear(&e);
            return 1;
        }
        patches = s.patch_count;
        scene_free(&s);
    }
    qsort(t, (size_t)repeat, sizeof t[0], bench_cmp_double);
    double median = repeat % 2 ? t[repeat / 2] : 0.5 * (t[repeat / 2 - 1] + t[repeat / 2]);
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    double rss = (double)ru.ru_maxrss * 1024.0; /* Linux reports kilobytes */
    double potential = (double)patches * (double)(1u << (2 * TS_LOD_LIMIT));
    printf("%-28s %10u %14.4g %10.3f %12.1f\n", path, patches, potential, median, rss / 1048576.0);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "scene", path);
    cJSON_AddNumberToObject(o, "patches", patches);
    cJSON_AddNumberToObject(o, "micropolygons_potential", potential);
    cJSON_AddNumberToObject(o, "median_seconds", median);
    cJSON_AddNumberToObject(o, "min_seconds", t[0]);
    cJSON_AddNumberToObject(o, "peak_rss_bytes", rss);
    cJSON_AddItemToArray(rows, o);
    return 0;
}

static int write_json(const char *path, cJSON *root)
{
    char *text = cJSON_Print(root);
    FILE *f = text ? fopen(path, "w") : NULL;
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0) ok = 0;
    free(text);
    if (!ok) fprintf(stderr, "bench_scene_load: cannot write %s\n", path);
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    int repeat = 3, c;
    const char *json_path = NULL, *scene_dir = "scene";
    const char *const *defaults = forest_scenes;
    static const struct option opts[] = {{"repeat", required_argument, 0, 'r'},
                                         {"size", required_argument, 0, 's'},
                                         {"scene-dir", required_argument, 0, 'd'},
                                         {"json", required_argument, 0, 'j'},
                                         {0, 0, 0, 0}};
    while ((c = getopt_long(argc, argv, "r:s:d:j:", opts, NULL)) != -1) {
        if (c == 'r' && atoi(optarg) >= 1 && atoi(optarg) <= MAX_REPEAT) {
            repeat = atoi(optarg);
        } else if (c == 's' && strcmp(optarg, "tiny") == 0) {
            defaults = tiny_scenes;
            repeat = 1;
        } else if (c == 's' && strcmp(optarg, "small") == 0) {
            defaults = forest_scenes;
            repeat = 3;
        } else if (c == 's' && strcmp(optarg, "full") == 0) {
            defaults = forest_scenes;
            repeat = 9;
        } else if (c == 'd') {
            scene_dir = optarg;
        } else if (c == 'j') {
            json_path = optarg;
        } else {
            return usage();
        }
    }
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "benchmark", "scene_load");
    cJSON_AddNumberToObject(root, "repeat", repeat);
    cJSON_AddNumberToObject(root, "lod_limit", TS_LOD_LIMIT);
    cJSON *rows = cJSON_AddArrayToObject(root, "scenes");
    printf("%-28s %10s %14s %10s %12s\n", "scene", "patches", "potential", "load s",
           "peak RSS MiB");
    int rc = 0;
    if (optind < argc) {
        for (int a = optind; a < argc && !rc; a++)
            rc = bench_scene(argv[a], repeat, rows);
    } else {
        for (int k = 0; defaults[k] && !rc; k++) {
            char path[4096];
            snprintf(path, sizeof path, "%s/%s", scene_dir, defaults[k]);
            rc = bench_scene(path, repeat, rows);
        }
    }
    if (!rc && json_path) rc = write_json(json_path, root);
    cJSON_Delete(root);
    return rc;
}
