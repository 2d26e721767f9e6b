/* scene_pack.c — a scene as one block of bytes and back (scene_pack.h). The block is a
 * 16-byte header (magic "TSSCENE1", the version, the count of sections), then sections
 * in a fixed order, each a 64-bit byte length and the bytes. */
#include "scene/scene_pack.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PACK_MAGIC "TSSCENE1"
/* 3: the dome's map in memory; 4: ts_patch_attr of 160 bytes (the principled fields); 5: the
 * trim segments */
#define PACK_VERSION 5u

/* The sections: (pointer, bytes) in a fixed order; NULL with 0 bytes for what the scene
 * lacks. Strings (texture sources) are one section of NUL-separated names. */
enum {
    SEC_COUNTS,   /* uint32: patch, xform, texture, tile and light counts, 1 when cp1 */
    SEC_CP,       /* patch_count * 16 ts_vec4 */
    SEC_CP1,      /* the same, or nothing */
    SEC_CORNER_N, /* patch_count * 4 ts_vec4, or nothing */
    SEC_MID_N,    /* patch_count * 5 ts_vec4, or nothing */
    SEC_ATTR,     /* patch_count ts_patch_attr */
    SEC_XFORM,    /* xform_count ts_xform */
    SEC_TEXTURES, /* texture_count ts_texture */
    SEC_SOURCES,  /* texture_count NUL-terminated file names */
    SEC_TEX_POOL, /* tex_tile_count tiles of TS_TEX_TILE^2 ts_vec4 */
    SEC_TEX_PAGES,
    SEC_CAMERA,     /* ts_camera */
    SEC_LIGHTS,     /* light_count ts_scene_light */
    SEC_DOME,       /* ts_dome_light */
    SEC_SHAPE,      /* patch_count uint32 (scene.h instancing), or nothing */
    SEC_INSTANCE,   /* patch_count uint32, or nothing */
    SEC_INST_XFORM, /* inst_xform_count ts_xform */
    SEC_DOME_MAP,   /* the dome's map made in memory: map_width x map_height RGB floats */
    SEC_TRIM_SEG,   /* trim_seg_count ts_vec4 (trimmed NURBS), or nothing */
    SEC_COUNT
};

typedef struct pack_section {
    const void *data;
    uint64_t bytes;
} pack_section;

/* The sections of s; *names is the malloc'd SEC_SOURCES block (the caller frees it). */
static int pack_sections(const ts_scene *s, uint32_t counts[6], char **names,
                         pack_section sec[SEC_COUNT], ts_error *err)
{
    uint64_t n = s->patch_count, name_bytes = 0;
    for (uint32_t i = 0; i < s->texture_count; ++i)
        name_bytes += strlen(s->tex_source[i]) + 1;
    *names = malloc(name_bytes ? name_bytes : 1);
    if (!*names) return ts_error_set(err, TS_E_MEMORY, "out of memory (packing the scene)");
    for (uint32_t i = 0, at = 0; i < s->texture_count; ++i) {
        size_t len = strlen(s->tex_source[i]) + 1;
        memcpy(*names + at, s->tex_source[i], len);
        at += (uint32_t)len;
    }
    counts[0] = s->patch_count, counts[1] = s->xform_count, counts[2] = s->texture_count;
    counts[3] = s->tex_tile_count, counts[4] = s->light_count, counts[5] = s->cp1 != NULL;
    uint64_t tile = (uint64_t)TS_TEX_TILE * TS_TEX_TILE * sizeof(ts_vec4);
    sec[SEC_COUNTS] = (pack_section){counts, 6 * sizeof(uint32_t)};
    sec[SEC_CP] = (pack_section){s->cp, n * 16 * sizeof(ts_vec4)};
    sec[SEC_CP1] = (pack_section){s->cp1, s->cp1 ? n * 16 * sizeof(ts_vec4) : 0};
    sec[SEC_CORNER_N] = (pack_section){s->corner_n, s->corner_n ? n * 4 * sizeof(ts_vec4) : 0};
    sec[SEC_MID_N] = (pack_section){s->mid_n, s->mid_n ? n * 5 * sizeof(ts_vec4) : 0};
    sec[SEC_ATTR] = (pack_section){s->attr, n * sizeof(ts_patch_attr)};
    sec[SEC_XFORM] = (pack_section){s->xform, (uint64_t)s->xform_count * sizeof(ts_xform)};
    sec[SEC_TEXTURES] =
        (pack_section){s->textures, (uint64_t)s->texture_count * sizeof(ts_texture)};
    sec[SEC_SOURCES] = (pack_section){*names, name_bytes};
    sec[SEC_TEX_POOL] = (pack_section){s->tex_pool, s->tex_tile_count * tile};
    sec[SEC_TEX_PAGES] =
        (pack_section){s->tex_pages, (uint64_t)s->tex_tile_count * sizeof(uint32_t)};
    sec[SEC_CAMERA] = (pack_section){&s->camera, sizeof s->camera};
    sec[SEC_LIGHTS] = (pack_section){s->lights, (uint64_t)s->light_count * sizeof(ts_scene_light)};
    sec[SEC_DOME] = (pack_section){&s->dome, sizeof s->dome};
    uint64_t shared = s->shape ? n * sizeof(uint32_t) : 0;
    sec[SEC_SHAPE] = (pack_section){s->shape, shared};
    sec[SEC_INSTANCE] = (pack_section){s->instance, shared};
    sec[SEC_INST_XFORM] =
        (pack_section){s->inst_xform, (uint64_t)s->inst_xform_count * sizeof(ts_xform)};
    sec[SEC_DOME_MAP] = (pack_section){
        s->dome.map, s->dome.map ? (uint64_t)s->dome.map_width * s->dome.map_height * 3 * 4 : 0};
    sec[SEC_TRIM_SEG] = (pack_section){s->trim_seg, (uint64_t)s->trim_seg_count * sizeof(ts_vec4)};
    return TS_OK;
}

