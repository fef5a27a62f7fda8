/* One render, start to finish: load what the plugins need, build the BVH,
 * render tiles on a thread pool, write the image atomically, report. */
#include "render.h"
#include "../config/config.h"
#include "../image/image.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define TILE_SIZE 16

/* Shared state of the render workers. */
typedef struct render_job {
    const rtk_scene *scene;
    rtk_camera camera;
    const rtk_integrator_fns *integrator;
    const void *istate;
    const rtk_filter_fns *filter;
    const void *fstate;
    float radius;
    uint32_t spp;
    rtk_sampler_type sampler;
    rtk_reconstruction recon;
    rtk_filter_sampler fsampler; /* RTK_RECON_IMPORTANCE */
    uint64_t seed;
    rtk_film film;
    int batches; /* the integrator's li_batch renders (batches_wanted) */
    int on_device;  /* the scene's device runs the integrator's program */
    rtk_device_program program;
    int footprints; /* and reads trilinear textures: it gets camera differentials */
    uint32_t device_run; /* tiles a worker takes at once for the device */
    uint32_t tiles_x, tiles_y, tile_count;
    atomic_uint next_tile;
    atomic_uint tiles_done;
    /* Deterministic merge (merge_tiles): a finished tile waits in pending
     * until every lower-numbered tile that shares a pixel with it has been
     * merged. Under merge_lock: state, waits_on, the queue. */
    pthread_mutex_t merge_lock;
    rtk_film_tile *pending;
    uint8_t *state;      /* TILE_RENDERING, TILE_PENDING, TILE_QUEUED */
    uint32_t *waits_on;  /* lower-numbered tiles sharing pixels, not yet merged */
    uint32_t *queue;     /* tiles free to merge: [queue_head, queue_tail) */
    uint32_t queue_head, queue_tail;
    uint32_t reach;      /* tiles further apart in x or y share no pixel */
    rtk_status status; /* first failure, under merge_lock */
    atomic_int failed;  /* set with status, read by workers without the lock */
    char error[1024];
    /* Totals over all workers, added under merge_lock. */
    uint64_t rays, invalid_rays, bad_samples;
} render_job;

enum { TILE_RENDERING, TILE_PENDING, TILE_QUEUED };

/* Under merge_lock: a tile that tile u waits on is merged. */
static void release(render_job *job, uint32_t u)
{
    if (--job->waits_on[u] == 0 && job->state[u] == TILE_PENDING) {
        job->state[u] = TILE_QUEUED;
        job->queue[job->queue_tail++] = u;
    }
}

/* The columns [x0, x1] of tiles within job->reach of column tx. */
static void reach_columns(const render_job *job, uint32_t tx, uint32_t *x0, uint32_t *x1)
{
    const uint32_t r = job->reach;
    *x0 = tx > r ? tx - r : 0;
    *x1 = tx + r < job->tiles_x - 1 ? tx + r : job->tiles_x - 1;
}

/* release() for every tile after tile t within job->reach of it. */
static void release_later(render_job *job, uint32_t t)
{
    const uint32_t tx = t % job->tiles_x, ty = t / job->tiles_x, r = job->reach;
    const uint32_t y1 = ty + r < job->tiles_y - 1 ? ty + r : job->tiles_y - 1;
    uint32_t x0, x1;
    reach_columns(job, tx, &x0, &x1);
    for (uint32_t x = tx + 1; x <= x1; x++)
        release(job, ty * job->tiles_x + x);
    for (uint32_t y = ty + 1; y <= y1; y++)
        for (uint32_t x = x0; x <= x1; x++)
            release(job, y * job->tiles_x + x);
}

/* Each tile's count of lower-numbered tiles whose padded buffers overlap
 * its own: buffers reach pad pixels past tiles of TILE_SIZE, so tiles
 * (TILE_SIZE + 2 pad) / TILE_SIZE or more apart share none. */
static void init_merge(render_job *job)
{
    const uint32_t pad = (uint32_t)rtk_film_tile_pad(job->radius);
    const uint32_t r = job->reach = (TILE_SIZE + 2 * pad - 1) / TILE_SIZE;
    for (uint32_t t = 0; t < job->tile_count; t++) {
        const uint32_t tx = t % job->tiles_x, ty = t / job->tiles_x, y0 = ty > r ? ty - r : 0;
        uint32_t x0, x1;
        reach_columns(job, tx, &x0, &x1);
        job->waits_on[t] = (ty - y0) * (x1 - x0 + 1) + (tx - x0); /* rows above, then the left of its own */
    }
    job->queue_head = job->queue_tail = 0;
}

/* Under merge_lock, after tiles were made TILE_PENDING: merges every tile
 * free to merge, outside the lock, until none is left; returns with the
 * lock held. Two tiles that share a pixel are never merged at once (the
 * later waits on the earlier), so each pixel sums its tiles in tile order
 * whatever the threads, and tiles apart merge on several threads. */
static void merge_tiles(render_job *job)
{
    while (job->queue_head < job->queue_tail) {
        const uint32_t t = job->queue[job->queue_head++];
        pthread_mutex_unlock(&job->merge_lock);
        rtk_film_merge(&job->film, &job->pending[t]);
        rtk_film_tile_free(&job->pending[t]);
        pthread_mutex_lock(&job->merge_lock);
        release_later(job, t);
    }
}

/* Under merge_lock: tile t is rendered into job->pending[t]. */
static void tile_done(render_job *job, uint32_t t)
{
    job->state[t] = job->waits_on[t] == 0 ? TILE_QUEUED : TILE_PENDING;
    if (job->state[t] == TILE_QUEUED)
        job->queue[job->queue_tail++] = t;
}

