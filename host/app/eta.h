/* eta.h — the progress line's estimate of the time left (issue 38 item 6, issue 41 item 4).
 *
 * Samples do not cost the same: a sky pixel's path ends at once, a forest pixel's crosses
 * dozens of patch boxes and bounces. The lod stage traces every pixel's first eye ray
 * through the top level before any wave (kernels/lod.cl) and counts the leaf boxes it
 * crosses; a sample of pixel p is then weighed 1 in the sky, where it crosses none, and up to
 * TS_ETA_GEOMETRY_WEIGHT as it crosses up to TS_ETA_CROSSINGS_SEEN (pipeline.h pixel_cost
 * holds 1 + crossings), and
 * the frame's progress is the weight of the samples finished over the weight of all of them,
 * in the frame's sample order (kernels/lib/sample_order.h). The time left is the weight left
 * at the rate measured so far (weight finished per second). Without the lod stage (a fixed
 * --lod) every pixel weighs 1: samples finished over samples, as before. */
#ifndef TS_ETA_H
#define TS_ETA_H

#include "base/error.h"

#include <stdint.h>
#include <stdio.h>

/* The weight of a sample whose eye ray crosses a patch box against one that crosses none
 * (sky), whose path ends at once. Measured per wave on PoCL (2026-11-30, stop 58): forest-100
 * at 1920x768 x 8, waves of 1.05 M samples, took 0.06-0.08 s of sky and 2.2-2.6 s of forest
 * apart from their dicing, whatever the forest's crossings (11-20 a sample); so a forest wave's
 * seconds less dicing over its weight are 0.061-0.074 us with this weight, where 1 + 16
 * crossings, the weight before, gave 0.006-0.066 us (the line said 645 s left of a 26 s frame
 * once a sky wave had set the rate). At 640x256 x 16 in waves of 131 K samples: 0.14-0.20
 * us a unit of weight in the forest, 0.08-0.11 in the sky (a wave's fixed cost). */
#define TS_ETA_GEOMETRY_WEIGHT 37u
/* The crossings at which a sample weighs TS_ETA_GEOMETRY_WEIGHT; with fewer it weighs
 * 1 + (37 - 1) crossings / 4. The displaced teapot at 1280x720 x 16 with --memory 48 ends in
 * waves of samples that cross a box or two and miss the teapot, cheap as sky: weighed 37
 * each, the line said 34 s 8 s before the end (26 s with this, 20 s with 1 + 16 crossings);
 * forest-100's samples cross 11-20 and weigh 37 either way. */
#define TS_ETA_CROSSINGS_SEEN 4u

typedef struct ts_eta {
    uint64_t *prefix; /* prefix[p]: the weight of pixels [0, p), npix + 1 entries */
    uint32_t npix, spp, band;
    int weighted; /* the pixels' costs were given (not every sample 1) */
} ts_eta;

/* The weight of a sample of a pixel whose pixel_cost is cost (>= 1). */
uint64_t eta_weight(uint32_t cost);
/* The weights of npix pixels from cost[] (0: not counted, weighs the mean of those counted;
 * NULL: all 1), spp samples a pixel, bands of band pixels (0: one band). */
int eta_init(ts_eta *e, const uint32_t *cost, uint32_t npix, uint32_t spp, uint32_t band,
             ts_error *err);
void eta_free(ts_eta *e);
/* The weight of the frame's samples [0, k) in its sample order. */
double eta_work(const ts_eta *e, uint64_t k);
/* Of the waves of `per_wave` samples from `from` to `total`, how many hold a sample whose
 * eye ray crosses a patch box (a weight above 1): the waves that dice, where the frame's
 * patches do not fit: a wave whose eye rays cross no patch box has no hit to bounce from,
 * and dices nothing. All of them where the pixels' costs are not known. */
uint32_t eta_waves_with_geometry(const ts_eta *e, uint64_t from, uint64_t total, uint64_t per_wave);
/* The seconds left when the samples of weight `done` took `seconds` and [start, total) is the
 * frame's part to trace; -1 while nothing is done. */
double eta_seconds_left(const ts_eta *e, double done, double seconds, uint64_t start,
                        uint64_t total);

