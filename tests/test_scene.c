/* test_scene.c — the scene model (host/scene/scene.c): the displacement direction (a unit
 * vector from nine shared normals: handle and spout displaced like the body, shared edges
 * displaced identically, and which patch lies across each edge), corner displacement normals
 * from
 * scene_finalize, world-to-object transforms, moving patches and scene_patch_box, which
 * must hold the displaced surface (lib/bezier.h, lib/displace.h) over the whole shutter.
 * Host only: never skips. */
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "scene/scene_load.h"
#include "ref/bottom_level_ref.h"
#include "ref/dice_build_ref.h"
#include "lib/quadtree.h"

#include "lib/bezier.h"
#include "lib/displace.h"
#include "lib/patch.h"

#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

static double lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (*s >> 8) * (1.0 / 16777216.0);
}

static double vlen(const ts_vec4 *n)
{
    return sqrt((double)n->x * n->x + (double)n->y * n->y + (double)n->z * n->z);
}

static void assert_vec(const ts_vec4 *c, double x, double y, double z, double tol)
{
    if (fabs(c->x - x) > tol || fabs(c->y - y) > tol || fabs(c->z - z) > tol)
        fail_msg("got (%.9g %.9g %.9g), want (%.9g %.9g %.9g)", c->x, c->y, c->z, x, y, z);
}

static int in_box(const ts_box *b, float x, float y, float z)
{
    return x >= b->lo_x && x <= b->hi_x && y >= b->lo_y && y <= b->hi_y && z >= b->lo_z &&
           z <= b->hi_z;
}

/* A wavy bicubic patch over [0,3]^2 in x, y. */
static void wavy_grid(double g[16][3], double dx)
{
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            g[j * 4 + i][0] = i + dx;
            g[j * 4 + i][1] = j;
            g[j * 4 + i][2] = ((i + j) % 2) ? 0.5 : -0.25;
        }
}

/* ---- the displacement direction (issue 13, item 6) ---------------------------------- */

/* Patch p's displaced vertex at (u, v). */
static ts_vec4 displaced(const ts_scene *s, uint32_t p, float u, float v)
{
    const ts_vec4 *cp = &s->cp[p * 16];
    return patch_vertex(cp, cp, &s->corner_n[p * 4], &s->mid_n[p * 5], &s->attr[p],
                        &s->xform[s->attr[p].xform], scene_tex_ctx(s), u, v);
}

/* The displaced teapot: the direction is a unit vector everywhere, so the handle (patches
 * 12-15) and the spout (16-19) move as far from their undisplaced surface as the body
 * (4-11): the RMS displacement of every handle and spout patch is within a factor of 2 of
 * the body's mean. (With the bilinear blend of four corner normals it vanished in the middle
 * of those half-tube patches.) */
static void test_teapot_handle_and_spout_displaced_like_the_body(void **state)
{
    ts_scene s;
    memset(&s, 0, sizeof s);
    ts_error e = {0};
    assert_int_equal(scene_load(test_source_path("scene/teapot_displaced.rib"), &s, 1, &e), TS_OK);
    assert_int_equal(s.patch_count, 32);
    double rms[32], body = 0;
    for (uint32_t p = 0; p < 32; p++) {
        double sum = 0;
        int n = 0;
        for (int j = 0; j <= 32; j++)
            for (int i = 0; i <= 32; i++) {
                float u = i / 32.0f, v = j / 32.0f;
                ts_vec4 q = displaced(&s, p, u, v), b = bezier_eval(&s.cp[p * 16], u, v);
                double dx = q.x - b.x, dy = q.y - b.y, dz = q.z - b.z;
                sum += dx * dx + dy * dy + dz * dz, n++;
                /* |q - b| = |d|: a unit direction */
                assert_true(fabs(sqrt(dx * dx + dy * dy + dz * dz) - fabs(q.w)) < 1e-5);
            }
        rms[p] = sqrt(sum / n);
        if (p >= 4 && p < 12) body += rms[p] / 8;
    }
    for (uint32_t p = 12; p < 20; p++)
        if (!(rms[p] > body / 2 && rms[p] < body * 2))
            fail_msg("patch %u: RMS displacement %g, the body's %g", p, rms[p], body);
    scene_free(&s);
}

/* The control points of edge k (0: v = 0, 1: u = 0, 2: u = 1, 3: v = 1). */
static const int edge_cp[4][4] = {{0, 1, 2, 3}, {0, 4, 8, 12}, {3, 7, 11, 15}, {12, 13, 14, 15}};

