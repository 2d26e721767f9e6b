/* ranks.h — one frame on several processes, on one machine or many: `mpirun -np N tessera
 * render ...` (Open MPI; the optional build feature TESSERA_MPI, docs/building.md). Rank 0
 * loads the scene and broadcasts it (or, with --mpi-scene load, every rank loads the same
 * files), runs the lod stage and sends the levels of detail, hands out units from its board
 * (units.h) to its own devices and to the other ranks, merges every unit in order and writes
 * the image: bit for bit the image of one process. Every other rank renders the units it is
 * given on its own devices (workers.h) and sends back their samples and, at the end, its
 * stats. Without mpirun, or with one rank, nothing of this runs.
 *
 * Messages (MPI_COMM_WORLD, all from or to rank 0, only the main thread calls MPI):
 *   start (broadcast): ts_rank_start, then the packed scene (scene_pack.h)
 *   RANKS_TAG_LOD      0 -> r: the frame's max_lod and patch_lod, or a failure
 *   RANKS_TAG_REQUEST  r -> 0: how many more units r wants
 *   RANKS_TAG_UNIT     0 -> r: a ts_unit, or index UINT32_MAX: none left
 *   RANKS_TAG_RESULT   r -> 0: a unit's header and its samples (units.h ts_unit_result)
 *   RANKS_TAG_GIVE_BACK r -> 0: a unit r did not finish (its devices failed or stopped)
 *   RANKS_TAG_BYE      r -> 0: r's stats and devices' stats, or why it rendered nothing
 * A rank that dies (killed, crashed) makes mpirun send SIGTERM to the others: rank 0 stops
 * like on any stop signal and writes the merged prefix (exit status 3), which --resume
 * finishes. */
#ifndef TS_RANKS_H
#define TS_RANKS_H

#include "app/options.h"
#include "app/units.h"
#include "app/workers.h"
#include "base/stats.h"
#include "scene/scene.h"

/* This process among the ranks. size 1: alone (not started by mpirun, or -np 1). */
typedef struct ts_ranks {
    int size, rank;
    int node_ranks; /* ranks on this machine (they share its memory) */
    int mpi;        /* 1: MPI is initialised (MPI_Finalize at the end) */
    int started;    /* rank 0: the start was broadcast (the others wait for units) */
    char host[256];
    double t0, scene_seconds;
    struct ranks_peer *peers; /* rank 0: what each other rank asked for and said */
    int lod_sent;
    int quiet;       /* rank 0: --quiet (no warnings about the other ranks) */
    ts_stats *stats; /* rank 0: where the others' stats go */
} ts_ranks;

/* The world size mpirun (or another MPI launcher: PMI_SIZE) gave this process, 1 without. */
int ranks_launched_size(void);

/* Starts MPI when this process was launched by mpirun with several ranks. Without the MPI
 * feature in this build, several ranks are an error (TS_E_USAGE: every rank would render
 * the whole frame and write the same file). */
int ranks_init(int *argc, char ***argv, ts_ranks *r, ts_error *err);
/* Ends MPI: MPI_Finalize after a render that ended normally (status 0); after a failure or
 * an interruption the process just exits (mpirun ends the other ranks). */
void ranks_finalize(ts_ranks *r, int status);

#ifdef TESSERA_HAVE_MPI
/* How rank 0 starts the frame, broadcast to every rank. */
typedef struct ts_rank_start {
    int32_t status;     /* 0: render; 1: rank 0 failed or has nothing to do: every rank ends */
    int32_t scene_load; /* 1: every rank loads the scene files (--mpi-scene load) */
    int32_t width, height, spp, job_hash;
    uint64_t total, start, unit_samples; /* samples; start: resumed from */
    uint64_t share_samples;              /* a device's share of them (ts_frame) */
    uint64_t scene_bytes;                /* of the packed scene that follows */
    ts_camera_params cam;
} ts_rank_start;

/* Rank 0: broadcasts *start and (unless the ranks load the files, or start->status is not
 * 0) the scene. */
int ranks_start(ts_ranks *r, ts_rank_start *start, const ts_scene *scene, ts_error *err);
/* Rank 0: the service workers_render polls: sends the lod once device 0 made it, answers
 * requests from the board, merges results, takes back units and reads the ranks' stats
 * into stats. */
ts_frame_service ranks_service(ts_ranks *r, ts_stats *stats);
/* Rank 0, after the frame: answers the last requests and waits for every rank's stats;
 * adds "ranks" (rank 0's entry first) to stats. */
int ranks_finish(ts_ranks *r, ts_stats *stats, ts_error *err);
/* Every rank but 0: the whole render (start, scene, devices, units, stats). */
int ranks_follow(ts_ranks *r, ts_render_options *o, ts_error *err);
#endif

#endif
