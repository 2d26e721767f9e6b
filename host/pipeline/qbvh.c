#include "pipeline/qbvh.h"
#include "base/memory.h"

#include <float.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define SAH_BINS 16

/* A node of the binary BVH, built depth first: an inner node's first child is the node after
 * it, so only the second is kept. A leaf holds one patch. 32 bytes (two a patch, at the
 * build's memory peak with the 4-wide nodes). */
typedef struct bnode {
    ts_box box;
    int32_t right; /* the second child (binary node index), -1 for a leaf */
    uint32_t item; /* a leaf: its patch's place in the index array; an inner node: its axis */
} bnode;

typedef struct builder {
    const ts_box *boxes;
    uint32_t *index;
    float *centroid; /* 3 per box */
    bnode *nodes;
} builder;

static ts_box box_empty(void)
{
    return (ts_box){FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX};
}

/* b grown to hold o (selects rather than branches: scattered boxes mispredict). */
static void box_grow(ts_box *b, const ts_box *o)
{
    b->lo_x = o->lo_x < b->lo_x ? o->lo_x : b->lo_x;
    b->lo_y = o->lo_y < b->lo_y ? o->lo_y : b->lo_y;
    b->lo_z = o->lo_z < b->lo_z ? o->lo_z : b->lo_z;
    b->hi_x = o->hi_x > b->hi_x ? o->hi_x : b->hi_x;
    b->hi_y = o->hi_y > b->hi_y ? o->hi_y : b->hi_y;
    b->hi_z = o->hi_z > b->hi_z ? o->hi_z : b->hi_z;
}

static double box_area(const ts_box *b)
{
    if (b->lo_x > b->hi_x) return 0.0;
    double dx = b->hi_x - b->lo_x, dy = b->hi_y - b->lo_y, dz = b->hi_z - b->lo_z;
    return 2.0 * (dx * dy + dy * dz + dz * dx);
}

/* Chooses the binned-SAH split of [first, first+count). Returns 0 if no split beats the
 * others (all centroids equal): the caller then splits at the median index. */
static int sah_split(const builder *b, uint32_t first, uint32_t count, uint32_t *axis_out,
                     float *pos_out)
{
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (uint32_t i = first; i < first + count; ++i)
        for (int a = 0; a < 3; ++a) {
            float c = b->centroid[3 * b->index[i] + a];
            if (c < lo[a]) lo[a] = c;
            if (c > hi[a]) hi[a] = c;
        }
    double best = DBL_MAX;
    int found = 0;
    /* The bins of all three axes in one pass over the boxes. */
    ts_box bins[3][SAH_BINS];
    uint32_t bin_counts[3][SAH_BINS] = {{0}};
    float scales[3];
    for (uint32_t a = 0; a < 3; ++a) {
        scales[a] = hi[a] > lo[a] ? SAH_BINS / (hi[a] - lo[a]) : 0.0f;
        for (int k = 0; k < SAH_BINS; ++k)
            bins[a][k] = box_empty();
    }
    for (uint32_t i = first; i < first + count; ++i) {
        uint32_t p = b->index[i];
        const float *c = &b->centroid[3 * p];
        for (uint32_t a = 0; a < 3; ++a) {
            if (!(hi[a] > lo[a])) continue;
            int k = (int)((c[a] - lo[a]) * scales[a]);
            k = k < 0 ? 0 : k >= SAH_BINS ? SAH_BINS - 1 : k;
            bin_counts[a][k]++;
            box_grow(&bins[a][k], &b->boxes[p]);
        }
    }
    for (uint32_t a = 0; a < 3; ++a) {
        if (!(hi[a] > lo[a])) continue;
        const ts_box *bin_box = bins[a];
        const uint32_t *bin_n = bin_counts[a];
        float scale = scales[a];
        double right_cost[SAH_BINS];
        ts_box acc = box_empty();
        uint32_t n = 0;
        for (int k = SAH_BINS - 1; k > 0; --k) {
            box_grow(&acc, &bin_box[k]);
            n += bin_n[k];
            right_cost[k] = n * box_area(&acc);
        }
        acc = box_empty();
        n = 0;
        for (int k = 0; k < SAH_BINS - 1; ++k) {
            box_grow(&acc, &bin_box[k]);
            n += bin_n[k];
            double cost = n * box_area(&acc) + right_cost[k + 1];
            if (n > 0 && n < count && cost < best) {
                best = cost;
                *axis_out = a;
                *pos_out = lo[a] + (float)(k + 1) / scale;
                found = 1;
            }
        }
    }
    return found;
}

