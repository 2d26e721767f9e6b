/* test_devices.c — one frame on several devices of one process (host/app/workers.c), on two
 * PoCL devices (POCL_DEVICES="pthread pthread", set here): the image equals the one-device
 * image bit for bit (every channel) on the teapot, the displaced teapot and the textured
 * scene, also with units that cut passes at odd places; with one device slowed
 * (TESSERA_SLOW_DEVICE) the split shifts towards the other and the image stays the same, and
 * the slow device's last unit is backed up by the fast one (merged once, the same bits); an
 * interrupted render resumes to the same bits; --stats has one "devices" entry per device;
 * the devices share built patches (each diced once over both, same bits, also when the
 * arenas evict and when a device fails holding claims), in one arena for both by default
 * and through the copying store with TESSERA_SHARED_ARENAS=0; a frame whose patches do not fit
 * the budget dices about as often on two devices as on one;
 * bad input: an unknown device in a list, a repeated one, a device that fails to build (the
 * other goes on), a device that runs out of memory mid-frame (it retries smaller), every
 * device failing. Skipped (77) without PoCL's two devices. */
#include "test_support.h"
#include "base/file.h"
#include "image/image.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static char dir[4096];
/* The two PoCL pthread devices' indices, as "I,J", and the first alone. */
static char pair[32], first[16];

static const char *in_dir(const char *name)
{
    return test_path_in(dir, name);
}

/* Renders scene (relative to the source tree) to dir/out with the devices `devices` and
 * the extra arguments; fails the test unless it exits 0. */
static void render(const char *scene, const char *out, const char *devices, const char *extra)
{
    test_tessera_ok(dir, "render '%s' -o '%s' --device %s %s", test_source_path(scene), in_dir(out),
                    devices, extra);
}

/* render() with `args` and --stats into dir/stats. */
static void render_with_stats(const char *scene, const char *out, const char *devices,
                              const char *args, const char *stats)
{
    test_tessera_ok(dir, "render '%s' -o '%s' --device %s %s --stats '%s'", test_source_path(scene),
                    in_dir(out), devices, args, in_dir(stats));
}

/* The seconds of stage `stage` in device k's entry of a --stats file. */
static double device_stage(cJSON *root, int k, const char *stage)
{
    cJSON *d = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(root, "devices"), k);
    cJSON *v =
        cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(d, "stages"), stage);
    if (!cJSON_IsNumber(v)) fail_msg("stats: devices[%d].stages.%s is missing", k, stage);
    return v->valuedouble;
}

/* The devices entry of a --stats file, device k. */
static double device_number(cJSON *root, int k, const char *key)
{
    cJSON *devs = cJSON_GetObjectItemCaseSensitive(root, "devices");
    cJSON *d = cJSON_GetArrayItem(devs, k);
    cJSON *v = d ? cJSON_GetObjectItemCaseSensitive(d, key) : NULL;
    if (!cJSON_IsNumber(v)) fail_msg("stats: devices[%d].%s is missing", k, key);
    return v->valuedouble;
}

static const char *const scenes[] = {"scene/teapot.rib", "scene/teapot_displaced.rib",
                                     "scene/textured.rib"};

/* Two devices give the one-device image, every channel bit for bit, on three scenes; the
 * stats name both devices and account for every sample; both count a part of the lod pass
 * (app/workers.c), whose sums give the one-device levels of detail. */
static void test_two_devices_give_the_one_device_image(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 4 --max-lod 6 --quiet";
    /* Both devices' programs built first (the second device's text differs, -DTS_DEVICE_SLOT):
     * with the kernel cache cold, as after any kernel change, device 0 loaded its program
     * from the one-device render's entry and traced the whole small frame while device 1
     * was still compiling, which failed "units >= 1" below. */
    render(scenes[0], "warm.exr", pair, "--res 16x9 --spp 1 --quiet");
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; ++i) {
        render(scenes[i], "one.exr", first, args);
        char extra[256], slow[32];
        snprintf(extra, sizeof extra, "%s --stats '%s'", args, in_dir("two.json"));
        /* 20 units, device 0 pausing 20 ms after each: device 1 takes some even when it
         * starts late (compiling a kernel at a new size, or another test on the cores; with
         * 5 units device 0 once traced them all first, failing "units >= 1" in CI). */
        snprintf(slow, sizeof slow, "%s:20", first);
        setenv("TESSERA_UNIT_SAMPLES", "1024", 1);
        setenv("TESSERA_SLOW_DEVICE", slow, 1);
        render(scenes[i], "two.exr", pair, extra);
        unsetenv("TESSERA_UNIT_SAMPLES");
        unsetenv("TESSERA_SLOW_DEVICE");
        test_assert_same_pixels(in_dir("one.exr"), in_dir("two.exr"));
        cJSON *root = test_read_json(in_dir("two.json"));
        cJSON *devs = cJSON_GetObjectItemCaseSensitive(root, "devices");
        assert_int_equal(cJSON_GetArraySize(devs), 2);
        double samples = device_number(root, 0, "samples") + device_number(root, 1, "samples");
        assert_true(samples == 96.0 * 54 * 4);
        /* While a kernel ran on either device: at least each one's, at most both's sum. */
        double k0 = device_number(root, 0, "kernel_seconds");
        double k1 = device_number(root, 1, "kernel_seconds");
        double both = cJSON_GetObjectItemCaseSensitive(root, "kernel_seconds")->valuedouble;
        double wall = cJSON_GetObjectItemCaseSensitive(root, "wall_seconds")->valuedouble;
        double serial = cJSON_GetObjectItemCaseSensitive(root, "host_serial_seconds")->valuedouble;
        assert_true(k0 > 0 && k1 > 0 && both >= k0 - 1e-6 && both >= k1 - 1e-6);
        assert_true(both <= k0 + k1 + 1e-6 && both <= wall);
        assert_true(fabs(serial - (wall - both)) < 1e-6);
        for (int k = 0; k < 2; ++k) {
            assert_true(device_number(root, k, "kernel_seconds") <=
                        device_number(root, k, "frame_seconds"));
            double busy = device_number(root, k, "busy_fraction");
            assert_true(device_number(root, k, "units") >= 1);
            assert_true(busy > 0.0 && busy <= 1.0);
            assert_true(device_number(root, k, "rays") >= device_number(root, k, "samples"));
            assert_true(device_stage(root, k, "lod") > 0.0);
        }
        cJSON_Delete(root);
    }
}

