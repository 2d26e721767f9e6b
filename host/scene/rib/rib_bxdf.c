/* rib_bxdf.c — Bxdf and Displace (RenderMan 21-26, RIS) onto what Surface and Displacement
 * give: RenderMan's materials become the nearest of Tessera's matte, metal, glass and the
 * principled BRDF (PxrDisney, PxrSurface's diffuse, specular and clear coat; lib/principled.h),
 * with rib_shading.c's limits, their colour as the patch colour and an emission for glow;
 * PxrDisplace from a PxrTexture becomes the textured displacement. What Tessera cannot draw
 * (subsurface, partial presence, other lobes) is named in one warning each, with the
 * fallback docs/rib.md "RIS shading" lists; presence from a texture cuts the surface out
 * (bxdf_cutout). Colours and textures connected through Pattern
 * nodes come from rib_pattern.c, as do the constants of maths networks (PxrMix, ...) folded at
 * load, read as literal values. */
#include "scene/rib/rib_internal.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Everything a Bxdf here reads, with RenderMan's defaults set per Bxdf (bxdf_defaults). */
typedef struct bxdf_args {
    double diffuse_gain, color[3];                 /* the diffuse lobe (or base colour) */
    double spec_face[3], spec_edge[3], spec_rough; /* the specular lobe (Schlick face/edge) */
    double coat_face[3], coat_edge[3];             /* PxrSurface's clearcoat */
    double refr_gain, refr_color[3], glass_rough;  /* PxrSurface's glass (refraction) lobe */
    double dt_gain, dt_color[3];                   /* PxrSurface's diffuse transmission */
    double glow_gain, glow[3];                     /* emission */
    double metallic, specular, specular_tint;      /* PxrDisney */
    double sheen, sheen_tint, clearcoat, clearcoat_gloss;
    double coat_rough;       /* PxrSurface's clearcoatRoughness */
    double eta[3], kappa[3]; /* conductors: complex index of refraction */
    double ior;              /* dielectrics */
    double tint[3];          /* LamaConductor: multiplies the reflected colour */
    double fresnel_mode;     /* LamaConductor: 0 physical (IOR, extinction), 1 artistic */
    int has_reflectivity;    /* conductors: artistic face colour given */
} bxdf_args;

typedef enum bxdf_kind {
    BXDF_DIFFUSE,     /* PxrDiffuse, LamaDiffuse, LamaSurface, LamaSSS: matte */
    BXDF_SURFACE,     /* PxrSurface: principled (matte when it has no specular) */
    BXDF_DISNEY,      /* PxrDisney: principled */
    BXDF_CONDUCTOR,   /* PxrConductor, LamaConductor: metal */
    BXDF_CONSTANT,    /* PxrConstant, LamaEmission: emits, reflects nothing */
    BXDF_DIELECTRIC,  /* PxrDielectric, LamaDielectric, PxrGlass: glass, smooth or rough */
    BXDF_EMISSION,    /* PxrLightEmission: reflects nothing; its light is the AreaLightSource's */
    BXDF_TRANSLUCENT, /* LamaTranslucent: diffuse transmission through a thin sheet */
    BXDF_SHEEN        /* LamaSheen: not drawn (reflects nothing; a LamaLayer top leaves the base) */
} bxdf_kind;

/* One parameter a Bxdf reads: 1 or 3 numbers into bxdf_args at off; colour: a PxrTexture may
 * be connected to it (its image multiplies nothing: it is the colour). */
typedef struct bxdf_param {
    const char *name;
    size_t n, off;
    int colour;
} bxdf_param;

#define BP(name, n, field)                                                                         \
    {                                                                                              \
        name, n, offsetof(bxdf_args, field), 0                                                     \
    }
#define BC(name, field)                                                                            \
    {                                                                                              \
        name, 3, offsetof(bxdf_args, field), 1                                                     \
    }
static const bxdf_param bxdf_diffuse_params[] = {BC("diffuseColor", color), BC("color", color),
                                                 BP("diffuseGain", 1, diffuse_gain)};
static const bxdf_param bxdf_surface_params[] = {
    BC("diffuseColor", color),
    BP("diffuseGain", 1, diffuse_gain),
    BP("specularFaceColor", 3, spec_face),
    BP("specularEdgeColor", 3, spec_edge),
    BP("specularRoughness", 1, spec_rough),
    BP("clearcoatFaceColor", 3, coat_face),
    BP("clearcoatEdgeColor", 3, coat_edge),
    BP("clearcoatRoughness", 1, coat_rough),
    BP("glowGain", 1, glow_gain),
    BP("glowColor", 3, glow),
    BP("refractionGain", 1, refr_gain),
    BP("refractionColor", 3, refr_color),
    BP("glassIor", 1, ior),
    BP("glassRoughness", 1, glass_rough),
    BP("diffuseTransmitGain", 1, dt_gain),
    BP("diffuseTransmitColor", 3, dt_color),
};
static const bxdf_param bxdf_disney_params[] = {
    BC("baseColor", color),
    BP("metallic", 1, metallic),
    BP("roughness", 1, spec_rough),
    BP("specular", 1, specular),
    BP("specularTint", 1, specular_tint),
    BP("sheen", 1, sheen),
    BP("sheenTint", 1, sheen_tint),
    BP("clearcoat", 1, clearcoat),
    BP("clearcoatGloss", 1, clearcoat_gloss),
    BP("emitColor", 3, glow),
};
static const bxdf_param bxdf_conductor_params[] = {
    BP("roughness", 1, spec_rough), BP("eta", 3, eta),
    BP("kappa", 3, kappa),          BP("IOR", 3, eta),
    BP("extinction", 3, kappa),     BC("reflectivity", color),
    BC("specularColor", color),     BP("edgeColor", 3, spec_edge),
};
/* LamaConductor (MaterialX's ND_lama_conductor, Pixar's Lama nodes): PxrConductor's, its Fresnel
 * mode and its tint. */
