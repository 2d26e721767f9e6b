/* rib_cond.c — conditional RIB (RenderMan 21+): IfBegin "expr" ... ElseIf "expr" ... Else
 * ... IfEnd. The requests of the branches not taken are read and not run (rib.c asks
 * rib_cond_skip before dispatching). Expressions: numbers, 'strings' (or "strings"), bare
 * words (strings), $name and $user:name ("user" options and attributes, rib_ris.c), ( ),
 * ! && ||, == != < > <= >= (numbers compared as numbers, anything else as strings) and
 * =~ (POSIX extended regular expression match), defined(name). An undefined variable is the
 * empty string, with one warning. docs/rib.md "Conditional RIB" has the rules. */
#include "scene/rib/rib_internal.h"

#include <ctype.h>
#include <math.h>
#include <regex.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RIB_COND_STR 256 /* bytes of a string value (longer ones are cut) */
#define RIB_COND_NEST 64 /* parentheses and ! nested in one expression */
/* The product of the bounded repetitions {m,n} of one =~ pattern (cond_regex_check). */
#define RIB_COND_REPEAT_MAX 1000

typedef struct rib_cond_level {
    int line, col;     /* of its IfBegin */
    int parent_active; /* the enclosing branch runs */
    int active;        /* the current branch runs */
    int taken;         /* a branch has been taken */
    int else_seen;
} rib_cond_level;

struct rib_cond {
    rib_cond_level level[RIB_MAX_DEPTH];
    size_t depth;
};

void rib_cond_free(rib_parser *p)
{
    free(p->cond);
    p->cond = NULL;
}

static int rib_is_cond_request(const char *req)
{
    return strcmp(req, "IfBegin") == 0 || strcmp(req, "ElseIf") == 0 || strcmp(req, "Else") == 0 ||
           strcmp(req, "IfEnd") == 0;
}

int rib_cond_skip(const rib_parser *p)
{
    const struct rib_cond *c = p->cond;
    return c && c->depth && !c->level[c->depth - 1].active && !rib_is_cond_request(p->req);
}

int rib_cond_check_closed(rib_parser *p)
{
    const struct rib_cond *c = p->cond;
    if (!c || !c->depth) return TS_OK;
    const rib_cond_level *l = &c->level[c->depth - 1];
    return rib_error_at(p, l->line, l->col, "IfBegin without IfEnd before the end of the file");
}

/* ---- expressions ------------------------------------------------------------------------ */

typedef struct cond_val {
    int is_str;
    double num;
    char s[RIB_COND_STR];
} cond_val;

typedef struct cond_ctx {
    rib_parser *p;
    const char *s; /* the expression */
    size_t i;
    int line, col, nest;
    char why[160]; /* the first error */
} cond_ctx;

static int cond_fail(cond_ctx *c, const char *fmt, const char *arg)
{
    if (!c->why[0]) snprintf(c->why, sizeof c->why, fmt, arg);
    return 0;
}

static void cond_space(cond_ctx *c)
{
    while (c->s[c->i] && isspace((unsigned char)c->s[c->i]))
        c->i++;
}

static int cond_eat(cond_ctx *c, const char *tok)
{
    cond_space(c);
    size_t n = strlen(tok);
    if (strncmp(c->s + c->i, tok, n) != 0) return 0;
    c->i += n;
    return 1;
}

static int cond_truth(const cond_val *v)
{
    return v->is_str ? v->s[0] != '\0' : v->num != 0.0;
}

static void cond_set_num(cond_val *v, double x)
{
    v->is_str = 0;
    v->num = x;
    v->s[0] = '\0';
}

static void cond_set_str(cond_val *v, const char *s, size_t n)
{
    if (n >= RIB_COND_STR) n = RIB_COND_STR - 1;
    v->is_str = 1;
    v->num = 0.0;
    memcpy(v->s, s, n);
    v->s[n] = '\0';
}

static int cond_is_word(int ch)
{
    return isalnum(ch) || ch == '_' || ch == ':' || ch == '.';
}

