/* units.c — units of work, their results, and the board that hands them out and merges them
 * in order (units.h). */
#include "app/units.h"
#include "app/eta.h"
#include "base/stats.h"
#include "lib/sample_order.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Bounds of units_plan. */
#define UNITS_PER_WORKER 32u
#define UNIT_MIN_SAMPLES 4096u
#define UNIT_MAX_SAMPLES (1u << 20)
/* The last 1/UNITS_TAIL of a frame's samples go in units 1/UNITS_TAIL_SPLIT the size. */
#define UNITS_TAIL 16u
#define UNITS_TAIL_SPLIT 4u

int unit_result_alloc(ts_unit_result *r, const ts_unit *u, const ts_sample_order *o, ts_error *err)
{
    memset(r, 0, sizeof *r);
    r->aov_count = sample_order_zero_count(o, u->first, u->count);
    size_t n = (size_t)u->count + 2 * (size_t)r->aov_count;
    r->radiance = malloc((n ? n : 1) * sizeof(ts_vec4));
    if (!r->radiance)
        return ts_error_set(err, TS_E_MEMORY, "out of memory for the results of %llu samples",
                            (unsigned long long)u->count);
    if (r->aov_count) {
        r->aov = r->radiance + u->count;
        r->albedo = r->aov + r->aov_count;
    }
    return TS_OK;
}

void unit_result_free(ts_unit_result *r)
{
    free(r->radiance);
    memset(r, 0, sizeof *r);
}

void units_merge(ts_film_state *film, const ts_sample_order *o, const ts_unit *u,
                 const ts_unit_result *r)
{
    if (u->count == 0) return;
    /* The pixel and sample of the unit's first sample (lib/sample_order.h), then of each next
     * one by stepping: k + 1 is the band's next pixel, after its last pixel the first pixel
     * at the next sample, after the last sample the next band's first pixel at sample 0. */
    uint32_t band = o->band == 0 || o->band > o->pixels ? o->pixels : o->band;
    uint32_t p, sample;
    sample_order_at((uint32_t)u->first, o->pixels, o->spp, o->band, &p, &sample);
    uint32_t base = p / band * band, end = o->pixels - base < band ? o->pixels : base + band;
    uint64_t j = 0;
    for (uint64_t k = 0; k < u->count; ++k) {
        /* kernels/film.cl: acc = accum[p]; acc.x += r.x; ... acc.w += 1.0f. A pixel's sum is
         * zero before its sample 0 (no unit holds samples of it yet): not read then, so that
         * the film's pages are written first (one page fault each, not a read of the zero
         * page and then a copy on write that interrupts every other core). */
        ts_vec4 acc = sample == 0 ? (ts_vec4){0.0f, 0.0f, 0.0f, 0.0f} : film->accum[p],
                s = r->radiance[k];
        acc.x += s.x;
        acc.y += s.y;
        acc.z += s.z;
        acc.w += 1.0f;
        film->accum[p] = acc;
        if (sample == 0 && j < r->aov_count)
            film->aov[p] = r->aov[j], film->albedo[p] = r->albedo[j], ++j;
        if (++p == end) {
            p = base;
            if (++sample == o->spp) {
                sample = 0;
                base = end, p = base;
                end = o->pixels - base < band ? o->pixels : base + band;
            }
        }
    }
}

void units_plan(uint64_t samples, uint32_t workers, uint64_t *unit_samples)
{
    if (workers < 1) workers = 1;
    uint64_t u = (samples + UNITS_PER_WORKER * workers - 1) / (UNITS_PER_WORKER * workers);
    if (u < UNIT_MIN_SAMPLES) u = UNIT_MIN_SAMPLES;
    if (u > UNIT_MAX_SAMPLES) u = UNIT_MAX_SAMPLES;
    u = (u + 63) / 64 * 64;
    const char *env = getenv("TESSERA_UNIT_SAMPLES");
    if (env && *env) {
        char *end;
        errno = 0;
        unsigned long long v = strtoull(env, &end, 10);
        if (!errno && !*end && v > 0 && v <= UNIT_MAX_SAMPLES) u = v;
    }
    *unit_samples = u;
}