/* Prints the progress line on stderr (\r, no newline): samples finished of total, the
 * share `done` of the weight of [start, total), rays per second over `seconds`, and the time
 * left, or "ETA after one <what>" while nothing is done. */
void eta_print(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
               double rays, double seconds, const char *what);
/* The same line with the time left given (`left` < 0: "ETA after one <what>"). */
void eta_print_left(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
                    double rays, double seconds, double left, const char *what);
/* The same line with `tail` where the time left goes (a note while there is none yet). The
 * line stays under 80 columns for tails of up to 20 characters. */
void eta_print_tail(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
                    double rays, double seconds, const char *tail);

/* The passes of a wave (its eye rays', then each bounce's: waves_trace_paths): how many have
 * begun (`started`: the pass in flight is bounce started - 1) and the rays each traced, and as
 * they end (`count`) the seconds from the wave's start to the end of pass i and its dicing
 * seconds by then. */
#define TS_ETA_PASSES 16u
/* The wave in flight as the progress line last saw it: the work of its pass in flight's
 * batches so far and of those the device has run, and when the first of them began, in
 * seconds from the wave's start (pipeline.h trace_progress); the wave's dicing seconds and
 * micro-polygons so far and whether its patch cache has evicted. */
typedef struct ts_eta_flight {
    double work, done, t0, dicing;
    double mp; /* the micro-polygons the wave has diced so far */
    int evicted;
    /* when it was seen, in seconds from the wave's start (0: now); a unit's reaches the
     * progress line up to 0.25 s later, another MPI rank's up to 0.75 s */
    double at;
} ts_eta_flight;
typedef struct ts_eta_passes {
    double end[TS_ETA_PASSES], dicing[TS_ETA_PASSES], rays[TS_ETA_PASSES];
    uint32_t count, started;
    uint32_t depth;       /* the deepest bounce (--depth): passes 0 .. depth */
    ts_eta_flight flight; /* eta_wave_alone */
    /* Of each ended pass, its batches' work and when the first began (seconds from the
     * wave's start; eta_passes_batches) */
    double work[TS_ETA_PASSES], batches_t0[TS_ETA_PASSES];
    /* The wave's share of the weight of the frame's part to trace (0: not known; taken as
     * the whole: eta_first_bounce) */
    double share;
} ts_eta_passes;

/* The wave's next pass begins with `rays` rays (counted always; the rays of passes beyond
 * TS_ETA_PASSES are not kept). */
void eta_passes_start(ts_eta_passes *p, double rays);
/* Its pass `count` ended `seconds` after the wave's start, with `dicing` seconds diced by
 * then. */
void eta_passes_add(ts_eta_passes *p, double seconds, double dicing);
/* Pass `count - 1`, which has ended, had batches of `work` from `t0` seconds after the
 * wave's start (pipeline.h trace_progress; work 0: none). */
void eta_passes_batches(ts_eta_passes *p, double work, double t0);
/* waves_trace_paths' watch (app/waves.h) before bounce b is traced, with `rays` rays: pass
 * b - 1 (b > 0) ended `seconds` after the wave's start, `dicing` seconds diced by then, and
 * pass b begins (eta_passes_add, eta_passes_start). */
void eta_passes_before(ts_eta_passes *p, uint32_t bounce, double rays, double seconds,
                       double dicing);

/* Waves that dice again what they need. When a frame's patches do not fit, each wave dices
 * about as much whatever its share of the weight: its bounces reach the whole scene (issue 38;
 * docs/benchmarks.md "Scenes that don't fit"). Measured on a first wave of sky and treetops,
 * the weight rate alone put the time left of forest-100 1920x768 x 2 at --memory 512 at 119 s
 * when 47 s were left. So a wave in which the patch cache evicted counts its dicing seconds
 * (stages dice and build) apart: the rate is the weight per second of the rest, and while the
 * waves evict, each wave left that dices adds dicing seconds as a power of its weight, c w^e,
 * fitted to those that did (least squares of log d on log w; e within [0, 0.5], and
 * TS_ETA_REACH_EXPONENT until two waves of different weights have evicted). The power varies
 * with the scene: a forest wave's bounces reach most of it whatever their number (forest-100's
 * three waves, of 0.085, 0.536 and 0.380 of the weight as 1 + 16 crossings weighed it,
 * diced 10.3, 19.9 and 16.5 s: from the first the power 0.3 predicts 18.0 and 16.2 s, their
 * mean 10.3 and 10.3), a band of the displaced teapot dices the few patches its rays meet whatever
 * its weight (1.1 s at 9 a sample, 1.8 s at 22, 1.3 s at 33: about 0). A wave that did not evict
 * counts whole (what it dices is new to the frame, and as the weight shows more of the scene, more
 * is new: the rate holds it). */