int scene_pack(const ts_scene *s, void **out, size_t *size, ts_error *err)
{
    *out = NULL, *size = 0;
    uint32_t counts[6];
    char *names = NULL;
    pack_section sec[SEC_COUNT];
    if (pack_sections(s, counts, &names, sec, err)) return err->code;
    uint64_t total = 16;
    for (int i = 0; i < SEC_COUNT; ++i)
        total += 8 + sec[i].bytes;
    unsigned char *p = malloc(total);
    if (!p) {
        free(names);
        return ts_error_set(err, TS_E_MEMORY, "out of memory (packing the scene: %llu MB)",
                            (unsigned long long)(total >> 20));
    }
    uint32_t head[2] = {PACK_VERSION, SEC_COUNT};
    memcpy(p, PACK_MAGIC, 8);
    memcpy(p + 8, head, 8);
    uint64_t at = 16;
    for (int i = 0; i < SEC_COUNT; ++i) {
        memcpy(p + at, &sec[i].bytes, 8);
        if (sec[i].bytes) memcpy(p + at + 8, sec[i].data, sec[i].bytes);
        at += 8 + sec[i].bytes;
    }
    free(names);
    *out = p, *size = (size_t)total;
    return TS_OK;
}

/* Reads the block's sections into sec[]: pointers into the block. */
static int unpack_sections(const unsigned char *p, size_t size, pack_section sec[SEC_COUNT])
{
    uint32_t head[2];
    if (size < 16 || memcmp(p, PACK_MAGIC, 8) != 0) return -1;
    memcpy(head, p + 8, 8);
    if (head[0] != PACK_VERSION || head[1] != SEC_COUNT) return -1;
    uint64_t at = 16;
    for (int i = 0; i < SEC_COUNT; ++i) {
        if (size - at < 8) return -1;
        memcpy(&sec[i].bytes, p + at, 8);
        if (sec[i].bytes > size - at - 8) return -1;
        sec[i].data = p + at + 8;
        at += 8 + sec[i].bytes;
    }
    return at == size ? 0 : -1;
}

/* A malloc'd copy of a section that must hold exactly `bytes` (0: absent, NULL). */
static int copy_section(const pack_section *sec, uint64_t bytes, void **out)
{
    *out = NULL;
    if (sec->bytes != bytes) return -1;
    if (!bytes) return 0;
    if (!(*out = malloc(bytes))) return -2;
    memcpy(*out, sec->data, bytes);
    return 0;
}

/* The instancing tables (scene.h): absent, or a shape and an instance per patch that name
 * patches and transforms that exist. */
static int unpack_instances(const pack_section sec[SEC_COUNT], ts_scene *s)
{
    uint64_t shared = sec[SEC_SHAPE].bytes ? (uint64_t)s->patch_count * sizeof(uint32_t) : 0;
    if (sec[SEC_INST_XFORM].bytes % sizeof(ts_xform)) return -1;
    uint64_t xforms = sec[SEC_INST_XFORM].bytes / sizeof(ts_xform);
    int rc = copy_section(&sec[SEC_SHAPE], shared, (void **)&s->shape);
    if (!rc) rc = copy_section(&sec[SEC_INSTANCE], shared, (void **)&s->instance);
    if (!rc)
        rc = copy_section(&sec[SEC_INST_XFORM], sec[SEC_INST_XFORM].bytes, (void **)&s->inst_xform);
    if (rc) return rc;
    s->inst_xform_count = (uint32_t)xforms;
    for (uint32_t p = 0; s->shape && p < s->patch_count; ++p)
        if (s->shape[p] >= s->patch_count ||
            (s->shape[p] != p && (uint64_t)s->instance[p] >= xforms))
            return -1;
    return 0;
}

/* The trim segments, and every patch's range inside them. */
static int unpack_trims(const pack_section *sec, ts_scene *s)
{
    if (sec->bytes % sizeof(ts_vec4) || sec->bytes / sizeof(ts_vec4) > UINT32_MAX) return -1;
    uint32_t n = (uint32_t)(sec->bytes / sizeof(ts_vec4));
    int rc = copy_section(sec, sec->bytes, (void **)&s->trim_seg);
    if (rc) return rc;
    s->trim_seg_count = s->trim_seg_capacity = n;
    for (uint32_t p = 0; p < s->patch_count; ++p) {
        const ts_patch_attr *a = &s->attr[p];
        if (a->trim_count && (a->trim_first > n || a->trim_count > n - a->trim_first)) return -1;
    }
    return 0;
}