/* Whether edge a of patch p has the points of edge b of patch q (reversed when rev). */
static int same_edge(const ts_scene *s, uint32_t p, int a, uint32_t q, int b, int rev)
{
    for (int k = 0; k < 4; k++) {
        const ts_vec4 *x = &s->cp[p * 16 + edge_cp[a][k]];
        const ts_vec4 *y = &s->cp[q * 16 + edge_cp[b][rev ? 3 - k : k]];
        if (!(x->x == y->x && x->y == y->y && x->z == y->z)) return 0;
    }
    return 1;
}

static void load_teapot_displaced(ts_scene *s)
{
    memset(s, 0, sizeof *s);
    ts_error e = {0};
    assert_int_equal(scene_load(test_source_path("scene/teapot_displaced.rib"), s, 1, &e), TS_OK);
}

/* Neighbours share the displaced edge exactly: for every pair of teapot patches with the
 * same boundary curve (in either direction), the displaced vertices along it at m = 5 are
 * bitwise equal, so no crack opens between them. */
static void test_displaced_edges_are_shared_exactly(void **state)
{
    ts_scene s;
    load_teapot_displaced(&s);
    const int n = 32;
    int pairs = 0;
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (uint32_t q = p + 1; q < s.patch_count; q++)
            for (int a = 0; a < 4; a++)
                for (int b = 0; b < 4; b++)
                    for (int rev = 0; rev < 2; rev++) {
                        if (!same_edge(&s, p, a, q, b, rev)) continue;
                        const ts_vec4 *c0 = &s.cp[p * 16 + edge_cp[a][0]];
                        const ts_vec4 *c3 = &s.cp[p * 16 + edge_cp[a][3]];
                        if (c0->x == c3->x && c0->y == c3->y && c0->z == c3->z)
                            continue; /* a pole */
                        pairs++;
                        for (int i = 0; i <= n; i++) {
                            float t = (float)i / n, t2 = rev ? 1.0f - t : t;
                            float pu = a == 1 ? 0.0f : a == 2 ? 1.0f : t;
                            float pv = a == 0 ? 0.0f : a == 3 ? 1.0f : t;
                            float qu = b == 1 ? 0.0f : b == 2 ? 1.0f : t2;
                            float qv = b == 0 ? 0.0f : b == 3 ? 1.0f : t2;
                            ts_vec4 x = displaced(&s, p, pu, pv), y = displaced(&s, q, qu, qv);
                            if (x.x != y.x || x.y != y.y || x.z != y.z)
                                fail_msg("patches %u and %u: the shared edge differs at %d/%d by "
                                         "(%g %g %g)",
                                         p, q, i, n, x.x - y.x, x.y - y.y, x.z - y.z);
                        }
                    }
    assert_true(pairs >= 40); /* the teapot's 32 patches share many edges */
    scene_free(&s);
}

/* scene_edge_neighbours (triangle mode's stitching) against brute force on the teapot: an
 * edge whose four boundary points (either way round) are another patch's edge and no third
 * one's names that patch; every other edge (the rim's open edges, the poles shared by four
 * patches) names none. The same on three copies of one patch: each edge then lies on three. */
static void test_edge_neighbours(void **state)
{
    (void)state;
    ts_scene s;
    load_teapot_displaced(&s);
    ts_error e = {0};
    uint32_t *nb = malloc(4 * s.patch_count * sizeof *nb);
    assert_non_null(nb);
    assert_int_equal(scene_edge_neighbours(&s, nb, &e), TS_OK);
    int linked = 0;
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (int a = 0; a < 4; a++) {
            uint32_t other = TS_INVALID;
            int count = 0;
            for (uint32_t q = 0; q < s.patch_count; q++)
                for (int b = 0; b < 4; b++) {
                    if (q == p && b == a) continue;
                    if (same_edge(&s, p, a, q, b, 0) || same_edge(&s, p, a, q, b, 1))
                        count++, other = q;
                }
            uint32_t want = count == 1 && other != p ? other : TS_INVALID;
            if (nb[4 * p + a] != want)
                fail_msg("patch %u edge %d: %u, expected %u (%d other edges)", p, a, nb[4 * p + a],
                         want, count);
            linked += want != TS_INVALID;
        }
    assert_true(linked >= 80); /* the pairs of test_displaced_edges_are_shared_exactly, twice */
    /* three copies of patch 5: every edge on three patches, so none is linked */
    ts_scene t;
    memset(&t, 0, sizeof t);
    for (int c = 0; c < 3; c++) {
        double cp[16][3];
        for (int k = 0; k < 16; k++)
            cp[k][0] = s.cp[5 * 16 + k].x, cp[k][1] = s.cp[5 * 16 + k].y,
            cp[k][2] = s.cp[5 * 16 + k].z;
        ts_patch_attr at = {.cs_r = 1, .cs_g = 1, .cs_b = 1};
        assert_int_equal(scene_add_patch(&t, cp, &at, &e), TS_OK);
    }
    assert_int_equal(scene_finalize(&t, &e), TS_OK);
    assert_int_equal(scene_edge_neighbours(&t, nb, &e), TS_OK);
    for (int k = 0; k < 12; k++)
        assert_int_equal(nb[k], TS_INVALID);
    free(nb);
    scene_free(&t);
    scene_free(&s);
}

