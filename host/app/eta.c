/* eta.c — the progress line's estimate (eta.h). */
#include "app/eta.h"

#include <math.h>
#include <stdlib.h>
#include <unistd.h>

uint64_t eta_weight(uint32_t cost)
{
    uint32_t c = cost - 1u < TS_ETA_CROSSINGS_SEEN ? cost - 1u : TS_ETA_CROSSINGS_SEEN;
    return 1u + c * (TS_ETA_GEOMETRY_WEIGHT - 1u) / TS_ETA_CROSSINGS_SEEN;
}

int eta_init(ts_eta *e, const uint32_t *cost, uint32_t npix, uint32_t spp, uint32_t band,
             ts_error *err)
{
    e->npix = npix, e->spp = spp ? spp : 1, e->band = band == 0 || band > npix ? npix : band;
    e->weighted = cost != NULL;
    e->prefix = malloc(((size_t)npix + 1) * sizeof *e->prefix);
    if (!e->prefix) return ts_error_set(err, TS_E_MEMORY, "out of memory (progress weights)");
    uint64_t counted = 0, sum = 0;
    for (uint32_t p = 0; cost && p < npix; ++p)
        if (cost[p]) ++counted, sum += eta_weight(cost[p]);
    uint64_t mean = counted ? (sum + counted / 2) / counted : 1;
    e->prefix[0] = 0;
    for (uint32_t p = 0; p < npix; ++p)
        e->prefix[p + 1] = e->prefix[p] + (!cost ? 1 : cost[p] ? eta_weight(cost[p]) : mean);
    return TS_OK;
}

void eta_free(ts_eta *e)
{
    free(e->prefix);
    e->prefix = NULL;
}

double eta_work(const ts_eta *e, uint64_t k)
{
    if (!e->prefix || e->npix == 0) return (double)k;
    uint64_t per_band = (uint64_t)e->band * e->spp, b = k / per_band;
    uint64_t base = b * e->band;
    if (base >= e->npix) return (double)e->spp * (double)e->prefix[e->npix];
    uint64_t n = e->npix - base < e->band ? e->npix - base : e->band;
    uint64_t r = k - base * e->spp, s = r / n, rest = r % n;
    /* whole bands, then whole passes over band b's pixels, then part of one */
    return (double)e->spp * (double)e->prefix[base] +
           (double)s * (double)(e->prefix[base + n] - e->prefix[base]) +
           (double)(e->prefix[base + rest] - e->prefix[base]);
}

uint32_t eta_waves_works(const ts_eta *e, uint64_t from, uint64_t total, uint64_t per_wave,
                         double *out)
{
    uint32_t n = 0;
    if (per_wave == 0) per_wave = 1;
    double wa = eta_work(e, from);
    for (uint64_t a = from; a < total; a += per_wave) {
        uint64_t b = total - a < per_wave ? total : a + per_wave;
        double wb = eta_work(e, b);
        if (!e->weighted || wb - wa > (double)(b - a) + 0.5) {
            if (out) out[n] = wb - wa;
            n++;
        }
        wa = wb;
    }
    return n;
}

uint32_t eta_waves_with_geometry(const ts_eta *e, uint64_t from, uint64_t total, uint64_t per_wave)
{
    return eta_waves_works(e, from, total, per_wave, NULL);
}

double eta_seconds_left(const ts_eta *e, double done, double seconds, uint64_t start,
                        uint64_t total)
{
    if (!(done > 0.0)) return -1.0;
    double left = eta_work(e, total) - eta_work(e, start) - done;
    return left > 0.0 ? seconds * left / done : 0.0;
}

void eta_print(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
               double rays, double seconds, const char *what)
{
    eta_print_left(e, samples, start, total, done, rays, seconds,
                   eta_seconds_left(e, done, seconds, start, total), what);
}

void eta_passes_start(ts_eta_passes *p, double rays)
{
    if (p->started < TS_ETA_PASSES) p->rays[p->started] = rays;
    p->started++;
}

