/* rib_ris.c — the frame of RIB as RenderMan 21-26 (RIS) writes it, around the classic
 * requests: Integrator (PxrPathTracer's maxPathLength gives the path depth), Option (the
 * "Ri" options run the classic requests' handlers, "user" values for IfBegin, "searchpath"
 * for archives and textures), Attribute "user", Camera (names the camera's coordinate
 * system), and DisplayFilter, SampleFilter and Hider, accepted with one warning per name.
 * Projection "PxrPerspective" is in rib_state.c with "perspective". docs/rib.md "RenderMan
 * 21-26 (RIS)" has the rules. */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* ---- Integrator ---------------------------------------------------------------------- */

/* PxrPathTracer's parameters that only steer the noise, not what the image converges to
 * (sample counts per bounce and lobe, their mode, Russian roulette, which is unbiased, and the
 * continuation rays' length): silent whatever their value, as Tessera's estimator stands in
 * for RenderMan's. The others (allowCaustics, clampDepth and clampLuminance, which bias the
 * image, ...) still warn once each. */
static int integrator_steers_noise(const char *name)
{
    static const char *const names[] = {
        "numLightSamples",    "numBxdfSamples",       "numIndirectSamples",   "numDiffuseSamples",
        "numSpecularSamples", "numSubsurfaceSamples", "numRefractionSamples", "sampleMode",
        "rouletteDepth",      "rouletteThreshold",    "maxContinuationLength"};
    return rib_in_list(name, names, RIB_COUNT(names));
}

/* Integrator "PxrPathTracer" "handle" ["int maxPathLength" [n]]: the path depth
 * (camera.depth) unless --depth is given. Every other integrator renders as the path tracer,
 * with one warning; its parameters are not read. */
int rib_req_integrator(rib_parser *p)
{
    const char *name;
    char shown[RIB_PRINT_MAX], what[RIB_WARN_KEY];
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_string_arg(p, 0, "an integrator name", &name);
    if (rc != TS_OK) return rc;
    if (strcmp(name, "PxrPathTracer") != 0) {
        snprintf(what, sizeof what, "Integrator \"%s\" renders as PxrPathTracer (path tracing)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->args[0].line, p->args[0].col, what);
        return TS_OK;
    }
    size_t i = 1; /* the handle, a string, is optional */
    if (i < p->nargs && p->args[i].kind == RIB_ARG_STRING &&
        (i + 1 >= p->nargs || p->args[i + 1].kind == RIB_ARG_STRING))
        i++;
    for (; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "maxPathLength") != 0) {
            if (!integrator_steers_noise(prm.name)) rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_param_numbers(p, &prm, 1, &v, NULL);
        if (rc != TS_OK) return rc;
        if (!(v[0] >= 0.0 && v[0] <= 64.0 && v[0] == floor(v[0])))
            return rib_error_at(p, prm.val->line, prm.val->col,
                                "Integrator: maxPathLength must be an integer in [0, 64], got %g",
                                v[0]);
        p->scene->camera.depth = (int)v[0];
        p->scene->camera.has_depth = 1;
    }
    return TS_OK;
}

/* ---- Option "Ri" ---------------------------------------------------------------------- */

/* Runs handler fn as request `req` on the one argument [v], at the value's position. */
static int rib_run_as(rib_parser *p, const char *req, int (*fn)(rib_parser *), const double *v,
                      size_t n, const rib_arg *at)
{
    rib_arg *saved = malloc(p->nargs * sizeof *saved + 1);
    if (!saved) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    memcpy(saved, p->args, p->nargs * sizeof *saved);
    size_t nargs = p->nargs;
    char name[sizeof p->req];
    memcpy(name, p->req, sizeof name);
    int line = p->req_line, col = p->req_col;
    p->req_line = at->line, p->req_col = at->col; /* messages point at the option's value */
    p->nargs = 0;
    int rc = rib_args_push_numbers(p, v, n, at->line, at->col);
    snprintf(p->req, sizeof p->req, "%s", req);
    if (rc == TS_OK) rc = fn(p);
    memcpy(p->req, name, sizeof name);
    p->req_line = line, p->req_col = col;
    memcpy(p->args, saved, nargs * sizeof *saved); /* the pool holds at least nargs + 1 */
    p->nargs = nargs;
    free(saved);
    return rc;
}

/* Option "Ri": FormatResolution [w h] and FormatPixelAspectRatio [a] as Format w h a (a
 * resolution alone keeps the default aspect, an aspect alone the current Format or the
 * default size), CropWindow, Shutter, ScreenWindow and Clipping as those requests, each
 * through its handler (with its checks and warnings). Other "Ri" options are ignored with one
 * warning each. */
