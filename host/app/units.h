/* units.h — the units of work in which several devices (workers.h) and processes (ranks.h)
 * share one frame, and the board that hands them out and merges what they traced
 * (docs/rendering.md "Several devices and processes").
 *
 * A unit is a band of the frame's sample order (kernels/lib/sample_order.h: bands of rows,
 * each band's samples one after another), or what a resumed image lacks of one: a run
 * [first, first + count) of the order. A device traces it in waves like any run of samples
 * and hands back each sample's radiance (and, for the samples 0 of their pixels, the AOVs),
 * not a film. The board adds each unit into the host films as it finishes, sample by sample,
 * with the arithmetic of kernels/film.cl (accum[p] += radiance in float, w += 1): no pixel
 * has samples in two units, so every pixel's sum is that of a one-device render bit for
 * bit, whichever device traced which unit and whenever it finished. What the films hold is
 * recorded as runs of the order (done.h), which --resume continues. */
#ifndef TS_UNITS_H
#define TS_UNITS_H

#include "app/done.h"
#include "app/eta.h"
#include "app/resume.h"
#include "lib/shared_types.h"

#include <pthread.h>
#include <stdint.h>

typedef struct ts_unit {
    uint32_t index;        /* units are numbered from 0 in sample order */
    uint16_t taker;        /* the device slot + 1 that the board handed it to (0: none named) */
    uint16_t backup;       /* 1: handed out as a backup of a slower device's (board_take_as) */
    uint64_t first, count; /* global samples [first, first + count) */
} ts_unit;

/* What a device traced for a unit: radiance[k] of sample first + k (count entries); aov[j]
 * and albedo[j] of the j-th of its samples that are the samples 0 of their pixels
 * (aov_count = sample_order_zero_count of the unit, else 0 and NULL); the rays traced, for
 * the progress line. One allocation (radiance owns it). */
typedef struct ts_unit_result {
    ts_vec4 *radiance, *aov, *albedo;
    uint64_t aov_count;
    uint64_t rays;
    double dicing;        /* seconds its waves spent in the stages dice and build */
    uint32_t evicted;     /* the patch cache evicted while it was traced (the patches do not fit) */
    ts_eta_passes passes; /* its last wave's passes (eta.h), from that wave's start */
} ts_unit_result;

/* Allocates the result of unit u of a frame of order o (16 bytes a sample, 32 more for each
 * sample 0 of a pixel). TS_E_MEMORY when it cannot. */
int unit_result_alloc(ts_unit_result *r, const ts_unit *u, const ts_sample_order *o, ts_error *err);
void unit_result_free(ts_unit_result *r);

/* Adds unit u's samples into the films, in order: film->accum[p] += radiance of sample k
 * (x, y, z, and w += 1) for k's pixel p, film->aov and film->albedo set from samples 0:
 * film_accumulate's arithmetic. A pixel's sum starts from zero at its sample 0 (the films
 * hold no sample of a pixel before its sample 0; accum[p] is not read then). The units must
 * come in order. */
void units_merge(ts_film_state *film, const ts_sample_order *o, const ts_unit *u,
                 const ts_unit_result *r);

/* The size of the units for `samples` samples shared by `workers` devices: about 32 units
 * a device, so that a fast device takes more than a slow one and the last units end
 * together (8 a device left one device idle for most of a unit at the end of a forest-1
 * frame, and smaller bands keep each wave's patches closer together; docs/benchmarks.md), at least
 * 4096 samples (a wave too small fills no device) and at most 2^20 (16 MB of radiance), in
 * multiples of 64 (a work-group); TESSERA_UNIT_SAMPLES=N sets it (a testing aid: the image does not
 * depend on it). The frame's bands are single pixels (sample_order_band_pixel) gathered into units
 * of this size, or, with TESSERA_SAMPLE_BAND_ROWS, rows of about this size, a unit each
 * (units_list). */
void units_plan(uint64_t samples, uint32_t workers, uint64_t *unit_samples);

/* The units of the samples of [0, total) that d lacks: one a band (each band's run), or,
 * for bands of one pixel (done.h sample_order_band_pixel), the rest of a band and the whole
 * bands after it up to `gather` samples or more (0: 4096), and in the last sixteenth of the
 * frame up to a quarter of that (at least 4096), so that the devices' last units end close
 * together; no two units share a pixel. *units is malloc'd (NULL and 0 when nothing is
 * left). */
int units_list(const ts_sample_order *o, uint64_t total, const ts_done *d, uint64_t gather,
               ts_unit **units, uint32_t *count, ts_error *err);

/* Devices of one process that a board keeps the speeds of (slots 0 .. TS_BOARD_TAKERS - 1). */
#define TS_BOARD_TAKERS 64