/* A frame of 268,800 pixels splits the lod pass into four chunks, two a device, dealt out
 * in turn (app/workers.c lod_count_part): their sums are the one device's counts, so the
 * levels and the image are the one device's. */
static void test_lod_chunks_give_the_one_device_levels(void **state)
{
    (void)state;
    const char *args = "--res 640x420 --spp 1 --max-lod 6 --depth 1 --quiet";
    render("scene/teapot_displaced.rib", "chunks1.exr", first, args);
    render("scene/teapot_displaced.rib", "chunks2.exr", pair, args);
    test_assert_same_pixels(in_dir("chunks1.exr"), in_dir("chunks2.exr"));
}

/* --streams 2 on one device: two workers on it, each with its own queue, host thread and
 * half its budget, so that one's host stages overlap the other's kernels; the image is the
 * one stream's bit for bit, the stats list both (same index, half the budget each) and
 * account for every sample, and each ran kernels. */
static void test_two_streams_give_the_one_stream_image(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 4 --max-lod 6 --memory 64 --quiet";
    render("scene/teapot_displaced.rib", "stream1.exr", first, args);
    char extra[512];
    snprintf(extra, sizeof extra, "%s --streams 2 --stats '%s'", args, in_dir("streams.json"));
    render("scene/teapot_displaced.rib", "stream2.exr", first, extra);
    test_assert_same_pixels(in_dir("stream1.exr"), in_dir("stream2.exr"));
    cJSON *root = test_read_json(in_dir("streams.json"));
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(root, "devices")), 2);
    double samples = 0;
    for (int k = 0; k < 2; ++k) {
        assert_true(device_number(root, k, "index") == atof(first));
        assert_true(device_number(root, k, "memory_budget_bytes") == 32.0 * 1024 * 1024);
        assert_true(device_number(root, k, "kernel_seconds") > 0);
        samples += device_number(root, k, "samples");
    }
    assert_true(samples == 96.0 * 54 * 4);
    cJSON_Delete(root);
}

/* A CPU device leaves the host the cores app/workers.h workers_host_cores names (here
 * TESSERA_HOST_CORES=1, as no GPU sits beside these CPU devices): each device becomes a
 * sub-device of the other compute units (the stats say how many), and the image stays the
 * whole devices' bit for bit. */
static void test_cpu_devices_leave_the_host_its_cores(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 2 --max-lod 6 --quiet";
    render_with_stats("scene/teapot_displaced.rib", "whole.exr", pair, args, "whole.json");
    cJSON *whole = test_read_json(in_dir("whole.json"));
    double units = device_number(whole, 0, "compute_units");
    cJSON_Delete(whole);
    if (units < 2) test_skip("the CPU device has one compute unit: none to leave the host");
    setenv("TESSERA_HOST_CORES", "1", 1);
    render_with_stats("scene/teapot_displaced.rib", "sub.exr", pair, args, "sub.json");
    unsetenv("TESSERA_HOST_CORES");
    test_assert_same_pixels(in_dir("whole.exr"), in_dir("sub.exr"));
    cJSON *sub = test_read_json(in_dir("sub.json"));
    for (int k = 0; k < 2; ++k)
        assert_true(device_number(sub, k, "compute_units") == units - 1);
    cJSON_Delete(sub);
}

/* A device that cannot count its part of the lod pass (TESSERA_FAIL_LOD_PART=1: it gives its
 * part up, as one whose launches fail would) leaves it to device 0: the same image, and
 * device 1 counted nothing. */
static void test_an_abandoned_lod_part_is_counted_by_device_0(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 2 --max-lod 6 --quiet";
    render("scene/teapot_displaced.rib", "lod1.exr", first, args);
    char extra[256];
    snprintf(extra, sizeof extra, "%s --stats '%s'", args, in_dir("lod2.json"));
    setenv("TESSERA_FAIL_LOD_PART", "1", 1);
    render("scene/teapot_displaced.rib", "lod2.exr", pair, extra);
    unsetenv("TESSERA_FAIL_LOD_PART");
    test_assert_same_pixels(in_dir("lod1.exr"), in_dir("lod2.exr"));
    cJSON *root = test_read_json(in_dir("lod2.json"));
    assert_true(device_stage(root, 0, "lod") > 0.0);
    assert_true(device_stage(root, 1, "lod") == 0.0);
    cJSON_Delete(root);
}

/* Units of 777 samples cut passes and cross from one pass into the next, in pass order and
 * in bands of rows: same bits; so do the levels of detail of TESSERA_LOD_RULE=seen. */
