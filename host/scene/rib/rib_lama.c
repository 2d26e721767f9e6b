/* rib_lama.c — the Lama nodes that combine Bxdfs (LamaMix, LamaAdd, LamaLayer, LamaSurface:
 * Pixar's Lama family as MaterialX's ND_lama_* define it) onto one of Tessera's materials, and
 * the store of the materials of the Bxdfs read so far by handle, which they name. The Bxdfs
 * themselves are rib_bxdf.c's; docs/rib.md "RIS shading" has the rules. */
#include "scene/rib/rib_internal.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RIB_MAX_BXDFS 65536 /* Bxdf handles in one parse */

/* The materials of the Bxdfs read so far, by handle (the latest of a handle), for the Lama nodes
 * that combine them (lama_nodes). */
typedef struct bxdf_node {
    char *handle;
    rib_surface s;
} bxdf_node;

struct rib_bxdfs {
    bxdf_node *v;
    size_t count, cap;
};

void rib_bxdf_free(rib_parser *p)
{
    if (!p->bxdfs) return;
    for (size_t k = 0; k < p->bxdfs->count; k++)
        free(p->bxdfs->v[k].handle);
    free(p->bxdfs->v);
    free(p->bxdfs);
    p->bxdfs = NULL;
}

static int bxdf_oom(rib_parser *p)
{
    return rib_error_at(p, p->req_line, p->req_col, "Bxdf: out of memory");
}

/* The material of the Bxdf `handle` (its first len bytes), or NULL. */
static const rib_surface *bxdf_find(const rib_parser *p, const char *handle, size_t len)
{
    for (size_t k = p->bxdfs ? p->bxdfs->count : 0; k-- > 0;) {
        const bxdf_node *n = &p->bxdfs->v[k];
        if (strlen(n->handle) == len && strncmp(n->handle, handle, len) == 0) return &n->s;
    }
    return NULL;
}

/* Keeps material s under the request's handle (args[1], when it has one). */
int rib_bxdf_keep(rib_parser *p, size_t first, const rib_surface *s)
{
    if (first != 2 || p->nargs < 2) return TS_OK;
    const rib_arg *h = &p->args[1];
    if (h->kind != RIB_ARG_STRING && !(h->kind == RIB_ARG_STRINGS && h->count == 1))
        return TS_OK; /* no handle: nothing to keep it under */
    const char *handle = rib_arg_str(p, h, 0);
    if (!p->bxdfs && !(p->bxdfs = calloc(1, sizeof *p->bxdfs))) return bxdf_oom(p);
    struct rib_bxdfs *t = p->bxdfs;
    for (size_t k = 0; k < t->count; k++)
        if (strcmp(t->v[k].handle, handle) == 0) {
            t->v[k].s = *s;
            return TS_OK;
        }
    if (t->count == RIB_MAX_BXDFS)
        return rib_error_at(p, p->req_line, p->req_col, "Bxdf: more than %d handles",
                            RIB_MAX_BXDFS);
    if (t->count == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 16;
        bxdf_node *v = realloc(t->v, cap * sizeof *v);
        if (!v) return bxdf_oom(p);
        t->v = v, t->cap = cap;
    }
    if (!(t->v[t->count].handle = strdup(handle))) return bxdf_oom(p);
    t->v[t->count++].s = *s;
    return TS_OK;
}

/* (1 - w) a + w b, channel by channel. */
static void mix3(const double a[3], const double b[3], double w, double out[3])
{
    for (int c = 0; c < 3; c++)
        out[c] = (1.0 - w) * a[c] + w * b[c];
}

/* Material s as principled parameters: a matte's Kd Cs as the base colour of a dielectric
 * without specular, a metal's as a conductor's (metallic 1); a principled one as it is. */
