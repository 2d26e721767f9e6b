/* test_trim.c — trimmed NURBS (RiTrimCurve; host/scene/trim.c, rib_trim.c, lib/trim.h) on the
 * host: a rational quadratic circle's polyline lies on the circle and closes; bad curves are
 * refused with what is wrong; a piece is kept, dropped or given the segments that cross it as
 * its square and the curve say; two loops cut a hole (even-odd); TrimCurve trims the NuPatch
 * requests after it until its attribute block ends, dropping the pieces it removes whole, and
 * its argument errors name file:line:col; the host build reference gives exactly the
 * micro-quads whose centres the trim removes empty boxes, about the circle's area; a
 * packed scene keeps its trims; and instances share their master's dicing only under the same
 * trim. Host only (the kernels against the reference:
 * tests/test_bottom_level.c; renders: tests/test_trim_render.c). */
#include "test_support.h"
#include "lib/quadtree.h"
#include "lib/trim.h"
#include "ref/dice_build_ref.h"
#include "scene/scene.h"
#include "scene/scene_pack.h"
#include "scene/trim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The rational quadratic circle of radius r about (cx, cy), four quarter arcs (9 homogeneous
 * points, knots 0 0 0 1/4 1/4 1/2 1/2 3/4 3/4 1 1 1), as TrimCurve arrays, and as RIB text. */
static const double circle_knot[12] = {0, 0, 0, .25, .25, .5, .5, .75, .75, 1, 1, 1};
static void circle(double cx, double cy, double r, double u[9], double v[9], double w[9])
{
    static const double x[9] = {1, 1, 0, -1, -1, -1, 0, 1, 1},
                        y[9] = {0, 1, 1, 1, 0, -1, -1, -1, 0};
    for (int k = 0; k < 9; k++) {
        w[k] = k % 2 ? sqrt(0.5) : 1.0;
        u[k] = (cx + r * x[k]) * w[k], v[k] = (cy + r * y[k]) * w[k];
    }
}

static void circle_rib(char *out, size_t cap, double cx, double cy, double r)
{
    double u[9], v[9], w[9];
    circle(cx, cy, r, u, v, w);
    int n =
        snprintf(out, cap, "TrimCurve [1] [3] [0 0 0 .25 .25 .5 .5 .75 .75 1 1 1] [0] [1] [9] [");
    for (int a = 0; a < 3; a++) {
        const double *x = a == 0 ? u : a == 1 ? v : w;
        for (int k = 0; k < 9; k++)
            n += snprintf(out + n, cap - (size_t)n, "%.17g ", x[k]);
        n += snprintf(out + n, cap - (size_t)n, a < 2 ? "] [" : "]\n");
    }
}

static void test_circle_polyline(void **state)
{
    (void)state;
    double u[9], v[9], w[9];
    circle(0.5, 0.5, 0.3, u, v, w);
    const double nc = 1, order = 3, n = 9;
    const double mn = 0, mx = 1;
    trim_curves c = {1, &nc, &order, &n, circle_knot, &mn, &mx, u, v, w};
    trim_set t;
    char why[256];
    assert_int_equal(trim_make(&c, &t, why, sizeof why), TS_OK);
    assert_int_equal(t.count, 4 * TRIM_SPAN_STEPS); /* four arcs, joined and closed exactly */
    for (uint32_t k = 0; k < t.count; k++) {
        const double *s = t.seg[k];
        test_assert_near(hypot(s[0] - 0.5, s[1] - 0.5), 0.3, 1e-12); /* on the circle */
        const double *nx = t.seg[(k + 1) % t.count];
        assert_true(s[2] == nx[0] && s[3] == nx[1]); /* head to tail, the last to the first */
        /* counter-clockwise: the inside to the left */
        assert_true((s[0] - 0.5) * (s[3] - 0.5) - (s[1] - 0.5) * (s[2] - 0.5) > 0.0);
    }
    trim_set_free(&t);
}

