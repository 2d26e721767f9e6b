/* rib_pattern.c — Pattern (RenderMan 21-26, RIS): the nodes of a shading network, by handle,
 * and the connections Bxdf and Displace parameters make to them ("reference color
 * diffuseColor" ["tex:resultRGB"]). Tessera draws two kinds of node: PxrTexture (an image,
 * through the scene's textures; RenderMan's own .tex files cannot be read, so a .tx, .exr,
 * .png, .tif or .jpg beside one is used instead) and PxrManifold2D (a scale and offset of
 * st). The maths nodes (pattern_math: PxrMix, PxrToFloat, ...) are folded at load: their inputs
 * are literal values, defaults or the folded outputs of other maths nodes, so the parameter
 * connected to them gets one constant, as if written literally. Any other pattern (an OSL
 * shader) is warned about once and what it feeds keeps its default value (a maths node's
 * input: its literal value or default). docs/rib.md "RIS shading" has the rules. */
#include "scene/rib/rib_internal.h"

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define RIB_MAX_PATTERNS 65536 /* Pattern nodes in one parse */
#define PATTERN_MAX_INPUTS 5   /* inputs of one maths node */
#define PATTERN_MAX_DEPTH 64   /* maths nodes in one chain, the Bxdf's parameter's first */
#define PATTERN_DRAWN "docs/rib.md lists the patterns drawn" /* for messages */

typedef enum pattern_kind {
    PATTERN_TEXTURE,
    PATTERN_MANIFOLD,
    PATTERN_MATH, /* folded at load (pattern_math) */
    PATTERN_OTHER
} pattern_kind;

struct pattern_fold;
struct rib_pattern_node;

/* One input of a maths node: its RIB name, 1 (float, int) or 3 (color) numbers, and the
 * default RenderMan documents for it. */
typedef struct pattern_input_def {
    const char *name;
    int n;
    double def[3];
} pattern_input_def;

/* A maths node: its inputs and its formula. eval computes the node's output from its input
 * values (in, in the order of `in`): out is the colour resultRGB, or with float_out the one
 * float resultF in out[0]; it returns 0 after one warning when the inputs ask for something
 * not drawn (the node is then not folded). */
typedef struct pattern_math {
    const char *type;
    int float_out;
    int nin;
    pattern_input_def in[PATTERN_MAX_INPUTS];
    int (*eval)(struct pattern_fold *f, const struct rib_pattern_node *n, double in[][3],
                double out[3]);
} pattern_math;

/* A maths node's input as written: a literal value, a reference ("handle:output"), both
 * or neither. */
typedef struct pattern_input {
    int has_value;
    double value[3];
    char *ref; /* NULL: not connected */
} pattern_input;

/* One Pattern request, what Tessera reads of it. */
typedef struct rib_pattern_node {
    char *handle, *type;
    pattern_kind kind;
    const pattern_math *math;             /* PATTERN_MATH: its formula */
    pattern_input in[PATTERN_MAX_INPUTS]; /* PATTERN_MATH: as math->in */
    int busy;                             /* being folded (a cycle when met again) */
    unsigned memo_gen;                    /* the fold whose result memo holds, 0: none */
    int memo_ok;                          /* that fold gave a value */
    double memo[3];
    char *filename;             /* PxrTexture: the file, as written; NULL: none given */
    int file_line, file_col;    /* of the file name, for messages */
    int invert_t;               /* PxrTexture: t -> 1 - t (RenderMan's default 1) */
    char *manifold;             /* PxrTexture: the handle of its PxrManifold2D, or NULL */
    double scale[2], offset[2]; /* PxrManifold2D: s' = scaleS s + offsetS, likewise t */
} rib_pattern_node;

struct rib_patterns {
    rib_pattern_node *v;
    size_t count, cap;
    unsigned gen; /* folds so far: each connection's fold memoises each node once */
};

void rib_pattern_free(rib_parser *p)
{
    if (!p->patterns) return;
    for (size_t k = 0; k < p->patterns->count; k++) {
        rib_pattern_node *n = &p->patterns->v[k];
        free(n->handle), free(n->type), free(n->filename), free(n->manifold);
        for (int k2 = 0; k2 < PATTERN_MAX_INPUTS; k2++)
            free(n->in[k2].ref);
    }
    free(p->patterns->v);
    free(p->patterns);
    p->patterns = NULL;
}

