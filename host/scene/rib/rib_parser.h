/* rib_parser.h — the state of one RIB parse, shared by every part of the RIB reader and
 * private to it: the bounds on what a file may ask for, the current request's arguments
 * (filled and read by rib_args.c) and the graphics state the handlers keep (rib_state.c
 * and the others; rib_internal.h says which file does what).
 *
 * Matrices are row-major 4x4 doubles acting on column vectors (p' = M p), as in scene.h.
 * RIB writes matrices for row vectors (p' = p M, translation in elements 12..14), so a RIB
 * [16] array is transposed on input.
 */
#ifndef TS_RIB_PARSER_H
#define TS_RIB_PARSER_H

#include "base/error.h"
#include "scene/rib/basis.h"
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
/* Patches that ObjectInstance may add to a scene, all instances together: each instance is
 * a copy (about 0.5 KB a patch on the host), and a few bytes of RIB can instance an object
 * many times, so the copies are bounded (rib_object.c). */
#define RIB_MAX_INSTANCED_PATCHES (1u << 20)
/* Requests that inline archives may run, every ReadArchive of them together: an archive that
 * reads another ten times, sixteen deep, would run 10^16 (rib_inline.c);
 * $TESSERA_MAX_INLINE_REQUESTS lowers it (the fuzzer). */
#define RIB_MAX_INLINE_REQUESTS (1u << 26)

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
    RIB_FRAME_SOLID, /* SolidBegin: saves what AttributeBegin saves, as Aqsis does */
} rib_frame_kind;

/* SolidBegin's operations (RI Spec 3.2 §5.9), in the order of rib_solid_ops. */
typedef enum rib_solid_op {
    RIB_SOLID_PRIMITIVE,
    RIB_SOLID_UNION,
    RIB_SOLID_INTERSECTION,
    RIB_SOLID_DIFFERENCE,
} rib_solid_op;

/* The Displacement attribute (docs/rib.md). kind TS_DISP_NONE: off. */
typedef struct rib_disp {
    uint32_t kind, octaves;
    double amplitude, frequency, lacunarity, gain;
    uint32_t tex;  /* "texture": the scene texture (TS_TEX_MINMAX) */
    double offset; /* "texture": texel value of zero displacement */
    /* Displace "PxrDisplace" from a PxrTexture (rib_bxdf.c): its texture coordinates are the
     * patch's st mapped s' = st_map[0] s + st_map[1], t' = st_map[2] t + st_map[3]. */
    int has_st_map;
    double st_map[4];
} rib_disp;

/* The current Surface (rib_shading.c). */
typedef struct rib_surface {
    uint32_t material; /* TS_MAT_* */
    double kd, ks, roughness;
    double ior;   /* TS_MAT_GLASS: the index of refraction inside */
    int textured; /* "texturename": Cs is multiplied by scene texture tex (TS_TEX_RGB) */
    uint32_t tex;
    int constant; /* Surface "constant": the patch emits its colour Cs and reflects nothing */
    /* Bxdf (rib_bxdf.c): its colour replaces Color and "Cs" (has_color); the patch also emits
     * radiance emit (PxrSurface's glow, PxrConstant); a PxrTexture's st map as rib_disp's. */
    int has_color;
    double color[3], emit[3];
    int has_st_map;
    double st_map[4];
    /* TS_MAT_PRINCIPLED (rib_bxdf.c): ts_patch_attr's fields of the same names */
    double metallic, specular, specular_tint, sheen, sheen_tint, clearcoat, clearcoat_gloss;
    /* LamaSheen (rib_bxdf.c): a lobe Tessera does not draw; black alone, and as a LamaLayer's
     * top it leaves the base as it is */
    int sheen_only;
    /* presence from a texture (rib_bxdf.c bxdf_cutout): the patch is cut out where the mask,
     * texture cutout_tex's alpha (its first channel with cutout_red), is below 0.5; the
     * texture is the colour texture when textured, and shares its st map */
    int cutout, cutout_red;
    uint32_t cutout_tex;
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
    double opacity[3];
    int no_shadow;      /* the patches cast no shadow (TS_PATCH_NO_SHADOW) */
    int no_camera;      /* the camera does not see them (TS_PATCH_NO_CAMERA) */
    int no_indirect;    /* indirect rays do not see them (TS_PATCH_NO_INDIRECT) */
    int trim;           /* the current TrimCurve (rib_trim.c): its number, 0 for none */
    rib_solid_op solid; /* RIB_FRAME_SOLID: its operation */
} rib_frame;

/* An open MotionBegin [t0 t1] block: its two samples, either two Patch requests of one
 * type or two transformations of one kind, applied at MotionEnd. */
typedef struct rib_motion {
    int active;
    int line, col;                /* of MotionBegin */
    double t[2];                  /* its times */
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
    /* Two samples of a surface request other than Patch (PatchMesh, SubdivisionMesh, ...,
     * rib_state.c rib_motion_deforms): the first adds its patches from first_patch on, `made`
     * of them; the second gives each of them, in the same order, its points at shutter close
     * (rib_geom.c geom_emit), `set` so far. sample: which of the two is being read. */
    int deform, sample;
    uint32_t first_patch, made, set;
} rib_motion;