void eta_passes_add(ts_eta_passes *p, double seconds, double dicing)
{
    if (p->count >= TS_ETA_PASSES) return;
    p->end[p->count] = seconds, p->dicing[p->count] = dicing;
    p->count++;
}

void eta_passes_batches(ts_eta_passes *p, double work, double t0)
{
    if (p->count == 0 || p->count > TS_ETA_PASSES) return;
    p->work[p->count - 1] = work, p->batches_t0[p->count - 1] = t0;
}

void eta_passes_before(ts_eta_passes *p, uint32_t bounce, double rays, double seconds,
                       double dicing)
{
    if (bounce > 0) eta_passes_add(p, seconds, dicing);
    eta_passes_start(p, rays);
}

/* After the eye rays' pass alone (eta.h eta_waves_project): the bounces as the last wave's,
 * scaled by the first bounce's rays. */
static double project_bounces(const ts_eta_waves *w, const ts_eta_passes *now, double *dicing)
{
    const ts_eta_passes *then = &w->last;
    if (now->count != 1 || now->started < 2 || then->count < 2 || then->started < 2) return -1.0;
    if (!(now->rays[1] > 0.0) || !(then->rays[1] > 0.0) || !(w->last_seconds >= then->end[0]))
        return -1.0;
    double scale = pow(now->rays[1] / then->rays[1], TS_ETA_REACH_EXPONENT);
    double then_dicing = then->dicing[then->count - 1];
    *dicing = now->dicing[0] +
              scale * (then_dicing > then->dicing[0] ? then_dicing - then->dicing[0] : 0.0);
    return now->end[0] + scale * (w->last_seconds - then->end[0]);
}

void eta_waves_done(ts_eta_waves *w, double work, double seconds, double dicing, int evicted,
                    const ts_eta_passes *passes)
{
    eta_waves_done_diced(w, work, seconds, dicing, evicted, passes, 0.0);
}

void eta_waves_done_diced(ts_eta_waves *w, double work, double seconds, double dicing, int evicted,
                          const ts_eta_passes *passes, double mp)
{
    int first = !evicted && mp > 0.0 && dicing > 0.0; /* the frame's first dicing */
    if (first) {
        w->first_dicing += dicing < seconds ? dicing : seconds, w->first_mp += mp;
        seconds = dicing < seconds ? seconds - dicing : 0.0;
    }
    w->work += work;
    w->seconds += evicted && dicing < seconds ? seconds - dicing : seconds;
    if (evicted) w->dicing += dicing < seconds ? dicing : seconds, w->evicting++;
    if (evicted && work > 0.0 && dicing > 0.0) {
        double x = log(work), y = log(dicing < seconds ? dicing : seconds);
        w->logged++, w->log_w += x, w->log_d += y, w->log_ww += x * x, w->log_wd += x * y;
    }
    w->last_evicted = evicted;
    if (evicted && passes) w->last = *passes, w->last_seconds = seconds;
}

double eta_waves_exponent(const ts_eta_waves *w)
{
    double n = (double)w->logged;
    if (w->logged < 2) return TS_ETA_REACH_EXPONENT;
    double mx = w->log_w / n, var = w->log_ww / n - mx * mx;
    if (!(var > 1e-4)) return TS_ETA_REACH_EXPONENT; /* the weights alike: no slope to see */
    double e = (w->log_wd / n - mx * w->log_d / n) / var;
    return e < 0.0 ? 0.0 : e > 0.5 ? 0.5 : e;
}

/* The dicing seconds of a wave of weight `work` as fitted to the waves that evicted (eta.h
 * ts_eta_waves): exp(mean log d + e (log work - mean log w)); their mean where none has both
 * a weight and dicing seconds; 0 when none evicted. */
