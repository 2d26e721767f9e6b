/* render.h — `tessera render`: load the scene, open the device, trace the image in waves of
 * samples through the pipeline, write the image and the stats. */
#ifndef TS_RENDER_H
#define TS_RENDER_H

#include "app/options.h"
#include "app/ranks.h"
#include "scene/scene.h"
#include "base/stats.h"

/* The camera kernel's parameters for an image of width x height (RenderMan: the screen
 * window is cam->screen, else [-a,a]x[-1,1] for aspect a >= 1, else [-1,1]x[-1/a,1/a];
 * perspective screen units are tan(fov / 2), so fov spans the shorter axis of the default
 * window; orthographic ones are camera-space units). Fails on a singular camera transform
 * or, for perspective, a fov outside (0, 180). */
int render_camera_params(const ts_camera *cam, int width, int height, ts_camera_params *out,
                         ts_error *err);

/* How a render that did not fail ended. */
typedef enum ts_render_outcome {
    TS_RENDER_COMPLETE,    /* every sample traced; the image is written */
    TS_RENDER_INTERRUPTED, /* SIGINT, SIGTERM or SIGHUP: the samples finished so far are written */
    TS_RENDER_UP_TO_DATE,  /* --resume of an image that is already complete: nothing done */
    /* memory ran out at the smallest budget: the samples finished so far are written, and
     * reason says what failed */
    TS_RENDER_OUT_OF_MEMORY,
    /* every device of a render on several failed: the samples merged so far are written,
     * and reason says what failed last */
    TS_RENDER_DEVICES_FAILED,
} ts_render_outcome;

typedef struct ts_render_result {
    ts_render_outcome outcome;
    unsigned long long samples_done, samples_total; /* global sample indices */
    int signal;                                     /* the signal that interrupted it */
    char reason[2048]; /* TS_RENDER_OUT_OF_MEMORY, TS_RENDER_DEVICES_FAILED: the error */
} ts_render_result;

/* Renders options->scene_path to options->output_path. Fills stats and result.
 * While samples are traced, SIGINT, SIGTERM and SIGHUP only set a flag: the render stops
 * after the current wave and writes what is finished (an EXR also holds what --resume
 * needs, see docs/rendering.md); before that they have their usual effect. With options->resume the
 * render continues from the partial EXR at output_path (or starts when there is none).
 * When the device cannot provide a buffer, the budget is halved and the render planned
 * again, down to 16 MB; when even that fails after samples were finished, they are
 * written (TS_RENDER_OUT_OF_MEMORY) instead of lost. */
/* ranks: this process among the MPI ranks (rank 0 of several: it leads the frame, ranks.h);
 * NULL or one rank: alone. */
int render_run(const ts_render_options *options, ts_ranks *ranks, ts_stats *stats,
               ts_render_result *result, ts_error *err);

#endif
