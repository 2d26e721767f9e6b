/* scene_load.c — picks the loader by file name (scene_load.h). */
#include "scene/scene_load.h"

#include "scene/mesh.h"
#include "scene/rib/rib.h"

#include <math.h>
#include <string.h>
#include <strings.h>

#define SCENE_AUTO_FOV 30.0
#define SCENE_AUTO_WIDTH 960
#define SCENE_AUTO_HEIGHT 540

/* ".rib", or ".rib.gz" (gzip RIB; rib_load inflates gzip by content whatever the name). */
static int has_rib_extension(const char *path)
{
    size_t n = strlen(path);
    return (n >= 4 && strcasecmp(path + n - 4, ".rib") == 0) ||
           (n >= 7 && strcasecmp(path + n - 7, ".rib.gz") == 0);
}

static void normalize(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0.0) v[0] /= l, v[1] /= l, v[2] /= l;
}

void scene_frame_auto(ts_scene *s)
{
    static const double y_up[3] = {0.0, 1.0, 0.0};
    scene_frame_auto_up(s, y_up);
}

void scene_frame_auto_up(ts_scene *s, const double up_axis[3])
{
    if (s->patch_count == 0) return;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t k = 0; k < (size_t)s->patch_count * 16u; k++) {
        const double q[3] = {s->cp[k].x, s->cp[k].y, s->cp[k].z};
        for (int d = 0; d < 3; d++)
            lo[d] = fmin(lo[d], q[d]), hi[d] = fmax(hi[d], q[d]);
    }
    double c[3], r2 = 0.0;
    for (int d = 0; d < 3; d++)
        c[d] = 0.5 * (lo[d] + hi[d]);
    for (size_t k = 0; k < (size_t)s->patch_count * 16u; k++) {
        double dx = s->cp[k].x - c[0], dy = s->cp[k].y - c[1], dz = s->cp[k].z - c[2];
        r2 = fmax(r2, dx * dx + dy * dy + dz * dz);
    }
    double r = sqrt(r2);
    if (!(r > 0.0)) r = 1.0;
    const double deg = 3.14159265358979323846 / 180.0;
    double az = 35.0 * deg, el = 25.0 * deg;
    /* The view of a y-up model (from +z, turned towards +x, raised), turned with the model
     * when its up axis is another: the frame (x0, up, z0) is right-handed, x0 = +x unless up
     * is along x. For y up it is the identity, so these are the y-up numbers exactly. */
    const double *wup = up_axis;
    double x0[3] = {1.0, 0.0, 0.0}, z0[3];
    if (fabs(wup[0]) > 0.5) x0[0] = 0.0, x0[1] = -wup[0];
    z0[0] = x0[1] * wup[2] - x0[2] * wup[1];
    z0[1] = x0[2] * wup[0] - x0[0] * wup[2];
    z0[2] = x0[0] * wup[1] - x0[1] * wup[0];
    double dir[3]; /* centre -> eye */
    for (int d = 0; d < 3; d++)
        dir[d] = sin(az) * cos(el) * x0[d] + sin(el) * wup[d] + cos(az) * cos(el) * z0[d];
    double dist = r / sin(0.5 * SCENE_AUTO_FOV * deg);
    double eye[3], f[3], right[3], up[3];
    for (int d = 0; d < 3; d++)
        eye[d] = c[d] + dist * dir[d], f[d] = -dir[d];
    /* RenderMan camera space: x right, y up, z forward. Mesh formats (OBJ, glTF, ...) are
     * right-handed, so "right" is forward x up: the model is seen as its authors saw it,
     * not mirrored. */
    right[0] = f[1] * wup[2] - f[2] * wup[1];
    right[1] = f[2] * wup[0] - f[0] * wup[2];
    right[2] = f[0] * wup[1] - f[1] * wup[0];
    normalize(right);
    up[0] = right[1] * f[2] - right[2] * f[1];
    up[1] = right[2] * f[0] - right[0] * f[2];
    up[2] = right[0] * f[1] - right[1] * f[0];
    double *m = s->camera.world_to_camera;
    const double *rows[3] = {right, up, f};
    for (int i = 0; i < 3; i++) {
        m[i * 4 + 0] = rows[i][0], m[i * 4 + 1] = rows[i][1], m[i * 4 + 2] = rows[i][2];
        m[i * 4 + 3] = -(rows[i][0] * eye[0] + rows[i][1] * eye[1] + rows[i][2] * eye[2]);
    }
    m[12] = m[13] = m[14] = 0.0, m[15] = 1.0;
    s->camera.fov_deg = SCENE_AUTO_FOV;
    s->camera.width = SCENE_AUTO_WIDTH;
    s->camera.height = SCENE_AUTO_HEIGHT;
    s->camera.has_format = 1;
    if (s->light_count == 0) {
        /* From the upper left of the view, a little from the camera's side: camera-space
         * direction (-1, 1, -1) towards the light. */
        ts_scene_light l;
        memset(&l, 0, sizeof l);
        l.intensity = 2.5;
        l.color[0] = 1.0, l.color[1] = 0.95, l.color[2] = 0.85;
        for (int d = 0; d < 3; d++) {
            l.to[d] = c[d];
            l.from[d] = c[d] - right[d] + up[d] - f[d];
        }
        ts_error ignored = {0};
        scene_add_light(s, &l, &ignored);
    }
    if (!s->dome.present) { /* a dim sky, so the sides away from the light are not black */
        s->dome.present = 1;
        s->dome.intensity = 0.35;
        s->dome.color[0] = 0.8, s->dome.color[1] = 0.9, s->dome.color[2] = 1.0;
    }
}

