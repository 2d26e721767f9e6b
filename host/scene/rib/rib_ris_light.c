/* rib_ris_light.c — Light (RenderMan 21-26, RIS) onto Tessera's lights: PxrDomeLight is the
 * dome (a lat-long map from lightColorMap), PxrDistantLight a distant light whose cone is
 * angleExtent, PxrRectLight, PxrDiskLight, PxrSphereLight and PxrCylinderLight emissive
 * geometry (a bilinear patch, a disk, a sphere or a cylinder of Bézier patches, which the
 * emitter table samples as area lights), PxrEnvDayLight Preetham's sky baked into the dome's
 * map and the sun as a distant light (sky.h). The radiance of every other light is
 * intensity * 2^exposure * lightColor (times a black body's colour with enableTemperature),
 * RenderMan's with normalize off; light filters are ignored (rib.c warns
 * about LightFilter). The light's shape is RenderMan's (USD's UsdLux took it): a unit square
 * or a disk of diameter 1 in the xy plane facing -z, a sphere of diameter 1, a cylinder of
 * length 1 and diameter 1 along x; a distant light shines down -z. docs/rib.md "RIS
 * shading" has the rules. */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"
#include "scene/quadric.h"
#include "scene/sky.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef enum ris_light_kind {
    RIS_DOME,
    RIS_DISTANT,
    RIS_RECT,
    RIS_DISK,
    RIS_SPHERE,
    RIS_CYLINDER,
    RIS_DAY
} ris_light_kind;

static const struct {
    const char *name;
    ris_light_kind kind;
} ris_lights[] = {
    {"PxrDomeLight", RIS_DOME},     {"PxrDistantLight", RIS_DISTANT},
    {"PxrRectLight", RIS_RECT},     {"PxrDiskLight", RIS_DISK},
    {"PxrSphereLight", RIS_SPHERE}, {"PxrCylinderLight", RIS_CYLINDER},
    {"PxrEnvDayLight", RIS_DAY},
};
#define RIS_LIGHT_COUNT (sizeof ris_lights / sizeof ris_lights[0])

/* What a RIS light reads. */
typedef struct ris_light_args {
    double intensity, exposure, color[3], temperature, angle, normalize, enable_temperature;
    double sky_tint[3];
    size_t map_arg; /* lightColorMap: the index of its value, 0 for none */
    /* PxrEnvDayLight's own (docs/rib.md "Daylight") */
    double sun_tint[3], sun_size, sun_direction[3], haziness, ground_color[3];
    double month, day, year, hour, zone, latitude, longitude;
} ris_light_args;

/* ---- black body ---------------------------------------------------------------------- */

void rib_blackbody(double kelvin, double rgb[3])
{
    double t = fmin(fmax(kelvin, 1000.0), 40000.0), xyz[3] = {0, 0, 0};
    for (double l = 380.0; l <= 780.0; l += 5.0) { /* nm */
        double m = l * 1e-9, planck = 1.0 / (pow(m, 5) * expm1(1.4387769e-2 / (m * t))), c[3];
        sky_cie_xyz(l, c); /* Wyman, Sloan and Shirley's fit of the CIE 1931 observer */
        for (int k = 0; k < 3; k++)
            xyz[k] += planck * c[k];
    }
    /* XYZ -> linear Rec. 709 (sRGB primaries, D65), negatives (deep red) clipped. */
    sky_xyz_to_rgb(xyz, rgb);
    double y = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    for (int k = 0; k < 3; k++)
        rgb[k] /= y;
}

/* ---- parameters ---------------------------------------------------------------------- */

/* Non-physical or sampling controls: ignored with one warning only when not at the value
 * that makes no difference to what Tessera draws (RenderMan's default, or what RenderMan for
 * Maya writes for "none": a cone of 90 degrees, black shadows, no shadow distance or falloff,
 * no near-distance fade, no IES profile). Three values for a colour, else one. */
