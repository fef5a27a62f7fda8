/* `rtk bench`: accelerators compared on the standard recipe
 * (docs/bench-vs-embree.md). The
 * mesh, camera, primary and AO rays are made exactly as the recipe says
 * (double precision, no FMA contraction: this file is compiled with
 * -ffp-contract=off), so every tracer traces bit-identical primary rays
 * and its counts can be checked against any other's. Each accelerator is
 * built through the kernel (rtk_bvh_build) and traced through the kernel's
 * path (rtk_bvh_closest / rtk_bvh_any), which hands the rays to a plugin's
 * own traversal when it has one (embree). Builds and passes both run in
 * rounds, each round over every accelerator at one thread count, so that
 * load from elsewhere on the machine, which drifts over seconds, weighs
 * on all of them alike: for the passes every accelerator's trees are
 * kept at once (rtk_accel_set) and swapped into the scene in turn. */
#include "bench.h"
#include "config/config.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#define BENCH_AO_RAYS 8u
#define BENCH_SEED 1u
/* Untimed builds before the timed ones, in at least two rounds: a
 * process's heap grows to what builds use again over its first few
 * (bunny with lbvh alone: 7 to 9), and until then every build faults
 * its arrays in anew, which would fall on the first thread count's
 * rows alone. */
#define BENCH_WARM_BUILDS 8u

/* ---- the recipe ---- */

static const char *skip_blank(const char *p)
{
    while (*p == ' ' || *p == '\t' || *p == '\r')
        p++;
    return p;
}

static int at_end(const char *p)
{
    return *p == '\0' || *p == '\n' || *p == '#';
}

/* Adds the fan of one face whose corners are idx[0 .. n). */
static rtk_status add_fan(rtk_scene *s, const uint32_t *idx, size_t n)
{
    for (size_t i = 1; i + 1 < n; i++) {
        rtk_status st = rtk_scene_add_triangle(s, idx[0], idx[i], idx[i + 1], NULL, NULL, RTK_INVALID_ID);
        if (st != RTK_OK)
            return st;
    }
    return RTK_OK;
}

rtk_status rtk_bench_read_obj(const char *path, rtk_scene **out)
{
    *out = NULL;
    FILE *f = fopen(path, "r");
    if (!f)
        return rtk_error(RTK_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    rtk_scene *s = rtk_scene_new(path, 0);
    char *line = NULL;
    size_t line_cap = 0, corner_cap = 0;
    uint32_t *corners = NULL;
    unsigned long lineno = 0, short_faces = 0, first_short = 0;
    rtk_status st = s ? RTK_OK : RTK_ERR_NOMEM;
    while (st == RTK_OK && getline(&line, &line_cap, f) >= 0) {
        lineno++;
        const char *p = skip_blank(line);
        if (p[0] == 'v' && (p[1] == ' ' || p[1] == '\t')) {
            float c[3];
            p += 2;
            for (int k = 0; k < 3; k++) {
                char *end;
                c[k] = strtof(p, &end);
                if (end == p) {
                    st = rtk_error(RTK_ERR_PARSE, "%s:%lu: vertex needs three coordinates", path, lineno);
                    break;
                }
                if (!isfinite(c[k])) {
                    st = rtk_error(RTK_ERR_PARSE, "%s:%lu: vertex coordinate is not finite", path, lineno);
                    break;
                }
                p = end;
            }
            if (st == RTK_OK)
                st = rtk_scene_add_vertex(s, c[0], c[1], c[2], NULL);
        } else if (p[0] == 'f' && (p[1] == ' ' || p[1] == '\t')) {
            size_t n = 0;
            p = skip_blank(p + 2);
            while (st == RTK_OK && !at_end(p)) {
                char *end;
                errno = 0;
                long v = strtol(p, &end, 10);
                if (end == p || (*end != '/' && *end != '\0' && !isspace((unsigned char)*end))) {
                    st = rtk_error(RTK_ERR_PARSE, "%s:%lu: bad vertex reference '%.*s'", path, lineno,
                                   (int)strcspn(p, " \t\r\n"), p);
                    break;
                }
                long count = (long)s->vertex_count;
                long idx = v > 0 ? v - 1 : count + v;
                if (v == 0 || errno == ERANGE || idx < 0 || idx >= count) {
                    st = rtk_error(RTK_ERR_PARSE, "%s:%lu: vertex index %ld is out of range (%ld vertices so far)",
                                   path, lineno, v, count);
                    break;
                }
                if (n == corner_cap) {
                    size_t cap = corner_cap ? 2 * corner_cap : 16;
                    uint32_t *grown = rtk_realloc_array(corners, cap, sizeof *corners);
                    if (!grown) {
                        st = RTK_ERR_NOMEM;
                        break;
                    }
                    corners = grown, corner_cap = cap;
                }
                corners[n++] = (uint32_t)idx;
                /* The texture and normal references are not used. */
                while (*end && !isspace((unsigned char)*end))
                    end++;
                p = skip_blank(end);
            }
            /* A face of one or two vertices fans into nothing, as in the
             * recipe (the showroom has 720 of them); counted and reported. */
            if (st == RTK_OK && n < 3 && short_faces++ == 0)
                first_short = lineno;
            if (st == RTK_OK)
                st = add_fan(s, corners, n);
        }
    }
    if (st == RTK_OK && ferror(f))
        st = rtk_error(RTK_ERR_IO, "%s: read error", path);
    if (st == RTK_OK && s->triangle_count == 0)
        st = rtk_error(RTK_ERR_PARSE, "%s: no triangles", path);
    if (st == RTK_OK && short_faces)
        rtk_log(RTK_LOG_WARN, "%s:%lu: %lu face%s with fewer than 3 vertices gave no triangles", path, first_short,
                short_faces, short_faces == 1 ? "" : "s");
    free(line);
    free(corners);
    fclose(f);
    if (st != RTK_OK) {
        rtk_scene_free(s);
        return st;
    }
    rtk_bounds b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    for (uint32_t i = 0; i < s->vertex_count; i++) {
        const float *v = s->positions + 3 * (size_t)i;
        b.lower = rtk_vec3_make(fminf(b.lower.x, v[0]), fminf(b.lower.y, v[1]), fminf(b.lower.z, v[2]));
        b.upper = rtk_vec3_make(fmaxf(b.upper.x, v[0]), fmaxf(b.upper.y, v[1]), fmaxf(b.upper.z, v[2]));
    }
    s->bounds = b;
    *out = s;
    return RTK_OK;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    memcpy(out, c, sizeof c);
}

/* v / |v|; returns |v|. */
static double normalize3(double v[3])
{
    double len = sqrt(dot3(v, v));
    v[0] = v[0] / len, v[1] = v[1] / len, v[2] = v[2] / len;
    return len;
}

double rtk_bench_diag(rtk_bounds b)
{
    double d[3] = {(double)b.upper.x - b.lower.x, (double)b.upper.y - b.lower.y, (double)b.upper.z - b.lower.z};
    return sqrt(dot3(d, d));
}

/* Right and up from fwd and the world up; 0 when they are parallel. */
static int camera_basis(rtk_bench_camera *cam, const double world_up[3], double fov_deg)
{
    cross3(cam->fwd, world_up, cam->right);
    if (normalize3(cam->right) == 0.0 || !isfinite(cam->right[0]))
        return 0;
    cross3(cam->right, cam->fwd, cam->up);
    cam->th = tan(0.5 * fov_deg * M_PI / 180.0);
    return 1;
}

void rtk_bench_camera_recipe(rtk_bounds b, rtk_bench_camera *cam)
{
    const double lo[3] = {b.lower.x, b.lower.y, b.lower.z}, hi[3] = {b.upper.x, b.upper.y, b.upper.z};
    const double world_up[3] = {0.0, 1.0, 0.0};
    double diag = rtk_bench_diag(b);
    double d[3] = {1.0, 0.6, 1.4};
    normalize3(d);
    for (int k = 0; k < 3; k++) {
        double c = (lo[k] + hi[k]) * 0.5;
        cam->eye[k] = c + 1.6 * diag * d[k];
        cam->fwd[k] = -d[k];
    }
    camera_basis(cam, world_up, 45.0);
}

rtk_status rtk_bench_camera_look(const double eye[3], const double look_at[3], const double up[3], double fov_deg,
                                 rtk_bench_camera *cam)
{
    for (int k = 0; k < 3; k++) {
        if (!isfinite(eye[k]) || !isfinite(look_at[k]) || !isfinite(up[k]))
            return rtk_error(RTK_ERR_INVALID, "camera: eye, look-at and up must be finite");
        cam->eye[k] = eye[k];
        cam->fwd[k] = look_at[k] - eye[k];
    }
    if (!(fov_deg > 0.0 && fov_deg < 180.0))
        return rtk_error(RTK_ERR_INVALID, "camera: field of view %g is not in (0, 180) degrees", fov_deg);
    if (normalize3(cam->fwd) == 0.0)
        return rtk_error(RTK_ERR_INVALID, "camera: eye and look-at are the same point");
    if (!camera_basis(cam, up, fov_deg))
        return rtk_error(RTK_ERR_INVALID, "camera: the view direction is parallel to up (%g, %g, %g)", up[0], up[1],
                         up[2]);
    return RTK_OK;
}

void rtk_bench_primary_rays(const rtk_bench_camera *cam, uint32_t width, uint32_t height, rtk_ray *rays)
{
    double aspect = (double)width / (double)height;
    rtk_vec3 org = rtk_vec3_make((float)cam->eye[0], (float)cam->eye[1], (float)cam->eye[2]);
    for (uint32_t y = 0; y < height; y++) {
        double sy = (1.0 - 2.0 * (y + 0.5) / height) * cam->th;
        for (uint32_t x = 0; x < width; x++) {
            double sx = (2.0 * (x + 0.5) / width - 1.0) * cam->th * aspect;
            double d[3];
            for (int k = 0; k < 3; k++)
                d[k] = cam->fwd[k] + sx * cam->right[k] + sy * cam->up[k];
            normalize3(d);
            rtk_ray *r = &rays[(size_t)y * width + x];
            r->org = org;
            r->dir = rtk_vec3_make((float)d[0], (float)d[1], (float)d[2]);
            r->tmin = 0.0f;
            r->tmax = INFINITY;
        }
    }
}

uint64_t rtk_bench_ray_hash(const rtk_ray *rays, size_t count)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < count; i++) {
        const float f[6] = {rays[i].org.x, rays[i].org.y, rays[i].org.z, rays[i].dir.x, rays[i].dir.y, rays[i].dir.z};
        for (int k = 0; k < 6; k++) {
            uint32_t bits;
            memcpy(&bits, &f[k], sizeof bits);
            for (int b = 0; b < 4; b++) {
                h ^= (bits >> (8 * b)) & 0xffu; /* little-endian byte order */
                h *= 0x100000001b3ull;
            }
        }
    }
    return h;
}