static void test_odd_units_give_the_same_image(void **state)
{
    (void)state;
    const char *args = "--res 64x36 --spp 3 --max-lod 6 --quiet";
    render("scene/teapot_displaced.rib", "odd1.exr", first, args);
    setenv("TESSERA_UNIT_SAMPLES", "777", 1);
    render("scene/teapot_displaced.rib", "odd2.exr", pair, args);
    /* Bands of one row and of five (kernels/lib/sample_order.h), units cutting across them:
     * the same bits. */
    setenv("TESSERA_SAMPLE_BAND_ROWS", "1", 1);
    render("scene/teapot_displaced.rib", "band1.exr", pair, args);
    setenv("TESSERA_SAMPLE_BAND_ROWS", "5", 1);
    render("scene/teapot_displaced.rib", "band5.exr", pair, args);
    unsetenv("TESSERA_SAMPLE_BAND_ROWS");
    unsetenv("TESSERA_UNIT_SAMPLES");
    test_assert_same_pixels(in_dir("odd1.exr"), in_dir("odd2.exr"));
    test_assert_same_pixels(in_dir("odd1.exr"), in_dir("band1.exr"));
    test_assert_same_pixels(in_dir("odd1.exr"), in_dir("band5.exr"));
    /* The seen rule traces the first pass in the lod stage (app/waves.c on the first
     * device); the others take its levels: same bits as one device under that rule. */
    setenv("TESSERA_LOD_RULE", "seen", 1);
    render("scene/teapot_displaced.rib", "seen1.exr", first, args);
    render("scene/teapot_displaced.rib", "seen2.exr", pair, args);
    unsetenv("TESSERA_LOD_RULE");
    test_assert_same_pixels(in_dir("seen1.exr"), in_dir("seen2.exr"));
}

/* Device k of the pair slowed by 150 ms a wave: the other takes most units, and the image is
 * the same. */
static void slowed(int k, const char *out, const char *json)
{
    char slow[64], extra[256];
    int index = atoi(k == 0 ? pair : strchr(pair, ',') + 1);
    snprintf(slow, sizeof slow, "%d:150", index);
    setenv("TESSERA_SLOW_DEVICE", slow, 1);
    snprintf(extra, sizeof extra, "--res 96x54 --spp 8 --max-lod 6 --quiet --stats '%s'",
             in_dir(json));
    render("scene/teapot.rib", out, pair, extra);
    unsetenv("TESSERA_SLOW_DEVICE");
}

static void test_a_slow_device_takes_fewer_units(void **state)
{
    (void)state;
    render("scene/teapot.rib", "fast.exr", first, "--res 96x54 --spp 8 --max-lod 6 --quiet");
    for (int k = 0; k < 2; ++k) {
        slowed(k, "slow.exr", "slow.json");
        cJSON *root = test_read_json(in_dir("slow.json"));
        double mine = device_number(root, k, "units"), other = device_number(root, 1 - k, "units");
        if (!(other > 2 * mine))
            fail_msg("device %d (slowed) took %g units, the other %g", k, mine, other);
        cJSON_Delete(root);
        test_assert_same_pixels(in_dir("fast.exr"), in_dir("slow.exr"));
    }
}

/* The first device 100 ms a wave, the second 20 s: when no unit is left, the first traces a
 * backup of the one the second holds (units.h); the backup is merged, the slow copy dropped
 * (stopped in its pause, so the 20 s are not waited for), every sample merged once, and the
 * image is the same. The second's pause is long so that it stays more than twice as slow, and
 * holds its unit more than 4x the first's time a unit, however slow the first runs (a CI run
 * under ASan with other tests beside it: at 3 s the first took long enough a unit that the
 * second finished both of its units and nothing was backed up). */
static void test_a_slow_devices_last_unit_is_backed_up(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 8 --max-lod 6 --quiet";
    render("scene/teapot.rib", "alone.exr", first, args);
    char slow[64];
    snprintf(slow, sizeof slow, "%d:100,%d:20000", atoi(pair), atoi(strchr(pair, ',') + 1));
    setenv("TESSERA_SLOW_DEVICE", slow, 1);
    setenv("TESSERA_UNIT_SAMPLES", "1024", 1);
    render_with_stats("scene/teapot.rib", "backup.exr", pair, args, "backup.json");
    unsetenv("TESSERA_SLOW_DEVICE");
    unsetenv("TESSERA_UNIT_SAMPLES");
    cJSON *root = test_read_json(in_dir("backup.json"));
    if (!(device_number(root, 0, "backup_units") >= 1 &&
          device_number(root, 1, "dropped_units") >= 1))
        fail_msg("no backup: device 0 took %g backups, device 1 dropped %g units (%g merged)",
                 device_number(root, 0, "backup_units"), device_number(root, 1, "dropped_units"),
                 device_number(root, 1, "units"));
    assert_true(device_number(root, 1, "backup_units") == 0);
    assert_true(device_number(root, 0, "samples") + device_number(root, 1, "samples") ==
                96.0 * 54 * 8);
    cJSON_Delete(root);
    test_assert_same_pixels(in_dir("alone.exr"), in_dir("backup.exr"));
}

/* The most samples a progress line of dir's stderr reports ("tessera: N / M samples"). */
static long progress_samples(void)
{
    const char *s = test_stderr_of(dir);
    long most = 0;
    for (const char *p = s; (p = strstr(p, "tessera: ")) != NULL; p += 9) {
        long n;
        if (sscanf(p + 9, "%ld / ", &n) == 1 && strstr(p, " samples") && n > most) most = n;
    }
    return most;
}

