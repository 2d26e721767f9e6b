/* test_failure.c — failures as a user meets them (docs/errors.md): the device running out
 * of memory (injected with TESSERA_FAIL_ALLOC / TESSERA_FAIL_LAUNCH) is retried with a
 * smaller budget, ends with the finished samples written, or ends in one clear line;
 * SIGTERM or SIGHUP during a render writes the finished samples and exits 3, a closed
 * stderr pipe does not stop it; --resume continues such an image to exactly the bits of an
 * uninterrupted render and refuses one made by another command; a kernel that does not
 * compile names kernels/FILE.cl:LINE. */
#include "test_support.h"
#include "app/options.h"
#include "app/render.h"
#include "app/resume.h"
#include "image/image.h"
#include "scene/scene_load.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* A render of a few seconds in many waves: 17 waves of about 14k samples at 16 MB. */
#define RES "320x180"
#define SPP "4"
#define MEMORY "16"
#define TOTAL (320u * 180u * 4u)
#define RENDER_ARGS "--res " RES " --spp " SPP " --memory " MEMORY

static char dir[4096];

static const char *in_dir(const char *name)
{
    static char buf[4][4200];
    static int next;
    char *out = buf[next++ % 4];
    snprintf(out, sizeof buf[0], "%s/%s", dir, name);
    return out;
}

static int exists(const char *name)
{
    struct stat st;
    return stat(in_dir(name), &st) == 0;
}

static char *read_text(const char *path)
{
    static char buf[1 << 16];
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    buf[n] = '\0';
    if (f) fclose(f);
    return buf;
}

static int meta_int(const char *name, const char *key)
{
    int v = -1;
    ts_error err = {0};
    if (image_read_meta_int(in_dir(name), key, &v, &err)) fail_msg("%s", err.msg);
    return v;
}

static void assert_no_temporary(void)
{
    char cmd[4400];
    snprintf(cmd, sizeof cmd, "ls -a '%s' | grep -q tmp", dir);
    if (system(cmd) == 0) fail_msg("a temporary file is left in %s", dir);
}

/* Starts `tessera render SCENE -o OUT --res RES --spp SPP --memory MB [extra]` in the
 * background with stderr to errpath; returns its pid. */
static pid_t render_start(const char *errpath, const char *scene, const char *out, const char *res,
                          const char *spp, const char *mb, const char *extra)
{
    const char *bin = test_tessera_binary();
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int fd = open(errpath, O_WRONLY | O_CREAT | O_TRUNC, 0644),
            nul = open("/dev/null", O_WRONLY);
        if (fd < 0 || nul < 0) _exit(126);
        dup2(fd, 2), dup2(nul, 1);
        execl(bin, bin, "render", scene, "-o", out, "--res", res, "--spp", spp, "--memory", mb,
              extra, (char *)NULL);
        _exit(127);
    }
    return pid;
}

/* Starts `tessera render teapot -o OUT RENDER_ARGS [extra]` in the background with stderr
 * to dir/NAME.stderr; waits for its first progress line (a wave is finished), sends
 * signal `sig` and returns the exit status. */
static int render_and_signal(const char *out, const char *extra, int sig)
{
    char errpath[4300];
    snprintf(errpath, sizeof errpath, "%s.stderr", in_dir(out));
    char outpath[4200];
    snprintf(outpath, sizeof outpath, "%s", in_dir(out));
    pid_t pid = render_start(errpath, test_source_path("scene/teapot.rib"), outpath, RES, SPP,
                             MEMORY, extra);
    int status = 0, progressed = 0;
    for (int i = 0; i < 6000 && !progressed; ++i) { /* up to 60 s (a cold kernel cache) */
        if (waitpid(pid, &status, WNOHANG) == pid)
            fail_msg("the render ended before it was interrupted:\n%s", read_text(errpath));
        progressed = strstr(read_text(errpath), " samples, ") != NULL;
        if (!progressed) nanosleep(&(struct timespec){0, 10000000}, NULL);
    }
    if (!progressed) kill(pid, SIGKILL);
    assert_true(progressed);
    kill(pid, sig);
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (!WIFEXITED(status)) fail_msg("the render died by signal %d", WTERMSIG(status));
    snprintf(errpath, sizeof errpath, "cp '%s.stderr' '%s'", in_dir(out), in_dir("stderr.txt"));
    assert_int_equal(system(errpath), 0);
    return WEXITSTATUS(status);
}

