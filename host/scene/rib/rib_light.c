/* rib_light.c — LightSource (RI Spec 3.2 §4.2, Light Sources) with RenderMan's standard
 * light shaders (its Table 4.7 and Appendix A: "ambientlight", "distantlight", "pointlight",
 * "spotlight") and Tessera's "domelight", into the scene's lights (scene.h ts_scene_light,
 * ts_dome_light). Files also name lights with shadow maps or more controls; those whose light
 * is one of the standard ones are drawn as it, with one warning per name: "shadowspot",
 * "shadowpoint", "shadowdistant" (Tessera traces its shadows) and "uberlight" (Barzel's light
 * from Advanced RenderMan: a spot or omni light at the origin of the current space looking
 * down +z).
 *
 * Points ("from", "to", a light's origin) are in the current space, moved by the CTM when
 * the request is read; before WorldBegin that is camera space, and rib_state.c moves the
 * lights to world space at WorldBegin. Angles are in radians, as in the shaders. Lights are
 * global: their attribute scope and Illuminate are not honoured (docs/rib.md). */
#include "scene/rib/rib_internal.h"

#include "base/mat4.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Every number a light shader here reads, with its default. */
typedef struct light_args {
    double intensity, color[3], from[3], to[3], angle;
    double coneangle, conedeltaangle, beamdistribution;
    double falloff, falloffdist, width, height, wedge, hedge;
} light_args;

/* The parameters, by name: how many numbers and where they go. */
static const struct {
    const char *name;
    size_t n, offset;
} light_params[] = {
    {"intensity", 1, offsetof(light_args, intensity)},
    {"lightcolor", 3, offsetof(light_args, color)},
    {"from", 3, offsetof(light_args, from)},
    {"to", 3, offsetof(light_args, to)},
    {"angle", 1, offsetof(light_args, angle)},
    {"coneangle", 1, offsetof(light_args, coneangle)},
    {"conedeltaangle", 1, offsetof(light_args, conedeltaangle)},
    {"beamdistribution", 1, offsetof(light_args, beamdistribution)},
    {"falloff", 1, offsetof(light_args, falloff)},
    {"falloffdist", 1, offsetof(light_args, falloffdist)},
    {"width", 1, offsetof(light_args, width)},
    {"height", 1, offsetof(light_args, height)},
    {"wedge", 1, offsetof(light_args, wedge)},
    {"hedge", 1, offsetof(light_args, hedge)},
};
#define LIGHT_NPARAMS (sizeof light_params / sizeof light_params[0])
#define LP(name) (1u << (name))
enum {
    P_INTENSITY,
    P_COLOR,
    P_FROM,
    P_TO,
    P_ANGLE,
    P_CONE,
    P_DELTA,
    P_BEAM,
    P_FALLOFF,
    P_FALLOFFDIST,
    P_WIDTH,
    P_HEIGHT,
    P_WEDGE,
    P_HEDGE
};
#define LIGHT_BASIC (LP(P_INTENSITY) | LP(P_COLOR))
#define LIGHT_SPOT (LIGHT_BASIC | LP(P_FROM) | LP(P_TO) | LP(P_CONE) | LP(P_DELTA) | LP(P_BEAM))

/* The light shaders Tessera draws: the kind, the parameters read (others are warned about
 * once each), and for the names it maps onto a standard light, the warning that says so. */
static const struct {
    const char *name;
    ts_scene_light_kind kind;
    unsigned params;
    const char *drawn_as; /* NULL: a standard light */
} light_shaders[] = {
    {"distantlight", SCENE_LIGHT_DISTANT, LIGHT_BASIC | LP(P_FROM) | LP(P_TO) | LP(P_ANGLE), NULL},
    {"pointlight", SCENE_LIGHT_POINT, LIGHT_BASIC | LP(P_FROM), NULL},
    {"spotlight", SCENE_LIGHT_SPOT, LIGHT_SPOT, NULL},
    {"ambientlight", SCENE_LIGHT_AMBIENT, LIGHT_BASIC, NULL},
    {"shadowdistant", SCENE_LIGHT_DISTANT, LIGHT_BASIC | LP(P_FROM) | LP(P_TO),
     "LightSource \"shadowdistant\" is drawn as \"distantlight\" (shadows are ray traced; its "
     "shadow map parameters are ignored)"},
    {"shadowpoint", SCENE_LIGHT_POINT, LIGHT_BASIC | LP(P_FROM),
     "LightSource \"shadowpoint\" is drawn as \"pointlight\" (shadows are ray traced; its "
     "shadow map parameters are ignored)"},
    {"shadowspot", SCENE_LIGHT_SPOT, LIGHT_SPOT,
     "LightSource \"shadowspot\" is drawn as \"spotlight\" (shadows are ray traced; its shadow "
     "map parameters are ignored)"},
    {"uberlight", SCENE_LIGHT_SPOT,
     LIGHT_BASIC | LP(P_BEAM) | LP(P_FALLOFF) | LP(P_FALLOFFDIST) | LP(P_WIDTH) | LP(P_HEIGHT) |
         LP(P_WEDGE) | LP(P_HEDGE),
     "LightSource \"uberlight\" is drawn as a spotlight down +z, or a pointlight for lighttype "
     "\"omni\" (shadows are ray traced; cuton, cutoff, shear, roundness, blockers, slides and "
     "noise are ignored)"},
};