/* ---- corner normals ------------------------------------------------------------------- */

/* The teapot: every corner normal is unit length, corners at the same position share one
 * normal, the lid apex looks up and the bottom centre down. */
static void test_teapot_corner_normals(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_error e = {0};
    if (rib_load(test_source_path("scene/teapot.rib"), &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 32);
    assert_non_null(s.corner_n);
    assert_null(s.cp1);
    static const int corner_cp[4] = {0, 3, 12, 15};
    int shared = 0;
    for (uint32_t p = 0; p < s.patch_count; p++)
        for (int c = 0; c < 4; c++) {
            const ts_vec4 *n = &s.corner_n[p * 4 + c];
            assert_true(fabs(vlen(n) - 1.0) < 1e-6);
            assert_true(n->w == 0.0f);
            const ts_vec4 *P = &s.cp[p * 16 + corner_cp[c]];
            for (uint32_t q = 0; q < s.patch_count; q++)
                for (int d = 0; d < 4; d++) {
                    const ts_vec4 *Q = &s.cp[q * 16 + corner_cp[d]];
                    if (P->x != Q->x || P->y != Q->y || P->z != Q->z) continue;
                    const ts_vec4 *m = &s.corner_n[q * 4 + d];
                    if (n->x != m->x || n->y != m->y || n->z != m->z)
                        fail_msg("patch %u corner %d and patch %u corner %d differ", p, c, q, d);
                    shared += (q != p);
                }
        }
    assert_true(shared > 100);
    /* Lid apex: patches 20..23, corners (0,0) and (1,0) (the collapsed row v = 0). */
    for (uint32_t p = 20; p < 24; p++)
        for (int c = 0; c < 2; c++) {
            assert_vec(&s.cp[p * 16 + corner_cp[c]], 0, 0, 3.15, 1e-6);
            assert_vec(&s.corner_n[p * 4 + c], 0, 0, 1, 1e-6);
        }
    /* Bottom centre: patches 28..31. */
    for (uint32_t p = 28; p < 32; p++)
        assert_vec(&s.corner_n[p * 4], 0, 0, -1, 1e-6);
    /* An ordinary corner: the body at (1.5, 0, 2.4) is shared by rim and body patches, and
     * every one of them gives the same normal (checked above); it is the renormalised mean
     * of the rim's and the body's own normals there. */
    assert_vec(&s.cp[4 * 16], 1.5, 0, 2.4, 1e-6);
    assert_true(s.corner_n[4 * 4].x > 0.5 && fabs(s.corner_n[4 * 4].y) < 1e-6);
    scene_free(&s);
}

/* Two flat patches meeting at a crease: the shared edge gets the mean of the two face
 * normals; the outer corners keep their own. */
static void test_average_across_crease(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_error e = {0};
    double a[16][3], b[16][3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            /* a: the plane z = 0 over x in [-1, 0]; b: rises at 45 degrees for x in [0, 1]. */
            a[j * 4 + i][0] = -1.0 + i / 3.0, a[j * 4 + i][1] = j / 3.0, a[j * 4 + i][2] = 0.0;
            b[j * 4 + i][0] = i / 3.0, b[j * 4 + i][1] = j / 3.0, b[j * 4 + i][2] = i / 3.0;
        }
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])a, NULL, &e), TS_OK);
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])b, NULL, &e), TS_OK);
    /* Before finalize: each patch's own unit normals (usable, not yet shared). */
    assert_vec(&s.corner_n[1], 0, 0, 1, 1e-7);
    assert_vec(&s.corner_n[4], -M_SQRT1_2, 0, M_SQRT1_2, 1e-7);
    assert_int_equal(scene_finalize(&s, &e), TS_OK);
    /* a's corners (1,0), (1,1) and b's (0,0), (0,1) lie on x = 0. */
    double h = sqrt(2.0 + M_SQRT2), nx = -M_SQRT1_2 / h, nz = (1.0 + M_SQRT1_2) / h;
    assert_vec(&s.corner_n[1], nx, 0, nz, 1e-6);
    assert_vec(&s.corner_n[3], nx, 0, nz, 1e-6);
    assert_vec(&s.corner_n[4], nx, 0, nz, 1e-6);
    assert_vec(&s.corner_n[6], nx, 0, nz, 1e-6);
    assert_vec(&s.corner_n[0], 0, 0, 1, 1e-7);
    assert_vec(&s.corner_n[5], -M_SQRT1_2, 0, M_SQRT1_2, 1e-7);
    for (int k = 0; k < 8; k++)
        assert_true(s.corner_n[k].w == 0.0f);
    assert_int_equal(s.xform_count, 1);
    scene_free(&s);
}

