/* rib_look.h — a RenderMan Look File (.rlf) as RenderMan for Maya 20-22 writes it beside
 * each frame's RIB: an XML document whose <InjectablePayloads> hold RIB fragments by Id and
 * whose <TightBindings> (static bindings) map an object's identifier path
 * ("pCube1/pCubeShape1") to one of them. rib_look.c reads it (with expat); rib_rlf.c applies
 * it at the RIB's "##RLF Inject" nuggets. Private to the RIB reader. */
#ifndef TS_RIB_LOOK_H
#define TS_RIB_LOOK_H

#include <stddef.h>

/* Bounds on what a look file may hold. */
#define RIB_LOOK_MAX_BYTES ((size_t)1 << 26) /* the file (64 MiB) */
#define RIB_LOOK_MAX_ITEMS (1u << 20)        /* payloads, bindings (each) */

/* One <Payload Id="..."> and its text (a RIB fragment, usually a CDATA section). (line, col):
 * where the text starts in the .rlf (1-based), so that messages about its requests name the
 * look file's own lines. */
typedef struct rib_look_payload {
    char *id;
    char *text;
    size_t len;
    int line, col;
    int id_line, id_col; /* of the <Payload> element */
} rib_look_payload;

/* One <Binding Key="path" PayloadId="..."/> of <TightBindings>, resolved to its payload. */
typedef struct rib_look_binding {
    char *key;
    size_t payload; /* index into payloads */
    size_t order;   /* position in the file: of equal keys the later one holds */
} rib_look_binding;

typedef struct rib_look {
    rib_look_payload *payloads;
    size_t npayloads;
    rib_look_binding *bindings; /* sorted by key, then order */
    size_t nbindings;
    size_t nrules;  /* <Rule>s of <RuleSet> (dynamic binding by XPath): counted, not applied */
    char other[64]; /* the first element under the root Tessera does not read, or "" */
} rib_look;

/* Reads the look file at path into *look (zeroed first). TS_OK; TS_E_IO when it cannot be
 * read (*absent 1 when there is no file at path) with why = strerror's text; TS_E_SCENE when
 * it is not a well-formed look file, with why = "PATH:LINE:COL: what" (bad XML: expat's
 * message at expat's position; a payload Id defined twice, a binding to an undefined
 * payload, a root element other than RenderManLookFile, an element inside a payload);
 * TS_E_MEMORY. *look is empty on failure. */
int rib_look_read(const char *path, rib_look *look, int *absent, char *why, size_t cap);
/* The payload bound to the identifier path `key` by a static binding, or NULL. */
const rib_look_payload *rib_look_bound(const rib_look *look, const char *key);
void rib_look_free(rib_look *look);

#endif
