/* test_cli.c — `tessera` as a user runs it: bad input gives a one-line error, exit status 1
 * and no output file; a render writes the EXR with its AOV channels and a --stats JSON with
 * the schema of DESIGN.md §4; the second run loads the kernels from the binary cache. */
#include "test_support.h"
#include "image/image.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char dir[4096], cache[4200];

/* Runs tessera with `args`; returns the exit status; stderr goes to dir/stderr.txt. */
static int run(const char *args)
{
    char cmd[16384];
    snprintf(cmd, sizeof cmd, "TESSERA_CACHE_DIR='%s' '%s' %s 2>'%s/stderr.txt' >/dev/null", cache,
             test_tessera_binary(), args, dir);
    int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void read_stderr(char *buf, size_t cap)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/stderr.txt", dir);
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(buf, 1, cap - 1, f) : 0;
    buf[n] = '\0';
    if (f) fclose(f);
}

static int exists(const char *name)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    struct stat st;
    return stat(path, &st) == 0;
}

static void expect_error(const char *args, const char *needle)
{
    assert_int_equal(run(args), 1);
    char err[8192];
    read_stderr(err, sizeof err);
    if (!strstr(err, needle))
        fail_msg("stderr of `tessera %s` lacks \"%s\":\n%s", args, needle, err);
    /* One line: the message and its newline, nothing else, and no control byte in it. */
    assert_non_null(strchr(err, '\n'));
    assert_true(strchr(err, '\n')[1] == '\0');
    for (const unsigned char *c = (const unsigned char *)err; *c != '\n'; ++c)
        if (*c < 0x20 || *c == 0x7f) fail_msg("byte 0x%02x in the message:\n%s", *c, err);
    assert_false(exists("out.png"));
}

static int setup(void **state)
{
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    snprintf(cache, sizeof cache, "%s/cache", dir);
    return 0;
}

static void test_bad_input(void **state)
{
    char args[16384], bad[4200];
    snprintf(bad, sizeof bad, "%s/bad.rib", dir);
    FILE *f = fopen(bad, "w");
    fputs("WorldBegin\nPatch \"bicubic\" \"P\" [0 0 0\n", f); /* unterminated array */
    fclose(f);
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png'", bad, dir);
    expect_error(args, "bad.rib:2:");
    snprintf(args, sizeof args, "render '%s/missing.rib' -o '%s/out.png'", dir, dir);
    expect_error(args, "missing.rib");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --device 99",
             test_source_path("scene/teapot.rib"), dir);
    expect_error(args, "unknown device index 99");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --bogus",
             test_source_path("scene/teapot.rib"), dir);
    expect_error(args, "unknown option --bogus");
    expect_error("frobnicate", "unknown command");
    /* Messages of issue 15, item 8. */
    const char *teapot = test_source_path("scene/teapot.rib");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --spp", teapot, dir);
    expect_error(args, "option --spp needs a value");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --quiet=1", teapot, dir);
    expect_error(args, "option --quiet takes no value");
    snprintf(args, sizeof args, "render '%s' -o '%s/.png'", teapot, dir);
    expect_error(args, "/.png: the output needs a name before .png");
    assert_false(exists(".png"));
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res 32x24junk", teapot, dir);
    expect_error(args, "bad value '32x24junk' for --res");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res=32x", teapot, dir);
    expect_error(args, "bad value '32x' for --res");
    /* --up: one axis, x, y or z, with an optional sign. */
    const char *ups[] = {"w", "", "xy", "--z", "+-y", "Z", "2"};
    for (size_t i = 0; i < sizeof ups / sizeof ups[0]; i++) {
        snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --up='%s'", teapot, dir, ups[i]);
        char want[64];
        snprintf(want, sizeof want, "bad value '%s' for --up", ups[i]);
        expect_error(args, want);
    }
    /* --dicing-rate: a plain decimal in 1/64..64 (no sign, space, hex, inf or nan). */
    const char *rates[] = {"0", "-1", "+2", " 2", "0x2", "inf", "nan", "65", "0.015", "2x", ""};
    for (size_t i = 0; i < sizeof rates / sizeof *rates; ++i) {
        char want[64];
        snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --dicing-rate '%s'", teapot, dir,
                 rates[i]);
        snprintf(want, sizeof want, "bad value '%s' for --dicing-rate", rates[i]);
        expect_error(args, want);
    }
    /* --streams: 1..4 waves in flight a device. */
    const char *streams[] = {"0", "5", "-1", "2x", ""};
    for (size_t i = 0; i < sizeof streams / sizeof *streams; ++i) {
        char want[64];
        snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --streams '%s'", teapot, dir,
                 streams[i]);
        snprintf(want, sizeof want, "bad value '%s' for --streams", streams[i]);
        expect_error(args, want);
    }
    setenv("TESSERA_DEVICE", "abc", 1);
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res 8x8", teapot, dir);
    expect_error(args, "TESSERA_DEVICE=abc is not a device index");
    unsetenv("TESSERA_DEVICE");
    snprintf(args, sizeof args, "render '%s/new\nline.rib' -o '%s/out.png'", dir, dir);
    expect_error(args, "new\\nline.rib: No such file or directory");
}