static int render_and_interrupt(const char *out, const char *extra)
{
    return render_and_signal(out, extra, SIGTERM);
}

/* The uninterrupted render, made once. */
static const char *reference(void)
{
    if (!exists("reference.exr"))
        assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --quiet",
                                          test_source_path("scene/teapot.rib"),
                                          in_dir("reference.exr")),
                         0);
    return "reference.exr";
}

/* The R G B Z N albedo channels of two EXRs are equal bit for bit. */
static void assert_same_image(const char *a_name, const char *b_name)
{
    ts_image a, b;
    ts_error err = {0};
    if (image_read(in_dir(a_name), &a, &err) || image_read(in_dir(b_name), &b, &err))
        fail_msg("%s", err.msg);
    assert_int_equal(a.width, b.width);
    assert_int_equal(a.height, b.height);
    assert_int_equal(b.channels, 10); /* complete: no partial channels left */
    const char *names[] = {"R",   "G",   "B",        "Z",        "N.x",
                           "N.y", "N.z", "albedo.R", "albedo.G", "albedo.B"};
    size_t npix = (size_t)a.width * a.height, differ = 0;
    for (int c = 0; c < 10; ++c) {
        int ia = -1, ib = -1;
        for (int k = 0; k < a.channels; ++k)
            ia = strcmp(a.channel_names[k], names[c]) ? ia : k;
        for (int k = 0; k < b.channels; ++k)
            ib = strcmp(b.channel_names[k], names[c]) ? ib : k;
        assert_true(ia >= 0 && ib >= 0);
        for (size_t i = 0; i < npix; ++i)
            differ += memcmp(&a.pixels[i * a.channels + ia], &b.pixels[i * b.channels + ib],
                             sizeof(float)) != 0;
    }
    if (differ) fail_msg("%s and %s differ in %zu values", a_name, b_name, differ);
    image_free(&a);
    image_free(&b);
}

static void test_alloc_failure_is_retried(void **state)
{
    (void)state;
    setenv("TESSERA_FAIL_ALLOC", "1", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --res 64x36 --max-lod 4 --memory 1024",
                              test_source_path("scene/teapot.rib"), in_dir("retried.png"));
    unsetenv("TESSERA_FAIL_ALLOC");
    assert_int_equal(rc, 0);
    test_expect_in_stderr(dir, "the device could not provide 1024 MB");
    test_expect_in_stderr(dir, "retrying with 512 MB");
    assert_true(exists("retried.png"));
}

static void test_alloc_failure_gives_up(void **state)
{
    (void)state;
    setenv("TESSERA_FAIL_ALLOC", "1000", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --res 64x36 --max-lod 4 --quiet",
                              test_source_path("scene/teapot.rib"), in_dir("never.png"));
    unsetenv("TESSERA_FAIL_ALLOC");
    assert_int_equal(rc, 1);
    const char *err = test_stderr_of(dir);
    /* One line naming the OpenCL error and what to do. */
    if (!strstr(err, "tessera: CL_MEM_OBJECT_ALLOCATION_FAILURE") || !strstr(err, "--max-lod"))
        fail_msg("unexpected message:\n%s", err);
    assert_non_null(strchr(err, '\n'));
    assert_true(strchr(err, '\n')[1] == '\0');
    assert_false(exists("never.png"));
    assert_no_temporary();
}

/* A launch that fails in the middle of the render: the finished waves are kept, the rest
 * is traced with half the budget, and the image is the uninterrupted one. */
static void test_launch_failure_mid_render_is_retried(void **state)
{
    (void)state;
    const char *ref = reference();
    /* The 150th launch comes after two of the nine waves (the two-level loop's iterations
     * each launch top_level, bottom_level per batch and resolve; trace.c). */
    setenv("TESSERA_FAIL_LAUNCH", "150", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --res " RES " --spp " SPP " --memory 32",
                              test_source_path("scene/teapot.rib"), in_dir("launch.exr"));
    unsetenv("TESSERA_FAIL_LAUNCH");
    assert_int_equal(rc, 0);
    const char *err = test_stderr_of(dir), *retry = strstr(err, "retrying with 16 MB");
    if (!retry || !strstr(err, "CL_OUT_OF_RESOURCES")) fail_msg("no retry:\n%s", err);
    const char *progress = strstr(err, " samples, ");
    if (!progress || progress > retry)
        fail_msg("the launch failed before any wave finished:\n%s", err);
    assert_same_image(ref, "launch.exr");
}