static const rib_neutral ris_light_neutral[] = {
    {"diffuse", 1, {1.0}},
    {"specular", 1, {1.0}},
    {"enableShadows", 1, {1.0}},
    {"areaNormalize", 1, {0.0}},
    {"thinShadow", 1, {1.0}},
    {"traceLightPaths", 1, {0.0}},
    {"importanceMultiplier", 1, {1.0}},
    {"coneAngle", 1, {90.0}},
    {"coneSoftness", 1, {0.0}},
    {"shadowColor", 3, {0.0, 0.0, 0.0}},
    {"shadowDistance", 1, {-1.0}},
    {"shadowFalloff", 1, {-1.0}},
    {"shadowFalloffGamma", 1, {1.0}},
    {"intensityNearDist", 1, {0.0}},
    {"iesProfileScale", 1, {0.0}},
    {"emissionFocus", 1, {0.0}},
};

/* What only steers the noise or names AOVs and links: silent whatever its value (a number), or
 * when empty (a string: no subset, no profile). */
static int ris_light_silent(const rib_parser *p, const rib_param *prm)
{
    /* and what only shapes a colour map or a focus, which warn themselves when present */
    static const char *const any[] = {"fixedSampleCount", "lightGroup", "emissionFocusTint",
                                      "colorMapGamma", "colorMapSaturation"};
    static const char *const empty_ok[] = {"shadowSubset", "shadowExcludeSubset", "iesProfile"};
    const rib_arg *v = prm->val;
    return rib_in_list(prm->name, any, RIB_COUNT(any)) ||
           (rib_in_list(prm->name, empty_ok, RIB_COUNT(empty_ok)) &&
            (v->kind == RIB_ARG_STRING || (v->kind == RIB_ARG_STRINGS && v->count == 1)) &&
            rib_arg_str(p, v, 0)[0] == '\0');
}

/* Reads the parameters from args[first] into *a; others warn once each. */
static int ris_light_read(rib_parser *p, ris_light_kind kind, size_t first, ris_light_args *a)
{
#define ALL ~0u
#define DAY (1u << RIS_DAY)
    static const struct {
        const char *name;
        size_t n, off;
        unsigned kinds; /* the lights that read it: bits 1 << ris_light_kind */
    } known[] = {
        {"intensity", 1, offsetof(ris_light_args, intensity), ALL},
        {"exposure", 1, offsetof(ris_light_args, exposure), ALL},
        {"lightColor", 3, offsetof(ris_light_args, color), ALL & ~DAY},
        {"temperature", 1, offsetof(ris_light_args, temperature), ALL & ~DAY},
        {"enableTemperature", 1, offsetof(ris_light_args, enable_temperature), ALL & ~DAY},
        {"angleExtent", 1, offsetof(ris_light_args, angle), 1u << RIS_DISTANT},
        {"normalize", 1, offsetof(ris_light_args, normalize), ALL & ~DAY},
        {"skyTint", 3, offsetof(ris_light_args, sky_tint), DAY},
        {"sunTint", 3, offsetof(ris_light_args, sun_tint), DAY},
        {"sunSize", 1, offsetof(ris_light_args, sun_size), DAY},
        {"sunDirection", 3, offsetof(ris_light_args, sun_direction), DAY},
        {"haziness", 1, offsetof(ris_light_args, haziness), DAY},
        {"groundColor", 3, offsetof(ris_light_args, ground_color), DAY},
        {"month", 1, offsetof(ris_light_args, month), DAY},
        {"day", 1, offsetof(ris_light_args, day), DAY},
        {"year", 1, offsetof(ris_light_args, year), DAY},
        {"hour", 1, offsetof(ris_light_args, hour), DAY},
        {"zone", 1, offsetof(ris_light_args, zone), DAY},
        {"latitude", 1, offsetof(ris_light_args, latitude), DAY},
        {"longitude", 1, offsetof(ris_light_args, longitude), DAY},
    };
#undef ALL
#undef DAY
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        /* the dome's map; RenderMan 20's PxrStdEnvMapLight calls it rman__EnvMap or envMap */
        if (kind == RIS_DOME &&
            (strcmp(prm.name, "lightColorMap") == 0 || strcmp(prm.name, "rman__EnvMap") == 0 ||
             strcmp(prm.name, "envMap") == 0)) {
            a->map_arg = i + 1;
            continue;
        }
        if (strcmp(prm.name, "rman__Shape") == 0) continue; /* RenderMan 20: its Geometry says it */
        size_t k = 0, nk = sizeof known / sizeof known[0];
        while (k < nk && strcmp(prm.name, known[k].name) != 0)
            k++;
        int usable = k < nk && (known[k].kinds >> kind & 1u);
        if (prm.val->kind == RIB_ARG_STRING || prm.val->kind == RIB_ARG_STRINGS)
            usable = 0; /* a connection to a pattern: lights are not textured here */
        if (!usable) {
            size_t nn = sizeof ris_light_neutral / sizeof ris_light_neutral[0];
            if (!rib_param_neutral(p, &prm, ris_light_neutral, nn) && !ris_light_silent(p, &prm))
                rib_warn_param(p, &prm);
            continue;
        }
        rc = rib_param_numbers(p, &prm, known[k].n, &v, NULL);
        if (rc != TS_OK) return rc;
        for (size_t c = 0; c < known[k].n; c++)
            if (!(fabs(v[c]) <= FLT_MAX))
                return rib_error_at(p, prm.val->line, prm.val->col,
                                    "Light: \"%s\" must be finite, got %g", prm.name, v[c]);
        memcpy((char *)a + known[k].off, v, known[k].n * sizeof *v);
    }
    return TS_OK;
}