void rtk_bench_ao_rays(const rtk_scene *s, const rtk_ray *primary, const rtk_hit *hit, uint64_t pixel, double diag,
                       uint32_t k, rtk_ray *out)
{
    const double org[3] = {primary->org.x, primary->org.y, primary->org.z};
    const double dir[3] = {primary->dir.x, primary->dir.y, primary->dir.z};
    double t = hit->t, p[3], e1[3], e2[3], n[3];
    rtk_vec3 v0, v1, v2;
    if (hit->inst != RTK_INVALID_ID)
        rtk_instance_triangle(s, hit->inst, hit->prim, &v0, &v1, &v2); /* the normal's sign is fixed below */
    else
        rtk_scene_triangle(s, hit->prim, &v0, &v1, &v2);
    const double a0[3] = {v0.x, v0.y, v0.z}, a1[3] = {v1.x, v1.y, v1.z}, a2[3] = {v2.x, v2.y, v2.z};
    for (int i = 0; i < 3; i++) {
        p[i] = org[i] + t * dir[i];
        e1[i] = a1[i] - a0[i];
        e2[i] = a2[i] - a0[i];
    }
    cross3(e1, e2, n);
    if (sqrt(dot3(n, n)) == 0.0)
        n[0] = -dir[0], n[1] = -dir[1], n[2] = -dir[2];
    else
        normalize3(n);
    if (dot3(n, dir) > 0.0)
        n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
    /* Duff et al. 2017, "Building an orthonormal basis, revisited". */
    double sign = copysign(1.0, n[2]);
    double a = -1.0 / (sign + n[2]);
    double b = n[0] * n[1] * a;
    const double b1[3] = {1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
    const double b2[3] = {b, sign + n[1] * n[1] * a, -n[1]};
    double offset = 1e-4 * diag;
    rtk_vec3 o = rtk_vec3_make((float)(p[0] + offset * n[0]), (float)(p[1] + offset * n[1]),
                               (float)(p[2] + offset * n[2]));
    float tfar = (float)(0.1 * diag);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, BENCH_SEED, pixel);
    for (uint32_t j = 0; j < k; j++) {
        double u1 = (double)(rtk_pcg32_next(&rng) >> 8) * 0x1p-24;
        double u2 = (double)(rtk_pcg32_next(&rng) >> 8) * 0x1p-24;
        double r = sqrt(u1), phi = 2.0 * M_PI * u2, h = sqrt(1.0 - u1);
        double d[3];
        for (int i = 0; i < 3; i++)
            d[i] = r * cos(phi) * b1[i] + r * sin(phi) * b2[i] + h * n[i];
        out[j].org = o;
        out[j].dir = rtk_vec3_make((float)d[0], (float)d[1], (float)d[2]);
        out[j].tmin = 0.0f;
        out[j].tmax = tfar;
    }
}

/* ---- tracing passes ---- */

/* One pass over rows of rays; threads take rows from next_row. */
typedef struct bench_pass {
    const rtk_scene *scene;
    const rtk_ray *rays;
    const size_t *row_start; /* row y holds rays [row_start[y], row_start[y + 1]) */
    uint32_t rows;
    int closest;             /* 1: closest hit into hits; 0: occlusion */
    int batch;               /* 1: each row as one batch (rtk_bvh_closest_batch / rtk_bvh_any_batch) */
    rtk_hit *hits;
    uint8_t *occluded;       /* batch occlusion: one per ray */
    uint64_t *row_count;     /* per row: hits (closest) or unoccluded rays (any) */
    atomic_uint next_row;
} bench_pass;

/* One worker of a pass and the CPU time it used. */
typedef struct pass_thread {
    bench_pass *pass;
    double cpu_seconds;
    uint64_t packet_rays;    /* rays its batches traced in packets, origin groups or streams */
} pass_thread;