static void fail(render_job *job, rtk_status st)
{
    pthread_mutex_lock(&job->merge_lock);
    if (job->status == RTK_OK) {
        job->status = st;
        atomic_store(&job->failed, 1);
        snprintf(job->error, sizeof job->error, "%s", rtk_error_message());
    }
    pthread_mutex_unlock(&job->merge_lock);
}

/* The integrator's li_batch (ABI 3.4), or NULL. */
static void (*batch_fn(const rtk_integrator_fns *f))(const void *, rtk_ctx *, const rtk_ray *, uint32_t,
                                                     rtk_li_result *)
{
    return f->size >= offsetof(rtk_integrator_fns, li_batch) + sizeof f->li_batch ? f->li_batch : NULL;
}

/* One worker's room for a batch of camera samples. */
typedef struct sample_batch {
    rtk_ray rays[RTK_BATCH_MAX];
    rtk_li_result out[RTK_BATCH_MAX];
    rtk_sample_state state[RTK_BATCH_MAX];
    float fx[RTK_BATCH_MAX], fy[RTK_BATCH_MAX], fw[RTK_BATCH_MAX];
    int px[RTK_BATCH_MAX], py[RTK_BATCH_MAX];
} sample_batch;

/* Starts sample s of pixel (x, y): its film position and weight, and its
 * camera ray, leaving ctx at li's first draw. */
static rtk_ray start_sample(render_job *job, rtk_ctx *ctx, uint32_t x, uint32_t y, uint32_t s, float *fx,
                            float *fy, float *fw)
{
    rtk_ctx_start_sample(ctx, (uint64_t)y * job->film.width + x, s);
    rtk_vec2 jitter = rtk_sample_2d(ctx);
    *fx = (float)x + jitter.x, *fy = (float)y + jitter.y, *fw = 1.0f;
    if (job->recon == RTK_RECON_IMPORTANCE) {
        /* The filter places the sample around the pixel centre. */
        float dx, dy;
        rtk_filter_sampler_sample(&job->fsampler, jitter, &dx, &dy, fw);
        *fx = (float)x + 0.5f + dx;
        *fy = (float)y + 0.5f + dy;
    }
    rtk_ray ray = rtk_camera_ray(&job->camera, *fx, *fy);
    ctx->film_x = *fx, ctx->film_y = *fy; /* for rtk_ctx_camera_differential */
    ctx->camera_ray = ray;                /* for rtk_trace's single-sided test */
    ctx->pos.dim_base = ctx->pos.dim;     /* rtk_sample_seek counts from here */
    return ray;
}

static void init_result(rtk_li_result *r)
{
    memset(r, 0, sizeof *r);
    r->depth = INFINITY;
}

/* Adds one sample's result to the tile (dropping non-finite radiance). */
static void add_sample(render_job *job, rtk_film_tile *tile, int x, int y, float fx, float fy, float fw,
                       const rtk_li_result *r, uint64_t *bad)
{
    if (!isfinite(r->radiance.r) || !isfinite(r->radiance.g) || !isfinite(r->radiance.b)) {
        (*bad)++;
        return;
    }
    float values[RTK_FILM_CHANNELS];
    values[0] = r->radiance.r, values[1] = r->radiance.g, values[2] = r->radiance.b;
    values[3] = r->albedo.r, values[4] = r->albedo.g, values[5] = r->albedo.b;
    values[6] = r->normal.x, values[7] = r->normal.y, values[8] = r->normal.z;
    values[9] = isfinite(r->depth) ? r->depth : 0.0f;
    if (job->recon == RTK_RECON_IMPORTANCE)
        rtk_film_tile_add(tile, x, y, fw, values);
    else
        rtk_film_tile_splat(tile, &job->film, fx, fy, values, job->filter, job->fstate, job->radius);
}

/* Runs li_batch on the n samples gathered in b and adds them in order. */
static void flush_batch(render_job *job, rtk_ctx *ctx, sample_batch *b, uint32_t n, rtk_film_tile *tile,
                        uint64_t *bad)
{
    ctx->batch = b->state;
    ctx->batch_rays = b->rays;
    ctx->batch_count = n;
    ctx->batch_current = 0;
    rtk_ctx_load_sample(ctx, &b->state[0]);
    batch_fn(job->integrator)(job->istate, ctx, b->rays, n, b->out);
    ctx->batch_count = 0;
    ctx->batch = NULL;
    ctx->batch_rays = NULL;
    for (uint32_t i = 0; i < n; i++)
        add_sample(job, tile, b->px[i], b->py[i], b->fx[i], b->fy[i], b->fw[i], &b->out[i], bad);
}

/* Camera samples of several tiles gathered for one device call. */
#define DEVICE_BATCH 65536u

typedef struct device_batch {
    rtk_ray rays[DEVICE_BATCH];
    rtk_sample_pos pos[DEVICE_BATCH];
    rtk_li_result out[DEVICE_BATCH];
    rtk_ray_differential diffs[DEVICE_BATCH]; /* when the job's footprints */
    float fx[DEVICE_BATCH], fy[DEVICE_BATCH], fw[DEVICE_BATCH];
    int px[DEVICE_BATCH], py[DEVICE_BATCH];
    uint32_t tile[DEVICE_BATCH]; /* index into the run's tiles */
} device_batch;

/* Has the device run the integrator's program on the n samples in b and
 * adds them, in order, to their tiles. */