/* The light's radiance: intensity * 2^exposure * lightColor (* skyTint) (* black body). */
static int ris_light_radiance(rib_parser *p, const char *name, const ris_light_args *a,
                              double out[3])
{
    double bb[3] = {1, 1, 1}, scale = a->intensity * exp2(a->exposure);
    if (a->enable_temperature != 0.0) {
        if (!(a->temperature > 0.0))
            return rib_error_at(p, p->req_line, p->req_col,
                                "Light \"%s\": temperature must be > 0 (kelvin), got %g", name,
                                a->temperature);
        rib_blackbody(a->temperature, bb);
    }
    int ok = scale >= 0.0 && scale <= FLT_MAX;
    for (int k = 0; k < 3; k++) {
        out[k] = scale * a->color[k] * a->sky_tint[k] * bb[k];
        ok &= a->color[k] >= 0.0 && a->sky_tint[k] >= 0.0 && out[k] <= FLT_MAX;
    }
    if (!ok)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Light \"%s\": intensity, 2^exposure and lightColor must be >= 0 and "
                            "finite, got %g, %g and [%g %g %g]",
                            name, a->intensity, exp2(a->exposure), a->color[0], a->color[1],
                            a->color[2]);
    return TS_OK;
}

/* ---- lights -------------------------------------------------------------------------- */

/* PxrDomeLight and PxrEnvDayLight: the scene's dome of radiance L (the map's texel times it);
 * a second dome is ignored with a warning (Tessera has one). */
static int ris_dome(rib_parser *p, const char *map, int line, int col, const double L[3])
{
    if (p->scene->dome.present) {
        rib_warn_once(p, p->req_line, p->req_col,
                      "Light: a second dome light is ignored (one dome per scene)");
        return TS_OK;
    }
    ts_dome_light d = {1, 1.0, {L[0], L[1], L[2]}, "", NULL, 0, 0};
    int rc = map && map[0] ? rib_light_dome_map(p, map, line, col, &d) : TS_OK;
    if (rc == TS_OK) p->scene->dome = d;
    return rc;
}

static int ris_light_dome(rib_parser *p, const ris_light_args *a, const double L[3])
{
    if (p->scene->dome.present) return ris_dome(p, NULL, 0, 0, L); /* (warns) */
    const char *map = NULL;
    if (a->map_arg) {
        int rc = rib_string_arg(p, a->map_arg, "a map name", &map);
        if (rc != TS_OK) return rc;
    }
    return ris_dome(p, map, a->map_arg ? p->args[a->map_arg].line : 0,
                    a->map_arg ? p->args[a->map_arg].col : 0, L);
}