static double cpu_now(clockid_t clock)
{
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void *pass_worker(void *arg)
{
    pass_thread *t = arg;
    bench_pass *p = t->pass;
    double c0 = cpu_now(CLOCK_THREAD_CPUTIME_ID);
    const uint64_t packed = rtk_wide_packet_rays();
    for (;;) {
        uint32_t y = atomic_fetch_add(&p->next_row, 1u);
        if (y >= p->rows)
            break;
        uint64_t count = 0;
        const size_t first = p->row_start[y], n = p->row_start[y + 1] - first;
        if (p->batch && p->closest) {
            rtk_bvh_closest_batch(p->scene, p->rays + first, (uint32_t)n, p->hits + first);
            for (size_t i = first; i < first + n; i++)
                count += p->hits[i].prim != RTK_INVALID_ID;
        } else if (p->batch) {
            rtk_bvh_any_batch(p->scene, p->rays + first, (uint32_t)n, p->occluded + first);
            for (size_t i = first; i < first + n; i++)
                count += !p->occluded[i];
        } else if (p->closest) {
            for (size_t i = p->row_start[y]; i < p->row_start[y + 1]; i++)
                count += (uint64_t)rtk_bvh_closest(p->scene, &p->rays[i], &p->hits[i]);
        } else {
            for (size_t i = p->row_start[y]; i < p->row_start[y + 1]; i++)
                count += (uint64_t)!rtk_bvh_any(p->scene, &p->rays[i]);
        }
        p->row_count[y] = count;
    }
    t->cpu_seconds = cpu_now(CLOCK_THREAD_CPUTIME_ID) - c0;
    t->packet_rays = rtk_wide_packet_rays() - packed;
    return NULL;
}

/* Runs the pass on threads (the calling thread is one of them); returns
 * its wall-clock seconds, the CPU seconds its threads used in *cpu (which
 * time-sharing with other processes does not inflate) and the summed
 * count in *count, or -1. */
static double run_pass(bench_pass *p, uint32_t threads, uint64_t *count, double *cpu, uint64_t *packet_rays)
{
    pthread_t ids[1024];
    pass_thread work[1024];
    uint32_t started = 0;
    atomic_store(&p->next_row, 0u);
    for (uint32_t i = 0; i < threads; i++)
        work[i] = (pass_thread){p, 0.0, 0};
    double t0 = rtk_now();
    for (uint32_t i = 1; i < threads; i++) {
        if (pthread_create(&ids[started], NULL, pass_worker, &work[i]) != 0)
            break;
        started++;
    }
    pass_worker(&work[0]);
    for (uint32_t i = 0; i < started; i++)
        pthread_join(ids[i], NULL);
    double seconds = rtk_now() - t0;
    *cpu = 0.0;
    if (packet_rays)
        *packet_rays = 0;
    for (uint32_t i = 0; i <= started; i++) {
        *cpu += work[i].cpu_seconds;
        if (packet_rays)
            *packet_rays += work[i].packet_rays;
    }
    if (started + 1 < threads) {
        rtk_error(RTK_ERR_NOMEM, "bench: could start only %u of %u threads", started + 1, threads);
        return -1.0;
    }
    uint64_t sum = 0;
    for (uint32_t y = 0; y < p->rows; y++)
        sum += p->row_count[y];
    *count = sum;
    return seconds;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, uint32_t n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* ---- the benchmark ---- */

/* One accelerator to measure. */
typedef struct bench_accel {
    char label[128];          /* as asked for: "embree:quality=low" */
    const rtk_plugin *plugin;
    rtk_params *params;       /* owned unless borrowed */
    int borrowed;             /* params belong to the config */
} bench_accel;

/* Measurements of one accelerator at one thread count. */
typedef struct bench_row {
    const bench_accel *accel;
    uint32_t threads;
    double build_ms, primary_ms, ao_ms;    /* wall clock */
    double build_cpu_ms;                   /* CPU time of the whole process during the build */
    double primary_cpu_ms, ao_cpu_ms;      /* CPU time of the tracing threads */
    double primary_batch_ms, ao_batch_ms;  /* the same rays, each image row one batch (wall clock) */
    double primary_batch_cpu_ms, ao_batch_cpu_ms;
    /* Of a batch pass, rays the kernel traced in packets, origin groups or streams. */
    uint64_t primary_packet_rays, ao_packet_rays;
    uint64_t primary_hits, ao_rays, ao_unoccluded;
    int has_tree;             /* kernel nodes exist: the statistics below are valid */
    uint32_t nodes, leaves, depth;
    double sah_cost;
    size_t memory;            /* bytes of the binary tree's nodes and leaf-order ids */
    size_t wide_memory;       /* bytes of the 8-wide tree the kernel traverses, 0 if none */
    const char *traversal;    /* "avx2", "sse", "scalar", "binary", "own" or "device" */
    int done;                 /* measured: in the report */
    /* A device accelerator: its batch passes trace each pass's rays in one
     * call; the traversal's own time (the device's report) besides. */
    int on_device;
    char device[128];
    double upload_ms;                         /* the tree to the device, in the build */
    double primary_traced_ms, ao_traced_ms;   /* median of the passes' traversal time on the device */
    uint64_t device_bytes, cpu_rays;          /* device memory; rays the CPU traced after a device failure */
} bench_row;

/* With --verbose: one row's build phases over its runs, merged by name
 * (a name marked more than once in a build, as an instanced scene's
 * meshes do, adds up). */
typedef struct bench_phases {
    const char *names[RTK_BUILD_LOG_MAX];
    int parallel[RTK_BUILD_LOG_MAX]; /* 1 several threads, 0 one, -1 not known, 2 mixed */
    uint32_t count;
    double *seconds;                 /* phase k, round i at k * runs + i */
    double *serial, *unknown;        /* per round: seconds in phases on one thread, and not known */
    uint32_t dropped;                /* marks past what a build log keeps */
} bench_phases;

/* AO rays made from one set of primary hits, shared by every tracer whose
 * hits are the same (prim, instance and the bits of t: what the rays are
 * made from), so that rtk's builders, which agree to the bit, hold one
 * copy between them. */
typedef struct ao_rays {
    rtk_hit *hits;            /* the hits they came from, one per pixel */
    rtk_ray *rays;
    size_t *rows;             /* image row y holds rays [rows[y], rows[y + 1]) */
    size_t count;
    uint8_t *occluded;        /* a batch pass's answers, one per ray */
} ao_rays;

/* Everything one run needs, freed by bench_free. */
typedef struct bench {
    rtk_bench_options opt;
    rtk_config *config;
    rtk_scene *scene;
    bench_accel *accels;
    size_t accel_count;
    uint32_t *threads;
    size_t thread_count;
    uint32_t width, height;
    rtk_bench_camera cam;
    double diag;
    rtk_ray *primary;
    rtk_hit *hits;
    rtk_hit *batch_hits;      /* the primary rays' hits through batches, checked against hits */
    size_t *primary_rows;
    uint64_t *row_count;
    double *times, *cpu_times;            /* one thread count's passes: accelerator a, round i at a * runs + i */
    double *traced;                       /* the same passes' traversal seconds on a device (batch passes) */
    size_t whole[2];                      /* a device's batch pass: one "row" of every ray */
    double *build_times, *build_cpu;      /* every row's builds: row r, round i at r * runs + i */
    bench_row *rows;
    bench_phases *phases;                 /* per row with --verbose, else NULL */
    size_t rows_done;
    uint64_t hash;
} bench;

static void bench_free(bench *b)
{
    for (size_t i = 0; i < b->accel_count; i++)
        if (!b->accels[i].borrowed)
            rtk_params_destroy(b->accels[i].params);
    free(b->accels);
    free(b->threads);
    free(b->primary);
    free(b->hits);
    free(b->batch_hits);
    free(b->primary_rows);
    free(b->row_count);
    free(b->times);
    free(b->cpu_times);
    free(b->traced);
    free(b->build_times);
    free(b->build_cpu);
    free(b->rows);
    for (size_t r = 0; b->phases && r < b->accel_count * b->thread_count; r++) {
        free(b->phases[r].seconds);
        free(b->phases[r].serial);
        free(b->phases[r].unknown);
    }
    free(b->phases);
    rtk_scene_free(b->scene);
    rtk_config_destroy(b->config);
}

static int has_suffix(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcasecmp(s + n - m, suffix) == 0;
}

/* Parses "name[:key=value]..." into a, with the plugin's defaults for the rest. */
static rtk_status parse_accel(rtk_registry *reg, const char *spec, bench_accel *a)
{
    char name[128];
    size_t len = strcspn(spec, ":");
    if (len == 0 || len >= sizeof name || strlen(spec) >= sizeof a->label)
        return rtk_error(RTK_ERR_INVALID, "bench: bad accelerator '%s' (expected NAME or NAME:KEY=VALUE:...)", spec);
    memcpy(name, spec, len);
    name[len] = '\0';
    snprintf(a->label, sizeof a->label, "%s", spec);
    rtk_status st = rtk_registry_find(reg, RTK_KIND_ACCELERATOR, name, &a->plugin);
    if (st != RTK_OK)
        return st;
    a->params = rtk_params_defaults(a->plugin);
    if (!a->params)
        return RTK_ERR_NOMEM;
    const char *p = spec + len;
    while (*p == ':') {
        p++;
        size_t n = strcspn(p, ":");
        char setting[256], *eq;
        snprintf(setting, sizeof setting, "%.*s", (int)n, p);
        eq = strchr(setting, '=');
        if (!eq)
            return rtk_error(RTK_ERR_INVALID, "bench: accelerator '%s': '%s' is not KEY=VALUE", spec, setting);
        *eq = '\0';
        st = rtk_params_set_text(a->params, setting, eq + 1);
        if (st != RTK_OK) {
            char msg[1024];
            snprintf(msg, sizeof msg, "%s", rtk_error_message());
            return rtk_error(st, "bench: accelerator '%s': %s", spec, msg);
        }
        p += n;
    }
    return RTK_OK;
}

static rtk_status choose_accels(bench *b, rtk_registry *reg)
{
    const rtk_bench_options *o = &b->opt;
    size_t n = o->accelerator_count;
    if (o->accelerators && n > 0) {
        b->accels = rtk_calloc(n, sizeof *b->accels);
        if (!b->accels)
            return RTK_ERR_NOMEM;
        for (size_t i = 0; i < n; i++) {
            rtk_status st = parse_accel(reg, o->accelerators[i], &b->accels[b->accel_count]);
            b->accel_count++;
            if (st != RTK_OK)
                return st;
        }
        return RTK_OK;
    }
    if (b->config) {
        b->accels = rtk_calloc(1, sizeof *b->accels);
        if (!b->accels)
            return RTK_ERR_NOMEM;
        bench_accel *a = &b->accels[b->accel_count++];
        a->plugin = b->config->accelerator.plugin;
        a->params = b->config->accelerator.params;
        a->borrowed = 1;
        snprintf(a->label, sizeof a->label, "%s", a->plugin->name);
        return RTK_OK;
    }
    size_t total = rtk_registry_count(reg);
    b->accels = rtk_calloc(total ? total : 1, sizeof *b->accels);
    if (!b->accels)
        return RTK_ERR_NOMEM;
    for (size_t i = 0; i < total; i++) {
        const rtk_plugin_info *info = rtk_registry_at(reg, i);
        if (!info->plugin || info->problem || info->plugin->kind != RTK_KIND_ACCELERATOR)
            continue;
        bench_accel *a = &b->accels[b->accel_count];
        rtk_status st = parse_accel(reg, info->plugin->name, a);
        b->accel_count++;
        if (st != RTK_OK)
            return st;
        /* Asked for by name it would fail the bench; among all, it is left out. */
        if (rtk_accelerator_is_device(a->plugin) && rtk_device_probe(a->plugin, a->params) != RTK_OK) {
            rtk_log(RTK_LOG_WARN, "bench: leaving out accelerator '%s': %s", a->label, rtk_error_message());
            rtk_params_destroy(a->params);
            memset(a, 0, sizeof *a);
            b->accel_count--;
        }
    }
    if (b->accel_count == 0)
        return rtk_error(RTK_ERR_PLUGIN, "bench: no accelerator plugins found (see `rtk plugins`)");
    return RTK_OK;
}

static rtk_status choose_threads(bench *b)
{
    const rtk_bench_options *o = &b->opt;
    if (o->threads && o->threads_count > 0) {
        b->threads = rtk_calloc(o->threads_count, sizeof *b->threads);
        if (!b->threads)
            return RTK_ERR_NOMEM;
        for (size_t i = 0; i < o->threads_count; i++) {
            if (o->threads[i] < 1 || o->threads[i] > 1024)
                return rtk_error(RTK_ERR_INVALID, "bench: %u threads is not in [1, 1024]", o->threads[i]);
            b->threads[b->thread_count++] = o->threads[i];
        }
        return RTK_OK;
    }
    uint32_t cores = rtk_core_count();
    if (b->config && b->config->threads)
        cores = b->config->threads;
    b->threads = rtk_calloc(2, sizeof *b->threads);
    if (!b->threads)
        return RTK_ERR_NOMEM;
    b->threads[b->thread_count++] = 1;
    if (cores > 1)
        b->threads[b->thread_count++] = cores > 1024 ? 1024 : cores;
    return RTK_OK;
}

static rtk_status load_scene(bench *b, const char *path, rtk_registry *reg)
{
    const char *mesh = path;
    if (has_suffix(path, ".cfg")) {
        rtk_config_options co;
        memset(&co, 0, sizeof co);
        co.size = sizeof co;
        co.allow_config_plugins = b->opt.allow_config_plugins;
        co.allow_outside_files = b->opt.allow_outside_files;
        co.oversubscribe = b->opt.oversubscribe;
        rtk_status st = rtk_config_load(path, reg, &co, &b->config);
        if (st != RTK_OK)
            return st;
        mesh = b->config->scene_path;
    }
    rtk_status st;
    if (has_suffix(mesh, ".obj")) {
        st = rtk_bench_read_obj(mesh, &b->scene);
    } else {
        /* glTF: the kernel's loader, which drops zero-area triangles; a
         * config's scene reads files as rendering it would. */
        st = b->config ? rtk_config_load_scene(b->config, 0, &b->scene) : rtk_scene_load(mesh, 0, &b->scene);
    }
    if (st == RTK_OK && b->config && b->config->instance_count)
        st = rtk_config_place_instances(b->config, b->scene);
    if (st != RTK_OK)
        return st;
    if (b->scene->triangle_count == 0 && b->scene->instance_count == 0)
        return rtk_error(RTK_ERR_INVALID, "%s: no triangles", mesh);
    return RTK_OK;
}

static rtk_status setup_camera(bench *b)
{
    const rtk_bench_options *o = &b->opt;
    const double world_up[3] = {0.0, 1.0, 0.0};
    if (o->has_camera)
        return rtk_bench_camera_look(o->eye, o->look_at, world_up, o->fov_deg, &b->cam);
    if (b->config && b->config->has_camera) {
        const rtk_camera_desc *c = &b->config->camera;
        const double eye[3] = {c->position.x, c->position.y, c->position.z};
        const double at[3] = {c->look_at.x, c->look_at.y, c->look_at.z};
        const double up[3] = {c->up.x, c->up.y, c->up.z};
        return rtk_bench_camera_look(eye, at, up, c->fov_deg, &b->cam);
    }
    rtk_bench_camera_recipe(b->scene->bounds, &b->cam);
    return RTK_OK;
}

static void progress(const bench *b, const bench_accel *a, uint32_t threads, const char *what, uint32_t i,
                     uint32_t n)
{
    if (!b->opt.progress)
        return;
    fprintf(stderr, "\r\033[Kbench: %s, %u thread%s: %s %u/%u", a->label, threads, threads == 1 ? "" : "s", what, i,
            n);
    fflush(stderr);
}

/* Node, leaf, depth, SAH cost (c_node = c_tri = 1, relative to the root's
 * area) and memory of the kernel tree the scene holds. An instanced scene:
 * nodes and leaves of every level (each mesh once), depth through the top
 * level, memory of every tree and the instance records, no SAH cost (the
 * levels' costs do not add up to one figure). */
static void instanced_stats(const rtk_scene *s, bench_row *row)
{
    row->traversal = "two-level";
    row->has_tree = 1;
    uint32_t leaves = 0, nodes = s->node_count + s->tlas_node_count, depth = s->bvh_depth;
    for (uint32_t i = 0; i < s->tlas_node_count; i++)
        leaves += s->tlas_nodes[i].count > 0;
    for (uint32_t i = 0; i < s->node_count; i++)
        leaves += s->nodes[i].count > 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const rtk_scene *mesh = s->meshes[m];
        nodes += mesh->node_count;
        for (uint32_t i = 0; i < mesh->node_count; i++)
            leaves += mesh->nodes[i].count > 0;
        if (s->tlas_depth + 1 + mesh->bvh_depth > depth)
            depth = s->tlas_depth + 1 + mesh->bvh_depth;
    }
    row->nodes = nodes;
    row->leaves = leaves;
    row->depth = depth;
    row->sah_cost = NAN;
    size_t geometry, bvh, instances;
    rtk_scene_memory(s, &geometry, &bvh, &instances);
    row->memory = bvh + instances;
}

static void tree_stats(const rtk_scene *s, bench_row *row)
{
    if (s->instance_count) {
        instanced_stats(s, row);
        return;
    }
    row->traversal = s->device                                        ? "device"
                     : s->own_traversal                              ? "own"
                     : s->wide && s->wide->path != RTK_SIMD_BINARY ? rtk_simd_name(s->wide->path)
                                                                    : "binary";
    if (s->wide)
        row->wide_memory = (size_t)s->wide->node_count * sizeof(rtk_wide_node) +
                           (size_t)s->wide->tri_block_count * sizeof(rtk_wide_tris);
    row->has_tree = s->node_count > 0;
    if (!row->has_tree)
        return;
    double root = 0.0, cost = 0.0;
    uint32_t leaves = 0;
    for (uint32_t i = 0; i < s->node_count; i++) {
        const rtk_bvh_node *n = &s->nodes[i];
        double dx = (double)n->upper[0] - n->lower[0], dy = (double)n->upper[1] - n->lower[1],
               dz = (double)n->upper[2] - n->lower[2];
        double area = 2.0 * (dx * dy + dy * dz + dz * dx);
        if (i == 0)
            root = area;
        if (n->count > 0) {
            leaves++;
            cost += area * n->count;
        } else {
            cost += area;
        }
    }
    row->nodes = s->node_count;
    row->leaves = leaves;
    row->depth = s->bvh_depth;
    row->sah_cost = root > 0.0 ? cost / root : NAN;
    row->memory = (size_t)s->node_count * sizeof(rtk_bvh_node) + (size_t)s->triangle_count * sizeof(uint32_t);
}

/* With -v: the kernel's work counters over the same rays, untimed (the
 * figures do not depend on the machine; zero for an own traversal). */
static void log_work(const bench *b, const bench_accel *a, uint32_t threads, const ao_rays *ao)
{
    const size_t n_ao = ao->count;
    const size_t n_primary = (size_t)b->width * b->height;
    uint64_t pn = 0, pt = 0, an = 0, at = 0;
    for (size_t i = 0; i < n_primary; i++) {
        rtk_trace_work w = {0, 0};
        rtk_hit h;
        rtk_bvh_closest_measure(b->scene, &b->primary[i], &h, &w);
        pn += w.nodes, pt += w.triangles;
    }
    for (size_t i = 0; i < n_ao; i++) {
        rtk_trace_work w = {0, 0};
        rtk_bvh_any_measure(b->scene, &ao->rays[i], &w);
        an += w.nodes, at += w.triangles;
    }
    double np = n_primary ? (double)n_primary : 1.0, na = n_ao ? (double)n_ao : 1.0;
    rtk_log(RTK_LOG_DEBUG, "bench: %s, %u threads: work per ray: primary %.3f nodes, %.3f triangles; AO %.3f nodes, "
            "%.3f triangles", a->label, threads, (double)pn / np, (double)pt / np, (double)an / na, (double)at / na);
}

/* One timed build of row's accelerator on row's threads: wall-clock and
 * process CPU seconds into *wall and *cpu, its phases into log (NULL:
 * not recorded). The previous tree is torn down outside the timed span,
 * and the build's log lines (-v) are written after it. */
static rtk_status timed_build(bench *b, const bench_row *row, double *wall, double *cpu, rtk_build_log *log)
{
    rtk_scene *s = b->scene;
    const bench_accel *a = row->accel;
    rtk_bvh_release(s);
    s->build_log = log;
    rtk_log_hold();
    double c0 = cpu_now(CLOCK_PROCESS_CPUTIME_ID), t0 = rtk_now();
    rtk_status st = s->instance_count ? rtk_instances_build(s, a->plugin, a->params, row->threads, NULL, NULL)
                                      : rtk_bvh_build(s, a->plugin, a->params, row->threads);
    *wall = rtk_now() - t0;
    *cpu = cpu_now(CLOCK_PROCESS_CPUTIME_ID) - c0;
    rtk_log_release();
    s->build_log = NULL;
    return st;
}

/* Room for each row's phases over runs rounds. 0 when out of memory. */
static int phases_init(bench *b)
{
    const size_t rows = b->accel_count * b->thread_count, runs = b->opt.runs;
    b->phases = rtk_calloc(rows, sizeof *b->phases);
    if (!b->phases)
        return 0;
    for (size_t r = 0; r < rows; r++) {
        bench_phases *p = &b->phases[r];
        p->seconds = rtk_calloc(RTK_BUILD_LOG_MAX * runs, sizeof *p->seconds);
        p->serial = rtk_calloc(runs, sizeof *p->serial);
        p->unknown = rtk_calloc(runs, sizeof *p->unknown);
        if (!p->seconds || !p->serial || !p->unknown)
            return 0;
    }
    return 1;
}

/* Adds round i's log to p: each phase to the one of its name (a new name
 * gets the next place while there is one, the rest go to the last), its
 * time to the round's serial or not-known sum. */
static void phases_add(bench_phases *p, uint32_t runs, uint32_t i, const rtk_build_log *log)
{
    p->dropped += log->dropped;
    for (uint32_t k = 0; k < log->count; k++) {
        const rtk_build_phase_time *ph = &log->phases[k];
        uint32_t j = 0;
        while (j < p->count && strcmp(p->names[j], ph->name) != 0)
            j++;
        if (j == p->count && p->count < RTK_BUILD_LOG_MAX) {
            p->names[p->count] = ph->name;
            p->parallel[p->count++] = ph->parallel;
        } else if (j == p->count) {
            j = p->count - 1;
        }
        if (p->parallel[j] != ph->parallel)
            p->parallel[j] = 2;
        p->seconds[j * runs + i] += ph->seconds;
        if (ph->parallel == 0)
            p->serial[i] += ph->seconds;
        else if (ph->parallel < 0)
            p->unknown[i] += ph->seconds;
    }
}

/* Untimed rounds of builds before the timed ones: at least two, and at
 * least BENCH_WARM_BUILDS builds. */
static size_t warm_build_rounds(const bench *b)
{
    const size_t rounds = (BENCH_WARM_BUILDS + b->accel_count - 1) / b->accel_count;
    return rounds > 2 ? rounds : 2;
}

/* The builds of every row, in rounds, after untimed warm-up rounds at
 * the first thread count (BENCH_WARM_BUILDS): for each thread count, each round
 * builds once with every accelerator, in order, so that the machine's
 * other load (which drifts over seconds) falls on all of them alike
 * rather than on whichever ran during a busy spell. The thread count
 * changes only between its rounds (Embree's is process-wide: the embree
 * plugin keeps one device and replaces it when the count changes).
 * Median of the rounds. On failure *failed is the row that failed. */
static rtk_status measure_builds(bench *b, size_t *failed)
{
    const uint32_t runs = b->opt.runs;
    const size_t rows = b->accel_count * b->thread_count;
    const size_t warm_rounds = warm_build_rounds(b);
    for (size_t i = 0; i < warm_rounds; i++) {
        for (size_t a = 0; a < b->accel_count; a++) {
            const bench_row *row = &b->rows[a * b->thread_count];
            progress(b, row->accel, row->threads, "warm-up build", (uint32_t)i + 1, (uint32_t)warm_rounds);
            double wall, cpu;
            rtk_status st = timed_build(b, row, &wall, &cpu, NULL);
            if (st != RTK_OK) {
                *failed = a * b->thread_count;
                return st;
            }
        }
    }
    for (size_t t = 0; t < b->thread_count; t++) {
        for (uint32_t i = 0; i < runs; i++) {
            for (size_t a = 0; a < b->accel_count; a++) {
                const size_t r = a * b->thread_count + t;
                bench_row *row = &b->rows[r];
                progress(b, row->accel, row->threads, "build round", i + 1, runs);
                rtk_build_log log;
                memset(&log, 0, sizeof log);
                rtk_status st = timed_build(b, row, &b->build_times[r * runs + i], &b->build_cpu[r * runs + i],
                                            b->phases ? &log : NULL);
                if (st != RTK_OK) {
                    *failed = r;
                    return st;
                }
                if (b->phases)
                    phases_add(&b->phases[r], runs, i, &log);
            }
        }
    }
    rtk_bvh_release(b->scene);
    for (size_t r = 0; r < rows; r++) {
        b->rows[r].build_ms = 1e3 * median(&b->build_times[r * runs], runs);
        b->rows[r].build_cpu_ms = 1e3 * median(&b->build_cpu[r * runs], runs);
    }
    return RTK_OK;
}

/* Whether hits a and b, one per pixel, make the same AO rays. */
static int same_hits(const rtk_hit *a, const rtk_hit *b, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (a[i].prim != b[i].prim || a[i].inst != b[i].inst || memcmp(&a[i].t, &b[i].t, sizeof a[i].t) != 0)
            return 0;
    return 1;
}

static void ao_rays_free(ao_rays *ao)
{
    free(ao->occluded);
    free(ao->hits);
    free(ao->rays);
    free(ao->rows);
}

/* The AO rays of the primary hits in b->hits: an earlier tracer's when
 * its hits were the same, else made here into sets[*count] (untimed).
 * Their index into *which. */
static rtk_status ao_rays_for_hits(bench *b, ao_rays *sets, size_t *count, size_t *which)
{
    const size_t pixels = (size_t)b->width * b->height;
    for (size_t k = 0; k < *count; k++) {
        if (same_hits(sets[k].hits, b->hits, pixels)) {
            *which = k;
            return RTK_OK;
        }
    }
    ao_rays *ao = &sets[*count];
    size_t n = 0;
    for (size_t i = 0; i < pixels; i++)
        n += b->hits[i].prim != RTK_INVALID_ID;
    ao->hits = rtk_alloc_large(sizeof *ao->hits * pixels);
    ao->rays = rtk_alloc_large(sizeof *ao->rays * (n ? n * BENCH_AO_RAYS : 1));
    ao->rows = rtk_alloc(sizeof *ao->rows * ((size_t)b->height + 1));
    ao->occluded = rtk_alloc_large(n ? n * BENCH_AO_RAYS : 1);
    if (!ao->hits || !ao->rays || !ao->rows || !ao->occluded) {
        ao_rays_free(ao);
        memset(ao, 0, sizeof *ao);
        return RTK_ERR_NOMEM;
    }
    memcpy(ao->hits, b->hits, sizeof *ao->hits * pixels);
    size_t n_ao = 0;
    for (uint32_t y = 0; y < b->height; y++) {
        ao->rows[y] = n_ao;
        for (uint32_t x = 0; x < b->width; x++) {
            size_t i = (size_t)y * b->width + x;
            if (b->hits[i].prim == RTK_INVALID_ID)
                continue;
            rtk_bench_ao_rays(b->scene, &b->primary[i], &b->hits[i], i, b->diag, BENCH_AO_RAYS, &ao->rays[n_ao]);
            n_ao += BENCH_AO_RAYS;
        }
    }
    ao->rows[b->height] = n_ao;
    ao->count = n_ao;
    *which = (*count)++;
    return RTK_OK;
}

/* The tracing of one thread count, every accelerator's trees alive at
 * once in sets (swapped into the scene for each pass, the others held
 * aside; builds untimed: the build figures are measure_builds'). */
typedef struct trace_round {
    bench *b;
    size_t t;                 /* the thread count's index */
    rtk_accel_set *sets;      /* per accelerator */
    size_t *ao_of;            /* per accelerator: its AO rays in ao */
    ao_rays *ao;              /* at most one per accelerator */
    size_t ao_count;
} trace_round;

static bench_row *round_row(const trace_round *tr, size_t a)
{
    return &tr->b->rows[a * tr->b->thread_count + tr->t];
}

/* A device's batch pass: every ray of pass p in one call (a GPU wants
 * them all at once, not a row at a time), on the one thread that takes
 * the single row. */
static void whole_pass(bench *b, bench_pass *p)
{
    b->whole[0] = p->row_start[0];
    b->whole[1] = p->row_start[p->rows];
    p->row_start = b->whole;
    p->rows = 1;
}

/* One pass of accelerator a (closest: primary rays, else its AO rays;
 * batch: each row as one batch) into round i's slot; the count must match
 * the warm-up's. */
static rtk_status timed_pass(trace_round *tr, size_t a, int closest, int batch, uint32_t i)
{
    bench *b = tr->b;
    bench_row *row = round_row(tr, a);
    const ao_rays *ao = &tr->ao[tr->ao_of[a]];
    bench_pass p = {.scene = b->scene, .rows = b->height, .closest = closest, .batch = batch,
                    .row_count = b->row_count};
    if (closest)
        p.rays = b->primary, p.row_start = b->primary_rows, p.hits = batch ? b->batch_hits : b->hits;
    else
        p.rays = ao->rays, p.row_start = ao->rows, p.occluded = ao->occluded;
    progress(b, row->accel, row->threads,
             closest ? (batch ? "primary batches" : "primary pass") : (batch ? "AO batches" : "AO pass"), i + 1,
             b->opt.runs);
    const size_t slot = ((size_t)batch * b->accel_count + a) * b->opt.runs + i;
    uint64_t count = 0, packed = 0;
    rtk_accel_swap(b->scene, &tr->sets[a]);
    rtk_device_report before, after;
    before.size = after.size = sizeof before;
    const int device = batch && rtk_device_report_of(b->scene, &before);
    if (device)
        whole_pass(b, &p);
    b->times[slot] = run_pass(&p, row->threads, &count, &b->cpu_times[slot], &packed);
    if (device && rtk_device_report_of(b->scene, &after)) {
        b->traced[slot] = after.trace_seconds - before.trace_seconds;
        row->cpu_rays = after.cpu_rays;
    }
    if (batch)
        *(closest ? &row->primary_packet_rays : &row->ao_packet_rays) = packed;
    rtk_accel_swap(b->scene, &tr->sets[a]);
    if (b->times[slot] < 0.0)
        return RTK_ERR_NOMEM;
    const uint64_t want = closest ? row->primary_hits : row->ao_unoccluded;
    if (count != want)
        return rtk_error(RTK_ERR_PLUGIN, "bench: %s: %s changed between passes (%llu, then %llu)", row->accel->label,
                         closest ? "primary hits" : "unoccluded AO rays", (unsigned long long)want,
                         (unsigned long long)count);
    return RTK_OK;
}

/* Accelerator a's tree, built into the scene and moved to its set; its
 * statistics, warm-up passes (which count its hits and unoccluded rays)
 * and AO rays. */
static rtk_status trace_setup(trace_round *tr, size_t a)
{
    bench *b = tr->b;
    bench_row *row = round_row(tr, a);
    progress(b, row->accel, row->threads, "build for tracing", 1, 1);
    double wall, cpu;
    rtk_status st = rtk_accel_set_init(&tr->sets[a], b->scene);
    if (st == RTK_OK)
        st = timed_build(b, row, &wall, &cpu, NULL);
    if (st != RTK_OK)
        return st;
    tree_stats(b->scene, row);
    rtk_device_report dev;
    dev.size = sizeof dev;
    if ((row->on_device = rtk_device_report_of(b->scene, &dev))) {
        snprintf(row->device, sizeof row->device, "%s", dev.device);
        row->upload_ms = 1e3 * dev.upload_seconds;
        row->device_bytes = dev.device_bytes;
    }
    progress(b, row->accel, row->threads, "primary warm-up", 1, 1);
    bench_pass pp = {.scene = b->scene, .rays = b->primary, .row_start = b->primary_rows, .rows = b->height,
                     .closest = 1, .hits = b->hits, .row_count = b->row_count};
    if (run_pass(&pp, row->threads, &row->primary_hits, &cpu, NULL) < 0.0)
        return RTK_ERR_NOMEM;
    /* The same rays in batches: the same hits, bit for bit. */
    uint64_t batch_hits = 0;
    pp.batch = 1, pp.hits = b->batch_hits;
    if (row->on_device)
        whole_pass(b, &pp);
    if (run_pass(&pp, row->threads, &batch_hits, &cpu, NULL) < 0.0)
        return RTK_ERR_NOMEM;
    for (size_t i = 0; i < (size_t)b->width * b->height; i++) {
        const rtk_hit *h = &b->hits[i], *g = &b->batch_hits[i];
        if (h->prim != g->prim || (h->prim != RTK_INVALID_ID && memcmp(h, g, sizeof *h) != 0))
            return rtk_error(RTK_ERR_PLUGIN, "bench: %s: the primary ray of pixel (%zu, %zu) hits prim %u at t %a "
                             "one at a time but prim %u at t %a in a batch", row->accel->label, i % b->width,
                             i / b->width, h->prim, (double)h->t, g->prim, (double)g->t);
    }
    /* AO rays from this tracer's own hits, made before any timing. */
    if ((st = ao_rays_for_hits(b, tr->ao, &tr->ao_count, &tr->ao_of[a])) != RTK_OK)
        return st;
    const ao_rays *ao = &tr->ao[tr->ao_of[a]];
    row->ao_rays = ao->count;
    progress(b, row->accel, row->threads, "AO warm-up", 1, 1);
    bench_pass ap = {.scene = b->scene, .rays = ao->rays, .row_start = ao->rows, .rows = b->height, .closest = 0,
                     .row_count = b->row_count};
    if (run_pass(&ap, row->threads, &row->ao_unoccluded, &cpu, NULL) < 0.0)
        return RTK_ERR_NOMEM;
    if (rtk_log_enabled(RTK_LOG_DEBUG))
        log_work(b, row->accel, row->threads, ao);
    rtk_accel_swap(b->scene, &tr->sets[a]); /* the scene has no tree again */
    return RTK_OK;
}

/* The passes of thread count t: every accelerator built and warmed up,
 * then runs rounds of primary passes, each round one pass of every
 * accelerator in turn, then as many rounds of AO passes; the median of
 * each accelerator's rounds. On failure *failed is the row that failed. */
static rtk_status measure_traces(bench *b, size_t t, size_t *failed)
{
    const size_t n = b->accel_count;
    const uint32_t runs = b->opt.runs;
    trace_round tr = {.b = b, .t = t};
    tr.sets = rtk_calloc(n, sizeof *tr.sets);
    tr.ao_of = rtk_calloc(n, sizeof *tr.ao_of);
    tr.ao = rtk_calloc(n, sizeof *tr.ao);
    rtk_status st = tr.sets && tr.ao_of && tr.ao ? RTK_OK : RTK_ERR_NOMEM;
    *failed = t;
    for (size_t a = 0; a < n && st == RTK_OK; a++) {
        *failed = a * b->thread_count + t;
        st = trace_setup(&tr, a);
    }
    /* Each round: every accelerator one at a time, then in batches. */
    for (int closest = 1; closest >= 0 && st == RTK_OK; closest--) {
        for (uint32_t i = 0; i < runs && st == RTK_OK; i++)
            for (int batch = 0; batch <= 1 && st == RTK_OK; batch++)
                for (size_t a = 0; a < n && st == RTK_OK; a++) {
                    *failed = a * b->thread_count + t;
                    st = timed_pass(&tr, a, closest, batch, i);
                }
        for (size_t a = 0; a < n && st == RTK_OK; a++) {
            bench_row *row = round_row(&tr, a);
            double ms = 1e3 * median(&b->times[a * runs], runs), cpu_ms = 1e3 * median(&b->cpu_times[a * runs], runs);
            double bms = 1e3 * median(&b->times[(n + a) * runs], runs),
                   bcpu_ms = 1e3 * median(&b->cpu_times[(n + a) * runs], runs);
            const double traced_ms = 1e3 * median(&b->traced[(n + a) * runs], runs);
            *(closest ? &row->primary_traced_ms : &row->ao_traced_ms) = traced_ms;
            if (closest)
                row->primary_ms = ms, row->primary_cpu_ms = cpu_ms, row->primary_batch_ms = bms,
                row->primary_batch_cpu_ms = bcpu_ms;
            else
                row->ao_ms = ms, row->ao_cpu_ms = cpu_ms, row->ao_batch_ms = bms, row->ao_batch_cpu_ms = bcpu_ms,
                row->done = 1;
        }
    }
    rtk_bvh_release(b->scene);
    for (size_t a = 0; tr.sets && a < n; a++)
        rtk_accel_set_free(&tr.sets[a]);
    for (size_t k = 0; k < tr.ao_count; k++)
        ao_rays_free(&tr.ao[k]);
    free(tr.sets);
    free(tr.ao_of);
    free(tr.ao);
    return st;
}

static double mrays(uint64_t rays, double ms)
{
    return ms > 0.0 ? (double)rays / (ms * 1e3) : 0.0;
}

static double mean_ao(const bench_row *r)
{
    return r->ao_rays ? (double)r->ao_unoccluded / (double)r->ao_rays : 0.0;
}

/* Median of n values copied out of v (v keeps its order); tmp holds n. */
static double median_of(const double *v, uint32_t n, double *tmp)
{
    memcpy(tmp, v, sizeof *tmp * n);
    return median(tmp, n);
}

/* With --verbose: each row's build phases (median ms over the rounds,
 * share of the row's median build, where each ran) and, on more than
 * one thread, the serial fraction: the phases' time on one thread over
 * the same accelerator's one-thread build; then the speed-up over that
 * build and the CPU time against its CPU time. */
static void print_phases(const bench *b, FILE *out, int w)
{
    const uint32_t runs = b->opt.runs;
    double *tmp = rtk_alloc(sizeof *tmp * runs);
    if (!tmp)
        return;
    fprintf(out, "\nbuild phases (median ms of %u builds; share of the row's build_ms; threads: where the phase "
            "ran, ? = not known, mixed = one in some marks and several in others)\n", runs);
    for (size_t r = 0; r < b->accel_count * b->thread_count; r++) {
        const bench_row *row = &b->rows[r];
        const bench_phases *p = &b->phases[r];
        if (!row->done)
            continue;
        fprintf(out, "%s, %u thread%s: build %.2f ms\n", row->accel->label, row->threads,
                row->threads == 1 ? "" : "s", row->build_ms);
        double sum = 0.0;
        for (uint32_t k = 0; k < p->count; k++) {
            const double ms = 1e3 * median_of(&p->seconds[k * runs], runs, tmp);
            sum += ms;
            fprintf(out, "  %-*s %9.2f %6.1f%%  %s\n", w + 24, p->names[k], ms,
                    row->build_ms > 0.0 ? 100.0 * ms / row->build_ms : 0.0,
                    p->parallel[k] == 2  ? "mixed"
                    : p->parallel[k] > 0 ? "many"
                    : p->parallel[k] == 0 ? "one"
                                          : "?");
        }
        fprintf(out, "  %-*s %9.2f %6.1f%%\n", w + 24, "(sum of the medians)", sum,
                row->build_ms > 0.0 ? 100.0 * sum / row->build_ms : 0.0);
        if (p->dropped)
            fprintf(out, "  %u marks past the log's %u phases went to the last\n", p->dropped, RTK_BUILD_LOG_MAX);
        if (row->threads == 1)
            continue;
        const bench_row *one = NULL;
        for (size_t j = 0; j < b->thread_count && !one; j++)
            if (b->rows[r - r % b->thread_count + j].threads == 1 && b->rows[r - r % b->thread_count + j].done)
                one = &b->rows[r - r % b->thread_count + j];
        const double serial = 1e3 * median_of(p->serial, runs, tmp), unknown = 1e3 * median_of(p->unknown, runs, tmp);
        if (one && one->build_ms > 0.0)
            fprintf(out, "  serial fraction %.1f%% (%.2f ms on one thread / %.2f ms, the 1-thread build)\n",
                    100.0 * serial / one->build_ms, serial, one->build_ms);
        else
            fprintf(out, "  serial fraction: needs a 1-thread row (--threads 1,...); %.2f ms on one thread\n", serial);
        if (unknown >= 0.005)
            fprintf(out, "  and %.2f ms on threads not known (a builder's unmarked time, an instanced top level)\n",
                    unknown);
        if (one && one->build_ms > 0.0 && row->build_ms > 0.0 && one->build_cpu_ms > 0.0)
            fprintf(out, "  speed-up %.2fx over one thread; CPU time %.2fx the 1-thread build's (%.2f / %.2f ms)\n",
                    one->build_ms / row->build_ms, row->build_cpu_ms / one->build_cpu_ms, row->build_cpu_ms,
                    one->build_cpu_ms);
    }
    free(tmp);
}

/* The first measured embree row with r's threads, or NULL (and for an
 * embree row or one not measured). */
static const bench_row *embree_row(const bench *b, const bench_row *r)
{
    if (!r->done || strcmp(r->accel->plugin->name, "embree") == 0)
        return NULL;
    for (size_t j = 0; j < b->accel_count * b->thread_count; j++)
        if (b->rows[j].done && strcmp(b->rows[j].accel->plugin->name, "embree") == 0 &&
            b->rows[j].threads == r->threads)
            return &b->rows[j];
    return NULL;
}

/* The CPU's model name from /proc/cpuinfo, or "unknown". */
static void cpu_model(char *name, size_t cap)
{
    snprintf(name, cap, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        const char *colon = strchr(line, ':');
        if (strncmp(line, "model name", 10) != 0 || !colon)
            continue;
        colon += 1 + (colon[1] == ' ');
        snprintf(name, cap, "%.*s", (int)strcspn(colon, "\n"), colon);
        break;
    }
    fclose(f);
}

static void print_report(const bench *b, const char *path, FILE *out)
{
    const rtk_scene *s = b->scene;
    const rtk_bench_camera *c = &b->cam;
    uint64_t pixels = (uint64_t)b->width * b->height;
    fprintf(out, "rtk bench: %s\n", path);
    char cpu[256];
    cpu_model(cpu, sizeof cpu);
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    const uint32_t usable = rtk_core_count();
    fprintf(out, "cpu %s, %u core%s this process may use (%ld online)\n", cpu, usable, usable == 1 ? "" : "s", online);
    fprintf(out, "triangles %u, vertices %u, bounds diagonal %.6g\n", s->triangle_count, s->vertex_count, b->diag);
    if (s->instance_count) {
        uint64_t placed = 0;
        for (uint32_t i = 0; i < s->instance_count; i++)
            placed += s->meshes[s->instances[i].mesh]->triangle_count;
        fprintf(out, "instances %u of %u mesh%s, placing %llu triangles (two-level: the accelerator builds each mesh "
                "and the top level)\n", s->instance_count, s->mesh_count, s->mesh_count == 1 ? "" : "es",
                (unsigned long long)placed);
    }
    fprintf(out, "image %ux%u, camera eye (%.6g, %.6g, %.6g) forward (%.6g, %.6g, %.6g), vertical fov %.6g\n",
            b->width, b->height, c->eye[0], c->eye[1], c->eye[2], c->fwd[0], c->fwd[1], c->fwd[2],
            2.0 * atan(c->th) * 180.0 / M_PI);
    fprintf(out, "AO: %u rays per hit, tfar %.6g; median of %u builds (after %zu untimed rounds) and of %u timed "
            "passes of each kind (after one warm-up), both in rounds over every accelerator at each thread count\n",
            BENCH_AO_RAYS, (double)(float)(0.1 * b->diag), b->opt.runs, warm_build_rounds(b), b->opt.runs);
    fprintf(out, "primary_ray_hash 0x%016llx\n\n", (unsigned long long)b->hash);
    int w = 11;
    for (size_t i = 0; i < b->accel_count; i++)
        if ((int)strlen(b->accels[i].label) > w)
            w = (int)strlen(b->accels[i].label);
    fprintf(out, "%-*s %7s %9s %13s %9s %12s %9s %13s %9s %9s\n", w, "accelerator", "threads", "build_ms",
            "primary_mrays", "ao_mrays", "primary_hits", "ao_rays", "ao_unoccluded", "mean_ao", "total_ms");
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i];
        if (!r->done)
            continue;
        fprintf(out, "%-*s %7u %9.2f %13.3f %9.3f %12llu %9llu %13llu %9.6f %9.2f\n", w, r->accel->label,
                r->threads, r->build_ms, mrays(pixels, r->primary_ms), mrays(r->ao_rays, r->ao_ms),
                (unsigned long long)r->primary_hits, (unsigned long long)r->ao_rays,
                (unsigned long long)r->ao_unoccluded, mean_ao(r), r->build_ms + r->primary_ms + r->ao_ms);
    }
    /* The same rays with each image row traced as one batch: the kernel's
     * packets, origin groups and streams, or an accelerator's own batch functions
     * (embree: its packets of 8 or 16 consecutive rays). */
    fprintf(out, "\nbatches: each image row's rays in one call (rtk_bvh_closest_batch / rtk_bvh_any_batch), the same "
            "hits; Mrays/s wall clock; speed-up against one ray at a time per CPU-second of the tracing threads; "
            "packets: share of the rays rtk's kernel traced in packets, origin groups or streams\n");
    fprintf(out, "%-*s %7s %13s %13s %8s %8s %9s %9s %8s %8s\n", w, "accelerator", "threads", "primary_mrays",
            "primary_batch", "speed-up", "packets", "ao_mrays", "ao_batch", "speed-up", "packets");
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i];
        if (!r->done)
            continue;
        fprintf(out, "%-*s %7u %13.3f %13.3f %7.3fx %7.1f%% %9.3f %9.3f %7.3fx %7.1f%%\n", w, r->accel->label,
                r->threads, mrays(pixels, r->primary_ms), mrays(pixels, r->primary_batch_ms),
                r->primary_cpu_ms / r->primary_batch_cpu_ms, 100.0 * (double)r->primary_packet_rays / (double)pixels,
                mrays(r->ao_rays, r->ao_ms), mrays(r->ao_rays, r->ao_batch_ms), r->ao_cpu_ms / r->ao_batch_cpu_ms,
                r->ao_rays ? 100.0 * (double)r->ao_packet_rays / (double)r->ao_rays : 0.0);
    }
    /* Device accelerators: end to end (rays there, hits back) and the
     * traversal alone, as the device timed it. */
    int header = 0;
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i];
        if (!r->done || !r->on_device)
            continue;
        if (!header) {
            fprintf(out, "\non a device: each batch pass's rays in one call; Mrays/s end to end (wall clock, the "
                         "transfers included) and of the traversal alone (the device's own timing); single rays "
                         "above are the kernel's, on the CPU\n");
            fprintf(out, "%-*s %7s %13s %14s %9s %10s %9s %9s %9s  %s\n", w, "accelerator", "threads",
                    "primary_batch", "primary_traced", "ao_batch", "ao_traced", "upload_ms", "device_MB", "cpu_rays",
                    "device");
            header = 1;
        }
        fprintf(out, "%-*s %7u %13.3f %14.3f %9.3f %10.3f %9.2f %9.1f %9llu  %s\n", w, r->accel->label, r->threads,
                mrays(pixels, r->primary_batch_ms), mrays(pixels, r->primary_traced_ms),
                mrays(r->ao_rays, r->ao_batch_ms), mrays(r->ao_rays, r->ao_traced_ms), r->upload_ms,
                (double)r->device_bytes / (1024.0 * 1024.0), (unsigned long long)r->cpu_rays, r->device);
    }
    /* CPU time is what the machine's other load does not inflate: tracing
     * rates per CPU-second of the tracing threads, build in process CPU. */
    fprintf(out, "\n%-*s %7s %9s %9s %5s %8s %9s %7s %9s %12s %14s %11s\n", w, "accelerator", "threads", "nodes",
            "leaves", "depth", "sah_cost", "memory_MB", "wide_MB", "traversal", "build_cpu_ms", "primary_cpu_mr",
            "ao_cpu_mr");
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i];
        if (!r->done)
            continue;
        fprintf(out, "%-*s %7u", w, r->accel->label, r->threads);
        if (r->has_tree)
            fprintf(out, " %9u %9u %5u %8.2f %9.2f", r->nodes, r->leaves, r->depth, r->sah_cost,
                    (double)r->memory / (1024.0 * 1024.0));
        else
            fprintf(out, " %9s %9s %5s %8s %9s", "-", "-", "-", "-", "-");
        if (r->wide_memory)
            fprintf(out, " %7.2f", (double)r->wide_memory / (1024.0 * 1024.0));
        else
            fprintf(out, " %7s", "-");
        fprintf(out, " %9s %12.2f %14.3f %11.3f\n", r->traversal, r->build_cpu_ms, mrays(pixels, r->primary_cpu_ms),
                mrays(r->ao_rays, r->ao_cpu_ms));
    }
    /* Each accelerator against the first embree row with the same threads. */
    header = 0;
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i], *e = embree_row(b, r);
        if (!e)
            continue;
        if (!header) {
            fprintf(out, "\nagainst embree at the same threads (speed: >1 is faster than embree; time: <1 is "
                         "faster; cpu: per CPU-second)\n");
            fprintf(out, "%-*s %7s %10s %13s %9s %10s %11s %7s   %s\n", w, "accelerator", "threads", "build_time",
                    "primary_speed", "ao_speed", "total_time", "primary_cpu", "ao_cpu", "versus");
            header = 1;
        }
        fprintf(out, "%-*s %7u %9.3fx %12.3fx %8.3fx %9.3fx %10.3fx %6.3fx   %s\n", w, r->accel->label, r->threads,
                r->build_ms / e->build_ms, e->primary_ms / r->primary_ms, e->ao_ms / r->ao_ms,
                (r->build_ms + r->primary_ms + r->ao_ms) / (e->build_ms + e->primary_ms + e->ao_ms),
                e->primary_cpu_ms / r->primary_cpu_ms, e->ao_cpu_ms / r->ao_cpu_ms, e->accel->label);
    }
    /* Batches against embree's: its packets and its single rays. */
    header = 0;
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i], *e = embree_row(b, r);
        if (!e)
            continue;
        if (!header) {
            fprintf(out, "\nbatches against embree at the same threads, per CPU-second (>1 is faster than embree; "
                         "its batches are its packets)\n");
            fprintf(out, "%-*s %7s %15s %16s %11s %12s   %s\n", w, "accelerator", "threads", "primary_batches",
                    "primary_vs_single", "ao_batches", "ao_vs_single", "versus");
            header = 1;
        }
        fprintf(out, "%-*s %7u %14.3fx %15.3fx %10.3fx %11.3fx   %s\n", w, r->accel->label, r->threads,
                e->primary_batch_cpu_ms / r->primary_batch_cpu_ms, e->primary_cpu_ms / r->primary_batch_cpu_ms,
                e->ao_batch_cpu_ms / r->ao_batch_cpu_ms, e->ao_cpu_ms / r->ao_batch_cpu_ms, e->accel->label);
    }
    if (b->phases)
        print_phases(b, out, w);
}