static int flush_device(render_job *job, rtk_ctx *ctx, device_batch *b, uint32_t n, rtk_film_tile *tiles,
                        uint64_t *bad)
{
    rtk_shade_batch sb;
    memset(&sb, 0, sizeof sb);
    sb.size = sizeof sb;
    sb.program = &job->program;
    sb.gen = &ctx->gen;
    sb.albedo = rtk_material_default().base_color;
    sb.count = n;
    sb.rays = b->rays;
    sb.pos = b->pos;
    sb.out = b->out;
    sb.diffs = job->footprints ? b->diffs : NULL;
    rtk_status st = rtk_device_shade(job->scene, &sb);
    if (st != RTK_OK) {
        fail(job, st);
        return 0;
    }
    ctx->rays += sb.rays_traced;
    ctx->invalid_rays += sb.invalid_rays;
    for (uint32_t i = 0; i < n; i++)
        add_sample(job, &tiles[b->tile[i]], b->px[i], b->py[i], b->fx[i], b->fy[i], b->fw[i], &b->out[i], bad);
    return 1;
}

/* Renders tiles [first, end) through the device's program: their samples
 * in film order, DEVICE_BATCH at a time, then merges them as render_tile does. */
static void render_tiles_on_device(render_job *job, uint32_t first, uint32_t end, rtk_ctx *ctx, device_batch *b,
                                   rtk_film_tile *tiles, uint64_t *bad)
{
    uint32_t made = 0, n = 0;
    int ok = 1;
    for (uint32_t k = 0; ok && k < end - first; k++) {
        uint32_t index = first + k;
        uint32_t x0 = index % job->tiles_x * TILE_SIZE, y0 = index / job->tiles_x * TILE_SIZE;
        uint32_t x1 = x0 + TILE_SIZE < job->film.width ? x0 + TILE_SIZE : job->film.width;
        uint32_t y1 = y0 + TILE_SIZE < job->film.height ? y0 + TILE_SIZE : job->film.height;
        rtk_status st = rtk_film_tile_init(&tiles[k], &job->film, x0, y0, x1, y1, job->radius);
        if (st != RTK_OK) {
            fail(job, st);
            ok = 0;
            break;
        }
        made++;
        for (uint32_t y = y0; ok && y < y1; y++)
            for (uint32_t x = x0; ok && x < x1; x++)
                for (uint32_t s = 0; ok && s < job->spp; s++) {
                    b->rays[n] = start_sample(job, ctx, x, y, s, &b->fx[n], &b->fy[n], &b->fw[n]);
                    b->pos[n] = ctx->pos;
                    if (job->footprints)
                        rtk_ctx_camera_differential(ctx, &b->diffs[n]);
                    b->px[n] = (int)x, b->py[n] = (int)y;
                    b->tile[n] = k;
                    if (++n == DEVICE_BATCH) {
                        ok = flush_device(job, ctx, b, n, tiles, bad);
                        n = 0;
                    }
                }
    }
    if (ok && n)
        ok = flush_device(job, ctx, b, n, tiles, bad);
    if (!ok) {
        for (uint32_t k = 0; k < made; k++)
            rtk_film_tile_free(&tiles[k]);
        return;
    }
    pthread_mutex_lock(&job->merge_lock);
    for (uint32_t k = 0; k < made; k++) {
        job->pending[first + k] = tiles[k];
        tile_done(job, first + k);
    }
    merge_tiles(job);
    pthread_mutex_unlock(&job->merge_lock);
    atomic_fetch_add(&job->tiles_done, made);
}

/* RTK_BATCH=off renders one camera ray at a time through li even where
 * the integrator has li_batch: the images must be equal, bit for bit. */
static int batches_wanted(void)
{
    const char *e = getenv("RTK_BATCH");
    if (!e || !*e || strcmp(e, "on") == 0)
        return 1;
    if (strcmp(e, "off") == 0)
        return 0;
    rtk_warn_once("RTK_BATCH unknown", "RTK_BATCH=%s is neither on nor off; batches stay on", e);
    return 1;
}

static void render_tile(render_job *job, uint32_t index, rtk_ctx *ctx, sample_batch *batch, uint64_t *bad)
{
    uint32_t tx = index % job->tiles_x, ty = index / job->tiles_x;
    uint32_t x0 = tx * TILE_SIZE, y0 = ty * TILE_SIZE;
    uint32_t x1 = x0 + TILE_SIZE < job->film.width ? x0 + TILE_SIZE : job->film.width;
    uint32_t y1 = y0 + TILE_SIZE < job->film.height ? y0 + TILE_SIZE : job->film.height;
    rtk_film_tile tile;
    rtk_status st = rtk_film_tile_init(&tile, &job->film, x0, y0, x1, y1, job->radius);
    if (st != RTK_OK) {
        fail(job, st);
        return;
    }
    uint32_t n = 0;
    for (uint32_t y = y0; y < y1; y++) {
        for (uint32_t x = x0; x < x1; x++) {
            for (uint32_t s = 0; s < job->spp; s++) {
                float fx, fy, fw;
                rtk_ray ray = start_sample(job, ctx, x, y, s, &fx, &fy, &fw);
                if (!batch) {
                    rtk_li_result r;
                    init_result(&r);
                    job->integrator->li(job->istate, ctx, &ray, &r);
                    add_sample(job, &tile, (int)x, (int)y, fx, fy, fw, &r, bad);
                    continue;
                }
                rtk_ctx_save_sample(ctx, &batch->state[n]);
                batch->rays[n] = ray;
                init_result(&batch->out[n]);
                batch->fx[n] = fx, batch->fy[n] = fy, batch->fw[n] = fw;
                batch->px[n] = (int)x, batch->py[n] = (int)y;
                if (++n == RTK_BATCH_MAX) {
                    flush_batch(job, ctx, batch, n, &tile, bad);
                    n = 0;
                }
            }
        }
    }
    if (n)
        flush_batch(job, ctx, batch, n, &tile, bad);
    pthread_mutex_lock(&job->merge_lock);
    job->pending[index] = tile;
    tile_done(job, index);
    merge_tiles(job);
    pthread_mutex_unlock(&job->merge_lock);
    atomic_fetch_add(&job->tiles_done, 1);
}

