/* patch_share.c — the store of built patches shared between devices (patch_share.h). */
#include "pipeline/patch_share.h"
#include "pipeline/patch_cache.h"

#include "lib/shared_types.h"

#include <stdlib.h>
#include <string.h>

uint64_t patch_share_bytes(uint32_t m, uint32_t times)
{
    return (uint64_t)patch_cache_vert_count(m, times) * sizeof(ts_vec4) +
           (uint64_t)patch_cache_group_count(m, times) * TS_GROUP_BYTES;
}

int patch_share_create(ts_patch_share *s, uint32_t patch_count, uint32_t devices, ts_error *err)
{
    memset(s, 0, sizeof *s);
    s->entry = calloc(patch_count ? patch_count : 1, sizeof *s->entry);
    if (!s->entry)
        return ts_error_set(err, TS_E_MEMORY, "out of memory (patch store of %u patches)",
                            patch_count);
    s->patch_count = patch_count;
    s->devices = devices ? devices : 1;
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->changed, NULL);
    return TS_OK;
}

void patch_share_free(ts_patch_share *s)
{
    if (!s->entry) return;
    for (uint32_t p = 0; p < s->patch_count; ++p)
        free(s->entry[p].data);
    free(s->entry);
    pthread_mutex_destroy(&s->lock);
    pthread_cond_destroy(&s->changed);
    memset(s, 0, sizeof *s);
}

void patch_share_allow(ts_patch_share *s, uint64_t bytes)
{
    pthread_mutex_lock(&s->lock);
    if (bytes > s->bound) s->bound = bytes;
    pthread_mutex_unlock(&s->lock);
}

void patch_share_in_place(ts_patch_share *s)
{
    pthread_mutex_lock(&s->lock);
    s->in_place = 1;
    pthread_mutex_unlock(&s->lock);
}

ts_share_take patch_share_take(ts_patch_share *s, uint32_t p, uint32_t m, uint32_t times,
                               uint64_t bytes, uint32_t owner, void **data)
{
    ts_share_take r = TS_TAKE_LOCAL;
    *data = NULL;
    pthread_mutex_lock(&s->lock);
    ts_share_entry *e = &s->entry[p];
    if (e->state != TS_SHARE_ABSENT && (e->lod != m || e->times != times)) {
        r = TS_TAKE_LOCAL; /* held at another m: the frame's levels are fixed, so not met */
    } else if (e->state == TS_SHARE_READY) {
        *data = e->data;
        r = TS_TAKE_READY;
    } else if (e->state == TS_SHARE_CLAIMED) {
        r = e->owner == owner ? TS_TAKE_LOCAL : TS_TAKE_WAIT; /* owner: a second segment */
    } else if (s->in_place) {
        *e = (ts_share_entry){NULL, 0, TS_SHARE_CLAIMED, (uint8_t)m, (uint8_t)times, 0, owner};
        r = TS_TAKE_MINE;
    } else if (bytes <= s->bound - (s->used < s->bound ? s->used : s->bound) &&
               (e->data = malloc(bytes)) != NULL) {
        *e = (ts_share_entry){e->data, bytes, TS_SHARE_CLAIMED, (uint8_t)m, (uint8_t)times,
                              0,       owner};
        s->used += bytes;
        *data = e->data;
        r = TS_TAKE_MINE;
    } else {
        ++s->refused;
    }
    pthread_mutex_unlock(&s->lock);
    return r;
}

void patch_share_publish(ts_patch_share *s, uint32_t p)
{
    pthread_mutex_lock(&s->lock);
    if (s->entry[p].state == TS_SHARE_CLAIMED) {
        s->entry[p].state = TS_SHARE_READY;
        ++s->published;
    }
    pthread_cond_broadcast(&s->changed);
    pthread_mutex_unlock(&s->lock);
}

void patch_share_abandon(ts_patch_share *s, uint32_t p)
{
    pthread_mutex_lock(&s->lock);
    ts_share_entry *e = &s->entry[p];
    if (e->state == TS_SHARE_CLAIMED) {
        free(e->data);
        s->used -= e->bytes;
        memset(e, 0, sizeof *e);
        ++s->abandoned;
    }
    pthread_cond_broadcast(&s->changed);
    pthread_mutex_unlock(&s->lock);
}

int patch_share_wait(ts_patch_share *s, uint32_t p, const void **data)
{
    pthread_mutex_lock(&s->lock);
    ts_share_entry *e = &s->entry[p];
    while (e->state == TS_SHARE_CLAIMED)
        pthread_cond_wait(&s->changed, &s->lock);
    int ready = e->state == TS_SHARE_READY;
    *data = ready ? e->data : NULL;
    pthread_mutex_unlock(&s->lock);
    return ready;
}

int patch_share_poll(ts_patch_share *s, uint32_t p, const void **data)
{
    pthread_mutex_lock(&s->lock);
    ts_share_entry *e = &s->entry[p];
    int state = e->state == TS_SHARE_CLAIMED ? -1 : e->state == TS_SHARE_READY ? 1 : 0;
    *data = state > 0 ? e->data : NULL;
    pthread_mutex_unlock(&s->lock);
    return state;
}