/* The texture sources: count NUL-terminated names filling the section. */
static int unpack_sources(const pack_section *sec, uint32_t count, ts_scene *s)
{
    if (!count) return sec->bytes ? -1 : 0;
    if (!(s->tex_source = calloc(count, sizeof *s->tex_source))) return -2;
    const char *at = sec->data, *end = at + sec->bytes;
    for (uint32_t i = 0; i < count; ++i) {
        const char *nul = memchr(at, '\0', (size_t)(end - at));
        if (!nul || !(s->tex_source[i] = strdup(at))) return nul ? -2 : -1;
        at = nul + 1;
    }
    return at == end ? 0 : -1;
}

int scene_unpack(const void *block, size_t size, ts_scene *s, ts_error *err)
{
    memset(s, 0, sizeof *s);
    pack_section sec[SEC_COUNT];
    uint32_t c[6];
    if (unpack_sections(block, size, sec) || sec[SEC_COUNTS].bytes != sizeof c ||
        sec[SEC_CAMERA].bytes != sizeof s->camera || sec[SEC_DOME].bytes != sizeof s->dome)
        return ts_error_set(err, TS_E_USAGE, "the scene block is damaged or of another version");
    memcpy(c, sec[SEC_COUNTS].data, sizeof c);
    uint64_t n = c[0], tile = (uint64_t)TS_TEX_TILE * TS_TEX_TILE * sizeof(ts_vec4);
    s->patch_count = s->patch_capacity = c[0];
    s->xform_count = s->xform_capacity = c[1];
    s->texture_count = c[2], s->tex_tile_count = c[3], s->light_count = c[4];
    int rc = copy_section(&sec[SEC_CP], n * 16 * sizeof(ts_vec4), (void **)&s->cp);
    if (!rc)
        rc = copy_section(&sec[SEC_CP1], c[5] ? n * 16 * sizeof(ts_vec4) : 0, (void **)&s->cp1);
    if (!rc)
        rc = copy_section(&sec[SEC_CORNER_N], sec[SEC_CORNER_N].bytes ? n * 4 * sizeof(ts_vec4) : 0,
                          (void **)&s->corner_n);
    if (!rc)
        rc = copy_section(&sec[SEC_MID_N], sec[SEC_MID_N].bytes ? n * 5 * sizeof(ts_vec4) : 0,
                          (void **)&s->mid_n);
    if (!rc) rc = copy_section(&sec[SEC_ATTR], n * sizeof(ts_patch_attr), (void **)&s->attr);
    if (!rc) rc = copy_section(&sec[SEC_XFORM], c[1] * sizeof(ts_xform), (void **)&s->xform);
    if (!rc)
        rc = copy_section(&sec[SEC_TEXTURES], c[2] * sizeof(ts_texture), (void **)&s->textures);
    if (!rc) rc = unpack_sources(&sec[SEC_SOURCES], c[2], s);
    if (!rc) rc = copy_section(&sec[SEC_TEX_POOL], c[3] * tile, (void **)&s->tex_pool);
    if (!rc)
        rc = copy_section(&sec[SEC_TEX_PAGES], c[3] * sizeof(uint32_t), (void **)&s->tex_pages);
    if (!rc)
        rc = copy_section(&sec[SEC_LIGHTS], c[4] * sizeof(ts_scene_light), (void **)&s->lights);
    if (!rc) rc = unpack_instances(sec, s);
    if (!rc) rc = unpack_trims(&sec[SEC_TRIM_SEG], s);
    if (!rc) {
        memcpy(&s->camera, sec[SEC_CAMERA].data, sizeof s->camera);
        memcpy(&s->dome, sec[SEC_DOME].data, sizeof s->dome);
        s->dome.mapname[sizeof s->dome.mapname - 1] = '\0';
        s->dome.map = NULL; /* the sender's pointer; its texels follow */
        uint64_t texels =
            sec[SEC_DOME_MAP].bytes ? (uint64_t)s->dome.map_width * s->dome.map_height : 0;
        rc = copy_section(&sec[SEC_DOME_MAP], texels * 3 * sizeof(float), (void **)&s->dome.map);
        if (!rc) return TS_OK;
    }
    /* Counts that the arrays do not match leave arrays NULL; scene_free needs them
     * consistent. */
    if (!s->tex_source) s->texture_count = 0;
    for (uint32_t i = 0; s->tex_source && i < s->texture_count; ++i)
        if (!s->tex_source[i]) s->texture_count = i;
    scene_free(s);
    return rc == -2
               ? ts_error_set(err, TS_E_MEMORY, "out of memory (unpacking the scene)")
               : ts_error_set(err, TS_E_USAGE, "the scene block is damaged or of another version");
}
