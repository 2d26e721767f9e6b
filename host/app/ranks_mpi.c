/* ranks_mpi.c — one frame on several MPI ranks (ranks.h): MPI's start and end, rank 0's
 * service (the lod, units for the other ranks, their results and stats) and the other
 * ranks' whole render. Built only with the MPI feature (CMakeLists.txt: TESSERA_MPI). */
#include "app/ranks.h"
#include "app/interrupt.h"
#include "app/render.h"
#include "app/resume.h"
#include "device/device.h"
#include "scene/scene_load.h"
#include "scene/scene_pack.h"

#include <mpi.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum {
    RANKS_TAG_LOD = 1,
    RANKS_TAG_REQUEST,
    RANKS_TAG_UNIT,
    RANKS_TAG_RESULT,
    RANKS_TAG_GIVE_BACK,
    RANKS_TAG_BYE,
    RANKS_TAG_PASSES,
};

/* Seconds between two looks at the messages: the main thread of a rank has nothing else to
 * do while its devices' threads render. */
#define RANKS_POLL_SECONDS 0.002
/* A rank is handed a unit beyond one for each of its devices while at least this many units a
 * rank wait on the board (serve). */
#define RANKS_AHEAD_WAITING 2u
/* Broadcasts move at most this many bytes at a time (MPI counts are ints). */
#define RANKS_CHUNK ((size_t)1 << 30)

/* What rank 0 knows of another rank. */
typedef struct ranks_peer {
    uint32_t wants;   /* units asked for and not yet sent */
    uint32_t devices; /* its devices rendering, as its last request said */
    int bye;          /* its stats came: it takes nothing more */
    ts_unit *out;     /* units sent to it and not yet back (out_count of out_capacity) */
    uint32_t out_count, out_capacity;
} ranks_peer;

/* The levels of detail, as rank 0 sends them. */
typedef struct ranks_lod_head {
    int32_t ok;
    uint32_t max_lod, patch_count, pad;
} ranks_lod_head;

/* A unit's results: this header, then count radiances, aov_count AOVs and albedos. */
typedef struct ranks_result_head {
    ts_unit unit;
    uint64_t rays, aov_count;
    double dicing;        /* ts_unit_result's */
    uint64_t evicted;     /* likewise */
    ts_eta_passes passes; /* likewise */
} ranks_result_head;

/* A rank's goodbye: this header, then device_count ts_device_stats. */
typedef struct ranks_bye_head {
    ts_rank_stats rank;
    double stage_seconds[TS_STAGE_COUNT];
    uint64_t counters[TS_COUNTER_COUNT];
    uint64_t lod_histogram[TS_LOD_LIMIT + 1];
    uint64_t frame_lod_histogram[TS_LOD_LIMIT + 1];
    double kernel_build_seconds;
    uint32_t device_count;
    int32_t failed; /* 1: it rendered nothing: error says why */
    char error[1024];
} ranks_bye_head;

static int mpi_fail(ts_error *err, int rc, const char *what)
{
    char text[MPI_MAX_ERROR_STRING] = "";
    int len = 0;
    MPI_Error_string(rc, text, &len);
    return ts_error_set(err, TS_E_DEVICE, "MPI: %s failed: %s", what, text);
}

static void sleep_seconds(double s)
{
    nanosleep(&(struct timespec){0, (long)(s * 1e9)}, NULL);
}

int ranks_init(int *argc, char ***argv, ts_ranks *r, ts_error *err)
{
    memset(r, 0, sizeof *r);
    r->size = r->node_ranks = 1;
    r->t0 = stats_now();
    gethostname(r->host, sizeof r->host - 1);
    if (ranks_launched_size() <= 1) return TS_OK;
    int provided = 0, rc = MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    if (rc != MPI_SUCCESS) return mpi_fail(err, rc, "MPI_Init_thread");
    r->mpi = 1;
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &r->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &r->size);
    MPI_Comm node;
    if (MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node) ==
        MPI_SUCCESS) {
        MPI_Comm_size(node, &r->node_ranks);
        MPI_Comm_free(&node);
    }
    return TS_OK;
}

void ranks_finalize(ts_ranks *r, int status)
{
    if (r->mpi && status == 0) MPI_Finalize();
    for (int k = 0; r->peers && k < r->size; ++k)
        free(r->peers[k].out);
    free(r->peers);
    r->peers = NULL;
}

/* Notes that unit u went to peer p (1), or came back from it (0, by its index). */
static int peer_track(ranks_peer *p, const ts_unit *u, int sent)
{
    if (!sent) {
        for (uint32_t i = 0; i < p->out_count; ++i)
            if (p->out[i].index == u->index) {
                p->out[i] = p->out[--p->out_count];
                break;
            }
        return TS_OK;
    }
    if (p->out_count == p->out_capacity) {
        uint32_t cap = p->out_capacity ? 2 * p->out_capacity : 8;
        ts_unit *grown = realloc(p->out, cap * sizeof *grown);
        if (!grown) return TS_E_MEMORY;
        p->out = grown, p->out_capacity = cap;
    }
    p->out[p->out_count++] = *u;
    return TS_OK;
}

