/* test_rib_requests.c — the RIB reader on files as others write them (issues 15 and 16): CR,
 * LF and CR LF line endings, a UTF-8 byte order mark, gzip by content, binary RIB after an ASCII
 * header. Host only: never skips. Every test asserts numbers or exact messages. */
#include "app/render.h"
#include "base/mat4.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include <setjmp.h>
#include <cmocka.h>
#include "test_support.h"

/* ---- helpers -------------------------------------------------------------------------- */

#define UNIT_QUAD "Patch \"bilinear\" \"P\" [0 0 0  1 0 0  0 1 0  1 1 0]\n"

/* Parses len bytes named "t.rib"; the scene is zeroed first. */
static int parse_bytes(const char *text, size_t len, ts_scene *s, ts_error *e)
{
    memset(s, 0, sizeof *s);
    memset(e, 0, sizeof *e);
    return rib_parse_string("t.rib", text, len, s, 1, e);
}

/* len bytes must fail with exactly msg; the scene is left empty. */
static void expect_bytes_error(const char *text, size_t len, const char *msg)
{
    ts_scene s;
    ts_error e;
    assert_int_equal(parse_bytes(text, len, &s, &e), TS_E_SCENE);
    if (strcmp(e.msg, msg) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, msg);
    assert_int_equal(s.patch_count, 0);
    ts_error_clear(&e);
}

/* The two scenes hold the same patches, bit for bit. */
static void assert_same_patches(const ts_scene *a, const ts_scene *b)
{
    assert_int_equal(a->patch_count, b->patch_count);
    assert_memory_equal(a->cp, b->cp, (size_t)a->patch_count * 16 * sizeof(ts_vec4));
    assert_memory_equal(a->corner_n, b->corner_n, (size_t)a->patch_count * 4 * sizeof(ts_vec4));
}

/* The whole of a file into a malloc'd buffer. */
static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return buf;
}