/* TESSERA_SYNC_LAUNCHES=1 finishes the queue after every launch, so that a kernel that
 * faults on a GPU is reported at its own launch (docs/errors.md): the image is the same
 * bits, and the launches' times still reach --stats (they stay pending until the stage's
 * own dev_finish). */
static void test_sync_launches_change_no_bit(void **state)
{
    (void)state;
    const char *ref = reference();
    setenv("TESSERA_SYNC_LAUNCHES", "1", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --quiet --stats '%s'",
                              test_source_path("scene/teapot.rib"), in_dir("sync.exr"),
                              in_dir("sync.json"));
    unsetenv("TESSERA_SYNC_LAUNCHES");
    if (rc != 0) fail_msg("exit status %d:\n%s", rc, test_stderr_of(dir));
    assert_same_image(ref, "sync.exr");
    const char *json = read_text(in_dir("sync.json")), *at = strstr(json, "\"bottom_level\":");
    double seconds = 0.0;
    if (!at || sscanf(at + strlen("\"bottom_level\":"), "%lf", &seconds) != 1 || !(seconds > 0.0))
        fail_msg("bottom_level's time is not in --stats:\n%s", json);
}

/* A launch that fails in the first wave, before any sample is in the film: the smaller
 * budget dices at other levels of detail (m = 7 at 16 MB, m = 8 at 32 MB), which is no
 * reason to refuse it, since no sample was traced at the old ones. The image is the one
 * --memory 16 makes. */
static void test_launch_failure_in_the_first_wave_is_retried(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/one_patch.rib");
    setenv("TESSERA_FAIL_LAUNCH", "10", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' --res 256x256 --memory 32", scene,
                              in_dir("first_wave.exr"));
    unsetenv("TESSERA_FAIL_LAUNCH");
    const char *err = test_stderr_of(dir);
    if (rc != 0) fail_msg("exit status %d:\n%s", rc, err);
    const char *retry = strstr(err, "retrying with 16 MB"), *progress = strstr(err, " samples, ");
    if (!retry || (progress && progress < retry))
        fail_msg("no retry before the first finished wave:\n%s", err);
    test_tessera_ok(dir, "render '%s' -o '%s' --res 256x256 --memory 16 --quiet", scene,
                    in_dir("at16.exr"));
    test_assert_same_pixels(in_dir("at16.exr"), in_dir("first_wave.exr"));
}

/* Memory runs out at the smallest budget after waves were finished: they are written as a
 * resumable partial EXR (exit status 3), and --resume completes it to the bits of the
 * uninterrupted render. */
static void test_out_of_memory_at_the_floor_writes_the_finished_samples(void **state)
{
    (void)state;
    const char *ref = reference(), *scene = test_source_path("scene/teapot.rib");
    setenv("TESSERA_FAIL_LAUNCH", "300", 1);
    int rc = test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS, scene, in_dir("floor.exr"));
    unsetenv("TESSERA_FAIL_LAUNCH");
    if (rc != 3) fail_msg("exit status %d:\n%s", rc, test_stderr_of(dir));
    test_expect_in_stderr(dir, "tessera: CL_OUT_OF_RESOURCES in clEnqueueNDRangeKernel(");
    test_expect_in_stderr(dir, "the device could not provide 16 MB");
    test_expect_in_stderr(dir, " samples finished to ");
    test_expect_in_stderr(dir, "(continue with --resume once more memory is free)");
    assert_no_temporary();
    unsigned done = (unsigned)meta_int("floor.exr", "tessera:samples_done");
    assert_true(done > 0 && done < TOTAL);
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                      scene, in_dir("floor.exr")),
                     0);
    assert_same_image(ref, "floor.exr");
}

