/* rib_shading.c — the RIB requests that say how surfaces look and what lights them:
 * Surface "matte" / "plastic" (with the current Color as Cs), AreaLightSource "arealight"
 * (the following patches emit), Opacity (fully transparent or opaque), LightSource
 * "domelight" (a uniform sky). DESIGN.md §3. */
#include "scene/rib/rib_internal.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
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

/* Surface "matte" "float Kd" [k] | "plastic" "float Kd" [..] "float Ks" [..]
 * "float roughness" [..], either with "string texturename" ["file"]: Cs times the file's
 * colour at the point's st. Defaults as RenderMan's shaders: matte Kd 1; plastic Kd 0.5,
 * Ks 0.5, roughness 0.1. Other shaders are warned about once and render as matte. */
int rib_req_surface(rib_parser *p)
{
    const char *name;
    int rc = rib_string_arg(p, 0, "a surface shader name", &name);
    if (rc != TS_OK) return rc;
    rib_surface s = {TS_MAT_MATTE, 1.0, 0.0, 0.1, 0, 0};
    if (strcmp(name, "plastic") == 0)
        s = (rib_surface){TS_MAT_PLASTIC, 0.5, 0.5, 0.1, 0, 0};
    else if (strcmp(name, "matte") != 0) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what, "Surface \"%s\" renders as matte (matte, plastic)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    static const char *const names[] = {"Kd", "Ks", "roughness"};
    static const size_t counts[] = {1, 1, 1};
    double *out[] = {&s.kd, &s.ks, &s.roughness};
    rc = shading_params(p, 1, names, counts, out, s.material == TS_MAT_PLASTIC ? 3 : 1,
                        "texturename");
    if (rc != TS_OK) return rc;
    if (!(s.kd >= 0 && s.ks >= 0 && s.kd + s.ks <= 1.0 + 1e-6 && s.roughness > 0 &&
          s.roughness <= 1))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Surface \"%s\": need Kd, Ks >= 0 with Kd + Ks <= 1 (energy "
                            "conservation) and 0 < roughness <= 1",
                            name);
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "texturename") != 0) continue;
        rc = rib_texture_arg(p, i + 1, TS_TEX_RGB, &s.tex);
        if (rc != TS_OK) return rc;
        s.textured = 1;
    }
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
    if (strcmp(name, "arealight") != 0) {
        char shown[RIB_PRINT_MAX];
        return rib_error_at(p, p->args[0].line, p->args[0].col,
                            "unknown area light \"%s\" (arealight)", rib_printable(name, shown));
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

/* LightSource "domelight" handle "float intensity" [i] "color lightcolor" [r g b]
 * ["string mapname" ["sky.exr"]]: a sky of radiance i * color, times the lat-long map's
 * texel in each direction when it has one (the path is relative to the RIB file; the image
 * is read when the render starts). */
int rib_dome_light(rib_parser *p, size_t first)
{
    ts_dome_light d = {1, 1.0, {1, 1, 1}, ""};
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "mapname") != 0) continue;
        const char *name;
        rc = rib_string_arg(p, i + 1, "a map name", &name);
        if (rc != TS_OK) return rc;
        char *path = rib_resolve(p, name);
        if (!path || strlen(path) >= sizeof d.mapname) {
            free(path);
            return rib_error_at(p, prm.key->line, prm.key->col,
                                "domelight \"mapname\": path too long");
        }
        strcpy(d.mapname, path);
        free(path);
    }
    static const char *const names[] = {"intensity", "lightcolor"};
    static const size_t counts[] = {1, 3};
    double *out[] = {&d.intensity, d.color};
    int rc = shading_params(p, first, names, counts, out, 2, "mapname");
    if (rc != TS_OK) return rc;
    if (p->scene->dome.present)
        return rib_error_at(p, p->req_line, p->req_col, "only one domelight per scene");
    p->scene->dome = d;
    return TS_OK;
}