/* Starts `tessera render SCENE -o OUT --device DEVICES ARGS` in the background (stderr to
 * dir/stderr.txt); returns its process id. */
static int render_in_background(const char *scene, const char *out, const char *devices,
                                const char *args)
{
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "'%s' render '%s' -o '%s' --device %s %s 2>'%s' & echo $! > '%s'",
             test_tessera_binary(), scene, in_dir(out), devices, args, in_dir("stderr.txt"),
             in_dir("pid"));
    assert_int_equal(system(cmd), 0);
    FILE *f = fopen(in_dir("pid"), "r");
    int pid = 0;
    assert_true(f && fscanf(f, "%d", &pid) == 1);
    fclose(f);
    return pid;
}

/* Waits up to 60 s for process pid to end. */
static void wait_for_exit(int pid)
{
    for (int i = 0; i < 6000 && kill(pid, 0) == 0; ++i)
        nanosleep(&(struct timespec){0, 10000000}, NULL);
}

/* render_in_background, then, once its progress line reports more than `after` samples,
 * SIGTERM; waits for it to write the finished samples and exit. */
static void render_and_interrupt(const char *scene, const char *out, const char *devices,
                                 const char *args, long after)
{
    int pid = render_in_background(scene, out, devices, args);
    int progressed = 0;
    for (int i = 0; i < 6000 && !progressed; ++i) { /* up to 60 s */
        progressed = progress_samples() > after;
        if (!progressed) nanosleep(&(struct timespec){0, 10000000}, NULL);
    }
    assert_true(progressed);
    kill(pid, SIGTERM);
    wait_for_exit(pid);
    test_expect_in_stderr(dir, "interrupted by SIGTERM after ");
}

/* Whether files a and b hold the same bytes. */
static int same_bytes(const char *a, const char *b)
{
    char *ta = NULL, *tb = NULL, why[256];
    size_t na = 0, nb = 0;
    int same = ts_file_read_all(a, &ta, &na, why, sizeof why) == TS_OK &&
               ts_file_read_all(b, &tb, &nb, why, sizeof why) == TS_OK && na == nb &&
               memcmp(ta, tb, na) == 0;
    free(ta), free(tb);
    return same;
}

/* Two devices write the EXR's rows while they render (app/output.h): its temporary beside
 * the output holds compressed rows while the progress line is short of the frame's
 * samples, and the file it becomes is the one-device render's, byte for byte, with no
 * temporary left; a PNG's too. */
static void test_the_exr_is_written_while_rendering(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 8 --max-lod 6";
    render("scene/teapot.rib", "stream1.exr", first, "--res 96x54 --spp 8 --max-lod 6 --quiet");
    char slow[64];
    snprintf(slow, sizeof slow, "%d:60,%d:60", atoi(pair), atoi(strchr(pair, ',') + 1));
    setenv("TESSERA_SLOW_DEVICE", slow, 1); /* 60 ms a wave: a render of about 2 s */
    setenv("TESSERA_UNIT_SAMPLES", "1024", 1);
    int pid = render_in_background(test_source_path("scene/teapot.rib"), "stream2.exr", pair, args);
    unsetenv("TESSERA_SLOW_DEVICE");
    unsetenv("TESSERA_UNIT_SAMPLES");
    char tmp[4096]; /* the stream's temporary (image.h: written beside, renamed at the end) */
    assert_int_equal(ts_file_temp_name(in_dir("stream2.exr"), pid, 0, tmp, sizeof tmp), 0);
    int seen = 0;
    for (int i = 0; i < 12000 && !seen && kill(pid, 0) == 0; ++i) { /* up to 60 s */
        struct stat st;
        seen = stat(tmp, &st) == 0 && st.st_size > 4096 &&
               progress_samples() < 96 * 54 * 8; /* rows in, the frame not done */
        if (!seen) nanosleep(&(struct timespec){0, 5000000}, NULL);
    }
    wait_for_exit(pid);
    assert_true(seen);
    assert_true(access(tmp, F_OK) != 0);
    assert_true(same_bytes(in_dir("stream1.exr"), in_dir("stream2.exr")));
    /* A PNG is streamed the same way: the one-device file, byte for byte. */
    render("scene/teapot.rib", "stream1.png", first, "--res 96x54 --spp 8 --max-lod 6 --quiet");
    render("scene/teapot.rib", "stream2.png", pair, "--res 96x54 --spp 8 --max-lod 6 --quiet");
    assert_true(same_bytes(in_dir("stream1.png"), in_dir("stream2.png")));
}

/* One device writes the image's rows on a thread beside its waves (app/writer.h): with waves
 * of 4096 paths (TESSERA_FIT_WAVE_RAYS) and a pause after each, the temporary beside the
 * output holds compressed rows (past `header` bytes) while the progress line is short of the
 * frame's `samples`, and the file it becomes is the one-wave render's (whose rows all come at
 * the end), byte for byte, with no temporary left. ext: "exr" or "png". */