static const bxdf_param bxdf_lama_conductor_params[] = {
    BP("roughness", 1, spec_rough),     BP("IOR", 3, eta),
    BP("extinction", 3, kappa),         BC("reflectivity", color),
    BP("edgeColor", 3, spec_edge),      BP("tint", 3, tint),
    BP("fresnelMode", 1, fresnel_mode),
};
/* PxrLMDiffuse (RenderMan 19-21's layered-material diffuse): its front colour; backColor,
 * roughness, sheen, translucence, incandescence and its layers are warned about as unread. */
static const bxdf_param bxdf_lm_diffuse_params[] = {BC("frontColor", color)};
/* PxrLMGlass (RenderMan 19-21): glass of index eta, its transmission tinted by refractionColor;
 * reflectionColor, transmissionColor, thin and its layers are warned about as unread. */
static const bxdf_param bxdf_lm_glass_params[] = {
    BP("eta", 1, ior), BP("refractionColor", 3, refr_color), BP("roughness", 1, spec_rough)};
/* LamaTranslucent: its colour (ND_lama_translucent's 0.18), all of it transmitted. */
static const bxdf_param bxdf_translucent_params[] = {BC("color", color)};
static const bxdf_param bxdf_constant_params[] = {BC("emitColor", color), BC("color", color)};
static const bxdf_param bxdf_dielectric_params[] = {BP("roughness", 1, spec_rough),
                                                    BP("ior", 1, ior), BP("IOR", 1, ior)};
/* LamaDielectric: its transmissionTint tints what goes through, as PxrLMGlass's refractionColor. */
static const bxdf_param bxdf_lama_dielectric_params[] = {
    BP("roughness", 1, spec_rough), BP("IOR", 1, ior), BP("transmissionTint", 3, refr_color)};
#define BXDF_PARAMS(a) a, sizeof a / sizeof a[0]

/* The Bxdfs Tessera draws. */
static const struct {
    const char *name;
    bxdf_kind kind;
    const bxdf_param *params;
    size_t nparams;
} bxdf_table[] = {
    {"PxrDiffuse", BXDF_DIFFUSE, BXDF_PARAMS(bxdf_diffuse_params)},
    {"LamaDiffuse", BXDF_DIFFUSE, BXDF_PARAMS(bxdf_diffuse_params)},
    {"LamaSurface", BXDF_DIFFUSE, BXDF_PARAMS(bxdf_diffuse_params)},
    {"PxrSurface", BXDF_SURFACE, BXDF_PARAMS(bxdf_surface_params)},
    {"PxrDisney", BXDF_DISNEY, BXDF_PARAMS(bxdf_disney_params)},
    {"PxrConductor", BXDF_CONDUCTOR, BXDF_PARAMS(bxdf_conductor_params)},
    {"LamaConductor", BXDF_CONDUCTOR, BXDF_PARAMS(bxdf_lama_conductor_params)},
    {"PxrConstant", BXDF_CONSTANT, BXDF_PARAMS(bxdf_constant_params)},
    {"LamaEmission", BXDF_CONSTANT, BXDF_PARAMS(bxdf_constant_params)},
    {"PxrDielectric", BXDF_DIELECTRIC, BXDF_PARAMS(bxdf_dielectric_params)},
    {"LamaDielectric", BXDF_DIELECTRIC, BXDF_PARAMS(bxdf_lama_dielectric_params)},
    {"PxrGlass", BXDF_DIELECTRIC, BXDF_PARAMS(bxdf_dielectric_params)},
    {"PxrLMDiffuse", BXDF_DIFFUSE, BXDF_PARAMS(bxdf_lm_diffuse_params)},
    {"PxrLMGlass", BXDF_DIELECTRIC, BXDF_PARAMS(bxdf_lm_glass_params)},
    {"PxrLMMetal", BXDF_CONDUCTOR, BXDF_PARAMS(bxdf_conductor_params)},
    {"PxrLightEmission", BXDF_EMISSION, NULL, 0},
    {"LamaTranslucent", BXDF_TRANSLUCENT, BXDF_PARAMS(bxdf_translucent_params)},
    {"LamaSSS", BXDF_DIFFUSE, BXDF_PARAMS(bxdf_diffuse_params)},
    {"LamaSheen", BXDF_SHEEN, BXDF_PARAMS(bxdf_translucent_params)},
};
#define BXDF_COUNT (sizeof bxdf_table / sizeof bxdf_table[0])

/* PxrSurface's and PxrDisney's lobes (and parts of lobes) Tessera does not draw: a parameter whose
 * name starts with the prefix is ignored silently while the lobe's weight (`gain`, summed over its
 * values) is 0, and the weight, when not 0, is named in one warning. */
static const struct {
    const char *prefix, *gain, *what;
} bxdf_lobes[] = {
    {"refraction", "refractionGain", "refraction is not supported yet"},
    {"glass", "refractionGain", "refraction is not supported yet"},
    {"subsurface", "subsurfaceGain", "subsurface scattering is not supported"},
    {"fuzz", "fuzzGain", "the fuzz lobe is not drawn"},
    {"singlescatter", "singlescatterGain", "single scattering is not supported"},
    {"iridescence", "iridescenceFaceGain", "iridescence is not drawn"},
    {"roughSpecular", "roughSpecularFaceColor", "the rough specular lobe is not drawn"},
    {"subsurface", "subsurface", "subsurface scattering is not supported"},
    {"clearcoat", "clearcoatThickness", "the clear coat's absorption is not drawn"},
    {"specTrans", "specTrans", "refraction is not supported yet"},
    {"anisotropic", "anisotropic", "anisotropy is not drawn (an isotropic lobe)"},
    {"sss", "sssRadius", "subsurface scattering is not supported (its Lambertian lobe is drawn)"},
};
#define BXDF_LOBES (sizeof bxdf_lobes / sizeof bxdf_lobes[0])

