/* test_temp_files.c — the temporaries outputs are written through (base/file.h, issue 15,
 * item 8): ".BASE.tmp-PID-N" beside the target, BASE cut so that the name fits NAME_MAX
 * even for a 249-character output name; and the removal of stale ones, which touches only
 * this output's temporaries of processes that no longer run. Host only. */
#include "test_support.h"
#include "base/file.h"
#include "image/image.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char dir[4096];

static const char *in_dir(const char *name)
{
    static char buf[4][8192];
    static int next;
    char *out = buf[next++ % 4];
    snprintf(out, sizeof buf[0], "%s/%s", dir, name);
    return out;
}

static void touch(const char *name)
{
    FILE *f = fopen(in_dir(name), "w");
    assert_non_null(f);
    fclose(f);
}

static int exists(const char *name)
{
    struct stat st;
    return stat(in_dir(name), &st) == 0;
}

/* A process id that no longer runs: a child that has exited and been reaped. */
static long dead_pid(void)
{
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) _exit(0);
    assert_int_equal(waitpid(pid, NULL, 0), pid);
    return (long)pid;
}

/* `n` copies of 'a' followed by ext, in static storage. */
static const char *long_name(size_t n, const char *ext)
{
    static char buf[512];
    memset(buf, 'a', n);
    snprintf(buf + n, sizeof buf - n, "%s", ext);
    return buf;
}

static void test_temp_names(void **state)
{
    (void)state;
    char out[8192], want[8192];
    assert_int_equal(ts_file_temp_name(in_dir("out.png"), 123, 4, out, sizeof out), 0);
    snprintf(want, sizeof want, "%s/.out.png.tmp-123-4", dir);
    assert_string_equal(out, want);
    assert_int_equal(ts_file_temp_name("out.png", 123, 4, out, sizeof out), 0);
    assert_string_equal(out, ".out.png.tmp-123-4");
    /* A 249-character name: BASE is cut so that the temporary is exactly NAME_MAX long. */
    const char *name = long_name(245, ".png");
    assert_int_equal(ts_file_temp_name(in_dir(name), 4194303, 17, out, sizeof out), 0);
    const char *last = strrchr(out, '/') + 1;
    assert_int_equal(strlen(last), NAME_MAX);
    assert_true(last[0] == '.' && strncmp(last + 1, name, 20) == 0);
    assert_string_equal(last + strlen(last) - strlen(".tmp-4194303-17"), ".tmp-4194303-17");
    assert_int_equal(ts_file_temp_name(in_dir("out.png"), 1, 1, out, 8), -1); /* too small */
}

static void test_stale_temps_removed(void **state)
{
    (void)state;
    long dead = dead_pid(), alive = (long)getppid();
    char gone[2][512], keep[4][512];
    snprintf(gone[0], sizeof gone[0], ".out.png.tmp-%ld-0", dead);
    snprintf(gone[1], sizeof gone[1], ".out.png.tmp-%ld-12", dead);
    snprintf(keep[0], sizeof keep[0], ".out.png.tmp-%ld-0", alive);  /* a render still writing */
    snprintf(keep[1], sizeof keep[1], ".other.png.tmp-%ld-0", dead); /* another output's */
    snprintf(keep[2], sizeof keep[2], ".out.png.tmp-%ld-x", dead);   /* not the pattern */
    snprintf(keep[3], sizeof keep[3], ".out.tmp-%ld-0", dead);       /* "out", a shorter name */
    for (int i = 0; i < 2; ++i)
        touch(gone[i]);
    for (int i = 0; i < 4; ++i)
        touch(keep[i]);
    assert_int_equal(ts_file_remove_stale_temps(in_dir("out.png")), 2);
    for (int i = 0; i < 2; ++i)
        if (exists(gone[i])) fail_msg("%s was not removed", gone[i]);
    for (int i = 0; i < 4; ++i)
        if (!exists(keep[i])) fail_msg("%s was removed", keep[i]);
    /* The cut temporaries of a 249-character name are found too. */
    const char *lname = long_name(245, ".png");
    char tmp[8192];
    assert_int_equal(ts_file_temp_name(in_dir(lname), dead, 3, tmp, sizeof tmp), 0);
    FILE *f = fopen(tmp, "w");
    assert_non_null(f);
    fclose(f);
    assert_int_equal(ts_file_remove_stale_temps(in_dir(lname)), 1);
    struct stat st;
    assert_int_not_equal(stat(tmp, &st), 0);
}

/* An image written under a 249-character name: the temporary fits, nothing is left. */
static void test_image_with_a_long_name(void **state)
{
    (void)state;
    float rgb[2 * 2 * 3] = {0};
    ts_error err = {0};
    const char *name = long_name(245, ".png");
    if (image_write_png(in_dir(name), 2, 2, rgb, &err)) fail_msg("%s", err.msg);
    assert_true(exists(name));
    char cmd[4400];
    snprintf(cmd, sizeof cmd, "ls -a '%s' | grep -q 'tmp-%ld-'", dir, (long)getpid());
    assert_int_not_equal(system(cmd), 0);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_temp_names),
        cmocka_unit_test(test_stale_temps_removed),
        cmocka_unit_test(test_image_with_a_long_name),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