/* Broadcasts `size` bytes from rank 0 in chunks. */
static int bcast_bytes(void *data, size_t size, ts_error *err)
{
    for (size_t at = 0; at < size; at += RANKS_CHUNK) {
        size_t n = size - at < RANKS_CHUNK ? size - at : RANKS_CHUNK;
        int rc = MPI_Bcast((char *)data + at, (int)n, MPI_BYTE, 0, MPI_COMM_WORLD);
        if (rc != MPI_SUCCESS) return mpi_fail(err, rc, "MPI_Bcast");
    }
    return TS_OK;
}

int ranks_start(ts_ranks *r, ts_rank_start *start, const ts_scene *scene, ts_error *err)
{
    double t0 = stats_now();
    void *block = NULL;
    size_t size = 0;
    ts_error pack = {0};
    if (!start->status && !start->scene_load && scene_pack(scene, &block, &size, &pack))
        start->status = 1;
    start->scene_bytes = size;
    int rc = MPI_Bcast(start, (int)sizeof *start, MPI_BYTE, 0, MPI_COMM_WORLD);
    if (rc != MPI_SUCCESS) rc = mpi_fail(err, rc, "MPI_Bcast");
    if (!rc && size) rc = bcast_bytes(block, size, err);
    free(block);
    r->scene_seconds += stats_now() - t0;
    if (!rc && pack.code) rc = ts_error_set(err, pack.code, "%s", pack.msg);
    ts_error_clear(&pack);
    if (rc || start->status) return rc;
    r->peers = calloc((size_t)r->size, sizeof *r->peers);
    if (!r->peers) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    r->started = 1;
    return TS_OK;
}

/* The next message from anyone (from `source` unless MPI_ANY_SOURCE), if one has come:
 * 1 with *data (malloc'd), *bytes, *from and *tag; 0 none; -1 an MPI error. */
static int recv_any(int source, int *from, int *tag, void **data, int *bytes, ts_error *err)
{
    int flag = 0, rc;
    MPI_Status st;
    if ((rc = MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st)) != MPI_SUCCESS)
        return mpi_fail(err, rc, "MPI_Iprobe"), -1;
    if (!flag) return 0;
    MPI_Get_count(&st, MPI_BYTE, bytes);
    *data = malloc(*bytes ? (size_t)*bytes : 1);
    if (!*data) return ts_error_set(err, TS_E_MEMORY, "out of memory (a message)"), -1;
    *from = st.MPI_SOURCE, *tag = st.MPI_TAG;
    rc = MPI_Recv(*data, *bytes, MPI_BYTE, *from, *tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (rc != MPI_SUCCESS) {
        free(*data);
        return mpi_fail(err, rc, "MPI_Recv"), -1;
    }
    return 1;
}

static int send_bytes(const void *data, size_t bytes, int to, int tag, ts_error *err)
{
    int rc = MPI_Send(data, (int)bytes, MPI_BYTE, to, tag, MPI_COMM_WORLD);
    return rc == MPI_SUCCESS ? TS_OK : mpi_fail(err, rc, "MPI_Send");
}

/* ---- rank 0 ---------------------------------------------------------------------------- */

/* Sends the frame's levels of detail (or their failure) to every other rank. */
static int send_lod(ts_ranks *r, ts_workers *g, ts_error *err)
{
    uint32_t max_lod = 0;
    const uint8_t *lod = NULL;
    int ok = workers_lod_wait(g, &max_lod, &lod);
    uint32_t n = g->frame.scene->patch_count;
    size_t bytes = sizeof(ranks_lod_head) + (ok ? n : 0);
    unsigned char *msg = malloc(bytes);
    if (!msg) return ts_error_set(err, TS_E_MEMORY, "out of memory");
    ranks_lod_head head = {ok, max_lod, ok ? n : 0, 0};
    memcpy(msg, &head, sizeof head);
    if (ok && n) memcpy(msg + sizeof head, lod, n);
    int rc = TS_OK;
    for (int k = 1; k < r->size && !rc; ++k)
        rc = send_bytes(msg, bytes, k, RANKS_TAG_LOD, err);
    free(msg);
    r->lod_sent = 1;
    return rc;
}