static double dicing_fit(const ts_eta_waves *w, double work)
{
    if (!w->evicting) return 0.0;
    if (!w->logged || !(work > 0.0)) return w->dicing / w->evicting;
    double n = (double)w->logged;
    return exp(w->log_d / n + eta_waves_exponent(w) * (log(work) - w->log_w / n));
}

double eta_waves_dicing(const ts_eta_waves *w, double work)
{
    return w->last_evicted ? dicing_fit(w, work) : 0.0;
}

/* The seconds a unit of weight takes, less recurring dicing, over the finished waves. */
static double waves_rate(const ts_eta_waves *w)
{
    return w->work > 0.0 ? w->seconds / w->work : 0.0;
}

double eta_waves_expect(const ts_eta_waves *w, double work)
{
    if (!(w->work > 0.0) && !(w->seconds > 0.0)) return -1.0;
    return waves_rate(w) * work + eta_waves_dicing(w, work);
}

double eta_waves_left(const ts_eta_waves *w, double current, double elapsed, double after,
                      const double *works, uint32_t n)
{
    if (!(w->work > 0.0) && !(w->seconds > 0.0)) return -1.0;
    double left = 0.0;
    if (current > 0.0) {
        double now = eta_waves_expect(w, current);
        left += now > elapsed ? now - elapsed : 0.0;
    }
    /* the weight's seconds, and the dicing of the waves after that dice; where the waves
     * fit, the first dicing of the patches not diced yet, in the share of the weight left
     * (some patches a frame's eye rays cross are never reached: forest-1000 dices 97% of
     * its micro-polygons at their levels; what is left to trace can dice no more than it
     * meets) */
    for (uint32_t i = 0; i < n; ++i)
        left += eta_waves_dicing(w, works[i]);
    double rest = current + after, all = w->work + rest;
    if (!w->last_evicted && w->first_mp > 0.0 && w->mp_left > 0.0 && all > 0.0)
        left += w->first_dicing / w->first_mp * w->mp_left * rest / all;
    return left + waves_rate(w) * after;
}

double eta_waves_project(const ts_eta_waves *w, const ts_eta_passes *now, double *dicing)
{
    uint32_t k = now->count;
    if (!w->last_evicted) return -1.0;
    if (k < TS_ETA_PROJECT_PASSES) return project_bounces(w, now, dicing);
    if (k > w->last.count) return -1.0;
    double then = w->last.end[k - 1], ran = now->end[k - 1];
    if (!(then > 0.0) || !(ran > 0.0) || !(w->last_seconds >= then)) return -1.0;
    double seconds = ran * w->last_seconds / then;
    *dicing = now->dicing[k - 1] * seconds / ran;
    return seconds;
}

double eta_first_bounce(double share)
{
    if (!(share > 0.0) || share >= 1.0) return TS_ETA_FIRST_BOUNCE;
    return TS_ETA_FIRST_BOUNCE * pow(share < 0.01 ? 0.01 : share, -TS_ETA_BAND_EXPONENT);
}

/* The batches of the pass in flight are planned: trace_progress holds its own, not the pass
 * before's (their first began after the pass before ended). */
static int batches_planned(const ts_eta_passes *now)
{
    double begun = now->count > 0 ? now->end[now->count - 1] : 0.0; /* the pass in flight */
    return now->flight.work > 0.0 && now->flight.t0 >= begun;
}