static rib_surface bxdf_as_principled(const rib_surface *s)
{
    rib_surface o = *s;
    if (s->material == TS_MAT_PRINCIPLED) return o;
    int metal = s->material == TS_MAT_METAL;
    o.material = TS_MAT_PRINCIPLED;
    for (int c = 0; c < 3; c++)
        o.color[c] = (metal ? 1.0 : s->kd) * s->color[c];
    o.metallic = metal ? 1.0 : 0.0, o.specular = 0.0, o.specular_tint = 0.0;
    o.sheen = 0.0, o.sheen_tint = 0.5, o.clearcoat = 0.0, o.clearcoat_gloss = 1.0;
    o.kd = 1.0 - o.metallic, o.ks = 0.0;
    return o;
}

/* A Lama node that combines two Bxdfs: its name, its two material inputs (connections to Bxdf
 * handles), its float inputs and their defaults, MaterialX's ND_lama_mix_bsdf, ND_lama_add_bsdf,
 * ND_lama_layer_bsdf and ND_lama_surface (Pixar's Lama nodes; LamaSurface is the node a Lama
 * network ends in, its materials by the side of the geometric normal). */
typedef enum lama_op { LAMA_MIX, LAMA_ADD, LAMA_LAYER, LAMA_SURFACE } lama_op;

typedef struct lama_node {
    const char *name;
    lama_op op;
    const char *material[2], *param[2];
    double dflt[2];
} lama_node;

static const lama_node lama_nodes[] = {
    {"LamaMix", LAMA_MIX, {"material1", "material2"}, {"mix", NULL}, {0.0, 0.0}},
    {"LamaAdd", LAMA_ADD, {"material1", "material2"}, {"weight1", "weight2"}, {1.0, 0.0}},
    {"LamaLayer",
     LAMA_LAYER,
     {"materialBase", "materialTop"},
     {"topMix", "topThickness"},
     {1.0, 0.0}},
    {"LamaSurface",
     LAMA_SURFACE,
     {"materialFront", "materialBack"},
     {"presence", NULL},
     {1.0, 0.0}},
};
#define LAMA_NODES (sizeof lama_nodes / sizeof lama_nodes[0])

/* Material m times weight s in [0, 1] (LamaAdd): exact for a matte (Kd and Ks scaled), a metal
 * and an emitter (their colour scaled) and every emission; glass and the principled BRDF get
 * their colour scaled, which leaves their specular reflection as it was (one warning). */
static void bxdf_scale(rib_parser *p, const lama_node *nd, double s, rib_surface *m)
{
    if (s >= 1.0) return;
    for (int c = 0; c < 3; c++)
        m->emit[c] *= s;
    if (m->material == TS_MAT_MATTE || m->material == TS_MAT_PLASTIC ||
        m->material == TS_MAT_TRANSLUCENT) {
        m->kd *= s, m->ks *= s;
        if (!m->constant) return;
    }
    for (int c = 0; c < 3; c++)
        m->color[c] *= s;
    if (!m->constant && (m->material == TS_MAT_GLASS || m->material == TS_MAT_PRINCIPLED)) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": %s under a weight below 1 has its colour scaled, not its "
                 "specular reflection (an approximation)",
                 nd->name, m->material == TS_MAT_GLASS ? "glass" : "a principled BRDF");
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
}

/* (1 - w) m1 + w m2 as one principled BRDF of their mixed parameters (bxdf_as_principled):
 * mattes, metals and principled BRDFs among each other, an approximation. */
static void bxdf_mix_principled(const rib_surface *m1, const rib_surface *m2, double w,
                                rib_surface *out)
{
    rib_surface a = bxdf_as_principled(m1), b = bxdf_as_principled(m2);
    *out = a;
    mix3(a.color, b.color, w, out->color);
    /* a matte has no lobe the roughness shapes: the other's keeps its own */
    out->roughness = m1->material == TS_MAT_MATTE   ? b.roughness
                     : m2->material == TS_MAT_MATTE ? a.roughness
                                                    : (1.0 - w) * a.roughness + w * b.roughness;
    out->metallic = (1.0 - w) * a.metallic + w * b.metallic;
    out->specular = (1.0 - w) * a.specular + w * b.specular;
    out->specular_tint = (1.0 - w) * a.specular_tint + w * b.specular_tint;
    out->sheen = (1.0 - w) * a.sheen + w * b.sheen;
    out->sheen_tint = (1.0 - w) * a.sheen_tint + w * b.sheen_tint;
    out->clearcoat = (1.0 - w) * a.clearcoat + w * b.clearcoat;
    out->clearcoat_gloss = (1.0 - w) * a.clearcoat_gloss + w * b.clearcoat_gloss;
    out->kd = 1.0 - out->metallic, out->ks = 0.0;
}

