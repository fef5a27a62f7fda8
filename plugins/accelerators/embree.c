/* embree: Intel Embree 3 as the yardstick for rtk's builders. It builds
 * Embree's own BVH over the scene's indexed triangles, shared with Embree
 * as an application shares its mesh (the kernel prepares no bounds or
 * corners for it), and answers every trace itself through the
 * accelerator's own-traversal functions; it emits no kernel nodes. Built
 * only when libembree-dev is installed.
 *
 * Two traversal modes: a single ray (rtk_trace, rtk_occluded) goes
 * through rtcIntersect1 / rtcOccluded1; a batch (rtk_trace_batch,
 * rtk_occluded_batch) is cut into packets of consecutive rays traced with
 * rtcIntersect4/8/16 / rtcOccluded4/8/16 (a short last packet with the
 * missing lanes masked off), or one ray at a time with packets = off.
 * Packets of 4 and 8 give the single-ray answers bit for bit (`rtk
 * conform embree` checks it); auto takes 8 where Embree runs 8-wide
 * natively (AVX, AVX2, AVX-512), else 4 (SSE). 16 is there to be asked
 * for only: on AVX-512, rtcOccluded16 reports occluded where rtcOccluded1
 * lets the ray through a crack between triangles (2 of the 5,000 rays
 * `rtk conform embree` aims at an icosphere at 1e5; none with robust =
 * true), so packets = 16 fails that check.
 *
 * Parameters:
 *   quality  string low|medium|high   high   Embree's build quality (RTC_BUILD_QUALITY_*)
 *   threads  int [0, 1024]            0      Embree's threads; 0 = the kernel's thread count
 *   robust   bool                     false  RTC_SCENE_FLAG_ROBUST: no cracks on edges, slower
 *   packets  string auto|off|4|8|16   auto   rays per packet in batches: auto = 8 (4 on SSE); off = one at a time
 *
 * Example: accelerator = { plugin = "embree"; quality = "medium"; packets = "8"; };
 *
 * Embree's distances are its own (not the kernel's watertight test), so
 * t may differ from brute force in the last bits and exact ties may go to
 * another triangle than the lowest id. Its default intersector lets some
 * rays aimed exactly at shared edges and vertices pass between triangles
 * (`rtk conform embree` fails those cases); robust = true closes most of
 * them, but also changes the build (no spatial splits) and slows tracing.
 * Embree traces from t >= 0 only (it asserts so): a ray with a negative
 * tmin starts at 0, and a ray with a coordinate beyond 1.8e18 misses.
 */
#include <rtk/rtk.h>

#include <embree3/rtcore.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

typedef struct embree {
    enum RTCBuildQuality quality;
    uint32_t threads;        /* 0: follow the build arguments */
    int robust;
    uint32_t packets;        /* asked for: 0 auto, 1 off, 4, 8 or 16 */
    uint32_t width;          /* rays per packet the batches use (1: none), set by build */
    RTCDevice device;        /* created on the first build */
    uint32_t device_threads; /* threads the device was created with */
    RTCScene scene;          /* the committed scene, or NULL */
} embree;

/* Status for Embree's last error on device, or RTK_OK. */
static rtk_status device_status(RTCDevice device, const char *what)
{
    enum RTCError e = rtcGetDeviceError(device);
    if (e == RTC_ERROR_NONE)
        return RTK_OK;
    static const char *const names[] = {"none", "unknown error", "invalid argument", "invalid operation",
                                        "out of memory", "unsupported CPU", "cancelled"};
    const char *name = (unsigned)e < sizeof names / sizeof names[0] ? names[e] : "error";
    return rtk_error(e == RTC_ERROR_OUT_OF_MEMORY ? RTK_ERR_NOMEM : RTK_ERR_PLUGIN, "embree: %s: %s (code %d)", what,
                     name, (int)e);
}

static rtk_status embree_create(const rtk_params *params, void **state)
{
    embree *e = calloc(1, sizeof *e);
    if (!e)
        return rtk_error(RTK_ERR_NOMEM, "embree: out of memory");
    const char *q = rtk_params_string(params, "quality");
    e->quality = strcmp(q, "low") == 0      ? RTC_BUILD_QUALITY_LOW
                 : strcmp(q, "medium") == 0 ? RTC_BUILD_QUALITY_MEDIUM
                                            : RTC_BUILD_QUALITY_HIGH;
    e->threads = (uint32_t)rtk_params_int(params, "threads");
    e->robust = rtk_params_bool(params, "robust");
    const char *pk = rtk_params_string(params, "packets");
    e->packets = strcmp(pk, "off") == 0 ? 1 : strcmp(pk, "auto") == 0 ? 0 : (uint32_t)atoi(pk);
    *state = e;
    return RTK_OK;
}