/* A variable name after '$' (or inside defined( )), "user:" dropped; its value. */
static int cond_var(cond_ctx *c, cond_val *v, int *defined, char name[RIB_COND_STR])
{
    int brace = c->s[c->i] == '{';
    if (brace) c->i++;
    size_t start = c->i;
    while (cond_is_word((unsigned char)c->s[c->i]))
        c->i++;
    size_t n = c->i - start;
    if (brace && c->s[c->i++] != '}') return cond_fail(c, "%s", "'${' without '}'");
    if (n == 0) return cond_fail(c, "%s", "a variable name after '$'");
    if (n >= RIB_COND_STR) n = RIB_COND_STR - 1;
    memcpy(name, c->s + start, n);
    name[n] = '\0';
    const char *key = strncmp(name, "user:", 5) == 0 ? name + 5 : name;
    const char *str;
    double num;
    *defined = rib_user_get(c->p, key, &str, &num);
    if (!*defined)
        cond_set_str(v, "", 0);
    else if (str)
        cond_set_str(v, str, strlen(str));
    else
        cond_set_num(v, num);
    return 1;
}

static int cond_or(cond_ctx *c, cond_val *v);

static int cond_primary(cond_ctx *c, cond_val *v)
{
    cond_space(c);
    const char *s = c->s;
    char ch = s[c->i];
    if (ch == '(') {
        c->i++;
        if (++c->nest > RIB_COND_NEST) return cond_fail(c, "%s", "parentheses nested too deep");
        if (!cond_or(c, v)) return 0;
        c->nest--;
        return cond_eat(c, ")") ? 1 : cond_fail(c, "%s", "'(' without ')'");
    }
    if (ch == '\'' || ch == '"') {
        size_t start = ++c->i;
        while (s[c->i] && s[c->i] != ch)
            c->i++;
        if (!s[c->i]) return cond_fail(c, "%s", "an unterminated string");
        cond_set_str(v, s + start, c->i - start);
        c->i++;
        return 1;
    }
    if (ch == '$') {
        c->i++;
        int defined;
        char name[RIB_COND_STR];
        if (!cond_var(c, v, &defined, name)) return 0;
        if (!defined) {
            char what[RIB_WARN_KEY], shown[RIB_PRINT_MAX];
            snprintf(what, sizeof what,
                     "%s: $%s is not defined (Option or Attribute \"user\"): the empty string",
                     c->p->req, rib_printable(name, shown));
            rib_warn_once(c->p, c->line, c->col, what);
        }
        return 1;
    }
    if (isdigit((unsigned char)ch) || ch == '.' || ch == '-' || ch == '+') {
        char *end;
        double x = strtod(s + c->i, &end);
        if (end == s + c->i) return cond_fail(c, "%s", "a malformed number");
        c->i = (size_t)(end - s);
        cond_set_num(v, x);
        return 1;
    }
    if (strncmp(s + c->i, "defined", 7) == 0 && !cond_is_word((unsigned char)s[c->i + 7])) {
        c->i += 7;
        if (!cond_eat(c, "(")) return cond_fail(c, "%s", "'(' after defined");
        cond_space(c);
        if (s[c->i] == '$') c->i++;
        int defined;
        cond_val tmp;
        char name[RIB_COND_STR];
        if (!cond_var(c, &tmp, &defined, name)) return 0;
        if (!cond_eat(c, ")")) return cond_fail(c, "%s", "')' after defined(name");
        cond_set_num(v, defined);
        return 1;
    }
    if (cond_is_word((unsigned char)ch)) { /* a bare word: a string */
        size_t start = c->i;
        while (cond_is_word((unsigned char)s[c->i]))
            c->i++;
        cond_set_str(v, s + start, c->i - start);
        return 1;
    }
    return ch ? cond_fail(c, "unexpected '%s'", (char[2]){ch, '\0'})
              : cond_fail(c, "%s", "an operand missing at the end");
}

/* As a string, for comparing a number with a string. */
static void cond_as_str(const cond_val *v, char *out, size_t n)
{
    if (v->is_str)
        snprintf(out, n, "%s", v->s);
    else
        snprintf(out, n, "%.17g", v->num);
}

/* Skips the bracket expression opening at *s ('['): returns where it closes (its ']'), or
 * the end of the string. Inside it '\\', '{' and '(' are plain characters. */