/* (1 - w) m1 + w m2, node's inputs (LamaMix's, or another node's mixing step), where Tessera's
 * materials can hold it. Exact: w 0 or 1; two mattes of one specular lobe (their Kd Cs mixed);
 * two metals, or two glasses of one index, of one roughness (their tints mixed: each BSDF is
 * linear in Cs); the emissions always mix. Approximate, with one warning: mattes, metals and
 * principled BRDFs among each other become one principled BRDF of their mixed parameters.
 * An emitter that reflects nothing (PxrConstant, LamaEmission) mixes exactly: the other
 * material scaled by its share (bxdf_scale), emitting the emitter's share of its radiance.
 * Otherwise (glass or a texture with another material) the larger share, with one warning. */
static void bxdf_mix_surfaces(rib_parser *p, const lama_node *nd, const rib_surface *m1,
                              const rib_surface *m2, double w, rib_surface *out)
{
    char what[RIB_WARN_KEY];
    if (w <= 0.0 || w >= 1.0) {
        *out = w <= 0.0 ? *m1 : *m2;
        return;
    }
    if (m1->constant || m2->constant) { /* emitters that reflect nothing: exact */
        const rib_surface *e = m1->constant ? m1 : m2, *r = m1->constant ? m2 : m1;
        double we = m1->constant ? 1.0 - w : w; /* e's share */
        *out = *r;
        if (m1->constant && m2->constant) {
            mix3(m1->color, m2->color, w, out->color);
            mix3(m1->emit, m2->emit, w, out->emit);
            return;
        }
        bxdf_scale(p, nd, 1.0 - we, out); /* the reflector's share */
        for (int c = 0; c < 3; c++)       /* Surface "constant"'s radiance is its colour */
            out->emit[c] += we * (e->color[c] + e->emit[c]);
        return;
    }
    int t1 = m1->material == TS_MAT_TRANSLUCENT, t2 = m2->material == TS_MAT_TRANSLUCENT;
    int sheets = (t1 || (m1->material == TS_MAT_MATTE && m1->ks == 0.0)) &&
                 (t2 || (m2->material == TS_MAT_MATTE && m2->ks == 0.0));
    if ((t1 || t2) && sheets && !m1->textured && !m2->textured) { /* matte and translucent */
        double refl[3], trans[3];
        for (int c = 0; c < 3; c++) {
            double r1 = m1->kd * m1->color[c], r2 = m2->kd * m2->color[c];
            double x1 = t1 ? m1->ks * m1->color[c] : 0.0, x2 = t2 ? m2->ks * m2->color[c] : 0.0;
            refl[c] = (1.0 - w) * r1 + w * r2, trans[c] = (1.0 - w) * x1 + w * x2;
        }
        snprintf(what, sizeof what, "Bxdf \"%s\"", nd->name);
        *out = *m1;
        rib_bxdf_sheet(p, what, refl, trans, out);
        mix3(m1->emit, m2->emit, w, out->emit);
        return;
    }
    const rib_surface *big = w < 0.5 ? m1 : m2;
    int same = m1->material == m2->material && m1->roughness == m2->roughness;
    if (t1 || t2 || m1->textured || m2->textured ||
        ((m1->material == TS_MAT_GLASS) != (m2->material == TS_MAT_GLASS)) ||
        (m1->material == TS_MAT_GLASS && (!same || m1->ior != m2->ior))) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": %s cannot be mixed: it is drawn as %s, the larger share", nd->name,
                 t1 || t2                       ? "a translucent sheet with another material"
                 : m1->textured || m2->textured ? "a textured material"
                                                : "glass with another material",
                 nd->material[w < 0.5 ? 0 : 1]);
        rib_warn_once(p, p->req_line, p->req_col, what);
        *out = *big;
        return;
    }
    if (same && (m1->material == TS_MAT_METAL || m1->material == TS_MAT_GLASS ||
                 (m1->material == TS_MAT_MATTE && m1->ks == m2->ks))) {
        *out = *m1;
        double a[3], b[3];
        for (int c = 0; c < 3; c++) /* a matte's diffuse albedo is Kd Cs */
            a[c] = (m1->material == TS_MAT_MATTE ? m1->kd : 1.0) * m1->color[c],
            b[c] = (m2->material == TS_MAT_MATTE ? m2->kd : 1.0) * m2->color[c];
        mix3(a, b, w, out->color);
        if (m1->material == TS_MAT_MATTE) out->kd = 1.0;
    } else {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": materials of different kinds are drawn as one principled BRDF of "
                 "their mixed parameters (an approximation)",
                 nd->name);
        rib_warn_once(p, p->req_line, p->req_col, what);
        bxdf_mix_principled(m1, m2, w, out);
    }
    mix3(m1->emit, m2->emit, w, out->emit);
}