/* The latest node defined with `handle` (a later Pattern replaces an earlier one), or NULL. */
static rib_pattern_node *pattern_find(const rib_parser *p, const char *handle, size_t len)
{
    if (!p->patterns) return NULL;
    for (size_t k = p->patterns->count; k-- > 0;) {
        rib_pattern_node *n = &p->patterns->v[k];
        if (strlen(n->handle) == len && strncmp(n->handle, handle, len) == 0) return n;
    }
    return NULL;
}

/* One connection's fold: where its warnings point, and its generation for the memos. */
typedef struct pattern_fold {
    rib_parser *p;
    int line, col; /* the Bxdf or Displace parameter's value */
    unsigned gen;
} pattern_fold;

/* PxrMix (RenderMan 20): result = (1 - mix) color1 + mix color2; clampMix (added in later
 * versions), when not 0, clamps mix into [0, 1] first. */
static int math_mix(pattern_fold *f, const rib_pattern_node *n, double in[][3], double out[3])
{
    (void)f, (void)n;
    double m = in[3][0] != 0.0 ? fmin(fmax(in[2][0], 0.0), 1.0) : in[2][0];
    for (int c = 0; c < 3; c++)
        out[c] = (1.0 - m) * in[0][c] + m * in[1][c];
    return 1;
}

/* PxrToFloat (RenderMan 20, its Japanese translation): resultF is channel `mode` (0, 1, 2) of
 * input, or with mode 4 the mean of its three channels. Mode 3 (luminance) is not folded: the docs
 * do not give its weights; any other mode is not one. Either warns once and the node is not folded.
 */
static int math_to_float(pattern_fold *f, const rib_pattern_node *n, double in[][3], double out[3])
{
    double mode = in[1][0];
    if (mode == 0.0 || mode == 1.0 || mode == 2.0) {
        out[0] = in[0][(int)mode];
    } else if (mode == 4.0) {
        out[0] = (in[0][0] + in[0][1] + in[0][2]) / 3.0;
    } else {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Pattern \"%s\": mode %g is not folded (%s): what it feeds keeps its default",
                 n->type, mode,
                 mode == 3.0 ? "luminance, whose weights the docs do not give" : "no such mode");
        rib_warn_once(f->p, f->line, f->col, what);
        return 0;
    }
    out[1] = out[2] = out[0];
    return 1;
}

/* PxrToFloat3: input in all three channels; when inputR, inputG or inputB is connected, the
 * colour (inputR, inputG, inputB) instead (its page: "if inputR, inputG, inputB are connected,
 * then those will be converted to a color"). */
static int math_to_float3(pattern_fold *f, const rib_pattern_node *n, double in[][3], double out[3])
{
    (void)f;
    int split = n->in[1].ref || n->in[2].ref || n->in[3].ref;
    for (int c = 0; c < 3; c++)
        out[c] = split ? in[1 + c][0] : in[0][0];
    return 1;
}

/* PxrExposure: inputRGB 2^stops (each stop doubles it). */
static int math_exposure(pattern_fold *f, const rib_pattern_node *n, double in[][3], double out[3])
{
    (void)f, (void)n;
    double k = exp2(in[1][0]);
    for (int c = 0; c < 3; c++)
        out[c] = in[0][c] * k;
    return 1;
}

/* PxrClamp: each channel of inputRGB clamped into [min, max]; modulus other than 0 (its page
 * gives no formula) is not folded, with one warning. */
static int math_clamp(pattern_fold *f, const rib_pattern_node *n, double in[][3], double out[3])
{
    if (in[3][0] != 0.0) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Pattern \"%s\": modulus %g is not folded: what it feeds keeps its default",
                 n->type, in[3][0]);
        rib_warn_once(f->p, f->line, f->col, what);
        return 0;
    }
    for (int c = 0; c < 3; c++)
        out[c] = fmin(fmax(in[0][c], in[1][c]), in[2][c]);
    return 1;
}

/* PxrInvert in the RGB model (colorModel 0): channel c becomes 1 - c where invertChannel<c> is
 * not 0, and the result is clamped into [0, 1] (its page: "the output is a RGB color clamped to
 * the [0 0 0] to [1 1 1] range"). The HSL and HSV models (1, 2) are not folded: one warning. */