/* A unit's results from another rank, into the board. */
static int take_result(ranks_peer *p, ts_board *b, const void *data, int bytes, ts_error *err)
{
    ranks_result_head head;
    if ((size_t)bytes < sizeof head) return ts_error_set(err, TS_E_INTERNAL, "MPI: a short result");
    memcpy(&head, data, sizeof head);
    ts_unit_result res;
    if (unit_result_alloc(&res, &head.unit, &b->order, err)) return err->code;
    size_t payload = (size_t)(head.unit.count + 2 * res.aov_count) * sizeof(ts_vec4);
    if (res.aov_count != head.aov_count || (size_t)bytes != sizeof head + payload) {
        unit_result_free(&res);
        return ts_error_set(err, TS_E_INTERNAL, "MPI: a result of the wrong size");
    }
    memcpy(res.radiance, (const char *)data + sizeof head, payload);
    res.rays = head.rays;
    res.dicing = head.dicing, res.evicted = head.evicted != 0, res.passes = head.passes;
    peer_track(p, &head.unit, 0);
    board_done(b, &head.unit, &res);
    return TS_OK;
}

/* Another rank's goodbye: its stats into r->stats (warnings for its devices that failed);
 * the units it still held (its devices failed) go back on the board. */
static int take_bye(ts_ranks *r, ts_board *b, int from, const void *data, int bytes, int quiet,
                    ts_error *err)
{
    ranks_bye_head head;
    if ((size_t)bytes < sizeof head) return ts_error_set(err, TS_E_INTERNAL, "MPI: a short bye");
    memcpy(&head, data, sizeof head);
    if ((size_t)bytes != sizeof head + head.device_count * sizeof(ts_device_stats))
        return ts_error_set(err, TS_E_INTERNAL, "MPI: a bye of the wrong size");
    ranks_peer *p = &r->peers[from];
    p->bye = 1;
    p->wants = 0;
    while (p->out_count > 0)
        board_give_back(b, &p->out[--p->out_count]);
    head.error[sizeof head.error - 1] = '\0';
    head.rank.host[sizeof head.rank.host - 1] = head.rank.error[sizeof head.rank.error - 1] = '\0';
    if (head.failed && !quiet) {
        fputc('\n', stderr); /* end the progress line */
        ts_print_line("tessera: warning: rank %d (%s) stopped: %s", from, head.rank.host,
                      head.error);
    }
    ts_stats s;
    memset(&s, 0, sizeof s);
    memcpy(s.stage_seconds, head.stage_seconds, sizeof s.stage_seconds);
    memcpy(s.counters, head.counters, sizeof s.counters);
    memcpy(s.lod_histogram, head.lod_histogram, sizeof s.lod_histogram);
    memcpy(s.frame_lod_histogram, head.frame_lod_histogram, sizeof s.frame_lod_histogram);
    s.kernel_build_seconds = head.kernel_build_seconds;
    if (stats_merge(r->stats, &s, err) || stats_add_rank(r->stats, &head.rank, err))
        return err->code;
    for (uint32_t i = 0; i < head.device_count; ++i) {
        ts_device_stats d;
        memcpy(&d, (const char *)data + sizeof head + i * sizeof d, sizeof d);
        d.name[sizeof d.name - 1] = d.error[sizeof d.error - 1] = '\0';
        if (d.failed && !quiet) {
            fputc('\n', stderr); /* end the progress line */
            ts_print_line("tessera: warning: rank %d (%s): device %d (%s) stopped: %s", from,
                          head.rank.host, d.index, d.name, d.error);
        }
        if (stats_add_device(r->stats, &d, err)) return err->code;
        r->stats->memory_budget_bytes += d.memory_budget_bytes;
    }
    return TS_OK;
}

