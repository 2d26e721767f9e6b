/* rib_internal.h — what the parts of the RIB loader share, private to them:
 *   rib_lex.c    tokens;
 *   rib.c        reads each request and its arguments, dispatches, rib_load/rib_parse_string;
 *   rib_state.c  graphics state: transformations, blocks, camera options, Color, Basis,
 *                Displacement, motion blocks;
 *   rib_geom.c   Patch, PatchMesh and LightSource into the scene.
 *
 * Matrices are row-major 4x4 doubles acting on column vectors (p' = M p), as in scene.h.
 * RIB writes matrices for row vectors (p' = p M, translation in elements 12..14), so a RIB
 * [16] array is transposed on input.
 */
#ifndef TS_RIB_INTERNAL_H
#define TS_RIB_INTERNAL_H

#include "base/mat4.h"
#include "scene/rib/basis.h"
#include "base/error.h"
#include "scene/rib/rib_lex.h"
#include "scene/scene.h"

#include <stddef.h>
#include <stdint.h>

/* Bounds that keep a hostile file from exhausting memory or stack. */
#define RIB_MAX_VALUES (1u << 24) /* numbers or strings in one request */
#define RIB_MAX_ARGS (1u << 16)   /* arguments of one request */
#define RIB_MAX_CHARS (1u << 26)  /* string bytes in one request */
#define RIB_MAX_DEPTH 1024        /* nested Attribute/Transform blocks */
#define RIB_MAX_WARNED 64         /* distinct warnings remembered */
#define RIB_WARN_KEY 160          /* bytes of one remembered warning */
#define RIB_PRINT_MAX 48          /* bytes of a file string echoed in a message */
#define RIB_MAX_INCLUDE 16        /* nested ReadArchive / DelayedReadArchive files */

typedef enum rib_arg_kind {
    RIB_ARG_NUMBER,
    RIB_ARG_STRING,
    RIB_ARG_NUMBERS, /* [ numbers ], also the empty array [] */
    RIB_ARG_STRINGS, /* [ "strings" ] */
} rib_arg_kind;

/* One argument of a request. first indexes nums (numbers) or strs (strings). */
typedef struct rib_arg {
    rib_arg_kind kind;
    int line, col;
    size_t first, count;
} rib_arg;

typedef enum rib_frame_kind {
    RIB_FRAME_ATTRIBUTE,
    RIB_FRAME_TRANSFORM,
    RIB_FRAME_WORLD,
} rib_frame_kind;

/* The Displacement attribute (docs/rib.md). kind TS_DISP_NONE: off. */
typedef struct rib_disp {
    uint32_t kind, octaves;
    double amplitude, frequency, lacunarity, gain;
    uint32_t tex;  /* "texture": the scene texture (TS_TEX_MINMAX) */
    double offset; /* "texture": texel value of zero displacement */
} rib_disp;

/* The current Surface (rib_shading.c). */
typedef struct rib_surface {
    uint32_t material; /* TS_MAT_* */
    double kd, ks, roughness;
    int textured; /* "texturename": Cs is multiplied by scene texture tex (TS_TEX_RGB) */
    uint32_t tex;
} rib_surface;

/* What AttributeBegin / TransformBegin / WorldBegin saved. */
typedef struct rib_frame {
    rib_frame_kind kind;
    int line, col;
    double ctm[16], ctm1[16];
    int ctm_moving;
    double color[3];
    ts_basis ubasis, vbasis;
    rib_disp disp;
    rib_surface surface;
    double emission[3];
} rib_frame;

/* An open MotionBegin [t0 t1] block: its two samples, either two Patch requests of one
 * type or two transformations of one kind, applied at MotionEnd. */