/* Adds distant light *l shining from light-space point `from` towards `to`, both through the
 * CTM; `light` and `toward` name it in the error when the CTM collapses the direction. */
static int ris_distant_add(rib_parser *p, ts_scene_light *l, const double from[3],
                           const double to[3], const char *light, const char *toward)
{
    if (!mat4_point(p->ctm, from, l->from) || !mat4_point(p->ctm, to, l->to))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Light: its direction leaves the float range");
    if (l->from[0] == l->to[0] && l->from[1] == l->to[1] && l->from[2] == l->to[2])
        return rib_error_at(p, p->req_line, p->req_col,
                            "Light \"%s\": the current transformation has no direction for %s",
                            light, toward);
    return scene_add_light(p->scene, l, p->err);
}

/* PxrDistantLight: light travelling down -z of the current space, radiance L in a cone of
 * angular diameter angleExtent (degrees), that is irradiance L pi sin^2(angle / 2) on a
 * surface facing it (lights.c's cone); with normalize, or angleExtent 0 (a delta light), the
 * irradiance is L itself. */
static int ris_light_distant(rib_parser *p, const ris_light_args *a, const double L[3])
{
    if (!(a->angle >= 0.0 && a->angle < 180.0))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Light \"PxrDistantLight\": angleExtent %g is outside [0, 180) degrees",
                            a->angle);
    double half = 0.5 * a->angle * M_PI / 180.0;
    double e = a->normalize != 0.0 || half == 0.0 ? 1.0 : M_PI * sin(half) * sin(half);
    ts_scene_light l = {.intensity = e,
                        .color = {L[0], L[1], L[2]},
                        .angle = a->angle,
                        .kind = SCENE_LIGHT_DISTANT};
    const double from[3] = {0, 0, 0}, to[3] = {0, 0, -1};
    return ris_distant_add(p, &l, from, to, "PxrDistantLight", "-z");
}

/* ---- PxrEnvDayLight ---------------------------------------------------------------------- */

/* The sun's direction in the light's space (z up, x east, y north): sunDirection when month
 * is 0, else from the date, hour, zone and place. 1 when the sun is above the horizon. */
static int day_sun(rib_parser *p, const ris_light_args *a, double sun[3])
{
    if (a->month == 0.0) {
        double len = sqrt(a->sun_direction[0] * a->sun_direction[0] +
                          a->sun_direction[1] * a->sun_direction[1] +
                          a->sun_direction[2] * a->sun_direction[2]);
        if (!(len > 0.0))
            return rib_error_at(p, p->req_line, p->req_col,
                                "Light \"PxrEnvDayLight\": sunDirection must not be 0");
        for (int k = 0; k < 3; k++)
            sun[k] = a->sun_direction[k] / len;
        return TS_OK;
    }
    double elevation, azimuth;
    if (a->month != floor(a->month) || a->day != floor(a->day) || a->year != floor(a->year) ||
        fabs(a->year) > 1e6 ||
        sky_solar_position((int)a->year, (int)a->month, (int)a->day, a->hour, a->zone, a->latitude,
                           a->longitude, &elevation, &azimuth) != 0)
        return rib_error_at(p, p->req_line, p->req_col,
                            "Light \"PxrEnvDayLight\": no such date: year %g, month %g, day %g "
                            "(month 0 uses sunDirection)",
                            a->year, a->month, a->day);
    sky_direction(elevation, azimuth, sun);
    return TS_OK;
}

/* PxrEnvDayLight: Preetham's sky (sky.h) baked into the dome's map, in the light's space
 * rotated into the world by the CTM (z its zenith), and the sun as a distant light of
 * diameter sunSize * 0.55 degrees and the disc's radiance through that sky; radiances in
 * cd/m^2 times intensity * 2^exposure * skyTint (sunTint). docs/rib.md "Daylight". */