static bxdf_args bxdf_defaults(bxdf_kind kind)
{
    bxdf_args a = {.diffuse_gain = 1.0,
                   .color = {0.18, 0.18, 0.18},
                   .spec_rough = 0.2,
                   .glow = {1, 1, 1},
                   .specular = 0.5,
                   .eta = {4.3696, 2.916, 1.6544}, /* PxrConductor's defaults */
                   .kappa = {5.2057, 4.2142, 3.7519},
                   .ior = 1.5,
                   .refr_color = {1, 1, 1},
                   .glass_rough = 0.1,
                   .dt_color = {0.18, 0.18, 0.18}, /* PxrSurface's diffuseTransmitColor */
                   .sheen_tint = 0.5,
                   .clearcoat_gloss = 1.0};
    if (kind == BXDF_DIFFUSE) a.color[0] = a.color[1] = a.color[2] = 0.5; /* PxrDiffuse */
    if (kind == BXDF_DISNEY) {
        a.color[0] = 0.2, a.color[1] = 0.5, a.color[2] = 0.8, a.spec_rough = 0.25;
        a.glow[0] = a.glow[1] = a.glow[2] = 0.0;
    }
    if (kind == BXDF_CONSTANT) a.color[0] = a.color[1] = a.color[2] = 1.0;
    if (kind == BXDF_DIELECTRIC) a.spec_rough = 0.0;
    if (kind == BXDF_CONDUCTOR) a.spec_edge[0] = a.spec_edge[1] = a.spec_edge[2] = 1.0;
    a.tint[0] = a.tint[1] = a.tint[2] = 1.0;
    a.fresnel_mode = -1.0; /* not given */
    return a;
}

/* The Lama nodes' own defaults where they differ from the Pxr Bxdfs' of their kind: those of
 * MaterialX's Lama node definitions (libraries/bxdf/lama, ND_lama_*, written by Pixar for its
 * Lama nodes): LamaDiffuse's colour 0.18; LamaConductor's IOR and extinction (gold), its
 * artistic reflectivity and edge colour, roughness 0.1; LamaDielectric's roughness 0.1 (smooth
 * still: alpha 0.01). */
static void bxdf_lama_defaults(const char *name, bxdf_args *a)
{
    static const double eta[3] = {0.18, 0.42, 1.37}, kappa[3] = {3.42, 2.35, 1.77},
                        refl[3] = {0.945, 0.7772, 0.3737}, edge[3] = {0.9979, 0.9813, 0.7523};
    if (strcmp(name, "LamaDiffuse") == 0 || strcmp(name, "LamaSSS") == 0)
        a->color[0] = a->color[1] = a->color[2] = 0.18;
    if (strcmp(name, "LamaConductor") == 0) {
        memcpy(a->eta, eta, sizeof eta), memcpy(a->kappa, kappa, sizeof kappa);
        memcpy(a->color, refl, sizeof refl), memcpy(a->spec_edge, edge, sizeof edge);
        a->spec_rough = 0.1;
    }
    if (strcmp(name, "LamaDielectric") == 0) a->spec_rough = 0.1;
}

/* Glass (TS_MAT_GLASS) of index ior (outside [1, 4]: 1.5, with a warning) and colour cs,
 * keeping the roughness and emission *s has. */
static void bxdf_glass(rib_parser *p, const char *bxdf, double ior, const double cs[3],
                       rib_surface *s)
{
    s->material = TS_MAT_GLASS, s->kd = 0.0, s->ks = 0.0;
    s->ior = ior >= 1.0 && ior <= 4.0 ? ior : 1.5;
    memcpy(s->color, cs, sizeof s->color);
    if (s->ior != ior) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what, "Bxdf \"%s\": ior %g outside [1, 4]: 1.5 instead", bxdf, ior);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
}

/* The hemispherical average of Schlick's Fresnel from face colour f0 to edge colour f90:
 * f0 + (f90 - f0) / 21 (the integral of (1 - cos)^5 against 2 cos). */
double rib_schlick_mean(double f0, double f90)
{
    return f0 + (f90 - f0) / 21.0;
}

/* Whether args[i] names a lobe weight (bxdf_lobes) or lies in a lobe, and warns about a weight
 * that is not 0. Returns 1 when the parameter is handled so. */
static int bxdf_lobe_param(rib_parser *p, const char *bxdf, const rib_param *prm)
{
    for (size_t k = 0; k < BXDF_LOBES; k++) {
        if (strcmp(prm->name, bxdf_lobes[k].gain) != 0) continue;
        const rib_arg *v = prm->val;
        double sum = 0.0;
        if (v->kind == RIB_ARG_NUMBER || v->kind == RIB_ARG_NUMBERS)
            for (size_t j = 0; j < v->count; j++)
                sum += fabs(rib_arg_nums(p, v)[j]);
        else
            sum = 1.0; /* connected to a pattern */
        if (sum != 0.0) {
            char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
            snprintf(what, sizeof what, "Bxdf \"%s\": \"%s\" is not 0, but %s", bxdf,
                     rib_printable(prm->name, shown), bxdf_lobes[k].what);
            rib_warn_once(p, prm->key->line, prm->key->col, what);
        }
        return 1;
    }
    for (size_t k = 0; k < BXDF_LOBES; k++) /* in a lobe: silent, its weight speaks for it */
        if (strncmp(prm->name, bxdf_lobes[k].prefix, strlen(bxdf_lobes[k].prefix)) == 0) return 1;
    return 0;
}

/* The Bxdf parameters at the values that are what Tessera draws, which RenderMan for Maya
 * writes on every Bxdf: silent there, warned about at any other value. presence 1 (opaque),
 * inputAOV 0 (no matte-ID AOV), no bump; PxrSurface's artistic Fresnel (specularFresnelMode 0:
 * the face and edge colours Tessera reads), no anisotropy, no energy compensation, lobes lit
 * from both sides (Tessera's are), the irradiance untinted and unroughened, black shadows. */