/* The defaults of the shaders' parameters (uberlight's where it differs: no distance
 * falloff, no beam falloff, edges of 0.1). */
static light_args light_defaults(int uber)
{
    light_args a = {.intensity = 1.0,
                    .color = {1, 1, 1},
                    .from = {0, 0, 0},
                    .to = {0, 0, 1},
                    .angle = 0.0,
                    .coneangle = 30.0 * M_PI / 180.0,
                    .conedeltaangle = 5.0 * M_PI / 180.0,
                    .beamdistribution = uber ? 0.0 : 2.0,
                    .falloff = uber ? 0.0 : 2.0,
                    .falloffdist = 1.0,
                    .width = 1.0,
                    .height = 1.0,
                    .wedge = 0.1,
                    .hedge = 0.1};
    return a;
}

/* Reads the parameters from index `first` that `params` allows into *a, and when omni is
 * not NULL (uberlight) "lighttype" into *omni: 0 for "spot", 1 for "omni" and, with a
 * warning, anything else. `skip` (or NULL) is the caller's; the others are warned about. */
static int light_read_params(rib_parser *p, size_t first, unsigned params, light_args *a, int *omni,
                             const char *skip)
{
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (skip && strcmp(prm.name, skip) == 0) continue;
        if (omni && strcmp(prm.name, "lighttype") == 0) {
            const char *type;
            rc = rib_string_arg(p, i + 1, "a light type", &type);
            if (rc != TS_OK) return rc;
            *omni = strcmp(type, "spot") != 0;
            if (*omni && strcmp(type, "omni") != 0) {
                char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
                snprintf(what, sizeof what,
                         "LightSource \"uberlight\": lighttype \"%s\" is drawn as \"omni\" "
                         "(spot or omni)",
                         rib_printable(type, shown));
                rib_warn_once(p, prm.val->line, prm.val->col, what);
            }
            continue;
        }
        size_t k = 0;
        while (k < LIGHT_NPARAMS && strcmp(prm.name, light_params[k].name) != 0)
            k++;
        if (k == LIGHT_NPARAMS || !(params & LP(k))) {
            rib_warn_param(p, &prm);
            continue;
        }
        const double *v;
        rc = rib_param_numbers(p, &prm, light_params[k].n, &v, NULL);
        if (rc != TS_OK) return rc;
        memcpy((char *)a + light_params[k].offset, v, light_params[k].n * sizeof(double));
    }
    return TS_OK;
}

/* The checks every light shares: intensity and colour >= 0 and finite. */
static int light_check_energy(rib_parser *p, const char *shader, const light_args *a)
{
    char shown[RIB_PRINT_MAX];
    int ok = a->intensity >= 0 && a->intensity <= DBL_MAX;
    for (int k = 0; k < 3; k++)
        ok &= a->color[k] >= 0 && a->color[k] <= DBL_MAX;
    if (!ok)
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource \"%s\": intensity and lightcolor must be >= 0 and "
                            "finite, got %g and [%g %g %g]",
                            rib_printable(shader, shown), a->intensity, a->color[0], a->color[1],
                            a->color[2]);
    return TS_OK;
}

/* A spot's cone (spotlight.sl) into l: 0 < coneangle <= pi, conedeltaangle >= 0 (at most
 * the cone: a larger one is clamped, the soft edge then reaching the axis), beamdistribution
 * >= 0; the distance falloff 1 / d^2. A finite coneangle over pi (degrees written for
 * radians, as in files RenderMan renders) warns, an error when strict, and lights what
 * spotlight.sl lights: where cos(angle to the axis) >= cos(coneangle) (illuminate's cone is
 * then every direction), the soft edge from cos(coneangle - conedeltaangle), a step where
 * that is the smaller (lib/lights.h light_smoothstep). */
