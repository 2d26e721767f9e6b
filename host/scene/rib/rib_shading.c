/* rib_shading.c — the RIB requests that say how surfaces look and what lights them:
 * Surface (RenderMan's matte, plastic, paintedplastic, metal, shinymetal and constant, with
 * the current Color as Cs), AreaLightSource "arealight" (the following patches emit),
 * Opacity (fully transparent or opaque).
 * DESIGN.md §3. */
#include "scene/rib/rib_internal.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* Reads parameters named in `names` (one number each, or three for colours) into `out`;
 * `skip` (or NULL) is handled by the caller; other names are warned about once. */
static int shading_params(rib_parser *p, size_t first, const char *const *names,
                          const size_t *counts, double *const *out, size_t n, const char *skip)
{
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        size_t k = 0;
        while (k < n && strcmp(prm.name, names[k]) != 0)
            k++;
        if (skip && strcmp(prm.name, skip) == 0) continue;
        if (k == n) {
            rib_warn_param(p, &prm);
            continue;
        }
        const double *v;
        rc = rib_param_numbers(p, &prm, counts[k], &v, NULL);
        if (rc != TS_OK) return rc;
        memcpy(out[k], v, counts[k] * sizeof *v);
    }
    return TS_OK;
}

/* The standard surface shaders of RenderMan (RI Spec 3.2 Appendix A) as Tessera's
 * materials, with their defaults. A shader reads `count` of the parameters Kd, Ks,
 * roughness from the `first`; colour_map: its "texturename" multiplies Cs. */
static const struct {
    const char *name;
    uint32_t material;
    double kd, ks, roughness;
    int first, count, colour_map, constant;
} shading_shaders[] = {
    {"matte", TS_MAT_MATTE, 1.0, 0.0, 0.1, 0, 1, 1, 0},
    {"plastic", TS_MAT_PLASTIC, 0.5, 0.5, 0.1, 0, 3, 1, 0},
    {"paintedplastic", TS_MAT_PLASTIC, 0.5, 0.5, 0.1, 0, 3, 1, 0},
    {"metal", TS_MAT_METAL, 0.0, 1.0, 0.1, 1, 2, 0, 0},
    {"shinymetal", TS_MAT_METAL, 0.0, 1.0, 0.1, 1, 2, 0, 0},
    {"constant", TS_MAT_MATTE, 0.0, 0.0, 0.1, 0, 0, 0, 1},
    {"glass", TS_MAT_GLASS, 0.0, 0.0, 0.01, 3, 1, 0, 0}, /* "eta" (1.5); smooth (lib/bsdf.h) */
};

/* Kd, Ks >= 0; Kd + Ks above 1 scaled down to 1 and roughness into [0.01, 1], each with
 * one warning: a file written for another renderer still loads. */