static void one_device_writes_while_rendering(const char *ext, const char *args, long samples,
                                              long header)
{
    char one[64], waves[64], quiet[256];
    snprintf(one, sizeof one, "wave1.%s", ext);
    snprintf(waves, sizeof waves, "waves.%s", ext);
    snprintf(quiet, sizeof quiet, "%s --quiet", args);
    render("scene/teapot.rib", one, first, quiet);
    char slow[32];
    snprintf(slow, sizeof slow, "%s:150", first);
    setenv("TESSERA_SLOW_DEVICE", slow, 1); /* 150 ms a wave: a render of seconds */
    setenv("TESSERA_FIT_WAVE_RAYS", "8192", 1);
    int pid = render_in_background(test_source_path("scene/teapot.rib"), waves, first, args);
    unsetenv("TESSERA_SLOW_DEVICE");
    unsetenv("TESSERA_FIT_WAVE_RAYS");
    char tmp[4096];
    assert_int_equal(ts_file_temp_name(in_dir(waves), pid, 0, tmp, sizeof tmp), 0);
    int seen = 0;
    for (int i = 0; i < 12000 && !seen && kill(pid, 0) == 0; ++i) { /* up to 60 s */
        struct stat st;
        seen = stat(tmp, &st) == 0 && st.st_size > header && progress_samples() < samples;
        if (!seen) nanosleep(&(struct timespec){0, 5000000}, NULL);
    }
    wait_for_exit(pid);
    assert_true(seen);
    assert_true(access(tmp, F_OK) != 0);
    assert_true(same_bytes(in_dir(one), in_dir(waves)));
}

static void test_one_device_writes_the_exr_while_rendering(void **state)
{
    (void)state;
    one_device_writes_while_rendering("exr", "--res 96x54 --spp 8 --max-lod 6", 96 * 54 * 8, 4096);
}

static void test_one_device_writes_the_png_while_rendering(void **state)
{
    (void)state;
    /* zlib and stdio hold a PNG's first 16 KB: a frame whose rows make more */
    one_device_writes_while_rendering("png", "--res 320x180 --spp 1 --max-lod 6", 320 * 180, 512);
}

/* SIGTERM in the middle of a two-device render: the units merged so far are written (exit 3)
 * and --resume, on two devices or one, finishes it to the uninterrupted image. Units are
 * merged as they finish (each is a band of rows, no pixel in two), so with one device far
 * slower than the other the film holds runs past a gap: the file says which
 * ("tessera:done"), and the resume traces exactly the rest. */
static void test_interrupted_two_device_render_resumes(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/teapot.rib");
    const char *args = "--res 96x54 --spp 8 --max-lod 6";
    render("scene/teapot.rib", "whole.exr", first, "--res 96x54 --spp 8 --max-lod 6 --quiet");
    for (int resume_on_two = 0; resume_on_two < 2; ++resume_on_two) {
        char slow[64];
        /* The first device 40 ms a wave, the second 3 s: it holds its first unit while the
         * other merges several. */
        snprintf(slow, sizeof slow, "%d:40,%d:3000", atoi(pair), atoi(strchr(pair, ',') + 1));
        setenv("TESSERA_SLOW_DEVICE", slow, 1); /* a render of a few seconds */
        setenv("TESSERA_UNIT_SAMPLES", "1024", 1);
        /* The environment is read at the start: interrupted once three units of 768 merged. */
        render_and_interrupt(scene, "cut.exr", pair, args, 3 * 768 - 1);
        unsetenv("TESSERA_SLOW_DEVICE");
        unsetenv("TESSERA_UNIT_SAMPLES");
        int done = -1;
        ts_error err = {0};
        if (image_read_meta_int(in_dir("cut.exr"), "tessera:samples_done", &done, &err))
            fail_msg("%s", err.msg);
        assert_true(done > 0 && done < 96 * 54 * 8);
        char runs[256];
        if (image_read_meta_string(in_dir("cut.exr"), "tessera:done", runs, sizeof runs, &err))
            fail_msg("%s: the runs past the gap are not recorded", err.msg);
        /* Not a prefix: a run after a gap, or a run that starts past unit 0. */
        assert_true(strchr(runs, ' ') != NULL || strncmp(runs, "0-", 2) != 0);
        test_tessera_ok(dir, "render '%s' -o '%s' --device %s %s --resume --quiet", scene,
                        in_dir("cut.exr"), resume_on_two ? pair : first, args);
        test_assert_same_pixels(in_dir("whole.exr"), in_dir("cut.exr"));
    }
}

/* One device traces pixel after pixel (bands of one pixel, app/done.h): SIGTERM in the middle
 * of such a render leaves a prefix of that order, and --resume on two devices finishes it to
 * the uninterrupted image, its units made of whole pixels (units_list gathers the one-pixel
 * bands) with the samples 0's AOVs picked from each wave (workers.c). */
static void test_one_device_render_resumes_on_two(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/teapot.rib");
    /* 17 waves of about 14k samples at 16 MB (as in test_failure). */
    const char *args = "--res 320x180 --spp 4 --memory 16 --max-lod 6";
    render("scene/teapot.rib", "whole1.exr", first,
           "--res 320x180 --spp 4 --memory 16 --max-lod 6 --quiet");
    render_and_interrupt(scene, "cut1.exr", first, args, 0); /* after a wave */
    int done = -1, band = -1;
    ts_error err = {0};
    if (image_read_meta_int(in_dir("cut1.exr"), "tessera:samples_done", &done, &err) ||
        image_read_meta_int(in_dir("cut1.exr"), "tessera:band", &band, &err))
        fail_msg("%s", err.msg);
    assert_true(done > 0 && done < 320 * 180 * 4);
    assert_int_equal(band, 1); /* the one-device order */
    test_tessera_ok(dir, "render '%s' -o '%s' --device %s %s --resume --quiet", scene,
                    in_dir("cut1.exr"), pair, args);
    test_assert_same_pixels(in_dir("whole1.exr"), in_dir("cut1.exr"));
}