/* Handles every message that has come; answers what the board can answer. */
static int serve(ts_ranks *r, ts_board *b, int quiet, ts_error *err)
{
    void *data;
    int from, tag, bytes, got;
    while ((got = recv_any(MPI_ANY_SOURCE, &from, &tag, &data, &bytes, err)) > 0) {
        int rc = TS_OK;
        ts_unit u;
        uint32_t n[2]; /* a request: how many units, and the rank's devices rendering */
        ts_eta_passes passes;
        if (tag == RANKS_TAG_REQUEST && bytes == (int)sizeof n)
            memcpy(n, data, sizeof n), r->peers[from].wants += n[0], r->peers[from].devices = n[1];
        else if (r->peers[from].bye) /* units it had in flight: given back at its bye */
            rc = TS_OK;
        else if (tag == RANKS_TAG_RESULT)
            rc = take_result(&r->peers[from], b, data, bytes, err);
        else if (tag == RANKS_TAG_PASSES && bytes == (int)(sizeof u + sizeof passes))
            memcpy(&u, data, sizeof u),
                memcpy(&passes, (const char *)data + sizeof u, sizeof passes),
                board_unit_passes(b, &u, &passes); /* for the progress line */
        else if (tag == RANKS_TAG_GIVE_BACK && bytes == (int)sizeof u)
            memcpy(&u, data, sizeof u), peer_track(&r->peers[from], &u, 0), board_give_back(b, &u);
        else if (tag == RANKS_TAG_BYE)
            rc = take_bye(r, b, from, data, bytes, quiet, err);
        else
            rc = ts_error_set(err, TS_E_INTERNAL, "MPI: an unknown message (tag %d) from rank %d",
                              tag, from);
        free(data);
        if (rc) return rc;
    }
    if (got < 0) return err->code;
    for (int k = 1; k < r->size; ++k) {
        ranks_peer *p = &r->peers[k];
        while (p->wants > 0 && !p->bye) {
            /* One unit a device; one more, to start at once when one ends, only while many
             * wait: a frame whose patches do not fit has a few long units (forest-100
             * 1920x768 x 2 at --memory 512: four of 30-50 s), and a rank holding the next
             * while it traces one left rank 0 without work for 86 of 126 s. */
            if (p->out_count >= (p->devices ? p->devices : 1u) &&
                board_waiting(b) < RANKS_AHEAD_WAITING * (uint32_t)r->size)
                break;
            ts_unit u;
            int t = board_try_take_for(b, TS_BOARD_TAKERS + (uint32_t)k, &u);
            if (t == 0) break;
            if (t < 0) u = (ts_unit){.index = UINT32_MAX}; /* none left */
            if (t > 0 && peer_track(p, &u, 1)) {
                board_give_back(b, &u);
                return ts_error_set(err, TS_E_MEMORY, "out of memory");
            }
            if (send_bytes(&u, sizeof u, k, RANKS_TAG_UNIT, err)) return err->code;
            p->wants = t < 0 ? 0 : p->wants - 1;
        }
    }
    return TS_OK;
}

/* The ranks that may still take units. */
static int ranks_active(const ts_ranks *r)
{
    int n = 0;
    for (int k = 1; k < r->size; ++k)
        n += !r->peers[k].bye;
    return n;
}

static int service_poll(void *ctx, ts_board *b, ts_workers *g, ts_error *err)
{
    ts_ranks *r = ctx;
    if (!r->lod_sent && workers_lod_state(g) != 0 && send_lod(r, g, err)) return -1;
    if (serve(r, b, r->quiet, err)) return -1;
    return ranks_active(r);
}

ts_frame_service ranks_service(ts_ranks *r, ts_stats *stats)
{
    r->stats = stats;
    return (ts_frame_service){.ctx = r, .poll = service_poll, .interval = RANKS_POLL_SECONDS};
}

static int cmp_rank(const void *a, const void *b)
{
    const ts_rank_stats *x = a, *y = b;
    return (x->rank > y->rank) - (x->rank < y->rank);
}

int ranks_finish(ts_ranks *r, ts_stats *stats, ts_error *err)
{
    r->stats = stats;
    /* The board is finished: every request is answered "none left". A throwaway board
     * answers them. */
    ts_board done;
    memset(&done, 0, sizeof done);
    ts_sample_order one = {1, 1, 0};
    if (board_init(&done, NULL, &one, 0, 0, NULL, err)) return err->code;
    int rc = TS_OK;
    while (!rc && ranks_active(r) > 0) {
        rc = serve(r, &done, r->quiet, err);
        if (!rc && interrupt_signal()) break;
        sleep_seconds(RANKS_POLL_SECONDS);
    }
    board_free(&done);
    ts_rank_stats me = {
        .rank = 0, .seconds = stats_now() - r->t0, .scene_seconds = r->scene_seconds};
    snprintf(me.host, sizeof me.host, "%s", r->host);
    for (uint32_t i = 0; i < stats->device_count; ++i) {
        const ts_device_stats *d = &stats->devices[i];
        if (d->rank != 0) continue;
        me.devices += !d->failed;
        me.units += d->units;
        me.samples += d->samples;
    }
    me.kernel_seconds = stats_kernel_seconds(stats); /* its spans: the other ranks send none */
    me.host_serial_seconds = stats_host_serial(me.seconds, me.kernel_seconds);
    if (!rc) rc = stats_add_rank(stats, &me, err);
    if (!rc) qsort(stats->ranks, stats->rank_count, sizeof *stats->ranks, cmp_rank);
    return rc;
}

/* ---- every other rank ------------------------------------------------------------------ */

/* What the devices of a rank other than 0 finished, for the main thread to send. */
typedef struct relay_item {
    ts_unit unit;
    int given_back; /* 1: not traced */
    ts_unit_result result;
    struct relay_item *next;
} relay_item;

/* The passes of a unit this rank traces, as its device last handed them (units.h
 * ts_unit_source.passes), for rank 0's progress line (eta.h eta_units_left): sent at most
 * every RANKS_PASSES_SECONDS while they change. */
typedef struct relay_passes {
    ts_unit unit;
    ts_eta_passes passes;
    int fresh; /* changed since sent */
} relay_passes;
#define RANKS_PASSES_UNITS 16u
#define RANKS_PASSES_SECONDS 0.5