static int math_invert(pattern_fold *f, const rib_pattern_node *n, double in[][3], double out[3])
{
    if (in[1][0] != 0.0) {
        char what[RIB_WARN_KEY];
        snprintf(what, sizeof what,
                 "Pattern \"%s\": colorModel %g (HSL or HSV) is not folded: what it feeds keeps "
                 "its default",
                 n->type, in[1][0]);
        rib_warn_once(f->p, f->line, f->col, what);
        return 0;
    }
    for (int c = 0; c < 3; c++)
        out[c] = fmin(fmax(in[2 + c][0] != 0.0 ? 1.0 - in[0][c] : in[0][c], 0.0), 1.0);
    return 1;
}

/* The maths nodes, with the parameters, defaults and formulas of RenderMan 20's pages:
 * renderman.pixar.com/resources/RenderMan_20/PxrMix.html (clampMix: RenderMan 24's "Clamp
 * Mixer", whose page gives no RIB line or default; 0 keeps RenderMan 20's behaviour) and
 * PxrToFloat as renderman.jp/PxrToFloat.html translates it. A node is here only where its
 * page gives RIB names, defaults and an unambiguous formula (docs/rib.md "RIS shading"). */
static const pattern_math pattern_maths[] = {
    {"PxrMix",
     0,
     4,
     {{"color1", 3, {0, 0, 0}}, {"color2", 3, {1, 1, 1}}, {"mix", 1, {0}}, {"clampMix", 1, {0}}},
     math_mix},
    {"PxrToFloat", 1, 2, {{"input", 3, {0, 0, 0}}, {"mode", 1, {0}}}, math_to_float},
    /* RenderMan 22's pattern plugins as their args files give them (the RIB lines and
     * defaults) and their one-line descriptions (the formulas) */
    {"PxrToFloat3",
     0,
     4,
     {{"input", 1, {0}}, {"inputR", 1, {0}}, {"inputG", 1, {0}}, {"inputB", 1, {0}}},
     math_to_float3},
    {"PxrExposure", 0, 2, {{"inputRGB", 3, {0, 0, 0}}, {"stops", 1, {0}}}, math_exposure},
    {"PxrClamp",
     0,
     4,
     {{"inputRGB", 3, {0, 0, 0}},
      {"min", 3, {0, 0, 0}},
      {"max", 3, {1, 1, 1}},
      {"modulus", 1, {0}}},
     math_clamp},
    {"PxrInvert",
     0,
     5,
     {{"inputRGB", 3, {0, 0, 0}},
      {"colorModel", 1, {0}},
      {"invertChannel0", 1, {1}},
      {"invertChannel1", 1, {1}},
      {"invertChannel2", 1, {1}}},
     math_invert},
};
#define PATTERN_MATHS (sizeof pattern_maths / sizeof pattern_maths[0])

static int pattern_oom(rib_parser *p)
{
    return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
}

/* A new zeroed node at the end of the table. */
static int pattern_append(rib_parser *p, rib_pattern_node **out)
{
    if (!p->patterns && !(p->patterns = calloc(1, sizeof *p->patterns))) return pattern_oom(p);
    struct rib_patterns *t = p->patterns;
    if (t->count == RIB_MAX_PATTERNS)
        return rib_error_at(p, p->req_line, p->req_col, "Pattern: more than %d nodes",
                            RIB_MAX_PATTERNS);
    if (t->count == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 16;
        rib_pattern_node *v = realloc(t->v, cap * sizeof *v);
        if (!v) return pattern_oom(p);
        t->v = v, t->cap = cap;
    }
    *out = &t->v[t->count++];
    memset(*out, 0, sizeof **out);
    return TS_OK;
}

/* Whether the parameter's declaration says "reference" (a connection). */
static int pattern_is_reference(const rib_parser *p, const rib_param *prm)
{
    const char *key = rib_arg_str(p, prm->key, 0);
    for (const char *s = strstr(key, "reference"); s; s = strstr(s + 1, "reference"))
        if ((s == key || s[-1] == ' ') && s[9] == ' ') return 1;
    return 0;
}

/* A maths node's parameter prm (at args[i]) into n's input of that name: its reference or its
 * literal value, which must be finite; a parameter the node does not have warns once. */