static int light_spot(rib_parser *p, const char *shader, const light_args *a, ts_scene_light *l)
{
    char shown[RIB_PRINT_MAX];
    int over = a->coneangle > M_PI && a->coneangle <= DBL_MAX;
    if (!(a->coneangle > 0 && a->coneangle <= M_PI) && (!over || p->strict))
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource \"%s\": coneangle %g is outside (0, pi] (radians)",
                            rib_printable(shader, shown), a->coneangle);
    if (over) {
        char what[RIB_WARN_KEY + 96];
        snprintf(what, sizeof what,
                 "LightSource \"%s\": coneangle %g is outside (0, pi] (radians): lit as "
                 "spotlight.sl computes it, where cos(angle) >= cos(%g) (--strict makes this an "
                 "error)",
                 rib_printable(shader, shown), a->coneangle, a->coneangle);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    if (!(a->conedeltaangle >= 0 && a->conedeltaangle <= DBL_MAX) ||
        !(a->beamdistribution >= 0 && a->beamdistribution <= DBL_MAX))
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource \"%s\": conedeltaangle and beamdistribution must be >= 0 "
                            "and finite, got %g and %g",
                            rib_printable(shader, shown), a->conedeltaangle, a->beamdistribution);
    l->cone_angle = a->coneangle;
    l->cone_delta = fmin(a->conedeltaangle, a->coneangle);
    l->beam = a->beamdistribution;
    l->falloff = 2.0, l->falloff_dist = 1.0;
    return TS_OK;
}

/* uberlight as a spot or point light (uberlight.sl; "from" and "to" keep their defaults, the
 * origin of the current space and a point down +z); its superellipse cross-section (width x height
 * at distance 1, soft edges wedge, hedge) as the circle of the same area, r = sqrt(width height)
 * inside and sqrt((width + wedge) (height + hedge)) at the edge; distance falloff (falloffdist /
 * d)^falloff beyond falloffdist and the value at falloffdist nearer (its maxintensity is not read).
 */
static int light_uber(rib_parser *p, light_args *a, ts_scene_light *l, int omni)
{
    if (!(a->width > 0 && a->height > 0 && a->wedge >= 0 && a->hedge >= 0 &&
          a->width + a->wedge <= DBL_MAX && a->height + a->hedge <= DBL_MAX) ||
        !(a->falloff >= 0 && a->falloff <= DBL_MAX && a->falloffdist >= 0 &&
          a->falloffdist <= DBL_MAX) ||
        !(a->beamdistribution >= 0 && a->beamdistribution <= DBL_MAX))
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource \"uberlight\": width and height must be > 0; wedge, "
                            "hedge, falloff, falloffdist and beamdistribution >= 0 and finite");
    double inner = atan(sqrt(a->width * a->height));
    double outer = atan(sqrt((a->width + a->wedge) * (a->height + a->hedge)));
    l->kind = omni ? SCENE_LIGHT_POINT : SCENE_LIGHT_SPOT;
    l->cone_angle = outer, l->cone_delta = outer - inner, l->beam = a->beamdistribution;
    l->falloff = a->falloff, l->falloff_dist = a->falloffdist;
    l->falloff_min = a->falloff > 0 ? a->falloffdist : 0.0;
    if (!omni && a->width != a->height)
        rib_warn_once(p, p->req_line, p->req_col,
                      "LightSource \"uberlight\": the cross-section is drawn as a circle of the "
                      "same area (width x height)");
    return TS_OK;
}

/* Moves the light's points by the CTM into l. */
static int light_place(rib_parser *p, const light_args *a, ts_scene_light *l)
{
    if (!mat4_point(p->ctm, a->from, l->from) || !mat4_point(p->ctm, a->to, l->to))
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource: from/to leave the float range after the current "
                            "transformation");
    if (l->kind != SCENE_LIGHT_DISTANT && l->kind != SCENE_LIGHT_SPOT) return TS_OK;
    if (l->from[0] == l->to[0] && l->from[1] == l->to[1] && l->from[2] == l->to[2])
        return rib_error_at(p, p->req_line, p->req_col,
                            "LightSource: %s \"from\" and \"to\" are the same point",
                            l->kind == SCENE_LIGHT_DISTANT ? "distantlight" : "spotlight");
    return TS_OK;
}