int units_list(const ts_sample_order *o, uint64_t total, const ts_done *d, uint64_t gather,
               ts_unit **units, uint32_t *count, ts_error *err)
{
    *units = NULL, *count = 0;
    uint64_t band = sample_order_band_pixels(o);
    uint64_t bands = (o->pixels + band - 1) / band, first, end, zero_end;
    if (bands > UINT32_MAX) return ts_error_set(err, TS_E_USAGE, "too many bands");
    ts_unit *u = malloc((bands ? bands : 1) * sizeof *u);
    if (!u) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    uint32_t n = 0, i = 0;
    /* Bands of one pixel (done.h): a unit takes the rest of a band and the whole bands after
     * it, up to `gather` samples (units_plan's size; 0: UNIT_MIN_SAMPLES, enough to fill a
     * device); still no two units share a pixel. */
    int pixels = band == 1u && o->pixels > 1u;
    if (gather == 0) gather = UNIT_MIN_SAMPLES;
    /* The frame's last samples in smaller units (UNITS_TAIL): a device that runs out of units
     * waits for the others' last ones, half a unit on average (docs/benchmarks.md "Several
     * devices: where two devices lose to one ..."). */
    uint64_t small =
        gather / UNITS_TAIL_SPLIT > UNIT_MIN_SAMPLES ? gather / UNITS_TAIL_SPLIT : UNIT_MIN_SAMPLES;
    if (small > gather) small = gather; /* TESSERA_UNIT_SAMPLES below 4096 */
    uint64_t tail_from = total - total / UNITS_TAIL;
    for (uint64_t b = 0; sample_order_band_runs(o, b, &first, &end, &zero_end); ++b) {
        if (end > total) end = total;
        /* What d holds of the band is a prefix of it (done.h): the unit is the rest. */
        while (i < d->count && d->r[i].end <= first)
            ++i;
        int whole = !(i < d->count && d->r[i].first <= first);
        if (!whole) first = d->r[i].end < end ? d->r[i].end : end;
        if (first >= end) continue;
        if (pixels && whole && n > 0 && u[n - 1].first + u[n - 1].count == first &&
            u[n - 1].count < (u[n - 1].first >= tail_from ? small : gather)) {
            u[n - 1].count += end - first;
            continue;
        }
        u[n] = (ts_unit){.index = n, .first = first, .count = end - first}, ++n;
    }
    *units = u, *count = n;
    return TS_OK;
}

/* A unit's state on the board. */
enum { UNIT_NONE, UNIT_OUT, UNIT_MERGED, UNIT_GIVEN_BACK };

int board_init(ts_board *b, ts_film_state *film, const ts_sample_order *o, uint64_t total,
               uint64_t unit_samples, const ts_done *held, ts_error *err)
{
    memset(b, 0, sizeof *b);
    b->film = film;
    b->order = *o;
    b->total = total;
    ts_done none = {0};
    if (!held) held = &none;
    for (uint32_t i = 0; i < held->count; ++i)
        if (done_add(&b->done, held->r[i].first, held->r[i].end, err)) goto fail;
    b->start = done_samples(held);
    if (units_list(o, total, held, unit_samples, &b->units, &b->unit_count, err)) goto fail;
    b->gather = unit_samples ? unit_samples : UNIT_MIN_SAMPLES;
    size_t n = b->unit_count ? b->unit_count : 1;
    b->state = calloc(n, 1);
    b->holders = calloc(n, 1);
    b->holder = calloc(n, sizeof *b->holder);
    b->since = calloc(n, sizeof *b->since);
    b->took = calloc(n, sizeof *b->took);
    b->diced = calloc(n, sizeof *b->diced);
    b->evicted = calloc(n, 1);
    b->owner = calloc(n, sizeof *b->owner);
    b->started = calloc(n, sizeof *b->started);
    b->passes = calloc(n, sizeof *b->passes);
    if (!b->state || !b->holders || !b->holder || !b->since || !b->took || !b->diced ||
        !b->evicted || !b->owner || !b->started || !b->passes) {
        ts_error_set(err, TS_E_MEMORY, "out of memory");
        goto fail;
    }
    const char *env = getenv("TESSERA_BACKUP_UNITS"); /* a testing aid: 0 turns them off */
    b->backups = !(env && strcmp(env, "0") == 0);
    pthread_mutex_init(&b->lock, NULL);
    pthread_cond_init(&b->changed, NULL);
    return TS_OK;
fail:
    free(b->units);
    free(b->state);
    free(b->holders);
    free(b->holder);
    free(b->since);
    free(b->took);
    free(b->diced);
    free(b->evicted);
    free(b->owner);
    free(b->started);
    free(b->passes);
    done_free(&b->done);
    memset(b, 0, sizeof *b);
    return err->code;
}