/* Subtrees over at least this many boxes may be built on a thread of their own. */
#define QBVH_THREAD_MIN 16384u

static void build_binary(builder *b, int32_t id, uint32_t first, uint32_t count, uint32_t spawn);

/* One subtree for a thread of its own (build_binary). */
typedef struct subtree {
    builder *b;
    int32_t id;
    uint32_t first, count, spawn;
} subtree;

static void *subtree_build(void *arg)
{
    const subtree *t = arg;
    build_binary(t->b, t->id, t->first, t->count, t->spawn);
    return NULL;
}

/* Builds node id over the boxes index[first .. first + count) and its subtree, depth first:
 * a subtree over n boxes is 2n - 1 nodes (a leaf a box), so the left child is id + 1 and the
 * right one id + 2 n_left, whatever order the subtrees are built in. For `spawn` levels the
 * right subtree is built on a thread of its own (when it is large and a thread can be had):
 * the same nodes as one thread builds, the halves touching disjoint ranges of index and
 * nodes. */
static void build_binary(builder *b, int32_t id, uint32_t first, uint32_t count, uint32_t spawn)
{
    bnode *nd = &b->nodes[id];
    nd->box = box_empty();
    for (uint32_t i = first; i < first + count; ++i)
        box_grow(&nd->box, &b->boxes[b->index[i]]);
    nd->right = -1;
    nd->item = first;
    if (count == 1) return;
    uint32_t axis = 0, mid = first + count / 2;
    float pos;
    if (sah_split(b, first, count, &axis, &pos)) {
        /* Partition: centroids below pos go left (the lower side along axis). */
        uint32_t i = first, j = first + count;
        while (i < j) {
            if (b->centroid[3 * b->index[i] + axis] < pos)
                ++i;
            else {
                uint32_t t = b->index[i];
                b->index[i] = b->index[--j];
                b->index[j] = t;
            }
        }
        if (i > first && i < first + count) mid = i;
    }
    int32_t right = id + 2 * (int32_t)(mid - first);
    nd->right = right;
    nd->item = axis;
    uint32_t deeper = spawn ? spawn - 1u : 0u;
    subtree t = {b, right, mid, first + count - mid, deeper};
    pthread_t thread;
    int threaded = spawn && t.count >= QBVH_THREAD_MIN &&
                   pthread_create(&thread, NULL, subtree_build, &t) == 0;
    build_binary(b, id + 1, first, mid - first, deeper);
    if (threaded)
        pthread_join(thread, NULL);
    else
        subtree_build(&t);
}

typedef struct collapser {
    const builder *b;
    ts_qbvh_node *out;
    uint32_t count;
    uint32_t depth;
} collapser;

static void slot_set(collapser *c, uint32_t q, int slot, int32_t bn, uint32_t level);

/* Emits the 4-wide node for binary inner node bn; returns its index. */
static uint32_t collapse(collapser *c, int32_t bn, int32_t parent, uint32_t parent_slot,
                         uint32_t level)
{
    uint32_t q = c->count++;
    if (level + 1 > c->depth) c->depth = level + 1;
    ts_qbvh_node *n = &c->out[q];
    memset(n, 0, sizeof *n);
    n->parent = parent;
    n->parent_slot = parent_slot;
    for (int s = 0; s < 4; ++s) {
        n->child[s] = TS_CHILD_EMPTY;
        n->lo_x[s] = n->lo_y[s] = n->lo_z[s] = FLT_MAX;
        n->hi_x[s] = n->hi_y[s] = n->hi_z[s] = -FLT_MAX;
    }
    const bnode *bnd = &c->b->nodes[bn];
    if (bnd->right < 0) { /* a single leaf at the root */
        slot_set(c, q, 0, bn, level);
        return q;
    }
    uint32_t axes = bnd->item;
    const int32_t halves[2] = {bn + 1, bnd->right};
    for (int h = 0; h < 2; ++h) {
        const bnode *half = &c->b->nodes[halves[h]];
        if (half->right < 0) {
            slot_set(c, q, 2 * h, halves[h], level);
        } else {
            axes |= half->item << (2 + 2 * h);
            slot_set(c, q, 2 * h, halves[h] + 1, level);
            slot_set(c, q, 2 * h + 1, half->right, level);
        }
    }
    c->out[q].axes = axes;
    return q;
}

