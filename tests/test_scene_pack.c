/* test_scene_pack.c — a scene packed into one block and unpacked (host/scene/scene_pack.c,
 * what rank 0 of an MPI render broadcasts) is the scene loaded, array for array: the
 * textured scene (textures, tiles, source names), a moving patch with transforms and
 * explicit normals, the teapot (lights, dome), point and spot lights, object instances; a
 * block cut short, with another magic or a length that points past its end is refused and
 * leaves the scene zeroed. Host only. */
#include "test_support.h"
#include "scene/scene_load.h"
#include "scene/scene_pack.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* a and b hold the same arrays and fields. */
static void assert_same_scene(const ts_scene *a, const ts_scene *b)
{
    uint64_t n = a->patch_count;
    assert_int_equal(a->patch_count, b->patch_count);
    assert_memory_equal(a->cp, b->cp, n * 16 * sizeof(ts_vec4));
    assert_int_equal(a->cp1 != NULL, b->cp1 != NULL);
    if (a->cp1) assert_memory_equal(a->cp1, b->cp1, n * 16 * sizeof(ts_vec4));
    assert_int_equal(a->corner_n != NULL, b->corner_n != NULL);
    if (a->corner_n) assert_memory_equal(a->corner_n, b->corner_n, n * 4 * sizeof(ts_vec4));
    if (a->mid_n) assert_memory_equal(a->mid_n, b->mid_n, n * 5 * sizeof(ts_vec4));
    assert_memory_equal(a->attr, b->attr, n * sizeof(ts_patch_attr));
    assert_int_equal(a->xform_count, b->xform_count);
    if (a->xform_count) assert_memory_equal(a->xform, b->xform, a->xform_count * sizeof(ts_xform));
    assert_int_equal(a->texture_count, b->texture_count);
    assert_int_equal(a->tex_tile_count, b->tex_tile_count);
    for (uint32_t i = 0; i < a->texture_count; ++i)
        assert_string_equal(a->tex_source[i], b->tex_source[i]);
    if (a->texture_count) {
        assert_memory_equal(a->textures, b->textures, a->texture_count * sizeof(ts_texture));
        assert_memory_equal(a->tex_pool, b->tex_pool,
                            (size_t)a->tex_tile_count * TS_TEX_TILE * TS_TEX_TILE *
                                sizeof(ts_vec4));
        assert_memory_equal(a->tex_pages, b->tex_pages, a->tex_tile_count * sizeof(uint32_t));
    }
    assert_memory_equal(&a->camera, &b->camera, sizeof a->camera);
    assert_int_equal(a->light_count, b->light_count);
    if (a->light_count)
        assert_memory_equal(a->lights, b->lights, a->light_count * sizeof(ts_scene_light));
    ts_dome_light da = a->dome, db = b->dome; /* the maps made in memory: their texels */
    assert_true(!da.map == !db.map);
    if (da.map)
        assert_memory_equal(da.map, db.map,
                            (size_t)da.map_width * da.map_height * 3 * sizeof(float));
    da.map = db.map = NULL;
    assert_memory_equal(&da, &db, sizeof da);
    for (uint32_t i = 0; i < a->patch_count; ++i) {
        ts_box x = scene_patch_box(a, i), y = scene_patch_box(b, i);
        assert_memory_equal(&x, &y, sizeof x);
    }
}

static void round_trip(ts_scene *s)
{
    void *block;
    size_t size;
    ts_error err = {0};
    if (scene_pack(s, &block, &size, &err)) fail_msg("%s", err.msg);
    ts_scene back;
    if (scene_unpack(block, size, &back, &err)) fail_msg("%s", err.msg);
    assert_same_scene(s, &back);
    scene_free(&back);
    free(block);
}

static void test_scenes_survive_the_round_trip(void **state)
{
    (void)state;
    const char *files[] = {"scene/textured.rib",         "scene/teapot.rib",
                           "scene/teapot_displaced.rib", "scene/lights.rib",
                           "scene/instances.rib",        "scene/daylight.rib"};
    for (size_t i = 0; i < sizeof files / sizeof *files; ++i) {
        ts_scene s;
        memset(&s, 0, sizeof s);
        ts_error err = {0};
        if (scene_load(test_source_path(files[i]), &s, 1, &err)) fail_msg("%s", err.msg);
        round_trip(&s);
        scene_free(&s);
    }
    /* A moving patch under a transform, with explicit corner normals, and a dome. */
    ts_scene s;
    test_parse_rib_ok("LightSource \"domelight\" 1 \"float intensity\" [0.5]\n"
                      "WorldBegin\nTranslate 0 0 5\n"
                      "Displacement \"fbm\" \"float amplitude\" [0.1]\n"
                      "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 0.2 0 0\nMotionEnd\n"
                      "Patch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] "
                      "\"N\" [0 0 1 0 0 1 0.1 0 1 0 0.1 1]\nWorldEnd\n",
                      &s);
    assert_non_null(s.cp1);
    assert_true(s.xform_count > 0);
    round_trip(&s);
    scene_free(&s);
}

static void expect_refused(const void *block, size_t size)
{
    ts_scene s;
    ts_error err = {0};
    assert_int_equal(scene_unpack(block, size, &s, &err), TS_E_USAGE);
    assert_non_null(strstr(err.msg, "damaged or of another version"));
    ts_scene zero;
    memset(&zero, 0, sizeof zero);
    assert_memory_equal(&s, &zero, sizeof s);
    ts_error_clear(&err);
}

static void test_damaged_blocks_are_refused(void **state)
{
    (void)state;
    ts_scene s;
    memset(&s, 0, sizeof s);
    ts_error err = {0};
    if (scene_load(test_source_path("scene/textured.rib"), &s, 1, &err)) fail_msg("%s", err.msg);
    unsigned char *block;
    size_t size;
    if (scene_pack(&s, (void **)&block, &size, &err)) fail_msg("%s", err.msg);
    expect_refused(block, size - 1);
    expect_refused(block, 12);
    block[0] ^= 1; /* the magic */
    expect_refused(block, size);
    block[0] ^= 1;
    uint64_t huge = (uint64_t)1 << 40; /* the first section's length past the end */
    memcpy(block + 16, &huge, 8);
    expect_refused(block, size);
    free(block);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scenes_survive_the_round_trip),
        cmocka_unit_test(test_damaged_blocks_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
