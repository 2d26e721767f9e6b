/* rib.c — reads RIB requests (a name, then numbers, strings and [arrays] up to the next
 * name), checks their arguments and hands them to the handlers in rib_state.c and
 * rib_geom.c. Requests the renderer does not need are accepted with one warning per name;
 * others are scene errors. The subset is listed in docs/rib.md. */
#include "scene/rib/rib.h"

#include "scene/rib/rib_internal.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- messages ---------------------------------------------------------------------- */

int rib_error_at(rib_parser *p, int line, int col, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return ts_error_set(p->err, TS_E_SCENE, "%s:%d:%d: error: %s", p->lx.file, line, col, msg);
}

/* Prints "file:line:col: warning: <what>" once per distinct `what` unless quiet. */
void rib_warn_once(rib_parser *p, int line, int col, const char *what)
{
    if (p->quiet) return;
    for (int i = 0; i < p->nwarned; i++)
        if (strncmp(p->warned[i], what, RIB_WARN_KEY - 1) == 0) return;
    if (p->nwarned < RIB_MAX_WARNED) snprintf(p->warned[p->nwarned++], RIB_WARN_KEY, "%s", what);
    fprintf(stderr, "%s:%d:%d: warning: %s\n", p->lx.file, line, col, what);
}

/* ---- argument access ------------------------------------------------------------- */

const char *rib_printable(const char *s, char buf[RIB_PRINT_MAX])
{
    size_t n = 0;
    for (; s[n] && n < RIB_PRINT_MAX - 4; n++) {
        unsigned char c = (unsigned char)s[n];
        buf[n] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
    }
    if (s[n]) buf[n++] = '.', buf[n++] = '.', buf[n++] = '.';
    buf[n] = '\0';
    return buf;
}

const char *rib_arg_str(const rib_parser *p, const rib_arg *a, size_t k)
{
    return p->chars + p->strs[a->first + k];
}

const double *rib_arg_nums(const rib_parser *p, const rib_arg *a)
{
    return p->nums + a->first;
}

static int arg_is_numeric(const rib_arg *a)
{
    return a->kind == RIB_ARG_NUMBER || a->kind == RIB_ARG_NUMBERS;
}

/* Reads n numbers starting at args[*i], given either as n bare numbers or as one [n]
 * array; advances *i past them. */
int rib_numbers(rib_parser *p, size_t *i, size_t n, double *out)
{
    if (*i < p->nargs && p->args[*i].kind == RIB_ARG_NUMBERS) {
        const rib_arg *a = &p->args[*i];
        if (a->count != n)
            return rib_error_at(p, a->line, a->col, "%s expects %zu numbers, got an array of %zu",
                                p->req, n, a->count);
        memcpy(out, rib_arg_nums(p, a), n * sizeof *out);
        (*i)++;
        return TS_OK;
    }
    for (size_t k = 0; k < n; k++, (*i)++) {
        if (*i >= p->nargs)
            return rib_error_at(p, p->req_line, p->req_col, "%s expects %zu numbers, got %zu",
                                p->req, n, k);
        const rib_arg *a = &p->args[*i];
        if (a->kind != RIB_ARG_NUMBER)
            return rib_error_at(p, a->line, a->col, "%s expects %zu numbers", p->req, n);
        out[k] = p->nums[a->first];
    }
    return TS_OK;
}

/* Fails on arguments left after the positional ones of a request without parameters. */
int rib_no_more(rib_parser *p, size_t i)
{
    if (i >= p->nargs) return TS_OK;
    return rib_error_at(p, p->args[i].line, p->args[i].col, "too many arguments to %s", p->req);
}

/* Reads a positive integer (a count, a step, a resolution) at args[*i]. */
int rib_integer(rib_parser *p, size_t *i, const char *what, double max, int *out)
{
    double v;
    int rc = rib_numbers(p, i, 1, &v);
    if (rc != TS_OK) return rc;
    const rib_arg *a = &p->args[*i - 1];
    if (!(v >= 1.0 && v <= max && v == floor(v)))
        return rib_error_at(p, a->line, a->col, "%s: %s must be an integer in [1, %.0f], got %g",
                            p->req, what, max, v);
    *out = (int)v;
    return TS_OK;
}