/* Explicit normals are normalised and kept (not averaged); a degenerate corner of a patch
 * without them takes the limit from inside; -0 and +0 are the same position. */
static void test_explicit_and_degenerate(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_error e = {0};
    double g[16][3], n[4][3] = {{0, 0, 2}, {0, 3, 0}, {4, 0, 0}, {1, 1, 0}};
    wavy_grid(g, 0.0);
    assert_int_equal(
        scene_add_patch_ex(&s, (const double(*)[3])g, NULL, (const double(*)[3])n, NULL, &e),
        TS_OK);
    /* The same grid without normals, sharing every corner with the first. */
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])g, NULL, &e), TS_OK);
    /* Two faces of a pyramid with its apex (0, 0, 1), each a bicubic patch whose row v = 0
     * collapses to the apex: the planes x + y + z = 1 and -x + y + z = 1. The apex is
     * written with x = -0 in the first and +0 in the second: the same position. */
    double c[16][3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            double t = i / 3.0, r = j / 3.0;
            c[j * 4 + i][0] = j == 0 ? -0.0 : r * (1 - t);
            c[j * 4 + i][1] = r * t;
            c[j * 4 + i][2] = 1.0 - r;
        }
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])c, NULL, &e), TS_OK);
    for (int k = 0; k < 16; k++) { /* turned 90 degrees about z: same orientation */
        double x = c[k][0], y = c[k][1];
        c[k][0] = k < 4 ? 0.0 : -y, c[k][1] = k < 4 ? 0.0 : x;
    }
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])c, NULL, &e), TS_OK);
    assert_true(signbit(s.cp[32].x) && !signbit(s.cp[48].x));
    /* Before finalize: the limits from inside, dP/du x dP/dv = -(1, 1, 1) r on the first. */
    double r3 = 1.0 / sqrt(3.0);
    assert_vec(&s.corner_n[8], -r3, -r3, -r3, 1e-6);
    assert_vec(&s.corner_n[13], r3, -r3, -r3, 1e-6);
    assert_int_equal(scene_finalize(&s, &e), TS_OK);
    assert_vec(&s.corner_n[0], 0, 0, 1, 0);
    assert_vec(&s.corner_n[1], 0, 1, 0, 0);
    assert_vec(&s.corner_n[2], 1, 0, 0, 0);
    assert_vec(&s.corner_n[3], M_SQRT1_2, M_SQRT1_2, 0, 1e-7);
    ts_vec4 own = bezier_normal(&s.cp[16], 0.0f, 0.0f);
    assert_vec(&s.corner_n[4], own.x, own.y, own.z, 1e-5); /* not the explicit (0,0,2) */
    /* The apex: the four corners there share the mean of the two faces' normals. */
    for (int k = 8; k < 16; k++)
        assert_true(fabs(vlen(&s.corner_n[k]) - 1.0) < 1e-6);
    const int apex[4] = {8, 9, 12, 13};
    for (int k = 0; k < 4; k++)
        assert_vec(&s.corner_n[apex[k]], 0, -M_SQRT1_2, -M_SQRT1_2, 1e-6);
    /* A zero normal is refused. */
    double z[4][3] = {{0, 0, 1}, {0, 0, 0}, {0, 0, 1}, {0, 0, 1}};
    assert_int_equal(
        scene_add_patch_ex(&s, (const double(*)[3])g, NULL, (const double(*)[3])z, NULL, &e),
        TS_E_SCENE);
    assert_string_equal(e.msg, "scene: corner normal 1 of patch 4 has zero length");
    assert_int_equal(s.patch_count, 4);
    scene_free(&s);
}

