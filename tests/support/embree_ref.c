/* embree_ref.c — the Embree 3 reference tracer (embree_ref.h). Embree reports errors through
 * the device's error callback, which records the first one; every entry point checks it
 * after its Embree calls and turns it into a ts_error. The memory monitor keeps the bytes
 * Embree holds and their peak (the callback may run on Embree's worker threads, hence the
 * atomics). */
#include "embree_ref.h"
#include "lib/patch.h"

#include <embree3/rtcore.h>

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct ts_embree_ref {
    RTCDevice device;
    RTCScene scene;
    ts_embree_info info;
    atomic_llong bytes, peak;
    atomic_int error_claimed;
    int error_code; /* RTCError of the first error; 0 (RTC_ERROR_NONE) while none */
    char error_msg[512];
};

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const char *rtc_error_name(enum RTCError code)
{
    switch (code) {
    case RTC_ERROR_NONE:
        return "no error";
    case RTC_ERROR_UNKNOWN:
        return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
        return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
        return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
        return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
        return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
        return "cancelled";
    }
    return "error";
}

static void on_error(void *user, enum RTCError code, const char *str)
{
    ts_embree_ref *r = user;
    if (code == RTC_ERROR_NONE || atomic_exchange(&r->error_claimed, 1)) return;
    r->error_code = (int)code;
    snprintf(r->error_msg, sizeof r->error_msg, "%s%s%s", rtc_error_name(code), str ? ": " : "",
             str ? str : "");
}

static bool on_memory(void *user, ssize_t bytes, bool post)
{
    ts_embree_ref *r = user;
    long long now = atomic_fetch_add(&r->bytes, (long long)bytes) + (long long)bytes;
    long long peak = atomic_load(&r->peak);
    while (now > peak && !atomic_compare_exchange_weak(&r->peak, &peak, now)) {
    }
    return true;
}

/* TS_OK, or err set from the first Embree error recorded so far. */
static int check(ts_embree_ref *r, const char *what, ts_error *err)
{
    if (!atomic_load(&r->error_claimed)) return TS_OK;
    int code = r->error_code == RTC_ERROR_OUT_OF_MEMORY ? TS_E_MEMORY : TS_E_INTERNAL;
    return ts_error_set(err, code, "embree: %s: %s", what, r->error_msg);
}

ts_vec4 embree_ref_vertex(const ts_scene *s, uint32_t p, uint32_t m, uint32_t i, uint32_t j,
                          uint32_t time)
{
    const ts_vec4 *cp0 = &s->cp[(size_t)p * 16u];
    const ts_vec4 *cp = time && s->cp1 ? &s->cp1[(size_t)p * 16u] : cp0;
    const ts_patch_attr *a = &s->attr[p];
    const ts_vec4 *n = s->corner_n ? &s->corner_n[(size_t)p * 4u] : NULL;
    const ts_vec4 *mid = s->mid_n ? &s->mid_n[(size_t)p * 5u] : NULL;
    const ts_xform *x = s->xform ? &s->xform[a->xform] : NULL;
    ts_vec4 v = patch_vertex(cp, cp0, n, mid, a, x, scene_tex_ctx(s), quadtree_vertex_param(i, m),
                             quadtree_vertex_param(j, m));
    v.w = 1.0f;
    return v;
}

