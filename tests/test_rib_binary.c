/* test_rib_binary.c — binary RIB (issue 39 item 1; RI Spec 3.2 Appendix C.2): every scene in
 * scene/, encoded by the test-side encoder (support/rib_encode.c, its own tokenizer), all
 * binary, half binary and half ASCII, and gzipped, parses to the same scene as its ASCII
 * form (patch points, normals, attributes, transforms, lights, camera compared exactly);
 * an archive in binary and gzip; each number form decodes to its value; truncated and
 * damaged binary gives exact messages with the byte offset, and every prefix of an encoded
 * scene fails cleanly or parses; one scene renders the same bytes of .exr from both forms
 * (that test alone is skipped without an OpenCL device). */
#include "rib_encode.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* ---- helpers -------------------------------------------------------------------------- */

static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("%s: cannot open", path);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    buf[n] = '\0';
    *len = (size_t)n;
    return buf;
}

static void write_file(const char *path, const void *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b, 1, n, f), n);
    fclose(f);
}

static unsigned char *gzip_bytes(const void *in, size_t len, size_t *out_len)
{
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    assert_int_equal(deflateInit2(&zs, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
    size_t cap = deflateBound(&zs, (uLong)len) + 64;
    unsigned char *out = malloc(cap);
    assert_non_null(out);
    zs.next_in = (Bytef *)(uintptr_t)in;
    zs.avail_in = (uInt)len;
    zs.next_out = out;
    zs.avail_out = (uInt)cap;
    assert_int_equal(deflate(&zs, Z_FINISH), Z_STREAM_END);
    *out_len = zs.total_out;
    deflateEnd(&zs);
    return out;
}

/* Parses len bytes as the file `name` (relative paths resolve against it). */
static int parse_named(const char *name, const void *b, size_t len, ts_scene *s, ts_error *e)
{
    memset(s, 0, sizeof *s);
    memset(e, 0, sizeof *e);
    return rib_parse_string(name, (const char *)b, len, s, 1, e);
}

static void parse_ok(const char *name, const void *b, size_t len, ts_scene *s)
{
    ts_error e;
    if (parse_named(name, b, len, s, &e) != TS_OK) fail_msg("%s: %s", name, e.msg);
}

static void expect_error(const void *b, size_t len, const char *msg)
{
    ts_scene s;
    ts_error e;
    assert_int_equal(parse_named("t.rib", b, len, &s, &e), TS_E_SCENE);
    if (strcmp(e.msg, msg) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    assert_int_equal(s.patch_count, 0);
    ts_error_clear(&e);
}

#define SAME(field) assert_memory_equal(&a->field, &b->field, sizeof a->field)

static void assert_same_camera(const ts_camera *a, const ts_camera *b)
{
    SAME(world_to_camera);
    SAME(moving);
    if (a->moving) SAME(world_to_camera1);
    SAME(fov_deg);
    SAME(width);
    SAME(height);
    SAME(has_format);
    SAME(spp);
    SAME(clip_near);
    SAME(clip_far);
    SAME(shutter);
    SAME(crop);
    SAME(projection);
    SAME(has_screen);
    SAME(screen);
    SAME(has_exposure);
    SAME(exposure_gain);
    SAME(exposure_gamma);
}

/* The two scenes are the same, array for array, bit for bit. */
static void assert_same_scene(const ts_scene *a, const ts_scene *b)
{
    size_t n = a->patch_count;
    assert_int_equal(a->patch_count, b->patch_count);
    assert_memory_equal(a->cp, b->cp, n * 16 * sizeof(ts_vec4));
    assert_int_equal(a->cp1 != NULL, b->cp1 != NULL);
    if (a->cp1) assert_memory_equal(a->cp1, b->cp1, n * 16 * sizeof(ts_vec4));
    assert_memory_equal(a->corner_n, b->corner_n, n * 4 * sizeof(ts_vec4));
    assert_memory_equal(a->mid_n, b->mid_n, n * 5 * sizeof(ts_vec4));
    assert_memory_equal(a->attr, b->attr, n * sizeof(ts_patch_attr));
    assert_int_equal(a->xform_count, b->xform_count);
    assert_memory_equal(a->xform, b->xform, a->xform_count * sizeof(ts_xform));
    assert_int_equal(a->shape != NULL, b->shape != NULL);
    if (a->shape) assert_memory_equal(a->shape, b->shape, n * sizeof(uint32_t));
    assert_int_equal(a->texture_count, b->texture_count);
    for (uint32_t k = 0; k < a->texture_count; k++)
        assert_string_equal(a->tex_source[k], b->tex_source[k]);
    assert_int_equal(a->light_count, b->light_count);
    for (uint32_t k = 0; k < a->light_count; k++) {
        const ts_scene_light *x = &a->lights[k], *y = &b->lights[k];
        assert_memory_equal(x->from, y->from, sizeof x->from);
        assert_memory_equal(x->to, y->to, sizeof x->to);
        assert_memory_equal(x->color, y->color, sizeof x->color);
        assert_true(x->intensity == y->intensity && x->angle == y->angle && x->kind == y->kind);
        assert_true(x->cone_angle == y->cone_angle && x->cone_delta == y->cone_delta &&
                    x->beam == y->beam && x->falloff == y->falloff);
    }
    assert_int_equal(a->dome.present, b->dome.present);
    assert_true(a->dome.intensity == b->dome.intensity);
    assert_memory_equal(a->dome.color, b->dome.color, sizeof a->dome.color);
    assert_string_equal(a->dome.mapname, b->dome.mapname);
    assert_same_camera(&a->camera, &b->camera);
}

/* ---- every scene ---------------------------------------------------------------------- */

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* One scene file: ASCII, binary, mixed and gzipped binary parse to the same scene. */
static void check_scene(const char *path)
{
    size_t len, blen, mlen, zlen;
    char *text = read_file(path, &len);
    unsigned char *bin = rib_encode(text, len, RIB_ENCODE_BINARY, &blen);
    unsigned char *mixed = rib_encode(text, len, RIB_ENCODE_MIXED, &mlen);
    assert_non_null(bin);
    assert_non_null(mixed);
    unsigned char *z = gzip_bytes(bin, blen, &zlen);
    /* The encoding is binary: it starts with a request definition after the header. */
    assert_int_equal(bin[16], 0314);
    ts_scene ref, s;
    parse_ok(path, text, len, &ref);
    assert_true(ref.patch_count > 0);
    const void *forms[3] = {bin, mixed, z};
    size_t lens[3] = {blen, mlen, zlen};
    for (int f = 0; f < 3; f++) {
        parse_ok(path, forms[f], lens[f], &s);
        assert_same_scene(&ref, &s);
        scene_free(&s);
    }
    printf("%s: %u patches; %zu bytes ASCII, %zu binary, %zu mixed\n", path, ref.patch_count, len,
           blen, mlen);
    scene_free(&ref);
    free(z), free(mixed), free(bin), free(text);
}

static void test_every_scene(void **state)
{
    (void)state;
    const char *dir = test_source_path("scene");
    DIR *d = opendir(dir);
    if (!d) fail_msg("%s: cannot open", dir);
    char *names[256];
    int count = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".rib") != 0) continue;
        assert_true(count < 256);
        names[count++] = strdup(e->d_name);
    }
    closedir(d);
    qsort(names, (size_t)count, sizeof *names, by_name);
    assert_true(count >= 20);
    for (int i = 0; i < count; i++) {
        char path[4400];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        check_scene(path);
        free(names[i]);
    }
}

