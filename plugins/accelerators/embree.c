/* embree: Intel Embree 3 as the yardstick for rtk's builders. It builds
 * Embree's own BVH over the scene's indexed triangles, shared with Embree
 * as an application shares its mesh (the kernel prepares no bounds or
 * corners for it), and answers every trace
 * itself, one ray at a time (rtcIntersect1 / rtcOccluded1), through the
 * accelerator's own-traversal functions; it emits no kernel nodes. Built
 * only when libembree-dev is installed.
 *
 * Parameters:
 *   quality  string low|medium|high  high   Embree's build quality (RTC_BUILD_QUALITY_*)
 *   threads  int [0, 1024]           0      Embree's threads; 0 = the kernel's thread count
 *   robust   bool                    false  RTC_SCENE_FLAG_ROBUST: no cracks on edges, slower
 *
 * Example: accelerator = { plugin = "embree"; quality = "medium"; };
 *
 * Embree's distances are its own (not the kernel's watertight test), so
 * t may differ from brute force in the last bits and exact ties may go to
 * another triangle than the lowest id. Its default intersector lets some
 * rays aimed exactly at shared edges and vertices pass between triangles
 * (`rtk conform embree` fails those cases); robust = true closes most of
 * them, but also changes the build (no spatial splits) and slows tracing.
 */
#include <rtk/rtk.h>

#include <embree3/rtcore.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct embree {
    enum RTCBuildQuality quality;
    uint32_t threads;        /* 0: follow the build arguments */
    int robust;
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
    a->node_count = 0;
    return RTK_OK;
}

static int embree_closest(const void *state, const rtk_ray *ray, rtk_hit *hit)
{
    const embree *e = state;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    rh.ray.org_x = ray->org.x, rh.ray.org_y = ray->org.y, rh.ray.org_z = ray->org.z;
    rh.ray.tnear = ray->tmin;
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
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    r.org_x = ray->org.x, r.org_y = ray->org.y, r.org_z = ray->org.z;
    r.tnear = ray->tmin;
    r.dir_x = ray->dir.x, r.dir_y = ray->dir.y, r.dir_z = ray->dir.z;
    r.time = 0.0f;
    r.tfar = ray->tmax;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(e->scene, &ctx, &r);
    return r.tfar == -INFINITY; /* Embree marks an occluded ray this way */
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
};

static const rtk_accelerator_fns embree_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = embree_create,
    .build = embree_build,
    .destroy = embree_destroy,
    .closest = embree_closest,
    .any = embree_any,
    .build_flags = RTK_BUILD_NO_VERTICES | RTK_BUILD_NO_BOUNDS,
};

static const rtk_plugin embree_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_ACCELERATOR,
    .name = "embree",
    .version = "1.0",
    .summary = "Intel Embree 3 BVH and traversal, one ray at a time (a yardstick)",
    .params = embree_params,
    .param_count = RTK_COUNTOF(embree_params),
    .functions = &embree_fns,
};

RTK_PLUGIN_ENTRY(embree_plugin)