int rib_string_arg(rib_parser *p, size_t i, const char *what, const char **out)
{
    if (i >= p->nargs)
        return rib_error_at(p, p->req_line, p->req_col, "%s: missing %s (a string)", p->req, what);
    const rib_arg *a = &p->args[i];
    if (a->kind != RIB_ARG_STRING && !(a->kind == RIB_ARG_STRINGS && a->count == 1))
        return rib_error_at(p, a->line, a->col, "%s: expected %s (a string)", p->req, what);
    *out = rib_arg_str(p, a, 0);
    return TS_OK;
}

int rib_param_at(rib_parser *p, size_t i, rib_param *out)
{
    const rib_arg *key = &p->args[i];
    if (key->kind != RIB_ARG_STRING)
        return rib_error_at(p, key->line, key->col, "%s: expected a parameter name (a string)",
                            p->req);
    const char *name = rib_arg_str(p, key, 0);
    char shown[RIB_PRINT_MAX];
    if (i + 1 >= p->nargs)
        return rib_error_at(p, key->line, key->col, "%s: parameter \"%s\" has no value", p->req,
                            rib_printable(name, shown));
    const char *sp = strrchr(name, ' ');
    out->name = sp ? sp + 1 : name;
    out->key = key;
    out->val = &p->args[i + 1];
    return TS_OK;
}

/* The numbers of a parameter value; exactly n of them unless n == 0. */
int rib_param_numbers(rib_parser *p, const rib_param *prm, size_t n, const double **out,
                      size_t *count)
{
    const rib_arg *v = prm->val;
    char shown[RIB_PRINT_MAX];
    if (!arg_is_numeric(v))
        return rib_error_at(p, v->line, v->col, "%s: parameter \"%s\" needs numbers", p->req,
                            rib_printable(prm->name, shown));
    if (n != 0 && v->count != n)
        return rib_error_at(p, v->line, v->col, "%s: parameter \"%s\" needs %zu values, got %zu",
                            p->req, rib_printable(prm->name, shown), n, v->count);
    *out = rib_arg_nums(p, v);
    if (count) *count = v->count;
    return TS_OK;
}

void rib_warn_param(rib_parser *p, const rib_param *prm)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    snprintf(what, sizeof what, "%s parameter \"%s\" is ignored", p->req,
             rib_printable(prm->name, shown));
    rib_warn_once(p, prm->key->line, prm->key->col, what);
}

/* ---- reading requests -------------------------------------------------------------- */

/* Grows buf to hold `need` elements (doubling); NULL with err set when out of memory, buf
 * then still owned by the caller. */
static void *rib_reserve(rib_parser *p, void *buf, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return buf;
    size_t c = *cap ? *cap : 64;
    while (c < need)
        c *= 2;
    void *b = realloc(buf, c * elem);
    if (!b) {
        ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        return NULL;
    }
    *cap = c;
    return b;
}

static int rib_push_number(rib_parser *p, const rib_token *t)
{
    if (p->nnums >= RIB_MAX_VALUES)
        return rib_error_at(p, t->line, t->col, "more than %u numbers in one request",
                            RIB_MAX_VALUES);
    double *n = rib_reserve(p, p->nums, &p->nums_cap, p->nnums + 1, sizeof *n);
    if (!n) return TS_E_MEMORY;
    p->nums = n;
    p->nums[p->nnums++] = t->num;
    return TS_OK;
}

static int rib_push_string(rib_parser *p, const rib_token *t)
{
    if (p->nstrs >= RIB_MAX_VALUES || p->nchars + t->len + 1 > RIB_MAX_CHARS)
        return rib_error_at(p, t->line, t->col, "too many strings in one request");
    size_t *s = rib_reserve(p, p->strs, &p->strs_cap, p->nstrs + 1, sizeof *s);
    if (!s) return TS_E_MEMORY;
    p->strs = s;
    char *c = rib_reserve(p, p->chars, &p->chars_cap, p->nchars + t->len + 1, 1);
    if (!c) return TS_E_MEMORY;
    p->chars = c;
    memcpy(c + p->nchars, t->str, t->len);
    c[p->nchars + t->len] = '\0';
    p->strs[p->nstrs++] = p->nchars;
    p->nchars += t->len + 1;
    return TS_OK;
}