static const char *cond_skip_bracket(const char *s)
{
    s++;
    if (*s == '^') s++;
    if (*s == ']') s++; /* a leading ']' is a member */
    for (; *s && *s != ']'; s++)
        if (*s == '[' && (s[1] == ':' || s[1] == '.' || s[1] == '=')) { /* [:alpha:] ... */
            char close = s[1];
            for (s += 2; *s && !(*s == close && s[1] == ']'); s++)
                ;
            if (*s) s++;
        }
    return s;
}

/* What makes glibc's regex engine slow, or NULL: it backtracks on back-references ("(a*)*\\1b"
 * against 255 a's ran 40 s) and copies a bounded repetition's operand once per count, so that
 * nested counts multiply ("((a{1,255}){1,255}){1,255}" did not compile in minutes). Refused:
 * back-references, and counts whose product over the pattern passes RIB_COND_REPEAT_MAX (the
 * product over all of them, nested or not: a bound, not an exact cost). */
static const char *cond_regex_check(const char *pat)
{
    double product = 1.0;
    for (const char *s = pat; *s; s++) {
        if (*s == '\\') {
            if (s[1] >= '1' && s[1] <= '9') return "a back-reference (\\1 to \\9)";
            if (s[1]) s++;
        } else if (*s == '[') {
            s = cond_skip_bracket(s);
            if (!*s) break;
        } else if (*s == '{' && isdigit((unsigned char)s[1])) {
            char *end;
            double m = strtod(s + 1, &end), n = m;
            if (*end == ',' && isdigit((unsigned char)end[1])) n = strtod(end + 1, &end);
            product *= fmax(fmax(m, n), 1.0);
            if (product > RIB_COND_REPEAT_MAX)
                return "repetition counts {m,n} that multiply past 1000";
        }
    }
    return NULL;
}

static int cond_compare(cond_ctx *c, cond_val *v)
{
    if (!cond_primary(c, v)) return 0;
    static const char *const ops[] = {"==", "!=", "<=", ">=", "=~", "<", ">"};
    int op = -1;
    cond_space(c);
    for (int k = 0; k < 7 && op < 0; k++)
        if (strncmp(c->s + c->i, ops[k], strlen(ops[k])) == 0) op = k;
    if (op < 0) return 1;
    c->i += strlen(ops[op]);
    cond_val r;
    if (!cond_primary(c, &r)) return 0;
    int result;
    if (op == 4) { /* =~ */
        char text[RIB_COND_STR], pat[RIB_COND_STR];
        cond_as_str(v, text, sizeof text);
        cond_as_str(&r, pat, sizeof pat);
        regex_t re;
        const char *slow = cond_regex_check(pat);
        if (slow) {
            char msg[160];
            snprintf(msg, sizeof msg, "a regular expression '%.60s' with %s: not supported", pat,
                     slow);
            return cond_fail(c, "%s", msg);
        }
        if (regcomp(&re, pat, REG_EXTENDED | REG_NOSUB) != 0)
            return cond_fail(c, "a bad regular expression '%.60s'", pat);
        result = regexec(&re, text, 0, NULL, 0) == 0;
        regfree(&re);
    } else {
        int cmp;
        if (!v->is_str && !r.is_str) {
            cmp = (v->num > r.num) - (v->num < r.num);
        } else {
            char a[RIB_COND_STR], b[RIB_COND_STR];
            cond_as_str(v, a, sizeof a);
            cond_as_str(&r, b, sizeof b);
            cmp = strcmp(a, b);
        }
        result = op == 0   ? cmp == 0
                 : op == 1 ? cmp != 0
                 : op == 2 ? cmp <= 0
                 : op == 3 ? cmp >= 0
                 : op == 5 ? cmp < 0
                           : cmp > 0;
    }
    cond_set_num(v, result);
    return 1;
}

static int cond_not(cond_ctx *c, cond_val *v)
{
    cond_space(c);
    if (c->s[c->i] == '!' && c->s[c->i + 1] != '=') {
        c->i++;
        if (++c->nest > RIB_COND_NEST) return cond_fail(c, "%s", "'!' nested too deep");
        if (!cond_not(c, v)) return 0;
        c->nest--;
        cond_set_num(v, !cond_truth(v));
        return 1;
    }
    return cond_compare(c, v);
}