static const rib_neutral bxdf_neutral[] = {
    {"presence", 1, {1}},
    {"inputAOV", 1, {0}},
    {"bumpNormal", 3, {0, 0, 0}},
    {"specularFresnelMode", 1, {0}},
    {"specularAnisotropy", 1, {0}},
    {"specularEnergyCompensation", 1, {0}},
    {"diffuseDoubleSided", 1, {1}},
    {"specularDoubleSided", 1, {1}},
    {"irradianceTint", 3, {1, 1, 1}},
    {"irradianceRoughness", 1, {0}},
    {"shadowColor", 3, {0, 0, 0}},
    {"specularBumpNormal", 3, {0, 0, 0}},
    {"specularAnisotropyDirection", 3, {0, 0, 0}},
    {"clearcoatBumpNormal", 3, {0, 0, 0}},
    {"diffuseBumpNormal", 3, {0, 0, 0}},
    /* the Lama nodes' (MaterialX's ND_lama_*): air outside, isotropic, no thin film, the
     * energy compensation of a roughness Tessera does not draw (which warns itself) */
    {"exteriorIOR", 1, {1}},
    {"anisotropy", 1, {0}},
    {"iridescenceThickness", 1, {0}},
    {"energyCompensation", 1, {1}},
};

/* Silent at any value: presenceCached (RenderMan for Maya's bookkeeping), specularIor and
 * specularExtinctionCoeff (read only by the physical Fresnel, specularFresnelMode 1, which
 * warns itself), maxContinuationHits (the noise only), the Lama nodes' lobeName and matte (the
 * names of AOVs) and bumpShadowing (of a bump Tessera does not draw). */
int rib_bxdf_silent(const char *name)
{
    static const char *const names[] = {
        "presenceCached",      "specularIor", "specularExtinctionCoeff",
        "maxContinuationHits", "lobeName",    "matte",
        "bumpShadowing"};
    return rib_in_list(name, names, RIB_COUNT(names));
}

/* Reads Bxdf table entry k's parameters from args[first] into *a; a PxrTexture connected to
 * its colour parameter into *link. presence and the lobes warn; others are ignored with one
 * warning each. */
static int bxdf_read(rib_parser *p, size_t k, size_t first, bxdf_args *a, rib_link *link,
                     rib_link *mask)
{
    const char *bxdf = bxdf_table[k].name;
    char what[RIB_WARN_KEY];
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        size_t j = 0;
        while (j < bxdf_table[k].nparams && strcmp(prm.name, bxdf_table[k].params[j].name) != 0)
            j++;
        if (j == bxdf_table[k].nparams) {
            /* Silent: the values that are what is drawn (bxdf_neutral, bxdf_silent); "__"
             * names: rib_warn_param. */
            if (rib_bxdf_silent(prm.name) ||
                rib_param_neutral(p, &prm, bxdf_neutral,
                                  sizeof bxdf_neutral / sizeof *bxdf_neutral))
                continue;
            if (strcmp(prm.name, "presence") == 0) {
                rib_link l; /* a PxrTexture's alpha (or resultR) cuts the surface out */
                rc = rib_pattern_link(p, &prm, RIB_LINK_MASK, "the surface renders opaque", &l);
                if (rc != TS_OK) return rc;
                if (l.textured) *mask = l;
                if (l.textured || (l.linked && !(l.folded && l.value[0] < 1.0)))
                    continue; /* a mask, or opaque (an unfolded link has warned) */
                snprintf(what, sizeof what,
                         "Bxdf \"%s\": a \"presence\" below 1 that is not a texture (partial "
                         "transparency) is not supported: the surface renders opaque",
                         bxdf);
                rib_warn_once(p, prm.key->line, prm.key->col, what);
            } else if (!bxdf_lobe_param(p, bxdf, &prm)) {
                rib_warn_param(p, &prm);
            }
            continue;
        }
        const bxdf_param *bp = &bxdf_table[k].params[j];
        rib_link l;
        rc = rib_pattern_link(p, &prm, TS_TEX_RGB, "rendered with its colour parameter's default",
                              &l);
        if (rc != TS_OK) return rc;
        if (l.linked && !l.folded) {
            if (l.textured && bp->colour) *link = l;
            if (l.textured && !bp->colour) {
                snprintf(what, sizeof what,
                         "Bxdf \"%s\": a texture connected to \"%s\" is not drawn (only to its "
                         "colour): it keeps its default",
                         bxdf, prm.name);
                rib_warn_once(p, prm.key->line, prm.key->col, what);
            }
            continue;
        }
        if (l.folded && bp->n == 1 && !l.scalar) {
            snprintf(what, sizeof what,
                     "Bxdf \"%s\": float \"%s\" is connected to a colour output: it keeps its "
                     "default (resultR, resultG, resultB or resultF would be read)",
                     bxdf, prm.name);
            rib_warn_once(p, prm.val->line, prm.val->col, what);
            continue;
        }
        const double *v = l.value; /* folded from a Pattern network, or the literal's */
        if (!l.folded) rc = rib_param_numbers(p, &prm, bp->n, &v, NULL);
        if (rc != TS_OK) return rc;
        for (size_t c = 0; c < bp->n; c++)
            if (!(fabs(v[c]) <= FLT_MAX))
                return rib_error_at(p, prm.val->line, prm.val->col,
                                    "Bxdf \"%s\": \"%s\" must be finite", bxdf, prm.name);
        memcpy((char *)a + bp->off, v, bp->n * sizeof *v);
        if (strcmp(prm.name, "reflectivity") == 0 || strcmp(prm.name, "specularColor") == 0)
            a->has_reflectivity = 1;
    }
    return TS_OK;
}