void board_free(ts_board *b)
{
    if (!b->state) return;
    free(b->state);
    free(b->holders);
    free(b->holder);
    free(b->since);
    free(b->took);
    free(b->diced);
    free(b->evicted);
    free(b->owner);
    free(b->started);
    free(b->passes);
    free(b->units);
    done_free(&b->done);
    pthread_mutex_destroy(&b->lock);
    pthread_cond_destroy(&b->changed);
    memset(b, 0, sizeof *b);
}

int board_regather(ts_board *b, uint64_t samples)
{
    pthread_mutex_lock(&b->lock);
    ts_unit *units = NULL;
    uint32_t count = 0;
    ts_error err = {0};
    /* Nothing handed out yet: every unit's state is UNIT_NONE, and the films hold what they
     * held at the start (b->done); larger units are no more of them, so the per-unit
     * arrays keep their room. */
    if (b->next == 0 && b->merged == 0 && !b->closed && samples > b->gather &&
        units_list(&b->order, b->total, &b->done, samples, &units, &count, &err) == TS_OK &&
        count <= b->unit_count) {
        free(b->units);
        b->units = units, b->unit_count = count, b->gather = samples;
        units = NULL;
    }
    int made = units == NULL && count > 0;
    free(units);
    if (b->gated) b->gated = 0, b->changes++, pthread_cond_broadcast(&b->changed);
    pthread_mutex_unlock(&b->lock);
    return made;
}

void board_gate(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    b->gated = b->next == 0;
    pthread_mutex_unlock(&b->lock);
}

/* Hands unit i out to taker (0: none named) at time now. */
static void hand_out(ts_board *b, uint32_t i, uint16_t taker, double now, ts_unit *u)
{
    b->state[i] = UNIT_OUT;
    b->holders[i] = 1;
    b->holder[i] = taker;
    b->since[i] = now;
    b->owner[i] = taker, b->started[i] = now;
    memset(&b->passes[i], 0, sizeof b->passes[i]);
    if (taker) b->taker[taker - 1].since = now;
    *u = b->units[i];
    u->taker = taker;
    u->backup = 0;
}

/* Samples a second that taker (slot + 1) traced over the units it finished; 0 before its
 * first. */
static double taker_rate(const ts_board *b, uint16_t taker)
{
    const ts_board_taker *t = taker ? &b->taker[taker - 1] : NULL;
    return t && t->samples && t->seconds > 0 ? (double)t->samples / t->seconds : 0;
}

/* The unit out on a slower device that taker should trace a backup of now, or -1; *wake: when
 * one may become due (INFINITY: none will by waiting alone). board_take_as says the rule. */
static int64_t backup_pick(ts_board *b, uint16_t taker, double now, double *wake)
{
    double mine = taker_rate(b, taker), best = 0;
    int64_t pick = -1;
    if (!b->backups || !taker || mine <= 0) return -1;
    for (uint32_t i = 0; i < b->next; ++i) {
        if (b->state[i] != UNIT_OUT || b->holders[i] != 1 || !b->holder[i] || b->holder[i] == taker)
            continue;
        double need = (double)b->units[i].count / mine, held = now - b->since[i];
        double theirs = taker_rate(b, b->holder[i]), left;
        if (theirs > 0) {
            if (mine < 2 * theirs) continue; /* not much slower: it ends about as soon */
            left = (double)b->units[i].count / theirs - held;
            if (left <= 0) left = held; /* overdue: as far from the end as it has gone */
        } else if (held < 4 * need) {   /* its speed unknown yet: wait until it is clear */
            if (b->since[i] + 4 * need < *wake) *wake = b->since[i] + 4 * need;
            continue;
        } else {
            left = held;
        }
        if (left > 1.5 * need && left > best) best = left, pick = i;
    }
    return pick;
}