static int cond_and(cond_ctx *c, cond_val *v)
{
    if (!cond_not(c, v)) return 0;
    while (cond_eat(c, "&&")) {
        cond_val r;
        if (!cond_not(c, &r)) return 0;
        cond_set_num(v, cond_truth(v) && cond_truth(&r));
    }
    return 1;
}

static int cond_or(cond_ctx *c, cond_val *v)
{
    if (!cond_and(c, v)) return 0;
    while (cond_eat(c, "||")) {
        cond_val r;
        if (!cond_and(c, &r)) return 0;
        cond_set_num(v, cond_truth(v) || cond_truth(&r));
    }
    return 1;
}

/* The value of the request's expression (its one string argument), true or false. */
static int rib_cond_eval(rib_parser *p, int *out)
{
    const char *expr;
    int rc = rib_string_arg(p, 0, "a condition", &expr);
    if (rc == TS_OK) rc = rib_no_more(p, 1);
    if (rc != TS_OK) return rc;
    cond_ctx c = {p, expr, 0, p->args[0].line, p->args[0].col, 0, ""};
    cond_val v;
    int ok = cond_or(&c, &v);
    cond_space(&c);
    if (ok && c.s[c.i]) ok = cond_fail(&c, "unexpected '%.40s' after the expression", c.s + c.i);
    char shown[RIB_PRINT_MAX];
    if (!ok)
        return rib_error_at(p, c.line, c.col, "%s: condition \"%s\": %s", p->req,
                            rib_printable(expr, shown), c.why);
    *out = cond_truth(&v);
    return TS_OK;
}

/* ---- requests ------------------------------------------------------------------------- */

static rib_cond_level *rib_cond_top(rib_parser *p)
{
    if (!p->cond || !p->cond->depth) {
        rib_error_at(p, p->req_line, p->req_col, "%s without IfBegin", p->req);
        return NULL;
    }
    return &p->cond->level[p->cond->depth - 1];
}

int rib_req_if_begin(rib_parser *p)
{
    if (!p->cond && !(p->cond = calloc(1, sizeof *p->cond)))
        return ts_error_set(p->err, TS_E_MEMORY, "%s: out of memory", p->lx.file);
    struct rib_cond *c = p->cond;
    if (c->depth == RIB_MAX_DEPTH)
        return rib_error_at(p, p->req_line, p->req_col, "IfBegin nested deeper than %d levels",
                            RIB_MAX_DEPTH);
    int parent = c->depth == 0 || c->level[c->depth - 1].active, truth = 0;
    if (parent) { /* a condition in a branch not taken is not evaluated */
        int rc = rib_cond_eval(p, &truth);
        if (rc != TS_OK) return rc;
    }
    c->level[c->depth++] =
        (rib_cond_level){p->req_line, p->req_col, parent, parent && truth, truth, 0};
    return TS_OK;
}

int rib_req_else_if(rib_parser *p)
{
    rib_cond_level *l = rib_cond_top(p);
    if (!l) return TS_E_SCENE;
    if (l->else_seen)
        return rib_error_at(p, p->req_line, p->req_col, "ElseIf after Else (IfBegin at %d:%d)",
                            l->line, l->col);
    int truth = 0;
    if (l->parent_active && !l->taken) {
        int rc = rib_cond_eval(p, &truth);
        if (rc != TS_OK) return rc;
    }
    l->active = l->parent_active && !l->taken && truth;
    l->taken = l->taken || truth;
    return TS_OK;
}

int rib_req_else(rib_parser *p)
{
    rib_cond_level *l = rib_cond_top(p);
    if (!l) return TS_E_SCENE;
    int rc = rib_no_more(p, 0);
    if (rc != TS_OK) return rc;
    if (l->else_seen)
        return rib_error_at(p, p->req_line, p->req_col, "a second Else (IfBegin at %d:%d)", l->line,
                            l->col);
    l->else_seen = 1;
    l->active = l->parent_active && !l->taken;
    l->taken = 1;
    return TS_OK;
}

int rib_req_if_end(rib_parser *p)
{
    if (!rib_cond_top(p)) return TS_E_SCENE;
    int rc = rib_no_more(p, 0);
    if (rc == TS_OK) p->cond->depth--;
    return rc;
}