static void write_csv(const bench *b, const char *path, FILE *f)
{
    fprintf(f, "mesh,accelerator,threads,width,height,triangles,build_ms,primary_ms,ao_ms,primary_mrays,ao_mrays,"
               "primary_hits,ao_rays,ao_unoccluded,mean_ao,primary_ray_hash,nodes,leaves,depth,sah_cost,"
               "memory_bytes,wide_memory_bytes,traversal,total_ms,build_cpu_ms,primary_cpu_ms,ao_cpu_ms,"
               "primary_cpu_mrays,ao_cpu_mrays,primary_batch_ms,ao_batch_ms,primary_batch_cpu_ms,ao_batch_cpu_ms,"
               "primary_batch_mrays,ao_batch_mrays,"
               "primary_packet_rays,ao_packet_rays,device,upload_ms,primary_traced_ms,ao_traced_ms,device_bytes,"
               "cpu_rays\n");
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    uint64_t pixels = (uint64_t)b->width * b->height;
    for (size_t i = 0; i < b->accel_count * b->thread_count; i++) {
        const bench_row *r = &b->rows[i];
        if (!r->done)
            continue;
        fprintf(f, "%s,%s,%u,%u,%u,%u,%.4f,%.4f,%.4f,%.4f,%.4f,%llu,%llu,%llu,%.6f,0x%016llx,", base, r->accel->label,
                r->threads, b->width, b->height, b->scene->triangle_count, r->build_ms, r->primary_ms, r->ao_ms,
                mrays(pixels, r->primary_ms), mrays(r->ao_rays, r->ao_ms), (unsigned long long)r->primary_hits,
                (unsigned long long)r->ao_rays, (unsigned long long)r->ao_unoccluded, mean_ao(r),
                (unsigned long long)b->hash);
        if (r->has_tree)
            fprintf(f, "%u,%u,%u,%.4f,%zu,", r->nodes, r->leaves, r->depth, r->sah_cost, r->memory);
        else
            fprintf(f, ",,,,,");
        if (r->wide_memory)
            fprintf(f, "%zu", r->wide_memory);
        fprintf(f, ",%s,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f", r->traversal, r->build_ms + r->primary_ms + r->ao_ms,
                r->build_cpu_ms, r->primary_cpu_ms, r->ao_cpu_ms, mrays(pixels, r->primary_cpu_ms),
                mrays(r->ao_rays, r->ao_cpu_ms));
        fprintf(f, ",%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%llu,%llu", r->primary_batch_ms, r->ao_batch_ms,
                r->primary_batch_cpu_ms, r->ao_batch_cpu_ms, mrays(pixels, r->primary_batch_ms),
                mrays(r->ao_rays, r->ao_batch_ms),
                (unsigned long long)r->primary_packet_rays, (unsigned long long)r->ao_packet_rays);
        /* The device's name is a CSV field: quoted, its quotes doubled. */
        fputs(",\"", f);
        for (const char *c = r->on_device ? r->device : ""; *c; c++)
            fputs(*c == '"' ? "\"\"" : (char[2]){*c, 0}, f);
        fputc('"', f);
        if (r->on_device)
            fprintf(f, ",%.4f,%.4f,%.4f,%llu,%llu\n", r->upload_ms, r->primary_traced_ms, r->ao_traced_ms,
                    (unsigned long long)r->device_bytes, (unsigned long long)r->cpu_rays);
        else
            fprintf(f, ",,,,,\n");
    }
}

