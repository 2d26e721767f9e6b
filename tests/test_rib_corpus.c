/* test_rib_corpus.c — the public RIB files of tests/rib-corpus/ (written by others, kept
 * because their licence allows it; tests/rib-corpus/README.md) load as the scenes they
 * describe: the number of patches, the camera options they set; and so does
 * scene/teapots.rib, written to use the requests of issue 16. Host only: never skips.
 * test_rib_render renders them. */
#include "scene/rib/rib.h"
#include "scene/scene_load.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

typedef struct corpus_file {
    const char *path; /* under tests/rib-corpus/ */
    uint32_t patches, lights;
    int width, height;
    uint32_t projection;
} corpus_file;

/* lights: the file's, or 1 for the headlight a file without light gets (tst.rib, tenpatch.rib,
 * simpledeformation.rib). */
static const corpus_file corpus[] = {
    {"aqsis/tools/displays/exr/tst.rib", 32, 1, 720, 486, TS_PROJECTION_PERSPECTIVE},
    {"aqsis/tools/displays/xpm/teapotgeom.rib", 32, 3, 0, 0, TS_PROJECTION_PERSPECTIVE},
    {"aqsis/prototypes/newcore/scenes/tenpatch.rib", 10, 1, 1024, 1024, TS_PROJECTION_ORTHOGRAPHIC},
    {"aqsis/prototypes/newcore/scenes/simpledeformation.rib", 2, 1, 1024, 1024,
     TS_PROJECTION_PERSPECTIVE},
    {"aqsis/prototypes/newcore/scenes/mb_noise_test.rib", 1, 0, 256, 256,
     TS_PROJECTION_ORTHOGRAPHIC},
    {"aqsis/examples/features/textures/sticky.rib", 3, 1, 480, 360, TS_PROJECTION_PERSPECTIVE},
    {"aqsis/examples/features/objectinstance/singlepolygon.rib", 12, 1, 480, 360,
     TS_PROJECTION_PERSPECTIVE},
};

static void test_corpus_loads(void **state)
{
    (void)state;
    for (size_t k = 0; k < sizeof corpus / sizeof corpus[0]; k++) {
        const corpus_file *c = &corpus[k];
        char rel[256];
        snprintf(rel, sizeof rel, "tests/rib-corpus/%s", c->path);
        ts_scene s;
        ts_error e = {0};
        memset(&s, 0, sizeof s);
        if (rib_load(test_source_path(rel), &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
        if (s.patch_count != c->patches || s.light_count != c->lights ||
            s.camera.width != c->width || s.camera.height != c->height ||
            s.camera.projection != c->projection)
            fail_msg("%s: %u patches, %u lights, %dx%d, projection %u", c->path, s.patch_count,
                     s.light_count, s.camera.width, s.camera.height, s.camera.projection);
        scene_free(&s);
    }
}

/* What the two orthographic files set: their screen windows and the moving patch. */
static void test_corpus_details(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(test_source_path("tests/rib-corpus/aqsis/prototypes/newcore/scenes/"
                                  "mb_noise_test.rib"),
                 &s, 1, &e) != TS_OK)
        fail_msg("%s", e.msg);
    assert_int_equal(s.camera.has_screen, 1);
    assert_true(s.camera.screen[0] == 0 && s.camera.screen[1] == 1 && s.camera.screen[2] == 0.01 &&
                s.camera.screen[3] == 0.99);
    assert_true(s.attr[0].flags & TS_PATCH_MOVING);
    assert_true(s.attr[0].le_r == 1.0f && s.attr[0].kd == 0.0f); /* Surface "constant" */
    assert_int_equal(s.camera.spp, 16);
    scene_free(&s);
}

/* teapotgeom.rib (a 3ds Max export) lights its teapot with three pointlights, each placed
 * by a ConcatTransform in a TransformBegin block at the origin of its space. */
static void test_corpus_point_lights(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e = {0};
    memset(&s, 0, sizeof s);
    if (rib_load(test_source_path("tests/rib-corpus/aqsis/tools/displays/xpm/teapotgeom.rib"), &s,
                 1, &e) != TS_OK)
        fail_msg("%s", e.msg);
    const double want[3][4] = {{204.187, -437.336, 53.0255, 150000},
                               {-320.159, -429.109, -87.5622, 100000},
                               {121.927, 4.77862, 516.121, 100000}};
    for (int k = 0; k < 3; k++) {
        const ts_scene_light *l = &s.lights[k];
        assert_int_equal(l->kind, SCENE_LIGHT_POINT);
        for (int c = 0; c < 3; c++)
            if (!(fabs(l->from[c] - want[k][c]) < 1e-9))
                fail_msg("light %d: from[%d] %g", k, c, l->from[c]);
        assert_true(l->intensity == want[k][3]);
    }
    scene_free(&s);
}

/* scene/teapots.rib, the scene written to show issue 16's requests: frame 1 (the default)
 * and frame 2 hold the same world, the floor and four of the five teapots (the fifth is
 * fully transparent), in perspective through a ScreenWindow with Exposure, and from above
 * orthographically. */
static void test_feature_scene(void **state)
{
    (void)state;
    for (int frame = -1; frame <= 2; frame++) {
        if (frame == 0) continue;
        ts_scene s;
        ts_error e = {0};
        memset(&s, 0, sizeof s);
        if (scene_load_frame(test_source_path("scene/teapots.rib"), frame, &s, 1, &e) != TS_OK)
            fail_msg("frame %d: %s", frame, e.msg);
        int top = frame == 2;
        assert_int_equal(s.patch_count, 1 + 4 * 32);
        assert_int_equal(s.camera.projection,
                         top ? TS_PROJECTION_ORTHOGRAPHIC : TS_PROJECTION_PERSPECTIVE);
        assert_int_equal(s.camera.width, top ? 512 : 960);
        assert_int_equal(s.camera.has_screen, 1);
        assert_int_equal(s.camera.has_exposure, !top);
        assert_int_equal(s.camera.spp, 4);
        uint32_t metal = 0, constant = 0;
        for (uint32_t p = 0; p < s.patch_count; p++)
            metal += s.attr[p].material == TS_MAT_METAL, constant += s.attr[p].le_b > 0.0f;
        assert_int_equal(metal, 64);
        assert_int_equal(constant, 32);
        scene_free(&s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_corpus_loads),
        cmocka_unit_test(test_corpus_details),
        cmocka_unit_test(test_corpus_point_lights),
        cmocka_unit_test(test_feature_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