static void expect_error(const char *devices, const char *needle)
{
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --device %s --res 16x16",
                              test_source_path("scene/teapot.rib"), in_dir("bad.png"), devices);
    assert_int_equal(rc, 1);
    test_expect_in_stderr(dir, needle);
}

static void test_bad_device_lists(void **state)
{
    (void)state;
    char list[64];
    snprintf(list, sizeof list, "%s,41", pair);
    expect_error(list, "unknown device index 41 in --device ");
    expect_error("0,0", "bad value '0,0' for --device");
    expect_error("0,", "bad value '0,' for --device");
    expect_error("1,x", "bad value '1,x' for --device");
    setenv("TESSERA_DEVICE", "0,41", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --res 16x16",
                              test_source_path("scene/teapot.rib"), in_dir("bad.png"));
    unsetenv("TESSERA_DEVICE");
    assert_int_equal(rc, 1);
    test_expect_in_stderr(dir, "unknown device index 41 in TESSERA_DEVICE=0,41");
}

/* The index of the device of PoCL's driver `driver` under POCL_DEVICES=pocl (from `tessera
 * devices`: PoCL may not be the only platform), as text; its name prefix (test_pocl_prefix)
 * goes to *prefix unless NULL. */
static const char *index_of(const char *pocl, const char *driver, const char **prefix)
{
    static char out[2][16];
    static int next;
    char *o = out[next++ % 2], name[256];
    if (test_devices_named(pocl, driver, o, 16, 1, name, sizeof name) != 1)
        fail_msg("no %s device under POCL_DEVICES=%s", driver, pocl);
    if (prefix) *prefix = test_pocl_prefix(name);
    return o;
}

/* POCL_DEVICES="pthread basic": the basic device fails to build (TESSERA_FAIL_BUILD), the
 * pthread one renders the frame alone with a warning naming the other; when both fail, the
 * render fails with the build error. */
static void test_a_device_that_fails_to_build_is_left_out(void **state)
{
    (void)state;
    const char *basic_prefix;
    const char *pt = index_of("pthread basic", "pthread", NULL),
               *basic = index_of("pthread basic", "basic", &basic_prefix);
    char both[40], warning[80];
    snprintf(both, sizeof both, "%s,%s", pt, basic);
    snprintf(warning, sizeof warning, "warning: device %s cannot render: CL_BUILD_PROGRAM_FAILURE",
             basic);
    setenv("POCL_DEVICES", "pthread basic", 1);
    const char *args = "--res 64x36 --spp 2 --max-lod 6";
    render("scene/teapot.rib", "alone.exr", pt, "--res 64x36 --spp 2 --max-lod 6 --quiet");
    setenv("TESSERA_FAIL_BUILD", basic_prefix, 1);
    render("scene/teapot.rib", "left_out.exr", both, args);
    test_expect_in_stderr(dir, warning);
    test_expect_in_stderr(dir, "the other devices go on without it");
    test_assert_same_pixels(in_dir("alone.exr"), in_dir("left_out.exr"));
    setenv("TESSERA_FAIL_BUILD", "*", 1); /* every device */
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --device all %s",
                              test_source_path("scene/teapot.rib"), in_dir("none.exr"), args);
    assert_int_equal(rc, 1);
    test_expect_in_stderr(dir, "tessera: CL_BUILD_PROGRAM_FAILURE in clBuildProgram");
    assert_int_equal(access(in_dir("none.exr"), F_OK), -1);
    unsetenv("TESSERA_FAIL_BUILD");
    setenv("POCL_DEVICES", "pthread pthread", 1);
}

/* A launch on the basic device fails mid-frame (CL_OUT_OF_RESOURCES): that device gives its
 * unit back, makes its pipeline again at half the budget and goes on; same image. */
static void test_a_device_out_of_memory_mid_frame_retries(void **state)
{
    (void)state;
    const char *basic_prefix;
    const char *pt = index_of("pthread basic", "pthread", NULL),
               *basic = index_of("pthread basic", "basic", &basic_prefix);
    char both[40], note[80];
    snprintf(both, sizeof both, "%s,%s", pt, basic);
    snprintf(note, sizeof note, "tessera: device %s (%s", basic, basic_prefix);
    setenv("POCL_DEVICES", "pthread basic", 1);
    const char *args = "--res 64x36 --spp 4 --max-lod 6 --memory 64";
    render("scene/teapot.rib", "ref_oom.exr", pt, "--res 64x36 --spp 4 --max-lod 6 --quiet");
    /* The basic device's kernels compiled beforehand, and the pthread device slowed after
     * each wave, so that the basic one takes units whatever the kernel cache held (its first
     * compile takes seconds, in which the other could trace every unit). */
    render("scene/teapot.rib", "basic_warm.exr", basic, "--res 16x16 --max-lod 6 --quiet");
    char slow[32];
    snprintf(slow, sizeof slow, "%s:100", pt);
    setenv("TESSERA_SLOW_DEVICE", slow, 1);
    setenv("TESSERA_FAIL_LAUNCH", "5", 1); /* in the basic device's first unit */
    setenv("TESSERA_FAIL_LAUNCH_DEVICE", basic_prefix, 1);
    setenv("TESSERA_UNIT_SAMPLES", "1024", 1);
    render("scene/teapot.rib", "oom.exr", both, args);
    unsetenv("TESSERA_FAIL_LAUNCH");
    unsetenv("TESSERA_FAIL_LAUNCH_DEVICE");
    unsetenv("TESSERA_UNIT_SAMPLES");
    unsetenv("TESSERA_SLOW_DEVICE");
    setenv("POCL_DEVICES", "pthread pthread", 1);
    test_expect_in_stderr(dir, note);
    test_expect_in_stderr(dir, "could not provide 64 MB (CL_OUT_OF_RESOURCES");
    test_expect_in_stderr(dir, "retrying with 32 MB");
    test_assert_same_pixels(in_dir("ref_oom.exr"), in_dir("oom.exr"));
}

