/* test_fuzz_regressions.c — replays every input in tests/fuzz/regressions/ (crashes found by
 * tools/fuzz.sh, and hand-made tricky inputs) through rib_parse_string: each must return
 * without crashing (under tools/test_sanitize.sh also without an ASan/UBSan report or a
 * leak), a failure must leave the scene zeroed with a message, and a success must give a
 * scene that scene_free releases. Host only: never skips. */
#include "test_support.h"
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("%s: cannot open", path);
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    assert_non_null(buf);
    for (;;) {
        if (n == cap) {
            cap *= 2;
            buf = realloc(buf, cap);
            assert_non_null(buf);
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        if (got == 0) break;
        n += got;
    }
    fclose(f);
    /* An exact-size copy, so that ASan sees any read past the end. */
    char *exact = malloc(n ? n : 1);
    assert_non_null(exact);
    memcpy(exact, buf, n);
    free(buf);
    *len = n;
    return exact;
}

static void test_every_regression_input(void **state)
{
    const char *dir = test_source_path("tests/fuzz/regressions");
    DIR *d = opendir(dir);
    if (!d) fail_msg("%s: cannot open", dir);
    char *names[4096];
    int count = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || strcmp(e->d_name, "README.md") == 0) continue;
        if (count == (int)(sizeof names / sizeof *names)) fail_msg("too many files in %s", dir);
        names[count] = strdup(e->d_name);
        assert_non_null(names[count]);
        ++count;
    }
    closedir(d);
    qsort(names, (size_t)count, sizeof *names, by_name);
    assert_true(count > 0);
    static const ts_scene zero;
    for (int i = 0; i < count; ++i) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        size_t len = 0;
        char *text = read_all(path, &len);
        ts_scene scene;
        memset(&scene, 0, sizeof scene);
        ts_error err = {0};
        int rc = rib_parse_string(names[i], text, len, &scene, 1, &err);
        printf("%s: %zu bytes: %s\n", names[i], len, rc == TS_OK ? "parsed" : err.msg);
        if (rc != TS_OK) {
            if (memcmp(&scene, &zero, sizeof scene) != 0)
                fail_msg("%s: failed (%s) but left a non-empty scene", names[i], err.msg);
            if (err.code != rc || err.msg[0] == '\0')
                fail_msg("%s: returned %d with err.code %d and message \"%s\"", names[i], rc,
                         err.code, err.msg);
        }
        scene_free(&scene);
        ts_error_clear(&err);
        free(text);
        free(names[i]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_every_regression_input)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