static void *worker(void *arg)
{
    render_job *job = arg;
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = job->scene;
    ctx.camera = &job->camera;
    rtk_ctx_set_sampler(&ctx, job->sampler, job->seed, job->spp);
    sample_batch *batch = NULL;
    device_batch *dbatch = NULL;
    rtk_film_tile *tiles = NULL;
    if (job->on_device && (!(dbatch = malloc(sizeof *dbatch)) || !(tiles = calloc(job->device_run, sizeof *tiles)))) {
        free(dbatch);
        fail(job, rtk_error(RTK_ERR_NOMEM, "out of memory for a device batch of %u camera samples", DEVICE_BATCH));
        return NULL;
    }
    if (job->batches && !job->on_device && !(batch = malloc(sizeof *batch))) {
        fail(job, rtk_error(RTK_ERR_NOMEM, "out of memory for a batch of %u camera samples", RTK_BATCH_MAX));
        return NULL;
    }
    uint64_t bad = 0;
    for (;;) {
        uint32_t step = job->on_device ? job->device_run : 1;
        uint32_t i = atomic_fetch_add(&job->next_tile, step);
        if (i >= job->tile_count || atomic_load(&job->failed))
            break;
        if (job->on_device)
            render_tiles_on_device(job, i, i + step < job->tile_count ? i + step : job->tile_count, &ctx, dbatch,
                                   tiles, &bad);
        else
            render_tile(job, i, &ctx, batch, &bad);
    }
    free(batch);
    free(dbatch);
    free(tiles);
    pthread_mutex_lock(&job->merge_lock);
    job->rays += ctx.rays;
    job->invalid_rays += ctx.invalid_rays;
    job->bad_samples += bad;
    pthread_mutex_unlock(&job->merge_lock);
    return NULL;
}

static void draw_progress(uint32_t done, uint32_t total, double elapsed)
{
    int width = 40;
    int filled = total ? (int)((uint64_t)done * (uint64_t)width / total) : width;
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[width] = '\0';
    double eta = done ? elapsed * (double)(total - done) / (double)done : 0.0;
    fprintf(stderr, "\rrender [%s] %3u%%  %.1f s, %.1f s left ", bar, total ? 100u * done / total : 100u, elapsed, eta);
    fflush(stderr);
}

/* Frees the merge's state and the tiles a failed render left pending. */
static void free_merge(render_job *job)
{
    if (job->pending && job->state)
        for (uint32_t i = 0; i < job->tile_count; i++)
            if (job->state[i] == TILE_PENDING)
                rtk_film_tile_free(&job->pending[i]);
    free(job->pending);
    free(job->state);
    free(job->waits_on);
    free(job->queue);
    job->pending = NULL, job->state = NULL, job->waits_on = NULL, job->queue = NULL;
}

/* Renders job->film on threads; main thread draws the progress bar. */
static rtk_status run_workers(render_job *job, uint32_t threads, int progress)
{
    pthread_t *ids = rtk_calloc(threads, sizeof *ids);
    job->pending = rtk_calloc(job->tile_count, sizeof *job->pending);
    job->state = rtk_calloc(job->tile_count, 1);
    job->waits_on = rtk_calloc(job->tile_count, sizeof *job->waits_on);
    job->queue = rtk_calloc(job->tile_count, sizeof *job->queue);
    if (!ids || !job->pending || !job->state || !job->waits_on || !job->queue) {
        free(ids);
        free_merge(job);
        return RTK_ERR_NOMEM;
    }
    init_merge(job);
    uint32_t started = 0;
    for (; started < threads; started++)
        if (pthread_create(&ids[started], NULL, worker, job) != 0)
            break;
    if (started == 0) {
        free(ids);
        return rtk_error(RTK_ERR_NOMEM, "cannot start render threads");
    }
    double t0 = rtk_now();
    if (progress) {
        while (atomic_load(&job->tiles_done) < job->tile_count && !atomic_load(&job->failed)) {
            draw_progress(atomic_load(&job->tiles_done), job->tile_count, rtk_now() - t0);
            struct timespec ts = {0, 100 * 1000 * 1000};
            nanosleep(&ts, NULL);
        }
    }
    for (uint32_t i = 0; i < started; i++)
        pthread_join(ids[i], NULL);
    if (progress) {
        draw_progress(atomic_load(&job->tiles_done), job->tile_count, rtk_now() - t0);
        fputc('\n', stderr);
    }
    free(ids);
    free_merge(job);
    if (job->status != RTK_OK)
        return rtk_error(job->status, "%s", job->error);
    return RTK_OK;
}