static void test_sigterm_writes_the_finished_samples(void **state)
{
    (void)state;
    assert_int_equal(render_and_interrupt("partial.exr", NULL), 3);
    test_expect_in_stderr(dir, "interrupted by SIGTERM after ");
    assert_true(exists("partial.exr"));
    assert_no_temporary();
    unsigned done = (unsigned)meta_int("partial.exr", "tessera:samples_done");
    assert_true(done > 0 && done < TOTAL);
    assert_int_equal(meta_int("partial.exr", "tessera:spp"), 4);
    /* R G B are the means of the finished samples, next to their sums and counts. */
    ts_image img;
    ts_error err = {0};
    if (image_read(in_dir("partial.exr"), &img, &err)) fail_msg("%s", err.msg);
    assert_int_equal(img.channels, 14);
    assert_string_equal(img.channel_names[10], "tessera.sum.R");
    assert_string_equal(img.channel_names[13], "tessera.count");
    double counted = 0;
    for (int i = 0; i < img.width * img.height; ++i) {
        const float *px = &img.pixels[i * 14];
        counted += px[13];
        float inv = px[13] > 0 ? 1.0f / px[13] : 0.0f;
        assert_true(px[0] == px[10] * inv);
    }
    assert_true(counted == (double)done);
    image_free(&img);
}

/* Rewrites the partial EXR dir/name with its pixels and metadata, "tessera:samples_done"
 * moved by `shift` and the count of pixel `pixel` moved by `count_shift`. */
static void edit_partial(const char *name, int shift, int pixel, float count_shift)
{
    static const char *keys[] = {"tessera:samples_done", "tessera:spp", "tessera:seed",
                                 "tessera:job",          "tessera:lod", "tessera:max_lod",
                                 "tessera:band"};
    ts_image_meta meta[7];
    for (int k = 0; k < 7; ++k)
        meta[k] = (ts_image_meta){keys[k], meta_int(name, keys[k])};
    meta[0].value += shift;
    ts_image img;
    ts_error err = {0};
    if (image_read(in_dir(name), &img, &err)) fail_msg("%s", err.msg);
    assert_int_equal(img.channels, 14);
    img.pixels[(size_t)pixel * 14 + 13] += count_shift; /* tessera.count */
    if (image_write_exr(in_dir(name), &img, meta, 7, &err)) fail_msg("%s", err.msg);
    image_free(&img);
}

/* The job hashes of `render teapot RENDER_ARGS` (seed 0), computed here as render.c does:
 * today's (job_hash) and that of images written before 2026-11-30 (job_hash_legacy). */
static void teapot_job_hashes(int32_t *now, int32_t *legacy)
{
    ts_render_options o;
    render_options_defaults(&o);
    o.scene_path = test_source_path("scene/teapot.rib");
    o.spp = atoi(SPP);
    ts_load_options lo;
    render_load_options(&o, &lo);
    ts_scene scene;
    ts_error err = {0};
    memset(&scene, 0, sizeof scene);
    if (scene_load_with(o.scene_path, &lo, &scene, &err)) fail_msg("%s", err.msg);
    ts_camera_params cam;
    if (render_camera_params(&scene.camera, 320, 180, &cam, &err)) fail_msg("%s", err.msg);
    cam.spp = (uint32_t)o.spp, cam.seed = o.seed;
    if (job_hash(&o, &scene, &cam, now, &err) || job_hash_legacy(&o, &scene, &cam, legacy, &err))
        fail_msg("%s", err.msg);
    scene_free(&scene);
}

/* An image written before the job hash took the XXH3 digests of the scene's large pieces
 * (its "tessera:job" the FNV-1a hash of every byte) still resumes, to the same bits; and is
 * written back with today's hash. */
static void test_resume_accepts_the_legacy_job_hash(void **state)
{
    (void)state;
    const char *ref = reference(), *scene = test_source_path("scene/teapot.rib");
    assert_int_equal(render_and_interrupt("legacy.exr", NULL), 3);
    int32_t now, legacy;
    teapot_job_hashes(&now, &legacy);
    assert_int_equal(meta_int("legacy.exr", "tessera:job"), now);
    assert_int_not_equal(now, legacy);
    /* The same file with the legacy hash, then with one that is neither: refused. */
    for (int k = 0; k < 2; ++k) {
        static const char *keys[] = {"tessera:samples_done", "tessera:spp", "tessera:seed",
                                     "tessera:job",          "tessera:lod", "tessera:max_lod",
                                     "tessera:band"};
        ts_image_meta meta[7];
        for (int i = 0; i < 7; ++i)
            meta[i] = (ts_image_meta){keys[i], meta_int("legacy.exr", keys[i])};
        meta[3].value = k == 0 ? legacy + 1 : legacy;
        ts_image img;
        ts_error err = {0};
        if (image_read(in_dir("legacy.exr"), &img, &err)) fail_msg("%s", err.msg);
        if (image_write_exr(in_dir("legacy.exr"), &img, meta, 7, &err)) fail_msg("%s", err.msg);
        image_free(&img);
        if (k == 1) break;
        assert_int_equal(test_run_tessera(dir,
                                          "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                          scene, in_dir("legacy.exr")),
                         1);
        test_expect_in_stderr(dir, "cannot resume: it was rendered from another scene");
    }
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume", scene,
                                      in_dir("legacy.exr")),
                     0);
    test_expect_in_stderr(dir, "resuming");
    assert_int_equal(meta_int("legacy.exr", "tessera:samples_done"), (int)TOTAL);
    assert_int_equal(meta_int("legacy.exr", "tessera:job"), now);
    assert_same_image(ref, "legacy.exr");
}