static int rib_option_ri(rib_parser *p)
{
    const double *res = NULL, *aspect = NULL;
    const rib_arg *format_at = NULL;
    int rc = rib_before_world(p);
    for (size_t i = 1; rc == TS_OK && i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) break;
        static const struct {
            const char *name, *req;
            size_t n;
            int (*fn)(rib_parser *);
        } runs[] = {
            {"CropWindow", "CropWindow", 4, rib_req_crop_window},
            {"Shutter", "Shutter", 2, rib_req_shutter},
            {"ScreenWindow", "ScreenWindow", 4, rib_req_screen_window},
            {"Clipping", "Clipping", 2, rib_req_clipping},
        };
        size_t k = 0;
        while (k < sizeof runs / sizeof runs[0] && strcmp(prm.name, runs[k].name) != 0)
            k++;
        if (k < sizeof runs / sizeof runs[0]) {
            rc = rib_param_numbers(p, &prm, runs[k].n, &v, NULL);
            if (rc == TS_OK) rc = rib_run_as(p, runs[k].req, runs[k].fn, v, runs[k].n, prm.val);
        } else if (strcmp(prm.name, "FormatResolution") == 0) {
            rc = rib_param_numbers(p, &prm, 2, &res, NULL);
            format_at = prm.val;
        } else if (strcmp(prm.name, "FormatPixelAspectRatio") == 0) {
            rc = rib_param_numbers(p, &prm, 1, &aspect, NULL);
            if (!format_at) format_at = prm.val;
        } else {
            rib_warn_param(p, &prm);
        }
    }
    if (rc != TS_OK || !format_at) return rc;
    const ts_camera *c = &p->scene->camera;
    double f[3] = {res             ? res[0]
                   : c->has_format ? c->width
                                   : -1,
                   res             ? res[1]
                   : c->has_format ? c->height
                                   : -1,
                   aspect ? aspect[0] : -1};
    return rib_run_as(p, "Format", rib_req_format, f, 3, format_at);
}

/* ---- user values ("user" options and attributes, for IfBegin) ------------------------ */

#define RIB_MAX_USER 4096 /* user values defined at once */

/* A value of Option "user" (depth SIZE_MAX: not scoped) or Attribute "user" (the block
 * depth it was set at: dropped when that block ends). */
typedef struct rib_user_value {
    char *name;
    char *str; /* NULL: a number */
    double num;
    size_t depth;
} rib_user_value;

struct rib_user {
    rib_user_value *v;
    size_t count, cap;
};

void rib_user_free(rib_parser *p)
{
    if (!p->user) return;
    for (size_t k = 0; k < p->user->count; k++)
        free(p->user->v[k].name), free(p->user->v[k].str);
    free(p->user->v);
    free(p->user);
    p->user = NULL;
}

int rib_user_get(const rib_parser *p, const char *name, const char **str, double *num)
{
    if (!p->user) return 0;
    for (size_t k = p->user->count; k-- > 0;) /* the latest (innermost) first */
        if (strcmp(p->user->v[k].name, name) == 0) {
            *str = p->user->v[k].str;
            *num = p->user->v[k].num;
            return 1;
        }
    return 0;
}

void rib_user_scope_end(rib_parser *p)
{
    if (!p->user) return;
    size_t n = 0;
    for (size_t k = 0; k < p->user->count; k++) {
        rib_user_value *u = &p->user->v[k];
        if (u->depth != SIZE_MAX && u->depth > p->depth)
            free(u->name), free(u->str);
        else
            p->user->v[n++] = *u;
    }
    p->user->count = n;
}

/* Sets name to the parameter's value (its first string or number) at `depth`. */
static int rib_user_set(rib_parser *p, const rib_param *prm, size_t depth)
{
    char shown[RIB_PRINT_MAX];
    const rib_arg *v = prm->val;
    if (v->count == 0)
        return rib_error_at(p, v->line, v->col, "%s \"user\": \"%s\" has no value", p->req,
                            rib_printable(prm->name, shown));
    if (!p->user && !(p->user = calloc(1, sizeof *p->user)))
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    struct rib_user *u = p->user;
    rib_user_value *e = NULL;
    for (size_t k = 0; k < u->count && !e; k++) /* the same name at the same depth: replaced */
        if (u->v[k].depth == depth && strcmp(u->v[k].name, prm->name) == 0) e = &u->v[k];
    if (!e) {
        if (u->count == RIB_MAX_USER)
            return rib_error_at(p, v->line, v->col, "%s \"user\": more than %d values", p->req,
                                RIB_MAX_USER);
        if (u->count == u->cap) {
            size_t cap = u->cap ? u->cap * 2 : 16;
            rib_user_value *nv = realloc(u->v, cap * sizeof *nv);
            if (!nv) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
            u->v = nv, u->cap = cap;
        }
        e = &u->v[u->count];
        memset(e, 0, sizeof *e);
        if (!(e->name = strdup(prm->name)))
            return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        e->depth = depth;
        u->count++;
    }
    free(e->str);
    e->str = NULL;
    e->num = 0.0;
    int is_str = v->kind == RIB_ARG_STRING || v->kind == RIB_ARG_STRINGS;
    if (is_str && !(e->str = strdup(rib_arg_str(p, v, 0))))
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    if (!is_str) e->num = rib_arg_nums(p, v)[0];
    return TS_OK;
}