/* ---- transforms ----------------------------------------------------------------------- */

static void test_xform_dedupe(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_error e = {0};
    uint32_t a, b, c, d;
    const double t[16] = {2, 0, 0, 1, 0, 2, 0, 2, 0, 0, 2, 3, 0, 0, 0, 1};
    const double t2[16] = {4, 0, 0, 2, 0, 4, 0, 4, 0, 0, 4, 6, 0, 0, 0, 2}; /* same, w = 2 */
    const double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    assert_int_equal(scene_add_xform(&s, t, &a, &e), TS_OK);
    assert_int_equal(a, 1); /* xform[0] is the identity, made on first use */
    assert_int_equal(s.xform_count, 2);
    assert_true(s.xform[0].r0[0] == 1 && s.xform[0].r1[1] == 1 && s.xform[0].r2[2] == 1 &&
                s.xform[0].r0[3] == 0 && s.xform[0].r2[3] == 0);
    assert_true(s.xform[1].r0[0] == 2 && s.xform[1].r0[3] == 1 && s.xform[1].r1[3] == 2 &&
                s.xform[1].r2[3] == 3 && s.xform[1].r2[2] == 2 && s.xform[1].r0[1] == 0);
    assert_int_equal(scene_add_xform(&s, t2, &b, &e), TS_OK);
    assert_int_equal(scene_add_xform(&s, id, &c, &e), TS_OK);
    assert_int_equal(b, 1);
    assert_int_equal(c, 0);
    assert_int_equal(s.xform_count, 2);
    for (int k = 0; k < 20; k++) { /* growth past the first allocation */
        double m[16] = {1, 0, 0, k + 10.0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        assert_int_equal(scene_add_xform(&s, m, &d, &e), TS_OK);
        assert_int_equal(d, 2 + k);
    }
    assert_true(s.xform[21].r0[3] == 29.0f);
    const double proj[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    assert_int_equal(scene_add_xform(&s, proj, &d, &e), TS_E_INTERNAL);
    scene_free(&s);
    assert_null(s.xform);
    assert_int_equal(s.xform_count, 0);
    /* A patch referring to a transform that does not exist is a bug. */
    double g[16][3];
    wavy_grid(g, 0);
    ts_patch_attr at = {.cs_r = 1, .cs_g = 1, .cs_b = 1, .xform = 3};
    ts_error e2 = {0};
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])g, &at, &e2), TS_E_INTERNAL);
    scene_free(&s);
}

/* ---- boxes ---------------------------------------------------------------------------- */

/* The box of a displaced patch holds 10000 random points of the displaced surface
 * P(u,v) + d(P) n(u,v); the box of a moving one holds both time samples and the points
 * between them. */