/* The device outlives the builds: an application makes one device and
 * builds many scenes with it, and a fresh device per build would charge
 * the start of Embree's threads to every timed build. Embree's thread count is process-wide
 * (its tasking library follows the device made last: with a 1-thread and
 * a 2-thread device alive, a "1-thread" build used two), so one device is
 * kept, for the last thread count asked for, and replaced when another is
 * asked for (a state still holding the old one keeps it alive until it is
 * destroyed). The kept reference is dropped by an atexit handler,
 * registered after Embree's tasking library set itself up so that it runs
 * first (a destructor would run after that library's teardown and abort
 * in it). */
static pthread_mutex_t device_lock = PTHREAD_MUTEX_INITIALIZER;
static RTCDevice kept_device;
static uint32_t kept_threads;
static int release_registered;

static void release_kept_device(void)
{
    if (kept_device)
        rtcReleaseDevice(kept_device);
    kept_device = NULL;
}

/* A device with threads, retained for the caller; NULL when Embree cannot
 * make one. */
static RTCDevice shared_device(uint32_t threads)
{
    pthread_mutex_lock(&device_lock);
    if (kept_device && kept_threads != threads)
        release_kept_device();
    RTCDevice d = kept_device;
    if (!d) {
        char config[64];
        snprintf(config, sizeof config, "threads=%u,verbose=0", threads);
        d = rtcNewDevice(config);
        if (d && !release_registered)
            release_registered = atexit(release_kept_device) == 0;
        if (d && release_registered) {
            kept_device = d;
            kept_threads = threads;
        }
    }
    if (d && d == kept_device)
        rtcRetainDevice(d);
    pthread_mutex_unlock(&device_lock);
    return d;
}

/* Makes sure e->device runs on the wanted number of threads. */
static rtk_status ensure_device(embree *e, uint32_t threads)
{
    if (e->device && e->device_threads == threads)
        return RTK_OK;
    if (e->scene)
        rtcReleaseScene(e->scene);
    if (e->device)
        rtcReleaseDevice(e->device);
    e->scene = NULL;
    e->device = shared_device(threads);
    if (!e->device)
        return device_status(NULL, "rtcNewDevice");
    e->device_threads = threads;
    return RTK_OK;
}

/* packets = auto: 8 when device traces 8 rays natively, else 4, else 1
 * (none). Not 16: its occlusion differs from single rays (see the top). */
static uint32_t native_width(RTCDevice device)
{
    if (rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED))
        return 8;
    if (rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED))
        return 4;
    return 1;
}