/* board_try_take with the lock held; taker may be handed a backup (board_take_as). */
static int take_locked(ts_board *b, uint16_t taker, ts_unit *u, double *wake)
{
    *wake = INFINITY;
    if (b->closed) return -1;
    if (b->gated) return 0; /* board_regather opens it */
    int out = 0;
    double now = stats_now();
    for (uint32_t i = 0; i < b->next; ++i) {
        if (b->state[i] == UNIT_GIVEN_BACK) {
            hand_out(b, i, taker, now, u);
            return 1;
        }
        out |= b->state[i] == UNIT_OUT;
    }
    if (b->next < b->unit_count) {
        hand_out(b, b->next++, taker, now, u);
        return 1;
    }
    int64_t i = out ? backup_pick(b, taker, now, wake) : -1;
    if (i >= 0) {
        b->holders[i] = 2;
        b->taker[taker - 1].since = now;
        b->backups_taken++;
        *u = b->units[i];
        u->taker = taker;
        u->backup = 1;
        return 1;
    }
    /* Units still out may be given back; only when none is can nothing more come. */
    return out ? 0 : -1;
}

/* Unit i (out or not) is done with or given back: its owner's next unit out, waiting behind
 * it (started < 0), starts now. */
static void owner_next(ts_board *b, uint32_t i, double now)
{
    uint32_t o = b->owner[i];
    int64_t next = -1;
    for (uint32_t k = 0; o && k < b->next; ++k)
        if (k != i && b->state[k] == UNIT_OUT && b->owner[k] == o && b->started[k] < 0 &&
            (next < 0 || b->since[k] < b->since[next]))
            next = k;
    if (next >= 0) b->started[next] = now;
}

int board_try_take_for(ts_board *b, uint32_t owner, ts_unit *u)
{
    double wake;
    pthread_mutex_lock(&b->lock);
    int rc = take_locked(b, 0, u, &wake);
    if (rc == 1 && owner) {
        uint32_t i = u->index;
        int busy = 0;
        for (uint32_t k = 0; k < b->next; ++k)
            busy |= k != i && b->state[k] == UNIT_OUT && b->owner[k] == owner;
        b->owner[i] = owner;
        b->started[i] = busy ? -1.0 : b->since[i];
    }
    pthread_mutex_unlock(&b->lock);
    return rc;
}

void board_unit_passes(ts_board *b, const ts_unit *u, const ts_eta_passes *p)
{
    pthread_mutex_lock(&b->lock);
    if (u->index < b->unit_count && b->state[u->index] == UNIT_OUT && !u->backup)
        b->passes[u->index] = *p;
    pthread_mutex_unlock(&b->lock);
}

int board_try_take(ts_board *b, ts_unit *u)
{
    double wake;
    pthread_mutex_lock(&b->lock);
    int rc = take_locked(b, 0, u, &wake);
    pthread_mutex_unlock(&b->lock);
    return rc;
}

/* Waits on b->changed (lock held) for up to `seconds`. */
static void wait_for(ts_board *b, double seconds)
{
    struct timespec at; /* pthread_cond_timedwait's clock */
    clock_gettime(CLOCK_REALTIME, &at);
    long ns = at.tv_nsec + (long)(seconds * 1e9);
    at.tv_sec += ns / 1000000000L;
    at.tv_nsec = ns % 1000000000L;
    pthread_cond_timedwait(&b->changed, &b->lock, &at);
}

/* Waits on b->changed (lock held) until the monotonic-clock time `until` of stats_now, or
 * without a limit when it is INFINITY. */
static void wait_until(ts_board *b, double until)
{
    if (!isfinite(until)) {
        pthread_cond_wait(&b->changed, &b->lock);
        return;
    }
    double left = until - stats_now();
    wait_for(b, left < 0.001 ? 0.001 : left);
}

int board_take_as(ts_board *b, uint16_t taker, ts_unit *u)
{
    if (taker > TS_BOARD_TAKERS) taker = 0;
    pthread_mutex_lock(&b->lock);
    int rc;
    double wake;
    while ((rc = take_locked(b, taker, u, &wake)) == 0)
        wait_until(b, wake);
    pthread_mutex_unlock(&b->lock);
    return rc > 0;
}

int board_take(ts_board *b, ts_unit *u)
{
    return board_take_as(b, 0, u);
}

int board_dropped(ts_board *b, const ts_unit *u)
{
    pthread_mutex_lock(&b->lock);
    int dropped = u->index < b->unit_count && b->state[u->index] == UNIT_MERGED;
    pthread_mutex_unlock(&b->lock);
    return dropped;
}