typedef struct rib_motion {
    int active;
    int line, col;                /* of MotionBegin */
    int count;                    /* samples read so far (0..2) */
    char first[RIB_MAX_NAME + 1]; /* request name of the first sample */
    int first_line, first_col;
    double m[2][16];    /* transformation samples */
    int replace;        /* Transform (replaces the CTM) rather than a concat */
    int bicubic;        /* patch samples: type of the first */
    double g[2][16][3]; /* patch samples: object-space Bézier points */
    int has_n;
    double n[4][3]; /* "N" of the first patch sample, object space */
    int has_cs;
    double cs[3]; /* "Cs" of the first patch sample (its average) */
    int has_st;
    double st[4][2];                  /* "st" of the first patch sample at its corners */
    int p_line, p_col, n_line, n_col; /* of the first sample's "P" and "N" values */
} rib_motion;

typedef enum rib_world_phase { RIB_BEFORE_WORLD, RIB_IN_WORLD, RIB_AFTER_WORLD } rib_world_phase;

typedef struct rib_parser {
    rib_lexer lx;
    ts_scene *scene;
    ts_error *err;
    int quiet;
    /* The request being handled and its arguments (pools reset per request). */
    char req[RIB_MAX_NAME + 1];
    int req_line, req_col;
    rib_arg *args;
    size_t nargs, args_cap;
    double *nums;
    size_t nnums, nums_cap;
    size_t *strs; /* offsets into chars */
    size_t nstrs, strs_cap;
    char *chars;
    size_t nchars, chars_cap;
    /* Graphics state. */
    double ctm[16];  /* object to world in the world block, object to camera before it */
    double ctm1[16]; /* the CTM at shutter close; equal to ctm unless ctm_moving */
    int ctm_moving;
    double color[3];
    ts_basis ubasis, vbasis;
    rib_disp disp;
    rib_surface surface; /* Surface: material of the following patches */
    double emission[3];  /* AreaLightSource: radiance the following patches emit */
    rib_motion motion;
    /* The last world-to-object transform added for a displaced patch, by its CTM. */
    double xf_ctm[16];
    uint32_t xf_index;
    int xf_valid;
    rib_frame *stack;
    size_t depth, stack_cap;
    rib_world_phase phase;
    uint32_t first_patch, first_light; /* what this parse added: may need camera->world */
    char warned[RIB_MAX_WARNED][RIB_WARN_KEY];
    int nwarned;
    struct rib_include *inc; /* rib_archive.c: the archives being read, NULL before any */
} rib_parser;

/* ---- rib.c: messages and argument access ---- */