typedef enum rib_world_phase { RIB_BEFORE_WORLD, RIB_IN_WORLD, RIB_AFTER_WORLD } rib_world_phase;

#define RIB_MAX_FRAMES_LISTED 16 /* frame numbers a "no frame N" message lists */

/* What a frame read by default had at its FrameBegin, to go back to when its Display shows
 * it to be a depth-map pass (rib_frames.c). */
typedef struct rib_frame_start {
    rib_frame attrs; /* the CTM and attributes, as a block saves them */
    ts_camera camera;
    uint32_t patch_count, light_count;
    int dome;
} rib_frame_start;

/* FrameBegin/FrameEnd blocks (rib_frames.c): one of them is read, the others skipped. */
typedef struct rib_frame_choice {
    int wanted;        /* the FrameBegin number to read; -1: the first frame */
    int keep_depth;    /* wanted -1: read the first frame even if it is a depth-map pass */
    int depth_skipped; /* depth-map passes left for a later frame (wanted -1) */
    int depth_between; /* the last primary Display outside frames writes a depth map: */
    char between_type[RIB_PRINT_MAX], between_mode[RIB_PRINT_MAX]; /* its type and mode */
    rib_frame_start start;                                         /* of the frame being read */
    int open;              /* inside FrameBegin ... FrameEnd */
    int reading;           /* the open frame is the one read */
    int done;              /* the frame read has ended: the rest of the file is skipped */
    int line, col, number; /* of the open FrameBegin */
    int count;             /* FrameBegin blocks seen */
    int numbers[RIB_MAX_FRAMES_LISTED]; /* the numbers of the first ones, for messages */
} rib_frame_choice;

/* How a parse runs (rib.c rib_parse): no warnings; missing files are errors (rib.h
 * rib_load_with). */
#define RIB_QUIET 1u
#define RIB_STRICT 2u
#define RIB_PROGRAMS 4u /* Procedural "RunProgram" runs its program (rib_program.c) */

typedef struct rib_parser {
    rib_lexer lx;
    ts_scene *scene;
    ts_error *err;
    int quiet;
    int strict;       /* a file that cannot be read is an error, not a warning and a fallback */
    int run_programs; /* RIB_PROGRAMS: Procedural "RunProgram" runs; else it is skipped */
    /* The request being handled and its arguments (pools reset per request). */
    char req[RIB_MAX_NAME + 1];
    int req_line, req_col;
    rib_arg *args;
    size_t nargs, args_cap;
    double *nums;
    size_t nnums, nums_cap;
    double *st_join; /* "s" and "t" joined into "st" (rib_primvar.c), st_join_cap values */
    size_t st_join_cap;
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
    double opacity[3];   /* Opacity: 0 0 0 makes the following geometry absent */
    int no_shadow;       /* Attribute "visibility" "transmission" 0 (rib_ris.c): the following
                            patches cast no shadow (TS_PATCH_NO_SHADOW) */
    int no_camera;       /* Attribute "visibility" "camera" 0: the camera does not see them */
    int no_indirect;     /* Attribute "visibility" "indirect" 0: indirect rays do not */
    int trim;            /* TrimCurve: trims the NuPatch requests that follow (rib_trim.c
                            rib_trim_current); 0 for none */
    uint32_t emit_trim_first, emit_trim_count; /* the trim segments of the NuPatch piece being
                                                  emitted (rib_nurbs.c), 0 0 otherwise */
    rib_motion motion;
    int shutter_given; /* a Shutter request was read: motion blocks take its part of their times
                          (rib_motion_shutter) */
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
    struct rib_include *inc;           /* rib_archive.c: the archives being read, NULL before any */
    struct rib_objects *objects;       /* rib_object.c: ObjectBegin definitions, NULL before any */
    struct rib_coordsystems *coordsys; /* rib_coordsys.c: CoordinateSystem names, or NULL */
    struct rib_user *user;             /* rib_ris.c: "user" options and attributes, or NULL */
    struct rib_cond *cond;             /* rib_cond.c: open IfBegin blocks, or NULL */
    struct rib_resources *resources;   /* rib_resource.c: saved attribute states, or NULL */
    struct rib_patterns *patterns;     /* rib_pattern.c: Pattern nodes by handle, or NULL */
    struct rib_bxdfs *bxdfs;           /* rib_bxdf.c: the materials of Bxdf handles (LamaMix) */
    struct rib_rlf *rlf;               /* rib_rlf.c: identifier names, look-file scopes, or NULL */
    struct rib_trims *trims;           /* rib_trim.c: the TrimCurve requests read, or NULL */
    struct rib_program *programs;      /* rib_program.c: the RunProgram helpers started */
    struct rib_inlines *inlines;       /* rib_inline.c: ArchiveBegin archives, or NULL */
    char *searchpath[3]; /* Option "searchpath": "archive", "texture", "procedural"; or NULL */
    rib_frame_choice frames;
    int world_line, world_col; /* of the WorldBegin read (binary RIB: line 0, col its byte) */
    int world_seen;            /* 1 once a WorldBegin was read */
    char *rm20_map;            /* RenderMan 20's AreaLightSource "rman__EnvMap" (rib_ris_light.c) */
    int rm20_map_line, rm20_map_col;
    int whole_scene; /* rib_load: the file must make a scene (rib_frames.c rib_scene_check) */
} rib_parser;

#endif