/* Renders write EXR and PNG without the OpenImageIO module (image.c): with the module's
 * path pointing nowhere they still succeed, and only a texture in another format (the
 * textured scene's PPM and PGM) needs it, failing at once with the reason and the path. */
static void test_images_without_the_module(void **state)
{
    char args[16384];
    const char *teapot = test_source_path("scene/teapot.rib");
    setenv("TESSERA_IMAGE_MODULE", "/nonexistent/libtessera_image.so", 1);
    const char *outs[] = {"plain.exr", "plain.png"};
    for (int i = 0; i < 2; i++) {
        snprintf(args, sizeof args, "render '%s' -o '%s/%s' --res 16x9 --spp 1 --quiet", teapot,
                 dir, outs[i]);
        assert_int_equal(run(args), 0);
        assert_true(exists(outs[i]));
    }
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res 16x9 --spp 1",
             test_source_path("scene/textured.rib"), dir);
    expect_error(args, "cobbles_");
    expect_error(args, "cannot load the image module libtessera_image.so "
                       "(/nonexistent/libtessera_image.so: cannot open shared object file");
    unsetenv("TESSERA_IMAGE_MODULE");
}

static double number(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v)) fail_msg("stats: \"%s\" is missing or not a number", key);
    return v->valuedouble;
}

