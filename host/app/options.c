/* options.c — `tessera render`'s options: the defaults, set in one place (STYLE.md 16), and
 * the command line read into them with getopt_long. Nothing here prints or exits: a bad
 * argument comes back as a TS_E_USAGE message, which main() prints. */
#include "app/options.h"

#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void render_options_defaults(ts_render_options *o)
{
    memset(o, 0, sizeof *o);
    o->spp = 0; /* the scene's PixelSamples, else 1 */
    o->depth = 3;
    o->seed = 0;
    o->max_lod = 10;
    o->fixed_lod = -1;
    o->dicing_rate = 1.0; /* Hanika's rule, 4^m >= R / spp */
    o->exact = 0;
    o->leaf_group = 0;
    o->leaf_size = 1;
    o->streams = 1;
    o->memory_mb = 0; /* app/budget.h: sized to the device and the process's limits */
    o->cl.device_index = -1;
    o->frame = -1;
}

void render_load_options(const ts_render_options *o, ts_load_options *lo)
{
    scene_load_options_defaults(lo);
    lo->frame = o->frame;
    lo->quiet = o->quiet;
    lo->strict = o->strict;
    lo->programs = !o->no_programs;
    lo->up = o->up;
}

int options_parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return -1;
    *out = (int)v;
    return 0;
}

/* A decimal number in [lo, hi] (no sign, space, hexadecimal, infinity or NaN). */
static int parse_decimal(const char *s, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    if (!*s || strspn(s, "0123456789.eE-+") != strlen(s) || *s == '+' || *s == '-') return -1;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !(v >= lo && v <= hi)) return -1;
    *out = v;
    return 0;
}

int options_parse_res(const char *s, int *w, int *h)
{
    char *end;
    errno = 0;
    long a = strtol(s, &end, 10);
    if (errno || end == s || *end != 'x' || a < 1 || a > 65536) return -1;
    const char *second = end + 1;
    long b = strtol(second, &end, 10);
    if (errno || end == second || *end || b < 1 || b > 65536 || *second == '+' || *second == '-' ||
        *s == '+' || *s == '-' || *s == ' ' || *second == ' ')
        return -1;
    *w = (int)a, *h = (int)b;
    return 0;
}

/* --crop XMIN,XMAX,YMIN,YMAX: RenderMan's CropWindow, 0 <= min < max <= 1 on both axes. */
static int parse_crop(const char *s, double v[4])
{
    char part[64];
    for (int k = 0; k < 4; ++k) {
        size_t n = strcspn(s, ",");
        if (n == 0 || n >= sizeof part || (k < 3) != (s[n] == ',')) return -1;
        memcpy(part, s, n);
        part[n] = '\0';
        if (parse_decimal(part, 0.0, 1.0, &v[k])) return -1;
        s += n + (k < 3);
    }
    return !(v[0] < v[1] && v[2] < v[3]);
}

enum {
    OPT_RES = 256,
    OPT_CROP,
    OPT_LOD,
    OPT_DICING_RATE,
    OPT_INTERSECT,
    OPT_SAMPLING,
    OPT_LEAF_MODE,
    OPT_LEAF_SIZE,
    OPT_SPP,
    OPT_DEPTH,
    OPT_SEED,
    OPT_DEVICE,
    OPT_MAX_LOD,
    OPT_MEMORY,
    OPT_STATS,
    OPT_QUIET,
    OPT_KERNEL_DIR,
    OPT_NO_CACHE,
    OPT_HELP,
    OPT_RESUME,
    OPT_FRAME,
    OPT_MPI_SCENE,
    OPT_OCCLUSION,
    OPT_STRICT,
    OPT_NO_PROGRAMS,
    OPT_UP,
    OPT_STREAMS
};

static const struct option render_long_options[] = {
    {"output", required_argument, 0, 'o'},
    {"res", required_argument, 0, OPT_RES},
    {"crop", required_argument, 0, OPT_CROP},
    {"spp", required_argument, 0, OPT_SPP},
    {"depth", required_argument, 0, OPT_DEPTH},
    {"seed", required_argument, 0, OPT_SEED},
    {"device", required_argument, 0, OPT_DEVICE},
    {"max-lod", required_argument, 0, OPT_MAX_LOD},
    {"memory", required_argument, 0, OPT_MEMORY},
    {"lod", required_argument, 0, OPT_LOD},
    {"dicing-rate", required_argument, 0, OPT_DICING_RATE},
    {"intersect", required_argument, 0, OPT_INTERSECT},
    {"sampling", required_argument, 0, OPT_SAMPLING},
    {"leaf-mode", required_argument, 0, OPT_LEAF_MODE},
    {"leaf-size", required_argument, 0, OPT_LEAF_SIZE},
    {"stats", required_argument, 0, OPT_STATS},
    {"quiet", no_argument, 0, OPT_QUIET},
    {"kernel-dir", required_argument, 0, OPT_KERNEL_DIR},
    {"no-kernel-cache", no_argument, 0, OPT_NO_CACHE},
    {"help", no_argument, 0, OPT_HELP},
    {"resume", no_argument, 0, OPT_RESUME},
    {"frame", required_argument, 0, OPT_FRAME},
    {"mpi-scene", required_argument, 0, OPT_MPI_SCENE},
    {"occlusion", required_argument, 0, OPT_OCCLUSION},
    {"strict", no_argument, 0, OPT_STRICT},
    {"no-programs", no_argument, 0, OPT_NO_PROGRAMS},
    {"up", required_argument, 0, OPT_UP},
    {"streams", required_argument, 0, OPT_STREAMS},
    {0, 0, 0, 0},
};