/* A counter of a --stats file. */
static double counter(const char *json, const char *name)
{
    char key[128];
    snprintf(key, sizeof key, "counters.%s", name);
    return test_stats_number(in_dir(json), key);
}

/* A frame whose patches do not fit its budget (forest-100 320x128 x 2 at --memory 24: 63 MB of
 * patches, arenas of a few MB) on two devices. Each of the plan's small units was a wave of
 * its own that diced the forest again (214 K dicings where one device made 154 K, at
 * 1.7 times the time of one) with three quarters of each budget unused; now each device
 * traces its share of the frame in waves as large as its budget holds (app/workers.c
 * worker_squeeze, units.c board_regather): at most 1.15 times one device's dicings, one unit
 * or more a device, the same image. */
static void test_two_devices_squeezed_dice_as_one(void **state)
{
    (void)state;
    const char *args = "--res 320x128 --spp 2 --memory 24 --quiet";
    render_with_stats("scene/forest-100.rib", "sq1.exr", first, args, "sq1.json");
    render_with_stats("scene/forest-100.rib", "sq2.exr", pair, args, "sq2.json");
    test_assert_same_pixels(in_dir("sq1.exr"), in_dir("sq2.exr"));
    assert_true(counter("sq2.json", "patch_cache_evictions") > 0.0); /* it does not fit */
    assert_true(counter("sq2.json", "patches_diced") <=
                1.15 * counter("sq1.json", "patches_diced"));
    cJSON *root = test_read_json(in_dir("sq2.json"));
    for (int k = 0; k < 2; ++k)
        assert_true(device_number(root, k, "units") >= 1);
    cJSON_Delete(root);
}

/* Built patches shared between the two devices (host/pipeline/patch_share.h): the image is
 * the one-device image bit for bit; with every patch fitting the arenas and every claim waited
 * for (TESSERA_SHARE_WAIT=1), each is diced once over both devices (as many dicings as one
 * device makes) and every other miss is filled from the store; by default a small patch
 * still being built by the other device is diced again instead (trace.c share_await): at
 * most once more, the same bits; TESSERA_PATCH_SHARE=0 shares nothing and dices more. A budget
 * whose arenas evict (--memory 16 at --lod 7: the patches need 24 MB, more than the budget's trade
 * gives the arenas, so they keep the plan's quarter) still
 * shares, with the same bits. */
static void test_two_devices_share_built_patches(void **state)
{
    (void)state;
    char extra[512];
    const char *args = "--res 160x90 --spp 4 --max-lod 6 --memory 256 --quiet";
    render_with_stats("scene/teapot_displaced.rib", "share1.exr", first, args, "share1.json");
    snprintf(extra, sizeof extra, "%s --stats '%s'", args, in_dir("share3.json"));
    render("scene/teapot_displaced.rib", "share3.exr", pair, extra); /* the default */
    test_assert_same_pixels(in_dir("share1.exr"), in_dir("share3.exr"));
    double diced3 = counter("share3.json", "patches_diced");
    assert_true(diced3 >= 32.0 && diced3 <= 64.0);
    assert_true(diced3 + counter("share3.json", "patches_shared") ==
                counter("share3.json", "patch_cache_misses"));
    /* PoCL's devices share host memory: one arena for both, each patch at its own place
     * (app/workers.c workers_place), said unless quiet; TESSERA_SHARED_ARENAS=0 keeps an arena
     * a device and copies through the store (a GPU's way): the same bits, twice the arenas. */
    render("scene/teapot_displaced.rib", "share3n.exr", pair,
           "--res 160x90 --spp 4 --max-lod 6 --memory 256");
    test_expect_in_stderr(dir, "share one patch arena of");
    test_assert_same_pixels(in_dir("share1.exr"), in_dir("share3n.exr"));
    setenv("TESSERA_SHARED_ARENAS", "0", 1);
    render_with_stats("scene/teapot_displaced.rib", "share4.exr", pair, args, "share4.json");
    unsetenv("TESSERA_SHARED_ARENAS");
    test_assert_same_pixels(in_dir("share1.exr"), in_dir("share4.exr"));
    assert_true(counter("share4.json", "patches_shared") > 0.0);
    assert_true(counter("share4.json", "patch_cache_bytes") >
                counter("share3.json", "patch_cache_bytes"));
    assert_true(counter("share3.json", "patch_cache_peak_bytes") <=
                counter("share3.json", "patch_cache_bytes"));
    setenv("TESSERA_SHARE_WAIT", "1", 1);
    render_with_stats("scene/teapot_displaced.rib", "share2.exr", pair, args, "share2.json");
    unsetenv("TESSERA_SHARE_WAIT");
    test_assert_same_pixels(in_dir("share1.exr"), in_dir("share2.exr"));
    double diced = counter("share1.json", "patches_diced");
    assert_true(diced == 32.0);
    assert_true(counter("share1.json", "patches_shared") == 0.0);
    assert_true(counter("share2.json", "patches_diced") == diced);
    assert_true(counter("share2.json", "patches_shared") > 0.0);
    assert_true(counter("share2.json", "patches_diced") +
                    counter("share2.json", "patches_shared") ==
                counter("share2.json", "patch_cache_misses"));
    cJSON *root = test_read_json(in_dir("share2.json")); /* the devices' own counters */
    double own_diced = 0, own_shared = 0;
    for (int k = 0; k < 2; ++k) {
        own_diced += device_number(root, k, "patches_diced");
        own_shared += device_number(root, k, "patches_shared");
        assert_true(device_number(root, k, "share_wait_seconds") >= 0.0);
    }
    cJSON_Delete(root);
    assert_true(own_diced == diced);
    assert_true(own_shared == counter("share2.json", "patches_shared"));
    setenv("TESSERA_PATCH_SHARE", "0", 1);
    render_with_stats("scene/teapot_displaced.rib", "share0.exr", pair, args, "share0.json");
    unsetenv("TESSERA_PATCH_SHARE");
    test_assert_same_pixels(in_dir("share1.exr"), in_dir("share0.exr"));
    assert_true(counter("share0.json", "patches_shared") == 0.0);
    assert_true(counter("share0.json", "patches_diced") > diced);
    /* Arenas that evict: batches of several per iteration, the store full before the end. */
    const char *tight = "--res 160x90 --spp 2 --lod 7 --memory 16 --quiet";
    render("scene/teapot_displaced.rib", "tight1.exr", first, tight);
    render_with_stats("scene/teapot_displaced.rib", "tight2.exr", pair, tight, "tight2.json");
    test_assert_same_pixels(in_dir("tight1.exr"), in_dir("tight2.exr"));
    assert_true(counter("tight2.json", "patch_cache_evictions") > 0.0);
    assert_true(counter("tight2.json", "patches_shared") > 0.0);
}