rtk_status rtk_render_film(const rtk_film_render *r, float *pixels, rtk_render_stats *stats)
{
    render_job job;
    memset(&job, 0, sizeof job);
    pthread_mutex_init(&job.merge_lock, NULL);
    job.radius = r->filter->radius(r->filter_state);
    rtk_status st = RTK_OK;
    if (!(job.radius > 0.0f && job.radius <= 64.0f)) {
        st = rtk_error(RTK_ERR_PLUGIN, "filter reports radius %g, expected (0, 64]", job.radius);
        goto done;
    }
    job.recon = r->reconstruction;
    if (job.recon == RTK_RECON_IMPORTANCE &&
        (st = rtk_filter_sampler_init(&job.fsampler, r->filter, r->filter_state, job.radius)) != RTK_OK)
        goto done;
    /* Negative lobes (and importance sampling, whose weights f / pdf take
     * the sign of f) can cancel a pixel's weights: keep |weight| sums. */
    st = rtk_film_init(&job.film, r->camera->width, r->camera->height, RTK_FILM_CHANNELS,
                       rtk_filter_has_negative_lobes(r->filter, r->filter_state, job.radius), r->threads);
    if (st != RTK_OK)
        goto done;
    job.scene = r->scene;
    job.camera = *r->camera;
    job.integrator = r->integrator;
    job.batches = batch_fn(r->integrator) && !r->one_ray_at_a_time && batches_wanted();
    job.on_device = r->device_program != NULL;
    if (job.on_device) {
        job.program = *r->device_program;
        job.footprints = rtk_device_reads_footprints(r->scene);
        uint64_t per_tile = (uint64_t)TILE_SIZE * TILE_SIZE * (r->spp ? r->spp : 1);
        job.device_run = per_tile < DEVICE_BATCH ? (uint32_t)(DEVICE_BATCH / per_tile) : 1;
    }
    job.istate = r->integrator_state;
    job.filter = r->filter;
    job.fstate = r->filter_state;
    job.spp = r->spp;
    job.sampler = r->sampler;
    job.seed = r->seed;
    job.tiles_x = (r->camera->width + TILE_SIZE - 1) / TILE_SIZE;
    job.tiles_y = (r->camera->height + TILE_SIZE - 1) / TILE_SIZE;
    job.tile_count = job.tiles_x * job.tiles_y;
    st = run_workers(&job, r->threads ? r->threads : 1, r->progress);
    if (st != RTK_OK)
        goto done;
    rtk_film_resolve(&job.film, pixels, r->threads);
    if (stats) {
        stats->rays = job.rays;
        stats->invalid_rays = job.invalid_rays;
        stats->bad_samples = job.bad_samples;
    }
done:
    rtk_film_free(&job.film);
    rtk_filter_sampler_free(&job.fsampler);
    pthread_mutex_destroy(&job.merge_lock);
    return st;
}

/* 1 when the caller's report (of report->size bytes) has field: the struct
 * only grows at the end. */
#define REPORT_HAS(report, field) ((report)->size >= offsetof(rtk_render_report, field) + sizeof (report)->field)

static int has_extension(const char *path, const char *ext)
{
    const char *dot = strrchr(path, '.');
    return dot && strcasecmp(dot, ext) == 0;
}

/* Prefixes the current error with context. */
static rtk_status with_context(rtk_status st, const char *what)
{
    char msg[2048];
    snprintf(msg, sizeof msg, "%s", rtk_error_message());
    return rtk_error(st, "%s: %s", what, msg);
}

/* Images the scene and its meshes refer to, and how many were decoded
 * (each file once: glTF meshes share their file's textures). */
static void count_textures(const rtk_scene *s, uint32_t *total, uint32_t *decoded)
{
    *total = *decoded = 0;
    for (uint32_t m = 0; m <= s->mesh_count; m++) {
        const rtk_scene *x = m == 0 ? s : s->meshes[m - 1];
        if (m > 0 && x->owner)
            continue;
        for (uint32_t i = 0; i < x->texture_count; i++) {
            ++*total;
            *decoded += x->textures[i].decoded && !x->textures[i].missing;
        }
    }
}

/* What one rtk_render call has made so far; render_state_free frees it
 * whichever phase failed. */
typedef struct render_state {
    const rtk_config *cfg;
    rtk_render_report *report;
    int progress;
    rtk_sampler_type sampler;
    uint32_t threads;
    const rtk_integrator_fns *ifn;
    const rtk_filter_fns *ffn;
    void *istate, *fstate;
    rtk_scene *scene;
    rtk_camera camera;
    float *pixels; /* RTK_FILM_CHANNELS per pixel, then the written channels in place */
    rtk_render_stats stats;
} render_state;

/* Config errors that need nothing loaded, so a bad film.output or sampler
 * never costs a load or a render. */
static rtk_status phase_check(render_state *rs)
{
    const rtk_config *cfg = rs->cfg;
    int want_aovs = cfg->aov_albedo || cfg->aov_normal || cfg->aov_depth;
    if (want_aovs && !has_extension(cfg->output, ".exr"))
        return rtk_error(RTK_ERR_INVALID, "%s: film.aovs needs an EXR output (film.output = \"%s\"): use a .exr name",
                         cfg->path, cfg->output);
    int out_channels = 3 + 3 * (cfg->aov_albedo != 0) + 3 * (cfg->aov_normal != 0) + (cfg->aov_depth != 0);
    rtk_status out_st = rtk_image_check_output(cfg->output, (int)cfg->width, (int)cfg->height, out_channels);
    if (out_st != RTK_OK) {
        char where[1100];
        snprintf(where, sizeof where, "%s: film.output (-o)", cfg->path);
        return with_context(out_st, where);
    }
    rs->sampler = RTK_SAMPLER_INDEPENDENT;
    if (cfg->sampler_type && !rtk_sampler_type_from_name(cfg->sampler_type, &rs->sampler))
        return rtk_error(RTK_ERR_INVALID, "%s: sampler.type = \"%s\": expected independent, stratified or sobol",
                         cfg->path, cfg->sampler_type);
    if (rs->sampler == RTK_SAMPLER_SOBOL && (cfg->spp & (cfg->spp - 1)) != 0) {
        uint32_t below = 1;
        while (below <= cfg->spp / 2)
            below *= 2;
        char key[1100];
        snprintf(key, sizeof key, "sobol spp %u %s", cfg->spp, cfg->path);
        rtk_warn_once(key,
                      "%s: sampler.type = \"sobol\" with film.spp = %u, not a power of two: only whole "
                      "power-of-two runs of a pixel's samples are stratified nets; use %u or %u",
                      cfg->path, cfg->spp, below, below * 2);
    }
    return RTK_OK;
}