double eta_wave_alone(const ts_eta_passes *now, double elapsed)
{
    double first = eta_first_bounce(now->share);
    uint32_t c = now->count; /* the pass in flight */
    if (now->started <= c || c >= TS_ETA_PASSES) return -1.0;
    double start = c > 0 ? now->end[c - 1] : 0.0;
    double before = c > 0 ? start - (c > 1 ? now->end[c - 2] : 0.0) : 0.0;
    const ts_eta_flight *f = &now->flight;
    double d;                                               /* pass c's seconds */
    int planned = batches_planned(now) && elapsed >= f->t0; /* pass c's batches */
    double rate = c > 0 && now->work[c - 1] > 0.0 && now->end[c - 1] > now->batches_t0[c - 1]
                      ? (now->end[c - 1] - now->batches_t0[c - 1]) / now->work[c - 1]
                      : 0.0; /* the pass before's seconds a unit of batch work */
    double seen = f->at > 0.0 && f->at < elapsed ? f->at : elapsed; /* when f was seen */
    if (planned && f->done >= TS_ETA_BATCHES_SEEN * f->work && seen > f->t0)
        d = f->t0 - start + (seen - f->t0) * f->work / f->done;
    else if (planned && rate > 0.0)
        d = f->t0 - start + f->work * rate;
    else if (c == 0)
        return -1.0;
    else if (c == 1 || !(now->rays[c - 1] > 0.0))
        d = before * (c == 1 ? first : TS_ETA_NEXT_BOUNCE);
    else
        d = before * pow(now->rays[c] / now->rays[c - 1], TS_ETA_REACH_EXPONENT);
    if (d < elapsed - start) d = elapsed - start;
    double seconds = start + d;
    for (uint32_t k = c + 1; k <= now->depth; ++k) {
        d *= k == 1 ? first : TS_ETA_NEXT_BOUNCE;
        seconds += d;
    }
    return seconds;
}

/* The dicing seconds of a wave projected by eta_wave_alone to take `seconds`: those by the
 * end of the last pass that ended (stages dice and build are counted as their launches are
 * collected, seconds late), and TS_ETA_BOUNCE_DICING of the time after it, or of the time
 * left in the eye rays' pass. */
static double wave_alone_dicing(const ts_eta_passes *now, double elapsed, double seconds)
{
    uint32_t c = now->count;
    double from = c > 0 ? now->end[c - 1] : elapsed, diced = c > 0 ? now->dicing[c - 1] : 0.0;
    if (c == 0 && now->flight.dicing > diced) diced = now->flight.dicing;
    double d = diced + (seconds > from ? seconds - from : 0.0) * TS_ETA_BOUNCE_DICING;
    return d < seconds ? d : seconds;
}

double eta_waves_left_passes(const ts_eta_waves *w, double current, double elapsed, double after,
                             const double *works, uint32_t n, const ts_eta_passes *now,
                             double *projected)
{
    double dicing = 0.0, seconds = now && current > 0.0 ? eta_waves_project(w, now, &dicing) : -1.0;
    int evicted = 1;
    if (seconds < 0.0 && now && current > 0.0 && !(w->work > 0.0) && !(w->seconds > 0.0)) {
        seconds = eta_wave_alone(now, elapsed);
        dicing = wave_alone_dicing(now, elapsed, seconds);
        evicted = now->flight.evicted;
    }
    if (projected) *projected = seconds;
    if (seconds < 0.0) return eta_waves_left(w, current, elapsed, after, works, n);
    ts_eta_waves then = *w; /* as if the wave in flight had finished as projected */
    double mp = 0.0;        /* where it fits: its first dicing so far, the rest in mp_left */
    if (!evicted && now && now->flight.mp > 0.0) dicing = now->flight.dicing, mp = now->flight.mp;
    eta_waves_done_diced(&then, current, seconds, dicing, evicted, NULL, mp);
    double left = seconds > elapsed ? seconds - elapsed : 0.0;
    return left + eta_waves_left(&then, 0.0, 0.0, after, works, n);
}

/* The first of free[0..n) to free (the least). */
static uint32_t earliest(const double *free_at, uint32_t n)
{
    uint32_t k = 0;
    for (uint32_t i = 1; i < n; ++i)
        if (free_at[i] < free_at[k]) k = i;
    return k;
}

/* The seconds a unit of weight `work` is expected to take by the units that ended, w
 * (eta_units_left): its weight at their rate, less their dicing, and, where its eye rays cross
 * a patch box, their dicing fitted to its weight (dicing_fit). */
