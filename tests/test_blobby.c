/* test_blobby.c — Blobby implicit surfaces (host/scene/blobby.c, host/scene/rib/rib_blobby.c,
 * docs/rib.md "Blobby"): the field of each primitive and opcode against its formula; the
 * polygonized surface closed (every edge in exactly two triangles) with its vertices on the
 * surface and its normals the field's; the PN patches a lone blob makes within a stated
 * distance of the true sphere, and a sausage's of the true capsule; leaf colours blended by
 * field; bad programs refused with the instruction named. Host only: never skips. */
#include "scene/blobby.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"
#include "scene/scene_load.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

#define UNIT "1 0 0 0  0 1 0 0  0 0 1 0  "

static void compile_ok(ts_blobby *b, const double *code, size_t ncode, const double *fl, size_t nfl)
{
    char why[256];
    if (blobby_compile(b, code, ncode, fl, nfl, why, sizeof why)) fail_msg("compile: %s", why);
}

static const double unit_at_origin[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

/* Each leaf and opcode against its formula: (1 - r^2)^3 inside the unit ball of the blob. */
static void test_field(void **state)
{
    (void)state;
    ts_blobby b;
    const double code[] = {1001, 0};
    compile_ok(&b, code, 2, unit_at_origin, 16);
    for (double r = 0.0; r < 1.2; r += 0.05) {
        double p[3] = {r * 0.6, r * 0.8, 0.0}, s = 1.0 - r * r;
        double want = r < 1.0 ? s * s * s : 0.0;
        assert_true(fabs(blobby_field(&b, p, NULL) - want) < 1e-12);
    }
    const double half[3] = {0.5, 0, 0};
    assert_true(fabs(blobby_field(&b, half, NULL) - BLOBBY_THRESHOLD) < 1e-15);
    blobby_free(&b);

    /* An ellipsoid stretched 2x along x and moved to (3, 0, 0): r along x halves. */
    const double stretched[16] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 0, 0, 1};
    compile_ok(&b, code, 2, stretched, 16);
    const double px[3] = {4, 0, 0}, py[3] = {3, 0.5, 0};
    assert_true(fabs(blobby_field(&b, px, NULL) - BLOBBY_THRESHOLD) < 1e-12);
    assert_true(fabs(blobby_field(&b, py, NULL) - BLOBBY_THRESHOLD) < 1e-12);
    blobby_free(&b);

    /* A segment from (-1,0,0) to (1,0,0) of radius 2: r is the distance over 2. */
    double seg[23] = {-1, 0, 0, 1, 0, 0, 2};
    memcpy(seg + 7, unit_at_origin, sizeof unit_at_origin);
    const double scode[] = {1002, 0};
    compile_ok(&b, scode, 2, seg, 23);
    const double q1[3] = {0.3, 1.0, 0}, q2[3] = {2.0, 0, 0}, q3[3] = {-1.6, 0, 0.8};
    double s1 = 1.0 - 0.25, s2 = 1.0 - 0.25, s3 = 1.0 - (0.36 + 0.64) / 4.0;
    assert_true(fabs(blobby_field(&b, q1, NULL) - s1 * s1 * s1) < 1e-12);
    assert_true(fabs(blobby_field(&b, q2, NULL) - s2 * s2 * s2) < 1e-12);
    assert_true(fabs(blobby_field(&b, q3, NULL) - s3 * s3 * s3) < 1e-12);
    blobby_free(&b);

    /* Opcodes on constants 0.3 (instruction 1) and 0.6 (2) beside a blob (0). */
    const double consts[18] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.3, 0.6};
    const struct {
        double code[4];
        size_t n;
        double want;
    } ops[] = {
        {{0, 2, 1, 2}, 4, 0.9}, {{1, 2, 1, 2}, 4, 0.18}, {{2, 2, 1, 2}, 4, 0.6},
        {{3, 2, 1, 2}, 4, 0.3}, {{4, 1, 2}, 3, -0.3},    {{5, 1, 2}, 3, 0.5},
        {{6, 2}, 2, -0.6},      {{7, 1}, 2, 0.3},
    };
    const double far[3] = {10, 10, 10};
    for (size_t i = 0; i < sizeof ops / sizeof ops[0]; i++) {
        double c[10] = {1001, 0, 1000, 16, 1000, 17};
        memcpy(c + 6, ops[i].code, ops[i].n * sizeof *c);
        compile_ok(&b, c, 6 + ops[i].n, consts, 18);
        double f = blobby_field(&b, far, NULL);
        if (fabs(f - ops[i].want) > 1e-12)
            fail_msg("opcode %g: %g, want %g", ops[i].code[0], f, ops[i].want);
        blobby_free(&b);
    }
}