void scene_load_options_defaults(ts_load_options *o)
{
    memset(o, 0, sizeof *o);
    o->frame = -1;
    o->programs = 1;
}

int scene_parse_up(const char *s, int *up)
{
    int sign = 1;
    if (*s == '-' || *s == '+') sign = *s++ == '-' ? -1 : 1;
    if (s[0] < 'x' || s[0] > 'z' || s[1]) return -1;
    *up = sign * (TS_UP_X + (s[0] - 'x'));
    return 0;
}

int scene_load(const char *path, ts_scene *s, int quiet, ts_error *err)
{
    return scene_load_frame(path, -1, s, quiet, err);
}

int scene_load_frame(const char *path, int frame, ts_scene *s, int quiet, ts_error *err)
{
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.frame = frame;
    lo.quiet = quiet;
    return scene_load_with(path, &lo, s, err);
}

int scene_load_with(const char *path, const ts_load_options *lo, ts_scene *s, ts_error *err)
{
    int frame = lo->frame;
    if (has_rib_extension(path)) return rib_load_with(path, lo, s, err);
    if (frame >= 0)
        return ts_error_set(err, TS_E_USAGE, "--frame %d: %s is a mesh, which has no frames", frame,
                            path);
    double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    ts_patch_attr attr;
    memset(&attr, 0, sizeof attr);
    attr.cs_r = attr.cs_g = attr.cs_b = 0.75f;
    attr.disp_kind = TS_DISP_NONE;
    attr.disp_octaves = 1u;
    attr.disp_frequency = 1.0f;
    attr.disp_lacunarity = 2.0f;
    attr.disp_gain = 0.5f;
    attr.material = TS_MAT_MATTE;
    attr.kd = 1.0f;
    attr.emitter = TS_INVALID;
    double up[3];
    int rc = mesh_load_ex(path, id, &attr, s, up, err);
    if (rc == TS_OK) rc = scene_finalize(s, err);
    if (rc != TS_OK) {
        scene_free(s);
        return rc;
    }
    if (lo->up != 0) { /* --up: the file's own axis (or the format's convention) overridden */
        int axis = (lo->up < 0 ? -lo->up : lo->up) - TS_UP_X;
        up[0] = up[1] = up[2] = 0.0;
        up[axis] = lo->up < 0 ? -1.0 : 1.0;
    }
    scene_frame_auto_up(s, up);
    return TS_OK;
}