/* v clamped to [0, hi], with one warning naming the parameter when it lay outside. */
static double bxdf_clamp(rib_parser *p, const char *bxdf, const char *name, double v, double hi)
{
    if (v >= 0.0 && v <= hi) return v;
    char what[RIB_WARN_KEY];
    snprintf(what, sizeof what, "Bxdf \"%s\": \"%s\" outside [0, %g] is clamped to it", bxdf, name,
             hi);
    rib_warn_once(p, p->req_line, p->req_col, what);
    return fmin(fmax(v, 0.0), hi);
}

/* PxrDisney onto the principled BRDF (lib/principled.h), parameter for parameter. Kd = 1 -
 * metallic: the diffuse weight that relighting and the albedo AOV read (the BRDF does not). */
static void bxdf_disney(rib_parser *p, const char *bxdf, const bxdf_args *a, rib_surface *s)
{
    s->material = TS_MAT_PRINCIPLED;
    s->metallic = bxdf_clamp(p, bxdf, "metallic", a->metallic, 1.0);
    s->specular = bxdf_clamp(p, bxdf, "specular", a->specular, 1.0);
    s->specular_tint = bxdf_clamp(p, bxdf, "specularTint", a->specular_tint, 1.0);
    s->sheen = bxdf_clamp(p, bxdf, "sheen", a->sheen, 1.0);
    s->sheen_tint = bxdf_clamp(p, bxdf, "sheenTint", a->sheen_tint, 1.0);
    s->clearcoat = bxdf_clamp(p, bxdf, "clearcoat", a->clearcoat, 1.0);
    s->clearcoat_gloss = bxdf_clamp(p, bxdf, "clearcoatGloss", a->clearcoat_gloss, 1.0);
    s->kd = 1.0 - s->metallic, s->ks = 0.0;
    memcpy(s->emit, a->glow, sizeof s->emit);
}

/* PxrSurface's diffuse, primary specular and clear coat onto the principled BRDF: Cs =
 * diffuseGain diffuseColor; the specular's F0 = specularFaceColor (its mean, up to a
 * dielectric's 0.08: specular = F0 / 0.08), Schlick's Fresnel to 1 at the edge; with no diffuse
 * and F0 above 0.08 a conductor (metallic 1, Cs = specularFaceColor). The clear coat of mean
 * Schlick Fresnel c (face to edge colour) is clearcoat = 4 c / c(0.04, 1), up to 4 (0.25 x 4:
 * Schlick from 0.04 to 1), its GGX alpha clearcoatRoughness^2 in [0.01, 0.1]. Without any
 * specular or coat it stays matte (Schlick's edge would add a reflection PxrSurface lacks). */
static void bxdf_surface(rib_parser *p, const char *bxdf, const bxdf_args *a, rib_surface *s)
{
    char what[RIB_WARN_KEY];
    double face = 0.0, coat = 0.0, fmax_c = 0.0, dmax = 0.0;
    int grey = 1, spec = 0, edge1 = 1;
    for (int c = 0; c < 3; c++) {
        face += a->spec_face[c] / 3.0, fmax_c = fmax(fmax_c, a->spec_face[c]);
        coat += rib_schlick_mean(a->coat_face[c], a->coat_edge[c]) / 3.0;
        grey &= a->spec_face[c] == a->spec_face[0] && a->spec_edge[c] == a->spec_edge[0];
        spec |= a->spec_face[c] > 0.0 || a->spec_edge[c] > 0.0;
        edge1 &= a->spec_edge[c] == 1.0;
        dmax = fmax(dmax, a->diffuse_gain * a->color[c]);
    }
    /* matte, as *s is: without specular or coat, or with a negative gain (which
     * rib_shading_limits reports as Kd) */
    if ((!spec && !(coat > 0.0)) || !(a->diffuse_gain >= 0.0)) return;
    s->material = TS_MAT_PRINCIPLED, s->kd = 1.0, s->ks = 0.0;
    if (!(dmax > 0.0) && fmax_c > 0.08) { /* a conductor: its face colour is Cs */
        s->metallic = 1.0, s->kd = 0.0;
        for (int c = 0; c < 3; c++)
            s->color[c] = fmin(a->spec_face[c], 1.0);
    } else {
        for (int c = 0; c < 3; c++)
            s->color[c] = a->diffuse_gain * a->color[c];
        s->specular = fmin(face / 0.08, 1.0);
        if (!grey) {
            snprintf(what, sizeof what, "Bxdf \"%s\": the specular colour is drawn grey (its mean)",
                     bxdf);
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
        if (face > 0.08) {
            snprintf(what, sizeof what,
                     "Bxdf \"%s\": a specularFaceColor above 0.08 over a diffuse lobe is drawn as "
                     "0.08 (a dielectric's F0 up to index 1.8)",
                     bxdf);
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
    }
    if (spec && !edge1) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": specularEdgeColor is drawn as 1 (Schlick's Fresnel to white)", bxdf);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    s->clearcoat = fmin(4.0 * coat / rib_schlick_mean(0.04, 1.0), 4.0);
    double alpha_c = a->coat_rough * a->coat_rough;
    if (coat > 0.0 && alpha_c > 0.1) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": clearcoatRoughness above 0.32 is drawn as 0.32 (GGX alpha 0.1)",
                 bxdf);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    s->clearcoat_gloss = (0.1 - fmin(fmax(alpha_c, 0.01), 0.1)) / 0.09;
}

/* A thin sheet that reflects albedo refl and transmits albedo trans (per channel), as one
 * material (TS_MAT_TRANSLUCENT; matte when it transmits nothing): Cs = refl + trans, Kd and Ks
 * their shares of its mean. Exact when refl and trans are proportional (or one is 0): else
 * their two colours are drawn as one, with one warning naming `what`. A sum above 1 in a
 * channel would scatter more than arrives: scaled down to 1, with one warning. */
