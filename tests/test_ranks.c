/* test_ranks.c — one frame on several MPI processes (host/app/ranks_mpi.c), run with
 * `mpirun --oversubscribe -np N` on this machine (as root with OMPI_ALLOW_RUN_AS_ROOT): -np 2
 * and -np 3 give the single-process image bit for bit, the scene broadcast by rank 0 or
 * loaded by every rank (--mpi-scene load); rank 0's --stats has one "ranks" entry per rank
 * and every device of every rank under "devices"; a rank killed in mid-frame (SIGKILL,
 * TESSERA_KILL_RANK) leaves a resumable EXR that --resume, alone or under mpirun, finishes to
 * the same bits; a rank whose device cannot build the kernels is left out with a warning; a
 * frame whose patches do not fit dices about as often on two ranks as in one process.
 * Built without MPI, these are skipped and the test checks instead that a
 * process started by mpirun as one of several ranks refuses to render. */
#include "test_support.h"
#include "image/image.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[4096];
/* Put before mpirun in a shell command: the environment its ranks need (setup), and a time
 * limit, so that a frame that never ends fails this test with its stderr instead of
 * holding the suite until ctest's own timeout. */
static char mpi_env[4300];
#define MPIRUN_LIMIT_S 240

static const char *in_dir(const char *name)
{
    return test_path_in(dir, name);
}

#define ARGS "--res 96x54 --spp 4 --max-lod 6"

#ifdef TESSERA_HAVE_MPI
/* Runs `mpirun --oversubscribe -np N tessera ARGS` with stderr to dir/stderr.txt; returns
 * mpirun's exit status. */
static int mpirun(int n, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int mpirun(int n, const char *fmt, ...)
{
    char args[8192], cmd[16384];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    snprintf(cmd, sizeof cmd, "%smpirun --oversubscribe -np %d '%s' %s 2>'%s' >/dev/null", mpi_env,
             n, test_tessera_binary(), args, in_dir("stderr.txt"));
    int st = system(cmd);
    int rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    if (rc == 124)
        fail_msg("mpirun -np %d ran past %d s:\n%s", n, MPIRUN_LIMIT_S, test_stderr_of(dir));
    return rc;
}

static void mpirun_ok(int n, const char *scene, const char *out, const char *extra)
{
    int rc =
        mpirun(n, "render '%s' -o '%s' " ARGS " %s", test_source_path(scene), in_dir(out), extra);
    if (rc != 0) fail_msg("mpirun -np %d exited %d:\n%s", n, rc, test_stderr_of(dir));
}

static double number(cJSON *o, const char *key)
{
    cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v)) fail_msg("stats: \"%s\" is missing", key);
    return v->valuedouble;
}

/* -np 2 and 3, the scene broadcast: the one-process image; the stats account for every
 * rank and every sample. */
static void test_ranks_give_the_one_process_image(void **state)
{
    (void)state;
    const char *scenes[] = {"scene/teapot.rib", "scene/textured.rib"};
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; ++i) {
        test_tessera_ok(dir, "render '%s' -o '%s' " ARGS " --quiet", test_source_path(scenes[i]),
                        in_dir("one.exr"));
        for (int n = 2; n <= 3; ++n) {
            char extra[4300];
            snprintf(extra, sizeof extra, "--stats '%s' --quiet", in_dir("ranks.json"));
            mpirun_ok(n, scenes[i], "ranks.exr", extra);
            test_assert_same_pixels(in_dir("one.exr"), in_dir("ranks.exr"));
            cJSON *root = test_read_json(in_dir("ranks.json"));
            cJSON *ranks = cJSON_GetObjectItemCaseSensitive(root, "ranks");
            cJSON *devs = cJSON_GetObjectItemCaseSensitive(root, "devices");
            assert_int_equal(cJSON_GetArraySize(ranks), n);
            assert_int_equal(cJSON_GetArraySize(devs), n); /* one device a rank */
            double samples = 0;
            for (int k = 0; k < n; ++k) {
                cJSON *r = cJSON_GetArrayItem(ranks, k);
                assert_true(number(r, "rank") == k);
                assert_true(number(r, "devices") == 1);
                samples += number(r, "samples");
                assert_true(number(r, "seconds") > 0);
            }
            assert_true(samples == 96.0 * 54 * 4);
            assert_true(number(cJSON_GetObjectItemCaseSensitive(root, "counters"), "rays") >=
                        96.0 * 54 * 4);
            cJSON_Delete(root);
        }
    }
}