#define TS_ETA_REACH_EXPONENT 0.3
typedef struct ts_eta_waves {
    double work, seconds; /* the finished waves' weight, and their seconds less recurring dicing */
    double dicing;        /* the dicing seconds of the finished waves that evicted */
    uint32_t evicting;    /* how many those are */
    /* of those with weight and dicing: how many, and their sums of log w, log d, (log w)^2 and
     * log w log d (the fit above) */
    uint32_t logged;
    double log_w, log_d, log_ww, log_wd;
    int last_evicted; /* the last finished wave evicted */
    /* Waves that did not evict but diced (eta_waves_done_diced): their dicing seconds and
     * micro-polygons, counted apart from the rate; and the frame's micro-polygons at their
     * levels not diced yet (the caller keeps it current) */
    double first_dicing, first_mp, mp_left;
    ts_eta_passes last;  /* the passes of the last finished wave that evicted */
    double last_seconds; /* and its seconds */
} ts_eta_waves;

/* A finished wave of weight `work` took `seconds`, of which `dicing` diced and built; the
 * patch cache evicted during it when `evicted`; `passes` (NULL: not known) how its time went
 * by pass. */
void eta_waves_done(ts_eta_waves *w, double work, double seconds, double dicing, int evicted,
                    const ts_eta_passes *passes);
/* The same for a wave that created `mp` micro-polygons (0: not known). Where it did not evict,
 * what it diced is the frame's first dicing of those patches: a frame that fits dices each
 * once, most in its first waves with geometry (forest-100 1920x768 x 8: 3.96 of the 5.0 s of
 * the wave of 7.7% of its weight that met the forest first), so its dicing seconds count
 * apart from the weight's rate, and the waves left add the frame's micro-polygons not diced
 * yet (mp_left) at their seconds a micro-polygon, in the share of the weight left
 * (eta_waves_left). */
void eta_waves_done_diced(ts_eta_waves *w, double work, double seconds, double dicing, int evicted,
                          const ts_eta_passes *passes, double mp);
/* The seconds a wave of weight `work` is expected to take; -1 before a wave finished. */
double eta_waves_expect(const ts_eta_waves *w, double work);
/* The dicing seconds, among those, of a wave of weight `work` that dices (0 while the last
 * finished wave did not evict). */
double eta_waves_dicing(const ts_eta_waves *w, double work);
/* The exponent of the fit (TS_ETA_REACH_EXPONENT until it can be fitted). */
double eta_waves_exponent(const ts_eta_waves *w);
/* Of the waves of `per_wave` samples from `from` to `total`, those that dice (as
 * eta_waves_with_geometry counts them): their weights into out[0 ..) (NULL: none), returns
 * how many. */
uint32_t eta_waves_works(const ts_eta *e, uint64_t from, uint64_t total, uint64_t per_wave,
                         double *out);
/* The seconds left: the rest of the wave in flight, of weight `current`, which has run
 * `elapsed` seconds (none: current 0), then the waves after it, of weight `after` together,
 * those of which dice of weights works[0 .. n) (eta_waves_works); -1 before a wave
 * finished. */
double eta_waves_left(const ts_eta_waves *w, double current, double elapsed, double after,
                      const double *works, uint32_t n);