static int rib_push_arg(rib_parser *p, const rib_arg *a)
{
    if (p->nargs >= RIB_MAX_ARGS)
        return rib_error_at(p, a->line, a->col, "more than %u arguments to %s", RIB_MAX_ARGS,
                            p->req);
    rib_arg *args = rib_reserve(p, p->args, &p->args_cap, p->nargs + 1, sizeof *args);
    if (!args) return TS_E_MEMORY;
    p->args = args;
    p->args[p->nargs++] = *a;
    return TS_OK;
}

/* Reads the elements of an array after its '[': all numbers or all strings, no nesting. */
static int rib_read_array(rib_parser *p, const rib_token *open)
{
    rib_arg a = {RIB_ARG_NUMBERS, open->line, open->col, p->nnums, 0};
    for (;;) {
        rib_token t;
        int rc = rib_lex_next(&p->lx, &t);
        if (rc != TS_OK) return rc;
        if (t.kind == RIB_TOK_RBRACKET) return rib_push_arg(p, &a);
        if (t.kind == RIB_TOK_LBRACKET)
            return rib_error_at(p, t.line, t.col, "nested arrays are not allowed");
        if (t.kind == RIB_TOK_EOF)
            return rib_error_at(p, open->line, open->col,
                                "unterminated array ('[' without ']' before the end of file)");
        if (t.kind == RIB_TOK_NAME)
            return rib_error_at(p, open->line, open->col,
                                "unterminated array ('[' without ']' before %s at %d:%d)", t.str,
                                t.line, t.col);
        int is_num = t.kind == RIB_TOK_NUMBER;
        if (a.count == 0) {
            a.kind = is_num ? RIB_ARG_NUMBERS : RIB_ARG_STRINGS;
            a.first = is_num ? p->nnums : p->nstrs;
        } else if ((a.kind == RIB_ARG_NUMBERS) != is_num) {
            return rib_error_at(p, t.line, t.col, "array mixes numbers and strings");
        }
        rc = is_num ? rib_push_number(p, &t) : rib_push_string(p, &t);
        if (rc != TS_OK) return rc;
        a.count++;
    }
}

/* Reads the arguments after a request name, up to the next name or the end of the file,
 * which is left in *next. */
static int rib_read_args(rib_parser *p, rib_token *next)
{
    p->nargs = p->nnums = p->nstrs = p->nchars = 0;
    for (;;) {
        int rc = rib_lex_next(&p->lx, next);
        if (rc != TS_OK) return rc;
        rib_arg a = {RIB_ARG_NUMBER, next->line, next->col, 0, 1};
        if (next->kind == RIB_TOK_NUMBER) {
            a.first = p->nnums;
            rc = rib_push_number(p, next);
        } else if (next->kind == RIB_TOK_STRING) {
            a.kind = RIB_ARG_STRING;
            a.first = p->nstrs;
            rc = rib_push_string(p, next);
        } else if (next->kind == RIB_TOK_LBRACKET) {
            rc = rib_read_array(p, next);
            if (rc != TS_OK) return rc;
            continue;
        } else if (next->kind == RIB_TOK_RBRACKET) {
            return rib_error_at(p, next->line, next->col, "']' without '['");
        } else {
            return TS_OK; /* a name or the end */
        }
        if (rc == TS_OK) rc = rib_push_arg(p, &a);
        if (rc != TS_OK) return rc;
    }
}

/* ---- dispatch ---------------------------------------------------------------------- */

static const struct {
    const char *name;
    int (*fn)(rib_parser *p);
} rib_handlers[] = {
    {"AttributeBegin", rib_req_attribute_begin},
    {"AttributeEnd", rib_req_attribute_end},
    {"Basis", rib_req_basis},
    {"AreaLightSource", rib_req_area_light_source},
    {"Clipping", rib_req_clipping},
    {"Color", rib_req_color},
    {"ConcatTransform", rib_req_concat_transform},
    {"CropWindow", rib_req_crop_window},
    {"Displacement", rib_req_displacement},
    {"Format", rib_req_format},
    {"Identity", rib_req_identity},
    {"LightSource", rib_req_light_source},
    {"MotionBegin", rib_req_motion_begin},
    {"MotionEnd", rib_req_motion_end},
    {"Patch", rib_req_patch},
    {"PatchMesh", rib_req_patch_mesh},
    {"PixelSamples", rib_req_pixel_samples},
    {"Procedural", rib_req_procedural},
    {"Projection", rib_req_projection},
    {"ReadArchive", rib_req_read_archive},
    {"Rotate", rib_req_rotate},
    {"Scale", rib_req_scale},
    {"Shutter", rib_req_shutter},
    {"Surface", rib_req_surface},
    {"Transform", rib_req_transform},
    {"TransformBegin", rib_req_transform_begin},
    {"TransformEnd", rib_req_transform_end},
    {"Translate", rib_req_translate},
    {"WorldBegin", rib_req_world_begin},
    {"WorldEnd", rib_req_world_end},
};