/* --resume checks "tessera:samples_done" against the count channel pixel by pixel: a file
 * edited by hand (or damaged) is refused instead of counting samples twice. */
static void test_resume_refuses_counts_that_disagree(void **state)
{
    (void)state;
    const char *scene = test_source_path("scene/teapot.rib");
    assert_int_equal(render_and_interrupt("edited.exr", NULL), 3);
    int done = meta_int("edited.exr", "tessera:samples_done");
    edit_partial("edited.exr", 1000, 0, 0.0f);
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                      scene, in_dir("edited.exr")),
                     1);
    test_expect_in_stderr(dir, "edited.exr: cannot resume: pixel (");
    test_expect_in_stderr(dir, "(a damaged or edited file)");
    assert_int_equal(meta_int("edited.exr", "tessera:samples_done"), done + 1000); /* untouched */
    /* The metadata restored, one pixel's count raised: refused at that pixel. */
    edit_partial("edited.exr", -1000, 321 + 320 * 7, 1.0f);
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                      scene, in_dir("edited.exr")),
                     1);
    test_expect_in_stderr(dir, "cannot resume: pixel (1, 8) holds ");
}

/* One device traces pixel after pixel (bands of one pixel, app/done.h); TESSERA_SAMPLE_BAND_ROWS
 * makes bands of rows (kernels/lib/sample_order.h). The partial EXR records the band, and
 * --resume continues in the file's order whatever this run would choose
 * (TESSERA_SAMPLE_BAND_ROWS=0: one band), to the bits of the uninterrupted render; so does a
 * render in one band from the start. */
static void test_resume_continues_in_the_files_sample_order(void **state)
{
    (void)state;
    const char *ref = reference(), *scene = test_source_path("scene/teapot.rib");
    setenv("TESSERA_SAMPLE_BAND_ROWS", "3", 1);
    assert_int_equal(render_and_interrupt("rows.exr", NULL), 3);
    unsetenv("TESSERA_SAMPLE_BAND_ROWS");
    assert_int_equal(meta_int("rows.exr", "tessera:band"), 3 * 320);
    assert_int_equal(render_and_interrupt("bands.exr", NULL), 3);
    assert_int_equal(meta_int("bands.exr", "tessera:band"), 1); /* pixel after pixel */
    setenv("TESSERA_SAMPLE_BAND_ROWS", "0", 1);
    int rc_rows = test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                   scene, in_dir("rows.exr"));
    int rc = test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet", scene,
                              in_dir("bands.exr"));
    int rc_one = test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --quiet", scene,
                                  in_dir("one_band.exr"));
    unsetenv("TESSERA_SAMPLE_BAND_ROWS");
    assert_int_equal(rc_rows, 0);
    assert_int_equal(rc, 0);
    assert_int_equal(rc_one, 0);
    assert_int_equal(meta_int("one_band.exr", "tessera:band"), 0);
    assert_same_image(ref, "rows.exr");
    assert_same_image(ref, "bands.exr");
    assert_same_image(ref, "one_band.exr");
}

/* SIGHUP (the terminal or the ssh session went away) stops the render like SIGINT: the
 * finished samples are written, resumable, and --resume completes them. */
static void test_sighup_writes_the_finished_samples(void **state)
{
    (void)state;
    const char *ref = reference();
    assert_int_equal(render_and_signal("hup.exr", NULL, SIGHUP), 3);
    test_expect_in_stderr(dir, "interrupted by SIGHUP after ");
    unsigned done = (unsigned)meta_int("hup.exr", "tessera:samples_done");
    assert_true(done > 0 && done < TOTAL);
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                      test_source_path("scene/teapot.rib"), in_dir("hup.exr")),
                     0);
    assert_same_image(ref, "hup.exr");
}