static void test_render_exr_and_stats(void **state)
{
    char args[16384], path[4200]; /* three paths of up to 4095 bytes each */
    snprintf(
        args, sizeof args,
        "render '%s' -o '%s/t.exr' --res 64x36 --spp 1 --max-lod 4 --stats '%s/s.json' --quiet",
        test_source_path("scene/teapot.rib"), dir, dir);
    assert_int_equal(run(args), 0);
    snprintf(path, sizeof path, "%s/t.exr", dir);
    ts_image img;
    ts_error err = {0};
    assert_int_equal(image_read(path, &img, &err), TS_OK);
    assert_int_equal(img.width, 64);
    assert_int_equal(img.channels, 10);
    const char *want[] = {"R",   "G",   "B",        "Z",        "N.x",
                          "N.y", "N.z", "albedo.R", "albedo.G", "albedo.B"};
    for (int c = 0; c < 10; ++c)
        assert_string_equal(img.channel_names[c], want[c]);
    int hits = 0;
    for (int i = 0; i < img.width * img.height; ++i) {
        const float *px = &img.pixels[i * 10];
        if (isinf(px[3])) continue; /* a miss: black, no normal */
        ++hits;
        float nl = sqrtf(px[4] * px[4] + px[5] * px[5] + px[6] * px[6]);
        assert_true(px[3] > 0 && fabsf(nl - 1.0f) < 1e-3f);
    }
    assert_true(hits > 200 && hits < 64 * 36);
    image_free(&img);

    snprintf(path, sizeof path, "%s/s.json", dir);
    cJSON *j = test_read_json(path);
    assert_true(cJSON_IsString(cJSON_GetObjectItemCaseSensitive(j, "device")));
    assert_true(number(j, "wall_seconds") > 0);
    assert_true(number(j, "peak_rss_bytes") > 0);
    /* The default budget (app/budget.h): at most its cap, at least the floor. */
    assert_true(number(j, "memory_budget_bytes") >= 16 << 20);
    assert_true(number(j, "memory_budget_bytes") <= 1024 << 20);
    const cJSON *stages = cJSON_GetObjectItemCaseSensitive(j, "stages");
    double all = 0;
    for (int i = 0; i < TS_STAGE_COUNT; ++i) {
        assert_true(number(stages, ts_stage_names[i]) >= 0);
        all += number(stages, ts_stage_names[i]);
    }
    /* One device's kernels run one at a time: while they ran is their sum, at least the
     * stages that are kernels alone and at most every stage (host parts included); the host
     * ran alone the rest of the wall. */
    double kernels = number(j, "kernel_seconds"), wall = number(j, "wall_seconds");
    double only_kernels = number(stages, "camera") + number(stages, "top_level") +
                          number(stages, "dice") + number(stages, "build") +
                          number(stages, "bottom_level");
    assert_true(only_kernels > 0 && kernels >= only_kernels - 1e-6);
    assert_true(kernels <= all + 1e-6 && kernels <= wall);
    assert_true(fabs(number(j, "host_serial_seconds") - (wall - kernels)) < 1e-6);
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(j, "counters");
    /* Eye rays plus the bounce rays of the paths (depth 3); the teapot is lit: shadow rays. */
    assert_true(number(c, "rays") >= 64 * 36 && number(c, "rays") <= 4 * 64 * 36);
    assert_true(number(c, "shadow_rays") > 0 && number(c, "shadow_rays") <= 3 * 64 * 36);
    assert_true(number(c, "pairs") >= hits);
    assert_true(number(c, "patches_diced") >= 1);
    assert_true(number(c, "patches_shared") == 0); /* one device: nothing to share with */
    assert_int_equal((long)number(c, "micropolygons_potential"), 32L * 256);
    /* Ray-driven LOD: each dicing makes 4^m micro-quads with m <= --max-lod 4. */
    assert_true(number(c, "micropolygons_created") >= number(c, "patches_diced"));
    assert_true(number(c, "micropolygons_created") <= number(c, "patches_diced") * 256);
    const cJSON *its = cJSON_GetObjectItemCaseSensitive(j, "iterations");
    assert_true(cJSON_GetArraySize(its) >= 1);
    const cJSON *first = cJSON_GetArrayItem(its, 0);
    assert_int_equal((int)number(first, "active_rays"), 64 * 36);
    assert_true(number(first, "n_per_ray") >= 1 && number(first, "n_per_ray") <= 100);
    number(first, "wave"), number(first, "iteration"), number(first, "pairs");
    cJSON_Delete(j);

    /* Same command again: the kernels come from the binary cache. */
    assert_int_equal(run(args), 0);
    j = test_read_json(path);
    assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(j, "kernel_cache_hit")));
    cJSON_Delete(j);
}

static void test_png_is_written_atomically(void **state)
{
    char args[16384];
    /* A temporary left by a render that was killed while writing t.png (its process gone). */
    pid_t dead = fork();
    assert_true(dead >= 0);
    if (dead == 0) _exit(0);
    waitpid(dead, NULL, 0);
    char stale[4400];
    snprintf(stale, sizeof stale, "%s/.t.png.tmp-%ld-0", dir, (long)dead);
    FILE *f = fopen(stale, "w");
    assert_non_null(f);
    fclose(f);
    snprintf(args, sizeof args, "render '%s' -o '%s/t.png' --res 32x18 --max-lod 3 --quiet",
             test_source_path("scene/teapot.rib"), dir);
    assert_int_equal(run(args), 0);
    assert_true(exists("t.png"));
    /* Names of 249 characters (NAME_MAX is 255): their temporaries are cut to fit. */
    static char name[256];
    memset(name, 'n', 245);
    snprintf(args, sizeof args,
             "render '%s' -o '%s/%.245s.png' --stats '%s/%.245s.jsn' --res 8x8 --max-lod 3 --quiet",
             test_source_path("scene/teapot.rib"), dir, name, dir, name);
    assert_int_equal(run(args), 0);
    snprintf(name + 245, sizeof name - 245, ".png");
    assert_true(exists(name));
    snprintf(name + 245, sizeof name - 245, ".jsn");
    assert_true(exists(name));
    /* No temporary is left beside it. */
    char cmd[8400];
    snprintf(cmd, sizeof cmd, "ls -a '%s' | grep -q tmp", dir);
    assert_int_not_equal(system(cmd), 0);
}