/* The units of a frame's samples that the film lacks, handed out in order (given-back ones
 * first) and merged into the film as they finish: no two units share a pixel, so the order
 * of the merges changes no bit. Thread-safe: each device's thread takes and returns
 * units.
 *
 * Backup units: when nothing is left to hand out, a device that asks (board_take_as) may be
 * given a copy of a unit that a much slower device of the same process still traces (a GPU
 * beside a CPU: the CPU's last unit would otherwise hold the frame long after the GPU ran
 * out of work). Whichever finishes first is merged; the other is dropped (board_done
 * returns 0, board_dropped tells the slower one to stop between two waves). The same unit
 * traced on another device gives the same samples where the devices compute alike, and a
 * sample of its own device otherwise (docs/rendering.md "Backup units"). */
typedef struct ts_board_taker {
    double seconds;   /* spent on the units it finished */
    uint64_t samples; /* their samples */
    double since;     /* when it took the unit it traces now */
} ts_board_taker;

typedef struct ts_board {
    pthread_mutex_t lock;
    pthread_cond_t changed; /* a unit was merged or given back, or the board closed */
    uint64_t changes;       /* how many times `changed` was broadcast (board_changes) */
    ts_film_state *film;
    ts_sample_order order;
    uint64_t total, start; /* the frame's samples; those the films held at the start */
    ts_unit *units;
    uint32_t unit_count;
    uint32_t next;    /* the first unit never handed out */
    uint32_t merged;  /* how many units are in the films */
    uint8_t *state;   /* per unit */
    uint8_t *holders; /* per unit: devices tracing it (2 while it is backed up) */
    uint16_t *holder; /* per unit: the taker of its first holder (0: none named, or gone) */
    double *since;    /* per unit: when its first holder took it */
    double *took;     /* per unit merged: the seconds from then to its merge */
    double *diced;    /* per unit merged: its ts_unit_result dicing */
    uint8_t *evicted; /* per unit merged: its ts_unit_result evicted */
    /* per unit out: who traces it (a device slot + 1, board_try_take_for's owner; 0: not
     * known), and when it began (its take, or when its owner's unit before it was done with:
     * an MPI rank takes its next unit ahead; -1 until then) */
    uint32_t *owner;
    double *started;
    ts_eta_passes *passes; /* per unit: merged, its result's; out, its wave's so far */
    ts_board_taker taker[TS_BOARD_TAKERS]; /* per device slot: how fast it traces */
    int backups;                           /* backup units allowed (TESSERA_BACKUP_UNITS) */
    uint32_t backups_taken;                /* backup units handed out */
    ts_done done; /* the samples the films hold: what they held, and the merged units */
    uint64_t samples_finished, rays; /* units merged, for progress */
    double merge_seconds;            /* spent in units_merge */
    uint64_t gather;                 /* units_list's gather the units were made with */
    int gated;                       /* board_gate: nothing handed out until board_regather */
    int closed;                      /* board_close: nothing more is handed out */
    int frozen;                      /* board_freeze: nothing more is merged either */
} ts_board;

/* The board of a frame of `total` samples in order o, merging into film, which holds the
 * samples `held` (copied; NULL: none); units of about unit_samples where the bands are
 * single pixels (units_list's gather; 0: the least). TS_E_MEMORY when it cannot. */
int board_init(ts_board *b, ts_film_state *film, const ts_sample_order *o, uint64_t total,
               uint64_t unit_samples, const ts_done *held, ts_error *err);
void board_free(ts_board *b);
/* Before any unit is handed out: the units made again of up to `samples` samples each
 * (units_list's gather), when that is more than they were made with (returns 1); otherwise
 * nothing (0). For a frame whose patches do not fit (workers.c worker_squeeze): each unit is
 * a wave of its own and dices the scene again, so fewer, larger ones dice less. Opens a gated
 * board (board_gate) in either case. */
int board_regather(ts_board *b, uint64_t samples);
/* Hands out nothing until the first board_regather (rank 0 of several MPI ranks: the other
 * ranks' requests wait for its devices to decide the units' size). */
void board_gate(ts_board *b);

/* The next unit to trace into *u: a unit given back first, else the next in order. Returns
 * 1, or 0 when there is none left to hand out (every unit is out or merged) or the board is
 * closed. Waits while units are out that may yet be given back. */
int board_take(ts_board *b, ts_unit *u);
/* board_take for the device of slot taker - 1 (1 .. TS_BOARD_TAKERS), whose speed the board
 * learns from the units it finishes: when nothing new is left, it may be handed a backup of
 * a unit that a device at most half as fast holds (u->backup = 1) — as soon as that one's
 * speed says the backup ends first with a margin, or, while the holder has finished no
 * unit yet, once it has held the unit 4 times as long as the taker needs for it. */
int board_take_as(ts_board *b, uint16_t taker, ts_unit *u);
/* 1 when unit u is in the films from another device's copy: stop tracing it. */
int board_dropped(ts_board *b, const ts_unit *u);
/* The same without waiting: 1 a unit, 0 none now (every unit is out), -1 none ever again
 * (all handed out and merged, or closed). */
