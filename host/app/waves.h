/* waves.h — what one device's pipeline does for a frame, used by the one-device render
 * (render.c) and by each device of a render on several (workers.c): the lod stage over
 * the frame's eye rays, and the paths of one wave of samples (docs/rendering.md "Paths and
 * waves"). */
#ifndef TS_WAVES_H
#define TS_WAVES_H

#include "app/eta.h"
#include "app/options.h"
#include "app/resume.h"
#include "pipeline/pipeline.h"

/* The trace mode the options ask for (p->mode): spp, --lod, --intersect, --leaf-mode,
 * --leaf-size. */
ts_trace_mode waves_trace_mode(const ts_render_options *o);

/* ts_trace_mode.tight for a render or bake in mode `exact`: triangle mode's leaf boxes unless
 * TESSERA_TIGHT_LEAVES=0 (a testing aid, docs/errors.md: box mode's boxes, the same hits). */
int waves_tight_leaves(int exact);

/* The frame's levels of detail into p->patch_lod: the lod stage (pipeline_lod, by the rule
 * TESSERA_LOD_RULE names, crossed by default) counts the frame's first sample pass even when
 * the film already holds samples [0, job->samples_done) (--resume, a retry): it is
 * deterministic, so it gives the levels of
 * detail those samples were traced with, which job->check_lod verifies against job->lod
 * (TS_E_USAGE and job->lod_mismatch when they differ). Then job->lod, job->max_lod and
 * job->check_lod are recorded. With --lod nothing is counted. */
int waves_frame_lod(const ts_render_options *o, ts_pipeline *p, ts_camera_params cam, ts_job *job,
                    ts_error *err);
/* The rule TESSERA_LOD_RULE names (crossed when unset); TS_E_USAGE for another name. */
int waves_lod_rule(ts_lod_rule *rule, ts_error *err);
/* waves_frame_lod's second half, once p->patch_lod holds the frame's levels (made here or
 * over several devices, app/workers.c): the resume check and the job's record. */
int waves_lod_record(const ts_render_options *o, ts_pipeline *p, ts_job *job, ts_error *err);

/* Traces one wave of paths from the eye: the camera's rays of the samples [first, first + n)
 * of the frame's order (cam->first_sample, cam->ray_count, cam->band; pipeline_camera made
 * them), then each bounce's rays (BSDF and shadow rays together, Hanika §3.5: rays grouped
 * by generation) until none is left or the depth is reached. The radiance of path i
 * (sample first + i) is then in p->radiance[i], the AOVs of its first hit in p->aov[i] and
 * p->albedo[i]; nothing is added to the film. */
int waves_trace_paths(const ts_render_options *o, ts_pipeline *p, const ts_camera_params *cam,
                      ts_error *err);

/* What a caller may watch of waves_trace_paths (tools/bench_cache.c records every ray it
 * traces): called for bounce b with its rays listed in p->active[0..rays) (ray slot i < n:
 * path i's eye or BSDF ray, n + i: its shadow ray; n = cam->ray_count) before they are
 * traced (after 0: their origins, directions, flags and tmax in hit.t) and once they are
 * (after 1: their hits; active may be reordered by then). A non-zero return stops the wave
 * with the error in *err. */
typedef int (*ts_wave_watch)(void *ctx, ts_pipeline *p, uint32_t bounce, uint32_t rays, int after,
                             ts_error *err);
int waves_trace_paths_watched(const ts_render_options *o, ts_pipeline *p,
                              const ts_camera_params *cam, ts_wave_watch watch, void *ctx,
                              ts_error *err);

/* A wave's pass `bounce` begins with `rays` rays (ts_wave_watch before it is traced), the
 * wave having begun at stats_now() = t0 when p->stats held `dicing` dicing seconds: the pass
 * before it ended (eta_passes_before) with the batch work pipeline_trace left for it
 * (eta_passes_batches), into *e. One device's line (render.c) and a unit's (workers.c). */
void waves_pass_begins(ts_eta_passes *e, const ts_pipeline *p, uint32_t bounce, uint32_t rays,
                       double t0, double dicing);

/* The pass p traces, as the progress line projects a wave from it (eta.h ts_eta_flight,
 * eta_wave_alone), into *f: its batches' work so far and run (pipeline.h trace_progress), and
 * the wave's dicing seconds, micro-polygons and evictions since it began at stats_now() = t0,
 * when p->stats held dicing seconds, mp micro-polygons and `evictions` evictions. */
void waves_flight(const ts_pipeline *p, double t0, double dicing, uint64_t mp, uint64_t evictions,
                  ts_eta_flight *f);

/* TESSERA_SLOW_DEVICE="I:MS[,J:MS...]" (a testing aid, docs/errors.md): the milliseconds device
 * I pauses after each wave, alone or beside others; 0 when it names no such device. */
long waves_slow_ms(int device_index);

#endif