/* The light of shader table entry k from the parameters at `first`. */
static int light_add(rib_parser *p, size_t k, size_t first)
{
    const char *shader = light_shaders[k].name;
    int uber = strcmp(shader, "uberlight") == 0, omni = 0;
    light_args a = light_defaults(uber);
    int rc = light_read_params(p, first, light_shaders[k].params, &a, uber ? &omni : NULL, NULL);
    if (rc == TS_OK) rc = light_check_energy(p, shader, &a);
    if (rc != TS_OK) return rc;
    ts_scene_light l = {.intensity = a.intensity,
                        .color = {a.color[0], a.color[1], a.color[2]},
                        .angle = a.angle,
                        .kind = light_shaders[k].kind};
    if (uber)
        rc = light_uber(p, &a, &l, omni);
    else if (l.kind == SCENE_LIGHT_SPOT)
        rc = light_spot(p, shader, &a, &l);
    else if (l.kind == SCENE_LIGHT_POINT) /* pointlight.sl: 1 / d^2 */
        l.falloff = 2.0, l.falloff_dist = 1.0;
    else if (l.kind == SCENE_LIGHT_DISTANT && !(a.angle >= 0.0 && a.angle < 180.0))
        rc = rib_error_at(p, p->req_line, p->req_col,
                          "LightSource: distantlight \"angle\" %g is outside [0, 180) degrees",
                          a.angle);
    if (rc == TS_OK) rc = light_place(p, &a, &l);
    return rc == TS_OK ? scene_add_light(p->scene, &l, p->err) : rc;
}

/* LightSource "domelight" handle "float intensity" [i] "color lightcolor" [r g b]
 * ["string mapname" ["sky.exr"]]: a sky of radiance i * color, times the lat-long map's
 * texel in each direction when it has one (the path is relative to the RIB file; the image
 * is read when the render starts; a file that cannot be read leaves the sky uniform with a
 * warning, or is an error when strict). One per scene. */
int rib_light_dome_map(rib_parser *p, const char *name, int line, int col, ts_dome_light *d)
{
    char *use = rib_texture_sibling(p, name); /* a RenderMan .tex: its readable sibling */
    char *path = use ? rib_resolve_in(p, use, 1) : NULL;
    free(use);
    if (path && strlen(path) >= sizeof d->mapname) {
        free(path);
        return rib_error_at(p, line, col, "%s: the map's path is too long", p->req);
    }
    /* Read when the render starts; one that cannot be read is found here, at its name. */
    int rc = TS_OK;
    if (path && access(path, R_OK) == 0)
        strcpy(d->mapname, path);
    else
        rc = rib_missing_file(p, line, col, "", name, path ? strerror(errno) : RIB_TEX_NO_SIBLING,
                              "a uniform sky of the light's colour");
    free(path);
    return rc;
}

static int light_dome(rib_parser *p, size_t first)
{
    ts_dome_light d = {1, 1.0, {1, 1, 1}, "", NULL, 0, 0};
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (strcmp(prm.name, "mapname") != 0) continue;
        const char *name;
        rc = rib_string_arg(p, i + 1, "a map name", &name);
        if (rc == TS_OK)
            rc = rib_light_dome_map(p, name, p->args[i + 1].line, p->args[i + 1].col, &d);
        if (rc != TS_OK) return rc;
    }
    light_args a = light_defaults(0);
    int rc = light_read_params(p, first, LIGHT_BASIC, &a, NULL, "mapname");
    if (rc != TS_OK) return rc;
    d.intensity = a.intensity;
    memcpy(d.color, a.color, sizeof d.color);
    if (p->scene->dome.present)
        return rib_error_at(p, p->req_line, p->req_col, "only one domelight per scene");
    p->scene->dome = d;
    return TS_OK;
}

/* LightSource name [handle] params. The handle (a number or a string) is optional and
 * unused. Other shader names are ignored with one warning each. */
int rib_req_light_source(rib_parser *p)
{
    const char *shader;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a light shader name", &shader);
    if (rc == TS_OK) rc = rib_geom_check(p);
    if (rc != TS_OK) return rc;
    size_t first = (p->nargs % 2 == 0) ? 2 : 1; /* a handle makes the count even */
    if (first == 2 && p->args[1].kind != RIB_ARG_NUMBER && p->args[1].kind != RIB_ARG_STRING)
        return rib_error_at(p, p->args[1].line, p->args[1].col,
                            "LightSource: the light handle must be a number or a string");
    if (strcmp(shader, "domelight") == 0) return light_dome(p, first);
    size_t k = 0, n = sizeof light_shaders / sizeof light_shaders[0];
    while (k < n && strcmp(shader, light_shaders[k].name) != 0)
        k++;
    if (k == n) {
        snprintf(what, sizeof what,
                 "LightSource \"%s\" is ignored (ambientlight, distantlight, pointlight, "
                 "spotlight, domelight)",
                 rib_printable(shader, shown));
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    if (light_shaders[k].drawn_as)
        rib_warn_once(p, p->req_line, p->req_col, light_shaders[k].drawn_as);
    if (p->ctm_moving && light_shaders[k].kind != SCENE_LIGHT_AMBIENT)
        rib_warn_once(p, p->req_line, p->req_col,
                      "LightSource under a moving transformation is placed at shutter open");
    return light_add(p, k, first);
}