static double unit_expect(const ts_eta_waves *w, double work, int geometry)
{
    return waves_rate(w) * work + (geometry ? dicing_fit(w, work) : 0.0);
}

/* The seconds unit x, out, is projected to take from its wave's passes so far (NULL: not
 * known), and its dicing seconds into *dicing; -1 where they say nothing yet.
 * As the last merged unit that evicted spent its passes (eta_waves_project) where that unit
 * is like it, of a weight within TS_ETA_UNITS_ALIKE of its own; else, or where that cannot
 * say, from its own passes (eta_wave_alone, the unit holding `share` of the weight): a first
 * unit of sky and treetops, whose eye rays' pass is short and whose bounces reach the forest,
 * put a forest unit of 53 s at 40 s in its first bounce, its own passes at 48-55 s. */
static double unit_project(const ts_eta_waves *w, double last_work, const ts_eta_unit *x,
                           double share, double *dicing)
{
    if (!x->passes) return -1.0;
    ts_eta_passes p = *x->passes;
    p.share = share;
    double seconds = -1.0;
    if (last_work * TS_ETA_UNITS_ALIKE >= x->work && x->work * TS_ETA_UNITS_ALIKE >= last_work)
        seconds = eta_waves_project(w, &p, dicing);
    if (seconds >= 0.0) return seconds;
    /* Before its first bounce's batches are planned, where the units merged weigh more than
     * it, they say more than its eye rays' pass: their rate (forest-100 1920x768 x 2 at
     * --memory 512: the last unit, a band of 0.17 of the weight, took 3.3 times its eye rays'
     * pass in its first bounce; projected from that pass the line said 12 s with 25 left). */
    if ((p.count == 0 || (p.count == 1 && !batches_planned(&p))) && w->work >= x->work) return -1.0;
    seconds = eta_wave_alone(&p, x->seconds);
    if (seconds >= 0.0) {
        *dicing = wave_alone_dicing(&p, x->seconds, seconds);
        return seconds;
    }
    return eta_waves_project(w, &p, dicing);
}

