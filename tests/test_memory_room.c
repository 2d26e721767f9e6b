/* test_memory_room.c — ts_memory_room_query (base/memory.h) on fake /proc and cgroup trees, and
 * the default budget's room by the kind of device (app/budget.h):
 * the tightest of RLIMIT_AS and RLIMIT_DATA (against VmSize and VmData), every enclosing
 * cgroup's limit (v2 memory.max, v1 memory.limit_in_bytes) and MemAvailable, with the
 * limit named; missing files and "max" mean no limit. The rlimits are set in a child
 * process, so the test itself is not limited. Host only (never skipped for want of a
 * device). */
#include "test_support.h"
#include "app/budget.h"
#include "base/memory.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define MB ((uint64_t)1 << 20)

static char root[4096];

/* Writes text to root/rel, making its directories. */
static void put(const char *rel, const char *text)
{
    char path[8192], cmd[8400];
    snprintf(path, sizeof path, "%s/%s", root, rel);
    snprintf(cmd, sizeof cmd, "mkdir -p \"$(dirname '%s')\"", path);
    assert_int_equal(system(cmd), 0);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* A fresh fake tree: root/proc (self/status with VmSize 300 MB and VmData 200 MB, meminfo)
 * and root/cg (the cgroup file system, empty). */
static void fresh_tree(const char *name, uint64_t mem_available_mb)
{
    snprintf(root, sizeof root, "%s/%s", test_scratch_dir(), name);
    char text[256];
    put("proc/self/status", "Name:\ttessera\nVmPeak:\t  400000 kB\nVmSize:\t  307200 kB\n"
                            "VmData:\t  204800 kB\nThreads:\t1\n");
    snprintf(text, sizeof text, "MemTotal:       99999999 kB\nMemAvailable:   %llu kB\n",
             (unsigned long long)(mem_available_mb * 1024));
    put("proc/meminfo", text);
}

static void query(ts_memory_room *room)
{
    char proc[4200], cg[4200];
    snprintf(proc, sizeof proc, "%s/proc", root);
    snprintf(cg, sizeof cg, "%s/cg", root);
    ts_memory_sources src = {proc, cg};
    ts_memory_room_query(&src, room);
}

/* The query's answer with no rlimit in the way (skips when the process has one). */
static void query_unlimited(ts_memory_room *room)
{
    struct rlimit as, data;
    getrlimit(RLIMIT_AS, &as);
    getrlimit(RLIMIT_DATA, &data);
    if (as.rlim_cur != RLIM_INFINITY || data.rlim_cur != RLIM_INFINITY)
        test_skip("the process has an RLIMIT_AS or RLIMIT_DATA: no unlimited query");
    query(room);
}

static void test_mem_available_alone(void **state)
{
    (void)state;
    fresh_tree("avail", 5000);
    ts_memory_room room;
    query_unlimited(&room);
    assert_string_equal(room.which, "MemAvailable");
    assert_true(room.bytes == 5000 * MB);
}

static void test_nothing_known(void **state)
{
    (void)state;
    snprintf(root, sizeof root, "%s/none", test_scratch_dir());
    ts_memory_room room;
    query_unlimited(&room);
    assert_true(room.bytes == UINT64_MAX);
    assert_string_equal(room.which, "");
}

/* cgroup v2: the parent's memory.max binds the child; "max" is no limit. */
static void test_cgroup_v2_nested(void **state)
{
    (void)state;
    fresh_tree("v2", 5000);
    put("proc/self/cgroup", "0::/box/job\n");
    put("cg/memory.max", "max\n");
    put("cg/box/memory.max", "2147483648\n"); /* 2048 MB */
    put("cg/box/memory.current", "1073741824\n");
    put("cg/box/job/memory.max", "max\n");
    put("cg/box/job/memory.current", "524288000\n");
    ts_memory_room room;
    query_unlimited(&room);
    assert_string_equal(room.which, "cgroup memory.max");
    assert_true(room.bytes == 1024 * MB);
    assert_true(room.limit == 2048 * MB);
    /* The child's own limit, tighter: 300 MB of 800 MB left. */
    put("cg/box/job/memory.max", "838860800\n");
    query_unlimited(&room);
    assert_true(room.bytes == 300 * MB);
    /* Used beyond the limit: no room at all. */
    put("cg/box/job/memory.current", "900000000\n");
    query_unlimited(&room);
    assert_true(room.bytes == 0);
}

/* cgroup v1: the memory controller's own hierarchy; its "no limit" is a number near 2^63. */
static void test_cgroup_v1(void **state)
{
    (void)state;
    fresh_tree("v1", 5000);
    put("proc/self/cgroup", "9:name=systemd:/\n4:memory:/jobs/7\n3:cpuset:/\n0::/\n");
    put("cg/memory/memory.limit_in_bytes", "9223372036854771712\n");
    put("cg/memory/jobs/7/memory.limit_in_bytes", "1048576000\n"); /* 1000 MB */
    put("cg/memory/jobs/7/memory.usage_in_bytes", "104857600\n");  /* 100 MB */
    ts_memory_room room;
    query_unlimited(&room);
    assert_string_equal(room.which, "cgroup memory.limit_in_bytes");
    assert_true(room.bytes == 900 * MB);
    /* MemAvailable below it wins. */
    fresh_tree("v1", 600);
    query_unlimited(&room);
    assert_string_equal(room.which, "MemAvailable");
    assert_true(room.bytes == 600 * MB);
}

/* RLIMIT_AS and RLIMIT_DATA, set in a child: 2000 MB of address space with 300 MB in use,
 * then 1000 MB of data with 200 MB in use. The child reports the room in MB and which. */
static void test_rlimits(void **state)
{
    (void)state;
#if defined(__SANITIZE_ADDRESS__)
    test_skip("AddressSanitizer's allocator cannot work under a 2000 MB cap on the address space");
#endif
    fresh_tree("rlimit", 1000000);
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        struct rlimit rl;
        char out[256];
        ts_memory_room a, d;
        getrlimit(RLIMIT_AS, &rl);
        rl.rlim_cur = (rlim_t)2000 * MB;
        if (setrlimit(RLIMIT_AS, &rl) != 0) _exit(77);
        query(&a);
        getrlimit(RLIMIT_DATA, &rl);
        rl.rlim_cur = (rlim_t)1000 * MB;
        if (setrlimit(RLIMIT_DATA, &rl) != 0) _exit(77);
        query(&d);
        int n = snprintf(out, sizeof out, "%llu %s|%llu %s", (unsigned long long)(a.bytes / MB),
                         a.which, (unsigned long long)(d.bytes / MB), d.which);
        _exit(write(fds[1], out, (size_t)n) == n ? 0 : 1);
    }
    close(fds[1]);
    char got[256] = "";
    ssize_t n = read(fds[0], got, sizeof got - 1);
    close(fds[0]);
    int status;
    waitpid(pid, &status, 0);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 77)
        test_skip("a hard rlimit below 2000 MB of address space or 1000 MB of data");
    assert_true(n > 0);
    got[n] = '\0';
    assert_string_equal(got, "1700 RLIMIT_AS|800 RLIMIT_DATA");
}