/* LamaAdd: weight1 material1 + weight2 material2 (each weight clamped into [0, 1]). One input
 * alone: it, scaled (bxdf_scale); both: their mix at weight2 / (weight1 + weight2), scaled by
 * the sum (above 1, by 1: one warning, as the sum would reflect more than it receives); the
 * emissions add exactly. */
static void bxdf_add(rib_parser *p, const lama_node *nd, const rib_surface *m[2],
                     const int given[2], const double v[2], rib_surface *out)
{
    double w1 = fmin(1.0, fmax(0.0, v[0])), w2 = fmin(1.0, fmax(0.0, v[1])), t = w1 + w2;
    if (!given[0] || !given[1]) {
        int k = given[1] ? 1 : 0;
        *out = *m[k];
        bxdf_scale(p, nd, k ? w2 : w1, out);
        return;
    }
    bxdf_mix_surfaces(p, nd, m[0], m[1], t > 0.0 ? w2 / t : 0.0, out);
    if (t > 1.0) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": weights summing to %g would reflect more light than arrives: the "
                 "sum is drawn at weight 1",
                 nd->name, t);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    bxdf_scale(p, nd, fmin(t, 1.0), out);
    for (int c = 0; c < 3; c++) { /* the radiance added exactly (an emitter's is its colour) */
        double e = w1 * (m[0]->emit[c] + (m[0]->constant ? m[0]->color[c] : 0.0)) +
                   w2 * (m[1]->emit[c] + (m[1]->constant ? m[1]->color[c] : 0.0));
        if (out->constant)
            out->color[c] = e, out->emit[c] = 0.0;
        else
            out->emit[c] = e;
    }
}

/* LamaLayer: materialTop over materialBase, topMix (clamped into [0, 1]) of the top seen. No top
 * (or topMix 0): the base; no base: the top, scaled by topMix. A glass top over a base that
 * reflects (matte, metal, principled) is a clear coat: the base as a principled BRDF whose
 * clearcoat is topMix 4 c / c(0.04, 1), c the hemispherical mean of Schlick's Fresnel from the
 * top's F0 ((n - 1) / (n + 1))^2 to 1 (PxrSurface's coat, bxdf_surface), its gloss from the top's
 * GGX alpha in [0.01, 0.1]; the top's tint is not drawn (one warning). Any other top covers
 * the base where it is seen: (1 - topMix) base + topMix top (bxdf_mix_surfaces). topThickness
 * (absorption in the top) is read and not drawn. */
