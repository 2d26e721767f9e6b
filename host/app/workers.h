/* workers.h — one frame on several devices of one process (--device I,J,... or all;
 * docs/rendering.md "Several devices and processes"): each device has its own context,
 * queue and program (opened here, one after the other), its own memory budget sized from
 * its own memory, its own pipeline and a host thread of its own, which pulls units
 * (units.h) from a shared source, traces them and hands back their samples. The first device
 * runs the lod stage for the frame and every other device takes its levels of detail, so all
 * dice alike; the board merges the units in order, so the image is that of the first device
 * alone, bit for bit, on devices that compute alike (the same driver and kind of device). */
#ifndef TS_WORKERS_H
#define TS_WORKERS_H

#include "app/options.h"
#include "app/resume.h"
#include "app/units.h"
#include "pipeline/pipeline.h"

#include <pthread.h>

/* What every device of the frame needs to know. */
typedef struct ts_frame {
    const ts_render_options *opt; /* spp resolved */
    const ts_scene *scene;
    ts_camera_params cam; /* spp and seed set */
    uint32_t pixel_count;
    uint64_t unit_samples;  /* units_plan: the units' size (the bands' samples) */
    ts_job *job;            /* the lod device checks and records the lod hash in it */
    int rank;               /* MPI rank (0 without MPI), for the stats */
    uint32_t budget_share;  /* devices sharing the host's memory with this process's ones
                               (several ranks on one machine): each takes a share of it */
    uint64_t share_samples; /* a device's share of the samples left: of every device of
                               every rank (0: not known) */
    uint32_t devices_all;   /* the devices of every rank (each with as many as this one's, as
                               share_samples counts them; 0: this process's) */
} ts_frame;

typedef struct ts_worker ts_worker;

/* The devices of one process and their threads. */
typedef struct ts_workers {
    ts_frame frame;
    ts_unit_source src;
    uint32_t count; /* devices open */
    ts_worker *w;
    uint32_t sort_threads; /* each pipeline's share of the CPUs for the host sort */
    pthread_mutex_t lock;
    pthread_cond_t lod_cond;
    /* The frame's levels of detail: made by device 0 when makes_lod, else given by
     * workers_lod_set (ranks.c); lod_state 0 until then, 1 ready, -1 failed (fatal). */
    int makes_lod, lod_state;
    uint32_t max_lod;
    uint8_t *patch_lod;
    ts_error fatal; /* why the lod failed */
    /* The lod stage split over device 0 and the devices that compute like it (the crossed
     * rule, device 0 making the lod): the first sample pass's pixels in chunks dealt out in
     * turn, part k counting chunks k, k + lod_parts, ... (workers.c lod_count_part); lod_more
     * sums the counts of parts 1.. (integer sums: the levels do not depend on the split);
     * lod_part[k] is 0 while part k counts, 1 once added, -1 when its device could not
     * (device 0 counts it then). lod_parts 1: device 0 counts every pixel. */
    uint32_t lod_parts;
    uint32_t *lod_more;
    /* The pixels' weights for the progress line (pipeline.h pixel_cost, the largest of the
     * parts'), made with the levels (NULL: none); read once lod_state is 1. */
    uint32_t *pixel_cost;
    int8_t *lod_part;
    /* Built patches shared between the devices that compute like device 0 (patch_share.h;
     * docs/rendering.md "Shared patches"); sharing 0: none (one such device, or
     * TESSERA_PATCH_SHARE=0). */
    ts_patch_share share;
    int sharing;
    /* The arenas of the sharing devices as one host allocation with a place for every patch
     * (workers.c workers_place; patch_share_in_place): placed 0 until the first sharing
     * device with the frame's levels of detail decides, 1 when they are, -1 when not (a
     * device that does not share host memory, not enough room, or TESSERA_SHARED_ARENAS=0). */
    int placed;
    void *arena_grid, *arena_tree, *arena_tight;
    uint32_t *place_vert, *place_group;
    uint8_t *place_lod;
    uint64_t place_verts, place_groups;
    uint32_t alive;   /* threads still rendering or able to */
    uint32_t running; /* threads that have not ended */
    uint32_t set_up; /* threads past their set-up, its notes printed: the progress line may begin */
    int started;
} ts_workers;

/* --streams: indices[0..*count) repeated `streams` times (at most TS_DEVICE_MAX in all), the
 * devices in the same order each time: a worker a stream, each with its own context, queue,
 * host thread and share of its device's budget, so that one's host stages overlap another's
 * kernels (DESIGN.md §1 "Host and device overlap"). */