double eta_units_left(const ts_eta_unit *u, uint32_t n, uint32_t parallel, double *credit)
{
    if (credit) *credit = 0.0;
    ts_eta_waves w = {0};
    double last_work = 0.0; /* the weight of the unit whose passes are w.last */
    for (uint32_t i = 0; i < n; ++i)
        if (u[i].state == TS_ETA_UNIT_MERGED) {
            eta_waves_done(&w, u[i].work, u[i].seconds, u[i].dicing, u[i].evicted, u[i].passes);
            if (u[i].evicted && u[i].passes) last_work = u[i].work;
        }
    if (parallel == 0) return -1.0;
    /* Before a merged unit evicted, only units out whose patch caches evict, projected from
     * their own passes, can say (two MPI ranks with a unit each: nothing is merged until the
     * frame is nearly done). */
    int squeezed = w.evicting > 0;
    for (uint32_t i = 0; i < n && !squeezed; ++i)
        squeezed = u[i].state == TS_ETA_UNIT_OUT && u[i].passes && u[i].passes->flight.evicted;
    if (!squeezed) return -1.0;
    double *free_at = calloc(parallel, sizeof *free_at);
    double *expect = calloc(n ? n : 1, sizeof *expect);
    uint8_t *placed = calloc(n ? n : 1, 1);
    if (!free_at || !expect || !placed) {
        free(free_at), free(expect), free(placed);
        return -1.0;
    }
    /* The units out whose passes are known (those of this process's devices, and those other
     * MPI ranks send), projected from them, count as ended so for the rest (`then`). */
    ts_eta_waves then = w;
    int unknown = 0;
    double all = 0.0; /* the units' weight: each unit's share of it (ts_eta_passes.share) */
    for (uint32_t i = 0; i < n; ++i)
        all += u[i].work;
    for (uint32_t i = 0; i < n; ++i) {
        expect[i] = -1.0;
        if (u[i].state != TS_ETA_UNIT_OUT || u[i].queued) continue;
        double dicing = 0.0;
        expect[i] = unit_project(&w, last_work, &u[i], all > 0.0 ? u[i].work / all : 0.0, &dicing);
        if (expect[i] >= 0.0)
            eta_waves_done(&then, u[i].work, expect[i], dicing, 1, NULL);
        else if (u[i].passes && w.work < u[i].work) /* the merged ones say little of it */
            unknown = 1;
    }
    if (unknown || !then.evicting) {
        free(free_at), free(expect), free(placed);
        return unknown ? TS_ETA_UNITS_EYE_RAYS : -1.0;
    }
    /* The units a device traces, out longest first, each on a device of its own: as projected,
     * else expected by the rest. A device frees when its unit ends, or, for a unit out longer
     * than that, after another quarter of its time so far (it has not ended: 0 would be no
     * estimate). */
    for (uint32_t running = 0; running < parallel; ++running) {
        int64_t next = -1;
        for (uint32_t i = 0; i < n; ++i)
            if (u[i].state == TS_ETA_UNIT_OUT && !u[i].queued && !placed[i] &&
                (next < 0 || u[i].seconds > u[next].seconds))
                next = i;
        if (next < 0) break;
        const ts_eta_unit *x = &u[next];
        placed[next] = 1;
        double e = expect[next] >= 0.0 ? expect[next] : unit_expect(&then, x->work, x->geometry);
        double left = e - x->seconds;
        if (credit && e > 0.0) /* the share of its expected time it has run, at most 0.9 */
            *credit += x->work * (x->seconds < 0.9 * e ? x->seconds / e : 0.9);
        double least = TS_ETA_OVERRUN_LEFT * x->seconds;
        free_at[running] = left > least ? left : least;
    }
    /* Then the units out that wait (a device traces another, or more are out than devices),
     * and the units not out, in order: each to the device that frees first. */
    for (int pass = 0; pass < 2; ++pass)
        for (uint32_t i = 0; i < n; ++i)
            if (!placed[i] && u[i].state == (pass == 0 ? TS_ETA_UNIT_OUT : TS_ETA_UNIT_WAITING))
                free_at[earliest(free_at, parallel)] +=
                    unit_expect(&then, u[i].work, u[i].geometry);
    double left = 0.0;
    for (uint32_t i = 0; i < parallel; ++i)
        left = free_at[i] > left ? free_at[i] : left;
    free(free_at);
    free(expect);
    free(placed);
    return left;
}

/* "\rtessera: N / T samples, P% done, R Mrays/s, TAIL": under 80 columns (a longer line
 * wraps on a terminal and each update then scrolls). On a terminal the rest of a longer line
 * before it is erased (ESC [ K); elsewhere (a log) three spaces follow, as ever. */
void eta_print_tail(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
                    double rays, double seconds, const char *tail)
{
    double all = eta_work(e, total) - eta_work(e, start);
    fprintf(stderr, "\rtessera: %llu / %llu samples, %.0f%% done, %.2f Mrays/s, %s%s",
            (unsigned long long)samples, (unsigned long long)total,
            all > 0.0 ? 100.0 * done / all : 100.0, seconds > 0 ? rays / seconds / 1e6 : 0.0, tail,
            isatty(fileno(stderr)) ? "\x1b[K" : "   ");
}

void eta_print_left(const ts_eta *e, uint64_t samples, uint64_t start, uint64_t total, double done,
                    double rays, double seconds, double left, const char *what)
{
    char eta[48];
    if (left < 0.0)
        snprintf(eta, sizeof eta, "ETA after one %s", what);
    else
        snprintf(eta, sizeof eta, "ETA %.0f s", left);
    eta_print_tail(e, samples, start, total, done, rays, seconds, eta);
}