/* The parameters of a "user" Option or Attribute. */
static int rib_user_params(rib_parser *p, size_t depth)
{
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc == TS_OK) rc = rib_user_set(p, &prm, depth);
        if (rc != TS_OK) return rc;
    }
    return TS_OK;
}

/* ---- Option, Attribute ---------------------------------------------------------------- */

/* Warns once that `Request "name"` is ignored. */
static void rib_warn_named(rib_parser *p, const char *name)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    snprintf(what, sizeof what, "%s \"%s\" is ignored", p->req, rib_printable(name, shown));
    rib_warn_once(p, p->req_line, p->req_col, what);
}

int rib_req_option(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "an option name", &name);
    if (rc != TS_OK) return rc;
    if (strcmp(name, "Ri") == 0) return rib_option_ri(p);
    if (strcmp(name, "user") == 0) return rib_user_params(p, SIZE_MAX);
    if (strcmp(name, "searchpath") == 0) return rib_searchpath_option(p);
    /* What changes neither the image nor what is read: the log, the work's order and memory,
     * the RIB parser's settings, checkpoints, the AOVs' light path expressions (RenderMan for
     * Maya writes them in every frame). Other options (trace, hair, ...) warn once each. */
    static const char *const silent[] = {"statistics", "bucket",     "limits",
                                         "ribparse",   "checkpoint", "lpe"};
    if (!rib_in_list(name, silent, RIB_COUNT(silent))) rib_warn_named(p, name);
    return TS_OK;
}

/* Attribute "displacementbound" "sphere" [r] ["coordinatesystem" ["object"]]: read, checked
 * (r >= 0 and finite) and not needed: Tessera bounds each displaced patch from the
 * displacement's own parameters (a texture's min-max pyramid), which is never looser. */
static int rib_displacement_bound(rib_parser *p)
{
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "coordinatesystem") == 0) continue;
        if (strcmp(prm.name, "sphere") != 0) {
            rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_param_numbers(p, &prm, 1, &v, NULL);
        if (rc != TS_OK) return rc;
        if (!(v[0] >= 0.0 && v[0] <= 1e30))
            return rib_error_at(p, prm.val->line, prm.val->col,
                                "Attribute \"displacementbound\": sphere must be >= 0 and "
                                "finite, got %g",
                                v[0]);
    }
    return TS_OK;
}

/* Attribute "identifier" "name" ["pCubeShape1"]: the block's name in the identifier paths of
 * look files (rib_rlf.c); "id" and the others are ignored with a warning each. */
static int rib_identifier(rib_parser *p)
{
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        const rib_arg *v = prm.val;
        int one = (v->kind == RIB_ARG_STRING || v->kind == RIB_ARG_STRINGS) && v->count == 1;
        if (strcmp(prm.name, "name") != 0 || !one) {
            rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_rlf_identifier(p, rib_arg_str(p, v, 0));
        if (rc != TS_OK) return rc;
    }
    return TS_OK;
}

/* Which rays see the patches that follow. Whether they cast shadows (TS_PATCH_NO_SHADOW): from
 * Attribute "visibility" "transmission" (PRMan: an int, 0 = casts none; before RenderMan 16 a
 * string, "transparent" = none, "opaque", "Os" or "shader" = casts one) or BMRT's Attribute
 * "render" "casts_shadows" ("none"; "opaque", "Os", "shade"). Shadows stay opaque whatever the
 * opacity: "Os" and "shader"/"shade" cast the opaque shadow, with one warning. Attribute
 * "visibility" "camera" 0 hides the patches from the camera (TS_PATCH_NO_CAMERA), "indirect" 0 from
 * the bounces' BSDF rays (TS_PATCH_NO_INDIRECT). The attributes' other parameters are ignored with
 * a warning each. docs/rib.md "Shadows". */