static int pattern_math_param(rib_parser *p, rib_pattern_node *n, const rib_param *prm, size_t i)
{
    char shown[RIB_PRINT_MAX], what[RIB_WARN_KEY];
    int k = 0;
    while (k < n->math->nin && strcmp(prm->name, n->math->in[k].name) != 0)
        k++;
    if (k == n->math->nin) {
        snprintf(what, sizeof what, "Pattern \"%s\" parameter \"%s\" is ignored", n->type,
                 rib_printable(prm->name, shown));
        rib_warn_once(p, prm->key->line, prm->key->col, what);
        return TS_OK;
    }
    pattern_input *in = &n->in[k];
    const char *str;
    const double *v;
    if (pattern_is_reference(p, prm)) {
        int rc = rib_string_arg(p, i + 1, "a connection", &str);
        if (rc != TS_OK) return rc;
        free(in->ref);
        return (in->ref = strdup(str)) ? TS_OK : pattern_oom(p);
    }
    int n_in = n->math->in[k].n;
    int rc = rib_param_numbers(p, prm, (size_t)n_in, &v, NULL);
    if (rc != TS_OK) return rc;
    for (int c = 0; c < n_in; c++)
        if (!(fabs(v[c]) <= FLT_MAX))
            return rib_error_at(p, prm->val->line, prm->val->col,
                                "Pattern \"%s\": \"%s\" must be finite, got %g", n->type, prm->name,
                                v[c]);
    in->has_value = 1;
    for (int c = 0; c < 3; c++)
        in->value[c] = v[n_in == 3 ? c : 0];
    return TS_OK;
}

/* Reads PxrTexture's, PxrManifold2D's and the maths nodes' parameters into n; others are
 * warned about. */
static int pattern_params(rib_parser *p, rib_pattern_node *n)
{
    char shown[RIB_PRINT_MAX], what[RIB_WARN_KEY];
    for (size_t i = 2; i < p->nargs; i += 2) {
        rib_param prm;
        const double *v;
        const char *str;
        int rc = rib_param_at(p, i, &prm);
        if (rc != TS_OK) return rc;
        if (n->kind == PATTERN_MATH) {
            rc = pattern_math_param(p, n, &prm, i);
            if (rc != TS_OK) return rc;
            continue;
        }
        int tex = n->kind == PATTERN_TEXTURE, man = n->kind == PATTERN_MANIFOLD;
        if (tex && strcmp(prm.name, "filename") == 0) {
            rc = rib_string_arg(p, i + 1, "a file name", &str);
            if (rc == TS_OK) free(n->filename); /* given twice: the last one holds */
            if (rc == TS_OK && !(n->filename = strdup(str))) rc = pattern_oom(p);
            n->file_line = prm.val->line, n->file_col = prm.val->col;
        } else if (tex && strcmp(prm.name, "manifold") == 0) {
            rc = rib_string_arg(p, i + 1, "a manifold connection", &str);
            size_t len = rc == TS_OK ? strcspn(str, ":") : 0;
            if (rc == TS_OK) free(n->manifold);
            if (rc == TS_OK && !(n->manifold = malloc(len + 1))) rc = pattern_oom(p);
            if (rc == TS_OK) memcpy(n->manifold, str, len), n->manifold[len] = '\0';
        } else if ((tex && strcmp(prm.name, "invertT") == 0) ||
                   (tex && strcmp(prm.name, "linearize") == 0) ||
                   (tex && strcmp(prm.name, "atlasStyle") == 0)) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            if (prm.name[0] == 'i') n->invert_t = v[0] != 0.0;
            if (prm.name[0] == 'l' && v[0] != 0.0)
                rib_warn_once(p, prm.key->line, prm.key->col,
                              "PxrTexture: \"linearize\" is ignored (texels are used as stored, "
                              "as linear values)");
            if (prm.name[0] == 'a' && v[0] != 0.0)
                rib_warn_once(p, prm.key->line, prm.key->col,
                              "PxrTexture: \"atlasStyle\" (UDIM and other atlases) is not "
                              "supported: the file name is read as one image");
        } else if (man && (strcmp(prm.name, "scaleS") == 0 || strcmp(prm.name, "scaleT") == 0 ||
                           strcmp(prm.name, "offsetS") == 0 || strcmp(prm.name, "offsetT") == 0)) {
            rc = rib_param_numbers(p, &prm, 1, &v, NULL);
            if (rc != TS_OK) return rc;
            if (!(fabs(v[0]) <= 1e30))
                return rib_error_at(p, prm.val->line, prm.val->col,
                                    "PxrManifold2D: %s must be finite, got %g", prm.name, v[0]);
            int t = prm.name[strlen(prm.name) - 1] == 'T';
            if (prm.name[0] == 's')
                n->scale[t] = v[0];
            else
                n->offset[t] = v[0];
        } else {
            snprintf(what, sizeof what, "Pattern \"%s\" parameter \"%s\" is ignored",
                     rib_printable(n->type, shown), prm.name);
            rib_warn_once(p, prm.key->line, prm.key->col, what);
        }
        if (rc != TS_OK) return rc;
    }
    return TS_OK;
}