static void check_displaced_box(uint32_t kind, int moving)
{
    ts_scene s = {0};
    ts_error e = {0};
    double g0[16][3], g1[16][3];
    wavy_grid(g0, 0.0);
    wavy_grid(g1, 2.5);
    for (int k = 0; k < 16; k++)
        g1[k][2] += 1.0;
    const double w2o[16] = {0.5, 0, 0, 0.25, 0, 0.5, 0, -1, 0, 0, 0.5, 0.125, 0, 0, 0, 1};
    uint32_t xf;
    assert_int_equal(scene_add_xform(&s, w2o, &xf, &e), TS_OK);
    ts_patch_attr a = {.cs_r = 1,
                       .cs_g = 1,
                       .cs_b = 1,
                       .disp_kind = kind,
                       .disp_octaves = 5,
                       .disp_amplitude = 0.3f,
                       .disp_frequency = 3.0f,
                       .disp_lacunarity = 2.0f,
                       .disp_gain = 0.5f,
                       .xform = xf};
    assert_int_equal(scene_add_patch_ex(&s, (const double(*)[3])g0,
                                        moving ? (const double(*)[3])g1 : NULL, NULL, &a, &e),
                     TS_OK);
    assert_int_equal(scene_finalize(&s, &e), TS_OK);
    assert_true(((s.attr[0].flags & TS_PATCH_MOVING) != 0) == moving);
    ts_box b = scene_patch_box(&s, 0);
    float bound = displace_bound(&s.attr[0]);
    assert_true(bound > 0.3f);
    /* Exactly the control-point box (both times) grown by the bound, up to rounding. */
    double want_hi_x = moving ? 5.5 : 3.0, want_hi_z = moving ? 1.5 : 0.5;
    assert_true(fabs(b.lo_x - (0.0 - bound)) < 1e-5 && fabs(b.hi_x - (want_hi_x + bound)) < 1e-5);
    assert_true(fabs(b.lo_z - (-0.25 - bound)) < 1e-5 && fabs(b.hi_z - (want_hi_z + bound)) < 1e-5);
    uint32_t seed = 2024 + kind;
    float dmin = INFINITY, dmax = -INFINITY;
    for (int k = 0; k < 10000; k++) {
        float u = (float)lcg(&seed), v = (float)lcg(&seed), t = (float)lcg(&seed);
        if (k < 4) u = (float)(k & 1), v = (float)(k >> 1);
        ts_vec4 p0 = bezier_eval(&s.cp[0], u, v);
        float d = displace_value(&s.attr[0], &s.xform[s.attr[0].xform], p0.x, p0.y, p0.z);
        ts_vec4 n = displace_normal(&s.corner_n[0], &s.mid_n[0], u, v);
        dmin = fminf(dmin, d), dmax = fmaxf(dmax, d);
        ts_vec4 q0 = {p0.x + d * n.x, p0.y + d * n.y, p0.z + d * n.z, 0};
        if (!in_box(&b, q0.x, q0.y, q0.z))
            fail_msg("(%g %g) at time 0: (%g %g %g) outside the box", u, v, q0.x, q0.y, q0.z);
        if (!moving) continue;
        ts_vec4 p1 = bezier_eval(&s.cp1[0], u, v);
        ts_vec4 q1 = {p1.x + d * n.x, p1.y + d * n.y, p1.z + d * n.z, 0};
        ts_vec4 qt = {q0.x + t * (q1.x - q0.x), q0.y + t * (q1.y - q0.y), q0.z + t * (q1.z - q0.z),
                      0};
        if (!in_box(&b, q1.x, q1.y, q1.z) || !in_box(&b, qt.x, qt.y, qt.z))
            fail_msg("(%g %g) at time 1 or %g outside the box", u, v, t);
    }
    /* The displacement really varies (the test is not vacuous) and stays in its bound. */
    assert_true(dmax - dmin > 0.05f);
    assert_true(dmin >= -bound && dmax <= bound);
    scene_free(&s);
}

static void test_box_displaced(void **state)
{
    (void)state;
    check_displaced_box(TS_DISP_FBM, 0);
    check_displaced_box(TS_DISP_RIDGED, 0);
}

static void test_box_moving(void **state)
{
    (void)state;
    check_displaced_box(TS_DISP_FBM, 1);
    /* Without displacement: exactly the box of both control point sets. */
    ts_scene s = {0};
    ts_error e = {0};
    double g0[16][3], g1[16][3];
    wavy_grid(g0, 0.0);
    wavy_grid(g1, -4.0);
    assert_int_equal(scene_add_patch(&s, (const double(*)[3])g0, NULL, &e), TS_OK);
    assert_null(s.cp1);
    assert_int_equal(
        scene_add_patch_ex(&s, (const double(*)[3])g0, (const double(*)[3])g1, NULL, NULL, &e),
        TS_OK);
    assert_non_null(s.cp1);
    for (int k = 0; k < 100; k++) /* growth keeps cp1 in step */
        assert_int_equal(scene_add_patch(&s, (const double(*)[3])g1, NULL, &e), TS_OK);
    assert_int_equal(scene_finalize(&s, &e), TS_OK);
    ts_box b0 = scene_patch_box(&s, 0), b1 = scene_patch_box(&s, 1);
    /* The box of both control point sets, grown by a few ulps of |P| (scene_patch_box). */
    const float u = 1e-5f;
    assert_true(b0.lo_x < 0.0f && b0.lo_x > -u && b0.hi_x > 3.0f && b0.hi_x < 3.0f + u);
    assert_true(b1.lo_x < -4.0f && b1.lo_x > -4.0f - u && b1.hi_x > 3.0f && b1.hi_x < 3.0f + u);
    assert_true(b1.lo_z < -0.25f && b1.lo_z > -0.25f - u && b1.hi_z > 0.5f && b1.hi_z < 0.5f + u);
    /* Static patches: cp1 is a copy of cp. */
    assert_true(memcmp(s.cp1, s.cp, 16 * sizeof(ts_vec4)) == 0);
    assert_true(memcmp(s.cp1 + 101 * 16, s.cp + 101 * 16, 16 * sizeof(ts_vec4)) == 0);
    assert_true(s.cp1[16].x == -4.0f && s.cp[16].x == 0.0f);
    assert_int_equal(s.attr[1].flags, TS_PATCH_MOVING);
    assert_int_equal(s.attr[0].flags, 0);
    scene_free(&s);
    assert_null(s.cp1);
    assert_null(s.corner_n);
}