static int ris_light_day(rib_parser *p, const ris_light_args *a, const double scale)
{
    double sun[3], t = a->haziness, to_world[9];
    int rc = day_sun(p, a, sun);
    if (rc != TS_OK) return rc;
    if (!(a->sun_size >= 0.0 && a->sun_size * SKY_SUN_DIAMETER_DEG < 180.0))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Light \"PxrEnvDayLight\": sunSize %g is outside [0, %g)", a->sun_size,
                            180.0 / SKY_SUN_DIAMETER_DEG);
    for (int k = 0; k < 3; k++)
        if (!(a->sun_tint[k] >= 0.0 && a->ground_color[k] >= 0.0))
            return rib_error_at(p, p->req_line, p->req_col,
                                "Light \"PxrEnvDayLight\": sunTint and groundColor must be >= 0");
    if (!(t >= SKY_TURBIDITY_MIN && t <= SKY_TURBIDITY_MAX)) {
        rib_warn_once(p, p->req_line, p->req_col,
                      "Light \"PxrEnvDayLight\": haziness is clamped to the model's [1.7, 10]");
        t = fmin(fmax(t, SKY_TURBIDITY_MIN), SKY_TURBIDITY_MAX);
    }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            to_world[3 * r + c] = p->ctm[4 * r + c];
    int day = sun[2] > 0.0;
    if (!day)
        rib_warn_once(p, p->req_line, p->req_col,
                      "Light \"PxrEnvDayLight\": the sun is below the horizon; the sky is black "
                      "(Preetham's model has no twilight)");
    ts_sky sky;
    sky_init(&sky, t, sun);
    double half = 0.5 * a->sun_size * SKY_SUN_DIAMETER_DEG * M_PI / 180.0, sun_rgb[3] = {0, 0, 0};
    if (day) sky_sun_radiance(t, sky.theta_s, sun_rgb, NULL);
    sky_bake_args b = {.sky = &sky, .sun_solid_angle = 2.0 * M_PI * (1.0 - cos(half))};
    memcpy(b.to_world, to_world, sizeof to_world);
    for (int k = 0; k < 3; k++) {
        b.sky_tint[k] = day ? a->sky_tint[k] : 0.0;
        b.sun_rgb[k] = sun_rgb[k] * a->sun_tint[k];
        b.ground[k] = a->ground_color[k];
    }
    if (p->scene->dome.present) {
        rib_warn_once(p, p->req_line, p->req_col,
                      "Light: a second dome light is ignored (one dome per scene)");
    } else {
        float *rgb = malloc((size_t)SKY_MAP_WIDTH * SKY_MAP_HEIGHT * 3 * sizeof *rgb);
        if (!rgb) return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        sky_bake(&b, rgb);
        /* the map stays in memory: the scene owns it (scene.h ts_dome_light) */
        ts_dome_light d = {1, scale, {1, 1, 1}, "", rgb, SKY_MAP_WIDTH, SKY_MAP_HEIGHT};
        p->scene->dome = d;
    }
    if (!day || half == 0.0 || !(b.sun_rgb[0] > 0 || b.sun_rgb[1] > 0 || b.sun_rgb[2] > 0))
        return TS_OK;
    /* The sun: a cone of radiance L gives irradiance L pi sin^2(half) on a surface facing it
     * (ris_light_distant's, lights.c's). */
    ts_scene_light l = {.intensity = scale * M_PI * sin(half) * sin(half),
                        .color = {b.sun_rgb[0], b.sun_rgb[1], b.sun_rgb[2]},
                        .angle = 2.0 * half * 180.0 / M_PI,
                        .kind = SCENE_LIGHT_DISTANT};
    const double origin[3] = {0, 0, 0};
    return ris_distant_add(p, &l, sun, origin, "PxrEnvDayLight", "the sun");
}

static int ris_light_quadric_patch(void *ctx, const double cp[16][3], const double n[4][3],
                                   const double uv[4][2])
{
    rib_parser *p = ctx;
    (void)uv;
    return rib_geom_emit(p, p->req_line, p->req_col, cp, n, NULL, NULL);
}