/* The units rank 0 gave this rank, as a unit source for its devices (units.h). */
typedef struct relay {
    pthread_mutex_t lock;
    pthread_cond_t changed;
    ts_unit *queue; /* units not yet taken, in order */
    uint32_t queued, capacity;
    int no_more, closed;
    relay_item *out, **out_tail;             /* finished or given back, oldest first */
    relay_passes passes[RANKS_PASSES_UNITS]; /* unit.count 0: a free entry */
} relay;

static int relay_take(void *ctx, uint16_t taker, ts_unit *u)
{
    relay *q = ctx;
    (void)taker; /* rank 0's board hands out no backups to other ranks */
    pthread_mutex_lock(&q->lock);
    while (!q->queued && !q->no_more && !q->closed)
        pthread_cond_wait(&q->changed, &q->lock);
    int got = q->queued && !q->closed;
    if (got) {
        *u = q->queue[0];
        memmove(q->queue, q->queue + 1, --q->queued * sizeof *q->queue);
    }
    pthread_mutex_unlock(&q->lock);
    return got;
}

/* The entry of unit u's passes in q (lock held): its own, else a free one (NULL: none). */
static relay_passes *relay_passes_of(relay *q, const ts_unit *u, int add)
{
    relay_passes *free_entry = NULL;
    for (uint32_t i = 0; i < RANKS_PASSES_UNITS; ++i) {
        relay_passes *e = &q->passes[i];
        if (e->unit.count && e->unit.index == u->index) return e;
        if (!e->unit.count && !free_entry) free_entry = e;
    }
    return add ? free_entry : NULL;
}

static void relay_unit_passes(void *ctx, const ts_unit *u, const ts_eta_passes *p)
{
    relay *q = ctx;
    pthread_mutex_lock(&q->lock);
    relay_passes *e = relay_passes_of(q, u, 1);
    if (e) e->unit = *u, e->passes = *p, e->fresh = 1;
    pthread_mutex_unlock(&q->lock);
}

/* Queues a finished unit (result, or given back) for the main thread to send. A unit whose
 * item cannot be allocated is lost to this rank: rank 0 never hears of it and the frame
 * waits for it until the render is stopped, as for a rank that dies. */
static void relay_out(relay *q, const ts_unit *u, ts_unit_result *r)
{
    relay_item *it = calloc(1, sizeof *it);
    pthread_mutex_lock(&q->lock);
    relay_passes *e = relay_passes_of(q, u, 0); /* its result carries its last passes */
    if (e) memset(e, 0, sizeof *e);
    if (it) {
        it->unit = *u;
        it->given_back = r == NULL;
        if (r) it->result = *r, memset(r, 0, sizeof *r);
        *q->out_tail = it;
        q->out_tail = &it->next;
    }
    pthread_mutex_unlock(&q->lock);
    if (r) unit_result_free(r);
}

static int relay_done(void *ctx, const ts_unit *u, ts_unit_result *r)
{
    relay_out(ctx, u, r);
    return 1;
}

static void relay_give_back(void *ctx, const ts_unit *u)
{
    relay_out(ctx, u, NULL);
}

static int relay_closed(void *ctx)
{
    relay *q = ctx;
    pthread_mutex_lock(&q->lock);
    int closed = q->closed;
    pthread_mutex_unlock(&q->lock);
    return closed;
}

/* Adds a unit from rank 0 (index UINT32_MAX: none left), or closes the relay. */
static int relay_put(relay *q, const ts_unit *u, int close)
{
    pthread_mutex_lock(&q->lock);
    int rc = TS_OK;
    if (close) {
        q->closed = 1;
    } else if (u->index == UINT32_MAX) {
        q->no_more = 1;
    } else if (q->queued == q->capacity) {
        uint32_t cap = q->capacity ? 2 * q->capacity : 16;
        ts_unit *grown = realloc(q->queue, cap * sizeof *grown);
        if (grown) q->queue = grown, q->capacity = cap, q->queue[q->queued++] = *u;
        rc = grown ? TS_OK : TS_E_MEMORY;
    } else {
        q->queue[q->queued++] = *u;
    }
    pthread_cond_broadcast(&q->changed);
    pthread_mutex_unlock(&q->lock);
    return rc;
}

/* Takes the items to send (the caller frees them). */
static relay_item *relay_drain(relay *q)
{
    pthread_mutex_lock(&q->lock);
    relay_item *items = q->out;
    q->out = NULL;
    q->out_tail = &q->out;
    pthread_mutex_unlock(&q->lock);
    return items;
}

/* TESSERA_KILL_RANK="R:K" (a testing aid, docs/errors.md): rank R kills itself (SIGKILL)
 * once it has sent K units' results, as a crashed machine would vanish in mid-frame. */