/* Pattern "type" "handle" params: defines a node of the shading network. PxrTexture,
 * PxrManifold2D and the maths nodes are read; other types are kept by handle so that what
 * is connected to them is warned about (once per type) and takes its default. */
int rib_req_pattern(rib_parser *p)
{
    const char *type, *handle;
    int rc = rib_string_arg(p, 0, "a pattern name", &type);
    if (rc == TS_OK) rc = rib_string_arg(p, 1, "a pattern handle", &handle);
    if (rc != TS_OK) return rc;
    if (p->nargs % 2 != 0)
        return rib_error_at(p, p->args[p->nargs - 1].line, p->args[p->nargs - 1].col,
                            "Pattern: a parameter without a value");
    rib_pattern_node *n = NULL;
    rc = pattern_append(p, &n);
    if (rc != TS_OK) return rc;
    n->kind = strcmp(type, "PxrTexture") == 0      ? PATTERN_TEXTURE
              : strcmp(type, "PxrManifold2D") == 0 ? PATTERN_MANIFOLD
                                                   : PATTERN_OTHER;
    for (size_t k = 0; k < PATTERN_MATHS; k++)
        if (strcmp(type, pattern_maths[k].type) == 0)
            n->kind = PATTERN_MATH, n->math = &pattern_maths[k];
    n->invert_t = 1;
    n->scale[0] = n->scale[1] = 1.0;
    if (!(n->handle = strdup(handle)) || !(n->type = strdup(type))) return pattern_oom(p);
    if (n->kind == PATTERN_OTHER) return TS_OK; /* warned about where it is connected */
    return pattern_params(p, n);
}

/* The texture of PxrTexture node n as kind; *index TS_INVALID when the file is missing
 * (warned, or an error when strict). A RenderMan .tex is replaced by its sibling
 * (rib_texture_sibling). */
static int pattern_texture(rib_parser *p, const rib_pattern_node *n, uint32_t kind,
                           const char *fallback, uint32_t *index)
{
    *index = TS_INVALID;
    if (!n->filename || !n->filename[0]) {
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        snprintf(what, sizeof what, "PxrTexture \"%s\" has no \"filename\": %s",
                 rib_printable(n->handle, shown), fallback);
        rib_warn_once(p, p->req_line, p->req_col, what);
        return TS_OK;
    }
    char *use = rib_texture_sibling(p, n->filename);
    if (!use)
        return rib_missing_file(p, n->file_line, n->file_col, "texture ", n->filename,
                                RIB_TEX_NO_SIBLING, fallback);
    int rc = rib_texture_named(p, use, n->file_line, n->file_col, kind, fallback, index);
    free(use);
    return rc;
}

/* The st map of PxrTexture node n: its manifold's scale and offset, then invertT. */
static void pattern_st_map(rib_parser *p, const rib_pattern_node *n, double map[4])
{
    map[0] = 1, map[1] = 0, map[2] = 1, map[3] = 0;
    if (n->manifold) {
        const rib_pattern_node *m = pattern_find(p, n->manifold, strlen(n->manifold));
        char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
        if (m && m->kind == PATTERN_MANIFOLD) {
            map[0] = m->scale[0], map[1] = m->offset[0];
            map[2] = m->scale[1], map[3] = m->offset[1];
        } else {
            snprintf(what, sizeof what,
                     "PxrTexture: manifold \"%s\" is not a PxrManifold2D: the patch's st is used",
                     rib_printable(n->manifold, shown));
            rib_warn_once(p, p->req_line, p->req_col, what);
        }
    }
    if (n->invert_t) map[2] = -map[2], map[3] = 1.0 - map[3];
}

static int fold_output(pattern_fold *f, rib_pattern_node *n, const char *output, int depth,
                       double v[3], int *scalar, int *ok);

/* Input k of maths node n into v (three channels; a float's in all three): its literal value
 * or default, or, when connected, the folded output of the maths node it names. A connection
 * to anything else (no node, a PxrTexture, a pattern not folded) warns once and keeps the
 * literal value or default. */