int rib_shading_limits(rib_parser *p, const char *name, rib_surface *s)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    if (!(s->kd >= 0 && s->ks >= 0 && s->kd <= FLT_MAX && s->ks <= FLT_MAX &&
          fabs(s->roughness) <= FLT_MAX))
        return rib_error_at(p, p->req_line, p->req_col,
                            "%s \"%s\": Kd and Ks must be >= 0 and finite, got %g %g", p->req,
                            rib_printable(name, shown), s->kd, s->ks);
    if (s->kd + s->ks > 1.0 + 1e-6) {
        double k = s->kd + s->ks;
        s->kd /= k, s->ks /= k;
        snprintf(what, sizeof what,
                 "%s \"%s\": Kd + Ks above 1 is scaled down to 1 (energy conservation)", p->req,
                 rib_printable(name, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    if (s->roughness < 0.01 || s->roughness > 1.0) {
        s->roughness = s->roughness < 0.01 ? 0.01 : 1.0;
        snprintf(what, sizeof what,
                 "%s \"%s\": roughness outside [0.01, 1] is clamped to it (no perfect "
                 "mirrors)",
                 p->req, rib_printable(name, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    return TS_OK;
}

/* Surface "name" params: matte (Kd), plastic and paintedplastic (Kd, Ks, roughness; a
 * "texturename" colour map), metal and shinymetal (Ks, roughness: a GGX lobe tinted by Cs;
 * shinymetal's reflection map and Kr are ignored with a warning: the path tracer reflects
 * the scene itself), constant (emits Cs, reflects nothing). Defaults as RenderMan's
 * shaders. Any other shader renders as matte with one warning, its parameters unread. */
int rib_req_surface(rib_parser *p)
{
    const char *name;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a surface shader name", &name);
    if (rc != TS_OK) return rc;
    size_t k = 0, n = sizeof shading_shaders / sizeof shading_shaders[0];
    while (k < n && strcmp(name, shading_shaders[k].name) != 0)
        k++;
    rib_surface s = {.material = TS_MAT_MATTE, .kd = 1.0, .roughness = 0.1};
    if (k == n) {
        snprintf(what, sizeof what,
                 "Surface \"%s\" is unknown: it renders as matte (matte, plastic, "
                 "paintedplastic, metal, shinymetal, constant, glass)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
        p->surface = s;
        return TS_OK;
    }
    s = (rib_surface){.material = shading_shaders[k].material,
                      .kd = shading_shaders[k].kd,
                      .ks = shading_shaders[k].ks,
                      .roughness = shading_shaders[k].roughness,
                      .ior = 1.5,
                      .constant = shading_shaders[k].constant};
    static const char *const names[] = {"Kd", "Ks", "roughness", "eta"};
    static const size_t counts[] = {1, 1, 1, 1};
    double *out[] = {&s.kd, &s.ks, &s.roughness, &s.ior};
    int first = shading_shaders[k].first, shiny = strcmp(name, "shinymetal") == 0;
    int maps = shading_shaders[k].colour_map || shiny;
    rc = shading_params(p, 1, names + first, counts + first, out + first,
                        (size_t)shading_shaders[k].count, maps ? "texturename" : NULL);
    if (rc == TS_OK) rc = rib_shading_limits(p, name, &s);
    if (rc == TS_OK && s.material == TS_MAT_GLASS && !(s.ior >= 1.0 && s.ior <= 4.0))
        rc = rib_error_at(p, p->req_line, p->req_col,
                          "Surface \"glass\": eta must be in [1, 4] (the index of refraction "
                          "inside), got %g",
                          s.ior);
    for (size_t i = 1; rc == TS_OK && maps && i < p->nargs; i += 2) {
        rib_param prm;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK || strcmp(prm.name, "texturename") != 0) continue;
        if (shiny) {
            rib_warn_once(p, prm.key->line, prm.key->col,
                          "Surface \"shinymetal\": the reflection map \"texturename\" is ignored "
                          "(the path tracer reflects the scene itself)");
            continue;
        }
        rc = rib_texture_arg(p, i + 1, TS_TEX_RGB, "rendered with Cs alone, untextured", &s.tex);
        s.textured = rc == TS_OK && s.tex != TS_INVALID;
    }
    if (rc != TS_OK) return rc;
    p->surface = s;
    return TS_OK;
}

/* AreaLightSource "arealight" handle "float intensity" [i] "color lightcolor" [r g b]: the
 * patches that follow in the attribute block emit radiance i * color from both sides. */
int rib_req_area_light_source(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "an area light shader name", &name);
    if (rc != TS_OK) return rc;
    rc = rib_rm20_area_light(p, name, (p->nargs % 2 == 0) ? 2 : 1);
    if (rc >= 0) return rc;               /* RenderMan 20's RIS lights */
    if (strcmp(name, "arealight") != 0) { /* like other unknown shaders: warned, left out */
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what,
                 "AreaLightSource \"%s\" is unknown: the following geometry does not emit "
                 "(arealight)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->args[0].line, p->args[0].col, what);
        p->emission[0] = p->emission[1] = p->emission[2] = 0.0;
        return TS_OK;
    }
    size_t first = (p->nargs % 2 == 0) ? 2 : 1; /* a handle makes the count even */
    double intensity = 1.0, color[3] = {1, 1, 1};
    static const char *const names[] = {"intensity", "lightcolor"};
    static const size_t counts[] = {1, 3};
    double *out[] = {&intensity, color};
    rc = shading_params(p, first, names, counts, out, 2, NULL);
    if (rc != TS_OK) return rc;
    if (!(intensity >= 0))
        return rib_error_at(p, p->req_line, p->req_col, "AreaLightSource: intensity must be >= 0");
    for (int k = 0; k < 3; ++k)
        p->emission[k] = intensity * color[k];
    return TS_OK;
}

/* Opacity [r g b] or r g b (RI Spec §4.2.2): 0 0 0 makes the following geometry fully
 * transparent, which is the same as absent (no hits, no shadows); 1 1 1 is opaque. Tessera
 * has no partial transparency: anything between renders opaque, with one warning. Values
 * above 1 count as 1; negative ones are an error. */
int rib_req_opacity(rib_parser *p)
{
    double o[3];
    size_t i = 0;
    int rc = rib_numbers(p, &i, 3, o);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    int partial = 0;
    for (int k = 0; k < 3; k++) {
        if (!(o[k] >= 0.0 && o[k] <= FLT_MAX))
            return rib_error_at(p, p->req_line, p->req_col, "Opacity: %g is outside [0, 1]", o[k]);
        if (o[k] > 1.0) o[k] = 1.0;
        partial |= o[k] > 0.0 && o[k] < 1.0;
    }
    int transparent = o[0] == 0.0 && o[1] == 0.0 && o[2] == 0.0;
    if (!transparent && (partial || o[0] == 0.0 || o[1] == 0.0 || o[2] == 0.0))
        rib_warn_once(p, p->req_line, p->req_col,
                      "Opacity between 0 and 1 renders opaque (only Opacity 0 0 0, fully "
                      "transparent, is honoured: that geometry is left out)");
    memcpy(p->opacity, o, sizeof o);
    return TS_OK;
}

/* ShaderLayer type name handle params (RenderMan 16's shader layering): the layers of a group
 * run in order and each writes the shader's outputs, so the group shows what its last
 * layer makes. Tessera draws each "surface" or "displacement" layer as that request with the
 * layer's own parameters, the last one staying (an unknown shader warns as the request
 * does); a layer of another type is ignored with a warning. ConnectShaderLayers (one
 * layer's output feeding another's parameter) is ignored with a warning: each layer keeps
 * its parameters' own values. docs/rib.md "Surface shaders". */
int rib_req_shader_layer(rib_parser *p)
{
    const char *type, *name, *handle;
    int rc = rib_string_arg(p, 0, "a shader type (surface, displacement, ...)", &type);
    if (rc == TS_OK) rc = rib_string_arg(p, 1, "a shader name", &name);
    if (rc == TS_OK) rc = rib_string_arg(p, 2, "a layer handle", &handle);
    if (rc != TS_OK) return rc;
    int surface = strcmp(type, "surface") == 0, disp = strcmp(type, "displacement") == 0;
    if (!surface && !disp) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what,
                 "ShaderLayer \"%s\" is ignored (surface and displacement "
                 "layers are drawn)",
                 rib_printable(type, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    /* The request as Surface/Displacement name params: the name moved over the handle, the
     * two first arguments dropped for the call. */
    rib_arg saved = p->args[2];
    p->args[2] = p->args[1];
    p->args += 2, p->nargs -= 2;
    rc = surface ? rib_req_surface(p) : rib_req_displacement(p);
    p->args -= 2, p->nargs += 2;
    p->args[2] = saved;
    return rc;
}

int rib_req_connect_shader_layers(rib_parser *p)
{
    rib_warn_once(p, p->req_line, p->req_col,
                  "ConnectShaderLayers is ignored: each layer keeps its parameters' own values");
    return TS_OK;
}