/* One triangle mesh for patch p at m, attached with geomID = p. */
static int add_patch(ts_embree_ref *r, const ts_scene *s, uint32_t p, uint32_t m, ts_error *err)
{
    uint32_t q = 1u << m, n = q + 1u;
    RTCGeometry g = rtcNewGeometry(r->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g) {
        if (check(r, "rtcNewGeometry", err)) return err->code;
        return ts_error_set(err, TS_E_INTERNAL, "embree: rtcNewGeometry failed");
    }
    /* A moving patch: its grids at both time samples, interpolated linearly at the ray's
     * time like the bottom level's vertices (Hanika §3.4). */
    uint32_t times = s->cp1 && (s->attr[p].flags & TS_PATCH_MOVING) ? 2u : 1u;
    if (times == 2u) rtcSetGeometryTimeStepCount(g, 2);
    uint32_t *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(uint32_t), 2u * (size_t)q * q);
    for (uint32_t time = 0; time < times && ib; ++time) {
        /* float3 at a 16-byte stride: ts_vec4 as is (w is ignored). */
        ts_vec4 *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, time, RTC_FORMAT_FLOAT3,
                                              sizeof(ts_vec4), (size_t)n * n);
        if (!vb) {
            ib = NULL;
            break;
        }
        for (uint32_t j = 0; j < n; ++j)
            for (uint32_t i = 0; i < n; ++i)
                vb[j * n + i] = embree_ref_vertex(s, p, m, i, j, time);
    }
    if (!ib) {
        rtcReleaseGeometry(g);
        if (check(r, "rtcSetNewGeometryBuffer", err)) return err->code;
        return ts_error_set(err, TS_E_MEMORY, "embree: no geometry buffer for patch %u", p);
    }
    for (uint32_t j = 0; j < q; ++j)
        for (uint32_t i = 0; i < q; ++i) {
            uint32_t v00 = j * n + i, v10 = v00 + 1u, v01 = v00 + n, v11 = v01 + 1u;
            uint32_t *t = &ib[6u * (j * q + i)]; /* triangles 2k and 2k + 1, k = j * 2^m + i */
            t[0] = v00, t[1] = v10, t[2] = v11;
            t[3] = v00, t[4] = v11, t[5] = v01;
        }
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(r->scene, g, p);
    rtcReleaseGeometry(g);
    r->info.vertices += (uint64_t)times * n * n;
    r->info.triangles += 2u * (uint64_t)q * q;
    return check(r, "patch geometry", err);
}

int embree_ref_create(ts_embree_ref **out, const ts_scene *s, uint32_t m,
                      const ts_embree_options *opt, ts_error *err)
{
    *out = NULL;
    ts_embree_options o = opt ? *opt : TS_EMBREE_DEFAULTS;
    if (m > TS_LOD_LIMIT)
        return ts_error_set(err, TS_E_USAGE, "embree: m = %u > %u", m, TS_LOD_LIMIT);
    ts_embree_ref *r = calloc(1, sizeof *r);
    if (!r) return ts_error_set(err, TS_E_MEMORY, "embree: out of memory");
    atomic_init(&r->bytes, 0);
    atomic_init(&r->peak, 0);
    atomic_init(&r->error_claimed, 0);
    r->info.lod = m;
    r->device = rtcNewDevice(NULL);
    if (!r->device) {
        enum RTCError e = rtcGetDeviceError(NULL);
        free(r);
        return ts_error_set(err, e == RTC_ERROR_OUT_OF_MEMORY ? TS_E_MEMORY : TS_E_INTERNAL,
                            "embree: rtcNewDevice failed: %s", rtc_error_name(e));
    }
    rtcSetDeviceErrorFunction(r->device, on_error, r);
    rtcSetDeviceMemoryMonitorFunction(r->device, on_memory, r);
    double t0 = now_seconds();
    r->scene = rtcNewScene(r->device);
    if (!r->scene) {
        if (!check(r, "rtcNewScene", err))
            ts_error_set(err, TS_E_INTERNAL, "embree: rtcNewScene failed");
        embree_ref_destroy(r);
        return err->code;
    }
    rtcSetSceneFlags(r->scene, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION |
                                   (o.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE));
    static const enum RTCBuildQuality quality[3] = {RTC_BUILD_QUALITY_LOW, RTC_BUILD_QUALITY_MEDIUM,
                                                    RTC_BUILD_QUALITY_HIGH};
    rtcSetSceneBuildQuality(r->scene, quality[o.quality < 0 ? 0 : o.quality > 2 ? 2 : o.quality]);
    for (uint32_t p = 0; p < s->patch_count; ++p)
        if (add_patch(r, s, p, m, err)) {
            embree_ref_destroy(r);
            return err->code;
        }
    double t1 = now_seconds();
    r->info.bytes_before_build = atomic_load(&r->bytes);
    rtcCommitScene(r->scene);
    double t2 = now_seconds();
    r->info.tessellate_seconds = t1 - t0;
    r->info.build_seconds = t2 - t1;
    r->info.bytes_after_build = atomic_load(&r->bytes);
    r->info.bytes_peak = atomic_load(&r->peak);
    if (check(r, "rtcCommitScene", err)) {
        embree_ref_destroy(r);
        return err->code;
    }
    *out = r;
    return TS_OK;
}