void rib_bxdf_sheet(rib_parser *p, const char *what, const double refl[3], const double trans[3],
                    rib_surface *s)
{
    char msg[RIB_WARN_KEY];
    double sum[3], mr = 0.0, mt = 0.0, big = 0.0, cross = 0.0;
    for (int c = 0; c < 3; c++) {
        sum[c] = refl[c] + trans[c], mr += refl[c], mt += trans[c], big = fmax(big, sum[c]);
        for (int d = 0; d < 3; d++) /* proportional: refl[c] trans[d] = refl[d] trans[c] */
            cross = fmax(cross, fabs(refl[c] * trans[d] - refl[d] * trans[c]));
    }
    s->material = mt > 0.0 ? TS_MAT_TRANSLUCENT : TS_MAT_MATTE;
    s->kd = mr + mt > 0.0 ? mr / (mr + mt) : 0.0, s->ks = mr + mt > 0.0 ? mt / (mr + mt) : 0.0;
    for (int c = 0; c < 3; c++)
        s->color[c] = big > 1.0 ? sum[c] / big : sum[c];
    if (cross > 1e-9 * (mr + mt) * (mr + mt)) {
        snprintf(msg, sizeof msg,
                 "%s: the reflected and transmitted colours differ and are drawn as one, their "
                 "sum (each lobe keeps its mean albedo: an approximation)",
                 what);
        rib_warn_once(p, p->req_line, p->req_col, msg);
    }
    if (big > 1.0) {
        snprintf(msg, sizeof msg,
                 "%s: reflection and transmission sum to %g: scaled down to 1 (energy "
                 "conservation)",
                 what, big);
        rib_warn_once(p, p->req_line, p->req_col, msg);
    }
}

/* PxrConductor, LamaConductor and PxrLMMetal onto metal: Cs per channel = tint x the Schlick
 * average from the face colour to the edge colour. Artistic (the face and edge colours):
 * fresnelMode 1, or a reflectivity given without a fresnelMode; else physical, the face colour
 * from IOR and extinction. LamaConductor's physical Fresnel goes to 1 at the edge (its
 * edgeColor is the artistic mode's). */
static void bxdf_conductor(rib_parser *p, const char *bxdf, const bxdf_args *a, rib_surface *s)
{
    s->material = TS_MAT_METAL, s->kd = 0.0, s->ks = 1.0;
    int artistic = a->fresnel_mode == 1.0 || (a->fresnel_mode < 0.0 && a->has_reflectivity);
    int lama = strcmp(bxdf, "LamaConductor") == 0;
    if (a->fresnel_mode >= 0.0 && a->fresnel_mode != 1.0 && a->has_reflectivity) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": \"reflectivity\" is not read under fresnelMode %g (physical: IOR "
                 "and extinction)",
                 bxdf, a->fresnel_mode);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    for (int c = 0; c < 3; c++) {
        double n = a->eta[c], k = a->kappa[c]; /* normal-incidence Fresnel of n + ik */
        double f0 =
            artistic ? a->color[c] : ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
        double edge = artistic || !lama ? a->spec_edge[c] : 1.0;
        s->color[c] = a->tint[c] * rib_schlick_mean(f0, edge);
    }
}

/* PxrSurface's lobes that go through the surface, after bxdf_surface: diffuse transmission
 * beside its diffuse lobe alone makes a translucent sheet (beside a specular lobe or a coat,
 * the principled BRDF, it is not drawn: one warning); refraction makes it glass. */
static void bxdf_surface_through(rib_parser *p, const char *bxdf, const bxdf_args *a,
                                 rib_surface *s)
{
    char what[RIB_WARN_KEY];
    if (a->dt_gain > 0.0) {
        snprintf(what, sizeof what, "Bxdf \"%s\"", bxdf);
        if (s->material == TS_MAT_MATTE) {
            double refl[3], trans[3];
            for (int c = 0; c < 3; c++)
                refl[c] = s->kd * s->color[c], trans[c] = a->dt_gain * a->dt_color[c];
            rib_bxdf_sheet(p, what, refl, trans, s);
        } else {
            snprintf(what, sizeof what,
                     "Bxdf \"%s\": \"diffuseTransmitGain\" is not 0, but diffuse transmission "
                     "is drawn only beside a diffuse lobe alone (no specular lobe or clear coat)",
                     bxdf);
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
    }
    if (a->refr_gain > 0.0) {
        /* PxrSurface's glass lobe: the surface is glass of index glassIor, alpha
         * glassRoughness^2, tinted by refractionGain * refractionColor; its other lobes go */
        double tint[3];
        for (int c = 0; c < 3; c++)
            tint[c] = fmin(1.0, fmax(0.0, a->refr_gain * a->refr_color[c]));
        int others = a->diffuse_gain * (a->color[0] + a->color[1] + a->color[2]) > 0.0 ||
                     s->material == TS_MAT_PRINCIPLED;
        bxdf_glass(p, bxdf, a->ior, tint, s);
        s->roughness = fmin(fmax(a->glass_rough * a->glass_rough, 0.01), 1.0);
        if (others) {
            snprintf(what, sizeof what,
                     "Bxdf \"%s\": with refractionGain it is drawn as glass: its diffuse and "
                     "specular lobes are not drawn",
                     bxdf);
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
    }
}

/* The material of a Bxdf of `kind` from its arguments (docs/rib.md "RIS shading"). */
static void bxdf_material(rib_parser *p, const char *bxdf, bxdf_kind kind, const bxdf_args *a,
                          rib_surface *s)
{
    char what[RIB_WARN_KEY];
    /* Perceptual roughness -> GGX alpha, at least 0.01 (Tessera has no perfect mirrors; the
     * classic shaders' clamp warns, RIS files write 0 for smooth glass and metal). */
    double alpha = fmin(fmax(a->spec_rough * a->spec_rough, 0.01), 1.0);
    *s = (rib_surface){.material = TS_MAT_MATTE, .kd = a->diffuse_gain, .roughness = alpha};
    s->has_color = 1;
    memcpy(s->color, a->color, sizeof s->color);
    if (kind == BXDF_SURFACE) {
        bxdf_surface(p, bxdf, a, s);
        for (int c = 0; c < 3; c++)
            s->emit[c] = a->glow_gain * a->glow[c];
    } else if (kind == BXDF_DISNEY) {
        bxdf_disney(p, bxdf, a, s);
    } else if (kind == BXDF_CONDUCTOR) {
        bxdf_conductor(p, bxdf, a, s);
    } else if (kind == BXDF_CONSTANT) {
        s->kd = 0.0, s->constant = 1; /* emits its colour (rib_geom.c), reflects nothing */
    } else if (kind == BXDF_SHEEN) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": the sheen lobe is not drawn: alone it reflects nothing, as a "
                 "LamaLayer's top it leaves the base as it is",
                 bxdf);
        rib_warn_once(p, p->req_line, p->req_col, what);
        s->kd = 0.0, s->sheen_only = 1;
    } else if (kind == BXDF_TRANSLUCENT) { /* all of it through: Kd 0, Ks 1 */
        s->material = TS_MAT_TRANSLUCENT, s->kd = 0.0, s->ks = 1.0;
    } else if (kind == BXDF_EMISSION) {
        /* RenderMan 20's light geometry (rib_ris_light.c rib_rm20_area_light): the emission
         * is the AreaLightSource's, and the surface reflects nothing. */
        s->kd = 0.0;
    } else if (kind == BXDF_DIELECTRIC) {
        /* roughness: GGX alpha as for the other Bxdfs; up to TS_GLASS_SMOOTH (lib/bsdf.h)
         * the glass is smooth, above it Walter et al. 2007's rough dielectric */
        double tint[3]; /* PxrLMGlass's refractionColor; the others' 1 */
        for (int c = 0; c < 3; c++)
            tint[c] = fmin(1.0, fmax(0.0, a->refr_color[c]));
        bxdf_glass(p, bxdf, a->ior, tint, s);
    }
    if (kind == BXDF_SURFACE) bxdf_surface_through(p, bxdf, a, s);
}