/* A frame whose patches do not fit its budget (forest-100 320x128 x 2 at --memory 24) on two
 * ranks of one device each: the units rank 0 told them of (sized for four devices' load) were
 * each a wave that diced the forest again; now every rank's device sizes its waves for its
 * share of the frame, and rank 0's board waits for its own device to make the units as large
 * before it hands any out (units.c board_gate, board_regather): at most 1.15 times one
 * process's dicings, the one-process image. */
static void test_squeezed_ranks_dice_as_one(void **state)
{
    (void)state;
    const char *scene = "scene/forest-100.rib";
    const char *args = "--res 320x128 --spp 2 --max-lod 6 --memory 24 --quiet";
    test_tessera_ok(dir, "render '%s' -o '%s' %s --stats '%s'", test_source_path(scene),
                    in_dir("sq1.exr"), args, in_dir("sq1.json"));
    char extra[4300];
    snprintf(extra, sizeof extra, "%s --stats '%s'", args, in_dir("sq2.json"));
    mpirun_ok(2, scene, "sq2.exr", extra);
    test_assert_same_pixels(in_dir("sq1.exr"), in_dir("sq2.exr"));
    double one = test_stats_number(in_dir("sq1.json"), "counters.patches_diced");
    double two = test_stats_number(in_dir("sq2.json"), "counters.patches_diced");
    assert_true(test_stats_number(in_dir("sq2.json"), "counters.patch_cache_evictions") > 0);
    if (!(two <= 1.15 * one)) fail_msg("two ranks diced %.0f patches, one process %.0f", two, one);
}

/* A frame of a few long units (forest-100 320x128 x 4 at --memory 24: four units of 49,172
 * samples or fewer, each a wave that dices the forest again): rank 1 is handed one unit for
 * its device and no more while fewer than two units a rank wait (ranks_mpi.c serve), so rank
 * 0, whose first unit is the frame's top band of sky and treetops, takes another when it
 * ends. When rank 1 kept one more than it had devices waiting, it held the other three from
 * the start and rank 0 traced its first unit alone (49,172 samples; forest-100 1920x768 x 2
 * at --memory 512 took up to 130 s instead of 82). */
static void test_few_long_units_are_shared(void **state)
{
    (void)state;
    int rc =
        mpirun(2,
               "render '%s' -o '%s' --res 320x128 --spp 4 --max-lod 6 --memory 24 --quiet "
               "--stats '%s'",
               test_source_path("scene/forest-100.rib"), in_dir("few.exr"), in_dir("few.json"));
    if (rc != 0) fail_msg("mpirun -np 2 exited %d:\n%s", rc, test_stderr_of(dir));
    cJSON *root = test_read_json(in_dir("few.json"));
    double unit = number(root, "unit_samples");
    cJSON *ranks = cJSON_GetObjectItemCaseSensitive(root, "ranks");
    assert_int_equal(cJSON_GetArraySize(ranks), 2);
    double rank0 = number(cJSON_GetArrayItem(ranks, 0), "samples");
    double rank1 = number(cJSON_GetArrayItem(ranks, 1), "samples");
    cJSON_Delete(root);
    assert_true(unit < 320.0 * 128 * 4 / 3); /* at least four units */
    assert_true(rank0 + rank1 == 320.0 * 128 * 4);
    if (!(rank0 > unit && rank1 > 0))
        fail_msg("rank 0 traced %.0f samples, rank 1 %.0f, in units of %.0f", rank0, rank1, unit);
}