void embree_ref_destroy(ts_embree_ref *r)
{
    if (!r) return;
    if (r->scene) rtcReleaseScene(r->scene);
    if (r->device) rtcReleaseDevice(r->device);
    free(r);
}

const ts_embree_info *embree_ref_info(const ts_embree_ref *r)
{
    return &r->info;
}

/* The intersection context of one ray: which patch it leaves and how near its hits there
 * are ignored. */
typedef struct self_context {
    struct RTCIntersectContext ctx; /* first: Embree passes &ctx to the filter */
    uint32_t from;                  /* patch + 1, 0: none */
    float self;
} self_context;

static void self_filter(const struct RTCFilterFunctionNArguments *args)
{
    const self_context *c = (const self_context *)args->context;
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        /* SOA layouts of rtcore_ray.h (its accessors are C++ only): RTCHitN is Ng_x, Ng_y,
         * Ng_z, u, v, primID, geomID, ...; RTCRayN is org_x, org_y, org_z, tnear, dir_x,
         * dir_y, dir_z, time, tfar, ...; each an array of N. */
        unsigned geom = ((const unsigned *)args->hit)[6 * args->N + i];
        float t = ((const float *)args->ray)[8 * args->N + i];
        if (c->from && geom == c->from - 1u && t < c->self) args->valid[i] = 0;
    }
}

int embree_ref_trace(ts_embree_ref *r, const ts_vec4 *org, const ts_vec4 *dir, const uint32_t *from,
                     uint32_t count, ts_hit *hit, ts_error *err)
{
    float scale = ldexpf(1.0f, -(int)r->info.lod);
    uint32_t q = 1u << r->info.lod;
    self_context sc;
    rtcInitIntersectContext(&sc.ctx);
    sc.ctx.filter = self_filter;
    struct RTCIntersectContext *ctx = &sc.ctx;
    for (uint32_t k = 0; k < count; ++k) {
        sc.from = from ? from[k] : 0u;
        sc.self = org[k].w;
        struct RTCRayHit rh;
        memset(&rh, 0, sizeof rh);
        rh.ray.org_x = org[k].x, rh.ray.org_y = org[k].y, rh.ray.org_z = org[k].z;
        rh.ray.dir_x = dir[k].x, rh.ray.dir_y = dir[k].y, rh.ray.dir_z = dir[k].z;
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = INFINITY;
        rh.ray.time = dir[k].w;
        rh.ray.mask = 0xffffffffu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(r->scene, ctx, &rh);
        ts_hit h = {TS_NO_HIT, 0.0f, 0.0f, TS_INVALID, TS_INVALID};
        if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
            /* Barycentrics (b1, b2) weigh the triangle's second and third vertex. */
            uint32_t quad = rh.hit.primID / 2u, i = quad % q, j = quad / q;
            float b1 = rh.hit.u, b2 = rh.hit.v;
            h.t = rh.ray.tfar;
            h.patch = rh.hit.geomID;
            h.prim = TS_PRIM(r->info.lod, rh.hit.primID);
            if (rh.hit.primID % 2u == 0u) { /* (v00, v10, v11) */
                h.u = ((float)i + b1 + b2) * scale;
                h.v = ((float)j + b2) * scale;
            } else { /* (v00, v11, v01) */
                h.u = ((float)i + b1) * scale;
                h.v = ((float)j + b1 + b2) * scale;
            }
        }
        hit[k] = h;
    }
    return check(r, "rtcIntersect1", err);
}