static void write_text(const char *name, const char *text)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* The file dir/name still holds exactly `text`. */
static void assert_text(const char *name, const char *text)
{
    char path[4200], buf[1 << 14];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    if (strcmp(buf, text) != 0) fail_msg("%s was changed", name);
}

/* Output paths are checked against each other, the scene and its textures, and for a
 * directory that takes the file, before anything renders (issue 15, item 4): one line, exit
 * status 1, every file as it was (expect_error: no progress header, so no render started). */
static void test_paths_are_checked_before_rendering(void **state)
{
    (void)state;
    char args[16384], scene[4200];
    /* one_patch.rib coloured by a texture t.png beside it. */
    FILE *src = fopen(test_source_path("scene/one_patch.rib"), "r");
    static char text[1 << 14];
    size_t n = src ? fread(text, 1, sizeof text - 1, src) : 0;
    if (src) fclose(src);
    text[n] = '\0';
    char *color = strstr(text, "Color [0.7 0.7 0.75]\n");
    assert_non_null(color);
    static char rib[1 << 14];
    snprintf(rib, sizeof rib, "%.*sSurface \"matte\" \"string texturename\" [\"t.png\"]\n%s",
             (int)(color - text), text, color);
    write_text("scene.rib", rib);
    snprintf(scene, sizeof scene, "%s/scene.rib", dir);
    float px[4 * 4 * 3];
    for (int i = 0; i < 4 * 4 * 3; ++i)
        px[i] = (float)(i % 7) / 7.0f;
    char tex[4200];
    snprintf(tex, sizeof tex, "%s/t.png", dir);
    ts_error err = {0};
    assert_int_equal(image_write_png(tex, 4, 4, px, &err), TS_OK);
    write_text("old.exr", "the old image");

    snprintf(args, sizeof args, "render '%s' -o '%s/old.exr' --res 8x8 --stats '%s/./old.exr'",
             scene, dir, dir);
    expect_error(args, "--stats and -o name the same file");
    snprintf(args, sizeof args, "render '%s' -o '%s/old.exr' --res 8x8 --stats '%s'", scene, dir,
             scene);
    expect_error(args, "--stats names the scene file");
    assert_text("scene.rib", rib);
    snprintf(args, sizeof args, "render '%s' -o '%s/old.exr' --res 8x8 --stats '%s/no/s.json'",
             scene, dir, dir);
    expect_error(args, "no/s.json: cannot write there: ");
    snprintf(args, sizeof args, "render '%s' -o '%s/no/x.png' --res 8x8", scene, dir);
    expect_error(args, "no/x.png: cannot write there: ");
    snprintf(args, sizeof args, "render '%s' -o '%s/old.exr' --res 8x8 --stats '%s'", scene, dir,
             tex);
    expect_error(args, "--stats names a texture the scene reads");
    snprintf(args, sizeof args, "render '%s' -o '%s' --res 8x8", scene, tex);
    expect_error(args, "-o names a texture the scene reads");
    assert_text("old.exr", "the old image");
    ts_image img;
    assert_int_equal(image_read(tex, &img, &err), TS_OK); /* the texture is intact */
    assert_int_equal(img.width, 4);
    image_free(&img);
    /* The same scene with other paths renders. */
    snprintf(args, sizeof args,
             "render '%s' -o '%s/new.png' --res 8x8 --stats '%s/s2.json' --quiet", scene, dir, dir);
    assert_int_equal(run(args), 0);
    /* A RIB archive the scene reads is an input too (so is a mesh). */
    write_text("inner.rib", "Sphere 1 -1 1 360\n");
    write_text("outer.rib", "Format 8 8 1\nWorldBegin\nLightSource \"distantlight\" 1\nReadArchive "
                            "\"inner.rib\"\nWorldEnd\n");
    snprintf(args, sizeof args, "render '%s/outer.rib' -o '%s/o.png' --stats '%s/inner.rib'", dir,
             dir, dir);
    expect_error(args, "inner.rib: --stats names a file the scene reads");
    assert_text("inner.rib", "Sphere 1 -1 1 360\n");
}

/* Sizes are computed in 64 bits (issue 15, item 6): an image whose samples the kernels'
 * 32-bit index cannot hold is refused before anything is set up, with the limit in the
 * message; one whose film exceeds the device's largest buffer, before any buffer. */
