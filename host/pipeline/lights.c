/* lights.c — the light list, the emitter table and the environment map's CDFs (lights.h),
 * from the scene, in plain C. Sums run in double and are stored as float; the last entry
 * of every CDF is set to exactly 1 so that a sample u < 1 always finds an entry
 * (lib/lights.h cdf_find). */
#include "pipeline/lights.h"
#include "lib/bezier.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void env_map_free(ts_env_map *e)
{
    free(e->texels);
    free(e->marginal);
    free(e->conditional);
    memset(e, 0, sizeof *e);
}

/* Row y's texels from the image and their CDF, cumulative and normalised to end at 1
 * (uniform when the row has no weight); returns the row's total weight, luminance times
 * sin(theta) of the row's centre. */
static double env_row(const ts_image *img, uint32_t y, ts_env_map *e)
{
    uint32_t w = e->width, h = e->height;
    double row = 0, s = sin(M_PI * (y + 0.5) / h);
    for (uint32_t x = 0; x < w; ++x) {
        const float *px = &img->pixels[((size_t)y * w + x) * img->channels];
        float r = px[0], g = img->channels > 2 ? px[1] : r, b = img->channels > 2 ? px[2] : r;
        if (!(r >= 0 && g >= 0 && b >= 0 && r < 1e30f && g < 1e30f && b < 1e30f)) r = g = b = 0;
        e->texels[(size_t)y * w + x] = (ts_vec4){r, g, b, 0};
        row += (0.2126 * r + 0.7152 * g + 0.0722 * b) * s;
        e->conditional[(size_t)y * w + x] = (float)row;
    }
    for (uint32_t x = 0; x < w; ++x) /* cumulative within the row, ending at 1 */
        e->conditional[(size_t)y * w + x] =
            row > 0 ? (float)(e->conditional[(size_t)y * w + x] / row) : (float)(x + 1) / w;
    e->conditional[(size_t)y * w + w - 1] = 1.0f;
    return row;
}

int env_map_from_image(const ts_image *img, ts_env_map *e, ts_error *err)
{
    memset(e, 0, sizeof *e);
    uint32_t w = (uint32_t)img->width, h = (uint32_t)img->height;
    e->texels = malloc((size_t)w * h * sizeof *e->texels);
    e->marginal = malloc(h * sizeof *e->marginal);
    e->conditional = malloc((size_t)w * h * sizeof *e->conditional);
    if (!e->texels || !e->marginal || !e->conditional) {
        env_map_free(e);
        return ts_error_set(err, TS_E_MEMORY, "out of memory for the environment map (%u x %u)", w,
                            h);
    }
    e->width = w, e->height = h;
    double total = 0;
    for (uint32_t y = 0; y < h; ++y) {
        total += env_row(img, y, e);
        e->marginal[y] = (float)total;
    }
    for (uint32_t y = 0; y < h; ++y)
        e->marginal[y] = total > 0 ? (float)(e->marginal[y] / total) : (float)(y + 1) / h;
    e->marginal[h - 1] = 1.0f;
    return TS_OK;
}

int env_map_load(const char *path, ts_env_map *e, ts_error *err)
{
    memset(e, 0, sizeof *e);
    ts_image img;
    if (image_read(path, &img, err)) return err->code;
    int rc = env_map_from_image(&img, e, err);
    image_free(&img);
    return rc;
}

/* Area of patch p's undisplaced surface at time 0: |dP/du x dP/dv| on an 8 x 8 midpoint
 * grid, world units^2. */
static float patch_area(const ts_scene *s, uint32_t p)
{
    double a = 0;
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i) {
            ts_vec4 n = bezier_cross_derivs(&s->cp[p * 16], (i + 0.5f) / 8, (j + 0.5f) / 8);
            a += sqrt((double)n.x * n.x + (double)n.y * n.y + (double)n.z * n.z) / 64.0;
        }
    return (float)a;
}

/* Rec. 709 luminance. */
static double luminance(const float c[3])
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/* A distant light: a delta light of irradiance E, or for angle a > 0 a cone of half angle
 * a / 2 with radiance L, L pi sin^2(a / 2) = E, uniform in the cone. Its weight: the
 * radiance it gives a white matte point facing it, E / pi (luminance). */
static ts_light distant_light(const ts_scene_light *d)
{
    ts_light l = {.type = TS_LIGHT_DISTANT, .cos_max = 1.0f};
    double dir[3] = {d->from[0] - d->to[0], d->from[1] - d->to[1], d->from[2] - d->to[2]};
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    double half = 0.5 * d->angle * M_PI / 180.0, e_scale = 1.0;
    if (half > 0) {
        l.cos_max = (float)cos(half);
        l.solid_angle = (float)(2 * M_PI * (1 - cos(half)));
        e_scale = 1.0 / (M_PI * sin(half) * sin(half));
    }
    float e[3];
    for (int k = 0; k < 3; ++k) {
        l.dir[k] = (float)(dir[k] / len);
        l.radiance[k] = (float)(d->intensity * d->color[k] * e_scale);
        e[k] = (float)(d->intensity * d->color[k]);
    }
    l.weight = (float)(luminance(e) / M_PI);
    return l;
}