/* Scene, instance and texture counts of the loaded scene. */
static void report_scene(rtk_render_report *report, const rtk_scene *scene)
{
    report->triangles = scene->triangle_count;
    if (REPORT_HAS(report, instance_bytes)) {
        report->instances = scene->instance_count;
        report->meshes = scene->mesh_count;
        report->placed_triangles = 0;
        for (uint32_t i = 0; i < scene->instance_count; i++)
            report->placed_triangles += scene->meshes[scene->instances[i].mesh]->triangle_count;
        for (uint32_t i = 0; i < scene->mesh_count; i++)
            report->triangles += scene->meshes[i]->triangle_count;
    }
    if (REPORT_HAS(report, textures_decoded))
        count_textures(scene, &report->textures, &report->textures_decoded);
}

/* Creates the integrator and the filter, then loads the scene (keeping what
 * the integrator needs) with the config's lights, instances and texture filter. */
static rtk_status phase_load(render_state *rs)
{
    const rtk_config *cfg = rs->cfg;
    rs->ifn = cfg->integrator.plugin->functions;
    rs->ffn = cfg->filter.plugin->functions;
    rtk_status st = rs->ifn->create(cfg->integrator.params, &rs->istate);
    if (st != RTK_OK) {
        rs->istate = NULL;
        return with_context(st, cfg->integrator.plugin->name);
    }
    st = rs->ffn->create(cfg->filter.params, &rs->fstate);
    if (st != RTK_OK) {
        rs->fstate = NULL;
        return with_context(st, cfg->filter.plugin->name);
    }
    rs->threads = cfg->threads ? cfg->threads : rtk_core_count();

    double t = rtk_now();
    uint32_t needs = rs->ifn->needs(rs->istate);
    rtk_interrupt_phase("loading the scene", cfg->output);
    st = rtk_config_load_scene(cfg, needs, &rs->scene);
    for (uint32_t i = 0; st == RTK_OK && i < cfg->light_count; i++)
        st = rtk_scene_add_punctual(rs->scene, &cfg->lights[i]);
    if (st == RTK_OK && cfg->instance_count)
        st = rtk_config_place_instances(cfg, rs->scene);
    if (st == RTK_OK)
        st = rtk_scene_set_texture_filter(rs->scene, cfg->texture_filter);
    if (st != RTK_OK)
        return st;
    rs->report->load_seconds = rtk_now() - t;
    report_scene(rs->report, rs->scene);
    return RTK_OK;
}

/* Keeps the BVH cache within cache_limit, sparing the trees used or saved
 * since build_start. */
static void prune_cache(const rtk_config *cfg, struct timespec build_start)
{
    /* Less two seconds, for file times from a coarse clock (a tick behind)
     * or stored in whole seconds (two on FAT). */
    build_start.tv_sec -= 2;
    uint64_t freed = 0;
    uint32_t removed = rtk_bvh_cache_prune(cfg->cache_dir, cfg->cache_limit, build_start, &freed);
    if (removed)
        rtk_log(RTK_LOG_INFO, "BVH cache %s: removed %u old file%s (%.1f MB) to stay within cache_limit = %llu MB",
                cfg->cache_dir, removed, removed == 1 ? "" : "s", (double)freed / (1024.0 * 1024.0),
                (unsigned long long)(cfg->cache_limit >> 20));
}

/* BVH size, depth, cache file and memory of the built scene. */
static void report_bvh(rtk_render_report *report, const rtk_scene *scene, const rtk_bvh_cache_use *cache)
{
    if (REPORT_HAS(report, bvh_cache_file)) {
        report->bvh_from_cache = cache->from_cache;
        snprintf(report->bvh_cache_file, sizeof report->bvh_cache_file, "%s", cache->file);
    }
    report->bvh_nodes = scene->node_count;
    report->bvh_depth = scene->bvh_depth;
    if (REPORT_HAS(report, instance_bytes)) {
        for (uint32_t i = 0; i < scene->mesh_count; i++) {
            report->bvh_nodes += scene->meshes[i]->node_count;
            if (scene->meshes[i]->bvh_depth + scene->tlas_depth + 1 > report->bvh_depth)
                report->bvh_depth = scene->meshes[i]->bvh_depth + scene->tlas_depth + 1;
        }
        report->bvh_nodes += scene->tlas_node_count;
        rtk_scene_memory(scene, &report->geometry_bytes, &report->bvh_bytes, &report->instance_bytes);
    }
}

/* Builds the BVH through the cache (or loads it from there), then prunes
 * the cache. */
static rtk_status phase_build(render_state *rs)
{
    const rtk_config *cfg = rs->cfg;
    double t = rtk_now();
    rtk_interrupt_phase("building the BVH", cfg->output);
    struct timespec build_start;
    clock_gettime(CLOCK_REALTIME, &build_start);
    rtk_bvh_cache_use cache;
    rtk_status st = rtk_bvh_build_cached(rs->scene, cfg->accelerator.plugin, cfg->accelerator.params, rs->threads,
                                         cfg->cache_dir, &cache);
    if (st != RTK_OK)
        return st;
    rs->report->build_seconds = rtk_now() - t;
    if (cfg->cache_dir && cfg->cache_limit)
        prune_cache(cfg, build_start);
    report_bvh(rs->report, rs->scene, &cache);
    return RTK_OK;
}

/* The camera (the config's, else the file's, else one framing the scene),
 * the integrator's prepare over the built scene, and the film's pixels. */