/* A device that fails while it holds claims (the K-th launch of the process fails, in the
 * first batches' dice and build for these K): it abandons them, the other device dices
 * what it waited for, the failed one retries at half its budget; same bits, no hang. */
static void test_a_device_failing_with_claims_abandons_them(void **state)
{
    (void)state;
    const char *args = "--res 96x54 --spp 4 --max-lod 6 --memory 64";
    render("scene/teapot_displaced.rib", "claims_ref.exr", first,
           "--res 96x54 --spp 4 --max-lod 6 --quiet");
    const char *at[] = {"8", "11", "14", "17"};
    for (size_t i = 0; i < sizeof at / sizeof *at; ++i) {
        setenv("TESSERA_FAIL_LAUNCH", at[i], 1);
        render("scene/teapot_displaced.rib", "claims.exr", pair, args);
        unsetenv("TESSERA_FAIL_LAUNCH");
        test_expect_in_stderr(dir, "retrying with 32 MB");
        test_assert_same_pixels(in_dir("claims_ref.exr"), in_dir("claims.exr"));
    }
}

/* The indices of the two pthread devices PoCL exposes: PoCL may not be the first platform. */
static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    ts_device_info *list = NULL;
    ts_error err = {0};
    int n = dev_list(&list, &err), found = 0;
    for (int i = 0; i < n && found < 2; ++i)
        if (test_pocl_driver(list[i].name) &&
            strcmp(test_pocl_driver(list[i].name), "pthread") == 0) {
            size_t used = strlen(pair);
            snprintf(pair + used, sizeof pair - used, "%s%d", found ? "," : "", i);
            if (!found) snprintf(first, sizeof first, "%d", i);
            ++found;
        }
    free(list);
    return found == 2 ? 0 : -1;
}

int main(void)
{
    /* Before PoCL starts in this process (dev_list): two CPU devices. */
    setenv("POCL_DEVICES", "pthread pthread", 1);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_two_devices_give_the_one_device_image),
        cmocka_unit_test(test_lod_chunks_give_the_one_device_levels),
        cmocka_unit_test(test_cpu_devices_leave_the_host_its_cores),
        cmocka_unit_test(test_two_streams_give_the_one_stream_image),
        cmocka_unit_test(test_one_device_writes_the_exr_while_rendering),
        cmocka_unit_test(test_one_device_writes_the_png_while_rendering),
        cmocka_unit_test(test_an_abandoned_lod_part_is_counted_by_device_0),
        cmocka_unit_test(test_two_devices_share_built_patches),
        cmocka_unit_test(test_two_devices_squeezed_dice_as_one),
        cmocka_unit_test(test_a_device_failing_with_claims_abandons_them),
        cmocka_unit_test(test_odd_units_give_the_same_image),
        cmocka_unit_test(test_a_slow_device_takes_fewer_units),
        cmocka_unit_test(test_a_slow_devices_last_unit_is_backed_up),
        cmocka_unit_test(test_the_exr_is_written_while_rendering),
        cmocka_unit_test(test_interrupted_two_device_render_resumes),
        cmocka_unit_test(test_one_device_render_resumes_on_two),
        cmocka_unit_test(test_bad_device_lists),
        cmocka_unit_test(test_a_device_that_fails_to_build_is_left_out),
        cmocka_unit_test(test_a_device_out_of_memory_mid_frame_retries),
    };
    if (!test_has_device()) return TS_TEST_SKIP;
    ts_device_info *list = NULL;
    ts_error err = {0};
    int n = dev_list(&list, &err), pthreads = 0;
    for (int i = 0; i < n; ++i)
        pthreads += test_pocl_driver(list[i].name) &&
                    strcmp(test_pocl_driver(list[i].name), "pthread") == 0;
    free(list);
    if (pthreads < 2) return TS_TEST_SKIP; /* not PoCL */
    return cmocka_run_group_tests(tests, setup, NULL);
}