/* Every rank loads the files itself: the same image. */
static void test_ranks_that_load_the_scene(void **state)
{
    (void)state;
    test_tessera_ok(dir, "render '%s' -o '%s' " ARGS " --quiet",
                    test_source_path("scene/teapot_displaced.rib"), in_dir("one_d.exr"));
    mpirun_ok(2, "scene/teapot_displaced.rib", "load.exr", "--mpi-scene load --quiet");
    test_assert_same_pixels(in_dir("one_d.exr"), in_dir("load.exr"));
    int rc = mpirun(2, "render '%s' -o '%s' " ARGS " --mpi-scene files",
                    test_source_path("scene/teapot.rib"), in_dir("x.exr"));
    assert_true(rc != 0);
    test_expect_in_stderr(dir, "bad value 'files' for --mpi-scene");
}

/* Rank 1's device fails to build the kernels (TESSERA_FAIL_BUILD in that rank's environment
 * alone: mpirun's second app context runs it through env): rank 0 warns, naming the rank and
 * its error, and renders the frame itself, the one-process image. */
static void test_a_rank_whose_devices_fail_is_left_out(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/teapot.rib");
    test_tessera_ok(dir, "render '%s' -o '%s' " ARGS " --quiet", scene, in_dir("one_f.exr"));
    char cmd[16384];
    snprintf(cmd, sizeof cmd,
             "%smpirun --oversubscribe -np 1 '%s' render '%s' -o '%s' " ARGS
             " --stats '%s' : -np 1 env 'TESSERA_FAIL_BUILD=*' '%s' render '%s' -o '%s' " ARGS
             " 2>'%s' >/dev/null",
             mpi_env, test_tessera_binary(), scene, in_dir("failed.exr"), in_dir("failed.json"),
             test_tessera_binary(), scene, in_dir("failed.exr"), in_dir("stderr.txt"));
    int st = system(cmd);
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) fail_msg("mpirun: %d\n%s", st, test_stderr_of(dir));
    test_expect_in_stderr(dir, "tessera: warning: rank 1 (");
    test_expect_in_stderr(dir, "CL_BUILD_PROGRAM_FAILURE");
    test_assert_same_pixels(in_dir("one_f.exr"), in_dir("failed.exr"));
    cJSON *root = test_read_json(in_dir("failed.json"));
    cJSON *ranks = cJSON_GetObjectItemCaseSensitive(root, "ranks");
    assert_int_equal(cJSON_GetArraySize(ranks), 2);
    cJSON *one = cJSON_GetArrayItem(ranks, 1);
    assert_true(number(one, "rank") == 1 && number(one, "devices") == 0);
    assert_true(number(one, "samples") == 0);
    cJSON *why = cJSON_GetObjectItemCaseSensitive(one, "error");
    assert_true(cJSON_IsString(why) && strstr(why->valuestring, "CL_BUILD_PROGRAM_FAILURE"));
    assert_null(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(ranks, 0), "error"));
    assert_true(number(cJSON_GetArrayItem(ranks, 0), "samples") == 96.0 * 54 * 4);
    cJSON_Delete(root);
}

/* Rank 1 dies (SIGKILL) after sending two units: mpirun sends the others SIGTERM, rank 0
 * writes the merged prefix; --resume alone and under mpirun finish it to the same bits. */