static void kill_rank_test(int sent)
{
    static int rank = -1, after = -1;
    const char *v = getenv("TESSERA_KILL_RANK");
    if (after < 0 && (!v || sscanf(v, "%d:%d", &rank, &after) != 2)) after = 0;
    int me = -2;
    MPI_Comm_rank(MPI_COMM_WORLD, &me);
    if (after > 0 && me == rank && sent >= after) raise(SIGKILL);
}

/* Sends finished units' results and given-back units to rank 0. */
static int send_items(relay_item *it, ts_error *err)
{
    static int sent;
    int rc = TS_OK;
    while (it) {
        relay_item *next = it->next;
        if (!rc && it->given_back) {
            rc = send_bytes(&it->unit, sizeof it->unit, 0, RANKS_TAG_GIVE_BACK, err);
        } else if (!rc) {
            ts_unit_result *res = &it->result;
            ranks_result_head head = {it->unit,    res->rays,    res->aov_count,
                                      res->dicing, res->evicted, res->passes};
            size_t payload = (size_t)(it->unit.count + 2 * res->aov_count) * sizeof(ts_vec4);
            char *msg = malloc(sizeof head + payload);
            if (!msg) rc = ts_error_set(err, TS_E_MEMORY, "out of memory (sending a unit)");
            if (msg) {
                memcpy(msg, &head, sizeof head);
                memcpy(msg + sizeof head, res->radiance, payload);
                rc = send_bytes(msg, sizeof head + payload, 0, RANKS_TAG_RESULT, err);
                free(msg);
                if (!rc) kill_rank_test(++sent);
            }
        }
        unit_result_free(&it->result);
        free(it);
        it = next;
    }
    return rc;
}

/* The passes of the units this rank traces that changed since they were last sent: a unit,
 * then its passes, as serve reads them. */
static int send_passes(relay *q, ts_error *err)
{
    char msg[RANKS_PASSES_UNITS][sizeof(ts_unit) + sizeof(ts_eta_passes)];
    uint32_t n = 0;
    pthread_mutex_lock(&q->lock);
    for (uint32_t i = 0; i < RANKS_PASSES_UNITS; ++i)
        if (q->passes[i].unit.count && q->passes[i].fresh) {
            memcpy(msg[n], &q->passes[i].unit, sizeof(ts_unit));
            memcpy(msg[n] + sizeof(ts_unit), &q->passes[i].passes, sizeof(ts_eta_passes));
            q->passes[i].fresh = 0, n++;
        }
    pthread_mutex_unlock(&q->lock);
    for (uint32_t i = 0; i < n; ++i)
        if (send_bytes(msg[i], sizeof msg[i], 0, RANKS_TAG_PASSES, err)) return err->code;
    return TS_OK;
}

/* What this rank needs of rank 0's start: the options it resolved, the scene (received, or
 * loaded and checked against rank 0's job hash) and the camera. *skip: rank 0 ends the
 * frame without rendering (a failure there, or nothing to do). A scene this rank cannot
 * get goes to *why (it renders nothing and says so in its bye); MPI's failures to err. */
static int follow_start(ts_ranks *r, ts_render_options *o, ts_rank_start *start, ts_scene *scene,
                        int *skip, ts_error *why, ts_error *err)
{
    int rc = MPI_Bcast(start, (int)sizeof *start, MPI_BYTE, 0, MPI_COMM_WORLD);
    if (rc != MPI_SUCCESS) return mpi_fail(err, rc, "MPI_Bcast");
    *skip = start->status != 0;
    if (*skip) return TS_OK;
    double t0 = stats_now();
    o->spp = start->spp, o->width = start->width, o->height = start->height;
    if (start->scene_load) {
        int32_t hash = 0;
        ts_load_options lo;
        render_load_options(o, &lo);
        lo.quiet = 1;
        if (!scene_load_with(o->scene_path, &lo, scene, why) &&
            !job_hash(o, scene, &start->cam, &hash, why) && hash != start->job_hash)
            ts_error_set(why, TS_E_USAGE,
                         "%s here is not the scene rank 0 loaded (another file, or other files "
                         "it reads): give every rank the same files, or leave out --mpi-scene "
                         "load",
                         o->scene_path);
    } else {
        void *block = malloc(start->scene_bytes ? start->scene_bytes : 1);
        if (!block) return ts_error_set(err, TS_E_MEMORY, "out of memory (the scene)");
        rc = bcast_bytes(block, start->scene_bytes, err);
        if (!rc) scene_unpack(block, start->scene_bytes, scene, why);
        free(block);
        if (rc) return rc;
    }
    r->scene_seconds = stats_now() - t0;
    return TS_OK;
}

/* Waits for the levels of detail from rank 0 and gives them to the devices, if they
 * started (or tells them the lod failed). A stop signal ends the wait: *stopped. */