int board_done(ts_board *b, const ts_unit *u, ts_unit_result *r)
{
    pthread_mutex_lock(&b->lock);
    ts_error err = {0};
    int merged = 0;
    /* The unit's run joins the held samples first: when that cannot grow (out of memory),
     * the unit is handed out again rather than merged unrecorded. */
    if (u->index >= b->unit_count || !b->holders[u->index]) { /* not this board's, or not out */
        unit_result_free(r);
        pthread_mutex_unlock(&b->lock);
        return 0;
    }
    uint32_t i = u->index;
    b->holders[i]--;
    owner_next(b, i, stats_now());
    if (u->taker && u->taker <= TS_BOARD_TAKERS) { /* its speed, merged or not */
        ts_board_taker *t = &b->taker[u->taker - 1];
        t->seconds += stats_now() - t->since;
        t->samples += u->count;
    }
    if (!b->frozen && b->state[i] == UNIT_OUT &&
        done_add(&b->done, u->first, u->first + u->count, &err) == TS_OK) {
        double t0 = stats_now();
        units_merge(b->film, &b->order, u, r);
        b->merge_seconds += stats_now() - t0;
        b->state[i] = UNIT_MERGED;
        b->took[i] = t0 - b->since[i];
        b->diced[i] = r->dicing, b->evicted[i] = r->evicted != 0;
        b->passes[i] = r->passes;
        b->merged++;
        b->samples_finished += u->count;
        b->rays += r->rays;
        merged = 1;
    } else if (!b->frozen && b->state[i] == UNIT_OUT && !b->holders[i]) {
        b->state[i] = UNIT_GIVEN_BACK;
    }
    ts_error_clear(&err);
    unit_result_free(r);
    b->changes++;
    pthread_cond_broadcast(&b->changed);
    pthread_mutex_unlock(&b->lock);
    return merged;
}

void board_give_back(ts_board *b, const ts_unit *u)
{
    pthread_mutex_lock(&b->lock);
    if (u->index < b->unit_count && b->holders[u->index]) {
        uint32_t i = u->index;
        b->holders[i]--;
        owner_next(b, i, stats_now());
        if (b->state[i] == UNIT_OUT && !b->holders[i]) b->state[i] = UNIT_GIVEN_BACK;
        /* Its first holder gone, the backup's device holds it: no speed to judge that one
         * by (holder names the first), so no further backup of it. */
        if (b->holders[i] && u->taker == b->holder[i] && !u->backup) b->holder[i] = 0;
    }
    b->changes++;
    pthread_cond_broadcast(&b->changed);
    pthread_mutex_unlock(&b->lock);
}

void board_close(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    b->closed = 1;
    b->changes++;
    pthread_cond_broadcast(&b->changed);
    pthread_mutex_unlock(&b->lock);
}

void board_freeze(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    b->closed = b->frozen = 1;
    b->changes++;
    pthread_cond_broadcast(&b->changed);
    pthread_mutex_unlock(&b->lock);
}

uint32_t board_waiting(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    uint32_t n = b->unit_count - b->next;
    for (uint32_t i = 0; i < b->next; ++i)
        n += b->state[i] == UNIT_GIVEN_BACK;
    pthread_mutex_unlock(&b->lock);
    return n;
}

int board_finished(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    int done = b->merged == b->unit_count;
    pthread_mutex_unlock(&b->lock);
    return done;
}

uint64_t board_samples_done(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    uint64_t n = done_samples(&b->done);
    pthread_mutex_unlock(&b->lock);
    return n;
}

int board_held(ts_board *b, ts_done *held, ts_error *err)
{
    pthread_mutex_lock(&b->lock);
    int rc = TS_OK;
    for (uint32_t i = 0; i < b->done.count && !rc; ++i)
        rc = done_add(held, b->done.r[i].first, b->done.r[i].end, err);
    pthread_mutex_unlock(&b->lock);
    return rc;
}

uint64_t board_prefix(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    uint64_t end = b->done.count && b->done.r[0].first == 0 ? b->done.r[0].end : 0;
    pthread_mutex_unlock(&b->lock);
    return end;
}

void board_progress(ts_board *b, uint64_t *samples_finished, uint64_t *rays)
{
    pthread_mutex_lock(&b->lock);
    *samples_finished = b->samples_finished;
    *rays = b->rays;
    pthread_mutex_unlock(&b->lock);
}

double board_work_finished(ts_board *b, const ts_eta *eta)
{
    double work = 0.0;
    pthread_mutex_lock(&b->lock);
    for (uint32_t i = 0; i < b->unit_count; ++i)
        if (b->state[i] == UNIT_MERGED)
            work += eta_work(eta, b->units[i].first + b->units[i].count) -
                    eta_work(eta, b->units[i].first);
    pthread_mutex_unlock(&b->lock);
    return work;
}