/* A presence mask (a PxrTexture's alpha or resultR, `mask`) on material s: the patch is cut out
 * where the mask is below 0.5 (TS_PATCH_CUTOUT, at the micro-quads' centres: build.cl). A
 * patch reads one texture, with one st map: when s is coloured by a texture the mask must be
 * that texture, read through the same manifold; else (one warning) the surface stays opaque,
 * as it does on an emitter (whose light samples would land on the parts cut away). */
void rib_bxdf_cutout(rib_parser *p, const char *bxdf, const rib_link *mask, rib_surface *s)
{
    char what[RIB_WARN_KEY];
    const char *why = NULL;
    if (s->constant || s->emit[0] > 0.0 || s->emit[1] > 0.0 || s->emit[2] > 0.0)
        why = "on a surface that emits";
    else if (s->textured &&
             (s->tex != mask->tex || memcmp(s->st_map, mask->st_map, sizeof s->st_map) != 0))
        why = "from another texture (or manifold) than its colour's";
    if (why) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": \"presence\" %s is not drawn: the surface renders opaque", bxdf,
                 why);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return;
    }
    s->cutout = 1, s->cutout_red = mask->mask_red, s->cutout_tex = mask->tex;
    if (!s->textured) {
        s->has_st_map = 1;
        memcpy(s->st_map, mask->st_map, sizeof s->st_map);
    }
}

/* PxrDiffuse's default material (a Lama node's input that names no Bxdf). */
void rib_bxdf_default(rib_parser *p, rib_surface *s)
{
    bxdf_args def = bxdf_defaults(BXDF_DIFFUSE);
    bxdf_material(p, "PxrDiffuse", BXDF_DIFFUSE, &def, s);
}

/* Whether the request's parameters from args[first] name `name`. */
static int bxdf_has_param(rib_parser *p, size_t first, const char *name)
{
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        if (rib_param_at(p, i, &prm) == TS_OK && strcmp(prm.name, name) == 0) return 1;
    }
    return 0;
}

/* Bxdf "name" "handle" params: the material of the following geometry (an attribute, as
 * Surface), from the Bxdfs of bxdf_table or the Lama nodes that combine them (rib_lama.c); any
 * other Bxdf renders as matte (its parameters unread) with one warning naming it. Each is kept
 * under its handle, for the Lama nodes. */