/* trim_make refuses c with exactly `msg`. */
static void expect_refused(const trim_curves *c, const char *msg)
{
    trim_set t;
    char why[256];
    assert_int_equal(trim_make(c, &t, why, sizeof why), TS_E_SCENE);
    assert_string_equal(why, msg);
    assert_null(t.seg);
}

static void test_bad_curves(void **state)
{
    (void)state;
    const double k5[10] = {0, 0, 0, 0, 0, 1, 1, 1, 1, 1}, p5[5] = {0, 1, 2, 3, 4},
                 w5[5] = {1, 1, 1, 1, 1};
    const double nc = 1, o5 = 5, n5 = 5, o2 = 2, n2 = 2, n1 = 1;
    const double mn = 0, mx = 1, lo = 2, hi = 3;
    trim_curves c = {1, &nc, &o5, &n5, k5, &mn, &mx, p5, p5, w5};
    expect_refused(&c, "curve 0: order 5 is not supported (at most 4, cubic)");
    const double kd[4] = {0, 1, 0.5, 1}, kk[4] = {0, 0, 1, 1}, w0[2] = {1, 0};
    c = (trim_curves){1, &nc, &o2, &n2, kd, &mn, &mx, p5, p5, w5};
    expect_refused(&c, "curve 0: knot 2 (0.5) is less than the one before (1)");
    c = (trim_curves){1, &nc, &o2, &n2, kk, &mn, &mx, p5, p5, w0};
    expect_refused(&c, "curve 0: weight 1 is 0 (weights must be positive)");
    c = (trim_curves){1, &nc, &o2, &n2, kk, &lo, &hi, p5, p5, w5};
    expect_refused(&c, "curve 0: min 2 and max 3 leave no part of the valid range [0, 1]");
    c = (trim_curves){1, &nc, &o2, &n1, kk, &mn, &mx, p5, p5, w5};
    expect_refused(&c, "curve 0: n = 1 control points are fewer than the order 2");
}

/* A circle of radius 0.3 about (0.5, 0.5), and inside it (hole) one of radius 0.1 when hole. */
static void make_ring(trim_set *t, int hole)
{
    double u[18], v[18], w[18], knot[24], mn[2] = {0, 0}, mx[2] = {1, 1};
    double nc[2] = {1, 1}, order[2] = {3, 3}, n[2] = {9, 9};
    circle(0.5, 0.5, 0.3, u, v, w);
    circle(0.5, 0.5, 0.1, u + 9, v + 9, w + 9);
    memcpy(knot, circle_knot, sizeof circle_knot);
    memcpy(knot + 12, circle_knot, sizeof circle_knot);
    trim_curves c = {hole ? 2 : 1, nc, order, n, knot, mn, mx, u, v, w};
    char why[256];
    assert_int_equal(trim_make(&c, t, why, sizeof why), TS_OK);
}