/* The world-space area of the light's shape (for normalize): the unit shape's area scaled by
 * the CTM (its xy columns for a rect or disk; the mean scale squared for a sphere or
 * cylinder). */
static double ris_light_area(const rib_parser *p, ris_light_kind kind)
{
    const double *m = p->ctm; /* row-major, column vectors: column j is m[j], m[4 + j], ... */
    double ex[3] = {m[0], m[4], m[8]}, ey[3] = {m[1], m[5], m[9]}, ez[3] = {m[2], m[6], m[10]};
    double c[3] = {ex[1] * ey[2] - ex[2] * ey[1], ex[2] * ey[0] - ex[0] * ey[2],
                   ex[0] * ey[1] - ex[1] * ey[0]};
    double xy = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    double det = fabs(c[0] * ez[0] + c[1] * ez[1] + c[2] * ez[2]), s2 = pow(det, 2.0 / 3.0);
    switch (kind) {
    case RIS_RECT:
        return xy;
    case RIS_DISK:
        return 0.25 * M_PI * xy;
    case RIS_SPHERE:
        return M_PI * s2; /* 4 pi r^2, r = 1/2 */
    default:
        return M_PI * s2 + 0.5 * M_PI * s2; /* side pi d l and two disks (not drawn) */
    }
}

/* PxrRectLight, PxrDiskLight, PxrSphereLight, PxrCylinderLight: the shape's patches emit
 * radiance L (from both sides: Tessera's emitters are two-sided) and reflect nothing, with
 * neither displacement nor the current Opacity. */
static int ris_light_shape(rib_parser *p, ris_light_kind kind, const ris_light_args *a, double L[3])
{
    if (a->normalize != 0.0) {
        double area = ris_light_area(p, kind);
        if (!(area > 0.0))
            return rib_error_at(p, p->req_line, p->req_col,
                                "Light: normalize needs a light of non-zero area");
        for (int k = 0; k < 3; k++)
            L[k] /= area;
    }
    rib_surface surface = p->surface;
    rib_disp disp = p->disp;
    double emission[3], opacity[3], ctm[16], ctm1[16];
    memcpy(emission, p->emission, sizeof emission), memcpy(opacity, p->opacity, sizeof opacity);
    memcpy(ctm, p->ctm, sizeof ctm), memcpy(ctm1, p->ctm1, sizeof ctm1);
    p->surface = (rib_surface){.material = TS_MAT_MATTE, .kd = 0.0, .roughness = 0.1};
    p->disp = (rib_disp){TS_DISP_NONE, 4, 0.1, 1.0, 2.0, 0.5, 0, 0.0, 0, {0}};
    memcpy(p->emission, L, sizeof emission);
    p->opacity[0] = p->opacity[1] = p->opacity[2] = 1.0;
    int rc = rib_geom_check(p), count = 0;
    if (rc == TS_OK && kind == RIS_RECT) {
        double g[16][3];
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++)
                g[4 * j + i][0] = i / 3.0 - 0.5, g[4 * j + i][1] = j / 3.0 - 0.5,
                          g[4 * j + i][2] = 0;
        rc = rib_geom_bezier(p, (const double(*)[3])g);
    } else if (rc == TS_OK) {
        ts_quadric q = {QUADRIC_SPHERE, {0.5, -0.5, 0.5, 360.0}, 0};
        if (kind == RIS_DISK) q = (ts_quadric){QUADRIC_DISK, {0.0, 0.5, 360.0}, 0};
        if (kind == RIS_CYLINDER) { /* along x: z -> x by a quarter turn about y */
            q = (ts_quadric){QUADRIC_CYLINDER, {0.5, -0.5, 0.5, 360.0}, 0};
            double r[16] = {0, 0, 1, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1};
            mat4_concat(p->ctm, r), mat4_concat(p->ctm1, r);
        }
        char why[256] = "";
        rc = quadric_patches(&q, ris_light_quadric_patch, p, &count, why, sizeof why);
        if (rc == TS_E_SCENE && why[0]) rc = rib_error_at(p, p->req_line, p->req_col, "%s", why);
    }
    p->surface = surface, p->disp = disp;
    memcpy(p->emission, emission, sizeof emission), memcpy(p->opacity, opacity, sizeof opacity);
    memcpy(p->ctm, ctm, sizeof ctm), memcpy(p->ctm1, ctm1, sizeof ctm1);
    return rc;
}