static int rib_visibility_attribute(rib_parser *p, const char *name, const char *param)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int camera = strcmp(prm.name, "camera") == 0, indirect = strcmp(prm.name, "indirect") == 0;
        if (strcmp(name, "visibility") == 0 && (camera || indirect)) {
            const double *v; /* 0: eye rays, or a bounce's BSDF rays, pass through */
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            *(camera ? &p->no_camera : &p->no_indirect) = v[0] == 0.0;
            continue;
        }
        if (strcmp(prm.name, param) != 0) {
            snprintf(what, sizeof what, "Attribute \"%s\" \"%s\" is ignored", name,
                     rib_printable(prm.name, shown));
            rib_warn_once(p, prm.key->line, prm.key->col, what);
            continue;
        }
        const rib_arg *v = prm.val;
        if ((v->kind == RIB_ARG_NUMBER || v->kind == RIB_ARG_NUMBERS) && v->count == 1) {
            p->no_shadow = rib_arg_nums(p, v)[0] == 0.0;
            continue;
        }
        if (!((v->kind == RIB_ARG_STRING || v->kind == RIB_ARG_STRINGS) && v->count == 1))
            return rib_error_at(p, v->line, v->col,
                                "Attribute \"%s\": \"%s\" takes one value (0 or 1, or a "
                                "string: none/transparent, opaque, Os, shade/shader)",
                                name, param);
        const char *s = rib_arg_str(p, v, 0);
        int none = strcmp(s, "none") == 0 || strcmp(s, "transparent") == 0;
        int opacity = strcmp(s, "Os") == 0 || strcmp(s, "shade") == 0 || strcmp(s, "shader") == 0;
        if (!none && !opacity && strcmp(s, "opaque") != 0)
            return rib_error_at(p, v->line, v->col,
                                "Attribute \"%s\": unknown \"%s\" \"%s\" (none, transparent, "
                                "opaque, Os, shade or shader)",
                                name, param, rib_printable(s, shown));
        if (opacity) {
            snprintf(what, sizeof what,
                     "Attribute \"%s\" \"%s\" \"%s\": the shadow is opaque (Tessera's "
                     "shadows do not read the surface's opacity)",
                     name, param, rib_printable(s, shown));
            rib_warn_once(p, v->line, v->col, what);
        }
        p->no_shadow = none;
    }
    return TS_OK;
}

int rib_req_attribute(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "an attribute name", &name);
    if (rc != TS_OK) return rc;
    if (strcmp(name, "user") == 0) return rib_user_params(p, p->depth);
    if (strcmp(name, "displacementbound") == 0) return rib_displacement_bound(p);
    if (strcmp(name, "identifier") == 0) return rib_identifier(p);
    if (strcmp(name, "visibility") == 0) return rib_visibility_attribute(p, name, "transmission");
    if (strcmp(name, "render") == 0) return rib_visibility_attribute(p, name, "casts_shadows");
    rib_warn_named(p, name);
    return TS_OK;
}

/* ---- Camera, filters ------------------------------------------------------------------ */

/* Camera "name" [params]: names the camera's coordinate system (camera space, what
 * CoordSysTransform "camera" gives), as CoordinateSystem would there; the camera rendered is
 * the one in effect at WorldBegin, as before. Parameters are ignored with one warning each,
 * except a shutterOpening of [0 1], which is what Tessera's shutter does. */
int rib_req_camera(rib_parser *p)
{
    const char *name;
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_string_arg(p, 0, "a camera name", &name);
    if (rc == TS_OK) {
        double m[16], m1[16];
        int moving = p->ctm_moving;
        memcpy(m, p->ctm, sizeof m), memcpy(m1, p->ctm1, sizeof m1);
        mat4_identity(p->ctm), mat4_identity(p->ctm1), p->ctm_moving = 0;
        rc = rib_coordsys_mark(p, name, 0);
        memcpy(p->ctm, m, sizeof m), memcpy(p->ctm1, m1, sizeof m1), p->ctm_moving = moving;
    }
    for (size_t i = 1; rc == TS_OK && i < p->nargs; i += 2) {
        rib_param prm;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) break;
        /* shutterOpening [0 1] (RenderMan for Maya writes it in every frame): a shutter open
         * from the Shutter's open to its close, as Tessera's is; silent at that value only */
        const rib_arg *v = prm.val;
        if (strcasecmp(prm.name, "shutterOpening") == 0 &&
            (v->kind == RIB_ARG_NUMBERS && v->count == 2) && rib_arg_nums(p, v)[0] == 0.0 &&
            rib_arg_nums(p, v)[1] == 1.0)
            continue;
        rib_warn_param(p, &prm);
    }
    return rc;
}

/* DisplayFilter, SampleFilter, Hider "name" [params]: nothing Tessera's film does; one
 * warning per request and name. */
int rib_req_ris_ignored(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "a name", &name);
    if (rc == TS_OK) rib_warn_named(p, name);
    return rc;
}
