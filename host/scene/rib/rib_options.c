/* rib_options.c — camera and image options that real RIB files give before WorldBegin:
 * PixelSamples (sets the default samples per pixel), ScreenWindow (the camera kernel's
 * window), Exposure (gain and gamma applied to the image written), Clipping (applied to the
 * eye rays), Shutter (applied to motion blocks: rib_motion_shutter), CropWindow (the part
 * of the frame rendered: app/render.c render_crop) and DepthOfField (a thin lens).
 * docs/rib.md has the rules. */
#include "scene/rib/rib_internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* n numbers, then nothing. */
static int options_numbers(rib_parser *p, size_t n, double *v)
{
    size_t i = 0;
    int rc = rib_before_world(p);
    if (rc == TS_OK) rc = rib_numbers(p, &i, n, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    return rc;
}

/* PixelSamples xsamples ysamples: spp = round(x) * round(y), each in [1, 256]. */
int rib_req_pixel_samples(rib_parser *p)
{
    double v[2];
    int rc = options_numbers(p, 2, v);
    if (rc != TS_OK) return rc;
    for (int k = 0; k < 2; k++)
        if (!(v[k] >= 0.5 && v[k] < 256.5))
            return rib_error_at(p, p->req_line, p->req_col,
                                "PixelSamples: %csamples must be between 1 and 256, got %g",
                                k ? 'y' : 'x', v[k]);
    p->scene->camera.spp = (int)floor(v[0] + 0.5) * (int)floor(v[1] + 0.5);
    return TS_OK;
}

/* Clipping near far: 0 < near < far; the camera sees camera-space depths in [near, far]
 * (render_camera_params, kernels/camera.cl camera_clip). */
int rib_req_clipping(rib_parser *p)
{
    double v[2];
    int rc = options_numbers(p, 2, v);
    if (rc != TS_OK) return rc;
    if (!(v[0] > 0.0 && v[1] > v[0]))
        return rib_error_at(p, p->req_line, p->req_col, "Clipping: need 0 < near < far, got %g %g",
                            v[0], v[1]);
    p->scene->camera.clip_near = v[0];
    p->scene->camera.clip_far = v[1];
    return TS_OK;
}

/* Shutter open close: open <= close. The motion blocks that follow take their motion at these
 * times as their two time samples (rib_state.c rib_motion_shutter); a scene without motion
 * (RenderMan for Maya's `Shutter 0 0`) renders as RenderMan renders it, without a warning. */
int rib_req_shutter(rib_parser *p)
{
    double v[2];
    int rc = options_numbers(p, 2, v);
    if (rc != TS_OK) return rc;
    if (!(v[0] <= v[1]))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Shutter: the close time must not precede the open time, got %g %g",
                            v[0], v[1]);
    p->scene->camera.shutter[0] = v[0];
    p->scene->camera.shutter[1] = v[1];
    p->shutter_given = 1;
    return TS_OK;
}

/* CropWindow xmin xmax ymin ymax: within [0, 1], min < max; tessera render renders that part of
 * the frame (app/render.c render_crop). */
int rib_req_crop_window(rib_parser *p)
{
    double v[4];
    int rc = options_numbers(p, 4, v);
    if (rc != TS_OK) return rc;
    if (!(v[0] >= 0.0 && v[0] < v[1] && v[1] <= 1.0 && v[2] >= 0.0 && v[2] < v[3] && v[3] <= 1.0))
        return rib_error_at(p, p->req_line, p->req_col,
                            "CropWindow: need 0 <= min < max <= 1 on both axes, got %g %g %g %g",
                            v[0], v[1], v[2], v[3]);
    for (int k = 0; k < 4; k++)
        p->scene->camera.crop[k] = v[k];
    return TS_OK;
}

int rib_set_lens(rib_parser *p, int line, int col, const char *what, double fstop,
                 double focal_length, double focal_distance)
{
    ts_camera *c = &p->scene->camera;
    if (fstop >= 1e30) { /* RI_INFINITY: a pinhole */
        c->fstop = c->focal_length = c->focal_distance = 0.0;
        return TS_OK;
    }
    if (!(fstop > 0.0 && focal_length > 0.0 && focal_distance > 0.0))
        return rib_error_at(p, line, col,
                            "%s: need fstop, focallength and focaldistance above 0 (fstop %g for "
                            "a pinhole), got %g %g %g",
                            what, 1e30, fstop, focal_length, focal_distance);
    /* The rays' lengths are squared in floats: a lens or a distance beyond 1e18 would overflow */
    if (!(focal_length / fstop <= 1e18 && focal_distance <= 1e18))
        return rib_error_at(p, line, col,
                            "%s: a lens %g across focused at %g is beyond the range rays can "
                            "hold (1e18)",
                            what, focal_length / fstop, focal_distance);
    c->fstop = fstop, c->focal_length = focal_length, c->focal_distance = focal_distance;
    return TS_OK;
}

/* DepthOfField fstop focallength focaldistance (RI Spec 3.2 §4.1.3): a thin lens of aperture
 * focallength / fstop focused at focaldistance (camera-space units: the lens radius is
 * focallength / (2 fstop)); DepthOfField alone, or an infinite fstop, a pinhole. */
int rib_req_depth_of_field(rib_parser *p)
{
    int rc = rib_before_world(p);
    if (rc != TS_OK) return rc;
    if (p->nargs == 0) return rib_set_lens(p, p->req_line, p->req_col, "DepthOfField", 1e30, 0, 0);
    double v[3];
    size_t i = 0;
    rc = rib_numbers(p, &i, 3, v);
    if (rc == TS_OK) rc = rib_no_more(p, i);
    if (rc != TS_OK) return rc;
    return rib_set_lens(p, p->req_line, p->req_col, "DepthOfField", v[0], v[1], v[2]);
}

/* ScreenWindow left right bottom top (RI Spec §4.1.1): the part of the screen plane the
 * image shows; left < right, bottom < top. */
int rib_req_screen_window(rib_parser *p)
{
    double v[4];
    int rc = options_numbers(p, 4, v);
    if (rc != TS_OK) return rc;
    for (int k = 0; k < 4; k++)
        if (!(fabs(v[k]) <= FLT_MAX))
            return rib_error_at(p, p->req_line, p->req_col, "ScreenWindow: %g is out of range",
                                v[k]);
    if (!(v[0] < v[1] && v[2] < v[3]))
        return rib_error_at(p, p->req_line, p->req_col,
                            "ScreenWindow: need left < right and bottom < top, got %g %g %g %g",
                            v[0], v[1], v[2], v[3]);
    memcpy(p->scene->camera.screen, v, sizeof v);
    p->scene->camera.has_screen = 1;
    return TS_OK;
}

/* Exposure gain gamma (RI Spec §4.1.3): the image's colours c become (gain c)^(1/gamma)
 * when it is written (app/output.c); gain >= 0, gamma > 0. An option: it may come before
 * WorldBegin only. */
int rib_req_exposure(rib_parser *p)
{
    double v[2];
    int rc = options_numbers(p, 2, v);
    if (rc != TS_OK) return rc;
    if (!(v[0] >= 0.0 && v[0] <= FLT_MAX && v[1] > 0.0 && v[1] <= FLT_MAX))
        return rib_error_at(p, p->req_line, p->req_col,
                            "Exposure: need gain >= 0 and gamma > 0, got %g %g", v[0], v[1]);
    p->scene->camera.has_exposure = v[0] != 1.0 || v[1] != 1.0;
    p->scene->camera.exposure_gain = v[0];
    p->scene->camera.exposure_gamma = v[1];
    return TS_OK;
}