/* The average radiance of a lat-long map over the sphere (texels weighted by sin(theta)). */
static double env_mean_luminance(const ts_env_map *env)
{
    double sum = 0, weight = 0;
    for (uint32_t y = 0; y < env->height; ++y) {
        double s = sin(M_PI * (y + 0.5) / env->height);
        for (uint32_t x = 0; x < env->width; ++x) {
            const ts_vec4 *t = &env->texels[(size_t)y * env->width + x];
            float c[3] = {t->x, t->y, t->z};
            sum += luminance(c) * s, weight += s;
        }
    }
    return weight > 0 ? sum / weight : 0.0;
}

/* The box of the scene's patches (scene_patch_box), for typical distances. */
static ts_box scene_box(const ts_scene *s)
{
    ts_box b = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (uint32_t p = 0; p < s->patch_count; ++p) {
        ts_box q = scene_patch_box(s, p);
        b.lo_x = fminf(b.lo_x, q.lo_x), b.lo_y = fminf(b.lo_y, q.lo_y),
        b.lo_z = fminf(b.lo_z, q.lo_z);
        b.hi_x = fmaxf(b.hi_x, q.hi_x), b.hi_y = fmaxf(b.hi_y, q.hi_y),
        b.hi_z = fmaxf(b.hi_z, q.hi_z);
    }
    return b;
}

/* Half the diagonal of box b (infinite or NaN when it is empty). */
static double box_half_diagonal(ts_box b)
{
    double dx = b.hi_x - b.lo_x, dy = b.hi_y - b.lo_y, dz = b.hi_z - b.lo_z;
    return 0.5 * sqrt(dx * dx + dy * dy + dz * dz);
}

/* The area light's weight: its emitters' luminous power over pi d^2, d a typical distance
 * to the points it lights (half the diagonal of the scene's patch boxes, or the square root
 * of the emitting area if larger). A guess: it only steers how often the light is chosen. */
static float area_weight(const ts_patch_attr *attr, const ts_light_table *t, ts_box b)
{
    double power = 0, area = 0;
    for (uint32_t k = 0; k < t->emitter_count; ++k) {
        const ts_patch_attr *a = &attr[t->emitters[k].patch];
        float le[3] = {a->le_r, a->le_g, a->le_b};
        power += luminance(le) * t->emitters[k].area, area += t->emitters[k].area;
    }
    double d = fmax(box_half_diagonal(b), sqrt(area));
    return d > 0 && isfinite(d) ? (float)(power / (M_PI * d * d)) : (float)power;
}

/* A point or spot light (scene.h ts_scene_light): at `from`, radiance field intensity *
 * color times its falloff; a spot's axis from `from` towards `to`, cos_max = cos(cone),
 * cos_inner = cos(cone - delta). Its weight: the radiance its unit-beam peak gives a white
 * matte point facing it at a typical distance d, the light's distance to the centre of the
 * scene's box b or half its diagonal if larger (points on the far side of the scene, or
 * around a light inside it): I falloff(d) / pi. A guess, like the area light's. */
static ts_light point_light(const ts_scene_light *src, ts_box b)
{
    ts_light l = {.type = src->kind == SCENE_LIGHT_SPOT ? TS_LIGHT_SPOT : TS_LIGHT_POINT,
                  .cos_max = -1.0f,
                  .cos_inner = -1.0f,
                  .beam = (float)src->beam,
                  .falloff = (float)src->falloff,
                  .falloff_dist = (float)src->falloff_dist,
                  .falloff_min = (float)src->falloff_min};
    double axis[3] = {src->to[0] - src->from[0], src->to[1] - src->from[1],
                      src->to[2] - src->from[2]};
    double len = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double c[3] = {0.5 * ((double)b.lo_x + b.hi_x), 0.5 * ((double)b.lo_y + b.hi_y),
                   0.5 * ((double)b.lo_z + b.hi_z)};
    double dc = 0, e[3];
    for (int k = 0; k < 3; ++k) {
        l.pos[k] = (float)src->from[k];
        l.dir[k] = len > 0 ? (float)(axis[k] / len) : 0.0f;
        l.radiance[k] = (float)(src->intensity * src->color[k]);
        dc += (src->from[k] - c[k]) * (src->from[k] - c[k]);
    }
    if (l.type == TS_LIGHT_SPOT) {
        l.cos_max = (float)cos(src->cone_angle);
        l.cos_inner = (float)cos(src->cone_angle - src->cone_delta);
    }
    double d = fmax(sqrt(dc), box_half_diagonal(b));
    if (!(d > 0 && isfinite(d))) d = 1.0; /* no patches: any distance */
    double r = src->falloff_dist / fmax(d, src->falloff_min);
    double atten = src->falloff == 0 ? 1.0 : pow(r, src->falloff);
    for (int k = 0; k < 3; ++k)
        e[k] = src->intensity * src->color[k] * atten;
    l.weight = (float)((0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]) / M_PI);
    return l;
}

/* The emitter table: every patch with some le > 0, chosen by power (area times brightest
 * channel); attr[i].emitter names patch i's entry (attr: the caller's copy of s->attr, or NULL
 * when no patch emits). */