static void test_pieces(void **state)
{
    (void)state;
    trim_set t;
    make_ring(&t, 0);
    ts_vec4 out[4 * TRIM_SPAN_STEPS];
    uint32_t n = 99;
    assert_int_equal(trim_piece(&t, 0.45, 0.45, 0.55, 0.55, out, &n), TRIM_KEEP);
    assert_int_equal(n, 0);
    assert_int_equal(trim_piece(&t, 0.0, 0.0, 0.1, 0.1, out, &n), TRIM_DROP);
    assert_int_equal(trim_piece(&t, 0.9, 0.4, 1.0, 0.6, out, &n), TRIM_DROP); /* right of it */
    assert_int_equal(trim_piece(&t, 0.7, 0.4, 0.9, 0.6, out, &n), TRIM_PARTIAL);
    /* only segments a ray towards +u from the square can cross: y in [0, 1], x >= 0 */
    assert_true(n > 0u && n < t.count);
    for (uint32_t k = 0; k < n; k++)
        assert_true(fmaxf(out[k].x, out[k].z) >= 0.0f && fmaxf(out[k].y, out[k].w) >= 0.0f &&
                    fminf(out[k].y, out[k].w) <= 1.0f);
    /* the piece's own square: u 0.7 + 0.2 x, v 0.4 + 0.2 y; kept inside the circle */
    assert_int_equal(trim_keeps(out, n, 0.25f, 0.5f), 1u); /* (0.75, 0.5) */
    assert_int_equal(trim_keeps(out, n, 0.75f, 0.5f), 0u); /* (0.85, 0.5) */
    assert_int_equal(trim_keeps(out, n, 0.5f, 0.05f), 0u); /* (0.8, 0.41): 0.313 from the centre */
    trim_set_free(&t);
    make_ring(&t, 1); /* the inner loop cuts a hole */
    assert_int_equal(trim_piece(&t, 0.45, 0.45, 0.55, 0.55, out, &n), TRIM_DROP);
    assert_int_equal(trim_piece(&t, 0.3, 0.45, 0.35, 0.55, out, &n), TRIM_KEEP);
    trim_set_free(&t);
}

/* A 4 x 4 cubic NURBS grid (uniform knots 0..4) under a circle of radius 1.2 about (2, 2) in
 * knot space: the four corner pieces lie outside it whole and are dropped, the other twelve
 * are cut; a NuPatch after the attribute block is not trimmed. */
static void test_rib_trim(void **state)
{
    (void)state;
    char trim[2048], pts[4096], text[16384];
    circle_rib(trim, sizeof trim, 2.0, 2.0, 1.2);
    int n = 0;
    for (int j = 0; j < 7; j++)
        for (int i = 0; i < 7; i++)
            n += snprintf(pts + n, sizeof pts - (size_t)n, "%d %d 0 ", i, j);
    const char *nu =
        "NuPatch 7 4 [0 0 0 0 1 2 3 4 4 4 4] 0 4 7 4 [0 0 0 0 1 2 3 4 4 4 4] 0 4 \"P\"";
    snprintf(text, sizeof text, "AttributeBegin\n%s%s [%s]\nAttributeEnd\n%s [%s]\n", trim, nu, pts,
             nu, pts);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 12 + 16);
    for (uint32_t p = 0; p < s.patch_count; p++) {
        const ts_patch_attr *a = &s.attr[p];
        assert_int_equal(a->trim_count > 0, p < 12);
        assert_true(a->trim_first + a->trim_count <= s.trim_seg_count);
    }
    ts_error e = {0};
    void *block;
    size_t size;
    ts_scene u;
    assert_int_equal(scene_pack(&s, &block, &size, &e), TS_OK);
    assert_int_equal(scene_unpack(block, size, &u, &e), TS_OK);
    assert_int_equal(u.trim_seg_count, s.trim_seg_count);
    assert_memory_equal(u.trim_seg, s.trim_seg, s.trim_seg_count * sizeof *s.trim_seg);
    assert_memory_equal(u.attr, s.attr, s.patch_count * sizeof *s.attr);
    free(block);
    scene_free(&u);
    scene_free(&s);
}

static void test_rib_trim_errors(void **state)
{
    (void)state;
    test_parse_rib_error("TrimCurve [1] [2] [0 0 1 1] [0] [1] [2] [0 1] [0 1] [1]",
                         "t.rib:1:53: error: TrimCurve: [w] needs 2 values, got 1");
    test_parse_rib_error("TrimCurve [1] [2] [0 0 1] [0] [1] [2] [0 1] [0 1] [1 1]",
                         "t.rib:1:19: error: TrimCurve: [knot] needs 4 values, got 3");
    test_parse_rib_error("TrimCurve [1] [2.5] [0 0 1 1] [0] [1] [2] [0 1] [0 1] [1 1]",
                         "t.rib:1:15: error: TrimCurve: order: value 0 is 2.5, not an integer in "
                         "[1, 16777216]");
    test_parse_rib_error("TrimCurve [] [2] [0 0 1 1] [0] [1] [2] [0 1] [0 1] [1 1]",
                         "t.rib:1:11: error: TrimCurve: no loops");
    test_parse_rib_error(
        "TrimCurve [1] [5] [0 0 0 0 0 1 1 1 1 1] [0] [1] [5] [0 1 2 3 4] "
        "[0 1 2 3 4] [1 1 1 1 1]",
        "t.rib:1:1: error: TrimCurve: curve 0: order 5 is not supported (at most 4, "
        "cubic)");
}