void workers_streams(int *indices, int *count, int streams);

/* The cores a CPU device among the devices `indices` leaves the host (DESIGN.md §1: a CPU
 * device beside a GPU takes only the cores the host stages leave it), for
 * ts_device_options.host_cores: with a GPU or accelerator among them, TESSERA_HOST_CORES,
 * else a quarter of the CPUs and at least 2 (the GPU's sort, resolve and shade ordering, the
 * merges and the drivers' threads); without one, TESSERA_HOST_CORES alone (to try it, or on
 * a CPU-only machine that runs other work); else 0, the whole device. */
unsigned workers_host_cores(const int *indices, int count);

/* Opens the devices indices[0..count) (dev_select's order) one after the other with
 * their programs; a device that fails is left out with a warning naming it (unless none
 * opens: then its error). Chooses each device's budget (--memory, else budget_default
 * from its own memory, the host's memory shared among the devices that use it) and,
 * unless quiet, says so. A CPU device leaves workers_host_cores to the host. */
int workers_open(ts_workers *g, const ts_frame *frame, const int *indices, int count,
                 ts_error *err);
/* Starts a thread per device taking units from src. makes_lod: device 0 runs the lod
 * stage (and checks frame->job's lod hash); else workers_lod_set gives the levels. */
int workers_start(ts_workers *g, ts_unit_source src, int makes_lod, ts_error *err);
/* The frame's levels of detail from elsewhere (rank 0): max_lod and patch_lod (patch_count
 * entries, copied); patch_lod NULL: failed (the threads end). */
void workers_lod_set(ts_workers *g, uint32_t max_lod, const uint8_t *patch_lod);
/* Waits for the lod (device 0's): 1 ready (*max_lod, *patch_lod valid until workers_close),
 * 0 failed (g->fatal says why). */
int workers_lod_wait(ts_workers *g, uint32_t *max_lod, const uint8_t **patch_lod);
/* Threads that have not failed; threads that have not ended (a thread ends when its source
 * has no unit left for it, or when it fails). */
uint32_t workers_alive(ts_workers *g);
uint32_t workers_running(ts_workers *g);
/* The frame's levels of detail: 0 not yet, 1 ready, -1 failed (does not wait). */
int workers_lod_state(ts_workers *g);
/* Prints (unless quiet) a warning for each device that failed since the last call, and
 * copies the last such error into *last (when not NULL). */
void workers_report(ts_workers *g, ts_error *last);
void workers_join(ts_workers *g);
/* Adds each device's stages, counters and lod histogram into stats, and its entry to
 * stats->devices. */
int workers_stats(ts_workers *g, ts_stats *stats, ts_error *err);
/* Joins the threads and releases the pipelines and the devices. */
void workers_close(ts_workers *g);

/* How the frame ended on several devices. */
typedef struct ts_frame_end {
    uint64_t samples_done; /* the films hold that many samples (which: the job's done) */
    int all_failed;        /* every device failed before the end: failure says why */
    ts_error failure;
} ts_frame_end;

/* What the waiting loop of workers_render does besides waiting. poll (ranks.c: MPI
 * messages; NULL: none) returns how many devices elsewhere may still take units (0: none),
 * or -1 with err set. on_stop (NULL: none) is called once on a stop signal, with the films
 * frozen at samples [0, samples_done), before the devices end their waves: rank 0 of an
 * MPI render writes the image there, since mpirun may kill it soon after its SIGTERM. */
typedef struct ts_frame_service {
    void *ctx;
    int (*poll)(void *ctx, ts_board *b, ts_workers *g, ts_error *err);
    double interval; /* seconds between polls */
    void (*on_stop)(void *stop_ctx, uint64_t samples_done);
    void *stop_ctx;
    /* Called on the waiting thread after each merge (and each interval): what the films
     * hold so far may be written out (render.c writes the EXR's finished rows). */
    void (*progress)(void *progress_ctx, ts_board *b, ts_workers *g);
    void *progress_ctx;
} ts_frame_service;

/* Renders samples [frame->job->samples_done, total) of the frame on the devices
 * indices[0..count) into film (which holds the samples before), with progress on stderr
 * (unless quiet). A stop signal (interrupt_signal, app/interrupt.h) closes the board: each device
 * ends at its current wave and the merged prefix is kept. When every device fails, the merged
 * prefix is kept and end->all_failed says so. service may be NULL. */
int workers_render(const ts_frame *frame, ts_film_state *film, const int *indices, int count,
                   const ts_frame_service *service, ts_stats *stats, ts_frame_end *end,
                   ts_error *err);

#endif