static int cmp(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Every edge of the mesh is in exactly two quads, used once each way (closed and
 * consistently oriented); every vertex is on the surface and its normal is the field's. */
static void check_closed(const ts_blobby *b, const blobby_mesh *m)
{
    assert_true(m->nquad > 0);
    size_t ne = 4 * m->nquad;
    uint64_t *e = malloc(ne * sizeof *e);
    assert_non_null(e);
    for (size_t t = 0; t < m->nquad; t++)
        for (int k = 0; k < 4; k++)
            e[4 * t + (size_t)k] = (uint64_t)m->quad[t][k] << 32 | m->quad[t][(k + 1) % 4];
    qsort(e, ne, sizeof *e, cmp);
    for (size_t i = 0; i < ne; i++) {
        if (i + 1 < ne && e[i] == e[i + 1]) fail_msg("edge used twice the same way");
        uint64_t rev = (e[i] << 32) | (e[i] >> 32);
        if (!bsearch(&rev, e, ne, sizeof *e, cmp)) fail_msg("edge without its twin: open mesh");
    }
    free(e);
    for (size_t v = 0; v < m->nvert; v++) {
        double f = blobby_field(b, m->p[v], NULL);
        if (fabs(f - BLOBBY_THRESHOLD) > 1e-9) fail_msg("vertex %zu: field %.12f", v, f);
        double in[3], out[3], step = 1e-3 * m->cell;
        for (int j = 0; j < 3; j++)
            in[j] = m->p[v][j] - step * m->n[v][j], out[j] = m->p[v][j] + step * m->n[v][j];
        if (!(blobby_field(b, in, NULL) > BLOBBY_THRESHOLD &&
              blobby_field(b, out, NULL) < BLOBBY_THRESHOLD))
            fail_msg("vertex %zu: the normal does not point outwards", v);
    }
}

static void test_closed_meshes(void **state)
{
    (void)state;
    /* Two blended blobs; a blob minus a smaller one (a dent); the max and min of two. */
    double fl[32] = {1,   0, 0, 0, 0, 1,   0, 0, 0, 0, 1,   0, 0,    0,   0, 1,
                     0.6, 0, 0, 0, 0, 0.6, 0, 0, 0, 0, 0.6, 0, 0.55, 0.1, 0, 1};
    const struct {
        double code[8];
        size_t n;
    } progs[] = {
        {{1001, 0, 1001, 16, 0, 2, 0, 1}, 8},
        {{1001, 0, 1001, 16, 4, 0, 1}, 7},
        {{1001, 0, 1001, 16, 2, 2, 0, 1}, 8},
        {{1001, 0, 1001, 16, 3, 2, 0, 1}, 8},
    };
    for (size_t i = 0; i < sizeof progs / sizeof progs[0]; i++) {
        ts_blobby b;
        blobby_mesh m;
        char why[256];
        compile_ok(&b, progs[i].code, progs[i].n, fl, 32);
        assert_int_equal(b.sum_only, i == 0);
        if (blobby_polygonize(&b, NULL, &m, why, sizeof why)) fail_msg("%s", why);
        check_closed(&b, &m);
        blobby_mesh_free(&m);
        blobby_free(&b);
    }
}

/* Bézier patch point (u, v) of patch q (control points u fastest). */
static void patch_point(const ts_scene *s, uint32_t q, double u, double v, double out[3])
{
    double bu[4] = {(1 - u) * (1 - u) * (1 - u), 3 * u * (1 - u) * (1 - u), 3 * u * u * (1 - u),
                    u * u * u};
    double bv[4] = {(1 - v) * (1 - v) * (1 - v), 3 * v * (1 - v) * (1 - v), 3 * v * v * (1 - v),
                    v * v * v};
    out[0] = out[1] = out[2] = 0.0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            const ts_vec4 *c = &s->cp[q * 16 + (uint32_t)(j * 4 + i)];
            double w = bu[i] * bv[j];
            out[0] += w * c->x, out[1] += w * c->y, out[2] += w * c->z;
        }
}