/* Inside a wave that dices again (the last finished wave evicted): the waves' weight alone
 * cannot say what the wave in flight takes (forest-100 1920x768 x 2 at --memory 512: its first
 * wave, of sky and treetops, diced 10 s, the second 20 s), but its passes can. Once it has
 * finished TS_ETA_PROJECT_PASSES passes (`now`; the eye rays' pass alone varies with the sky
 * the wave holds: 8% of the first wave, 23% of the second), its seconds are projected as the
 * last evicting wave spent its own over the same passes, and its dicing seconds in the
 * proportion of those it has run. After its eye rays' pass alone, with the first bounce's rays
 * known, the bounces are projected from the last wave's, scaled by the ratio of their first
 * bounce's rays to the power TS_ETA_REACH_EXPONENT: a bounce's rays reach most of the scene
 * whatever their number (that frame's bounces took 10.4 s after 158 K first-bounce rays,
 * 21.2 s after 1.63 M and 17.4 s after 1.54 M). Returns the projected seconds (and *dicing),
 * or -1 where there is nothing to project from. */
#define TS_ETA_PROJECT_PASSES 2u
double eta_waves_project(const ts_eta_waves *w, const ts_eta_passes *now, double *dicing);
/* A wave with no finished wave to compare with (the frame's first): its seconds projected
 * from its own passes. A squeezed frame may be one wave (forest-1000 at 1920x768 x 2 with
 * --memory 1536: 2.9 M paths, 50 s, in which the line said only which pass was in flight).
 * The pass in flight takes what its batches say once the device has run TS_ETA_BATCHES_SEEN
 * of their work (now->flight: its time before them, then their time so far over the share
 * of their work run, a batch's work being its misses' micro-quads and its pairs; a later
 * iteration adds its batches as it begins); before then, once its batches are planned, at the
 * seconds a unit of work took in the pass before (forest-1000's first bounce: 16.9 s, true
 * 18.2, where 1.2 times the eye rays' pass says 19.4; a wave of sky whose eye rays hit
 * little and whose bounces reach the forest: its first bounce took 5.9 times its eye rays'
 * pass); and otherwise the pass before it times TS_ETA_FIRST_BOUNCE for the first bounce
 * (forest-100, waves of 960x384 at --memory 128-256, and forest-1000's: a first bounce took
 * 0.87-1.68 times the eye rays' pass) and for a later one its rays' ratio to the pass before's to
 * the power TS_ETA_REACH_EXPONENT (the same waves' second and third bounces: 0.40-0.68 of the pass
 * before, that power of the rays' ratio 0.55-0.65); each pass after it up to now->depth, whose rays
 * are not known yet, takes the one before's times TS_ETA_FIRST_BOUNCE or TS_ETA_NEXT_BOUNCE. A pass
 * takes at least what it has run. Returns the wave's projected seconds, -1 in the eye rays' pass
 * before then. */
#define TS_ETA_BATCHES_SEEN 0.25
/* Where such a wave's patch cache has evicted, the waves after it are estimated as if it had
 * finished as projected (eta_waves_left_passes), its dicing seconds those so far and this
 * share of the rest: a squeezed frame's bounces dice most of their time (forest-100 at
 * 1920x768 x 2 with --memory 512: 0.93-0.96; at 960x384 with --memory 192: 0.65-0.93). */
#define TS_ETA_BOUNCE_DICING 0.9
#define TS_ETA_FIRST_BOUNCE 1.2
#define TS_ETA_NEXT_BOUNCE 0.6
double eta_wave_alone(const ts_eta_passes *now, double elapsed);
/* The first bounce's seconds over the eye rays' pass in a wave holding `share` (0..1] of the
 * frame's weight: TS_ETA_FIRST_BOUNCE times share to the power -TS_ETA_BAND_EXPONENT (share at
 * least 0.01). A wave's eye rays see its band of the image, its bounces reach most of the
 * scene whatever the band: forest-100 1920x768 x 2 at --memory 512 in four units of 873,676
 * samples on two MPI ranks (2026-11-30, stop 59), units of 0.45, 0.36 and 0.17 of the weight
 * had first bounces of 1.86, 1.55 and 3.3 times their eye rays' pass, the one of sky and
 * treetops (0.022) 16 times; but at 960x384 x 2 with --memory 192 on three ranks, units of 0.44
 * and 0.51 had 1.10 and 0.98. Replaying both frames' lines (every unit's passes at every
 * update): the time left within 14.9% and 44% on average with the power 0.4, 15.8% and 40%
 * with 0.2, 16.9% and 35% with none. A frame in one wave (share 1) keeps 1.2. */
