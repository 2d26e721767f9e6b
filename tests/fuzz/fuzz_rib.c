/* fuzz_rib.c — libFuzzer harness for the RIB parser (tools/fuzz.sh; -DTESSERA_FUZZ=ON with
 * clang). Each input is parsed by rib_parse_string as one RIB file and the scene freed; a
 * crash, an ASan/UBSan report, a leak or a broken contract (a failed parse must leave the
 * scene zeroed and say why) aborts. Inputs that crashed go to tests/fuzz/regressions/,
 * which test_fuzz_regressions replays in the normal suite. */
#include "scene/rib/rib.h"
#include "scene/scene.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

/* ObjectInstance copies its object, and ReadArchive an inline archive's requests: a 64 KiB
 * input can ask for gigabytes of patches or 10^16 requests, which is the bounds' job
 * (rib_object.c, rib_inline.c), so the fuzzer runs with low ones. Likewise a Blobby whose
 * one huge blob widens the box of a tiny one samples its grid up to BLOBBY_MAX_WORK (2e8
 * field evaluations, 0.3 s in a release build, 5 s under ASan, past the 10 s timeout on a busy
 * machine: tests/fuzz/regressions/blobby_grid_work_bound.rib); the fuzzer's bound is 2e6. */
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    setenv("TESSERA_MAX_INSTANCED_PATCHES", "65536", 1);
    setenv("TESSERA_BLOBBY_MAX_WORK", "2e6", 1);
    setenv("TESSERA_MAX_INLINE_REQUESTS", "65536", 1);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const ts_scene zero;
    ts_scene scene;
    memset(&scene, 0, sizeof scene);
    ts_error err = {0};
    int rc = rib_parse_string("fuzz.rib", (const char *)data, size, &scene, 1, &err);
    if (rc != TS_OK) {
        if (memcmp(&scene, &zero, sizeof scene) != 0) {
            fprintf(stderr, "fuzz_rib: failed parse (%s) left a non-empty scene\n", err.msg);
            abort();
        }
        if (err.code != rc || err.msg[0] == '\0') {
            fprintf(stderr, "fuzz_rib: failed parse returned %d, err.code %d, message \"%s\"\n", rc,
                    err.code, err.msg);
            abort();
        }
    }
    scene_free(&scene);
    ts_error_clear(&err);
    return 0;
}