/* Sets TS_E_SCENE "file:line:col: error: <fmt>" and returns TS_E_SCENE. */
int rib_error_at(rib_parser *p, int line, int col, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* Prints "file:line:col: warning: <what>" once per distinct text unless quiet. */
void rib_warn_once(rib_parser *p, int line, int col, const char *what);

/* s with control and non-ASCII bytes as '?', cut to RIB_PRINT_MAX - 1 bytes ("..."):
 * for echoing file strings in one-line messages. Returns buf. */
const char *rib_printable(const char *s, char buf[RIB_PRINT_MAX]);
const char *rib_arg_str(const rib_parser *p, const rib_arg *a, size_t k);
const double *rib_arg_nums(const rib_parser *p, const rib_arg *a);
/* n numbers at args[*i], as n bare numbers or one [n] array; advances *i past them. */
int rib_numbers(rib_parser *p, size_t *i, size_t n, double *out);
/* Fails when arguments are left from index i on. */
int rib_no_more(rib_parser *p, size_t i);
/* An integer in [1, max] at args[*i]; advances *i. */
int rib_integer(rib_parser *p, size_t *i, const char *what, double max, int *out);
/* A string (or a one-string array) at args[i]. */
int rib_string_arg(rib_parser *p, size_t i, const char *what, const char **out);

/* One "name" value pair of a parameter list; an inline declaration ("float fov",
 * "uniform color lightcolor") is reduced to its last word. */
typedef struct rib_param {
    const char *name;
    const rib_arg *key, *val;
} rib_param;

/* The pair at args[i], args[i + 1]. */
int rib_param_at(rib_parser *p, size_t i, rib_param *out);
/* The numbers of a parameter value: exactly n of them unless n == 0. */
int rib_param_numbers(rib_parser *p, const rib_param *prm, size_t n, const double **out,
                      size_t *count);
/* Warns once that a parameter of the current request is ignored. */
void rib_warn_param(rib_parser *p, const rib_param *prm);

/* ---- rib_state.c: motion blocks ---- */

/* Called for every request inside an open motion block (MotionEnd excepted): fails for
 * requests a motion block may not hold, a third sample, or a kind that differs from the
 * first sample's. */
int rib_motion_check(rib_parser *p);

/* ---- request handlers: all read p->args, return TS_OK or an error code ---- */

int rib_req_identity(rib_parser *p);
int rib_req_translate(rib_parser *p);
int rib_req_rotate(rib_parser *p);
int rib_req_scale(rib_parser *p);
int rib_req_concat_transform(rib_parser *p);
int rib_req_transform(rib_parser *p);
int rib_req_attribute_begin(rib_parser *p);
int rib_req_attribute_end(rib_parser *p);
int rib_req_transform_begin(rib_parser *p);
int rib_req_transform_end(rib_parser *p);
int rib_req_world_begin(rib_parser *p);
int rib_req_world_end(rib_parser *p);
int rib_req_format(rib_parser *p);
int rib_req_projection(rib_parser *p);
int rib_req_color(rib_parser *p);
int rib_req_basis(rib_parser *p);
int rib_req_displacement(rib_parser *p);
int rib_req_motion_begin(rib_parser *p);
int rib_req_motion_end(rib_parser *p);
int rib_req_patch(rib_parser *p);
int rib_req_patch_mesh(rib_parser *p);
int rib_req_light_source(rib_parser *p);

/* `name` relative to the directory of the file being read (absolute names as they are);
 * a malloc'd path or NULL (rib_archive.c). */
char *rib_resolve(const rib_parser *p, const char *name);
/* Reads the texture named by string argument args[i] (relative to the RIB file) as kind
 * TS_TEX_* into the scene; an unreadable file is an error at that argument naming it
 * (rib_shading.c). */
int rib_texture_arg(rib_parser *p, size_t i, uint32_t kind, uint32_t *index);

/* ---- rib_shading.c: Surface, AreaLightSource, LightSource "domelight" ---- */

int rib_req_surface(rib_parser *p);
int rib_req_area_light_source(rib_parser *p);
/* LightSource "domelight": params from index `first`. */
int rib_dome_light(rib_parser *p, size_t first);
/* rib_geom.c: emits the moving patch of a completed motion block (MotionEnd). */
int rib_geom_motion_patch(rib_parser *p);
/* rib_geom.c: the attributes in effect (colour, displacement with its world-to-object
 * transform, surface, emission) for patches a procedural adds; fails where geometry may
 * not stand (after WorldEnd, a projective or, for displacement, singular CTM). */
int rib_geom_procedural_attr(rib_parser *p, ts_patch_attr *attr);

/* ---- rib.c: the request loop, also run on the text of an archive ---- */

/* Reads and dispatches requests from p->lx until its end of file. */
int rib_run_requests(rib_parser *p);

/* ---- rib_options.c: PixelSamples, Clipping, Shutter, CropWindow ---- */

int rib_req_pixel_samples(rib_parser *p);
int rib_req_clipping(rib_parser *p);
int rib_req_shutter(rib_parser *p);
int rib_req_crop_window(rib_parser *p);

/* ---- rib_archive.c: ReadArchive, Procedural ---- */

int rib_req_read_archive(rib_parser *p);
int rib_req_procedural(rib_parser *p);
/* Frees p->inc. */
void rib_archive_free(rib_parser *p);
/* Reads a whole file into a malloc'd buffer; TS_E_IO or TS_E_MEMORY with *errnum set. */
int rib_read_file(const char *path, char **text, size_t *len, int *errnum);

#endif
