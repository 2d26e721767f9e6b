/* test_kernel_cache.c — the kernel binary cache never hands the driver a damaged entry
 * (issue 15, item 1). A render fills a private cache; the entry is then truncated to half,
 * to 64 bytes and by one byte, given garbage after a valid header, has one byte flipped, or
 * is replaced by a directory or a FIFO. Each time the next render must exit 0 with exactly
 * one warning naming the entry, give the same pixels as the first render, and leave a good
 * entry behind (the render after it warns no more). */
#include "test_support.h"

#include "image/image.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char dir[4096], cache[4200];

static int setup(void **state)
{
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    snprintf(cache, sizeof cache, "%s/cache", dir);
    setenv("TESSERA_CACHE_DIR", cache, 1);
    return 0;
}

/* The one entry in the cache directory (fails unless there is exactly one). */
static const char *the_entry(void)
{
    static char path[8400];
    DIR *d = opendir(cache);
    assert_non_null(d);
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        if (strstr(e->d_name, ".bin") && !strstr(e->d_name, ".tmp")) {
            snprintf(path, sizeof path, "%s/%s", cache, e->d_name);
            ++n;
        }
    closedir(d);
    assert_int_equal(n, 1);
    return path;
}

static int count_warnings(void)
{
    FILE *f = fopen(test_path_in(dir, "stderr.txt"), "r");
    assert_non_null(f);
    char line[8192];
    int n = 0;
    while (fgets(line, sizeof line, f))
        if (strstr(line, "warning: kernel cache entry") && strstr(line, cache)) ++n;
    fclose(f);
    return n;
}

static void render(const char *out)
{
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --res 16x16 --spp 1",
                              test_source_path("scene/one_patch.rib"), out);
    assert_int_equal(rc, 0);
}

static void write_bytes(const char *path, const unsigned char *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

static unsigned char *read_bytes(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *p = malloc(*n);
    assert_non_null(p);
    assert_int_equal(fread(p, 1, *n, f), *n);
    fclose(f);
    return p;
}

static void test_damaged_entries_are_rebuilt(void **state)
{
    char ref[8400], out[8400];
    snprintf(ref, sizeof ref, "%s/ref.exr", dir);
    snprintf(out, sizeof out, "%s/out.exr", dir);
    render(ref);
    assert_int_equal(count_warnings(), 0);
    size_t n;
    unsigned char *good = read_bytes(the_entry(), &n);
    assert_true(n > 1000);
    enum { HALF, SIXTY_FOUR, ONE_SHORT, GARBAGE, FLIP, DIRECTORY, FIFO, CASES };
    for (int c = 0; c < CASES; ++c) {
        const char *entry = the_entry();
        unsigned char *bad = malloc(n);
        assert_non_null(bad);
        memcpy(bad, good, n);
        switch (c) {
        case HALF:
            write_bytes(entry, bad, n / 2);
            break;
        case SIXTY_FOUR:
            write_bytes(entry, bad, 64);
            break;
        case ONE_SHORT:
            write_bytes(entry, bad, n - 1);
            break;
        case GARBAGE: /* a valid header, then noise */
            for (size_t i = 32; i < n; ++i)
                bad[i] = (unsigned char)(i * 2654435761u >> 13);
            write_bytes(entry, bad, n);
            break;
        case FLIP:
            bad[n / 2] ^= 0xff;
            write_bytes(entry, bad, n);
            break;
        case DIRECTORY:
            assert_int_equal(unlink(entry), 0);
            assert_int_equal(mkdir(entry, 0755), 0);
            break;
        case FIFO:
            assert_int_equal(unlink(entry), 0);
            assert_int_equal(mkfifo(entry, 0644), 0);
            break;
        }
        free(bad);
        render(out);
        if (count_warnings() != 1) fail_msg("case %d: not exactly one warning", c);
        test_assert_same_pixels(ref, out);
        if (c == DIRECTORY) { /* a directory cannot be replaced by rename: left as it is */
            struct stat st;
            assert_int_equal(stat(entry, &st), 0);
            assert_true(S_ISDIR(st.st_mode));
            assert_int_equal(rmdir(entry), 0);
        }
        render(out); /* the entry was rewritten (or removed above): no warning */
        if (count_warnings() != 0) fail_msg("case %d: the entry was not rewritten", c);
        test_assert_same_pixels(ref, out);
    }
    free(good);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_damaged_entries_are_rebuilt),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