/* budget_default (app/budget.h): the room the patch cache may grow into is half of what is
 * left, times 8/9. A CPU device that shares host memory is bounded by the process's room,
 * not by the global memory it reports (PoCL's guess, which it does not enforce: 4.75 GiB on
 * a 24 GiB virtual machine); a GPU by its global memory; an integrated GPU by both; a CPU device
 * whose process room is unknown by its global memory. */
static void test_budget_room_by_device(void **state)
{
    (void)state;
    const uint64_t GB = (uint64_t)1 << 30, fixed = 100 * MB;
    ts_memory_room known = {22 * GB, 22 * GB, "MemAvailable"}, unknown = {UINT64_MAX, 0, ""};
    ts_device_info cpu = {0};
    cpu.type = CL_DEVICE_TYPE_CPU, cpu.host_unified = CL_TRUE;
    cpu.global_mem = 5104100352ull, cpu.max_alloc = 2 * GB;
    ts_device_info gpu = cpu, igpu = cpu;
    gpu.type = igpu.type = CL_DEVICE_TYPE_GPU, gpu.host_unified = CL_FALSE;
    ts_budget_choice c;
    uint64_t host_half = (22 * GB - fixed) / 2 / 9 * 8 >> 20,
             dev_half = (cpu.global_mem - fixed) / 2 / 9 * 8 >> 20;
    budget_default(&cpu, fixed, &known, &c);
    assert_int_equal(c.mb, TS_BUDGET_CAP_MB);
    assert_int_equal(c.room_mb, host_half); /* 10 GB, not the 2 GB of its global memory */
    budget_default(&gpu, fixed, &known, &c);
    assert_int_equal(c.room_mb, dev_half);
    budget_default(&igpu, fixed, &known, &c);
    assert_int_equal(c.room_mb, dev_half);
    budget_default(&cpu, fixed, &unknown, &c);
    assert_int_equal(c.room_mb, dev_half);
    /* A process room below the device's bounds the CPU device too. */
    ts_memory_room tight = {1 * GB, 4 * GB, "RLIMIT_AS"};
    budget_default(&cpu, fixed, &tight, &c);
    assert_int_equal(c.room_mb, (1 * GB - fixed) / 2 / 9 * 8 >> 20);
    assert_int_equal(c.mb, c.room_mb);
    assert_non_null(strstr(c.why, "RLIMIT_AS"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mem_available_alone),
        cmocka_unit_test(test_nothing_known),
        cmocka_unit_test(test_cgroup_v2_nested),
        cmocka_unit_test(test_cgroup_v1),
        cmocka_unit_test(test_rlimits),
        cmocka_unit_test(test_budget_room_by_device),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