rtk_status rtk_bench(const char *path, rtk_registry *registry, const rtk_bench_options *options, FILE *out)
{
    bench b;
    memset(&b, 0, sizeof b);
    if (options)
        memcpy(&b.opt, options, options->size < sizeof b.opt ? options->size : sizeof b.opt);
    b.opt.size = sizeof b.opt;
    if (b.opt.runs == 0)
        b.opt.runs = 5;
    if (b.opt.runs > 1000)
        return rtk_error(RTK_ERR_INVALID, "bench: %u runs is more than 1000", b.opt.runs);
    /* The CSV goes through a temporary file opened now, so that a path
     * that cannot be written fails before minutes of measuring, and an
     * interrupted run leaves no half a table under its name. */
    rtk_out_file csv = {0};
    rtk_status st = b.opt.csv ? rtk_out_open(&csv, b.opt.csv) : RTK_OK;
    if (st == RTK_OK)
        st = load_scene(&b, path, registry);
    if (st == RTK_OK)
        st = choose_accels(&b, registry);
    if (st == RTK_OK)
        st = choose_threads(&b);
    if (st != RTK_OK) {
        rtk_out_close(&csv, 0);
        bench_free(&b);
        return st;
    }
    b.width = b.opt.width ? b.opt.width : b.config ? b.config->width : 1024;
    b.height = b.opt.height ? b.opt.height : b.config ? b.config->height : 768;
    if (b.width > 16384 || b.height > 16384 || (!b.opt.width) != (!b.opt.height)) {
        rtk_out_close(&csv, 0);
        bench_free(&b);
        return rtk_error(RTK_ERR_INVALID, "bench: image %ux%u: give both width and height, at most 16384 each",
                         b.width, b.height);
    }
    b.diag = rtk_bench_diag(b.scene->bounds);
    st = setup_camera(&b);
    size_t pixels = (size_t)b.width * b.height;
    if (st == RTK_OK) {
        b.primary = rtk_alloc_large(sizeof *b.primary * pixels);
        b.hits = rtk_alloc_large(sizeof *b.hits * pixels);
        b.primary_rows = rtk_alloc(sizeof *b.primary_rows * (b.height + 1));
        b.row_count = rtk_alloc(sizeof *b.row_count * b.height);
        b.batch_hits = rtk_alloc_large(sizeof *b.batch_hits * pixels);
        b.times = rtk_alloc(sizeof *b.times * b.opt.runs * 2 * b.accel_count);
        b.cpu_times = rtk_alloc(sizeof *b.cpu_times * b.opt.runs * 2 * b.accel_count);
        b.traced = rtk_calloc((size_t)b.opt.runs * 2 * b.accel_count, sizeof *b.traced);
        b.rows = rtk_calloc(b.accel_count * b.thread_count, sizeof *b.rows);
        b.build_times = rtk_alloc(sizeof *b.build_times * b.opt.runs * b.accel_count * b.thread_count);
        b.build_cpu = rtk_alloc(sizeof *b.build_cpu * b.opt.runs * b.accel_count * b.thread_count);
        if (!b.primary || !b.hits || !b.batch_hits || !b.primary_rows || !b.row_count || !b.times || !b.cpu_times ||
            !b.traced ||
            !b.rows || !b.build_times || !b.build_cpu)
            st = RTK_ERR_NOMEM;
        else if (rtk_log_enabled(RTK_LOG_DEBUG) && !phases_init(&b))
            st = RTK_ERR_NOMEM;
    }
    if (st != RTK_OK) {
        rtk_out_close(&csv, 0);
        bench_free(&b);
        return st;
    }
    rtk_bench_primary_rays(&b.cam, b.width, b.height, b.primary);
    b.hash = rtk_bench_ray_hash(b.primary, pixels);
    for (uint32_t y = 0; y <= b.height; y++)
        b.primary_rows[y] = (size_t)y * b.width;
    /* Rows in the report's order: accelerators, then thread counts. */
    const size_t rows = b.accel_count * b.thread_count;
    for (size_t r = 0; r < rows; r++) {
        b.rows[r].accel = &b.accels[r / b.thread_count];
        b.rows[r].threads = b.threads[r % b.thread_count];
    }
    size_t failed = 0;
    st = measure_builds(&b, &failed);
    for (size_t t = 0; t < b.thread_count && st == RTK_OK; t++)
        st = measure_traces(&b, t, &failed);
    for (size_t r = 0; r < rows; r++)
        b.rows_done += b.rows[r].done;
    if (b.opt.progress)
        fprintf(stderr, "\r\033[K");
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        st = rtk_error(st, "bench: %s: %s", b.rows[failed].accel->label, msg);
    }
    if (b.rows_done > 0)
        print_report(&b, path, out);
    if (b.rows_done > 0 && csv.f)
        write_csv(&b, path, csv.f);
    rtk_status cst = rtk_out_close(&csv, b.rows_done > 0);
    if (st == RTK_OK)
        st = cst;
    bench_free(&b);
    return st;
}