/* The host build reference on a unit quad trimmed to a circle of radius 0.3: a leaf box is
 * empty exactly where trim_keeps says its centre is removed, every other one is not, and the
 * kept ones cover the circle's area within the micro-quads along its edge. */
static void test_build_reference(void **state)
{
    (void)state;
    char trim[2048], text[4096];
    circle_rib(trim, sizeof trim, 0.5, 0.5, 0.3);
    snprintf(text, sizeof text,
             "%sNuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n",
             trim);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 1);
    const ts_patch_attr *a = &s.attr[0];
    assert_true(a->trim_count > 0);
    enum { M = 6 };
    static ts_vec4 grid[(1 << M) + 1][(1 << M) + 1];
    static ts_box4 groups[1 + ((1 << (2 * M)) - 1) / 3];
    static ts_tight4 codes[sizeof groups / sizeof *groups];
    assert_int_equal(quadtree_group_count(M), sizeof groups / sizeof *groups);
    dice_build_ref(&s, 0, M, 0, &grid[0][0], groups, codes);
    uint32_t kept = 0;
    for (uint32_t k = 0; k < (1u << (2 * M)); k++) {
        uint32_t keep =
            trim_keeps(s.trim_seg + a->trim_first, a->trim_count, quadtree_centre(morton_i(k), M),
                       quadtree_centre(morton_j(k), M));
        assert_int_equal(quadtree_leaf_empty(groups, M, k), !keep);
        kept += keep;
    }
    double area = M_PI * 0.09 * (1 << (2 * M)), edge = 2.0 * M_PI * 0.3 * (1 << M);
    assert_true(fabs(kept - area) < 0.5 * edge);
    /* the root holds the kept micro-quads: the circle's box, not the whole square */
    assert_true(groups[0].lo_x[0] > 0.15f && groups[0].hi_x[0] < 0.85f);
    scene_free(&s);
}

/* An object's NuPatch instanced three times: under the same TrimCurve the second instance
 * shares the first's dicing (scene_share_instances), under another it is a copy. */
static void test_instances(void **state)
{
    (void)state;
    char a[2048], b[2048], text[8192];
    circle_rib(a, sizeof a, 0.5, 0.5, 0.3);
    circle_rib(b, sizeof b, 0.5, 0.5, 0.2);
    snprintf(text, sizeof text,
             "ObjectBegin 1\nNuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"P\" "
             "[0 0 0  1 0 0  0 1 0  1 1 0]\nObjectEnd\nWorldBegin\n"
             "AttributeBegin\n%sObjectInstance 1\nAttributeEnd\n"
             "AttributeBegin\nTranslate 3 0 0\n%sObjectInstance 1\nAttributeEnd\n"
             "AttributeBegin\nTranslate 6 0 0\n%sObjectInstance 1\nAttributeEnd\nWorldEnd\n",
             a, a, b);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 3);
    assert_non_null(s.shape);
    assert_int_equal(s.shape[1], 0); /* the same trim: shares */
    assert_int_equal(s.shape[2], 2); /* another trim: its own dicing */
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_circle_polyline), cmocka_unit_test(test_bad_curves),
        cmocka_unit_test(test_pieces),          cmocka_unit_test(test_rib_trim),
        cmocka_unit_test(test_rib_trim_errors), cmocka_unit_test(test_build_reference),
        cmocka_unit_test(test_instances),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
