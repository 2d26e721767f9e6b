/* relight.c — the relighting tables (relight.h): the domes' SH projection and the mapped
 * dome's G table, in double precision, stored as floats. */
#include "pipeline/relight.h"
#include "lib/sh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void relight_tables_free(ts_relight_tables *t)
{
    free(t->light);
    memset(t, 0, sizeof *t);
}

void relight_table_normal(uint32_t c, uint32_t r, float n[3])
{
    double theta = M_PI * (r + 0.5) / TS_RELIGHT_TABLE_H,
           phi = 2.0 * M_PI * (c + 0.5) / TS_RELIGHT_TABLE_W;
    n[0] = (float)(sin(theta) * cos(phi));
    n[1] = (float)(sin(theta) * sin(phi));
    n[2] = (float)cos(theta);
}

/* The mapped dome (map_width > 0) of the light table, or NULL. */
static const ts_light *mapped_dome(const ts_light_table *t)
{
    for (uint32_t i = 0; i < t->light_count; ++i)
        if (t->lights[i].type == TS_LIGHT_DOME && t->lights[i].map_width) return &t->lights[i];
    return NULL;
}

/* The part [a0, a1) x [b0, b1) of the map (in texels, within texel (tx, ty)): its centre's
 * direction, its radiance (the dome's radiance times the texel, as lib/lights.h light_escape
 * gives it) and, returned, its exact solid angle (a rectangle in phi and cos theta). */
static double map_rect(const ts_light *dome, const ts_env_map *env, uint32_t tx, uint32_t ty,
                       double a0, double a1, double b0, double b1, double dir[3], double rgb[3])
{
    uint32_t w = env->width, h = env->height;
    double t0 = M_PI * b0 / h, t1 = M_PI * b1 / h, tc = 0.5 * (t0 + t1);
    double pc = M_PI * (a0 + a1) / w;
    dir[0] = sin(tc) * cos(pc), dir[1] = sin(tc) * sin(pc), dir[2] = cos(tc);
    const ts_vec4 *t = &env->texels[(size_t)ty * w + tx];
    rgb[0] = dome->radiance[0] * t->x, rgb[1] = dome->radiance[1] * t->y,
    rgb[2] = dome->radiance[2] * t->z;
    return 2.0 * M_PI * (a1 - a0) / w * (cos(t0) - cos(t1));
}

/* L_j of every dome into light[0 .. nc): the uniform domes' 4 pi L Y_00 at j = 0, the map
 * summed texel by texel (its centre's Y_j times its solid angle). */
static void project_domes(const ts_light_table *t, const ts_env_map *env, uint32_t nc,
                          ts_vec4 *light)
{
    double acc[TS_SH_MAX_COEFFS][3] = {{0}};
    for (uint32_t i = 0; i < t->light_count; ++i) {
        const ts_light *l = &t->lights[i];
        if (l->type != TS_LIGHT_DOME || l->map_width) continue;
        for (int k = 0; k < 3; ++k)
            acc[0][k] += 4.0 * M_PI * 0.282094791773878 * l->radiance[k];
    }
    const ts_light *dome = mapped_dome(t);
    for (uint32_t y = 0; dome && y < env->height; ++y)
        for (uint32_t x = 0; x < env->width; ++x) {
            double d[3], rgb[3], da = map_rect(dome, env, x, y, x, x + 1.0, y, y + 1.0, d, rgb);
            float ys[TS_SH_MAX_COEFFS];
            sh_eval((float)d[0], (float)d[1], (float)d[2], TS_SH_MAX_BANDS, ys);
            for (uint32_t j = 0; j < nc; ++j)
                for (int k = 0; k < 3; ++k)
                    acc[j][k] += rgb[k] * ys[j] * da;
        }
    for (uint32_t j = 0; j < nc; ++j)
        light[j] = (ts_vec4){(float)acc[j][0], (float)acc[j][1], (float)acc[j][2], 0.0f};
}

/* One cell of the map for the G table: its radiance times solid angle (rgb) and Y_j of its
 * texels' mean direction times that. */
typedef struct map_cell {
    double dir[3];
    double ly[TS_SH_MAX_COEFFS][3];
} map_cell;

/* The map summed into TS_RELIGHT_CELLS_W x TS_RELIGHT_CELLS_H cells of equal angles (*count):
 * each cell gets every texel it overlaps, weighted by the exact solid angle of the overlap
 * (a rectangle in phi and cos theta), so no texel's light is lost or counted twice whatever
 * the map's size; the cell's direction is the solid-angle-weighted mean of the overlaps'
 * centres. */