/* A long wave is not waited for: forest-100 at a budget whose arenas hold an eighth of its
 * patches (each wave dices for seconds, in many batches); SIGINT once a third of the frame
 * is finished ends the render within 3 s with exit 3 and those samples kept. Before the cancel hook
 * asked between batches, the render finished the wave it was in first (tens of seconds here, 90-130
 * s on forest-1000 at 1920x768). */
static void test_sigint_in_a_long_wave_is_honoured_at_once(void **state)
{
    (void)state;
    char errpath[4300], outpath[4200];
    snprintf(errpath, sizeof errpath, "%s", in_dir("long.stderr"));
    snprintf(outpath, sizeof outpath, "%s", in_dir("long.exr"));
    pid_t pid = render_start(errpath, test_source_path("scene/forest-100.rib"), outpath, "640x256",
                             "16", "128", NULL);
    /* The top quarter of the frame is mostly sky: its waves are quick. Past it each wave dices
     * for seconds (6-15 s here); the signal comes just after one ended. */
    int status = 0, progressed = 0;
    for (int i = 0; i < 18000 && !progressed; ++i) { /* up to 180 s (a cold kernel cache) */
        if (waitpid(pid, &status, WNOHANG) == pid)
            fail_msg("the render ended before it was interrupted:\n%s", read_text(errpath));
        const char *cr = strrchr(read_text(errpath), '\r'); /* "\rtessera: N / T samples" */
        unsigned long done =
            cr && strncmp(cr, "\rtessera: ", 10) == 0 ? strtoul(cr + 10, NULL, 10) : 0;
        progressed = done >= 640ul * 256ul * 16ul / 3ul;
        if (!progressed) nanosleep(&(struct timespec){0, 10000000}, NULL);
    }
    if (!progressed) kill(pid, SIGKILL);
    assert_true(progressed);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    kill(pid, SIGINT);
    assert_int_equal(waitpid(pid, &status, 0), pid);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 3);
    if (seconds > 3.0) fail_msg("SIGINT took %.1f s to end the render", seconds);
    int done = meta_int("long.exr", "tessera:samples_done");
    assert_true(done >= 640 * 256 * 16 / 3 && done < 640 * 256 * 16); /* the waves' samples, kept */
    assert_no_temporary();
}

/* stderr into a pipe that is closed after 100 bytes (`tessera ... 2>&1 | head -c 100`): the
 * render must not die of SIGPIPE; progress stops and the image is written. */
static void test_closed_stderr_pipe_does_not_kill_the_render(void **state)
{
    (void)state;
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    const char *bin = test_tessera_binary(), *scene = test_source_path("scene/teapot.rib");
    char outpath[4200];
    snprintf(outpath, sizeof outpath, "%s", in_dir("piped.exr"));
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fds[0]);
        dup2(fds[1], 1), dup2(fds[1], 2);
        execl(bin, bin, "render", scene, "-o", outpath, "--res", RES, "--spp", SPP, "--memory",
              MEMORY, (char *)NULL);
        _exit(127);
    }
    close(fds[1]);
    char buf[100];
    size_t got = 0;
    while (got < sizeof buf) {
        ssize_t n = read(fds[0], buf + got, sizeof buf - got);
        if (n <= 0) break;
        got += (size_t)n;
    }
    close(fds[0]); /* what head -c 100 does */
    assert_true(got == sizeof buf);
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (!WIFEXITED(status)) fail_msg("the render died by signal %d", WTERMSIG(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    assert_same_image(reference(), "piped.exr");
}

static void test_resume_matches_the_uninterrupted_render(void **state)
{
    (void)state;
    const char *ref = reference(), *scene = test_source_path("scene/teapot.rib");
    assert_int_equal(render_and_interrupt("resumed.exr", NULL), 3);
    int done = meta_int("resumed.exr", "tessera:samples_done");
    /* Another command: refused, the file untouched. */
    assert_int_equal(
        test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --seed 1 --resume --quiet",
                         scene, in_dir("resumed.exr")),
        1);
    test_expect_in_stderr(
        dir, "cannot resume: it was rendered with --seed 0, this command has --seed 1");
    assert_int_equal(meta_int("resumed.exr", "tessera:samples_done"), done);
    assert_int_equal(
        test_run_tessera(dir, "render '%s' -o '%s' --res 160x90 --spp " SPP " --resume --quiet",
                         scene, in_dir("resumed.exr")),
        1);
    test_expect_in_stderr(dir, "cannot resume: it is 320x180 but this command renders 160x90");
    assert_int_equal(test_run_tessera(dir,
                                      "render '%s' -o '%s' " RENDER_ARGS
                                      " --dicing-rate 2 --resume --quiet",
                                      scene, in_dir("resumed.exr")),
                     1);
    test_expect_in_stderr(dir, "cannot resume: it was rendered from another scene or with other "
                               "--depth, --sampling, --max-lod, --lod, --dicing-rate or");
    assert_int_equal(meta_int("resumed.exr", "tessera:samples_done"), done);
    /* The same command (the default --dicing-rate spelt out is the same): continues from the
     * finished samples to the same bits. */
    assert_int_equal(
        test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --dicing-rate 1 --resume", scene,
                         in_dir("resumed.exr")),
        0);
    test_expect_in_stderr(dir, "resuming");
    assert_int_equal(meta_int("resumed.exr", "tessera:samples_done"), (int)TOTAL);
    assert_same_image(ref, "resumed.exr");
    assert_no_temporary();
    /* Complete: nothing to do. */
    assert_int_equal(test_run_tessera(dir, "render '%s' -o '%s' " RENDER_ARGS " --resume --quiet",
                                      scene, in_dir("resumed.exr")),
                     0);
    test_expect_in_stderr(dir, "already complete");
}

