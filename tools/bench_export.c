/* bench_export.c — a loaded scene as JSON, for rebuilding it in a peer renderer
 * (tools/bench_cycles.py builds the same teapot in Blender Cycles from it).
 *
 *   build/bench_export SCENE --res WxH [--grid N] > scene.json
 *
 * Writes what `tessera render SCENE --res WxH` traces, after loading (RIB, meshes, forests):
 *   camera:  origin and the world-space right/up/forward vectors of the camera kernel
 *            (ts_camera_params: a ray through screen (sx, sy) in [-1,1]^2 has direction
 *            sx * right + sy * up + forward), the fov of the shorter axis in degrees;
 *   lights:  every distant light (unit direction towards the light, irradiance rgb, angular
 *            diameter in degrees) and the dome (radiance rgb);
 *   patches: per patch an (N+1) x (N+1) grid of points and unit normals evaluated on the
 *            undisplaced Bézier surface (u fastest), its corner displacement normals, the
 *            material (Cs * Kd albedo, Ks, roughness, kind) and the displacement function
 *            with its parameters (only the noise functions; textures are not exported).
 * Static scenes only (time-0 points), lit by distant lights and the dome only (a point, spot or
 * ambient light is an error). */
#include "app/render.h"
#include "lib/bezier.h"
#include "scene/scene_load.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static cJSON *vec(const float *v, int n)
{
    double d[4];
    for (int i = 0; i < n; ++i)
        d[i] = v[i];
    return cJSON_CreateDoubleArray(d, n);
}

static cJSON *export_camera(const ts_scene *s, int width, int height, ts_error *err)
{
    ts_camera_params cam;
    if (render_camera_params(&s->camera, width, height, &cam, err)) return NULL;
    cJSON *c = cJSON_CreateObject();
    cJSON_AddItemToObject(c, "origin", vec(cam.origin, 3));
    cJSON_AddItemToObject(c, "right", vec(cam.right, 3));
    cJSON_AddItemToObject(c, "up", vec(cam.up, 3));
    cJSON_AddItemToObject(c, "forward", vec(cam.forward, 3));
    cJSON_AddNumberToObject(c, "fov_deg", s->camera.fov_deg);
    cJSON_AddNumberToObject(c, "width", width);
    cJSON_AddNumberToObject(c, "height", height);
    return c;
}

static cJSON *export_lights(const ts_scene *s)
{
    cJSON *l = cJSON_CreateObject(), *distant = cJSON_AddArrayToObject(l, "distant");
    for (uint32_t i = 0; i < s->light_count; ++i) {
        const ts_scene_light *d = &s->lights[i];
        double dir[3] = {d->from[0] - d->to[0], d->from[1] - d->to[1], d->from[2] - d->to[2]};
        double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        double e[3];
        for (int k = 0; k < 3; ++k)
            dir[k] /= len, e[k] = d->intensity * d->color[k];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToObject(o, "to_light", cJSON_CreateDoubleArray(dir, 3));
        cJSON_AddItemToObject(o, "irradiance", cJSON_CreateDoubleArray(e, 3));
        cJSON_AddNumberToObject(o, "angle_deg", d->angle);
        cJSON_AddItemToArray(distant, o);
    }
    if (s->dome.present) {
        double r[3];
        for (int k = 0; k < 3; ++k)
            r[k] = s->dome.intensity * s->dome.color[k];
        cJSON_AddItemToObject(l, "dome_radiance", cJSON_CreateDoubleArray(r, 3));
        cJSON_AddBoolToObject(l, "dome_mapped", s->dome.mapname[0] != '\0');
    }
    return l;
}