static map_cell *map_cells(const ts_light *dome, const ts_env_map *env, uint32_t nc,
                           uint32_t *count)
{
    uint32_t cw = TS_RELIGHT_CELLS_W, ch = TS_RELIGHT_CELLS_H, w = env->width, h = env->height;
    map_cell *cells = calloc((size_t)cw * ch, sizeof *cells);
    if (!cells) return NULL;
    for (uint32_t cy = 0; cy < ch; ++cy)
        for (uint32_t cx = 0; cx < cw; ++cx) {
            map_cell *c = &cells[cy * cw + cx];
            double flux[3] = {0, 0, 0}, mean[3] = {0, 0, 0};
            /* the cell in map texels: [x0, x1) x [y0, y1) */
            double x0 = (double)cx * w / cw, x1 = (double)(cx + 1) * w / cw;
            double y0 = (double)cy * h / ch, y1 = (double)(cy + 1) * h / ch;
            for (uint32_t ty = (uint32_t)y0; ty < h && ty < y1; ++ty)
                for (uint32_t tx = (uint32_t)x0; tx < w && tx < x1; ++tx) {
                    double a0 = fmax(x0, tx), a1 = fmin(x1, tx + 1.0);
                    double b0 = fmax(y0, ty), b1 = fmin(y1, ty + 1.0);
                    if (!(a1 > a0 && b1 > b0)) continue;
                    double d[3], rgb[3], da = map_rect(dome, env, tx, ty, a0, a1, b0, b1, d, rgb);
                    for (int k = 0; k < 3; ++k)
                        flux[k] += rgb[k] * da, mean[k] += d[k] * da;
                }
            double len = sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]);
            for (int k = 0; k < 3; ++k)
                c->dir[k] = len > 0.0 ? mean[k] / len : 0.0;
            float ys[TS_SH_MAX_COEFFS];
            sh_eval((float)c->dir[0], (float)c->dir[1], (float)c->dir[2], TS_SH_MAX_BANDS, ys);
            for (uint32_t j = 0; j < nc; ++j)
                for (int k = 0; k < 3; ++k)
                    c->ly[j][k] = ys[j] * flux[k];
        }
    *count = cw * ch;
    return cells;
}

/* G_j(n) at every normal of the table into g (TS_RELIGHT_TABLE_W x _H x nc entries). */
static int build_table(const ts_light *dome, const ts_env_map *env, uint32_t nc, ts_vec4 *g,
                       ts_error *err)
{
    uint32_t n_cells;
    map_cell *cells = map_cells(dome, env, nc, &n_cells);
    if (!cells) return ts_error_set(err, TS_E_MEMORY, "out of memory (relighting table)");
    for (uint32_t r = 0; r < TS_RELIGHT_TABLE_H; ++r)
        for (uint32_t c = 0; c < TS_RELIGHT_TABLE_W; ++c) {
            float nf[3];
            relight_table_normal(c, r, nf);
            double acc[TS_SH_MAX_COEFFS][3] = {{0}};
            for (uint32_t k = 0; k < n_cells; ++k) {
                const map_cell *m = &cells[k];
                double cosine = nf[0] * m->dir[0] + nf[1] * m->dir[1] + nf[2] * m->dir[2];
                if (!(cosine > 0.0)) continue;
                for (uint32_t j = 0; j < nc; ++j)
                    for (int ch = 0; ch < 3; ++ch)
                        acc[j][ch] += cosine * m->ly[j][ch];
            }
            ts_vec4 *out = g + ((size_t)r * TS_RELIGHT_TABLE_W + c) * nc;
            for (uint32_t j = 0; j < nc; ++j)
                out[j] = (ts_vec4){(float)acc[j][0], (float)acc[j][1], (float)acc[j][2], 0.0f};
        }
    free(cells);
    return TS_OK;
}

int relight_tables_build(const ts_occlusion *occ, const ts_light_table *t, const ts_env_map *env,
                         ts_relight_tables *out, ts_error *err)
{
    memset(out, 0, sizeof *out);
    const ts_light *dome = mapped_dome(t);
    uint32_t nc = occ ? occ->bands * occ->bands : 0u;
    int table = occ && !occ->cosine && dome && env->width;
    out->light_count = TS_RELIGHT_TABLE_FIRST +
                       (table ? (size_t)TS_RELIGHT_TABLE_W * TS_RELIGHT_TABLE_H * nc : 0u);
    out->light = calloc(out->light_count, sizeof *out->light);
    if (!out->light) return ts_error_set(err, TS_E_MEMORY, "out of memory (relighting table)");
    if (!occ) return TS_OK;
    ts_relight_params *rp = &out->params;
    rp->bands = occ->bands;
    rp->cosine = occ->cosine;
    rp->patch_count = occ->patch_count;
    for (uint32_t i = 0; i < t->light_count; ++i) {
        const ts_light *l = &t->lights[i];
        if (l->type != TS_LIGHT_DOME || l->map_width) continue;
        for (int k = 0; k < 3; ++k)
            rp->uniform[k] += l->radiance[k];
    }
    project_domes(t, env, nc, out->light);
    if (!table) return TS_OK;
    rp->table_w = TS_RELIGHT_TABLE_W;
    rp->table_h = TS_RELIGHT_TABLE_H;
    return build_table(dome, env, nc, out->light + TS_RELIGHT_TABLE_FIRST, err);
}