/* Applies one option c with argument arg (NULL for flags) to o; returns 1 for a bad value. */
static int apply_option(int c, const char *arg, ts_render_options *o)
{
    int v;
    switch (c) {
    case 'o':
        o->output_path = arg;
        return 0;
    case OPT_RES:
        return options_parse_res(arg, &o->width, &o->height);
    case OPT_CROP:
        o->crop_given = 1;
        return parse_crop(arg, o->crop);
    case OPT_LEAF_MODE:
        o->leaf_group = strcmp(arg, "group") == 0;
        return strcmp(arg, "ray") != 0 && strcmp(arg, "group") != 0;
    case OPT_LEAF_SIZE:
        return options_parse_int(arg, 1, 4, &o->leaf_size) || o->leaf_size == 3;
    case OPT_SAMPLING:
        o->sampling = !strcmp(arg, "mis")     ? (int)TS_SAMPLING_MIS
                      : !strcmp(arg, "light") ? (int)TS_SAMPLING_LIGHT
                      : !strcmp(arg, "bsdf")  ? (int)TS_SAMPLING_BSDF
                                              : -1;
        return o->sampling < 0;
    case OPT_SPP:
        return options_parse_int(arg, 1, 1 << 16, &o->spp);
    case OPT_DEPTH:
        o->depth_given = 1;
        return options_parse_int(arg, 0, 64, &o->depth);
    case OPT_SEED:
        if (options_parse_int(arg, 0, 0x7fffffff, &v)) return 1;
        o->seed = (unsigned)v;
        return 0;
    case OPT_DEVICE: {
        int list[TS_DEVICE_MAX], n;
        o->cl.device_list = arg; /* app/render.c resolves it (dev_select) */
        return dev_parse_list(arg, list, &n);
    }
    case OPT_MAX_LOD:
        return options_parse_int(arg, 0, TS_LOD_LIMIT, &o->max_lod);
    case OPT_LOD:
        return options_parse_int(arg, 0, TS_LOD_LIMIT, &o->fixed_lod);
    case OPT_DICING_RATE:
        return parse_decimal(arg, 1.0 / 64.0, 64.0, &o->dicing_rate);
    case OPT_INTERSECT:
        o->exact = strcmp(arg, "triangles") == 0;
        return strcmp(arg, "boxes") != 0 && strcmp(arg, "triangles") != 0;
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
    case OPT_MPI_SCENE:
        o->mpi_scene_load = strcmp(arg, "load") == 0;
        return strcmp(arg, "load") != 0 && strcmp(arg, "broadcast") != 0;
    case OPT_OCCLUSION:
        o->occlusion_path = arg;
        return 0;
    case OPT_STRICT:
        o->strict = 1;
        return 0;
    case OPT_NO_PROGRAMS:
        o->no_programs = 1;
        return 0;
    case OPT_UP:
        return scene_parse_up(arg, &o->up) != 0;
    case OPT_STREAMS:
        return options_parse_int(arg, 1, 4, &o->streams);
    case OPT_KERNEL_DIR:
        o->cl.kernel_dir = arg;
        return 0;
    case OPT_NO_CACHE:
        o->cl.no_cache = 1;
        return 0;
    }
    return 0;
}

/* c is ':' for an option without its value (argv[optind - 1] is the option as typed), '?'
 * for an unknown one (optopt: its character for a short option, 0 for a long one) or a flag
 * given a value (optopt: the flag's value, above 255). optopt is printed as a character only
 * when it is a printable one. */
int options_error(int c, char **argv, const struct option *longopts, ts_error *err)
{
    if (c == ':')
        return ts_error_set(err, TS_E_USAGE, "option %s needs a value (see tessera --help)",
                            argv[optind - 1]);
    for (const struct option *l = longopts; optopt > 255 && l->name; ++l)
        if (l->val == optopt) /* "--quiet=3" */
            return ts_error_set(err, TS_E_USAGE, "option --%s takes no value (see tessera --help)",
                                l->name);
    if (optopt > 32 && optopt < 127)
        return ts_error_set(err, TS_E_USAGE, "unknown option -%c (see tessera --help)", optopt);
    return ts_error_set(err, TS_E_USAGE, "unknown option %s (see tessera --help)",
                        argv[optind - 1]);
}

int render_options_parse(int argc, char **argv, ts_render_options *o, int *help, ts_error *err)
{
    int c, index = -1;
    *help = 0;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":o:", render_long_options, &index)) != -1) {
        if (c == OPT_HELP) {
            *help = 1;
            return TS_OK;
        }
        if (c == '?' || c == ':') return options_error(c, argv, render_long_options, err);
        if (apply_option(c, optarg, o))
            return ts_error_set(err, TS_E_USAGE, "bad value '%s' for %s%s", optarg,
                                index >= 0 ? "--" : "-o",
                                index >= 0 ? render_long_options[index].name : "");
        index = -1; /* getopt_long sets it for long options only */
    }
    if (optind != argc - 1)
        return ts_error_set(err, TS_E_USAGE,
                            "render takes exactly one scene file (see tessera --help)");
    o->scene_path = argv[optind];
    return TS_OK;
}