/* Leaf-box mode: every node box of the quad-trees build makes, at every m, lies inside the
 * patch's top-level box, so the top level never culls a patch whose leaf boxes a ray could
 * still hit nearer (a coarse leaf, its corners' box grown by the flatness bound, sticks out
 * of the control hull unless build clamps it). Checked with the plain-C dice/build
 * reference, bitwise equal to the kernels (test_bottom_level). */
static void check_trees_in_patch_boxes(const char *scene, uint32_t stride)
{
    ts_scene s = {0};
    ts_error e = {0};
    if (scene_load(test_source_path(scene), &s, 1, &e) != TS_OK) fail_msg("%s: %s", scene, e.msg);
    size_t checked = 0;
    for (uint32_t p = 0; p < s.patch_count; p += stride) {
        ts_box b = scene_patch_box(&s, p);
        for (uint32_t m = 0; m <= 4; ++m) {
            uint32_t n = (1u << m) + 1u, ng = quadtree_group_count(m),
                     times = dice_build_ref_times(&s, p);
            ts_vec4 *grid = malloc(times * n * n * sizeof *grid);
            ts_box4 *groups = malloc(times * ng * sizeof *groups);
            ts_tight4 *codes = malloc(times * ng * sizeof *codes);
            assert_true(grid && groups && codes);
            dice_build_ref(&s, p, m, 0, grid, groups, codes);
            for (uint32_t g = 0; g < times * ng; ++g)
                for (int q = 0; q < 4; ++q) {
                    const ts_box4 *x = &groups[g];
                    if (x->lo_x[q] > x->hi_x[q]) continue; /* an empty lane of the root group */
                    if (x->lo_x[q] < b.lo_x || x->lo_y[q] < b.lo_y || x->lo_z[q] < b.lo_z ||
                        x->hi_x[q] > b.hi_x || x->hi_y[q] > b.hi_y || x->hi_z[q] > b.hi_z)
                        fail_msg("%s patch %u, m = %u: a tree box sticks out of the patch box",
                                 scene, p, m);
                    ++checked;
                }
            for (uint32_t v = 0; v < times * n * n; ++v) /* and so does every vertex */
                if (grid[v].x < b.lo_x || grid[v].y < b.lo_y || grid[v].z < b.lo_z ||
                    grid[v].x > b.hi_x || grid[v].y > b.hi_y || grid[v].z > b.hi_z)
                    fail_msg("%s patch %u, m = %u: vertex %u outside the patch box", scene, p, m,
                             v);
            free(grid);
            free(groups);
            free(codes);
        }
    }
    assert_true(checked > 1000);
    scene_free(&s);
}

static void test_trees_inside_patch_boxes(void **state)
{
    (void)state;
    check_trees_in_patch_boxes("scene/teapot.rib", 1);
    check_trees_in_patch_boxes("scene/teapot_displaced.rib", 1);
    check_trees_in_patch_boxes("scene/textured.rib", 1);
    check_trees_in_patch_boxes("scene/forest-1.rib", 7);
}

/* The origin-patch rule's culling by tight boxes (ts_tight4) loses no hit: rays leaving the
 * displaced teapot's patches from points on their micro-triangles, in every direction (half of
 * them into the rough surface), traced through the patch as micro-triangles with the tight
 * boxes and with box mode's node boxes, find the same hits bit for bit (the plain-C
 * reference, itself bitwise the kernels': test_bottom_level), with far fewer micro-quad
 * tests. */