static rtk_status embree_build(void *state, rtk_build_args *a)
{
    embree *e = state;
    if (a->size < offsetof(rtk_build_args, vertex_count) + sizeof a->vertex_count || !a->indices || !a->positions)
        return rtk_error(RTK_ERR_UNSUPPORTED, "embree: the kernel passes no triangles (instances are not supported)");
    rtk_status st = ensure_device(e, e->threads ? e->threads : (a->thread_count ? a->thread_count : 1));
    if (st != RTK_OK)
        return st;
    if (e->scene)
        rtcReleaseScene(e->scene);
    e->scene = rtcNewScene(e->device);
    if (!e->scene)
        return device_status(e->device, "rtcNewScene");
    rtcSetSceneBuildQuality(e->scene, e->quality);
    rtcSetSceneFlags(e->scene, e->robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    RTCGeometry geom = rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geom)
        return device_status(e->device, "rtcNewGeometry");
    rtcSetGeometryBuildQuality(geom, e->quality);
    /* The scene's own arrays, as an application shares its mesh with
     * Embree: nothing copied, and the build starts from the triangles as
     * rtk's builders do (they from the kernel's bounds, which it times
     * with them). The positions carry the float of padding Embree reads
     * past the last vertex, and live as long as the scene, as this state
     * does. */
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, a->positions, 0,
                               3 * sizeof(float), a->vertex_count);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, a->indices, 0,
                               3 * sizeof(uint32_t), a->prim_count);
    st = device_status(e->device, "rtcSetSharedGeometryBuffer");
    if (st != RTK_OK) {
        rtcReleaseGeometry(geom);
        return st;
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(e->scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(e->scene);
    st = device_status(e->device, "building the scene");
    if (st != RTK_OK) {
        rtcReleaseScene(e->scene);
        e->scene = NULL;
        return st;
    }
    e->width = e->packets ? e->packets : native_width(e->device);
    a->node_count = 0;
    return RTK_OK;
}

/* The segment's start as Embree takes it, or 0 when Embree cannot trace
 * the ray and it misses: Embree asserts tnear >= 0 (a negative tmin
 * starts at 0) and coordinates below 1.844e18 (its FLT_LARGE). */
static int embree_segment(const rtk_ray *ray, float *tnear)
{
    const float large = 1.8e18f;
    *tnear = ray->tmin > 0.0f ? ray->tmin : 0.0f;
    return *tnear <= ray->tmax && fabsf(ray->org.x) < large && fabsf(ray->org.y) < large &&
           fabsf(ray->org.z) < large && fabsf(ray->dir.x) < large && fabsf(ray->dir.y) < large &&
           fabsf(ray->dir.z) < large;
}

static int embree_closest(const void *state, const rtk_ray *ray, rtk_hit *hit)
{
    const embree *e = state;
    float tnear;
    if (!embree_segment(ray, &tnear))
        return 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    rh.ray.org_x = ray->org.x, rh.ray.org_y = ray->org.y, rh.ray.org_z = ray->org.z;
    rh.ray.tnear = tnear;
    rh.ray.dir_x = ray->dir.x, rh.ray.dir_y = ray->dir.y, rh.ray.dir_z = ray->dir.z;
    rh.ray.time = 0.0f;
    rh.ray.tfar = ray->tmax;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(e->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    /* Embree's u and v weight corners 1 and 2, as rtk's do. */
    hit->t = rh.ray.tfar, hit->u = rh.hit.u, hit->v = rh.hit.v, hit->prim = rh.hit.primID;
    return 1;
}

static int embree_any(const void *state, const rtk_ray *ray)
{
    const embree *e = state;
    float tnear;
    if (!embree_segment(ray, &tnear))
        return 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    r.org_x = ray->org.x, r.org_y = ray->org.y, r.org_z = ray->org.z;
    r.tnear = tnear;
    r.dir_x = ray->dir.x, r.dir_y = ray->dir.y, r.dir_z = ray->dir.z;
    r.time = 0.0f;
    r.tfar = ray->tmax;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(e->scene, &ctx, &r);
    return r.tfar == -INFINITY; /* Embree marks an occluded ray this way */
}

/* A packet of up to 16 rays: RTCRayHit4/8/16 are structures of arrays in
 * which field f of lane i of an n-wide packet is 32-bit word f n + i, so
 * that one filler serves every width. */
enum {
    F_ORG_X, F_ORG_Y, F_ORG_Z, F_TNEAR, F_DIR_X, F_DIR_Y, F_DIR_Z, F_TIME, F_TFAR, F_MASK, F_ID, F_FLAGS,
    F_NG_X, F_NG_Y, F_NG_Z, F_U, F_V, F_PRIM, F_GEOM, F_INST, F_COUNT
};

typedef union packet {
    struct RTCRayHit4 rh4;
    struct RTCRayHit8 rh8;
    struct RTCRayHit16 rh16;
    float f[16 * F_COUNT];
    uint32_t w[16 * F_COUNT];
} packet;

_Static_assert(offsetof(struct RTCRayHit4, hit.geomID) == 4 * 4 * F_GEOM &&
                   offsetof(struct RTCRayHit8, hit.u) == 8 * 4 * F_U &&
                   offsetof(struct RTCRayHit16, ray.tfar) == 16 * 4 * F_TFAR &&
                   sizeof(struct RTCRayHit16) == 16 * 4 * F_COUNT,
               "Embree's packet layout");

/* Writes ray, from tnear on, into lane i of the n-wide packet p, its hit
 * cleared. */
static void packet_put(packet *p, uint32_t n, uint32_t i, const rtk_ray *ray, float tnear)
{
    p->f[F_ORG_X * n + i] = ray->org.x, p->f[F_ORG_Y * n + i] = ray->org.y, p->f[F_ORG_Z * n + i] = ray->org.z;
    p->f[F_TNEAR * n + i] = tnear;
    p->f[F_DIR_X * n + i] = ray->dir.x, p->f[F_DIR_Y * n + i] = ray->dir.y, p->f[F_DIR_Z * n + i] = ray->dir.z;
    p->f[F_TIME * n + i] = 0.0f;
    p->f[F_TFAR * n + i] = ray->tmax;
    p->w[F_MASK * n + i] = 0xffffffffu;
    p->w[F_ID * n + i] = 0;
    p->w[F_FLAGS * n + i] = 0;
    p->w[F_PRIM * n + i] = p->w[F_GEOM * n + i] = p->w[F_INST * n + i] = RTC_INVALID_GEOMETRY_ID;
}

/* Loads rays[0 .. m) into the n-wide packet p and valid; lanes m .. n and
 * rays Embree cannot trace (embree_segment) are masked off and hold an
 * empty ray, so that nothing reads garbage, and miss. */
static void packet_load(packet *p, int *valid, uint32_t n, const rtk_ray *rays, uint32_t m)
{
    static const rtk_ray empty = {{0.0f, 0.0f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, 0.0f};
    for (uint32_t i = 0; i < n; i++) {
        float tnear = 0.0f;
        valid[i] = i < m && embree_segment(&rays[i], &tnear) ? -1 : 0;
        packet_put(p, n, i, valid[i] ? &rays[i] : &empty, tnear);
    }
}

static void embree_closest_batch(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    const embree *e = state;
    const uint32_t n = e->width;
    if (n <= 1) {
        for (uint32_t i = 0; i < count; i++)
            embree_closest(state, &rays[i], &hits[i]);
        return;
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    packet p;
    RTC_ALIGN(64) int valid[16];
    for (uint32_t first = 0; first < count; first += n) {
        const uint32_t m = count - first < n ? count - first : n;
        packet_load(&p, valid, n, rays + first, m);
        if (n == 16)
            rtcIntersect16(valid, e->scene, &ctx, &p.rh16);
        else if (n == 8)
            rtcIntersect8(valid, e->scene, &ctx, &p.rh8);
        else
            rtcIntersect4(valid, e->scene, &ctx, &p.rh4);
        /* The misses keep the kernel's cleared hit, as with embree_closest. */
        for (uint32_t i = 0; i < m; i++) {
            if (p.w[F_GEOM * n + i] == RTC_INVALID_GEOMETRY_ID)
                continue;
            rtk_hit *h = &hits[first + i];
            h->t = p.f[F_TFAR * n + i], h->u = p.f[F_U * n + i], h->v = p.f[F_V * n + i];
            h->prim = p.w[F_PRIM * n + i];
        }
    }
}

static void embree_any_batch(const void *state, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    const embree *e = state;
    const uint32_t n = e->width;
    if (n <= 1) {
        for (uint32_t i = 0; i < count; i++)
            occluded[i] = (uint8_t)embree_any(state, &rays[i]);
        return;
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    packet p;
    RTC_ALIGN(64) int valid[16];
    for (uint32_t first = 0; first < count; first += n) {
        const uint32_t m = count - first < n ? count - first : n;
        packet_load(&p, valid, n, rays + first, m);
        /* RTCRayN is the first member of RTCRayHitN: the occlusion calls read the same words. */
        if (n == 16)
            rtcOccluded16(valid, e->scene, &ctx, &p.rh16.ray);
        else if (n == 8)
            rtcOccluded8(valid, e->scene, &ctx, &p.rh8.ray);
        else
            rtcOccluded4(valid, e->scene, &ctx, &p.rh4.ray);
        for (uint32_t i = 0; i < m; i++)
            occluded[first + i] = valid[i] && p.f[F_TFAR * n + i] == -INFINITY;
    }
}

static void embree_destroy(void *state)
{
    embree *e = state;
    if (e->scene)
        rtcReleaseScene(e->scene);
    if (e->device)
        rtcReleaseDevice(e->device);
    free(e);
}

static const rtk_param_desc embree_params[] = {
    {.name = "quality", .type = RTK_PARAM_STRING, .def_string = "high", .choices = "low|medium|high",
     .doc = "Embree's build quality: low (Morton), medium (binned SAH), high (SAH with spatial splits)"},
    {.name = "threads", .type = RTK_PARAM_INT, .def = 0, .min = 0, .max = 1024,
     .doc = "threads Embree builds with; 0 = the kernel's thread count"},
    {.name = "robust", .type = RTK_PARAM_BOOL, .def = 0,
     .doc = "RTC_SCENE_FLAG_ROBUST: watertight edges at some cost in speed"},
    {.name = "packets", .type = RTK_PARAM_STRING, .def_string = "auto", .choices = "auto|off|4|8|16",
     .doc = "rays per Embree packet in batch traces (rtcIntersect4/8/16): auto = 8, or 4 where the CPU runs "
            "no 8-wide packets; off = rtcIntersect1 for each ray; 16 may differ from single rays at cracks"},
};

static const rtk_accelerator_fns embree_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = embree_create,
    .build = embree_build,
    .destroy = embree_destroy,
    .closest = embree_closest,
    .any = embree_any,
    .build_flags = RTK_BUILD_NO_VERTICES | RTK_BUILD_NO_BOUNDS,
    .closest_batch = embree_closest_batch,
    .any_batch = embree_any_batch,
};

static const rtk_plugin embree_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_ACCELERATOR,
    .name = "embree",
    .version = "1.1",
    .summary = "Intel Embree 3 BVH and traversal, one ray at a time or in packets (a yardstick)",
    .params = embree_params,
    .param_count = RTK_COUNTOF(embree_params),
    .functions = &embree_fns,
};

RTK_PLUGIN_ENTRY(embree_plugin)
