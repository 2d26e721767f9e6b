/* layout.cl — not a stage: writes sizeof and offsetof of every entry of TS_LAYOUT_FIELDS
 * (lib/shared_types.h) so tests/test_layout.c can compare the device's struct layout with
 * the host's (STYLE.md 2). out[2k] = sizeof(struct), out[2k+1] = offsetof(struct, field). */
#include "lib/shared_types.h"

__kernel void layout_probe(__global uint *out)
{
    if (get_global_id(0) != 0) return;
    uint k = 0;
    /* OpenCL C 1.2 has no offsetof: measure on a private instance. */
#define TS_LAYOUT_PROBE(type, field)                                                               \
    {                                                                                              \
        type probe;                                                                                \
        out[k++] = (uint)sizeof(type);                                                             \
        out[k++] = (uint)((char *)&probe.field - (char *)&probe);                                  \
    }
    TS_LAYOUT_FIELDS(TS_LAYOUT_PROBE)
#undef TS_LAYOUT_PROBE
}
