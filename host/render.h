/* render.h — `tessera render`: load the scene, open the device, trace the image in waves of
 * samples through the pipeline, write the image and the stats. */
#ifndef TS_RENDER_H
#define TS_RENDER_H

#include "options.h"
#include "scene.h"
#include "stats.h"

/* The camera kernel's parameters for an image of width x height (RenderMan perspective:
 * screen window [-a,a]x[-1,1] for aspect a >= 1, else [-1,1]x[-1/a,1/a]; fov spans the
 * shorter axis). Fails on a singular camera transform or a fov outside (0, 180). */
int render_camera_params(const ts_camera *cam, int width, int height, ts_camera_params *out,
                         ts_error *err);

/* Renders options->scene_path to options->output_path. Fills stats. */
int render_run(const ts_render_options *options, ts_stats *stats, ts_error *err);

#endif