/* text (len bytes) gzip-compressed by zlib into a malloc'd buffer. */
static unsigned char *gzip_bytes(const char *text, size_t len, size_t *out_len)
{
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    assert_int_equal(deflateInit2(&zs, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
    size_t cap = deflateBound(&zs, (uLong)len) + 64;
    unsigned char *out = malloc(cap);
    assert_non_null(out);
    zs.next_in = (Bytef *)text;
    zs.avail_in = (uInt)len;
    zs.next_out = out;
    zs.avail_out = (uInt)cap;
    assert_int_equal(deflate(&zs, Z_FINISH), Z_STREAM_END);
    *out_len = cap - zs.avail_out;
    deflateEnd(&zs);
    return out;
}

static void write_bytes(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    fclose(f);
}

static void write_text(const char *path, const char *text)
{
    write_bytes(path, text, strlen(text));
}

/* rib_load_with of path at `frame` with stderr captured (warnings, not quiet) into a static buffer.
 */
static const char *load_capturing(const char *path, int frame, ts_scene *s, ts_error *e, int *rc)
{
    static char out[4096];
    FILE *tmp = tmpfile();
    assert_non_null(tmp);
    fflush(stderr);
    int saved = dup(fileno(stderr));
    assert_true(saved >= 0 && dup2(fileno(tmp), fileno(stderr)) >= 0);
    memset(s, 0, sizeof *s);
    memset(e, 0, sizeof *e);
    ts_load_options lo;
    scene_load_options_defaults(&lo);
    lo.frame = frame;
    *rc = rib_load_with(path, &lo, s, e);
    fflush(stderr);
    dup2(saved, fileno(stderr));
    close(saved);
    rewind(tmp);
    size_t got = fread(out, 1, sizeof out - 1, tmp);
    out[got] = '\0';
    fclose(tmp);
    return out;
}

/* rib_load_with of path at `frame` must fail with exactly msg (with the path in front of ":"). */
static void expect_load_error(const char *path, int frame, const char *msg)
{
    ts_scene s;
    ts_error e;
    int rc;
    load_capturing(path, frame, &s, &e, &rc);
    assert_int_equal(rc, TS_E_SCENE);
    char want[4400];
    snprintf(want, sizeof want, "%s:%s", path, msg);
    if (strcmp(e.msg, want) != 0) fail_msg("got \"%s\", want \"%s\"", e.msg, want);
    assert_int_equal(s.patch_count, 0);
    ts_error_clear(&e);
}

/* ---- line endings and the byte order mark (issue 15 item 3) ---------------------------- */

/* text with every "\n" replaced by `eol`. */
static char *with_line_ends(const char *text, const char *eol)
{
    size_t n = strlen(text), k = strlen(eol), o = 0;
    char *out = malloc(n * k + 1);
    assert_non_null(out);
    for (size_t i = 0; i < n; i++) {
        if (text[i] == '\n') {
            memcpy(out + o, eol, k);
            o += k;
        } else {
            out[o++] = text[i];
        }
    }
    out[o] = '\0';
    return out;
}

/* LF, CR LF and a lone CR read alike: same patches, comments end at the line end, and an
 * error names the same line and column in all three. */
static void test_line_endings(void **state)
{
    (void)state;
    const char *text =
        "# a comment: Translate 9 9 9\nWorldBegin\n# another\nTranslate 1 2 3\n" UNIT_QUAD
        "Color [1 0 0] # the colour\n" UNIT_QUAD "WorldEnd\n";
    const char *bad = "WorldBegin\n# comment\n  Translate 1 2\nWorldEnd\n";
    const char *eols[] = {"\n", "\r\n", "\r"};
    ts_scene ref;
    test_parse_rib_ok(text, &ref);
    assert_int_equal(ref.patch_count, 2);
    assert_true(ref.cp[0].x == 1.0f && ref.cp[0].y == 2.0f && ref.cp[0].z == 3.0f);
    assert_true(ref.attr[1].cs_g == 0.0f);
    for (int k = 0; k < 3; k++) {
        char *t = with_line_ends(text, eols[k]);
        ts_scene s;
        ts_error e;
        if (parse_bytes(t, strlen(t), &s, &e) != TS_OK) fail_msg("%s", e.msg);
        assert_same_patches(&ref, &s);
        scene_free(&s);
        free(t);
        t = with_line_ends(bad, eols[k]);
        expect_bytes_error(t, strlen(t), "t.rib:3:3: error: Translate expects 3 numbers, got 2");
        free(t);
    }
    scene_free(&ref);
}

/* A UTF-8 byte order mark at the start is skipped; one anywhere else is not a token. */
static void test_byte_order_mark(void **state)
{
    (void)state;
    const char bom_text[] = "\xef\xbb\xbfWorldBegin\n" UNIT_QUAD "WorldEnd\n";
    ts_scene s;
    ts_error e;
    if (parse_bytes(bom_text, sizeof bom_text - 1, &s, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
    const char bom_error[] = "\xef\xbb\xbf  Frobnicate\n";
    expect_bytes_error(bom_error, sizeof bom_error - 1,
                       "t.rib:1:3: error: unknown request Frobnicate");
    const char late[] = "WorldBegin\n\xef\xbb\xbfWorldEnd\n";
    expect_bytes_error(late, sizeof late - 1,
                       "t.rib:byte 11: error: binary RIB: reserved byte 0357 (0xef)");
}

/* A binary token after an ASCII header is read as binary (test_rib_binary.c has the rest);
 * a truncated one is named by its byte offset. */
static void test_binary_rib_named(void **state)
{
    (void)state;
    const char bin[] = "##RenderMan RIB\nversion 3.03\n\x81\x02";
    expect_bytes_error(bin, sizeof bin - 1,
                       "t.rib:byte 29: error: binary RIB: an integer (byte 0201) needs 2 more "
                       "bytes, only 1 are left (a truncated file)");
    /* Bytes above 0x7f inside strings and comments are text. */
    const char utf8[] = "# caf\xc3\xa9\nDisplay \"caf\xc3\xa9.tif\" \"file\" \"rgb\"\n"
                        "WorldBegin\n" UNIT_QUAD "WorldEnd\n";
    ts_scene s;
    ts_error e;
    if (parse_bytes(utf8, sizeof utf8 - 1, &s, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
}

/* ---- gzip by content (issue 16 item 3) ------------------------------------------------- */

/* The teapot scene gzip-compressed loads to the same patches as the plain file, as a string,
 * as a file named .rib, and through ReadArchive of a .rib.gz; several members one after
 * another read as their concatenation. */
static void test_gzip(void **state)
{
    (void)state;
    size_t len, zlen;
    char *plain = read_file(test_source_path("scene/teapot.rib"), &len);
    unsigned char *z = gzip_bytes(plain, len, &zlen);
    assert_true(zlen < len / 2);
    ts_scene ref, s;
    ts_error e;
    if (parse_bytes(plain, len, &ref, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(ref.patch_count, 32);
    if (parse_bytes((const char *)z, zlen, &s, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_same_patches(&ref, &s);
    scene_free(&s);

    const char *dir = test_scratch_dir();
    char path[4200], top[4200];
    snprintf(path, sizeof path, "%s/teapot.rib", dir); /* gzip, though named .rib */
    write_bytes(path, z, zlen);
    memset(&s, 0, sizeof s);
    if (rib_load(path, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_same_patches(&ref, &s);
    scene_free(&s);

    /* The world block of the teapot as an archive, in two gzip members. */
    const char *world = strstr(plain, "WorldBegin");
    assert_non_null(world);
    size_t head = (size_t)(world - plain), half = (len - head) / 2, z1, z2;
    unsigned char *m1 = gzip_bytes(world, half, &z1),
                  *m2 = gzip_bytes(world + half, len - head - half, &z2);
    unsigned char *both = malloc(z1 + z2);
    assert_non_null(both);
    memcpy(both, m1, z1);
    memcpy(both + z1, m2, z2);
    snprintf(path, sizeof path, "%s/world.rib.gz", dir);
    write_bytes(path, both, z1 + z2);
    snprintf(top, sizeof top, "%s/top.rib", dir);
    FILE *f = fopen(top, "wb");
    assert_non_null(f);
    fwrite(plain, 1, head, f);
    fputs("ReadArchive \"world.rib.gz\"\n", f);
    fclose(f);
    memset(&s, 0, sizeof s);
    if (rib_load(top, &s, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    assert_same_patches(&ref, &s);
    scene_free(&s);
    scene_free(&ref);
    free(both), free(m1), free(m2), free(z), free(plain);
}

/* Damaged gzip data is one clear error naming gzip, at 1:1 of the file that holds it. */
static void test_gzip_errors(void **state)
{
    (void)state;
    const char *text = "WorldBegin\n" UNIT_QUAD "WorldEnd\n";
    size_t zlen;
    unsigned char *z = gzip_bytes(text, strlen(text), &zlen);
    expect_bytes_error((const char *)z, zlen - 12,
                       "t.rib:1:1: error: gzip: the compressed data ends early (a truncated file)");
    unsigned char *bad = malloc(zlen + 4);
    assert_non_null(bad);
    memcpy(bad, z, zlen);
    bad[12] ^= 0xff; /* inside the deflate stream */
    ts_scene s;
    ts_error e;
    assert_int_equal(parse_bytes((const char *)bad, zlen, &s, &e), TS_E_SCENE);
    assert_true(strncmp(e.msg, "t.rib:1:1: error: gzip: ", 24) == 0);
    ts_error_clear(&e);
    memcpy(bad, z, zlen);
    memcpy(bad + zlen, "junk", 4);
    expect_bytes_error((const char *)bad, zlen + 4,
                       "t.rib:1:1: error: gzip: data that is not gzip follows the compressed "
                       "data");
    /* What the gzip data holds is read like any RIB: errors name its lines. */
    const char *wrong = "WorldBegin\n\nTranslate 1\n";
    free(z);
    z = gzip_bytes(wrong, strlen(wrong), &zlen);
    expect_bytes_error((const char *)z, zlen,
                       "t.rib:3:1: error: Translate expects 3 numbers, got 1");
    free(z);
    free(bad);
}

/* ---- FrameBegin/FrameEnd and --frame (issue 16 item 3) ------------------------------- */

/* Frame k has Format 10k x 10k and k patches; options before the first frame are shared. */
static const char *const frames_text =
    "PixelSamples 2 3\n"
    "FrameBegin 1\nFormat 10 10 1\nWorldBegin\n" UNIT_QUAD "WorldEnd\nFrameEnd\n"
    "FrameBegin 2\nFormat 20 20 1\nWorldBegin\n" UNIT_QUAD UNIT_QUAD "WorldEnd\nFrameEnd\n"
    "FrameBegin 3\n  Format 30 30 1\n  WorldBegin\n  Frobnicate 1\n" UNIT_QUAD UNIT_QUAD UNIT_QUAD
    "  WorldEnd\nFrameEnd\n";

/* One frame is read: the first by default, or the one asked for; the others' requests are
 * not run (frame 3 has an unknown request, which fails only frame 3). */
static void test_frames(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/anim.rib", test_scratch_dir());
    write_text(path, frames_text);
    const int frame[] = {-1, 1, 2};
    const uint32_t patches[] = {1, 1, 2};
    for (int k = 0; k < 3; k++) {
        ts_scene s;
        ts_error e;
        int rc;
        load_capturing(path, frame[k], &s, &e, &rc);
        if (rc != TS_OK) fail_msg("frame %d: %s", frame[k], e.msg);
        assert_int_equal(s.patch_count, patches[k]);
        assert_int_equal(s.camera.width, 10 * (int)patches[k]);
        assert_int_equal(s.camera.spp, 6);
        scene_free(&s);
    }
    ts_scene s;
    ts_error e;
    int rc;
    load_capturing(path, 3, &s, &e, &rc);
    assert_int_equal(rc, TS_E_SCENE);
    assert_non_null(strstr(e.msg, ":18:3: error: unknown request Frobnicate"));
    ts_error_clear(&e);
    expect_load_error(path, 7, "24:1: error: no frame 7: the file's frames are 1, 2, 3");
    /* Without frames, only the default may be asked for. */
    snprintf(path, sizeof path, "%s/still.rib", test_scratch_dir());
    write_text(path, "WorldBegin\n" UNIT_QUAD "WorldEnd\n");
    expect_load_error(path, 2,
                      "4:1: error: no frame 2: the file has no FrameBegin (render it without "
                      "--frame)");
    /* rib_parse_string reads the first frame too. */
    test_parse_rib_ok(frames_text, &s);
    assert_int_equal(s.patch_count, 1);
    scene_free(&s);
}

/* A shadow-map pass (a frame whose Display writes a depth map: type "zfile" or "shadow", or
 * mode "z") read by default is left for the next frame, its options and transformations
 * undone; a Display between frames belongs to the frame after it; --frame still reads the
 * pass; a file of passes only is read from its first frame. */
static void test_depth_pass_frames(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/passes.rib", test_scratch_dir());
    write_text(path, "Format 8 8 1\n"
                     "FrameBegin 1\nDisplay \"s.z\" \"zfile\" \"z\"\nFormat 10 10 1\n"
                     "Projection \"orthographic\"\nTranslate 0 0 9\n"
                     "WorldBegin\n" UNIT_QUAD "WorldEnd\nFrameEnd\n"
                     "MakeShadow \"s.z\" \"s.shd\"\n"
                     "Display \"t.shd\" \"shadow\" \"z\"\n"
                     "FrameBegin 2\nWorldBegin\n" UNIT_QUAD "WorldEnd\nFrameEnd\n"
                     "Display \"u.tif\" \"file\" \"rgb\"\n"
                     "FrameBegin 3\nDisplay \"+u.z\" \"zfile\" \"z\"\nProjection "
                     "\"perspective\" \"fov\" 40\nWorldBegin\n" UNIT_QUAD UNIT_QUAD
                     "WorldEnd\nFrameEnd\n");
    ts_scene s;
    ts_error e;
    int rc;
    const char *out = load_capturing(path, -1, &s, &e, &rc);
    if (rc != TS_OK) fail_msg("%s", e.msg);
    assert_int_equal(s.patch_count, 2); /* frame 3 */
    assert_int_equal(s.camera.width, 8);
    assert_int_equal(s.camera.projection, TS_PROJECTION_PERSPECTIVE);
    assert_true(s.camera.fov_deg == 40.0 && s.camera.world_to_camera[11] == 0.0);
    char want[2][4608];
    snprintf(want[0], sizeof want[0],
             "%s:3:1: warning: frame 1 renders a depth map (Display \"zfile\" \"z\"), a "
             "shadow-map pass Tessera does not need: the next frame is read (--frame 1 reads it)",
             path);
    snprintf(want[1], sizeof want[1],
             "%s:13:1: warning: frame 2 renders a depth map (Display \"shadow\" \"z\"), a "
             "shadow-map pass Tessera does not need: the next frame is read (--frame 2 reads it)",
             path);
    assert_non_null(strstr(out, want[0]));
    assert_non_null(strstr(out, want[1]));
    assert_non_null(strstr(out, "warning: MakeShadow is ignored"));
    scene_free(&s);
    load_capturing(path, 1, &s, &e, &rc);
    assert_int_equal(rc, TS_OK);
    assert_int_equal(s.patch_count, 1);
    assert_int_equal(s.camera.width, 10);
    assert_int_equal(s.camera.projection, TS_PROJECTION_ORTHOGRAPHIC);
    scene_free(&s);
    /* Passes only: the first frame, as before. */
    write_text(path,
               "FrameBegin 1\nDisplay \"s.z\" \"zfile\" \"z\"\nFormat 10 10 1\n"
               "WorldBegin\n" UNIT_QUAD "WorldEnd\nFrameEnd\n"
               "FrameBegin 2\nDisplay \"s.z\" \"shadow\" \"z\"\nWorldBegin\n" UNIT_QUAD UNIT_QUAD
               "WorldEnd\nFrameEnd\n");
    load_capturing(path, -1, &s, &e, &rc);
    assert_int_equal(rc, TS_OK);
    assert_int_equal(s.patch_count, 1);
    assert_int_equal(s.camera.width, 10);
    scene_free(&s);
}

static void test_frame_errors(void **state)
{
    (void)state;
    static const struct {
        const char *text, *msg;
    } cases[] = {
        {"FrameBegin 1\nFrameBegin 2\n",
         "t.rib:2:1: error: FrameBegin inside the frame 1 at 1:1 (missing FrameEnd)"},
        {"FrameEnd\n", "t.rib:1:1: error: FrameEnd without FrameBegin"},
        {"FrameBegin 1\nWorldBegin\nWorldEnd\n",
         "t.rib:1:1: error: FrameBegin is never closed (missing FrameEnd)"},
        {"WorldBegin\nFrameBegin 1\n",
         "t.rib:2:1: error: FrameBegin inside the block opened at 1:1 (a frame holds its world "
         "block, not the other way round)"},
        {"FrameBegin 1\nWorldBegin\nFrameEnd\n",
         "t.rib:2:1: error: WorldBegin is never closed (missing WorldEnd)"},
        {"FrameBegin 1.5\n",
         "t.rib:1:12: error: FrameBegin: the frame number must be an integer, got 1.5"},
        {"WorldBegin\nWorldEnd\nFrameBegin 1\nFrameEnd\n",
         "t.rib:3:1: error: FrameBegin after the world block at 1:1, which no frame holds"},
        /* Skipped frames are still read as tokens: a lexical error anywhere is an error. */
        {"FrameBegin 1\nFrameEnd\nFrameBegin 2\nColor [1 2\n",
         "t.rib:4:7: error: unterminated array ('[' without ']' before the end of file)"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++)
        expect_bytes_error(cases[k].text, strlen(cases[k].text), cases[k].msg);
}

/* ---- a file that makes no scene (issue 15 item 3) ------------------------------------- */

/* No world block, an empty one, comments only, a CR-only file whose world block was cut: one
 * clear error each; a scene without light loads with one warning. */
static void test_scene_checks(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    static const struct {
        const char *name, *text, *msg;
    } cases[] = {
        {"empty.rib", "",
         "1:1: error: the file ends without a world block (WorldBegin ... "
         "WorldEnd) and holds no geometry: nothing to render"},
        {"comments.rib", "##RenderMan RIB\n# nothing\n",
         "3:1: error: the file ends without a world block (WorldBegin ... WorldEnd) and holds "
         "no geometry: nothing to render"},
        {"options.rib", "Format 64 48 1\rProjection \"perspective\"\r",
         "3:1: error: the file ends without a world block (WorldBegin ... WorldEnd) and holds "
         "no geometry: nothing to render"},
        {"world.rib", "Format 64 48 1\n\n  WorldBegin\n  Color 1 0 0\nWorldEnd\n",
         "3:3: error: the world block holds no geometry: nothing to render"},
        {"frame.rib", "FrameBegin 4\nWorldBegin\nWorldEnd\nFrameEnd\n",
         "2:1: error: the world block of the frame read holds no geometry: nothing to render"},
    };
    char path[4200];
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, cases[k].name);
        write_text(path, cases[k].text);
        expect_load_error(path, -1, cases[k].msg);
    }
    snprintf(path, sizeof path, "%s/dark.rib", dir);
    write_text(path, "WorldBegin\n" UNIT_QUAD "WorldEnd\n");
    ts_scene s;
    ts_error e;
    int rc;
    const char *out = load_capturing(path, -1, &s, &e, &rc);
    assert_int_equal(rc, TS_OK);
    char want[4608];
    snprintf(want, sizeof want,
             "%s:1:1: warning: the scene has no light Tessera renders (LightSource "
             "\"distantlight\", \"pointlight\", \"spotlight\", \"ambientlight\" or "
             "\"domelight\", AreaLightSource, Surface \"constant\"): it is lit by a headlight "
             "at the camera, as RenderMan's default surface shows a scene without lights\n",
             path);
    assert_string_equal(out, want);
    /* The headlight: a point light at the eye (here the world origin), no distance falloff,
     * irradiance pi (a white matte surface facing it reflects radiance 1). */
    assert_int_equal(s.light_count, 1);
    assert_int_equal(s.lights[0].kind, SCENE_LIGHT_POINT);
    assert_true(s.lights[0].falloff == 0.0 && s.lights[0].intensity == M_PI);
    assert_true(s.lights[0].from[0] == 0.0 && s.lights[0].from[1] == 0.0 &&
                s.lights[0].from[2] == 0.0);
    scene_free(&s);
    /* With a camera transform and an orthographic projection: a distant light along the
     * view, from the eye at world (0, 0, -5) towards +z. */
    write_text(path,
               "Projection \"orthographic\"\nTranslate 0 0 5\nWorldBegin\n" UNIT_QUAD "WorldEnd\n");
    out = load_capturing(path, -1, &s, &e, &rc);
    assert_int_equal(rc, TS_OK);
    assert_int_equal(s.light_count, 1);
    assert_int_equal(s.lights[0].kind, SCENE_LIGHT_DISTANT);
    assert_true(fabs(s.lights[0].from[2] + 5.0) < 1e-12 && fabs(s.lights[0].to[2] + 4.0) < 1e-12);
    assert_true(s.lights[0].from[0] == s.lights[0].to[0] &&
                s.lights[0].from[1] == s.lights[0].to[1]);
    scene_free(&s);
    /* An area light is light, and so are point, spot and ambient lights. */
    const char *lit[] = {"AreaLightSource \"arealight\" 1\n", "LightSource \"pointlight\" 1\n",
                         "LightSource \"spotlight\" 1\n", "LightSource \"ambientlight\" 1\n"};
    for (size_t k = 0; k < sizeof lit / sizeof lit[0]; k++) {
        char text[256];
        snprintf(text, sizeof text, "WorldBegin\n%s" UNIT_QUAD "WorldEnd\n", lit[k]);
        write_text(path, text);
        out = load_capturing(path, -1, &s, &e, &rc);
        assert_int_equal(rc, TS_OK);
        assert_string_equal(out, "");
        scene_free(&s);
    }
}

/* `tessera render` of a file that makes no scene fails before any work: exit status 1, one
 * line naming the file and the reason, and the output that was there is left as it was. */
static void test_render_refuses_empty_scene(void **state)
{
    (void)state;
    const char *dir = test_scratch_dir();
    char scene[4200], out[4200];
    snprintf(scene, sizeof scene, "%s/cut.rib", dir);
    snprintf(out, sizeof out, "%s/out.png", dir);
    write_text(scene, "Format 64 48 1\rProjection \"perspective\"\rTranslate 0 0 5\r");
    write_text(out, "an existing image");
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s'", scene, out), 1);
    size_t n;
    char *err = read_file(test_path_in(dir, "stderr.txt"), &n);
    err[n] = '\0';
    char want[4400];
    snprintf(want, sizeof want,
             "tessera: %s:4:1: error: the file ends without a world block (WorldBegin ... "
             "WorldEnd) and holds no geometry: nothing to render\n",
             scene);
    assert_string_equal(err, want);
    free(err);
    char *kept = read_file(out, &n);
    assert_int_equal(n, strlen("an existing image"));
    assert_memory_equal(kept, "an existing image", n);
    free(kept);
    /* --frame names a frame the file lacks: the same. */
    write_text(scene, frames_text);
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' --frame 9", scene, out), 1);
    err = read_file(test_path_in(dir, "stderr.txt"), &n);
    err[n] = '\0';
    assert_non_null(strstr(err, "error: no frame 9: the file's frames are 1, 2, 3\n"));
    free(err);
}

/* ---- Format, ScreenWindow, Projection "orthographic", Exposure (issue 16 item 3) ------ */

static void test_format_defaults(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        int w, h;
    } cases[] = {{"Format 320 240 -1\n", 320, 240},
                 {"Format -1 -1 -1\n", 640, 480},
                 {"Format [800 -1 1]\n", 800, 480},
                 {"Format 0 200 0\n", 640, 200}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        ts_scene s;
        test_parse_rib_ok(cases[k].text, &s);
        assert_int_equal(s.camera.width, cases[k].w);
        assert_int_equal(s.camera.height, cases[k].h);
        assert_int_equal(s.camera.has_format, 1);
        scene_free(&s);
    }
    const char *bad = "Format 320 240.5 1\n";
    expect_bytes_error(bad, strlen(bad),
                       "t.rib:1:12: error: Format: yresolution must be an integer in [1, 65536] "
                       "(or -1: the default), got 240.5");
    const char *big = "Format 70000 10 1\n";
    expect_bytes_error(big, strlen(big),
                       "t.rib:1:8: error: Format: xresolution must be an integer in [1, 65536] "
                       "(or -1: the default), got 70000");
}

static void test_camera_requests(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("Projection \"orthographic\"\nScreenWindow -2 2 -1.5 1.5\nExposure 1.5 2.2\n"
                      "WorldBegin\nWorldEnd\n",
                      &s);
    assert_int_equal(s.camera.projection, TS_PROJECTION_ORTHOGRAPHIC);
    assert_int_equal(s.camera.has_screen, 1);
    assert_true(s.camera.screen[0] == -2 && s.camera.screen[1] == 2 && s.camera.screen[2] == -1.5 &&
                s.camera.screen[3] == 1.5);
    assert_int_equal(s.camera.has_exposure, 1);
    assert_true(s.camera.exposure_gain == 1.5 && s.camera.exposure_gamma == 2.2);
    scene_free(&s);
    /* Exposure 1 1 is no exposure at all (the image is left bit for bit as it was). */
    test_parse_rib_ok("Exposure 1 1\n", &s);
    assert_int_equal(s.camera.has_exposure, 0);
    assert_int_equal(s.camera.projection, TS_PROJECTION_PERSPECTIVE);
    scene_free(&s);
    static const struct {
        const char *text, *msg;
    } cases[] = {
        {"ScreenWindow 1 -1 -1 1",
         "t.rib:1:1: error: ScreenWindow: need left < right and bottom < top, got 1 -1 -1 1"},
        {"ScreenWindow -1 1 -1", "t.rib:1:1: error: ScreenWindow expects 4 numbers, got 3"},
        {"WorldBegin\nScreenWindow -1 1 -1 1", "t.rib:2:1: error: ScreenWindow must come before "
                                               "WorldBegin"},
        {"Exposure 1 0", "t.rib:1:1: error: Exposure: need gain >= 0 and gamma > 0, got 1 0"},
        {"Exposure -1 2", "t.rib:1:1: error: Exposure: need gain >= 0 and gamma > 0, got -1 2"},
        {"Projection \"fisheye\"", "t.rib:1:12: error: unknown projection \"fisheye\" "
                                   "(perspective, PxrPerspective, PxrCamera or orthographic)"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++)
        expect_bytes_error(cases[k].text, strlen(cases[k].text), cases[k].msg);
    int rc;
    const char *out = test_rib_warnings("Projection \"orthographic\" \"fov\" [30]\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:27: warning: Projection parameter \"fov\" is ignored\n");
    out = test_rib_warnings("GeometricRepresentation \"points\"\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:1: warning: GeometricRepresentation is ignored\n");
}

/* The camera kernel's ray through the centre of pixel (x, y), as kernels/camera.cl makes it
 * from ts_camera_params (one sample per pixel: no jitter). */
static void kernel_ray(const ts_camera_params *p, int x, int y, double org[3], double dir[3])
{
    float sx = 2.0f * ((float)x + 0.5f) / (float)p->width - 1.0f;
    float sy = 1.0f - 2.0f * ((float)y + 0.5f) / (float)p->height;
    float d[3], o[3];
    for (int k = 0; k < 3; k++) {
        o[k] = p->origin[k];
        if (p->projection == TS_PROJECTION_ORTHOGRAPHIC) {
            o[k] += sx * p->right[k] + sy * p->up[k];
            d[k] = p->forward[k];
        } else {
            d[k] = sx * p->right[k] + sy * p->up[k] + p->forward[k];
        }
    }
    float inv = 1.0f / sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        org[k] = o[k], dir[k] = d[k] * inv;
}

/* The ray through the centre of pixel (x, y) straight from the RenderMan definitions: the
 * screen point lerps the window (raster y down), perspective looks from the camera origin
 * through (sx tan(fov/2), sy tan(fov/2), 1), orthographic along +z from (sx, sy, 0); then to
 * world space. */
static void spec_ray(const ts_camera *c, int w, int h, int x, int y, double org[3], double dir[3])
{
    double a = (double)w / h, win[4] = {-a, a, -1, 1};
    if (a < 1) win[0] = -1, win[1] = 1, win[2] = -1 / a, win[3] = 1 / a;
    if (c->has_screen) memcpy(win, c->screen, sizeof win);
    double sx = win[0] + (win[1] - win[0]) * (x + 0.5) / w;
    double sy = win[3] - (win[3] - win[2]) * (y + 0.5) / h;
    double o[3] = {0, 0, 0}, d[3] = {0, 0, 1}, inv[16];
    if (c->projection == TS_PROJECTION_ORTHOGRAPHIC) {
        o[0] = sx, o[1] = sy;
    } else {
        double t = tan(c->fov_deg * M_PI / 360.0);
        d[0] = sx * t, d[1] = sy * t;
    }
    assert_true(mat4_invert(c->world_to_camera, inv));
    assert_true(mat4_point(inv, o, org));
    mat4_dir(inv, d, dir);
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (int k = 0; k < 3; k++)
        dir[k] /= len;
}

/* render_camera_params with the kernel's arithmetic gives the rays of the definition, for
 * perspective and orthographic cameras with and without a ScreenWindow; without one the
 * perspective parameters are those of before (forward = the camera's unit z axis). */
static void test_camera_rays(void **state)
{
    (void)state;
    static const char *const heads[] = {
        "Projection \"perspective\" \"fov\" [35]\n",
        "Projection \"perspective\" \"fov\" [35]\nScreenWindow -0.5 1.5 -0.25 0.75\n",
        "Projection \"orthographic\"\n",
        "Projection \"orthographic\"\nScreenWindow -3 1 2 4\n",
    };
    const char *camera =
        "Translate 0.5 -1 7\nRotate 30 1 0.5 0\nScale 2 2 2\nWorldBegin\nWorldEnd\n";
    const int sizes[2][2] = {{64, 36}, {30, 50}};
    for (int k = 0; k < 4; k++)
        for (int z = 0; z < 2; z++) {
            char text[512];
            snprintf(text, sizeof text, "%s%s", heads[k], camera);
            ts_scene s;
            test_parse_rib_ok(text, &s);
            ts_camera_params p;
            ts_error e = {0};
            int w = sizes[z][0], h = sizes[z][1];
            if (render_camera_params(&s.camera, w, h, &p, &e) != TS_OK) fail_msg("%s", e.msg);
            for (int y = 0; y < h; y += 7)
                for (int x = 0; x < w; x += 5) {
                    double ko[3], kd[3], so[3], sd[3];
                    kernel_ray(&p, x, y, ko, kd);
                    spec_ray(&s.camera, w, h, x, y, so, sd);
                    for (int d = 0; d < 3; d++)
                        if (fabs(ko[d] - so[d]) > 1e-5 || fabs(kd[d] - sd[d]) > 1e-6)
                            fail_msg("case %d size %d pixel (%d %d): kernel (%g %g %g)->(%g %g "
                                     "%g), spec (%g %g %g)->(%g %g %g)",
                                     k, z, x, y, ko[0], ko[1], ko[2], kd[0], kd[1], kd[2], so[0],
                                     so[1], so[2], sd[0], sd[1], sd[2]);
                }
            if (k == 0) { /* the default window: forward is the unit camera z axis */
                double inv[16], zc[3] = {0, 0, 1}, zw[3];
                assert_true(mat4_invert(s.camera.world_to_camera, inv));
                mat4_dir(inv, zc, zw);
                for (int d = 0; d < 3; d++)
                    assert_true(p.forward[d] == (float)zw[d]);
            }
            scene_free(&s);
        }
}

/* ---- Opacity, Geometry "teapot" (issue 16 item 3) -------------------------------------- */

/* Opacity 0 0 0 leaves geometry out (its attribute block restores opacity); partial opacity
 * renders opaque with one warning. */
/* A motion block around the camera transformation: the camera moves. ts_camera keeps both
 * world_to_camera samples and render_camera_params both sets of vectors, the second those of
 * a static camera at shutter close; a static camera leaves them zero. */
static void test_moving_camera_params(void **state)
{
    (void)state;
    ts_scene s;
    ts_error e = {0};
    const char *text = "Projection \"perspective\" \"fov\" [40]\nRotate 10 0 1 0\n"
                       "MotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\n"
                       "WorldBegin\n" UNIT_QUAD "WorldEnd\n";
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.camera.moving, 1);
    ts_camera_params moving, still;
    assert_int_equal(render_camera_params(&s.camera, 64, 48, &moving, &e), TS_OK);
    assert_int_equal(moving.moving, 1);
    scene_free(&s);
    test_parse_rib_ok("Projection \"perspective\" \"fov\" [40]\nRotate 10 0 1 0\n"
                      "Translate 1 0 5\nWorldBegin\n" UNIT_QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.camera.moving, 0);
    assert_int_equal(render_camera_params(&s.camera, 64, 48, &still, &e), TS_OK);
    assert_int_equal(still.moving, 0);
    for (int k = 0; k < 4; k++) {
        assert_true(moving.origin1[k] == still.origin[k] && moving.right1[k] == still.right[k]);
        assert_true(moving.up1[k] == still.up[k] && moving.forward1[k] == still.forward[k]);
        assert_true(still.origin1[k] == 0.0f && still.forward1[k] == 0.0f);
    }
    /* The eye: (0 0 -5) at shutter open, (-1 0 -5) at close (the rotation turns only the
     * axes: it acts after the translations). */
    assert_true(fabsf(moving.origin[0]) < 1e-6f && fabsf(moving.origin[2] + 5.0f) < 1e-5f);
    assert_true(fabsf(moving.origin1[0] + 1.0f) < 1e-6f && fabsf(moving.origin1[2] + 5.0f) < 1e-5f);
    scene_free(&s);
}

static void test_opacity(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nAttributeBegin\nOpacity [0 0 0]\n" UNIT_QUAD
                      "Geometry \"teapot\"\nMotionBegin [0 1]\n" UNIT_QUAD UNIT_QUAD
                      "MotionEnd\nAttributeEnd\n" UNIT_QUAD "Opacity 0 0 0\nAttributeBegin\n"
                      "Opacity 1 1 1\n" UNIT_QUAD "AttributeEnd\n" UNIT_QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 2);
    scene_free(&s);
    int rc;
    const char *out =
        test_rib_warnings("WorldBegin\nOpacity 0.5 0.5 0.5\n" UNIT_QUAD "Opacity [1 0 1]\n"
                          "WorldEnd\n",
                          &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:2:1: warning: Opacity between 0 and 1 renders opaque (only "
                             "Opacity 0 0 0, fully transparent, is honoured: that geometry is "
                             "left out)\n");
    const char *bad = "Opacity -1 0 0";
    expect_bytes_error(bad, strlen(bad), "t.rib:1:1: error: Opacity: -1 is outside [0, 1]");
}

/* Geometry "teapot" is the 32 patches of scene/teapot.rib (both from shared/data/teapot.txt:
 * one embedded, one written as RIB), moved by the CTM, with the current attributes. */
static void test_geometry_teapot(void **state)
{
    (void)state;
    ts_scene ref, s;
    ts_error e = {0};
    memset(&ref, 0, sizeof ref);
    if (rib_load(test_source_path("scene/teapot.rib"), &ref, 1, &e) != TS_OK) fail_msg("%s", e.msg);
    test_parse_rib_ok("WorldBegin\nGeometry \"teapot\"\nWorldEnd\n", &s);
    assert_same_patches(&ref, &s);
    scene_free(&s);
    test_parse_rib_ok("WorldBegin\nColor 0.25 0.5 1\nTranslate 1 -2 0.5\nScale 2 2 2\n"
                      "Geometry \"teapot\"\nWorldEnd\n",
                      &s);
    assert_int_equal(s.patch_count, 32);
    for (size_t k = 0; k < 32 * 16; k++) {
        const ts_vec4 *a = &ref.cp[k], *b = &s.cp[k];
        if (fabsf(b->x - (2 * a->x + 1)) > 1e-6f || fabsf(b->y - (2 * a->y - 2)) > 1e-6f ||
            fabsf(b->z - (2 * a->z + 0.5f)) > 1e-6f)
            fail_msg("control point %zu: (%g %g %g) from (%g %g %g)", k, b->x, b->y, b->z, a->x,
                     a->y, a->z);
    }
    assert_true(s.attr[31].cs_r == 0.25f && s.attr[31].cs_b == 1.0f);
    scene_free(&s);
    scene_free(&ref);
    const char *bad = "WorldBegin\nGeometry \"bunny\"\n";
    expect_bytes_error(bad, strlen(bad), "t.rib:2:10: error: unknown Geometry \"bunny\" (teapot)");
    int rc;
    const char *out = test_rib_warnings("Geometry \"teapot\" \"float size\" [2]\n", &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:1:19: warning: Geometry parameter \"size\" is ignored\n");
}

/* ---- surface and displacement shaders (issue 16 item 4) -------------------------------- */

/* The material, weights and emission of the one patch that `surface` gives. */
static ts_patch_attr surface_attr(const char *surface)
{
    char text[1024];
    snprintf(text, sizeof text, "WorldBegin\nColor 0.8 0.4 0.2\n%s\n" UNIT_QUAD "WorldEnd\n",
             surface);
    ts_scene s;
    test_parse_rib_ok(text, &s);
    assert_int_equal(s.patch_count, 1);
    ts_patch_attr a = s.attr[0];
    scene_free(&s);
    return a;
}

static void test_standard_surfaces(void **state)
{
    (void)state;
    static const struct {
        const char *surface;
        uint32_t material;
        float kd, ks, roughness, le;
    } cases[] = {
        {"Surface \"matte\"", TS_MAT_MATTE, 1.0f, 0.0f, 0.1f, 0.0f},
        {"Surface \"matte\" \"Kd\" 0.5", TS_MAT_MATTE, 0.5f, 0.0f, 0.1f, 0.0f},
        {"Surface \"plastic\"", TS_MAT_PLASTIC, 0.5f, 0.5f, 0.1f, 0.0f},
        {"Surface \"paintedplastic\" \"Ks\" [0.3] \"roughness\" 0.2", TS_MAT_PLASTIC, 0.5f, 0.3f,
         0.2f, 0.0f},
        {"Surface \"metal\"", TS_MAT_METAL, 0.0f, 1.0f, 0.1f, 0.0f},
        {"Surface \"metal\" \"Ks\" 0.7 \"roughness\" 0.3", TS_MAT_METAL, 0.0f, 0.7f, 0.3f, 0.0f},
        {"Surface \"shinymetal\" \"Kr\" 1 \"texturename\" \"env.tx\"", TS_MAT_METAL, 0.0f, 1.0f,
         0.1f, 0.0f},
        {"Surface \"constant\"", TS_MAT_MATTE, 0.0f, 0.0f, 0.1f, 0.8f},
        /* Kd + Ks > 1: scaled to sum 1; roughness 0: clamped to 0.01. */
        {"Surface \"plastic\" \"Kd\" 0.8 \"Ks\" 1 \"roughness\" 0", TS_MAT_PLASTIC, 0.8f / 1.8f,
         1.0f / 1.8f, 0.01f, 0.0f},
        {"Surface \"metal\" \"Ks\" 2", TS_MAT_METAL, 0.0f, 1.0f, 0.1f, 0.0f},
        /* Unknown: matte with its defaults, parameters unread. */
        {"Surface \"wood\" \"Kd\" 0.2", TS_MAT_MATTE, 1.0f, 0.0f, 0.1f, 0.0f},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        ts_patch_attr a = surface_attr(cases[k].surface);
        if (a.material != cases[k].material || fabsf(a.kd - cases[k].kd) > 1e-6f ||
            fabsf(a.ks - cases[k].ks) > 1e-6f || fabsf(a.roughness - cases[k].roughness) > 1e-6f ||
            fabsf(a.le_r - cases[k].le) > 1e-6f)
            fail_msg("%s: material %u Kd %g Ks %g roughness %g Le %g", cases[k].surface, a.material,
                     a.kd, a.ks, a.roughness, a.le_r);
    }
    /* constant emits its colour, "Cs" of the patch included, and reflects nothing. */
    ts_patch_attr c = surface_attr("Surface \"constant\"");
    assert_true(c.le_r == 0.8f && c.le_g == 0.4f && c.le_b == 0.2f && c.kd == 0.0f);
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nSurface \"constant\"\nPatch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 "
                      "0 1 1 0] \"constant color Cs\" [0 1 0.5]\nWorldEnd\n",
                      &s);
    assert_true(s.attr[0].le_r == 0.0f && s.attr[0].le_g == 1.0f && s.attr[0].le_b == 0.5f);
    scene_free(&s);
    const char *bad = "Surface \"plastic\" \"Kd\" -1";
    expect_bytes_error(bad, strlen(bad),
                       "t.rib:1:1: error: Surface \"plastic\": Kd and Ks must be >= 0 and finite, "
                       "got -1 0.5");
}

/* Each fallback says so once: unknown surface and displacement shaders alike. */
static void test_shader_warnings(void **state)
{
    (void)state;
    int rc;
    const char *out = test_rib_warnings(
        "Surface \"wood\" \"Kd\" 1 \"grain\" 3\nSurface \"wood\"\n"
        "Displacement \"dented\" \"Km\" 1\nDisplacement \"dented\"\n"
        "Surface \"plastic\" \"Kd\" 0.8 \"Ks\" 0.5\nSurface \"metal\" \"roughness\" 0\n"
        "Surface \"shinymetal\" \"texturename\" \"env.tx\"\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out,
                        "w.rib:1:1: warning: Surface \"wood\" is unknown: it renders as matte "
                        "(matte, plastic, paintedplastic, metal, shinymetal, constant, glass)\n"
                        "w.rib:3:14: warning: Displacement \"dented\" is unknown: no displacement "
                        "(fbm, ridged, texture or null)\n"
                        "w.rib:5:1: warning: Surface \"plastic\": Kd + Ks above 1 is scaled down "
                        "to 1 (energy conservation)\n"
                        "w.rib:6:1: warning: Surface \"metal\": roughness outside [0.01, 1] is "
                        "clamped to it (no perfect mirrors)\n"
                        "w.rib:7:22: warning: Surface \"shinymetal\": the reflection map "
                        "\"texturename\" is ignored (the path tracer reflects the scene itself)\n");
    /* An unknown displacement turns displacement off. */
    ts_scene s;
    test_parse_rib_ok("WorldBegin\nDisplacement \"fbm\" \"amplitude\" 0.1\nDisplacement "
                      "\"dented\"\n" UNIT_QUAD "WorldEnd\n",
                      &s);
    assert_int_equal(s.attr[0].disp_kind, TS_DISP_NONE);
    scene_free(&s);
}

/* ---- what the corpus needed: exporter float noise, unknown area lights ------------------ */

/* mtor and Maya write affine matrices with float noise where the projective column holds 0:
 * such a camera is affine; a truly projective one is still refused. */
static void test_matrix_noise(void **state)
{
    (void)state;
    ts_scene s;
    test_parse_rib_ok("ConcatTransform [0.692143 0.161604 0.703436 -4.76745e-009 -7.1284e-010 "
                      "0.974612 -0.223903 -6.76273e-018 0.72176 -0.154973 -0.674571 -4.97145e-009 "
                      "4.31253e-008 3.03732e-008 4.76251 1]\nWorldBegin\n" UNIT_QUAD "WorldEnd\n",
                      &s);
    const double *m = s.camera.world_to_camera;
    assert_true(m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] == 1.0);
    assert_true(fabs(m[11] - 4.76251) < 1e-12); /* the translation is kept */
    scene_free(&s);
    const char *bad = "ConcatTransform [1 0 0 0.001  0 1 0 0  0 0 1 0  0 0 5 1]\nWorldBegin\n";
    expect_bytes_error(bad, strlen(bad), "t.rib:2:1: error: the camera transform is projective");
}

static void test_unknown_area_light(void **state)
{
    (void)state;
    int rc;
    const char *out = test_rib_warnings(
        "WorldBegin\nAttributeBegin\nAreaLightSource \"arealight\" 1 "
        "\"intensity\" 2\nAreaLightSource \"uberlight\" 2\n" UNIT_QUAD "AttributeEnd\nWorldEnd\n",
        &rc);
    assert_int_equal(rc, TS_OK);
    assert_string_equal(out, "w.rib:4:17: warning: AreaLightSource \"uberlight\" is unknown: the "
                             "following geometry does not emit (arealight)\n");
    ts_scene s;
    test_parse_rib_ok(
        "WorldBegin\nAreaLightSource \"arealight\" 1\nAreaLightSource \"uberlight\" 2\n" UNIT_QUAD
        "WorldEnd\n",
        &s);
    assert_true(s.attr[0].le_r == 0.0f && s.attr[0].le_g == 0.0f && s.attr[0].le_b == 0.0f);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_line_endings),      cmocka_unit_test(test_byte_order_mark),
        cmocka_unit_test(test_binary_rib_named),  cmocka_unit_test(test_gzip),
        cmocka_unit_test(test_gzip_errors),       cmocka_unit_test(test_frames),
        cmocka_unit_test(test_frame_errors),      cmocka_unit_test(test_depth_pass_frames),
        cmocka_unit_test(test_scene_checks),      cmocka_unit_test(test_render_refuses_empty_scene),
        cmocka_unit_test(test_format_defaults),   cmocka_unit_test(test_camera_requests),
        cmocka_unit_test(test_camera_rays),       cmocka_unit_test(test_moving_camera_params),
        cmocka_unit_test(test_opacity),           cmocka_unit_test(test_geometry_teapot),
        cmocka_unit_test(test_standard_surfaces), cmocka_unit_test(test_shader_warnings),
        cmocka_unit_test(test_matrix_noise),      cmocka_unit_test(test_unknown_area_light),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