static void bxdf_layer(rib_parser *p, const lama_node *nd, const rib_surface *m[2],
                       const int given[2], const double v[2], rib_surface *out)
{
    char what[RIB_WARN_KEY];
    const rib_surface *base = m[0], *top = m[1];
    double w = fmin(1.0, fmax(0.0, v[0]));
    if (!given[1] || w <= 0.0 || top->sheen_only) { /* a sheen top: not drawn (bxdf_material) */
        *out = *base;
        return;
    }
    if (!given[0]) {
        *out = *top;
        bxdf_scale(p, nd, w, out);
        return;
    }
    if (top->material != TS_MAT_GLASS || base->material == TS_MAT_GLASS || base->constant ||
        base->material == TS_MAT_TRANSLUCENT) {
        bxdf_mix_surfaces(p, nd, base, top, w, out);
        return;
    }
    *out = bxdf_as_principled(base);
    double n = top->ior, f0 = (n - 1.0) * (n - 1.0) / ((n + 1.0) * (n + 1.0));
    double coat = w * 4.0 * rib_schlick_mean(f0, 1.0) / rib_schlick_mean(0.04, 1.0);
    double alpha = top->roughness, gloss = (0.1 - fmin(fmax(alpha, 0.01), 0.1)) / 0.09;
    if (alpha > 0.1) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": a glass top rougher than 0.32 is drawn as a coat of roughness 0.32 "
                 "(GGX alpha 0.1)",
                 nd->name);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    if (out->clearcoat > 0.0) { /* a coat on a coat: one coat, the rougher gloss */
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": a glass top over a coated base is drawn as one coat (their "
                 "weights added, the rougher)",
                 nd->name);
        rib_warn_once(p, p->req_line, p->req_col, what);
        gloss = fmin(gloss, out->clearcoat_gloss);
    }
    out->clearcoat = fmin(out->clearcoat + coat, 4.0), out->clearcoat_gloss = gloss;
    if (top->color[0] != 1.0 || top->color[1] != 1.0 || top->color[2] != 1.0) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": the glass top's tint is not drawn (the coat is clear)", nd->name);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    for (int c = 0; c < 3; c++)
        out->emit[c] = base->emit[c] + w * top->emit[c];
}

/* Reads node nd's inputs from args[first]: its materials (`"reference bxdf materialTop"
 * ["h"]`: a Bxdf handle, ":output" ignored) into m[] (given[] set; a handle no Bxdf defines is
 * *dflt, with one warning), its floats into v[] (their defaults where absent; a texture
 * connected to one is not drawn, with one warning). Other parameters warn as ignored. */
static int lama_read(rib_parser *p, const lama_node *nd, size_t first, const rib_surface *dflt,
                     const rib_surface *m[2], int given[2], double v[2], rib_link *mask)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX], shown2[RIB_PRINT_MAX];
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int k = strcmp(prm.name, nd->material[0]) == 0   ? 0
                : strcmp(prm.name, nd->material[1]) == 0 ? 1
                                                         : -1;
        int j = nd->param[0] && strcmp(prm.name, nd->param[0]) == 0   ? 0
                : nd->param[1] && strcmp(prm.name, nd->param[1]) == 0 ? 1
                                                                      : -1;
        if (k >= 0) {
            const char *to;
            rc = rib_string_arg(p, i + 1, "a Bxdf handle", &to);
            if (rc != TS_OK) return rc;
            given[k] = 1;
            m[k] = bxdf_find(p, to, strcspn(to, ":"));
            if (!m[k]) {
                snprintf(what, sizeof what,
                         "Bxdf \"%s\": \"%s\" is connected to \"%s\", which no Bxdf defines: it "
                         "is PxrDiffuse's default",
                         nd->name, prm.name, rib_printable(to, shown));
                rib_warn_once(p, prm.val->line, prm.val->col, what);
                m[k] = dflt;
            }
        } else if (j >= 0) {
            rib_link l; /* LamaSurface's presence: a PxrTexture's alpha cuts it out (*mask) */
            int presence = nd->op == LAMA_SURFACE && j == 0;
            rc = rib_pattern_link(p, &prm, presence ? RIB_LINK_MASK : TS_TEX_RGB,
                                  "kept at its default", &l);
            if (rc != TS_OK) return rc;
            if (presence && l.textured) *mask = l;
            const double *x = l.value;
            if (l.linked && !l.folded) {
                if (l.textured && !presence) {
                    snprintf(what, sizeof what,
                             "Bxdf \"%s\": a texture connected to \"%s\" is not drawn: it keeps "
                             "its default, %g",
                             nd->name, prm.name, nd->dflt[j]);
                    rib_warn_once(p, prm.val->line, prm.val->col, what);
                }
                continue;
            }
            if (!l.folded) rc = rib_param_numbers(p, &prm, 1, &x, NULL);
            if (rc != TS_OK) return rc;
            if (!(fabs(x[0]) <= FLT_MAX))
                return rib_error_at(p, prm.val->line, prm.val->col,
                                    "Bxdf \"%s\": \"%s\" must be finite", nd->name, prm.name);
            v[j] = x[0];
        } else if (!rib_bxdf_silent(prm.name) &&
                   !(nd->op == LAMA_SURFACE && (strncmp(prm.name, "compute", 7) == 0 ||
                                                strcmp(prm.name, "materialSides") == 0))) {
            /* LamaSurface's feature switches (computePresence, ...) and its number of sides
             * change nothing Tessera draws */
            snprintf(what, sizeof what, "Bxdf \"%s\" parameter \"%s\" is ignored", nd->name,
                     rib_printable(prm.name, shown2));
            rib_warn_once(p, prm.key->line, prm.key->col, what);
        }
    }
    return TS_OK;
}