static int fold_input(pattern_fold *f, const rib_pattern_node *n, int k, int depth, double v[3])
{
    const pattern_input_def *d = &n->math->in[k];
    const pattern_input *in = &n->in[k];
    for (int c = 0; c < 3; c++)
        v[c] = in->has_value ? in->value[c] : d->def[d->n == 3 ? c : 0];
    if (!in->ref) return TS_OK;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX], shown2[RIB_PRINT_MAX];
    const char *keep = in->has_value ? "its value" : "its default";
    size_t len = strcspn(in->ref, ":");
    const char *output = in->ref[len] == ':' ? in->ref + len + 1 : "";
    rib_pattern_node *t = pattern_find(f->p, in->ref, len);
    if (!t) {
        snprintf(what, sizeof what,
                 "Pattern \"%s\": \"%s\" is connected to \"%s\", which no Pattern defines: it "
                 "takes %s",
                 n->type, d->name, rib_printable(in->ref, shown), keep);
    } else if (t->kind == PATTERN_TEXTURE) {
        snprintf(what, sizeof what,
                 "Pattern \"%s\": a PxrTexture through %s is not drawn: \"%s\" takes %s", n->type,
                 n->type, d->name, keep);
    } else if (t->kind != PATTERN_MATH) {
        snprintf(what, sizeof what,
                 "Pattern \"%s\" is not supported: the parameters connected to it keep their "
                 "defaults (" PATTERN_DRAWN ")",
                 rib_printable(t->type, shown));
    } else {
        double tv[3];
        int scalar, ok;
        int rc = fold_output(f, t, output, depth + 1, tv, &scalar, &ok);
        if (rc != TS_OK || !ok) return rc;
        if (d->n == 3 || scalar) {
            memcpy(v, tv, sizeof tv);
            return TS_OK;
        }
        snprintf(what, sizeof what,
                 "Pattern \"%s\": float \"%s\" is connected to colour output \"%s\": it takes %s",
                 n->type, d->name, rib_printable(in->ref, shown2), keep);
    }
    rib_warn_once(f->p, f->line, f->col, what);
    return TS_OK;
}

/* Folds maths node n into n->memo (*ok 0 when it cannot be: a cycle, a chain deeper than
 * PATTERN_MAX_DEPTH, an input its formula does not draw — each warned once); depth: the
 * nodes before it on the chain. Each node is folded once per connection (the memo), so a
 * network that shares nodes costs its node count, and recursion stops at the depth. */
static int fold_node(pattern_fold *f, rib_pattern_node *n, int depth, int *ok)
{
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    *ok = 0;
    if (n->memo_gen == f->gen) {
        *ok = n->memo_ok;
        return TS_OK;
    }
    if (n->busy || depth >= PATTERN_MAX_DEPTH) {
        if (n->busy)
            snprintf(what, sizeof what,
                     "Pattern \"%s\" is reached again through its own inputs (a cycle): that "
                     "connection takes its literal value or default",
                     rib_printable(n->handle, shown));
        else
            snprintf(what, sizeof what,
                     "Pattern: a chain of more than %d nodes (at \"%s\") is not folded: what "
                     "it feeds keeps its default",
                     PATTERN_MAX_DEPTH, rib_printable(n->handle, shown));
        rib_warn_once(f->p, f->line, f->col, what);
        return TS_OK;
    }
    double in[PATTERN_MAX_INPUTS][3];
    n->busy = 1;
    for (int k = 0; k < n->math->nin; k++) {
        int rc = fold_input(f, n, k, depth, in[k]);
        if (rc != TS_OK) {
            n->busy = 0;
            return rc;
        }
    }
    n->busy = 0;
    *ok = n->math->eval(f, n, in, n->memo);
    n->memo_gen = f->gen, n->memo_ok = *ok;
    return TS_OK;
}

/* Output `output` ("" is the node's first) of maths node n, folded, into v: resultRGB, or a
 * float (resultR, resultG, resultB of a colour; resultF) in all three channels with *scalar 1.
 * *ok 0: not folded, or an output the node lacks (warned). */