static void slot_set(collapser *c, uint32_t q, int slot, int32_t bn, uint32_t level)
{
    const bnode *b = &c->b->nodes[bn];
    ts_qbvh_node *n = &c->out[q];
    n->lo_x[slot] = b->box.lo_x;
    n->lo_y[slot] = b->box.lo_y;
    n->lo_z[slot] = b->box.lo_z;
    n->hi_x[slot] = b->box.hi_x;
    n->hi_y[slot] = b->box.hi_y;
    n->hi_z[slot] = b->box.hi_z;
    if (b->right < 0) {
        n->child[slot] = ~(int32_t)c->b->index[b->item];
    } else {
        uint32_t child = collapse(c, bn, (int32_t)q, (uint32_t)slot, level + 1);
        c->out[q].child[slot] = (int32_t)child;
    }
}

int qbvh_build(ts_qbvh *q, const ts_box *boxes, uint32_t count, uint32_t threads, ts_error *err)
{
    if (threads == 0) {
        long cpus = sysconf(_SC_NPROCESSORS_ONLN);
        threads = cpus > 0 ? (uint32_t)cpus : 1u;
    }
    uint32_t spawn = 0; /* levels whose right subtrees get threads: 2^spawn >= threads */
    while ((1u << spawn) < threads && spawn < 8u)
        ++spawn;
    memset(q, 0, sizeof *q);
    builder b = {.boxes = boxes};
    size_t bn_cap = count ? 2 * (size_t)count - 1 : 1;
    b.index = malloc((count ? count : 1) * sizeof *b.index);
    b.centroid = malloc((count ? count : 1) * 3 * sizeof *b.centroid);
    b.nodes = malloc(bn_cap * sizeof *b.nodes);
    /* 4-wide nodes <= binary inner nodes; page-aligned, so that a device sharing host memory
     * may read them in place (pipeline.c array_in_place) */
    q->nodes = ts_page_alloc(bn_cap * sizeof *q->nodes);
    if (!b.index || !b.centroid || !b.nodes || !q->nodes) {
        free(b.index), free(b.centroid), free(b.nodes), qbvh_free(q);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (top-level BVH, %u patches)", count);
    }
    for (uint32_t i = 0; i < count; ++i) {
        b.index[i] = i;
        b.centroid[3 * i + 0] = 0.5f * (boxes[i].lo_x + boxes[i].hi_x);
        b.centroid[3 * i + 1] = 0.5f * (boxes[i].lo_y + boxes[i].hi_y);
        b.centroid[3 * i + 2] = 0.5f * (boxes[i].lo_z + boxes[i].hi_z);
    }
    collapser c = {.b = &b, .out = q->nodes};
    if (count == 0) {
        bnode empty = {.box = box_empty(), .right = -1, .item = 0};
        b.index[0] = 0;
        b.nodes[0] = empty;
        collapse(&c, 0, -1, 0, 0);
        c.out[0].child[0] = TS_CHILD_EMPTY; /* no patch at all */
    } else {
        build_binary(&b, 0, 0, count, spawn);
        /* The centroids served the splits only: gone before the 4-wide nodes are written,
         * where the build's memory peaks (12 bytes a patch). */
        free(b.centroid), b.centroid = NULL;
        collapse(&c, 0, -1, 0, 0);
    }
    q->node_count = c.count;
    q->depth = c.depth;
    free(b.index);
    free(b.centroid);
    free(b.nodes);
    return TS_OK;
}

void qbvh_free(ts_qbvh *q)
{
    free(q->nodes);
    memset(q, 0, sizeof *q);
}