/* A warning names a file whose name holds a newline: it stays one line on stderr, the
 * newline written as \\n (issue 15, item 8), like the errors above. */
static void test_warning_lines_escape_control_characters(void **state)
{
    char scene[4200], args[16384];
    snprintf(scene, sizeof scene, "%s/warn\nname.rib", dir);
    FILE *f = fopen(scene, "w");
    assert_non_null(f);
    /* No light: the scene loads with a warning and renders black. */
    fputs("Format 8 8 1\nWorldBegin\nPatch \"bilinear\" \"P\" [-1 -1 5  1 -1 5  -1 1 5  1 1 5]\n"
          "WorldEnd\n",
          f);
    fclose(f);
    snprintf(args, sizeof args, "render '%s' -o '%s/warn.png' --spp 1 --max-lod 2", scene, dir);
    assert_int_equal(run(args), 0);
    char err[8192];
    read_stderr(err, sizeof err);
    if (!strstr(err, "warn\\nname.rib:") || !strstr(err, "warning: the scene has no light"))
        fail_msg("stderr lacks the escaped warning:\n%s", err);
    /* No line starts with the part of the name after its newline. */
    for (const char *line = err; line; line = strchr(line, '\n'), line = line ? line + 1 : NULL)
        if (strncmp(line, "name.rib", 8) == 0) fail_msg("a warning split in two lines:\n%s", err);
    remove(scene);
}

/* Reads dir/name (an EXR the test rendered) into *img; fails the test otherwise. */
static void read_exr(const char *name, ts_image *img)
{
    char path[4400];
    ts_error e = {0};
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (image_read(path, img, &e) != TS_OK) fail_msg("%s", e.msg);
}

/* A texture that is not there: `render` warns, naming it and the fallback, and renders the
 * image of the scene written without it, bit for bit; `render --strict` and `bake --strict`
 * stop with the error at the file name's line and column and write nothing. */
static void test_missing_texture_and_strict(void **state)
{
    (void)state;
    static const char *const head = "Format 8 8 1\nWorldBegin\nLightSource \"distantlight\" 1\n";
    static const char *const tail = "Patch \"bilinear\" \"P\" [-1 -1 5  1 -1 5  -1 1 5  1 1 5]\n"
                                    "WorldEnd\n";
    char text[1024], args[16384];
    snprintf(text, sizeof text, "%sSurface \"matte\" \"texturename\" [\"no-such.png\"]\n%s", head,
             tail);
    write_text("missing.rib", text);
    snprintf(text, sizeof text, "%sSurface \"matte\"\n%s", head, tail);
    write_text("untextured.rib", text);
    snprintf(args, sizeof args, "render '%s/missing.rib' -o '%s/missing.exr' --spp 2 --max-lod 2",
             dir, dir);
    assert_int_equal(run(args), 0);
    char err[8192];
    read_stderr(err, sizeof err);
    if (!strstr(err, "missing.rib:4:31: warning: Surface: cannot read texture \"no-such.png\": ") ||
        !strstr(err, "; rendered with Cs alone, untextured (--strict makes this an error)\n"))
        fail_msg("stderr lacks the warning:\n%s", err);
    snprintf(args, sizeof args,
             "render '%s/untextured.rib' -o '%s/untextured.exr' --spp 2 --max-lod 2 --quiet", dir,
             dir);
    assert_int_equal(run(args), 0);
    ts_image a, b;
    read_exr("missing.exr", &a);
    read_exr("untextured.exr", &b);
    assert_int_equal(a.width * a.height * a.channels, 8 * 8 * a.channels);
    assert_int_equal(a.channels, b.channels);
    assert_memory_equal(a.pixels, b.pixels, sizeof(float) * 64u * (size_t)a.channels);
    float sum = 0.0f;
    for (int k = 0; k < 64 * a.channels; k++)
        sum += isfinite(a.pixels[k]) ? a.pixels[k] : 0.0f;
    assert_true(sum > 0.0f); /* lit: not a black image passing for the same */
    image_free(&a);
    image_free(&b);
    const char *cmds[] = {"render", "bake"};
    for (int k = 0; k < 2; k++) {
        snprintf(args, sizeof args, "%s '%s/missing.rib' -o '%s/out.%s' --strict", cmds[k], dir,
                 dir, k ? "exr" : "png");
        expect_error(args, "missing.rib:4:31: error: Surface: cannot read texture "
                           "\"no-such.png\": ");
        assert_false(exists("out.exr"));
    }
}