/* Bxdf "LamaMix" | "LamaAdd" | "LamaLayer" | "LamaSurface" "handle" params: the material the
 * node makes of the Bxdfs it names (bxdf_mix_surfaces, bxdf_add, bxdf_layer). LamaMix: (1 - mix)
 * material1 + mix material2, mix clamped into [0, 1]; a material it does not name is
 * PxrDiffuse's default. LamaSurface: its materialFront on both sides (Tessera's patches have
 * one material; a different materialBack warns), presence other than 1 warns. */
static int lama_node_run(rib_parser *p, const lama_node *nd, size_t first)
{
    rib_surface dflt;
    rib_bxdf_default(p, &dflt);
    const rib_surface *m[2] = {&dflt, &dflt};
    int given[2] = {0, 0};
    double v[2] = {nd->dflt[0], nd->dflt[1]};
    rib_link mask = {0};
    int rc = lama_read(p, nd, first, &dflt, m, given, v, &mask);
    if (rc != TS_OK) return rc;
    rib_surface s;
    if (nd->op == LAMA_ADD) {
        bxdf_add(p, nd, m, given, v, &s);
    } else if (nd->op == LAMA_LAYER) {
        bxdf_layer(p, nd, m, given, v, &s);
    } else if (nd->op == LAMA_SURFACE) {
        s = *m[0];
        if (given[1] && m[1] != m[0]) /* another handle than the front's */
            rib_warn_once(p, p->req_line, p->req_col,
                          "Bxdf \"LamaSurface\": materialBack is not drawn: both sides of the "
                          "surface show materialFront");
        if (mask.textured)
            rib_bxdf_cutout(p, nd->name, &mask, &s);
        else if (v[0] < 1.0)
            rib_warn_once(p, p->req_line, p->req_col,
                          "Bxdf \"LamaSurface\": a \"presence\" below 1 that is not a texture "
                          "(partial transparency) is not supported: the surface renders opaque");
    } else {
        bxdf_mix_surfaces(p, nd, m[0], m[1], fmin(1.0, fmax(0.0, v[0])), &s);
    }
    s.sheen_only = 0; /* a node's result is drawn (a LamaLayer's sheen top gives its base) */
    rc = rib_shading_limits(p, nd->name, &s);
    if (rc == TS_OK) p->surface = s;
    if (rc == TS_OK) rc = rib_bxdf_keep(p, first, &s);
    return rc;
}

int rib_lama_node(rib_parser *p, const char *name, size_t first, int *is_lama)
{
    for (size_t n = 0; n < LAMA_NODES; n++)
        if (strcmp(name, lama_nodes[n].name) == 0) {
            *is_lama = 1;
            return lama_node_run(p, &lama_nodes[n], first);
        }
    *is_lama = 0;
    return TS_OK;
}