double board_work_in_flight(ts_board *b, const ts_eta *eta, double now)
{
    double work = 0.0, seconds = 0.0, credit = 0.0;
    pthread_mutex_lock(&b->lock);
    for (uint32_t i = 0; i < b->unit_count; ++i)
        if (b->state[i] == UNIT_MERGED)
            work += eta_work(eta, b->units[i].first + b->units[i].count) -
                    eta_work(eta, b->units[i].first),
                seconds += b->took[i];
    for (uint32_t i = 0; work > 0.0 && seconds > 0.0 && i < b->unit_count; ++i) {
        if (b->state[i] != UNIT_OUT) continue;
        double w =
            eta_work(eta, b->units[i].first + b->units[i].count) - eta_work(eta, b->units[i].first);
        double c = (now - b->since[i]) * work / seconds; /* elapsed / (seconds a weight) */
        credit += c < 0.0 ? 0.0 : c < 0.9 * w ? c : 0.9 * w;
    }
    pthread_mutex_unlock(&b->lock);
    return credit;
}

double board_units_left(ts_board *b, const ts_eta *eta, double now, uint32_t parallel,
                        double *credit)
{
    pthread_mutex_lock(&b->lock);
    uint32_t n = b->unit_count;
    ts_eta_unit *u = calloc(n ? n : 1, sizeof *u);
    for (uint32_t i = 0; u && i < n; ++i) {
        uint64_t first = b->units[i].first, end = first + b->units[i].count;
        u[i].work = eta_work(eta, end) - eta_work(eta, first);
        u[i].geometry = eta_waves_with_geometry(eta, first, end, b->units[i].count) != 0;
        u[i].state = b->state[i] == UNIT_MERGED ? TS_ETA_UNIT_MERGED
                     : b->state[i] == UNIT_OUT  ? TS_ETA_UNIT_OUT
                                                : TS_ETA_UNIT_WAITING;
        u[i].seconds = b->state[i] == UNIT_MERGED                        ? b->took[i]
                       : b->state[i] == UNIT_OUT && b->started[i] >= 0.0 ? now - b->started[i]
                                                                         : 0.0;
        u[i].queued = b->state[i] == UNIT_OUT && b->started[i] < 0.0;
        u[i].passes = b->passes[i].started ? &b->passes[i] : NULL;
        u[i].dicing = b->diced[i], u[i].evicted = b->evicted[i];
    }
    if (credit) *credit = 0.0;
    double left = u ? eta_units_left(u, n, parallel, credit) : -1.0; /* u[].passes: b's */
    pthread_mutex_unlock(&b->lock);
    free(u);
    return left;
}

uint64_t board_changes(ts_board *b)
{
    pthread_mutex_lock(&b->lock);
    uint64_t n = b->changes;
    pthread_mutex_unlock(&b->lock);
    return n;
}

void board_wait(ts_board *b, double seconds, uint64_t seen)
{
    pthread_mutex_lock(&b->lock);
    if (b->changes == seen) wait_for(b, seconds);
    pthread_mutex_unlock(&b->lock);
}

static int source_take(void *ctx, uint16_t taker, ts_unit *u)
{
    return board_take_as(ctx, taker, u);
}

static int source_done(void *ctx, const ts_unit *u, ts_unit_result *r)
{
    return board_done(ctx, u, r);
}

static int source_dropped(void *ctx, const ts_unit *u)
{
    return board_dropped(ctx, u);
}

static void source_give_back(void *ctx, const ts_unit *u)
{
    board_give_back(ctx, u);
}

static int source_regather(void *ctx, uint64_t samples)
{
    return board_regather(ctx, samples);
}

static void source_passes(void *ctx, const ts_unit *u, const ts_eta_passes *p)
{
    board_unit_passes(ctx, u, p);
}

static int source_closed(void *ctx)
{
    ts_board *b = ctx;
    pthread_mutex_lock(&b->lock);
    int closed = b->closed;
    pthread_mutex_unlock(&b->lock);
    return closed;
}

ts_unit_source board_source(ts_board *b)
{
    return (ts_unit_source){b,
                            source_take,
                            source_done,
                            source_give_back,
                            source_closed,
                            source_dropped,
                            source_regather,
                            source_passes};
}