/* Procedural "RunProgram": the image of a scene whose helper program answers two patches is
 * the image of the same RIB written in place inside an attribute block, bit for bit (render
 * and bake alike run it); `--no-programs` skips it with a warning, and renders the scene
 * without them. */
static void test_run_program(void **state)
{
    (void)state;
    static const char *const head = "Format 8 8 1\nWorldBegin\nLightSource \"distantlight\" 1\n";
    static const char *const quad = "Patch \"bilinear\" \"P\" [-1 -1 5  1 -1 5  -1 1 5  1 1 5]\n";
    static const char *const answer = "Color [1 0.5 0.25]\nScale 0.5 0.5 1\n";
    char text[2048], args[16384], path[4200];
    snprintf(text, sizeof text,
             "#!/bin/sh\nwhile read -r detail data; do\n  printf '%%s%%s' '%s' '%s'\n"
             "  printf '\\377'\ndone\n",
             answer, quad);
    write_text("gen.sh", text);
    snprintf(path, sizeof path, "%s/gen.sh", dir);
    assert_int_equal(chmod(path, 0755), 0);
    snprintf(text, sizeof text,
             "%sProcedural \"RunProgram\" [\"gen.sh\" \"\"] [-1 1 -1 1 5 5]\n"
             "Translate 0.5 0.5 0\nProcedural \"RunProgram\" [\"gen.sh\" \"\"] [-1 1 -1 1 5 5]\n"
             "WorldEnd\n",
             head);
    write_text("program.rib", text);
    snprintf(text, sizeof text,
             "%sAttributeBegin\n%s%sAttributeEnd\nTranslate 0.5 0.5 0\nAttributeBegin\n%s%s"
             "AttributeEnd\nWorldEnd\n",
             head, answer, quad, answer, quad);
    write_text("inline.rib", text);
    const char *names[] = {"program", "inline"};
    ts_image img[2];
    for (int k = 0; k < 2; k++) {
        snprintf(args, sizeof args, "render '%s/%s.rib' -o '%s/%s.exr' --spp 2 --max-lod 2 --quiet",
                 dir, names[k], dir, names[k]);
        assert_int_equal(run(args), 0);
        snprintf(path, sizeof path, "%s.exr", names[k]);
        read_exr(path, &img[k]);
    }
    assert_int_equal(img[0].channels, img[1].channels);
    assert_memory_equal(img[0].pixels, img[1].pixels,
                        sizeof(float) * 64u * (size_t)img[0].channels);
    float sum = 0.0f;
    for (int k = 0; k < 64 * img[0].channels; k++)
        sum += isfinite(img[0].pixels[k]) ? img[0].pixels[k] : 0.0f;
    assert_true(sum > 0.0f); /* the patches are there and lit */
    image_free(&img[0]);
    image_free(&img[1]);
    snprintf(args, sizeof args, "bake '%s/program.rib' -o '%s/program-bake.exr' --rays 4 --quiet",
             dir, dir);
    assert_int_equal(run(args), 0);
    snprintf(args, sizeof args,
             "render '%s/program.rib' -o '%s/none.png' --spp 1 --max-lod 2 --no-programs", dir,
             dir);
    assert_int_equal(run(args), 1); /* nothing left to render */
    char err[8192];
    read_stderr(err, sizeof err);
    if (!strstr(err, "program.rib:4:25: warning: Procedural \"RunProgram\": \"gen.sh\" is not run "
                     "(programs are off: --no-programs); skipped\n"))
        fail_msg("stderr lacks the warning:\n%s", err);
    assert_false(exists("none.png"));
}

/* Renders dir/scene to dir/out with `extra` options; returns the image (EXR) and the sum of
 * its R, G, B. */
static double render_exr(const char *scene, const char *out, const char *extra, ts_image *img)
{
    char args[16384];
    snprintf(args, sizeof args, "render '%s/%s' -o '%s/%s' --spp 4 --max-lod 2 --quiet %s", dir,
             scene, dir, out, extra);
    assert_int_equal(run(args), 0);
    read_exr(out, img);
    assert_true(img->channels >= 3 && img->width == 16 && img->height == 16);
    double sum = 0.0;
    for (int k = 0; k < img->width * img->height; k++)
        for (int c = 0; c < 3; c++)
            sum += img->pixels[k * img->channels + c];
    return sum;
}