/* The largest |distance(point, centre) - radius| over a 5x5 grid of every patch, relative
 * to the radius; dist gives the distance. */
static double worst_error(const ts_scene *s, double (*dist)(const double p[3]), double radius)
{
    double worst = 0.0;
    for (uint32_t q = 0; q < s->patch_count; q++)
        for (int j = 0; j <= 4; j++)
            for (int i = 0; i <= 4; i++) {
                double p[3];
                patch_point(s, q, i / 4.0, j / 4.0, p);
                worst = fmax(worst, fabs(dist(p) - radius) / radius);
            }
    return worst;
}

static double to_sphere(const double p[3])
{
    return sqrt(p[0] * p[0] + p[1] * p[1] + (p[2] - 5) * (p[2] - 5));
}

static double to_x_segment(const double p[3])
{
    double x = fmin(fmax(p[0], -1.0), 1.0);
    return sqrt((p[0] - x) * (p[0] - x) + p[1] * p[1] + (p[2] - 5) * (p[2] - 5));
}

/* A lone blob is the sphere of radius 1/2; its PN patches stay within 0.2% of it (0.09%
 * measured). A
 * sausage of radius 1 is the capsule of radius 1/2 around its segment. */
static void test_shapes(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nBlobby 1 [1001 0] [" UNIT "0 0 5 1] [\"\"]\nWorldEnd\n", &s);
    assert_true(s.patch_count > 100);
    double e = worst_error(&s, to_sphere, 0.5);
    print_message("sphere: %u patches, worst distance error %.4f%% of the radius\n", s.patch_count,
                  100.0 * e);
    assert_true(e < 0.002);
    scene_free(&s);
    test_parse_rib_ok(
        "WorldBegin\nBlobby 1 [1002 0] [-1 0 0 1 0 0 1 " UNIT "0 0 5 1] [\"\"]\nWorldEnd\n", &s);
    e = worst_error(&s, to_x_segment, 0.5);
    print_message("sausage: %u patches, worst distance error %.4f%% of the radius\n", s.patch_count,
                  100.0 * e);
    assert_true(e < 0.002);
    scene_free(&s);
}

/* Leaf colours blend by field: a red and a blue blob apart stay red and blue; a constant
 * "Cs" colours every patch. */
static void test_colours(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nBlobby 2 [1001 0 1001 16 0 2 0 1] [" UNIT "-2 0 5 1 " UNIT
                      "2 0 5 1] [\"\"] \"vertex color Cs\" [1 0 0  0 0 1]\nWorldEnd\n",
                      &s);
    for (uint32_t q = 0; q < s.patch_count; q++) {
        int left = s.cp[q * 16].x < 0.0f;
        const ts_patch_attr *a = &s.attr[q];
        if (left ? !(a->cs_r > 0.999f && a->cs_b < 0.001f)
                 : !(a->cs_b > 0.999f && a->cs_r < 0.001f))
            fail_msg("patch %u: colour %g %g %g", q, a->cs_r, a->cs_g, a->cs_b);
    }
    scene_free(&s);
    test_parse_rib_ok("WorldBegin\nBlobby 1 [1001 0] [" UNIT "0 0 5 1] [\"\"] \"Cs\" [0 1 0]\n"
                      "WorldEnd\n",
                      &s);
    for (uint32_t q = 0; q < s.patch_count; q++)
        assert_true(s.attr[q].cs_g == 1.0f && s.attr[q].cs_r == 0.0f);
    scene_free(&s);
}