static cJSON *export_patch(const ts_scene *s, uint32_t p, int n)
{
    const ts_vec4 *cp = &s->cp[p * 16];
    const ts_patch_attr *a = &s->attr[p];
    size_t count = (size_t)(n + 1) * (n + 1);
    double *pts = malloc(count * 3 * sizeof *pts), *nrm = malloc(count * 3 * sizeof *nrm);
    if (!pts || !nrm) {
        free(pts), free(nrm);
        return NULL;
    }
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            float u = (float)i / (float)n, v = (float)j / (float)n;
            ts_vec4 x = bezier_eval(cp, u, v), c = bezier_cross_derivs(cp, u, v);
            double len = sqrt((double)c.x * c.x + (double)c.y * c.y + (double)c.z * c.z);
            size_t k = ((size_t)j * (n + 1) + i) * 3;
            pts[k] = x.x, pts[k + 1] = x.y, pts[k + 2] = x.z;
            nrm[k] = len > 0 ? c.x / len : 0, nrm[k + 1] = len > 0 ? c.y / len : 0;
            nrm[k + 2] = len > 0 ? c.z / len : 1;
        }
    cJSON *o = cJSON_CreateObject();
    cJSON_AddItemToObject(o, "points", cJSON_CreateDoubleArray(pts, (int)(count * 3)));
    cJSON_AddItemToObject(o, "normals", cJSON_CreateDoubleArray(nrm, (int)(count * 3)));
    free(pts), free(nrm);
    double cn[12];
    for (int c = 0; c < 4; ++c) {
        ts_vec4 v = s->corner_n ? s->corner_n[p * 4 + c] : (ts_vec4){0, 0, 1, 0};
        cn[c * 3] = v.x, cn[c * 3 + 1] = v.y, cn[c * 3 + 2] = v.z;
    }
    cJSON_AddItemToObject(o, "corner_normals", cJSON_CreateDoubleArray(cn, 12));
    double albedo[3] = {a->kd * a->cs_r, a->kd * a->cs_g, a->kd * a->cs_b};
    cJSON_AddItemToObject(o, "albedo", cJSON_CreateDoubleArray(albedo, 3));
    cJSON_AddStringToObject(o, "material", a->material == TS_MAT_PLASTIC ? "plastic" : "matte");
    cJSON_AddNumberToObject(o, "ks", a->ks);
    cJSON_AddNumberToObject(o, "roughness", a->roughness);
    const char *kinds[] = {"none", "fbm", "ridged", "texture"};
    cJSON_AddStringToObject(o, "displacement", a->disp_kind < 4 ? kinds[a->disp_kind] : "none");
    if (a->disp_kind == TS_DISP_FBM || a->disp_kind == TS_DISP_RIDGED) {
        cJSON_AddNumberToObject(o, "amplitude", a->disp_amplitude);
        cJSON_AddNumberToObject(o, "frequency", a->disp_frequency);
        cJSON_AddNumberToObject(o, "octaves", a->disp_octaves);
        cJSON_AddNumberToObject(o, "lacunarity", a->disp_lacunarity);
        cJSON_AddNumberToObject(o, "gain", a->disp_gain);
        const ts_xform *x = &s->xform[a->xform];
        float rows[12];
        memcpy(rows, x->r0, 4 * sizeof(float));
        memcpy(rows + 4, x->r1, 4 * sizeof(float));
        memcpy(rows + 8, x->r2, 4 * sizeof(float));
        cJSON_AddItemToObject(o, "world_to_object", cJSON_CreateFloatArray(rows, 12));
    }
    return o;
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    int width = 1280, height = 720, grid = 16;
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--res") == 0 && i + 1 < argc) {
            if (sscanf(argv[++i], "%dx%d", &width, &height) != 2 || width < 1 || height < 1) {
                fprintf(stderr, "bench_export: --res WxH\n");
                return 2;
            }
        } else if (strcmp(argv[i], "--grid") == 0 && i + 1 < argc) {
            grid = atoi(argv[++i]);
            if (grid < 1 || grid > 256) {
                fprintf(stderr, "bench_export: --grid 1..256\n");
                return 2;
            }
        } else if (!path && argv[i][0] != '-') {
            path = argv[i];
        } else {
            fprintf(stderr, "usage: bench_export SCENE [--res WxH] [--grid N] > scene.json\n");
            return 2;
        }
    }
    if (!path) {
        fprintf(stderr, "usage: bench_export SCENE [--res WxH] [--grid N] > scene.json\n");
        return 2;
    }
    ts_scene s;
    memset(&s, 0, sizeof s);
    ts_error err = {0};
    if (scene_load(path, &s, 1, &err)) {
        fprintf(stderr, "bench_export: %s\n", err.msg);
        return 1;
    }
    for (uint32_t i = 0; i < s.light_count; ++i)
        if (s.lights[i].kind != SCENE_LIGHT_DISTANT) { /* bench_cycles.py builds suns only */
            fprintf(stderr,
                    "bench_export: %s: light %u is a point, spot or ambient light, which "
                    "the export does not hold (distant lights and the dome)\n",
                    path, i);
            scene_free(&s);
            return 1;
        }
    cJSON *root = cJSON_CreateObject(), *cam = export_camera(&s, width, height, &err);
    int rc = 0;
    if (!cam) {
        fprintf(stderr, "bench_export: %s\n", err.msg);
        rc = 1;
    } else {
        cJSON_AddItemToObject(root, "camera", cam);
        cJSON_AddItemToObject(root, "lights", export_lights(&s));
        cJSON *patches = cJSON_AddArrayToObject(root, "patches");
        for (uint32_t p = 0; p < s.patch_count && rc == 0; ++p) {
            cJSON *o = export_patch(&s, p, grid);
            if (!o)
                rc = 1;
            else
                cJSON_AddItemToArray(patches, o);
        }
        cJSON_AddNumberToObject(root, "grid", grid);
        cJSON_AddBoolToObject(root, "moving", s.cp1 != NULL);
    }
    if (rc == 0) {
        char *text = cJSON_PrintUnformatted(root);
        if (!text || fputs(text, stdout) == EOF || fputc('\n', stdout) == EOF) rc = 1;
        free(text);
    }
    cJSON_Delete(root);
    scene_free(&s);
    ts_error_clear(&err);
    return rc;
}