static int follow_lod(ts_workers *g, uint32_t patch_count, int *stopped, ts_error *err)
{
    for (;;) {
        void *data;
        int from, tag, bytes, got = recv_any(0, &from, &tag, &data, &bytes, err);
        if (got < 0) return err->code;
        if (got && tag == RANKS_TAG_LOD && (size_t)bytes >= sizeof(ranks_lod_head)) {
            ranks_lod_head head;
            memcpy(&head, data, sizeof head);
            int ok = head.ok && (size_t)bytes == sizeof head + head.patch_count &&
                     head.patch_count == patch_count;
            if (g->started)
                workers_lod_set(g, head.max_lod, ok ? (const uint8_t *)data + sizeof head : NULL);
            free(data);
            return ok ? TS_OK : ts_error_set(err, TS_E_USAGE, "rank 0 could not make the lod");
        }
        if (got) {
            free(data);
            return ts_error_set(err, TS_E_INTERNAL, "MPI: message %d before the lod", tag);
        }
        if ((*stopped = interrupt_signal() != 0)) return TS_OK;
        sleep_seconds(RANKS_POLL_SECONDS);
    }
}

/* Units that came from rank 0: given to the devices (index UINT32_MAX: none left). */
static int follow_receive(relay *q, uint32_t *requested, ts_error *err)
{
    void *data;
    int from, tag, bytes, got, rc = TS_OK;
    while (!rc && (got = recv_any(0, &from, &tag, &data, &bytes, err)) != 0) {
        if (got < 0) return err->code;
        ts_unit u;
        if (tag == RANKS_TAG_UNIT && bytes == (int)sizeof u) {
            memcpy(&u, data, sizeof u);
            *requested = u.index == UINT32_MAX ? 0 : *requested - 1;
            if (relay_put(q, &u, 0)) rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
        } else {
            rc = ts_error_set(err, TS_E_INTERNAL, "MPI: an unexpected message (tag %d)", tag);
        }
        free(data);
    }
    return rc;
}

/* The main loop of a rank other than 0 while its devices render: asks rank 0 for units
 * (one more than it has devices rendering), passes them on, sends back what they finished,
 * until every device thread has ended (rank 0 has no unit left, or every device failed:
 * then the bye gives back what this rank still held), or a stop signal. */
static int follow_units(ts_workers *g, relay *q, int *stopped, ts_error *err)
{
    uint32_t requested = 0;
    int rc = TS_OK;
    double sent_passes = 0.0;
    while (!rc && workers_running(g) > 0) {
        if ((*stopped = interrupt_signal() != 0)) break;
        rc = send_items(relay_drain(q), err);
        if (!rc && stats_now() - sent_passes >= RANKS_PASSES_SECONDS)
            rc = send_passes(q, err), sent_passes = stats_now();
        pthread_mutex_lock(&q->lock);
        uint32_t queued = q->queued, no_more = (uint32_t)q->no_more;
        pthread_mutex_unlock(&q->lock);
        uint32_t alive = workers_alive(g);
        if (!rc && !no_more && alive && queued + requested < alive + 1) {
            uint32_t n[2] = {alive + 1 - queued - requested, alive};
            rc = send_bytes(n, sizeof n, 0, RANKS_TAG_REQUEST, err);
            requested += n[0];
        }
        if (!rc) rc = follow_receive(q, &requested, err);
        sleep_seconds(RANKS_POLL_SECONDS);
    }
    return rc;
}

/* This rank's goodbye: its stats, or why it rendered nothing. */
static int follow_bye(ts_ranks *r, ts_workers *g, const ts_error *why, ts_error *err)
{
    ts_stats s;
    memset(&s, 0, sizeof s);
    int rc = g->w ? workers_stats(g, &s, err) : TS_OK;
    ranks_bye_head head;
    memset(&head, 0, sizeof head);
    head.rank.rank = r->rank;
    snprintf(head.rank.host, sizeof head.rank.host, "%s", r->host);
    head.rank.seconds = stats_now() - r->t0;
    head.rank.scene_seconds = r->scene_seconds;
    head.rank.kernel_seconds = stats_kernel_seconds(&s);
    head.rank.host_serial_seconds = stats_host_serial(head.rank.seconds, head.rank.kernel_seconds);
    for (uint32_t i = 0; i < s.device_count; ++i) {
        head.rank.devices += !s.devices[i].failed;
        head.rank.units += s.devices[i].units;
        head.rank.samples += s.devices[i].samples;
    }
    memcpy(head.stage_seconds, s.stage_seconds, sizeof head.stage_seconds);
    memcpy(head.counters, s.counters, sizeof head.counters);
    memcpy(head.lod_histogram, s.lod_histogram, sizeof head.lod_histogram);
    memcpy(head.frame_lod_histogram, s.frame_lod_histogram, sizeof head.frame_lod_histogram);
    head.kernel_build_seconds = s.kernel_build_seconds;
    head.device_count = s.device_count;
    head.failed = why && why->code;
    if (head.failed) snprintf(head.error, sizeof head.error, "%.1000s", why->msg);
    if (head.failed) snprintf(head.rank.error, sizeof head.rank.error, "%.500s", why->msg);
    size_t bytes = sizeof head + s.device_count * sizeof(ts_device_stats);
    char *msg = malloc(bytes);
    if (!rc && !msg) rc = ts_error_set(err, TS_E_MEMORY, "out of memory");
    if (!rc) {
        memcpy(msg, &head, sizeof head);
        if (s.device_count) memcpy(msg + sizeof head, s.devices, bytes - sizeof head);
        rc = send_bytes(msg, bytes, 0, RANKS_TAG_BYE, err);
    }
    free(msg);
    stats_free(&s);
    return rc;
}