static rtk_status phase_prepare(render_state *rs)
{
    const rtk_config *cfg = rs->cfg;
    rtk_camera_desc cam;
    if (cfg->has_camera)
        cam = cfg->camera;
    else if (rs->scene->has_camera)
        cam = rs->scene->camera;
    else
        cam = rtk_camera_frame(rs->scene->bounds, 39.3f, (float)cfg->width / (float)cfg->height);
    rtk_status st = rtk_camera_init(&rs->camera, &cam, cfg->width, cfg->height);
    if (st != RTK_OK)
        return with_context(st, cfg->path);
    if (rs->ifn->prepare) {
        st = rs->ifn->prepare(rs->istate, rs->scene);
        if (st != RTK_OK)
            return with_context(st, cfg->integrator.plugin->name);
    }
    rs->pixels = rtk_alloc((size_t)cfg->width * cfg->height * RTK_FILM_CHANNELS * sizeof(float));
    return rs->pixels ? RTK_OK : RTK_ERR_NOMEM;
}

/* The integrator's device program when the scene's device runs it (it
 * then shades whole samples), else NULL, saying why in the log. */
static const rtk_device_program *device_program(const render_state *rs, rtk_device_program *program)
{
    const rtk_integrator_fns *f = rs->ifn;
    if (!rs->scene->device)
        return NULL;
    const char *name = rs->cfg->integrator.plugin->name;
    int has = f->size >= offsetof(rtk_integrator_fns, device_program) + sizeof f->device_program &&
              f->device_program && f->device_program(rs->istate, program);
    if (!has) {
        rtk_log(RTK_LOG_INFO, "integrator '%s' (with these parameters) has no device program: it shades on the CPU "
                "and the device traces its batches", name);
        return NULL;
    }
    program->name[sizeof program->name - 1] = '\0';
    const char *why = rtk_device_runs(rs->scene, program);
    if (why) {
        rtk_log(RTK_LOG_INFO, "device program '%s' of integrator '%s' stays on the CPU (%s): the device traces its "
                "batches", program->name, name, why);
        return NULL;
    }
    return program;
}

/* Renders the film on the thread pool and reports its rays and mean. */
static rtk_status phase_render(render_state *rs)
{
    const rtk_config *cfg = rs->cfg;
    rtk_render_report *report = rs->report;
    double t = rtk_now();
    rtk_interrupt_phase("rendering", cfg->output);
    rtk_film_render job = RTK_FILM_RENDER_DEFAULTS;
    job.scene = rs->scene;
    job.camera = &rs->camera;
    job.integrator = rs->ifn;
    job.integrator_state = rs->istate;
    job.filter = rs->ffn;
    job.filter_state = rs->fstate;
    job.spp = cfg->spp;
    job.sampler = rs->sampler;
    job.reconstruction = cfg->importance ? RTK_RECON_IMPORTANCE : RTK_RECON_SPLAT;
    job.seed = cfg->seed;
    job.threads = rs->threads;
    job.progress = rs->progress;
    rtk_device_program program;
    job.device_program = device_program(rs, &program);
    rtk_status st = rtk_render_film(&job, rs->pixels, &rs->stats);
    if (st != RTK_OK)
        return with_context(st, cfg->path);
    report->render_seconds = rtk_now() - t;
    if (REPORT_HAS(report, device)) {
        report->device.size = sizeof report->device;
        report->on_device = rtk_device_report_of(rs->scene, &report->device);
    }
    report->rays = rs->stats.rays;
    report->invalid_rays = rs->stats.invalid_rays;
    report->bad_samples = rs->stats.bad_samples;
    report->width = cfg->width;
    report->height = cfg->height;
    report->spp = cfg->spp;
    report->threads = rs->threads;

    size_t npix = (size_t)cfg->width * cfg->height;
    double mean[3] = {0, 0, 0};
    for (size_t i = 0; i < npix; i++)
        for (int c = 0; c < 3; c++)
            mean[c] += rs->pixels[i * RTK_FILM_CHANNELS + c];
    for (int c = 0; c < 3; c++)
        report->mean[c] = npix ? mean[c] / (double)npix : 0.0;
    return RTK_OK;
}

/* Keeps only the channels the config writes (RGB, then its AOVs), in place;
 * returns how many, named in names. */
static int keep_channels(const rtk_config *cfg, float *pixels, const char *names[10])
{
    int keep[10] = {0, 1, 2};
    int nch = 3;
    names[0] = "R", names[1] = "G", names[2] = "B";
    if (cfg->aov_albedo) {
        names[nch] = "albedo.R", keep[nch++] = 3;
        names[nch] = "albedo.G", keep[nch++] = 4;
        names[nch] = "albedo.B", keep[nch++] = 5;
    }
    if (cfg->aov_normal) {
        names[nch] = "normal.X", keep[nch++] = 6;
        names[nch] = "normal.Y", keep[nch++] = 7;
        names[nch] = "normal.Z", keep[nch++] = 8;
    }
    if (cfg->aov_depth)
        names[nch] = "Z", keep[nch++] = 9;
    size_t npix = (size_t)cfg->width * cfg->height;
    for (size_t i = 0; i < npix; i++)
        for (int c = 0; c < nch; c++)
            pixels[i * (size_t)nch + (size_t)c] = pixels[i * RTK_FILM_CHANNELS + (size_t)keep[c]];
    return nch;
}

/* Writes the image atomically and warns of the samples and rays the
 * render dropped. */
