/* test_qbvh.c — the top-level BVH's build on the host (host/pipeline/qbvh.c; no device):
 * built on several threads it is the same nodes, byte for byte, as on one, and every patch is
 * a leaf exactly once, under a parent whose box holds its box. */
#include "test_support.h"
#include "pipeline/qbvh.h"

#include <stdlib.h>
#include <string.h>

/* n boxes scattered in a cube of side 100 (sizes up to 2), or all the same box (every
 * centroid equal: the build splits at the median index). */
static ts_box *make_boxes(uint32_t n, int same)
{
    ts_box *b = malloc(n * sizeof *b);
    assert_non_null(b);
    uint64_t s = 0x9e3779b97f4a7c15ull;
    for (uint32_t i = 0; i < n; ++i) {
        float v[6];
        for (int k = 0; k < 6; ++k) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            v[k] = (float)(s >> 40) / (float)(1u << 24);
        }
        if (same) v[0] = v[1] = v[2] = 0.5f, v[3] = v[4] = v[5] = 0.25f;
        b[i] = (ts_box){100 * v[0],
                        100 * v[1],
                        100 * v[2],
                        100 * v[0] + 2 * v[3],
                        100 * v[1] + 2 * v[4],
                        100 * v[2] + 2 * v[5]};
    }
    return b;
}

static int box_holds(const ts_qbvh_node *q, int c, ts_box b)
{
    return q->lo_x[c] <= b.lo_x && q->lo_y[c] <= b.lo_y && q->lo_z[c] <= b.lo_z &&
           q->hi_x[c] >= b.hi_x && q->hi_y[c] >= b.hi_y && q->hi_z[c] >= b.hi_z;
}

/* Every patch a leaf once, its slot's box holding its box; every inner child names its
 * parent and slot back. */
static void check_tree(const ts_qbvh *q, const ts_box *boxes, uint32_t n)
{
    uint8_t *seen = calloc(n, 1);
    assert_non_null(seen);
    for (uint32_t i = 0; i < q->node_count; ++i)
        for (int c = 0; c < 4; ++c) {
            int32_t child = q->nodes[i].child[c];
            if (child == TS_CHILD_EMPTY) continue;
            if (child >= 0) {
                assert_true((uint32_t)child < q->node_count);
                assert_int_equal(q->nodes[child].parent, (int32_t)i);
                assert_int_equal(q->nodes[child].parent_slot, (uint32_t)c);
                continue;
            }
            uint32_t patch = (uint32_t)~child;
            assert_true(patch < n);
            if (seen[patch]++) fail_msg("patch %u is a leaf twice", patch);
            assert_true(box_holds(&q->nodes[i], c, boxes[patch]));
        }
    for (uint32_t i = 0; i < n; ++i)
        if (!seen[i]) fail_msg("patch %u is no leaf", i);
    free(seen);
}

static void same_on_threads(uint32_t n, int same)
{
    ts_box *boxes = make_boxes(n, same);
    ts_error err = {0};
    ts_qbvh one, many;
    if (qbvh_build(&one, boxes, n, 1, &err) || qbvh_build(&many, boxes, n, 8, &err))
        fail_msg("%s", err.msg);
    assert_int_equal(one.node_count, many.node_count);
    assert_int_equal(one.depth, many.depth);
    assert_memory_equal(one.nodes, many.nodes, one.node_count * sizeof *one.nodes);
    check_tree(&many, boxes, n);
    qbvh_free(&one);
    qbvh_free(&many);
    free(boxes);
}

/* 200 K scattered boxes: subtrees of over 16 K boxes are built on threads of their own three
 * levels down. */
static void test_threads_build_the_same_nodes(void **state)
{
    (void)state;
    same_on_threads(200000, 0);
}

/* Equal centroids: no SAH split, the median index, on threads too. */
static void test_equal_centroids_split_at_the_median(void **state)
{
    (void)state;
    same_on_threads(50000, 1);
}

static void test_small_and_empty(void **state)
{
    (void)state;
    same_on_threads(1, 0);
    same_on_threads(5, 0);
    ts_qbvh q;
    ts_error err = {0};
    if (qbvh_build(&q, NULL, 0, 0, &err)) fail_msg("%s", err.msg);
    assert_int_equal(q.node_count, 1);
    for (int c = 0; c < 4; ++c)
        assert_int_equal(q.nodes[0].child[c], TS_CHILD_EMPTY);
    qbvh_free(&q);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_threads_build_the_same_nodes),
        cmocka_unit_test(test_equal_centroids_split_at_the_median),
        cmocka_unit_test(test_small_and_empty),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
