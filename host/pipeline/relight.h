/* relight.h — the tables `render --occlusion` shades with (kernels/lib/relight.h, docs/bake.md
 * "Relighting"), built on the host in plain C from the light table, the dome's map and the
 * baked occlusion: the domes' SH projection L_j and, for a file without the cosine and a
 * mapped dome, G_j(n) = integral of L(w) Y_j(w) max(0, n . w) dw at a lat-long grid of
 * normals. pipeline_create builds and uploads them; tests/test_relight_kernels.c checks the
 * table against direct integration over the map. */
#ifndef TS_PIPELINE_RELIGHT_H
#define TS_PIPELINE_RELIGHT_H

#include "base/error.h"
#include "lib/shared_types.h"
#include "pipeline/lights.h"
#include "scene/scene.h"

#include <stddef.h>

/* The G table's normals (lat-long, TS_RELIGHT_TABLE_W x TS_RELIGHT_TABLE_H) and the cells the
 * map is summed into for it (at most TS_RELIGHT_CELLS_W x TS_RELIGHT_CELLS_H, each cell's
 * radiance times solid angle at its texels' mean direction): 2048 x 2048 x B^2 products,
 * about 0.1 s on one core. The interpolation error is measured by test_relight_kernels and
 * stated in docs/bake.md. */
#define TS_RELIGHT_TABLE_W 64u
#define TS_RELIGHT_TABLE_H 32u
#define TS_RELIGHT_CELLS_W 64u
#define TS_RELIGHT_CELLS_H 32u

typedef struct ts_relight_tables {
    ts_relight_params params; /* bands 0: no occlusion */
    ts_vec4 *light;           /* light_count entries: ts_relight_params' light buffer */
    size_t light_count;
} ts_relight_tables;

/* The tables for occlusion occ (NULL: params.bands = 0 and one zeroed light entry) under the
 * scene's lights t and the dome's map env (0 x 0: none). Free with relight_tables_free (also
 * after a failure, TS_E_MEMORY). */
int relight_tables_build(const ts_occlusion *occ, const ts_light_table *t, const ts_env_map *env,
                         ts_relight_tables *out, ts_error *err);
void relight_tables_free(ts_relight_tables *t);

/* The normal of the G table's entry (column c, row r): theta = pi (r + 1/2) / H, phi =
 * 2 pi (c + 1/2) / W. */
void relight_table_normal(uint32_t c, uint32_t r, float n[3]);

#endif
