/* bake_options.c — `tessera bake`'s options: the defaults, set in one place (STYLE.md 16),
 * and the command line read into them with getopt_long. Nothing here prints or exits. */
#include "app/bake.h"
#include "app/options.h"
#include "lib/sh.h"

#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void bake_options_defaults(ts_bake_options *o)
{
    memset(o, 0, sizeof *o);
    o->bands = 3;
    o->rays = 512;
    o->fixed_lod = -1;
    o->min_points = 4;
    o->max_lod = 10;
    o->memory_mb = 0; /* app/budget.h: sized to the device and the process's limits */
    o->cl.device_index = -1;
    o->frame = -1;
}

enum {
    OPT_BANDS = 256,
    OPT_RAYS,
    OPT_LOD,
    OPT_POINTS,
    OPT_MAX_LOD,
    OPT_RES,
    OPT_COSINE,
    OPT_SPHERE,
    OPT_FRONT,
    OPT_SEED,
    OPT_INTERSECT,
    OPT_DEVICE,
    OPT_MEMORY,
    OPT_STATS,
    OPT_QUIET,
    OPT_RESUME,
    OPT_FRAME,
    OPT_KERNEL_DIR,
    OPT_NO_CACHE,
    OPT_HELP,
    OPT_STRICT,
    OPT_NO_PROGRAMS,
    OPT_UP
};

static const struct option bake_long_options[] = {
    {"output", required_argument, 0, 'o'},
    {"bands", required_argument, 0, OPT_BANDS},
    {"rays", required_argument, 0, OPT_RAYS},
    {"lod", required_argument, 0, OPT_LOD},
    {"points", required_argument, 0, OPT_POINTS},
    {"max-lod", required_argument, 0, OPT_MAX_LOD},
    {"res", required_argument, 0, OPT_RES},
    {"cosine", no_argument, 0, OPT_COSINE},
    {"sphere", no_argument, 0, OPT_SPHERE},
    {"front", no_argument, 0, OPT_FRONT},
    {"seed", required_argument, 0, OPT_SEED},
    {"intersect", required_argument, 0, OPT_INTERSECT},
    {"device", required_argument, 0, OPT_DEVICE},
    {"memory", required_argument, 0, OPT_MEMORY},
    {"stats", required_argument, 0, OPT_STATS},
    {"quiet", no_argument, 0, OPT_QUIET},
    {"resume", no_argument, 0, OPT_RESUME},
    {"frame", required_argument, 0, OPT_FRAME},
    {"kernel-dir", required_argument, 0, OPT_KERNEL_DIR},
    {"no-kernel-cache", no_argument, 0, OPT_NO_CACHE},
    {"help", no_argument, 0, OPT_HELP},
    {"strict", no_argument, 0, OPT_STRICT},
    {"no-programs", no_argument, 0, OPT_NO_PROGRAMS},
    {"up", required_argument, 0, OPT_UP},
    {0, 0, 0, 0},
};

/* Applies option c with argument arg to o; returns 1 for a bad value. */
static int apply_option(int c, const char *arg, ts_bake_options *o)
{
    int v;
    switch (c) {
    case 'o':
        o->output_path = arg;
        return 0;
    case OPT_BANDS:
        return options_parse_int(arg, 1, TS_SH_MAX_BANDS, &o->bands);
    case OPT_RAYS:
        return options_parse_int(arg, 1, 1 << 16, &o->rays);
    case OPT_LOD:
        return options_parse_int(arg, 0, TS_LOD_LIMIT, &o->fixed_lod);
    case OPT_POINTS:
        return options_parse_int(arg, 1, 1 << 21, &o->min_points);
    case OPT_MAX_LOD:
        return options_parse_int(arg, 0, TS_LOD_LIMIT, &o->max_lod);
    case OPT_RES:
        return options_parse_res(arg, &o->width, &o->height);
    case OPT_COSINE:
        o->flags |= TS_BAKE_COSINE;
        return 0;
    case OPT_SPHERE:
        o->flags |= TS_BAKE_SPHERE;
        return 0;
    case OPT_FRONT:
        o->flags |= TS_BAKE_FRONT;
        return 0;
    case OPT_SEED:
        if (options_parse_int(arg, 0, 0x7fffffff, &v)) return 1;
        o->seed = (unsigned)v;
        return 0;
    case OPT_INTERSECT:
        o->exact = strcmp(arg, "triangles") == 0;
        return strcmp(arg, "boxes") != 0 && strcmp(arg, "triangles") != 0;
    case OPT_DEVICE:
        return options_parse_int(arg, 0, 1 << 20, &o->cl.device_index);
    case OPT_MEMORY:
        return options_parse_int(arg, 1, 1 << 24, &o->memory_mb);
    case OPT_STATS:
        o->stats_path = arg;
        return 0;
    case OPT_QUIET:
        o->quiet = 1;
        return 0;
    case OPT_RESUME:
        o->resume = 1;
        return 0;
    case OPT_FRAME:
        return options_parse_int(arg, 0, 0x7fffffff, &o->frame);
    case OPT_KERNEL_DIR:
        o->cl.kernel_dir = arg;
        return 0;
    case OPT_NO_CACHE:
        o->cl.no_cache = 1;
        return 0;
    case OPT_STRICT:
        o->strict = 1;
        return 0;
    case OPT_NO_PROGRAMS:
        o->no_programs = 1;
        return 0;
    case OPT_UP:
        return scene_parse_up(arg, &o->up) != 0;
    }
    return 0;
}

int bake_options_parse(int argc, char **argv, ts_bake_options *o, int *help, ts_error *err)
{
    int c, index = -1;
    *help = 0;
    opterr = 0;
    optind = 1;
    while ((c = getopt_long(argc, argv, ":o:", bake_long_options, &index)) != -1) {
        if (c == OPT_HELP) {
            *help = 1;
            return TS_OK;
        }
        if (c == '?' || c == ':') return options_error(c, argv, bake_long_options, err);
        if (apply_option(c, optarg, o))
            return ts_error_set(err, TS_E_USAGE, "bad value '%s' for %s%s", optarg,
                                index >= 0 ? "--" : "-o",
                                index >= 0 ? bake_long_options[index].name : "");
        index = -1;
    }
    if (optind != argc - 1)
        return ts_error_set(err, TS_E_USAGE,
                            "bake takes exactly one scene file (see tessera --help)");
    o->scene_path = argv[optind];
    return TS_OK;
}
