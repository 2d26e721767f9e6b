/* qbvh.h — the top-level hierarchy (Hanika §3.1): a 4-wide BVH (Dammertz et al. 2008) whose
 * leaves are the conservative boxes of single patches. Built on the host by binned SAH
 * (Wald 2007) into a binary tree, then collapsed two levels at a time into ts_qbvh_node,
 * keeping each binary split's axis so kernels can order children by the ray direction. */
#ifndef TS_QBVH_H
#define TS_QBVH_H

#include "base/error.h"
#include "lib/shared_types.h"

#include <stdint.h>

typedef struct ts_qbvh {
    ts_qbvh_node *nodes; /* nodes[0] is the root */
    uint32_t node_count;
    uint32_t depth; /* longest root-to-leaf path in nodes */
} ts_qbvh;

/* Builds over `count` boxes (leaf i = patch i). count may be 0 (a root with no children).
 * Time O(n log n), memory ~ 130 bytes per box. The binary tree's large subtrees are built on up
 * to `threads` threads (0: every online CPU): the same nodes whatever the threads. */
int qbvh_build(ts_qbvh *q, const ts_box *boxes, uint32_t count, uint32_t threads, ts_error *err);
void qbvh_free(ts_qbvh *q);

#endif
