/* test_image.c — image I/O (host/image/image.h: OpenEXR, libpng, and OpenImageIO for other
 * formats) and the sRGB tone map
 * (host/image/tonemap.h): bit-exact EXR round trips, PNG values, metadata, and the atomic-write
 * guarantees (no partial file, no stray temporary, an existing target untouched). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/error.h"
#include "image/image.h"
#include "image/tonemap.h"

/* ---- scratch directory: one per test, emptied and removed by teardown ---- */

typedef struct scratch {
    char dir[64];
} scratch;

static int scratch_setup(void **state)
{
    scratch *s = calloc(1, sizeof *s);
    if (!s) return -1;
    strcpy(s->dir, "/tmp/ts-test-image-XXXXXX");
    if (!mkdtemp(s->dir)) return -1;
    *state = s;
    return 0;
}

static int scratch_teardown(void **state)
{
    scratch *s = *state;
    DIR *d = opendir(s->dir);
    struct dirent *e;
    char p[512];
    while (d && (e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        snprintf(p, sizeof p, "%s/%s", s->dir, e->d_name);
        if (unlink(p) != 0) rmdir(p); /* tests make at most one level of directories */
    }
    if (d) closedir(d);
    rmdir(s->dir);
    free(s);
    return 0;
}

/* Writes s->dir/name into out (256 bytes) and returns out. */
static const char *scratch_path(char *out, const scratch *s, const char *name)
{
    snprintf(out, 256, "%s/%s", s->dir, name);
    return out;
}

/* Asserts that dir holds exactly the n names given (so no temporary was left behind). */
static void assert_dir_holds(const char *dir, const char *const *names, int n)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    int count = 0;
    while ((e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        int known = 0;
        for (int i = 0; i < n; i++)
            known |= strcmp(e->d_name, names[i]) == 0;
        if (!known) print_error("unexpected file in %s: %s\n", dir, e->d_name);
        assert_true(known);
        count++;
    }
    closedir(d);
    assert_int_equal(count, n);
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Reads a whole (small) file into buf; returns its size in bytes. */
static size_t slurp(const char *path, char *buf, size_t cap)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    size_t n = fread(buf, 1, cap, f);
    fclose(f);
    return n;
}

static void spit(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static uint32_t float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* ---- tone map ---- */

static void test_tonemap_values(void **state)
{
    (void)state;
    assert_int_equal(tonemap_srgb8(0.0f), 0);
    assert_int_equal(tonemap_srgb8(0.0031308f), 10); /* 12.92 x * 255 = 10.31 */
    assert_int_equal(tonemap_srgb8(0.5f), 188);      /* 0.73536 * 255 = 187.52 */
    assert_int_equal(tonemap_srgb8(0.18f), 118);     /* 0.46135 * 255 = 117.64 */
    assert_int_equal(tonemap_srgb8(1.0f), 255);
    assert_int_equal(tonemap_srgb8(2.0f), 255);
    assert_int_equal(tonemap_srgb8(INFINITY), 255);
    assert_int_equal(tonemap_srgb8(NAN), 0);
    assert_int_equal(tonemap_srgb8(-1.0f), 0);
    assert_int_equal(tonemap_srgb8(-INFINITY), 0);
    /* Monotone over [0, 1] in steps of 1e-4, and the buffer form agrees. */
    uint8_t prev = 0, one;
    for (int i = 0; i <= 10000; i++) {
        float x = (float)i * 1e-4f;
        uint8_t v = tonemap_srgb8(x);
        assert_true(v >= prev);
        tonemap_srgb8_buffer(&x, &one, 1);
        assert_int_equal(one, v);
        prev = v;
    }
}

/* ---- EXR ---- */

enum { EXR_W = 3, EXR_H = 2, EXR_C = 7 };

static void fill_exr_pixels(float *px)
{
    for (int i = 0; i < EXR_W * EXR_H * EXR_C; i++)
        px[i] = (float)i / 3.0f - 5.0f;
    px[3] = INFINITY;  /* Z of a miss, pixel 0 */
    px[10] = INFINITY; /* Z, pixel 1 */
    px[11] = -0.0f;
    px[12] = 1e-45f; /* smallest denormal */
    px[13] = 3.4028235e38f;
    px[20] = -INFINITY;
    px[27] = NAN; /* bits must survive too */
}

static void test_exr_round_trip(void **state)
{
    scratch *s = *state;
    char buf0[256];
    const char *names[EXR_C] = {"R", "G", "B", "Z", "N.x", "N.y", "N.z"};
    float px[EXR_W * EXR_H * EXR_C];
    fill_exr_pixels(px);
    ts_image img = {
        .width = EXR_W, .height = EXR_H, .channels = EXR_C, .channel_names = names, .pixels = px};
    ts_error err = {0};
    const char *path = scratch_path(buf0, s, "out.exr");
    assert_int_equal(image_write_exr(path, &img, NULL, 0, &err), TS_OK);
    assert_int_equal(err.code, 0);

    ts_image back;
    assert_int_equal(image_read(path, &back, &err), TS_OK);
    assert_int_equal(back.width, EXR_W);
    assert_int_equal(back.height, EXR_H);
    assert_int_equal(back.channels, EXR_C);
    for (int c = 0; c < EXR_C; c++)
        assert_string_equal(back.channel_names[c], names[c]);
    assert_null(back.channel_names[EXR_C]);
    for (int i = 0; i < EXR_W * EXR_H * EXR_C; i++)
        assert_int_equal(float_bits(back.pixels[i]), float_bits(px[i]));
    image_free(&back);
    assert_null(back.pixels);

    const char *left[] = {"out.exr"};
    assert_dir_holds(s->dir, left, 1);
}

/* An EXR streamed a few rows at a time (image_exr_stream_*) is the file image_write_exr_text
 * writes of the same image, byte for byte; nothing takes the output's name before the last
 * row and the commit; an uncommitted stream, a commit before the last row and a row too
 * many leave the directory as it was. */
static void test_exr_stream(void **state)
{
    scratch *s = *state;
    char buf0[256], buf1[256];
    enum { W = 5, H = 37, C = 3 }; /* 37 rows: three ZIP blocks of 16 lines, the last short */
    static float px[W * H * C];
    for (int i = 0; i < W * H * C; i++)
        px[i] = (float)(i % 97) * 0.37f - 3.0f;
    const char *names[C] = {"R", "G", "B"};
    ts_image img = {.width = W, .height = H, .channels = C, .channel_names = names, .pixels = px};
    ts_image_meta meta[] = {{"tessera:spp", 16}};
    ts_image_text text = {"tessera:note", "streamed"};
    ts_error err = {0};
    const char *whole = scratch_path(buf0, s, "whole.exr"), *path = scratch_path(buf1, s, "s.exr");
    assert_int_equal(image_write_exr_text(whole, &img, meta, 1, &text, 1, &err), TS_OK);
    ts_exr_stream *st = NULL;
    assert_int_equal(image_exr_stream_open(path, &img, meta, 1, &text, 1, &st, &err), TS_OK);
    const int bands[] = {1, 6, 17, 0, 13};
    for (int b = 0, at = 0; b < 5; at += bands[b++]) {
        assert_int_equal(image_exr_stream_next_row(st), at);
        assert_int_equal(image_exr_stream_rows(st, px + (size_t)at * W * C, bands[b], &err), TS_OK);
        assert_false(file_exists(path)); /* the name only at the commit */
    }
    assert_int_equal(image_exr_stream_close(st, 1, &err), TS_OK);
    static char a[1 << 16], b2[1 << 16];
    size_t na = slurp(whole, a, sizeof a), nb = slurp(path, b2, sizeof b2);
    assert_true(na > 0 && na < sizeof a);
    assert_int_equal(na, nb);
    assert_memory_equal(a, b2, na);

    const char *left[] = {"whole.exr", "s.exr"};
    const char *other = scratch_path(buf1, s, "t.exr");
    /* Not committed; committed short of the last row; a row too many. */
    assert_int_equal(image_exr_stream_open(other, &img, NULL, 0, NULL, 0, &st, &err), TS_OK);
    assert_int_equal(image_exr_stream_rows(st, px, 3, &err), TS_OK);
    assert_int_equal(image_exr_stream_close(st, 0, NULL), TS_OK);
    assert_dir_holds(s->dir, left, 2);
    assert_int_equal(image_exr_stream_open(other, &img, NULL, 0, NULL, 0, &st, &err), TS_OK);
    assert_int_equal(image_exr_stream_rows(st, px, H - 1, &err), TS_OK);
    assert_int_equal(image_exr_stream_close(st, 1, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, "before its last row"));
    ts_error_clear(&err);
    assert_dir_holds(s->dir, left, 2);
    assert_int_equal(image_exr_stream_open(other, &img, NULL, 0, NULL, 0, &st, &err), TS_OK);
    assert_int_equal(image_exr_stream_rows(st, px, H, &err), TS_OK);
    assert_int_equal(image_exr_stream_rows(st, px, 1, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, "more rows"));
    ts_error_clear(&err);
    assert_int_equal(image_exr_stream_close(st, 0, NULL), TS_OK);
    assert_dir_holds(s->dir, left, 2);
    /* Only an .exr. */
    assert_int_equal(
        image_exr_stream_open(scratch_path(buf1, s, "t.png"), &img, NULL, 0, NULL, 0, &st, &err),
        TS_E_IO);
    assert_null(st);
    ts_error_clear(&err);
}

/* A part of a frame (a CropWindow's image): the EXR's data window is the part, its display
 * window the frame, written whole or streamed (the same bytes), read back as the part with
 * its place; one that does not lie in its frame is refused. */
static void test_exr_part_of_frame(void **state)
{
    scratch *s = *state;
    char buf0[256], buf1[256];
    enum { W = 3, H = 19, C = 3 };
    static float px[W * H * C];
    for (int i = 0; i < W * H * C; i++)
        px[i] = (float)(i % 89) * 0.25f - 1.0f;
    const char *names[C] = {"R", "G", "B"};
    ts_image img = {.width = W,
                    .height = H,
                    .channels = C,
                    .channel_names = names,
                    .pixels = px,
                    .x0 = 5,
                    .y0 = 2,
                    .full_width = 10,
                    .full_height = 30};
    ts_error err = {0};
    const char *whole = scratch_path(buf0, s, "part.exr"), *path = scratch_path(buf1, s, "ps.exr");
    assert_int_equal(image_write_exr(whole, &img, NULL, 0, &err), TS_OK);
    ts_exr_stream *st = NULL;
    assert_int_equal(image_exr_stream_open(path, &img, NULL, 0, NULL, 0, &st, &err), TS_OK);
    assert_int_equal(image_exr_stream_rows(st, px, 7, &err), TS_OK);
    assert_int_equal(image_exr_stream_rows(st, px + 7 * W * C, H - 7, &err), TS_OK);
    assert_int_equal(image_exr_stream_close(st, 1, &err), TS_OK);
    static char a[1 << 14], b[1 << 14];
    size_t na = slurp(whole, a, sizeof a), nb = slurp(path, b, sizeof b);
    assert_true(na > 0 && na < sizeof a && na == nb);
    assert_memory_equal(a, b, na);
    ts_image back;
    assert_int_equal(image_read(whole, &back, &err), TS_OK);
    assert_true(back.width == W && back.height == H && back.channels == C);
    assert_true(back.x0 == 5 && back.y0 == 2 && back.full_width == 10 && back.full_height == 30);
    for (int i = 0; i < W * H * C; i++)
        assert_int_equal(float_bits(back.pixels[i]), float_bits(px[i]));
    image_free(&back);
    img.x0 = 8; /* 8 + 3 columns in a frame of 10 */
    assert_int_equal(image_write_exr(scratch_path(buf0, s, "out.exr"), &img, NULL, 0, &err),
                     TS_E_IO);
    assert_non_null(strstr(err.msg, "does not lie in its frame"));
}
/* EXR sorts channels by name on disk and OIIO reads them R, G, B, A, Z first; the
 * order the writer gave must come back, with each value under its own name. */
static void test_exr_channel_order(void **state)
{
    scratch *s = *state;
    char buf0[256];
    const char *names[] = {"albedo.R", "Z", "B", "N.x", "G", "R", "N.y"};
    float px[7] = {1, 2, 3, 4, 5, 6, 7};
    ts_image img = {.width = 1, .height = 1, .channels = 7, .channel_names = names, .pixels = px};
    ts_error err = {0};
    const char *path = scratch_path(buf0, s, "order.exr");
    assert_int_equal(image_write_exr(path, &img, NULL, 0, &err), TS_OK);
    ts_image back;
    assert_int_equal(image_read(path, &back, &err), TS_OK);
    assert_int_equal(back.channels, 7);
    for (int c = 0; c < 7; c++) {
        assert_string_equal(back.channel_names[c], names[c]);
        assert_true(back.pixels[c] == px[c]);
    }
    image_free(&back);
}

static void test_exr_meta(void **state)
{
    scratch *s = *state;
    char buf0[256];
    float px[3] = {0.25f, 0.5f, 1.0f};
    ts_image img = {.width = 1, .height = 1, .channels = 3, .channel_names = NULL, .pixels = px};
    ts_image_meta meta[] = {{"tessera:spp", 16}, {"tessera:seed", -7}};
    ts_error err = {0};
    const char *path = scratch_path(buf0, s, "meta.exr");
    assert_int_equal(image_write_exr(path, &img, meta, 2, &err), TS_OK);
    int v = 0;
    assert_int_equal(image_read_meta_int(path, "tessera:spp", &v, &err), TS_OK);
    assert_int_equal(v, 16);
    assert_int_equal(image_read_meta_int(path, "tessera:seed", &v, &err), TS_OK);
    assert_int_equal(v, -7);
    assert_int_equal(image_read_meta_int(path, "tessera:depth", &v, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "tessera:depth"));
    ts_error_clear(&err);
}

/* String metadata beside the integers: written, read back whole or cut to the buffer; an
 * integer is not a string; an incomplete item fails the write. */
static void test_exr_text_meta(void **state)
{
    scratch *s = *state;
    char buf0[256];
    float px[3] = {0.25f, 0.5f, 1.0f};
    ts_image img = {.width = 1, .height = 1, .channels = 3, .channel_names = NULL, .pixels = px};
    ts_image_meta meta[] = {{"tessera:bake_bands", 3}};
    ts_image_text text[] = {{"tessera:sh_convention", "Y_00 = 1/(2 sqrt(pi))"}};
    ts_error err = {0};
    const char *path = scratch_path(buf0, s, "text.exr");
    assert_int_equal(image_write_exr_text(path, &img, meta, 1, text, 1, &err), TS_OK);
    char got[64];
    assert_int_equal(image_read_meta_string(path, "tessera:sh_convention", got, sizeof got, &err),
                     TS_OK);
    assert_string_equal(got, "Y_00 = 1/(2 sqrt(pi))");
    assert_int_equal(image_read_meta_string(path, "tessera:sh_convention", got, 5, &err), TS_OK);
    assert_string_equal(got, "Y_00");
    int v = 0;
    assert_int_equal(image_read_meta_int(path, "tessera:bake_bands", &v, &err), TS_OK);
    assert_int_equal(v, 3);
    assert_int_equal(image_read_meta_string(path, "tessera:bake_bands", got, sizeof got, &err),
                     TS_E_IO);
    assert_non_null(strstr(err.msg, "no string metadata"));
    ts_error_clear(&err);
    ts_image_text bad[] = {{"tessera:x", NULL}};
    assert_int_equal(image_write_exr_text(path, &img, NULL, 0, bad, 1, &err), TS_E_IO);
    ts_error_clear(&err);
    /* The failed write left the first file as it was. */
    assert_int_equal(image_read_meta_int(path, "tessera:bake_bands", &v, &err), TS_OK);
}

/* 1 when a shared object whose path contains name is mapped into this process. */
static int library_mapped(const char *name)
{
    FILE *f = fopen("/proc/self/maps", "r");
    char line[4096];
    int found = 0;
    while (f && !found && fgets(line, sizeof line, f))
        found = strstr(line, name) != NULL;
    if (f) fclose(f);
    return found;
}

/* EXR in and out and PNG out go through OpenEXR and libpng: a process that only writes its
 * image and reads EXR never maps OpenImageIO (whose ~260 libraries cost a process start
 * 0.17 s or more). Runs before any test here reads a PNG. */
static void test_exr_and_png_output_need_no_openimageio(void **state)
{
    scratch *s = *state;
    char buf0[256], buf1[256];
    float px[6] = {0.25f, 0.5f, 1.0f, 2.0f, 0.0f, 0.125f};
    ts_image img = {.width = 2, .height = 1, .channels = 3, .channel_names = NULL, .pixels = px};
    ts_error err = {0};
    const char *exr = scratch_path(buf0, s, "a.exr"), *png = scratch_path(buf1, s, "a.png");
    assert_int_equal(image_write_exr(exr, &img, NULL, 0, &err), TS_OK);
    assert_int_equal(image_write_png(png, 2, 1, px, &err), TS_OK);
    ts_image back;
    assert_int_equal(image_read(exr, &back, &err), TS_OK);
    image_free(&back);
    int v;
    assert_int_equal(image_read_meta_int(exr, "tessera:spp", &v, &err), TS_E_IO);
    ts_error_clear(&err);
    assert_true(library_mapped("libOpenEXR"));
    assert_false(library_mapped("libOpenImageIO"));
    /* Reading the PNG back is another format: the module comes in for it. */
    assert_int_equal(image_read(png, &back, &err), TS_OK);
    image_free(&back);
    assert_true(library_mapped("libtessera_image"));
    assert_true(library_mapped("libOpenImageIO"));
}

/* ---- PNG ---- */

static void test_png_round_trip(void **state)
{
    scratch *s = *state;
    char buf0[256];
    enum { N = 7 };
    const float lin[N] = {0.0f, 0.0031308f, 0.5f, 1.0f, 2.0f, NAN, -1.0f};
    const int want[N] = {0, 10, 188, 255, 255, 0, 0};
    float rgb[N * 3];
    for (int i = 0; i < N; i++) /* rotate values through R, G, B to catch channel swaps */
        for (int c = 0; c < 3; c++)
            rgb[i * 3 + c] = lin[(i + c) % N];
    ts_error err = {0};
    const char *path = scratch_path(buf0, s, "out.png");
    assert_int_equal(image_write_png(path, N, 1, rgb, &err), TS_OK);

    ts_image back;
    assert_int_equal(image_read(path, &back, &err), TS_OK);
    assert_int_equal(back.width, N);
    assert_int_equal(back.height, 1);
    assert_int_equal(back.channels, 3);
    assert_string_equal(back.channel_names[0], "R");
    assert_string_equal(back.channel_names[2], "B");
    for (int i = 0; i < N; i++)
        for (int c = 0; c < 3; c++) /* 8-bit values read back as v / 255 */
            assert_int_equal((int)lroundf(back.pixels[i * 3 + c] * 255.0f), want[(i + c) % N]);
    image_free(&back);
    const char *left[] = {"out.png"};
    assert_dir_holds(s->dir, left, 1);
}

/* ---- failures ---- */

static void test_write_into_missing_dir(void **state)
{
    scratch *s = *state;
    char buf0[256], buf1[256];
    float px[3] = {1, 1, 1};
    ts_image img = {.width = 1, .height = 1, .channels = 3, .channel_names = NULL, .pixels = px};
    ts_error err = {0};
    const char *exr = scratch_path(buf0, s, "no-such-dir/out.exr");
    assert_int_equal(image_write_exr(exr, &img, NULL, 0, &err), TS_E_IO);
    assert_int_equal(err.code, TS_E_IO);
    assert_non_null(strstr(err.msg, exr));
    assert_false(file_exists(exr));
    ts_error_clear(&err);

    const char *png = scratch_path(buf1, s, "no-such-dir/out.png");
    assert_int_equal(image_write_png(png, 1, 1, px, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, png));
    assert_false(file_exists(png));
    ts_error_clear(&err);
    assert_dir_holds(s->dir, NULL, 0);
}

static void test_failed_write_keeps_target(void **state)
{
    scratch *s = *state;
    char buf0[256], buf1[256], buf2[256];
    float px[3] = {0.5f, 0.5f, 0.5f};
    ts_error err = {0};
    char before[4096], after[4096];

    /* A bad image (0 width) over an existing PNG. */
    const char *png = scratch_path(buf0, s, "keep.png");
    assert_int_equal(image_write_png(png, 1, 1, px, &err), TS_OK);
    size_t n0 = slurp(png, before, sizeof before);
    assert_int_equal(image_write_png(png, 0, 1, px, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, png));
    assert_non_null(strstr(err.msg, "invalid image size"));
    ts_error_clear(&err);
    assert_int_equal(slurp(png, after, sizeof after), n0);
    assert_memory_equal(before, after, n0);

    /* An extension no writer here handles, over an existing file. */
    const char *xyz = scratch_path(buf1, s, "keep.xyz");
    spit(xyz, "old contents");
    ts_image img = {.width = 1, .height = 1, .channels = 3, .channel_names = NULL, .pixels = px};
    assert_int_equal(image_write_exr(xyz, &img, NULL, 0, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, xyz));
    assert_non_null(strstr(err.msg, "unsupported output format"));
    ts_error_clear(&err);
    size_t n1 = slurp(xyz, after, sizeof after);
    assert_int_equal(n1, strlen("old contents"));
    assert_memory_equal(after, "old contents", n1);

    /* A failure after the temporary was written: the rename onto a directory fails. */
    const char *dir = scratch_path(buf2, s, "taken.exr");
    assert_int_equal(mkdir(dir, 0700), 0);
    assert_int_equal(image_write_exr(dir, &img, NULL, 0, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, dir));
    ts_error_clear(&err);

    const char *left[] = {"keep.png", "keep.xyz", "taken.exr"};
    assert_dir_holds(s->dir, left, 3);
}

static void test_read_missing_file(void **state)
{
    scratch *s = *state;
    char buf0[256];
    ts_error err = {0};
    ts_image img;
    memset(&img, 0xff, sizeof img);
    const char *path = scratch_path(buf0, s, "absent.exr");
    assert_int_equal(image_read(path, &img, &err), TS_E_IO);
    assert_non_null(strstr(err.msg, path));
    assert_null(img.pixels);
    assert_null(img.channel_names);
    assert_null(strchr(err.msg, '\n'));
    ts_error_clear(&err);
    image_free(&img); /* a zeroed image is fine to free */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tonemap_values),
        cmocka_unit_test_setup_teardown(test_exr_and_png_output_need_no_openimageio, scratch_setup,
                                        scratch_teardown),
        cmocka_unit_test_setup_teardown(test_exr_round_trip, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_exr_channel_order, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_exr_stream, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_exr_part_of_frame, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_exr_meta, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_exr_text_meta, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_png_round_trip, scratch_setup, scratch_teardown),
        cmocka_unit_test_setup_teardown(test_write_into_missing_dir, scratch_setup,
                                        scratch_teardown),
        cmocka_unit_test_setup_teardown(test_failed_write_keeps_target, scratch_setup,
                                        scratch_teardown),
        cmocka_unit_test_setup_teardown(test_read_missing_file, scratch_setup, scratch_teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