/* Accepted with a warning: they change neither geometry nor camera placement. */
static const char *const rib_ignored[] = {
    "Atmosphere",
    "Attribute",
    "Bound",
    "ClippingPlane",
    "ColorSamples",
    "CoordinateSystem",
    "Declare",
    "DepthOfField",
    "Detail",
    "DetailRange",
    "Display",
    "DisplayChannel",
    "Exposure",
    "Exterior",
    "FrameAspectRatio",
    "FrameBegin",
    "FrameEnd",
    "GeometricApproximation",
    "Hider",
    "Illuminate",
    "Imager",
    "Interior",
    "Matte",
    "Opacity",
    "Option",
    "Orientation",
    "PixelFilter",
    "PixelVariance",
    "Quantize",
    "RelativeDetail",
    "ReverseOrientation",
    "ScreenWindow",
    "ShadingInterpolation",
    "ShadingRate",
    "Sides",
    "TextureCoordinates",
};

/* Known RenderMan requests this loader cannot honour: ignoring them would misplace or
 * drop geometry, so they are errors. */
static const char *const rib_unsupported[] = {
    "ArchiveRecord",
    "Blobby",
    "Cone",
    "CoordSysTransform",
    "Curves",
    "Cylinder",
    "Disk",
    "GeneralPolygon",
    "Hyperboloid",
    "ObjectBegin",
    "ObjectEnd",
    "ObjectInstance",
    "Paraboloid",
    "Perspective",
    "Points",
    "PointsGeneralPolygons",
    "PointsPolygons",
    "Polygon",
    "Skew",
    "SolidBegin",
    "SolidEnd",
    "Sphere",
    "SubdivisionMesh",
    "Torus",
    "TrimCurve",
};

static int rib_in_list(const char *name, const char *const *list, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(name, list[i]) == 0) return 1;
    return 0;
}

#define RIB_COUNT(a) (sizeof(a) / sizeof((a)[0]))

static int rib_dispatch(rib_parser *p)
{
    if (p->motion.active && strcmp(p->req, "MotionEnd") != 0) {
        int rc = rib_motion_check(p);
        if (rc != TS_OK) return rc;
    }
    for (size_t i = 0; i < RIB_COUNT(rib_handlers); i++)
        if (strcmp(p->req, rib_handlers[i].name) == 0) return rib_handlers[i].fn(p);
    if (strcmp(p->req, "version") == 0) return TS_OK; /* RIB header line */
    if (rib_in_list(p->req, rib_ignored, RIB_COUNT(rib_ignored))) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what, "%s is ignored", p->req);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    if (strcmp(p->req, "NuPatch") == 0)
        return rib_error_at(p, p->req_line, p->req_col,
                            "NuPatch is not supported: NURBS patches cannot be loaded "
                            "(use Patch or PatchMesh)");
    if (rib_in_list(p->req, rib_unsupported, RIB_COUNT(rib_unsupported)))
        return rib_error_at(p, p->req_line, p->req_col, "%s is not supported", p->req);
    return rib_error_at(p, p->req_line, p->req_col, "unknown request %s", p->req);
}

/* ---- driver ------------------------------------------------------------------------ */

static const char *const rib_frame_end[] = {"AttributeEnd", "TransformEnd", "WorldEnd"};
static const char *const rib_frame_name[] = {"AttributeBegin", "TransformBegin", "WorldBegin"};