static void test_a_rank_that_dies_leaves_a_resumable_image(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/teapot.rib");
    test_tessera_ok(dir, "render '%s' -o '%s' " ARGS " --quiet", scene, in_dir("whole.exr"));
    for (int resume_under_mpirun = 0; resume_under_mpirun < 2; ++resume_under_mpirun) {
        setenv("TESSERA_KILL_RANK", "1:2", 1);
        setenv("TESSERA_SLOW_DEVICE", "0:40", 1); /* every rank's device: a frame of seconds */
        setenv("TESSERA_UNIT_SAMPLES", "512", 1);
        int rc = mpirun(3, "render '%s' -o '%s' " ARGS, scene, in_dir("cut.exr"));
        unsetenv("TESSERA_KILL_RANK");
        unsetenv("TESSERA_SLOW_DEVICE");
        unsetenv("TESSERA_UNIT_SAMPLES");
        assert_true(rc != 0); /* mpirun reports the killed rank */
        test_expect_in_stderr(dir, "tessera: interrupted by SIGTERM after ");
        int done = -1;
        ts_error err = {0};
        if (image_read_meta_int(in_dir("cut.exr"), "tessera:samples_done", &done, &err))
            fail_msg("%s\n%s", err.msg, test_stderr_of(dir));
        /* Rank 1 sent two units before it died, and rank 0 merged them: the partial file
         * holds them (an empty one would pass the comparison below by re-rendering all). */
        if (!(done > 0 && done < 96 * 54 * 4))
            fail_msg("samples_done %d: want the merged units, in (0, %d)", done, 96 * 54 * 4);
        if (resume_under_mpirun)
            rc = mpirun(2, "render '%s' -o '%s' " ARGS " --resume --quiet", scene,
                        in_dir("cut.exr"));
        else
            rc = test_run_tessera(dir, "render '%s' -o '%s' " ARGS " --resume --quiet", scene,
                                  in_dir("cut.exr"));
        if (rc != 0) fail_msg("--resume exited %d:\n%s", rc, test_stderr_of(dir));
        test_assert_same_pixels(in_dir("whole.exr"), in_dir("cut.exr"));
    }
}
#endif

/* A process that mpirun (OMPI_COMM_WORLD_SIZE) started as one of several ranks, in a build
 * without MPI: refused, nothing written. */
static void test_ranks_without_mpi_are_refused(void **state)
{
    (void)state;
    setenv("OMPI_COMM_WORLD_SIZE", "2", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' " ARGS,
                              test_source_path("scene/teapot.rib"), in_dir("nompi.png"));
    unsetenv("OMPI_COMM_WORLD_SIZE");
    assert_int_equal(rc, 1);
    test_expect_in_stderr(
        dir, "started by mpirun as one of 2 ranks, but this tessera was built without MPI");
    assert_int_equal(access(in_dir("nompi.png"), F_OK), -1);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s", test_scratch_dir());
    /* mpirun refuses root without these (the CI machine runs as root). */
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    /* When a rank dies, mpirun gives the others 1 s between SIGTERM and SIGKILL: too little
     * for rank 0 to notice the signal and write its image under ASan on a loaded machine (a
     * CI run lost it so; 5 s costs this test about 20 s). docs/rendering.md gives users the
     * same advice for large images. */
    setenv("OMPI_MCA_odls_base_sigkill_timeout", "5", 1);
    /* Under tools/test_sanitize.sh: Open MPI's plugins have no frame pointers, so LeakSanitizer
     * needs the slow unwinder to see that what they keep until exit is theirs
     * (tools/lsan.supp). Only the commands under mpirun get it (mpi_env; the ranks inherit
     * mpirun's environment): it slows every allocation. */
    const char *asan = getenv("ASAN_OPTIONS");
    int k = 0;
    if (asan)
        k = snprintf(mpi_env, sizeof mpi_env, "ASAN_OPTIONS='%s:fast_unwind_on_malloc=0' ", asan);
    if (k < 0 || (size_t)k >= sizeof mpi_env / 2) k = 0;
    snprintf(mpi_env + k, sizeof mpi_env - (size_t)k, "timeout -k 10 %d ", MPIRUN_LIMIT_S);
    return 0;
}

int main(void)
{
#ifdef TESSERA_HAVE_MPI
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ranks_give_the_one_process_image),
        cmocka_unit_test(test_ranks_that_load_the_scene),
        cmocka_unit_test(test_squeezed_ranks_dice_as_one),
        cmocka_unit_test(test_few_long_units_are_shared),
        cmocka_unit_test(test_a_rank_whose_devices_fail_is_left_out),
        cmocka_unit_test(test_a_rank_that_dies_leaves_a_resumable_image),
    };
    (void)test_ranks_without_mpi_are_refused;
    if (system("mpirun --version >/dev/null 2>&1") != 0) {
        /* The library without its launcher (libopenmpi-dev without openmpi-bin): nothing
         * here can start ranks. */
        fprintf(stderr, "mpirun is not installed (Debian: openmpi-bin): skipped\n");
        return TS_TEST_SKIP;
    }
#else
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ranks_without_mpi_are_refused),
    };
#endif
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