static void test_tight_boxes_lose_no_hit(void **state)
{
    (void)state;
    ts_scene s = {0};
    ts_error e = {0};
    if (scene_load(test_source_path("scene/teapot_displaced.rib"), &s, 1, &e) != TS_OK)
        fail_msg("%s", e.msg);
    uint32_t seed = 2024u, hits = 0, rays = 0;
    uint64_t tests_tight = 0, tests_box = 0;
    for (uint32_t p = 0; p < s.patch_count; p += 3) {
        uint32_t m = 7u + p % 2u, n = (1u << m) + 1u, ng = quadtree_group_count(m);
        assert_int_equal(dice_build_ref_times(&s, p), 1u);
        assert_true(scene_patch_rough(&s, p, m)); /* so build gives it tight codes */
        ts_vec4 *grid = malloc(n * n * sizeof *grid);
        ts_box4 *groups = malloc(ng * sizeof *groups);
        ts_tight4 *codes = malloc(ng * sizeof *codes);
        assert_true(grid && groups && codes);
        dice_build_ref(&s, p, m, 0, grid, groups, codes);
        ts_segment seg = {.patch = p, .lod = m, .shape = p};
        bl_ref_patch box = bottom_level_ref_patch(&seg, grid, groups, NULL),
                     tight = bottom_level_ref_patch(&seg, grid, groups, codes);
        for (int r = 0; r < 200; ++r, ++rays) {
            uint32_t i = (uint32_t)test_uniform(&seed, 0.0f, (float)(n - 1)) % (n - 1u),
                     j = (uint32_t)test_uniform(&seed, 0.0f, (float)(n - 1)) % (n - 1u);
            ts_vec4 a = grid[j * n + i], b = grid[j * n + i + 1], c = grid[(j + 1) * n + i + 1];
            float b1 = test_uniform(&seed, 0.0f, 1.0f), b2 = test_uniform(&seed, 0.0f, 1.0f);
            if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
            /* A point of the micro-triangle; tmin one micro-quad diagonal (shade's org.w). */
            float dx = c.x - a.x, dy = c.y - a.y, dz = c.z - a.z;
            ts_vec4 o = {a.x + b1 * (b.x - a.x) + b2 * dx, a.y + b1 * (b.y - a.y) + b2 * dy,
                         a.z + b1 * (b.z - a.z) + b2 * dz, sqrtf(dx * dx + dy * dy + dz * dz)};
            float ux = test_uniform(&seed, -1, 1), uy = test_uniform(&seed, -1, 1),
                  uz = test_uniform(&seed, -1, 1), len = sqrtf(ux * ux + uy * uy + uz * uz);
            if (len < 0.1f || len > 1.0f) {
                --r, --rays;
                continue;
            }
            ts_vec4 d = {ux / len, uy / len, uz / len, 0.0f};
            uint32_t nb = 0, nt = 0;
            ts_hit hb = bottom_level_ref_trace(o, d, INFINITY, &box, 1, 0, 0u, &nb);
            ts_hit ht = bottom_level_ref_trace(o, d, INFINITY, &tight, 1, 0, 0u, &nt);
            if (memcmp(&hb, &ht, sizeof hb))
                fail_msg("patch %u m %u ray %d: node boxes (%a %a %a %x) tight boxes (%a %a %a %x)",
                         p, m, r, hb.t, hb.u, hb.v, hb.prim, ht.t, ht.u, ht.v, ht.prim);
            hits += hb.patch != TS_INVALID;
            tests_box += nb, tests_tight += nt;
        }
        free(grid), free(groups), free(codes);
    }
    /* Some rays meet the rough surface again beyond tmin; the tight boxes test a fraction of
     * the micro-quads. */
    assert_true(hits > rays / 20u && hits < rays);
    assert_true(tests_tight < tests_box / 2u);
    print_message("tight boxes: %u of %u rays hit their patch again; micro-quad tests %llu "
                  "(node boxes %llu)\n",
                  hits, rays, (unsigned long long)tests_tight, (unsigned long long)tests_box);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_teapot_corner_normals),
        cmocka_unit_test(test_teapot_handle_and_spout_displaced_like_the_body),
        cmocka_unit_test(test_displaced_edges_are_shared_exactly),
        cmocka_unit_test(test_edge_neighbours),
        cmocka_unit_test(test_average_across_crease),
        cmocka_unit_test(test_explicit_and_degenerate),
        cmocka_unit_test(test_xform_dedupe),
        cmocka_unit_test(test_box_displaced),
        cmocka_unit_test(test_box_moving),
        cmocka_unit_test(test_trees_inside_patch_boxes),
        cmocka_unit_test(test_tight_boxes_lose_no_hit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