static void test_kernel_build_failure_names_file_and_line(void **state)
{
    (void)state;
    char cmd[8800];
    snprintf(cmd, sizeof cmd, "cp -r '%s' '%s'", test_source_path("kernels"), in_dir("kernels"));
    assert_int_equal(system(cmd), 0);
    /* Break the line of film.cl that reads the work-item id. */
    char path[4300];
    snprintf(path, sizeof path, "%s/film.cl", in_dir("kernels"));
    static char text[1 << 16], out[(1 << 16) + 256];
    snprintf(text, sizeof text, "%s", read_text(path));
    int line = 0, broken = 0;
    size_t o = 0;
    for (const char *p = text; *p;) {
        size_t len = strcspn(p, "\n");
        ++line;
        if (!broken && memmem(p, len, "get_global_id", 13)) {
            broken = line;
            o += (size_t)snprintf(out + o, sizeof out - o, "    this line is broken on purpose;\n");
        } else {
            o += (size_t)snprintf(out + o, sizeof out - o, "%.*s\n", (int)len, p);
        }
        p += len + (p[len] == '\n');
    }
    assert_true(broken > 0);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(out, f);
    fclose(f);
    assert_int_equal(
        test_run_tessera(dir, "render '%s' -o '%s' --res 32x18 --kernel-dir '%s' --no-kernel-cache",
                         test_source_path("scene/teapot.rib"), in_dir("k.png"), in_dir("kernels")),
        1);
    test_expect_in_stderr(dir, "tessera: CL_BUILD_PROGRAM_FAILURE in clBuildProgram");
    char where[64];
    snprintf(where, sizeof where, "kernels/film.cl:%d:", broken);
    test_expect_in_stderr(dir, where);
    assert_false(exists("k.png"));
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
        cmocka_unit_test(test_alloc_failure_is_retried),
        cmocka_unit_test(test_alloc_failure_gives_up),
        cmocka_unit_test(test_launch_failure_mid_render_is_retried),
        cmocka_unit_test(test_launch_failure_in_the_first_wave_is_retried),
        cmocka_unit_test(test_sync_launches_change_no_bit),
        cmocka_unit_test(test_out_of_memory_at_the_floor_writes_the_finished_samples),
        cmocka_unit_test(test_sigterm_writes_the_finished_samples),
        cmocka_unit_test(test_resume_matches_the_uninterrupted_render),
        cmocka_unit_test(test_resume_accepts_the_legacy_job_hash),
        cmocka_unit_test(test_sighup_writes_the_finished_samples),
        cmocka_unit_test(test_sigint_in_a_long_wave_is_honoured_at_once),
        cmocka_unit_test(test_resume_refuses_counts_that_disagree),
        cmocka_unit_test(test_resume_continues_in_the_files_sample_order),
        cmocka_unit_test(test_closed_stderr_pipe_does_not_kill_the_render),
        cmocka_unit_test(test_kernel_build_failure_names_file_and_line),
    };
    return TEST_RUN_WITH_DEVICE(tests, setup);
}