/* A binary, gzipped archive read by an ASCII file (ReadArchive) and by a binary one
 * (Procedural "DelayedReadArchive") gives the scene of the plain teapot. */
static void test_binary_archive(void **state)
{
    (void)state;
    size_t len, blen, zlen;
    char *text = read_file(test_source_path("scene/teapot.rib"), &len);
    ts_scene ref, s;
    parse_ok("t.rib", text, len, &ref);
    const char *world = strstr(text, "WorldBegin");
    assert_non_null(world);
    size_t head = (size_t)(world - text);
    unsigned char *bin = rib_encode(world, len - head, RIB_ENCODE_BINARY, &blen);
    assert_non_null(bin);
    unsigned char *z = gzip_bytes(bin, blen, &zlen);
    const char *dir = test_scratch_dir();
    char path[4400], top[4400];
    snprintf(path, sizeof path, "%s/world.rib", dir);
    write_file(path, z, zlen);
    snprintf(top, sizeof top, "%s/top.rib", dir);
    FILE *f = fopen(top, "wb");
    assert_non_null(f);
    fwrite(text, 1, head, f);
    fputs("ReadArchive \"world.rib\"\n", f);
    fclose(f);
    memset(&s, 0, sizeof s);
    ts_error e = {0};
    if (rib_load(top, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_same_scene(&ref, &s);
    scene_free(&s);
    /* The top file itself binary, its archive through DelayedReadArchive. */
    char call[8000];
    snprintf(call, sizeof call,
             "%.*sProcedural \"DelayedReadArchive\" [\"world.rib\"] [-9 9 -9 9 -9 9]\n", (int)head,
             text);
    size_t clen;
    unsigned char *cbin = rib_encode(call, strlen(call), RIB_ENCODE_BINARY, &clen);
    assert_non_null(cbin);
    write_file(top, cbin, clen);
    memset(&s, 0, sizeof s);
    if (rib_load(top, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_same_scene(&ref, &s);
    scene_free(&s);
    scene_free(&ref);
    free(cbin), free(z), free(bin), free(text);
}

/* ---- number forms --------------------------------------------------------------------- */

/* Translate a b c written with hand-made binary numbers, then a unit bilinear patch: its
 * first point lands at (a, b, c). */
static void check_translate(const unsigned char *nums, size_t n, float x, float y, float z)
{
    unsigned char buf[256];
    static const char pre[] = "WorldBegin Translate ";
    static const char post[] = "\nPatch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0]\nWorldEnd\n";
    memcpy(buf, pre, sizeof pre - 1);
    memcpy(buf + sizeof pre - 1, nums, n);
    memcpy(buf + sizeof pre - 1 + n, post, sizeof post - 1);
    ts_scene s;
    parse_ok("t.rib", buf, sizeof pre - 1 + n + sizeof post - 1, &s);
    assert_int_equal(s.patch_count, 1);
    if (!(s.cp[0].x == x && s.cp[0].y == y && s.cp[0].z == z))
        fail_msg("got (%.9g %.9g %.9g), want (%.9g %.9g %.9g)", s.cp[0].x, s.cp[0].y, s.cp[0].z, x,
                 y, z);
    scene_free(&s);
}

static void test_number_forms(void **state)
{
    (void)state;
    /* Integers of 1..4 bytes, signed: 5, -2 (0xfe), 300 (0x012c). */
    check_translate((const unsigned char *)"\200\005\200\376\201\001\054", 7, 5, -2, 300);
    /* -70000 in 3 bytes, 2^24 - 1 in 4 (3 would read as -1), 0 in 1. */
    check_translate((const unsigned char *)"\202\376\356\220\203\000\377\377\377\200\000", 11,
                    -70000, 16777215, 0);
    /* Fixed point, signed: 0204 (.b) 0x40 = 0.25, 0x80 = -0.5; 0205 (b.b) 0xff 0x80 = -0.5;
     * 0214 (.__b) 0x01 = 2^-24. */
    check_translate((const unsigned char *)"\204\100\205\377\200\214\001", 7, 0.25f, -0.5f,
                    0x1p-24f);
    check_translate((const unsigned char *)"\204\200\200\000\200\000", 6, -0.5f, 0, 0);
    /* 0213 (bb.bb, 4 bytes, 2 after the point) 0x0001 8000 = 1.5; float 0244 -2.25;
     * double 0245 0.1 (rounded to float in the patch). */
    check_translate((const unsigned char *)"\213\000\001\200\000\244\300\020\000\000"
                                           "\245\077\271\231\231\231\231\231\232",
                    19, 1.5f, -2.25f, 0.1f);
    /* A float array of 3 (0310) and an empty one (0310 0) for ScreenWindow's count check. */
    check_translate((const unsigned char *)"\310\003\077\200\000\000\100\000\000\000\100\100\000"
                                           "\000",
                    14, 1, 2, 3);
    /* Strings: short 0223 "Kd", a defined string used twice, a long string (0240). */
    static const unsigned char strs[] =
        "WorldBegin\n"
        "\315\007\225matte"
        "Surface \317\007 \222Kd [0.25]\n"
        "\316\001\000\230bilinear" /* string 256 (two-byte token 0316) */
        "\314\003\225Patch"
        "\246\003 \320\001\000 \240\001P [0 0 0 1 0 0 0 1 0 1 1 0]\n"
        "WorldEnd\n";
    ts_scene s;
    parse_ok("t.rib", strs, sizeof strs - 1, &s);
    assert_int_equal(s.patch_count, 1);
    assert_true(s.cp[15].x == 1.0f && s.cp[15].y == 1.0f);
    assert_int_equal(s.attr[0].material, TS_MAT_MATTE);
    scene_free(&s);
}

/* ---- errors --------------------------------------------------------------------------- */

static void test_errors(void **state)
{
    (void)state;
#define E(lit, msg) expect_error(lit, sizeof lit - 1, msg)
    E("Translate 1 2 \202\001", "t.rib:byte 14: error: binary RIB: an integer (byte 0202) needs "
                                "3 more bytes, only 1 are left (a truncated file)");
    E("Display \241\001", "t.rib:byte 8: error: binary RIB: a string length (byte 0241) needs 2 "
                          "more bytes, only 1 are left (a truncated file)");
    E("Display \240\050abc", "t.rib:byte 8: error: binary RIB: a string (byte 0240) needs 41 "
                             "more bytes, only 4 are left (a truncated file)");
    E("Color \310\003\000\000\000\000", "t.rib:byte 6: error: binary RIB: a float array of 3 "
                                        "values runs past the end of the file (a truncated file)");
    E("Color \244\000\000", "t.rib:byte 6: error: binary RIB: a float (byte 0244) needs 4 more "
                            "bytes, only 2 are left (a truncated file)");
    E("Color \245\000", "t.rib:byte 6: error: binary RIB: a double (byte 0245) needs 8 more "
                        "bytes, only 1 are left (a truncated file)");
    E("WorldBegin \246\011", "t.rib:byte 11: error: binary RIB: request code 9 is used before it "
                             "is defined (0314)");
    E("WorldBegin \246", "t.rib:byte 11: error: binary RIB: a request code (byte 0246) needs 1 "
                         "more bytes, only 0 are left (a truncated file)");
    E("Surface \320\001\002", "t.rib:byte 8: error: binary RIB: string token 258 is used before it "
                              "is defined (0315)");
    E("\314\001\2231ab", "t.rib:byte 0: error: binary RIB: request code 1 is defined as something "
                         "that is not a request name");
    E("\314\001\200\001", "t.rib:byte 2: error: binary RIB: a request definition (0314) must be "
                          "followed by a string");
    E("\315\001 \"x\"", "t.rib:byte 2: error: binary RIB: a string definition (0315, 0316) must be "
                        "followed by a string");
    E("Color \247", "t.rib:byte 6: error: binary RIB: reserved byte 0247 (0xa7)");
    E("Color \377", "t.rib:byte 6: error: binary RIB: reserved byte 0377 (0xff)");
    E("Color \244\177\200\000\000", "t.rib:byte 6: error: binary RIB: a number that is not finite");
    E("Color \310\001\377\300\000\000",
      "t.rib:byte 8: error: binary RIB: a number that is not finite");
    /* The handlers' messages name the byte of the binary argument at fault. */
    E("Translate \200\001 \200\002", "t.rib:1:1: error: Translate expects 3 numbers, got 2");
    E("\314\000\231Translate\246\000\200\001\200\002\200\003\200\004",
      "t.rib:byte 20: error: too many arguments to Translate");
    E("Projection \"perspective\" \"fov\" \310\001\103\064\000\000",
      "t.rib:byte 31: error: fov must be between 0 and 180 degrees, got 180");
    /* ASCII and binary positions in one file: an unterminated array named by both. */
    E("Color [ \200\001\nWorldBegin", "t.rib:1:7: error: unterminated array ('[' without ']' "
                                      "before WorldBegin at 2:1)");
    E("Color \310\002\000\000\000\000\000\000\000\000 [ 1 \314\000\226Sphere\246\000",
      "t.rib:1:18: error: unterminated array ('[' without ']' before Sphere at byte 30)");
#undef E
}

/* A binary WorldBegin (line 0, its byte the column) is a world block all the same: a file
 * whose world holds no geometry says so, not that it has no world block (rib_load checks the
 * whole scene). */
static void test_empty_binary_world(void **state)
{
    (void)state;
    static const char bin[] = "\314\000\232WorldBegin\246\000\314\001\230WorldEnd\246\001";
    char path[4400];
    snprintf(path, sizeof path, "%s/empty.rib", test_scratch_dir());
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bin, 1, sizeof bin - 1, f), sizeof bin - 1);
    fclose(f);
    ts_scene s;
    ts_error e;
    memset(&s, 0, sizeof s);
    memset(&e, 0, sizeof e);
    assert_int_equal(rib_load(path, &s, 1, &e), TS_E_SCENE);
    if (!strstr(e.msg, ": error: the world block holds no geometry: nothing to render"))
        fail_msg("got \"%s\"", e.msg);
    ts_error_clear(&e);
}

/* Every prefix of an encoded scene (and one byte changed at each place in its first 600)
 * either parses or fails with a message naming the file; never a crash (the sanitizer
 * build checks that there is no undefined behaviour either). */
static void test_truncated_and_damaged(void **state)
{
    (void)state;
    size_t len, blen;
    char *text = read_file(test_source_path("scene/lights.rib"), &len);
    unsigned char *bin = rib_encode(text, len, RIB_ENCODE_MIXED, &blen);
    assert_non_null(bin);
    int failed = 0;
    for (size_t k = 0; k <= blen; k++) {
        unsigned char *copy = malloc(k ? k : 1); /* exact size: ASan sees a read past it */
        assert_non_null(copy);
        memcpy(copy, bin, k);
        ts_scene s;
        ts_error e;
        int rc = parse_named("t.rib", copy, k, &s, &e);
        if (rc != TS_OK) {
            failed++;
            assert_int_equal(rc, TS_E_SCENE);
            assert_true(strncmp(e.msg, "t.rib:", 6) == 0);
            ts_error_clear(&e);
        }
        scene_free(&s);
        free(copy);
    }
    assert_true(failed > (int)blen / 2);
    for (size_t k = 0; k < blen && k < 600; k++) {
        unsigned char *copy = malloc(blen);
        assert_non_null(copy);
        memcpy(copy, bin, blen);
        copy[k] ^= 0xa5;
        ts_scene s;
        ts_error e;
        if (parse_named("t.rib", copy, blen, &s, &e) != TS_OK) {
            assert_true(strncmp(e.msg, "t.rib:", 6) == 0);
            ts_error_clear(&e);
        }
        scene_free(&s);
        free(copy);
    }
    free(bin), free(text);
}

/* ---- the same image ------------------------------------------------------------------- */

/* The EXR's bytes, but for the value of its "tessera:job" attribute: the resume key, which
 * hashes the scene file's own bytes (host/app/resume.c job_hash) and so differs by design. */
static void blank_job(char *b, size_t n)
{
    static const char key[] = "tessera:job\0int\0\4\0\0\0";
    char *at = memmem(b, n, key, sizeof key - 1);
    assert_non_null(at);
    assert_true((size_t)(at - b) + sizeof key - 1 + 4 <= n);
    memset(at + sizeof key - 1, 0, 4);
}

/* one_patch.rib rendered from its ASCII and its binary form: the same PNG bytes, the same
 * EXR bytes (but the resume key) and the same pixels. */
static void test_render_same_bytes(void **state)
{
    (void)state;
    if (!test_has_device()) skip();
    size_t len, blen;
    char *text = read_file(test_source_path("scene/one_patch.rib"), &len);
    unsigned char *bin = rib_encode(text, len, RIB_ENCODE_BINARY, &blen);
    assert_non_null(bin);
    const char *dir = test_scratch_dir();
    static const char *const form[2] = {"ascii", "binary"};
    char rib[2][4400], exr[2][4400], png[2][4400];
    for (int k = 0; k < 2; k++) {
        snprintf(rib[k], sizeof rib[k], "%s/%s.rib", dir, form[k]);
        snprintf(exr[k], sizeof exr[k], "%s/%s.exr", dir, form[k]);
        snprintf(png[k], sizeof png[k], "%s/%s.png", dir, form[k]);
        write_file(rib[k], k ? (const void *)bin : text, k ? blen : len);
        for (int f = 0; f < 2; f++)
            test_tessera_ok(dir, "render '%s' -o '%s' --quiet --res 48x48 --spp 2", rib[k],
                            f ? png[k] : exr[k]);
    }
    size_t n0, n1;
    char *b0 = read_file(png[0], &n0), *b1 = read_file(png[1], &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(b0, b1, n0);
    free(b0), free(b1);
    b0 = read_file(exr[0], &n0), b1 = read_file(exr[1], &n1);
    assert_int_equal(n0, n1);
    assert_true(memcmp(b0, b1, n0) != 0); /* the resume keys differ, */
    blank_job(b0, n0);
    blank_job(b1, n1);
    assert_memory_equal(b0, b1, n0); /* and nothing else */
    test_assert_same_pixels(exr[0], exr[1]);
    free(b0), free(b1), free(bin), free(text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),        cmocka_unit_test(test_binary_archive),
        cmocka_unit_test(test_number_forms),       cmocka_unit_test(test_errors),
        cmocka_unit_test(test_empty_binary_world), cmocka_unit_test(test_truncated_and_damaged),
        cmocka_unit_test(test_render_same_bytes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