/* This rank's devices: those --device names here, opened and started on the relay. Why
 * none could be is in *why. */
static void follow_devices(ts_workers *g, const ts_frame *f, relay *q, ts_error *why)
{
    ts_device_info *list = NULL;
    int indices[TS_DEVICE_MAX], count = 0, n = dev_list(&list, why);
    free(list);
    if (n == 0) ts_error_set(why, TS_E_DEVICE, "no OpenCL device found");
    if (n > 0 && !dev_select(&f->opt->cl, n, indices, &count, why))
        workers_streams(indices, &count, f->opt->streams);
    if (n > 0 && count > 0 && !why->code && !workers_open(g, f, indices, count, why))
        workers_start(g,
                      (ts_unit_source){q, relay_take, relay_done, relay_give_back, relay_closed,
                                       NULL, NULL, relay_unit_passes},
                      0, why);
}

/* After a stop signal: stays up to 10 s before ending. When a rank dies, mpirun sends
 * SIGTERM to every other rank and SIGKILL a second later (odls_base_sigkill_timeout) — or as
 * soon as any of them exits, which cuts the second short. Rank 0 needs it to write the
 * finished samples, so the others wait for their SIGKILL instead of exiting. */
static void linger(void)
{
    struct timespec left = {10, 0};
    while (nanosleep(&left, &left) != 0 && (left.tv_sec > 0 || left.tv_nsec > 0))
        ;
}

int ranks_follow(ts_ranks *r, ts_render_options *o, ts_error *err)
{
    ts_rank_start start;
    ts_scene scene;
    memset(&scene, 0, sizeof scene);
    ts_error why = {0};
    int skip = 0, stopped = 0;
    o->quiet = 1; /* rank 0 speaks for every rank */
    interrupt_install();
    int rc = follow_start(r, o, &start, &scene, &skip, &why, err);
    if (rc || skip) {
        ts_error_clear(&why);
        scene_free(&scene);
        interrupt_restore();
        return rc;
    }
    ts_frame f = {.opt = o,
                  .scene = &scene,
                  .cam = start.cam,
                  .pixel_count = (uint32_t)((uint64_t)start.width * (uint64_t)start.height),
                  .unit_samples = start.unit_samples,
                  .share_samples = start.share_samples,
                  .rank = r->rank,
                  .budget_share = (uint32_t)r->node_ranks};
    relay q = {.out_tail = &q.out};
    pthread_mutex_init(&q.lock, NULL);
    pthread_cond_init(&q.changed, NULL);
    ts_workers g;
    memset(&g, 0, sizeof g);
    if (!why.code) follow_devices(&g, &f, &q, &why);
    rc = follow_lod(&g, scene.patch_count, &stopped, err);
    if (!rc && !stopped && g.started) rc = follow_units(&g, &q, &stopped, err);
    relay_put(&q, NULL, 1); /* the devices stop at their next wave */
    if (g.started && workers_lod_state(&g) == 0) workers_lod_set(&g, 0, NULL);
    workers_join(&g);
    if (!rc && !stopped) rc = send_items(relay_drain(&q), err);
    if (!rc && !stopped && !why.code && g.started && !workers_alive(&g))
        ts_error_set(&why, TS_E_DEVICE, "every device failed"); /* its warning names them */
    if (!rc && !stopped) rc = follow_bye(r, &g, why.code ? &why : NULL, err);
    if (!rc && stopped) rc = ts_error_set(err, TS_E_USAGE, "stopped by a signal");
    if (stopped) linger();
    ts_error_clear(&why);
    workers_close(&g);
    relay_item *left = relay_drain(&q); /* not sent: stopped, or MPI failed */
    while (left) {
        relay_item *next = left->next;
        unit_result_free(&left->result);
        free(left);
        left = next;
    }
    free(q.queue);
    pthread_mutex_destroy(&q.lock);
    pthread_cond_destroy(&q.changed);
    scene_free(&scene);
    interrupt_restore();
    return rc;
}