int board_try_take(ts_board *b, ts_unit *u);
/* board_try_take for `owner` (> TS_BOARD_TAKERS: an MPI rank's), which may take a unit while
 * it traces another: the new one is counted as begun once the one before is done with
 * (merged, dropped or given back), for the progress line's estimate (board_units_left). */
int board_try_take_for(ts_board *b, uint32_t owner, ts_unit *u);
/* The passes of the wave that unit u's device traces, so far (board_units_left projects the
 * unit from them); a backup's are not kept. */
void board_unit_passes(ts_board *b, const ts_unit *u, const ts_eta_passes *p);
/* Unit u is traced: merged into the films at once, and *r freed. Returns 1 when it was
 * merged, 0 when it was dropped (another copy was merged first, or the board is frozen). */
int board_done(ts_board *b, const ts_unit *u, ts_unit_result *r);
/* Unit u was not traced (its device failed or stopped, or its copy was dropped): unless
 * another device still traces it, it is handed out again first. */
void board_give_back(ts_board *b, const ts_unit *u);
/* Hands out nothing more (a stop signal, a failure): board_take returns 0 from now on;
 * units being traced may still be finished and merged. */
void board_close(ts_board *b);
/* Closes the board and merges nothing more: the films stay as they are (units finished
 * from now on are dropped), so they can be written while devices end their waves. */
void board_freeze(ts_board *b);
/* 1 when every unit is merged. */
int board_finished(ts_board *b);
/* How many units are waiting to be handed out (not out, not merged: given back or never
 * taken). */
uint32_t board_waiting(ts_board *b);
/* The samples the films hold, and (when held is not NULL) which: a copy into *held (empty
 * before). TS_E_MEMORY in *err when the copy cannot be made. */
uint64_t board_samples_done(ts_board *b);
int board_held(ts_board *b, ts_done *held, ts_error *err);
/* The end of the first run of samples the films hold, from sample 0 (0: they lack sample
 * 0): every sample before it is in the films and no unit adds to them any more. */
uint64_t board_prefix(ts_board *b);
/* Samples of the units merged so far (this run's) and their rays, for the progress line. */
void board_progress(ts_board *b, uint64_t *samples_finished, uint64_t *rays);
/* The weight (eta.h) of the samples of the units merged so far. */
double board_work_finished(ts_board *b, const ts_eta *eta);
/* The weight of the units out at time `now` that the progress line credits: each for the
 * share of its expected time it has been out, at most 90% of its weight, the expected time
 * being its weight at the seconds a unit of weight the merged units took from their take to
 * their merge (0 before the first is merged). So that the line moves while a device traces
 * a long unit (a frame whose patches do not fit: a unit or two a device) without claiming
 * samples that are not in the films. */
double board_work_in_flight(ts_board *b, const ts_eta *eta, double now);
/* The seconds left by eta_units_left (eta.h) on `parallel` devices: the units merged and out
 * at `now`, their weights by eta; -1 unless a unit evicted (eta.h); *credit (when not NULL):
 * the weight of the units out done as eta_units_left credits it. */
double board_units_left(ts_board *b, const ts_eta *eta, double now, uint32_t parallel,
                        double *credit);
/* How many times the board has changed (a unit merged or given back, the board closed). */
uint64_t board_changes(ts_board *b);
/* Waits up to `seconds` for the board to change after `seen` = board_changes: at once when
 * it already has, so that a change between the caller's look and its wait (the last unit
 * merged while the EXR stream wrote rows, say) is not slept through. */
void board_wait(ts_board *b, double seconds, uint64_t seen);

/* How the devices of one process get their units: from the board (board_source), or from a
 * relay that another process's board feeds (ranks.c). */
typedef struct ts_unit_source {
    void *ctx;
    /* 1: a unit for the device of slot taker - 1; 0: none left, or closed */
    int (*take)(void *ctx, uint16_t taker, ts_unit *u);
    /* takes *r; 1: merged (or sent on), 0: dropped (another copy was merged first) */
    int (*done)(void *ctx, const ts_unit *u, ts_unit_result *r);
    void (*give_back)(void *ctx, const ts_unit *u);
    int (*closed)(void *ctx); /* 1: stop at the end of the wave being traced */
    /* 1: u is merged from another device's copy, stop tracing it (NULL: never) */
    int (*dropped)(void *ctx, const ts_unit *u);
    /* board_regather (NULL: the units are another process's: an MPI rank's from rank 0) */
    int (*regather)(void *ctx, uint64_t samples);
    /* board_unit_passes (NULL: likewise) */
    void (*passes)(void *ctx, const ts_unit *u, const ts_eta_passes *p);
} ts_unit_source;

ts_unit_source board_source(ts_board *b);

#endif