#define TS_ETA_BAND_EXPONENT 0.2
double eta_first_bounce(double share);
/* eta_waves_left with the wave in flight projected from its passes where eta_waves_project
 * can, or before any wave finished where eta_wave_alone can (the waves after it then
 * estimated as if it had finished so), else the same; *projected (when not NULL): the
 * wave's projected seconds, -1 without. */
double eta_waves_left_passes(const ts_eta_waves *w, double current, double elapsed, double after,
                             const double *works, uint32_t n, const ts_eta_passes *now,
                             double *projected);

/* The units of several devices or MPI ranks (units.h) when the frame's patches do not fit:
 * each is a wave that dices the scene again (workers.c worker_squeeze), so a unit's time is
 * not its weight at the rate so far (forest-100 1920x768 x 2 at --memory 512 on two devices:
 * its first unit, of sky, 2% of the weight in 15 s, put the time left at 784 s when 65 s were
 * left). As one device's waves are modelled, from the merged units (their weight, seconds,
 * dicing seconds, whether they evicted, their passes): a unit out is projected from its
 * wave's passes so far (eta.c unit_project: as the last merged unit's where that one is alike,
 * else from its own passes and batches, eta_wave_alone; another MPI rank sends its units'
 * every half second), and every other unit (out without passes yet, or not out) expected to
 * take its weight at the rate of the rest plus dicing as fitted to its
 * weight where its eye rays cross a patch box, the units projected counted as ended so; the
 * `parallel` devices then
 * finish the units out and take the others in order, each the next as it frees (the units out
 * longest run first; those queued, or beyond `parallel`, wait, as an MPI rank's next unit does
 * while it traces one); a unit out longer than expected has a quarter of its time so far left. */
enum { TS_ETA_UNIT_WAITING, TS_ETA_UNIT_OUT, TS_ETA_UNIT_MERGED };
typedef struct ts_eta_unit {
    double work;    /* its weight (eta_work) */
    double seconds; /* merged: from taken to merged; out: since it began (0 when queued) */
    double dicing;  /* merged: its dicing seconds */
    int state;      /* TS_ETA_UNIT_... */
    int evicted;    /* merged: the patch cache evicted while it was traced */
    int geometry;   /* its eye rays cross a patch box (eta_waves_with_geometry) */
    int queued;     /* out, but its device traces another first (seconds 0) */
    /* merged: the passes of its (last) wave; out: those of the wave it traces, so far (NULL:
     * not known yet: another MPI rank's unit before its first report) */
    const ts_eta_passes *passes;
} ts_eta_unit;

/* The share of its time so far that a unit out longer than expected is given to run still. */
#define TS_ETA_OVERRUN_LEFT 0.25
/* The seconds left for units u[0..n) on `parallel` devices (>= 1) as above; -1 unless a
 * merged unit evicted or a unit out says its patch cache has (its passes' flight.evicted;
 * else the weights' rate holds: eta_seconds_left), or while nothing merged or projected can
 * say what the units take; TS_ETA_UNITS_EYE_RAYS
 * while a unit out cannot be projected from its passes yet (in its eye rays'
 * pass) and the units merged weigh less than it: they say little of it (forest-100 1920x768
 * x 2 at --memory 512 on two MPI ranks: after the first unit, of sky and treetops, 1.4 M of the
 * frame's 62.5 M, the others expected at its rate put 32 s left when 70 were; 6 s later the
 * unit's passes said 47). */
#define TS_ETA_UNITS_EYE_RAYS (-2.0)
/* Units alike: weights within this factor of each other (eta.c unit_project). */
#define TS_ETA_UNITS_ALIKE 2.0
/* *credit (when not NULL): the weight the units a device traces have done as the line credits
 * it: each unit's weight times the share of its expected time it has run, at most 0.9 (0 where
 * the time left is not estimated). The weights' credit (units.h board_work_in_flight, the
 * merged units' seconds a unit of weight) put forest-100 1920x768 x 2 at --memory 512 on two
 * MPI ranks at 25% done 47 s into its 82 s, after a first unit of sky. */
double eta_units_left(const ts_eta_unit *u, uint32_t n, uint32_t parallel, double *credit);

#endif