int rib_req_bxdf(rib_parser *p)
{
    const char *name;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a Bxdf name", &name);
    if (rc != TS_OK) return rc;
    size_t first = (p->nargs % 2 == 0) ? 2 : 1; /* a handle makes the count even */
    /* LamaSurface with a materialFront is the end of a Lama network; without, it is read as
     * a matte of its diffuse colour (bxdf_table), as files written for it so are */
    int lama_end = strcmp(name, "LamaSurface") != 0 || bxdf_has_param(p, first, "materialFront");
    int lama = 0;
    rc = lama_end ? rib_lama_node(p, name, first, &lama) : TS_OK;
    if (lama || rc != TS_OK) return rc;
    size_t k = 0;
    while (k < BXDF_COUNT && strcmp(name, bxdf_table[k].name) != 0)
        k++;
    /* A name that differs in case only (`PXRDisney`): RenderMan finds the plugin by its file
     * name, which matches regardless of case on macOS and Windows, where such files are made. */
    for (size_t c = 0; k == BXDF_COUNT && c < BXDF_COUNT; ++c)
        if (strcasecmp(name, bxdf_table[c].name) == 0) {
            snprintf(what, sizeof what, "Bxdf \"%s\" is read as %s (the names differ in case only)",
                     rib_printable(name, shown), bxdf_table[c].name);
            rib_warn_once(p, p->args[0].line, p->args[0].col, what);
            k = c;
        }
    if (k == BXDF_COUNT) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\" is unknown: it renders as PxrDiffuse (matte) of its default colour",
                 rib_printable(name, shown));
        rib_warn_once(p, p->args[0].line, p->args[0].col, what);
        rib_bxdf_default(p, &p->surface);
        return rib_bxdf_keep(p, first, &p->surface);
    }
    bxdf_args a = bxdf_defaults(bxdf_table[k].kind);
    bxdf_lama_defaults(bxdf_table[k].name, &a);
    rib_link link = {0};
    rib_link mask = {0};
    rc = bxdf_read(p, k, first, &a, &link, &mask);
    if (rc != TS_OK) return rc;
    rib_surface s;
    bxdf_material(p, bxdf_table[k].name, bxdf_table[k].kind, &a, &s);
    if (bxdf_table[k].kind == BXDF_CONSTANT && link.textured) {
        rib_warn_once(p, p->req_line, p->req_col,
                      "Bxdf: a texture connected to an emission colour is not drawn (emission is "
                      "one colour a patch)");
        link.textured = 0;
    }
    if (link.textured && s.material == TS_MAT_PRINCIPLED && a.diffuse_gain != 1.0) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": diffuseGain does not scale a colour connected to a texture",
                 bxdf_table[k].name);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    if (link.textured && s.material == TS_MAT_TRANSLUCENT && s.kd > 0.0) {
        snprintf(what, sizeof what,
                 "Bxdf \"%s\": the texture connected to its colour colours the transmitted light "
                 "too (one colour for both lobes)",
                 bxdf_table[k].name);
        rib_warn_once(p, p->req_line, p->req_col, what);
    }
    if (link.textured) { /* the texture is the colour: Cs 1 times it */
        s.textured = 1, s.tex = link.tex;
        s.color[0] = s.color[1] = s.color[2] = 1.0;
        s.has_st_map = 1;
        memcpy(s.st_map, link.st_map, sizeof s.st_map);
    }
    if (mask.textured) rib_bxdf_cutout(p, bxdf_table[k].name, &mask, &s);
    rc = rib_shading_limits(p, bxdf_table[k].name, &s);
    if (rc == TS_OK) p->surface = s;
    if (rc == TS_OK) rc = rib_bxdf_keep(p, first, &s);
    return rc;
}

/* Displace "PxrDisplace" "handle" ["float dispAmount" [a]] ["reference float dispScalar"
 * ["tex:resultR"]]: d = a * scalar along the displacement normal; a PxrTexture connected to
 * dispScalar becomes Displacement "texture" (amplitude a, offset 0). A constant dispScalar
 * other than 0 (a uniform offset of the surface) is not drawn, with a warning. Other Displace
 * shaders turn displacement off with one warning, as an unknown Displacement does. */
int rib_req_displace(rib_parser *p)
{
    const char *name;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    int rc = rib_string_arg(p, 0, "a displacement name", &name);
    if (rc != TS_OK) return rc;
    const rib_disp none = {TS_DISP_NONE, 4, 0.1, 1.0, 2.0, 0.5, 0, 0.0, 0, {0}};
    if (strcmp(name, "PxrDisplace") != 0) {
        snprintf(what, sizeof what, "Displace \"%s\" is unknown: no displacement (PxrDisplace)",
                 rib_printable(name, shown));
        rib_warn_once(p, p->args[0].line, p->args[0].col, what);
        p->disp = none;
        return TS_OK;
    }
    size_t first = (p->nargs % 2 == 0) ? 2 : 1;
    double amount = 1.0, scalar = 0.0;
    int enabled = 1;
    rib_link link = {0};
    for (size_t i = first; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        int is_amount = strcmp(prm.name, "dispAmount") == 0;
        int is_scalar = strcmp(prm.name, "dispScalar") == 0;
        int is_enabled = strcmp(prm.name, "enabled") == 0;
        if (!is_amount && !is_scalar && !is_enabled) {
            rib_warn_param(p, &prm);
            continue;
        }
        rib_link l;
        rc = rib_pattern_link(p, &prm, TS_TEX_MINMAX, "no displacement", &l);
        if (rc != TS_OK) return rc;
        if (l.linked && !l.folded) {
            if (is_scalar) link = l;
            if (!is_scalar && l.textured)
                rib_warn_once(p, prm.key->line, prm.key->col,
                              "Displace \"PxrDisplace\": only dispScalar may be connected to a "
                              "texture");
            continue;
        }
        if (l.folded && !l.scalar) {
            rib_warn_once(p, prm.val->line, prm.val->col,
                          "Displace \"PxrDisplace\": a float is connected to a colour output: it "
                          "keeps its default (resultR, resultG, resultB or resultF would be read)");
            continue;
        }
        v = l.value; /* folded from a Pattern network, or the literal's */
        if (!l.folded) rc = rib_param_numbers(p, &prm, 1, &v, NULL);
        if (rc != TS_OK) return rc;
        if (!(fabs(v[0]) <= FLT_MAX))
            return rib_error_at(p, prm.val->line, prm.val->col,
                                "Displace: \"%s\" must be finite, got %g", prm.name, v[0]);
        if (is_amount) amount = v[0];
        if (is_scalar) scalar = v[0];
        if (is_enabled) enabled = v[0] != 0.0;
    }
    rib_disp d = none;
    if (enabled && link.textured && amount != 0.0) {
        d.kind = TS_DISP_TEXTURE, d.tex = link.tex, d.amplitude = amount, d.offset = 0.0;
        d.has_st_map = 1;
        memcpy(d.st_map, link.st_map, sizeof d.st_map);
        if (p->surface.has_st_map && memcmp(p->surface.st_map, d.st_map, sizeof d.st_map) != 0)
            rib_warn_once(p, p->req_line, p->req_col,
                          "Displace: the displacement texture's manifold differs from the colour "
                          "texture's; both use the colour's");
    } else if (enabled && !link.linked && scalar * amount != 0.0) {
        rib_warn_once(p, p->req_line, p->req_col,
                      "Displace \"PxrDisplace\": a constant dispScalar (a uniform offset of the "
                      "surface) is not drawn: no displacement");
    }
    p->disp = d;
    return TS_OK;
}