/* Integrator "PxrPathTracer" "int maxPathLength" [1] renders at depth 1: the image is bit for
 * bit the one `--depth 1` makes of the scene without it, and darker than the default depth 3
 * (the two walls of a corner light each other again at every bounce); `--depth 3` overrides
 * the Integrator and gives the default's image again. */
static void test_integrator_depth(void **state)
{
    (void)state;
    static const char *const world =
        "WorldBegin\nLightSource \"distantlight\" 1 \"intensity\" 2\n"
        "Patch \"bilinear\" \"P\" [-2 -2 3  0 -2 5  -2 2 3  0 2 5]\n"
        "Patch \"bilinear\" \"P\" [0 -2 5  2 -2 3  0 2 5  2 2 3]\nWorldEnd\n";
    char text[1024];
    snprintf(text, sizeof text,
             "Format 16 16 1\nIntegrator \"PxrPathTracer\" \"pt\" \"int maxPathLength\" [1]\n%s",
             world);
    write_text("depth1.rib", text);
    snprintf(text, sizeof text, "Format 16 16 1\n%s", world);
    write_text("nodepth.rib", text);
    ts_image a, b, c, d;
    double sa = render_exr("depth1.rib", "a.exr", "", &a);
    double sb = render_exr("nodepth.rib", "b.exr", "--depth 1", &b);
    double sc = render_exr("nodepth.rib", "c.exr", "", &c);
    double sd = render_exr("depth1.rib", "d.exr", "--depth 3", &d);
    size_t bytes = sizeof(float) * 256u * (size_t)a.channels;
    assert_int_equal(a.channels, b.channels);
    assert_memory_equal(a.pixels, b.pixels, bytes);
    assert_int_equal(c.channels, d.channels);
    assert_memory_equal(c.pixels, d.pixels, bytes);
    if (!(sa > 0.0 && sa == sb && sc > sa * 1.05 && sd == sc))
        fail_msg("sums: maxPathLength 1 %g, --depth 1 %g, default %g, --depth 3 over it %g", sa, sb,
                 sc, sd);
    image_free(&a);
    image_free(&b);
    image_free(&c);
    image_free(&d);
}

static void test_huge_resolution_is_refused(void **state)
{
    (void)state;
    char args[16384];
    const char *scene = test_source_path("scene/one_patch.rib");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res 65536x65536 --spp 1", scene,
             dir);
    expect_error(args, "--res 65536x65536 at --spp 1 is 4294967296 samples; at most 4294967295");
    snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res 40000x30000 --spp 4", scene,
             dir);
    expect_error(args, "is 4800000000 samples; at most 4294967295 (2^32 - 1)");
    /* The default device's largest buffer, from `tessera devices` (opening the device here
     * would put this whole program under Oclgrind in check_kernels). */
    char cmd[4400], line[512];
    snprintf(cmd, sizeof cmd, "'%s' devices", test_tessera_binary());
    FILE *p = popen(cmd, "r");
    unsigned long long max_alloc_mb = 0;
    while (p && fgets(line, sizeof line, p) && !max_alloc_mb) {
        const char *at = strstr(line, "(max buffer ");
        if (at) max_alloc_mb = strtoull(at + 12, NULL, 10);
    }
    if (p) pclose(p);
    assert_true(max_alloc_mb > 0);
    if (max_alloc_mb < 65535) {
        snprintf(args, sizeof args, "render '%s' -o '%s/out.png' --res 65536x65535 --spp 1", scene,
                 dir);
        expect_error(args, "65536x65535 needs film buffers of 65535 MB; the device's largest "
                           "buffer is ");
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_render_exr_and_stats),
        cmocka_unit_test(test_png_is_written_atomically),
        cmocka_unit_test(test_paths_are_checked_before_rendering),
        cmocka_unit_test(test_huge_resolution_is_refused),
        cmocka_unit_test(test_warning_lines_escape_control_characters),
        cmocka_unit_test(test_missing_texture_and_strict),
        cmocka_unit_test(test_run_program),
        cmocka_unit_test(test_integrator_depth),
        cmocka_unit_test(test_images_without_the_module), /* last: it sets the environment */
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