static rtk_status phase_write(render_state *rs)
{
    const rtk_config *cfg = rs->cfg;
    const char *names[10];
    int nch = keep_channels(cfg, rs->pixels, names);
    double t = rtk_now();
    rtk_interrupt_phase("writing the image", cfg->output);
    rtk_status st = rtk_image_write(cfg->output, (int)cfg->width, (int)cfg->height, nch, names, rs->pixels, cfg->half);
    rtk_interrupt_phase(NULL, NULL);
    if (st != RTK_OK)
        return st;
    rs->report->write_seconds = rtk_now() - t;
    snprintf(rs->report->output, sizeof rs->report->output, "%s", cfg->output);
    if (rs->stats.bad_samples)
        rtk_log(RTK_LOG_WARN, "%llu NaN/Inf samples from integrator '%s' were dropped",
                (unsigned long long)rs->stats.bad_samples, cfg->integrator.plugin->name);
    if (rs->stats.invalid_rays)
        rtk_log(RTK_LOG_WARN, "%llu invalid rays (NaN, zero direction or empty interval) were rejected",
                (unsigned long long)rs->stats.invalid_rays);
    return RTK_OK;
}

/* Ends the interrupt phase, reports peak memory and frees what the phases made. */
static void render_state_free(render_state *rs)
{
    rtk_interrupt_phase(NULL, NULL);
    rs->report->peak_rss_bytes = rtk_peak_rss();
    free(rs->pixels);
    if (rs->istate)
        rs->ifn->destroy(rs->istate);
    if (rs->fstate)
        rs->ffn->destroy(rs->fstate);
    rtk_scene_free(rs->scene);
}

RTK_API rtk_status rtk_render(const rtk_config *cfg, const rtk_render_options *options, rtk_render_report *report)
{
    uint32_t report_size = report->size ? report->size : (uint32_t)sizeof *report;
    memset(report, 0, report_size < sizeof *report ? report_size : sizeof *report);
    report->size = report_size;
    render_state rs;
    memset(&rs, 0, sizeof rs);
    rs.cfg = cfg;
    rs.report = report;
    rs.progress = options && options->progress && !options->quiet;

    rtk_status st = phase_check(&rs);
    if (st != RTK_OK)
        return st; /* nothing made yet and no phase announced */
    st = phase_load(&rs);
    if (st == RTK_OK)
        st = phase_build(&rs);
    if (st == RTK_OK)
        st = phase_prepare(&rs);
    if (st == RTK_OK)
        st = phase_render(&rs);
    if (st == RTK_OK)
        st = phase_write(&rs);
    render_state_free(&rs);
    return st;
}

RTK_API void rtk_render_report_print(const rtk_render_report *r, FILE *f)
{
    double total = r->render_seconds > 0.0 ? r->render_seconds : 1e-9;
    int has_memory = REPORT_HAS(r, instance_bytes);
    fprintf(f, "load    %8.3f s   %u triangles", r->load_seconds, r->triangles);
    if (has_memory && r->instances)
        fprintf(f, "; %u instance%s of %u mesh%s place %llu triangles", r->instances, r->instances == 1 ? "" : "s",
                r->meshes, r->meshes == 1 ? "" : "es", (unsigned long long)r->placed_triangles);
    if (REPORT_HAS(r, textures_decoded) && r->textures)
        fprintf(f, "; %u of %u textures decoded", r->textures_decoded, r->textures);
    fputc('\n', f);
    const char *cache = "";
    if (REPORT_HAS(r, bvh_cache_file) && r->bvh_cache_file[0])
        cache = r->bvh_from_cache ? "from cache " : "saved to cache ";
    fprintf(f, "build   %8.3f s   %u nodes, depth %u", r->build_seconds, r->bvh_nodes, r->bvh_depth);
    if (cache[0])
        fprintf(f, " (%s%.1023s)", cache, r->bvh_cache_file);
    fputc('\n', f);
    fprintf(f, "render  %8.3f s   %ux%u, %u spp, %u thread%s\n", r->render_seconds, r->width, r->height, r->spp,
            r->threads, r->threads == 1 ? "" : "s");
    fprintf(f, "write   %8.3f s   %s\n", r->write_seconds, r->output);
    fprintf(f, "rays    %llu (%.2f Mrays/s), %llu invalid, %llu NaN/Inf samples dropped\n",
            (unsigned long long)r->rays, (double)r->rays / total * 1e-6, (unsigned long long)r->invalid_rays,
            (unsigned long long)r->bad_samples);
    if (REPORT_HAS(r, device) && r->on_device) {
        const rtk_device_report *d = &r->device;
        double busy = d->trace_seconds + d->shade_seconds;
        fprintf(f, "device  %8.3f s   %.127s: upload %.3f s, trace %.3f s, shade %.3f s, download %.3f s; %llu rays "
                "in %llu batches", d->upload_seconds + busy + d->download_seconds, d->device, d->upload_seconds,
                d->trace_seconds, d->shade_seconds, d->download_seconds, (unsigned long long)d->rays,
                (unsigned long long)d->batches);
        if (busy > 0.0)
            fprintf(f, " (%.1f Mrays/s on the device)", (double)d->rays / busy * 1e-6);
        if (d->samples)
            fprintf(f, "; %llu samples shaded by the integrator's device program", (unsigned long long)d->samples);
        fprintf(f, "; %.1f MiB device memory", (double)d->device_bytes / (1024.0 * 1024.0));
        if (d->cpu_rays)
            fprintf(f, "; %llu rays on the CPU after a device failure", (unsigned long long)d->cpu_rays);
        fputc('\n', f);
    }
    fprintf(f, "mean    %.6f %.6f %.6f (linear RGB)\n", r->mean[0], r->mean[1], r->mean[2]);
    const double mib = 1024.0 * 1024.0;
    fprintf(f, "memory  %.1f MiB peak", (double)r->peak_rss_bytes / mib);
    if (has_memory)
        fprintf(f, "; geometry %.1f MiB, BVH %.1f MiB, instances %.2f MiB", (double)r->geometry_bytes / mib,
                (double)r->bvh_bytes / mib, (double)r->instance_bytes / mib);
    fputc('\n', f);
}