int rib_run_requests(rib_parser *p)
{
    rib_token t;
    int rc = rib_lex_next(&p->lx, &t);
    while (rc == TS_OK && t.kind != RIB_TOK_EOF) {
        if (t.kind != RIB_TOK_NAME)
            return rib_error_at(p, t.line, t.col, "expected a request name, found %s",
                                t.kind == RIB_TOK_NUMBER   ? "a number"
                                : t.kind == RIB_TOK_STRING ? "a string"
                                                           : "a bracket");
        memcpy(p->req, t.str, t.len + 1); /* t.len <= RIB_MAX_NAME */
        p->req_line = t.line;
        p->req_col = t.col;
        rc = rib_read_args(p, &t);
        if (rc == TS_OK) rc = rib_dispatch(p);
    }
    return rc;
}

/* The whole file: its requests, then every block must be closed. */
static int rib_run(rib_parser *p)
{
    int rc = rib_run_requests(p);
    if (rc == TS_OK && p->motion.active)
        rc = rib_error_at(p, p->motion.line, p->motion.col,
                          "MotionBegin is never closed (missing MotionEnd)");
    if (rc == TS_OK && p->depth > 0) {
        const rib_frame *f = &p->stack[p->depth - 1];
        rc = rib_error_at(p, f->line, f->col, "%s is never closed (missing %s)",
                          rib_frame_name[f->kind], rib_frame_end[f->kind]);
    }
    return rc;
}

static void rib_parser_init(rib_parser *p, const char *name, const char *text, size_t len,
                            ts_scene *scene, int quiet, ts_error *err)
{
    rib_lex_init(&p->lx, name ? name : "<string>", text, len, err);
    p->scene = scene;
    p->err = err;
    p->quiet = quiet;
    mat4_identity(p->ctm);
    mat4_identity(p->ctm1);
    p->disp = (rib_disp){TS_DISP_NONE, 4, 0.1, 1.0, 2.0, 0.5, 0, 0.0};
    p->color[0] = p->color[1] = p->color[2] = 1.0;
    p->surface = (rib_surface){TS_MAT_MATTE, 1.0, 0.0, 0.1, 0, 0};
    p->ubasis = basis_bezier;
    p->vbasis = basis_bezier;
    p->phase = RIB_BEFORE_WORLD;
    p->first_patch = scene->patch_count;
    p->first_light = scene->light_count;
    mat4_identity(scene->camera.world_to_camera);
    scene->camera.fov_deg = 90.0;
    scene->camera.width = scene->camera.height = 0;
    scene->camera.has_format = 0;
    scene->camera.spp = 0;
    scene->camera.clip_near = 1e-10, scene->camera.clip_far = 1e30;
    scene->camera.shutter[0] = scene->camera.shutter[1] = 0.0;
    scene->camera.crop[0] = scene->camera.crop[2] = 0.0;
    scene->camera.crop[1] = scene->camera.crop[3] = 1.0;
}

int rib_parse_string(const char *name, const char *text, size_t len, ts_scene *scene, int quiet,
                     ts_error *err)
{
    if (!scene) return ts_error_set(err, TS_E_INTERNAL, "rib_parse_string: no scene");
    rib_parser *p = calloc(1, sizeof *p);
    if (!p) {
        scene_free(scene);
        return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", name ? name : "<string>");
    }
    rib_parser_init(p, name, text, len, scene, quiet, err);
    int rc = rib_run(p);
    if (rc == TS_OK) rc = scene_finalize(scene, err);
    rib_lex_free(&p->lx);
    rib_archive_free(p);
    free(p->args);
    free(p->nums);
    free(p->strs);
    free(p->chars);
    free(p->stack);
    free(p);
    if (rc != TS_OK) scene_free(scene);
    return rc;
}

int rib_load(const char *path, ts_scene *scene, int quiet, ts_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return ts_error_set(err, TS_E_IO, "%s: %s", path, strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len == cap) {
            size_t c = cap ? cap * 2 : 65536;
            char *b = realloc(buf, c);
            if (!b) {
                free(buf);
                fclose(f);
                return ts_error_set(err, TS_E_MEMORY, "%s: out of memory", path);
            }
            buf = b;
            cap = c;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) break;
    }
    int read_failed = ferror(f);
    int saved = errno;
    fclose(f);
    int rc = read_failed ? ts_error_set(err, TS_E_IO, "%s: %s", path, strerror(saved))
                         : rib_parse_string(path, buf, len, scene, quiet, err);
    free(buf);
    return rc;
}
