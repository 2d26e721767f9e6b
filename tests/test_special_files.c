/* test_special_files.c — inputs that are not regular files (issue 15, item 7): a FIFO as
 * the scene, as a ReadArchive target, as a texture or as a mesh used to block forever in
 * open(); /dev/zero spun inside OpenImageIO or grew memory until allocation failed. Each
 * must fail at once with one line naming the path and "not a regular file", and write no
 * image. Every run is under `timeout 10`, so a hang fails the test (exit 124) instead of
 * hanging the suite. Inputs are refused while the scene loads, before any device is opened,
 * so the test needs none. */
#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char dir[4096];

static const char *in_dir(const char *name)
{
    static char buf[4][4400];
    static int next;
    char *out = buf[next++ % 4];
    snprintf(out, sizeof buf[0], "%s/%s", dir, name);
    return out;
}

static void write_text(const char *name, const char *text)
{
    FILE *f = fopen(in_dir(name), "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* Renders scene (a path) and expects exit status 1 with one line holding `path` and "not a
 * regular file (what)", and no image. */
static void expect_refused(const char *scene, const char *path, const char *what)
{
    char cmd[16384];
    snprintf(cmd, sizeof cmd,
             "cd '%s' && timeout 10 '%s' render '%s' -o '%s' --res 8x8 2>'%s' >/dev/null", dir,
             test_tessera_binary(), scene, in_dir("out.png"), in_dir("stderr.txt"));
    int st = system(cmd);
    int rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    const char *err = test_stderr_of(dir);
    if (rc != 1) fail_msg("render %s: exit status %d (124: it hung):\n%s", scene, rc, err);
    char needle[4400];
    snprintf(needle, sizeof needle, "%s: not a regular file (%s)", path, what);
    if (!strstr(err, needle)) fail_msg("render %s: stderr lacks \"%s\":\n%s", scene, needle, err);
    assert_true(strchr(err, '\n') && strchr(err, '\n')[1] == '\0');
    struct stat st_out;
    assert_int_not_equal(stat(in_dir("out.png"), &st_out), 0);
}

/* one_patch.rib with `line` inserted before its Color request, as dir/name. */
static void scene_with(const char *name, const char *line)
{
    FILE *f = fopen(test_source_path("scene/one_patch.rib"), "r");
    static char text[1 << 14], out[1 << 15];
    size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f) fclose(f);
    text[n] = '\0';
    char *color = strstr(text, "Color [");
    assert_non_null(color);
    snprintf(out, sizeof out, "%.*s%s\n%s", (int)(color - text), text, line, color);
    write_text(name, out);
}

static void test_scene(void **state)
{
    (void)state;
    expect_refused("fifo", "fifo", "a FIFO");
    expect_refused("fifo.rib", "fifo.rib", "a FIFO");
    expect_refused("/dev/zero", "/dev/zero", "a character device");
}

static void test_read_archive(void **state)
{
    (void)state;
    write_text("archive_fifo.rib", "WorldBegin\nReadArchive \"fifo\"\nWorldEnd\n");
    expect_refused("archive_fifo.rib", "\"fifo\"", "a FIFO");
    write_text("archive_zero.rib", "WorldBegin\nReadArchive \"/dev/zero\"\nWorldEnd\n");
    expect_refused("archive_zero.rib", "\"/dev/zero\"", "a character device");
    write_text("delayed_fifo.rib", "WorldBegin\nProcedural \"DelayedReadArchive\" [\"fifo\"] "
                                   "[-1 1 -1 1 -1 1]\nWorldEnd\n");
    expect_refused("delayed_fifo.rib", "\"fifo\"", "a FIFO");
}

static void test_texture(void **state)
{
    (void)state;
    scene_with("colour_fifo.rib", "Surface \"matte\" \"string texturename\" [\"fifo\"]");
    expect_refused("colour_fifo.rib", "fifo", "a FIFO");
    scene_with("colour_zero.rib", "Surface \"matte\" \"string texturename\" [\"/dev/zero\"]");
    expect_refused("colour_zero.rib", "/dev/zero", "a character device");
    scene_with("height_zero.rib", "Displacement \"texture\" \"string texturename\" "
                                  "[\"/dev/zero\"] \"float amplitude\" [0.1]");
    expect_refused("height_zero.rib", "/dev/zero", "a character device");
}

static void test_mesh(void **state)
{
    (void)state;
    write_text("mesh_fifo.rib", "WorldBegin\nProcedural \"DynamicLoad\" [\"mesh\" \"fifo.obj\"] "
                                "[-1 1 -1 1 -1 1]\nWorldEnd\n");
    expect_refused("mesh_fifo.rib", "fifo.obj", "a FIFO");
    write_text("mesh_zero.rib", "WorldBegin\nProcedural \"DynamicLoad\" [\"mesh\" \"/dev/zero\"] "
                                "[-1 1 -1 1 -1 1]\nWorldEnd\n");
    expect_refused("mesh_zero.rib", "/dev/zero", "a character device");
    expect_refused("fifo.obj", "fifo.obj", "a FIFO"); /* a mesh as the scene */
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    const char *fifos[] = {"fifo", "fifo.rib", "fifo.obj"};
    for (int i = 0; i < 3; ++i)
        if (mkfifo(in_dir(fifos[i]), 0600) != 0) return -1;
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene),
        cmocka_unit_test(test_read_archive),
        cmocka_unit_test(test_texture),
        cmocka_unit_test(test_mesh),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