/* Light "name" "handle" params (the handle optional and unused, as LightSource's). */
int rib_req_light(rib_parser *p)
{
    const char *name;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a light shader name", &name);
    if (rc == TS_OK) rc = rib_geom_check(p);
    if (rc != TS_OK) return rc;
    size_t first = (p->nargs % 2 == 0) ? 2 : 1; /* a handle makes the count even */
    size_t k = 0;
    while (k < RIS_LIGHT_COUNT && strcmp(name, ris_lights[k].name) != 0)
        k++;
    if (k == RIS_LIGHT_COUNT) {
        snprintf(what, sizeof what,
                 "Light \"%s\" is ignored (PxrDomeLight, PxrDistantLight, PxrRectLight, "
                 "PxrDiskLight, PxrSphereLight, PxrCylinderLight, PxrEnvDayLight)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    ris_light_kind kind = ris_lights[k].kind;
    /* PxrEnvDayLight: RenderMan's documented intensity 1e-5 (1 gives cd/m^2) and month 0 (use
     * sunDirection); the date and place of its .args file (Seattle, 20 November 2014, 14:38),
     * used when a month is given. */
    ris_light_args a = {.intensity = kind == RIS_DISTANT ? 50000.0
                                     : kind == RIS_DAY   ? 1e-5
                                                         : 1.0,
                        .color = {1, 1, 1},
                        .temperature = 6500.0,
                        .angle = 0.53,
                        .sky_tint = {1, 1, 1},
                        .sun_tint = {1, 1, 1},
                        .sun_size = 1.0,
                        .sun_direction = {0, 0, 1},
                        .haziness = 2.0,
                        .day = 20,
                        .year = 2014,
                        .hour = 14.633333,
                        .zone = -8,
                        .latitude = 47.6019,
                        .longitude = -122.3318};
    double L[3];
    rc = ris_light_read(p, kind, first, &a);
    if (rc == TS_OK) rc = ris_light_radiance(p, name, &a, L);
    if (rc != TS_OK) return rc;
    if (p->ctm_moving && kind != RIS_DOME)
        rib_warn_once(p, p->req_line, p->req_col,
                      "Light under a moving transformation is placed at shutter open");
    if (kind == RIS_DOME) return ris_light_dome(p, &a, L);
    if (kind == RIS_DAY) return ris_light_day(p, &a, a.intensity * exp2(a.exposure));
    if (kind == RIS_DISTANT) return ris_light_distant(p, &a, L);
    return ris_light_shape(p, kind, &a, L);
}

/* ---- RenderMan 20 ----------------------------------------------------------------------- */

/* RenderMan 20's RIS lights were an AreaLightSource shader on geometry: "PxrStdAreaLight",
 * "PxrStdEnvMapLight", "PxrStdEnvDayLight" (or a path ending in such a name and a suffix, as
 * RenderMan for Maya writes them) with intensity, exposure and lightColor set the
 * radiance the following geometry emits (as "arealight" does: a Sphere under it is a sphere
 * light), and "rman__EnvMap" (or "envMap") the dome's map; then Geometry "rectlight",
 * "disklight", "spherelight", "cylinderlight" draws the RIS light of that shape, "distantlight"
 * ("anglesubtended" degrees) the distant light and "envsphere" the dome. */
static const char *const rm20_shaders[] = {"PxrStdAreaLight", "PxrStdEnvMapLight",
                                           "PxrStdEnvDayLight"};

int rib_rm20_area_light(rib_parser *p, const char *name, size_t first)
{
    /* RenderMan for Maya names its per-light shader instances by path:
     * "renderman/scene/shaders/PxrStdEnvMapLightShape1_rfm" */
    const char *base = strrchr(name, '/') ? strrchr(name, '/') + 1 : name;
    size_t k = 0, n = sizeof rm20_shaders / sizeof rm20_shaders[0];
    while (k < n && strncmp(base, rm20_shaders[k], strlen(rm20_shaders[k])) != 0)
        k++;
    if (k == n) return -1;
    ris_light_args a = {
        .intensity = 1.0, .color = {1, 1, 1}, .temperature = 6500.0, .sky_tint = {1, 1, 1}};
    double L[3];
    int rc = ris_light_read(p, k == 0 ? RIS_RECT : RIS_DOME, first, &a);
    if (rc == TS_OK) rc = ris_light_radiance(p, name, &a, L);
    if (rc != TS_OK) return rc;
    if (k == 2) /* RenderMan 20's parameters for it differ (a y-up "direction", "method") */
        rib_warn_once(p, p->req_line, p->req_col,
                      "AreaLightSource \"PxrStdEnvDayLight\" is drawn as a uniform dome of "
                      "intensity * 2^exposure (its sky and sun are not; Light \"PxrEnvDayLight\" "
                      "draws them)");
    free(p->rm20_map);
    p->rm20_map = NULL;
    if (a.map_arg) {
        const char *map;
        rc = rib_string_arg(p, a.map_arg, "a map name", &map);
        if (rc != TS_OK) return rc;
        if (map[0] && !(p->rm20_map = strdup(map)))
            return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
        p->rm20_map_line = p->args[a.map_arg].line, p->rm20_map_col = p->args[a.map_arg].col;
    }
    memcpy(p->emission, L, sizeof L);
    return TS_OK;
}

int rib_rm20_geometry_light(rib_parser *p, const char *name)
{
    static const struct {
        const char *name;
        ris_light_kind kind;
    } shapes[] = {{"rectlight", RIS_RECT},       {"disklight", RIS_DISK},
                  {"spherelight", RIS_SPHERE},   {"cylinderlight", RIS_CYLINDER},
                  {"distantlight", RIS_DISTANT}, {"envsphere", RIS_DOME}};
    size_t k = 0, n = sizeof shapes / sizeof shapes[0];
    while (k < n && strcmp(name, shapes[k].name) != 0)
        k++;
    if (k == n) return -1;
    int rc = rib_geom_check(p);
    if (rc != TS_OK) return rc;
    ris_light_args a = {.intensity = 1.0, .color = {1, 1, 1}, .sky_tint = {1, 1, 1}};
    double L[3] = {p->emission[0], p->emission[1], p->emission[2]};
    for (size_t i = 1; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (shapes[k].kind == RIS_DISTANT && strcmp(prm.name, "anglesubtended") == 0) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            a.angle = v[0];
        } else if (strcmp(prm.name, "resolution") != 0 && strcmp(prm.name, "radius") != 0) {
            rib_warn_param(p, &prm); /* (an envsphere's size and resolution: a dome has none) */
        }
    }
    if (!(L[0] > 0.0 || L[1] > 0.0 || L[2] > 0.0)) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Geometry \"%s\" emits nothing: no AreaLightSource \"PxrStdAreaLight\", "
                 "\"PxrStdEnvMapLight\" or \"PxrStdEnvDayLight\" with light is in effect",
                 name);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    if (shapes[k].kind == RIS_DISTANT) {
        if (!(a.angle >= 0.0 && a.angle < 180.0))
            return rib_error_at(p, p->req_line, p->req_col,
                                "Geometry \"distantlight\": anglesubtended %g is outside [0, 180) "
                                "degrees",
                                a.angle);
        return ris_light_distant(p, &a, L);
    }
    if (shapes[k].kind != RIS_DOME) return ris_light_shape(p, shapes[k].kind, &a, L);
    return ris_dome(p, p->rm20_map, p->rm20_map_line, p->rm20_map_col, L);
}
