/* ranks.c — how this process was launched (ranks.h), and, in a build without the MPI
 * feature, the refusal to run as one of several ranks. ranks_mpi.c is the MPI side. */
#include "app/ranks.h"

#include <stdlib.h>
#include <string.h>

int ranks_launched_size(void)
{
    const char *vars[] = {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"};
    for (size_t i = 0; i < sizeof vars / sizeof *vars; ++i) {
        const char *v = getenv(vars[i]);
        if (v && *v) {
            long n = strtol(v, NULL, 10);
            if (n > 1) return (int)(n < 1 << 20 ? n : 1 << 20);
        }
    }
    return 1;
}

#ifndef TESSERA_HAVE_MPI
int ranks_init(int *argc, char ***argv, ts_ranks *r, ts_error *err)
{
    (void)argc, (void)argv;
    memset(r, 0, sizeof *r);
    r->size = r->node_ranks = 1;
    int n = ranks_launched_size();
    if (n > 1)
        return ts_error_set(err, TS_E_USAGE,
                            "started by mpirun as one of %d ranks, but this tessera was built "
                            "without MPI (every rank would render the whole frame): install "
                            "libopenmpi-dev and build again (docs/building.md), or run it "
                            "without mpirun",
                            n);
    return TS_OK;
}

void ranks_finalize(ts_ranks *r, int status)
{
    (void)r, (void)status;
}
#endif