static int build_emitters(const ts_scene *s, ts_patch_attr *attr, ts_light_table *t, ts_error *err)
{
    const ts_patch_attr *sa = s->attr;
    uint32_t ne = 0;
    for (uint32_t i = 0; i < s->patch_count; ++i)
        ne += sa[i].le_r > 0 || sa[i].le_g > 0 || sa[i].le_b > 0;
    if (ne && !attr) return ts_error_set(err, TS_E_INTERNAL, "lights_build: emitters without attr");
    ts_emitter *em = calloc(ne ? ne : 1, sizeof *em);
    if (!em) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    double total = 0;
    ne = 0;
    for (uint32_t i = 0; attr && i < s->patch_count; ++i) {
        attr[i].emitter = TS_INVALID;
        float le = fmaxf(sa[i].le_r, fmaxf(sa[i].le_g, sa[i].le_b));
        if (!(le > 0)) continue;
        float area = patch_area(s, i);
        em[ne] = (ts_emitter){i, 0, area * le, area}; /* prob: the power until normalised */
        total += area * le;
        attr[i].emitter = ne++;
    }
    double acc = 0;
    for (uint32_t k = 0; k < ne; ++k) {
        em[k].prob = total > 0 ? (float)(em[k].prob / total) : 0.0f;
        acc += em[k].prob;
        em[k].cdf = k + 1 == ne ? 1.0f : (float)acc;
    }
    t->emitters = em;
    t->emitter_count = ne;
    return TS_OK;
}

/* The ambient lights added up into *l, one uniform dome that eye rays do not see (a matte
 * point under it gets its radiance L times the albedo: weight L); 0 when there is none. */
static int ambient_light(const ts_scene *s, ts_light *l)
{
    *l = (ts_light){.type = TS_LIGHT_DOME, .cos_max = 1.0f, .flags = TS_LIGHT_NOT_SEEN};
    double L[3] = {0, 0, 0};
    int any = 0;
    for (uint32_t i = 0; i < s->light_count; ++i)
        if (s->lights[i].kind == SCENE_LIGHT_AMBIENT) {
            any = 1;
            for (int k = 0; k < 3; ++k)
                L[k] += s->lights[i].intensity * s->lights[i].color[k];
        }
    for (int k = 0; k < 3; ++k)
        l->radiance[k] = (float)L[k];
    l->weight = (float)luminance(l->radiance);
    return any;
}

int lights_build(const ts_scene *s, const ts_env_map *env, ts_patch_attr *attr, ts_light_table *t,
                 ts_error *err)
{
    memset(t, 0, sizeof *t);
    uint32_t n = 0;
    for (uint32_t i = 0; i < s->light_count; ++i)
        n += s->lights[i].kind != SCENE_LIGHT_AMBIENT;
    if (n > TS_MAX_SCENE_LIGHTS)
        return ts_error_set(err, TS_E_SCENE, "%u distant, point and spot lights: at most %u", n,
                            TS_MAX_SCENE_LIGHTS);
    int local = 0; /* point or spot lights: their weights need the scene's box */
    for (uint32_t i = 0; i < s->light_count; ++i)
        local |= s->lights[i].kind == SCENE_LIGHT_POINT || s->lights[i].kind == SCENE_LIGHT_SPOT;
    if (build_emitters(s, attr, t, err)) return err->code;
    ts_box box = local || t->emitter_count ? scene_box(s) : (ts_box){0, 0, 0, 0, 0, 0};
    uint32_t nl = 0;
    for (uint32_t i = 0; i < s->light_count; ++i) {
        const ts_scene_light *src = &s->lights[i];
        if (src->kind == SCENE_LIGHT_DISTANT)
            t->lights[nl++] = distant_light(src);
        else if (src->kind == SCENE_LIGHT_POINT || src->kind == SCENE_LIGHT_SPOT)
            t->lights[nl++] = point_light(src, box);
    }
    if (s->dome.present) {
        ts_light l = {.type = TS_LIGHT_DOME,
                      .cos_max = 1.0f,
                      .map_width = env ? env->width : 0u,
                      .map_height = env ? env->height : 0u};
        for (int k = 0; k < 3; ++k)
            l.radiance[k] = (float)(s->dome.intensity * s->dome.color[k]);
        /* A matte point under the dome gets its radiance L times the albedo. */
        l.weight = (float)(luminance(l.radiance) *
                           (env && env->width && env->texels ? env_mean_luminance(env) : 1.0));
        t->lights[nl++] = l;
    }
    ts_light ambient;
    if (ambient_light(s, &ambient)) t->lights[nl++] = ambient;
    if (t->emitter_count)
        t->lights[nl++] = (ts_light){.type = TS_LIGHT_AREA,
                                     .emitter_count = t->emitter_count,
                                     .cos_max = 1.0f,
                                     .weight = area_weight(attr, t, box)};
    t->light_count = nl;
    return TS_OK;
}

void lights_free(ts_light_table *t)
{
    free(t->emitters);
    memset(t, 0, sizeof *t);
}
