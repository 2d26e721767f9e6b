/* patch_share.h — diced and built patches shared between the devices of one process (issue
 * 17; docs/rendering.md "Shared patches").
 *
 * Each device keeps its own arenas (patch_cache.h). Without sharing, two devices that meet
 * the same patch both dice and build it. The store holds, in host memory, one copy of each
 * patch's blocks as a device built them: its (2^m+1)^2 vertices and its quadtree_group_count
 * (m) sibling groups, twice for a moving patch (the blocks do not depend on where they lie
 * in an arena). A device whose cache misses a patch the store holds writes the blocks into
 * its arenas instead of dicing; only devices that compute alike (the same driver and kind of
 * device) share a store, so the bits are those the device would have made.
 *
 * Claims: the first device to miss a patch claims it (patch_share_take returns
 * TS_TAKE_MINE with room reserved), dices and builds it, reads the blocks back and
 * publishes them; a device that misses a claimed patch waits for it (patch_share_wait), or,
 * when the patch is small and not ready (patch_share_poll), dices it itself (trace.c
 * share_await).
 * A device claims a batch's misses in rounds of 1/devices of their bytes (host/pipeline/
 * trace.c share_round), so that devices that meet the same patches at once, as the first
 * units of a frame do, split the dicing instead of one waiting for the other.
 * No deadlock: a device claims only inside the batch it is making and publishes (or
 * abandons) every claim of that batch before it waits for anyone else's, so a claim waited
 * for is always being built by a device that waits for nothing meanwhile. A claim abandoned
 * (its device failed) wakes its waiters, who dice the patch themselves.
 *
 * Memory: at most `bound` bytes of blocks (patch_share_allow raises it; app/workers.c sets
 * it to the largest arenas of the sharing devices). Published blocks stay until
 * patch_share_free: a writer may read them from another thread at any time. When the bound
 * is reached, a patch not yet held is diced by each device that needs it (TS_SHARE_LOCAL),
 * as without sharing. Thread-safe: every call takes the store's lock. */
#ifndef TS_PATCH_SHARE_H
#define TS_PATCH_SHARE_H

#include "base/error.h"

#include <pthread.h>
#include <stdint.h>

/* One patch's slot in the store. */
typedef struct ts_share_entry {
    void *data;     /* the vertex block, then the group block (bytes), or NULL */
    uint64_t bytes; /* of data */
    uint8_t state;  /* ts_share_state */
    uint8_t lod;    /* m of the blocks */
    uint8_t times;  /* 1, or 2 for a moving patch */
    uint8_t pad;
    uint32_t owner; /* the claiming device's slot (while TS_SHARE_CLAIMED) */
} ts_share_entry;

typedef enum ts_share_state {
    TS_SHARE_ABSENT = 0,
    TS_SHARE_CLAIMED, /* a device is dicing and building it */
    TS_SHARE_READY,   /* published: data holds the blocks */
} ts_share_state;

typedef struct ts_patch_share {
    pthread_mutex_t lock;
    pthread_cond_t changed; /* a claim was published or abandoned */
    ts_share_entry *entry;  /* one per patch */
    uint32_t patch_count;
    uint32_t devices; /* that share it: a device claims 1/devices of what it needs at a time */
    int in_place;     /* patch_share_in_place: the blocks lie in arenas the devices share */
    uint64_t bound;   /* bytes the blocks may take */
    uint64_t used;    /* bytes of blocks reserved or published */
    /* Bookkeeping, for tests and notes. */
    uint64_t published, abandoned, refused;
} ts_patch_share;

/* An empty store for patch_count patches shared by `devices` devices, bound 0 (nothing is
 * stored until patch_share_allow). */
int patch_share_create(ts_patch_share *s, uint32_t patch_count, uint32_t devices, ts_error *err);
/* Frees every block; no thread may use the store any more. */
void patch_share_free(ts_patch_share *s);
/* The devices' arenas are one host allocation with a fixed place for every patch
 * (pipeline_place_arenas): the store then holds no blocks, only who dices what. A claim
 * reserves nothing (never TS_TAKE_LOCAL for want of room), and a published patch already
 * lies where every device reads it: TS_TAKE_READY and patch_share_wait give no data. */
void patch_share_in_place(ts_patch_share *s);
/* Raises the bound to at least `bytes` (never lowers it). */
void patch_share_allow(ts_patch_share *s, uint64_t bytes);

/* What patch_share_take found for a patch a device misses. */
typedef enum ts_share_take {
    TS_TAKE_READY, /* published: *data holds the blocks (valid until patch_share_free; NULL
                      in place, where the blocks already are) */
    TS_TAKE_WAIT,  /* another device claimed it: patch_share_wait for it, after publishing
                      this batch's own claims */
    TS_TAKE_MINE,  /* claimed by `owner`: *data has room for `bytes`; dice and build it, copy
                      the blocks there and patch_share_publish (or patch_share_abandon); in
                      place, *data is NULL and the dicing itself is the publishing's content */
    TS_TAKE_LOCAL, /* no room in the bound, or held at another m: dice it, publish nothing */
} ts_share_take;

/* Looks patch p (at m, `times` samples, `bytes` of blocks) up for device `owner`, claiming
 * it when nobody holds it and the bound has room. */
ts_share_take patch_share_take(ts_patch_share *s, uint32_t p, uint32_t m, uint32_t times,
                               uint64_t bytes, uint32_t owner, void **data);
/* The owner's claim of p holds its blocks: waiters take them. */
void patch_share_publish(ts_patch_share *s, uint32_t p);
/* The owner's claim of p is given up (its device failed): the room is freed and waiters dice
 * it themselves. */
void patch_share_abandon(ts_patch_share *s, uint32_t p);
/* Waits while p is claimed: 1 published (*data holds the blocks), 0 abandoned. */
int patch_share_wait(ts_patch_share *s, uint32_t p, const void **data);

/* The bytes of one patch's blocks at m with `times` samples (vertices and sibling groups). */
uint64_t patch_share_bytes(uint32_t m, uint32_t times);

/* Without waiting: 1 and *data when p is published, -1 while another device still builds
 * it, 0 when it is absent (abandoned). */
int patch_share_poll(ts_patch_share *s, uint32_t p, const void **data);

#endif