static void test_errors(void **state)
{
    (void)state;
    const char *W = "WorldBegin\nBlobby 1 ";
    const struct {
        const char *rest, *msg;
    } bad[] = {
        {"[1001 16] [" UNIT "0 0 0 1] [\"\"]",
         "t.rib:2:10: error: Blobby: instruction 0 (code[0]): opcode 1001 reads floats 16 to 31, "
         "but there are 16"},
        {"[0 -3 0 0 0] [] [\"\"]", /* a negative operand count */
         "t.rib:2:10: error: Blobby: instruction 0 (code[0]): no operands for opcode 0"},
        {"[1001 -6] [" UNIT "0 0 0 1] [\"\"]", /* the fuzzer's: a negative index */
         "t.rib:2:10: error: Blobby: instruction 0 (code[0]): opcode 1001 reads floats from -6, "
         "but there are 16"},
        {"[1001 0 0 2 0 1] [" UNIT "0 0 0 1] [\"\"]",
         "t.rib:2:10: error: Blobby: instruction 1 (code[2]): operand 1 is not an earlier "
         "instruction (0 to 0)"},
        {"[1001 0] [0 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1] [\"\"]",
         "t.rib:2:10: error: Blobby: instruction 0 (code[0]): the ellipsoid's matrix is singular "
         "or projective"},
        {"[1004 0 0 0 0 0] [] [\"x.so\"]",
         "t.rib:2:10: error: Blobby: instruction 0 (code[0]): a field plug-in (opcode 1004) is "
         "not supported"},
        {"[1000 0] [0.5] [\"\"]",
         "t.rib:2:10: error: Blobby: no ellipsoid or segment: the surface has no bounds"},
        {"[1002 0] [0 0 0 1 0 0 0 " UNIT "0 0 0 1] [\"\"]",
         "t.rib:2:10: error: Blobby: instruction 0 (code[0]): the segment's radius is not "
         "positive, or its matrix is singular or projective"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char text[512];
        snprintf(text, sizeof text, "%s%s\n", W, bad[i].rest);
        test_parse_rib_error(text, bad[i].msg);
    }
    test_parse_rib_error("WorldBegin\nMotionBegin [0 1]\nBlobby 1 [1001 0] [" UNIT
                         "0 0 0 1] [\"\"]\n",
                         "t.rib:3:1: error: Blobby is not allowed in the motion block at 2:1 (only "
                         "Patch, PatchMesh, SubdivisionMesh, NuPatch, polygons, quadrics, Points, "
                         "Curves, Translate, Rotate, Scale, ConcatTransform or Transform)");
}

/* scene/blobby.rib loads: three Blobby requests, with leaf colours, sausages and a dent. */
static void test_scene_file(void **state)
{
    (void)state;
    ts_scene s;
    memset(&s, 0, sizeof s); /* scene_load fills a zeroed scene */
    ts_error err = {0};
    if (scene_load(test_source_path("scene/blobby.rib"), &s, 1, &err)) fail_msg("%s", err.msg);
    assert_true(s.patch_count > 1000);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_field),  cmocka_unit_test(test_closed_meshes),
        cmocka_unit_test(test_shapes), cmocka_unit_test(test_colours),
        cmocka_unit_test(test_errors), cmocka_unit_test(test_scene_file),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
