/* options.h — everything `tessera render` takes from the command line, zero-initialised
 * with defaults set in one place (STYLE.md 16). */
#ifndef TS_OPTIONS_H
#define TS_OPTIONS_H

#include "device/device.h"
#include "scene/scene_load.h"

typedef struct ts_render_options {
    const char *scene_path;
    const char *output_path;
    const char *stats_path; /* NULL: no --stats */
    int width, height;      /* 0: from the scene's Format, else 640x480 */
    int crop_given;         /* --crop: the part of the frame rendered, instead of the scene's */
    double crop[4];         /* CropWindow: xmin xmax ymin ymax, fractions of the frame */
    int spp;                /* samples per pixel; 0: the scene's PixelSamples, else 1 */
    int depth;              /* path depth (primary rays only for now; kept for the contract) */
    int depth_given; /* --depth was given: the scene's Integrator maxPathLength is not used */
    unsigned seed;
    int max_lod;        /* the finest m: (2^m)^2 micro-quads per patch */
    int fixed_lod;      /* -1: m per patch from the frame's ray density; else this m */
    double dicing_rate; /* --dicing-rate: the ray-density rule's micro-quad size in pixels
                           across (pipeline.h ts_trace_mode); 1 */
    int exact;          /* 1: intersect micro-triangles; 0: leaf boxes (hole-free) */
    int sampling;       /* TS_SAMPLING_*: light and BSDF sampling by MIS, or one alone */
    int leaf_group;     /* 1: work-group-wide leaf intersection; 0: per ray */
    int leaf_size;      /* leaves of leaf_size x leaf_size micro-quads: 1, 2 or 4 */
    int memory_mb;      /* budget for rays, pairs and patch slots; 0: budget_default */
    int streams;        /* --streams: waves in flight on each device, each with its own host thread,
                           queue and share of the device's budget (app/workers.c); 1 */
    int quiet;
    int resume;                 /* 1: continue the partial EXR at output_path (--resume) */
    int frame;                  /* the RIB frame to render (FrameBegin number); -1: the first */
    int strict;                 /* --strict: a missing texture or archive is an error */
    int no_programs;            /* --no-programs: Procedural "RunProgram" is skipped, not run */
    int up;                     /* --up: a mesh's up axis (scene_load.h TS_UP_*); 0: the file's */
    const char *occlusion_path; /* --occlusion: relight with this bake (docs/bake.md); NULL:
                                   none */
    int mpi_scene_load;         /* --mpi-scene load: every MPI rank loads the scene files; 0
                                   (broadcast): rank 0 sends the scene it loaded (app/ranks.h) */
    ts_device_options cl;
} ts_render_options;

/* Defaults: spp from the scene (else 1), depth 3, seed 0, max_lod 10, ray-driven LOD, leaf boxes as
 * geometry, memory sized by budget_default (app/budget.h), device from TESSERA_DEVICE. */
void render_options_defaults(ts_render_options *o);

/* Reads `render`'s arguments (argv[0] is "render") over the defaults in o with getopt_long;
 * o keeps pointers into argv. Returns TS_OK, or TS_E_USAGE with the message main() prints
 * (an unknown option, a bad value, not exactly one scene file). --help stops the parsing
 * with *help = 1: the caller prints the usage. */
int render_options_parse(int argc, char **argv, ts_render_options *o, int *help, ts_error *err);

/* How the scene of o is loaded: its --frame, --quiet, --strict, --no-programs and --up. */
void render_load_options(const ts_render_options *o, ts_load_options *lo);

/* Shared by every subcommand's parser (render, bake), so that they accept and refuse values
 * alike. options_parse_int: a decimal int in [lo, hi], nothing around it; options_parse_res:
 * "WxH", each in 1..65536, nothing around them. Both return 0 on success. */
struct option;
int options_parse_int(const char *s, int lo, int hi, int *out);
int options_parse_res(const char *s, int *w, int *h);
/* The message for what getopt_long (optstring starting with ':') refused: c is ':' for an
 * option without its value, '?' for an unknown option or a flag given a value; `longopts`
 * names the flags. Returns TS_E_USAGE. */
int options_error(int c, char **argv, const struct option *longopts, ts_error *err);

#endif