static int fold_output(pattern_fold *f, rib_pattern_node *n, const char *output, int depth,
                       double v[3], int *scalar, int *ok)
{
    int rc = fold_node(f, n, depth, ok);
    if (rc != TS_OK || !*ok) return rc;
    const char *rgb[] = {"resultR", "resultG", "resultB"};
    int c = -1;
    if (n->math->float_out) {
        if (!output[0] || strcmp(output, "resultF") == 0) c = 0;
    } else if (!output[0] || strcmp(output, "resultRGB") == 0) {
        memcpy(v, n->memo, 3 * sizeof *v);
        *scalar = 0;
        return TS_OK;
    } else {
        for (int k = 0; k < 3; k++)
            if (strcmp(output, rgb[k]) == 0) c = k;
    }
    if (c >= 0) {
        v[0] = v[1] = v[2] = n->memo[c];
        *scalar = 1;
        return TS_OK;
    }
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
    snprintf(what, sizeof what,
             "Pattern \"%s\" has no output \"%s\" (%s): what it feeds keeps "
             "its default",
             n->type, rib_printable(output, shown),
             n->math->float_out ? "resultF" : "resultRGB, resultR, resultG, resultB");
    rib_warn_once(f->p, f->line, f->col, what);
    *ok = 0;
    return TS_OK;
}

int rib_pattern_link(rib_parser *p, const rib_param *prm, uint32_t kind, const char *fallback,
                     rib_link *out)
{
    memset(out, 0, sizeof *out);
    if (!pattern_is_reference(p, prm)) return TS_OK;
    out->linked = 1;
    const char *to;
    int rc = rib_string_arg(p, (size_t)(prm->val - p->args), "a connection", &to);
    if (rc != TS_OK) return rc;
    char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX], shown2[RIB_PRINT_MAX];
    size_t len = strcspn(to, ":");
    rib_pattern_node *n = pattern_find(p, to, len);
    if (!n) {
        snprintf(what, sizeof what,
                 "%s: \"%s\" is connected to \"%s\", which no Pattern defines: it keeps its "
                 "default",
                 p->req, rib_printable(prm->name, shown), rib_printable(to, shown2));
        rib_warn_once(p, prm->val->line, prm->val->col, what);
        return TS_OK;
    }
    const char *output = to[len] == ':' ? to + len + 1 : "";
    if (n->kind == PATTERN_MATH) { /* folded to one value, the caller's as a literal's */
        pattern_fold f = {p, prm->val->line, prm->val->col, ++p->patterns->gen};
        if (f.gen == 0) f.gen = ++p->patterns->gen; /* 0 marks "no memo" */
        int scalar = 0, ok;
        rc = fold_output(&f, n, output, 0, out->value, &scalar, &ok);
        if (rc != TS_OK || !ok) return rc;
        for (int c = 0; c < 3; c++)
            if (!(fabs(out->value[c]) <= FLT_MAX))
                return rib_error_at(p, prm->val->line, prm->val->col,
                                    "%s: \"%s\" is connected to \"%s\", whose value must be "
                                    "finite, got %g",
                                    p->req, rib_printable(prm->name, shown),
                                    rib_printable(to, shown2), out->value[c]);
        out->folded = 1, out->scalar = scalar;
        return TS_OK;
    }
    if (n->kind != PATTERN_TEXTURE) {
        snprintf(what, sizeof what,
                 "Pattern \"%s\" is not supported: the parameters connected to it keep their "
                 "defaults (" PATTERN_DRAWN ")",
                 rib_printable(n->type, shown));
        rib_warn_once(p, prm->val->line, prm->val->col, what);
        return TS_OK;
    }
    int mask = kind == RIB_LINK_MASK; /* resultA (the alpha) or resultR, of an RGB texture */
    int wanted = mask ? strcmp(output, "resultA") == 0 || strcmp(output, "resultR") == 0
                 : kind == TS_TEX_RGB ? strcmp(output, "resultRGB") == 0
                                      : strcmp(output, "resultR") == 0 || !output[0];
    if (!wanted) {
        snprintf(what, sizeof what, "%s: \"%s\" reads PxrTexture output \"%s\" as %s", p->req,
                 rib_printable(prm->name, shown), rib_printable(output, shown2),
                 mask                 ? "resultA (its alpha)"
                 : kind == TS_TEX_RGB ? "resultRGB"
                                      : "resultR (the first channel)");
        rib_warn_once(p, prm->val->line, prm->val->col, what);
    }
    out->mask_red = mask && strcmp(output, "resultR") == 0;
    rc = pattern_texture(p, n, mask ? TS_TEX_RGB : kind, fallback, &out->tex);
    if (rc != TS_OK || out->tex == TS_INVALID) return rc;
    out->textured = 1;
    pattern_st_map(p, n, out->st_map);
    return TS_OK;
}
