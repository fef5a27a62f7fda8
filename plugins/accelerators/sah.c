/* sah: top-down BVH build minimising the surface area heuristic. Each node
 * is split where t_node + t_tri * (A_left N_left + A_right N_right) / A is
 * least, or becomes a leaf when t_tri * N costs no more and N <= max_leaf.
 * binned mode bins centroids along each axis (O(n) per node; nodes of at
 * most 8 primitives try every object split instead); sweep mode tries
 * every split of the centroids sorted along each axis (exact SAH, the
 * sorted orders kept through stable partitions: O(n) per tree level).
 * Where no split separates the centroids, or past depth 200, a node is
 * halved by count, so the depth stays within the kernel's 256.
 *
 * Parameters:
 *   bins      int [4, 256]         16      bins per axis (binned mode; a node of n
 *                                          primitives uses min(bins, 4 + n / 20))
 *   mode      string binned|sweep  binned  binned: bin boundaries; sweep: every object split
 *   t_node    float [0.01, 100]    1.0     cost of visiting an inner node
 *   t_tri     float [0.01, 100]    1.0     cost of one ray/triangle test
 *   max_leaf  int [1, 64]          8       primitives per leaf at most
 *
 * Example: accelerator = { plugin = "sah"; bins = 32; max_leaf = 4; };
 *
 * The tree does not depend on thread_count: every node's descendants get
 * slots fixed by the node alone (a node over m primitives owns the 2m - 2
 * slots of its region, its children first), subtrees are built in parallel
 * into those, and a final pass closes the gaps while keeping the order.
 * A subtree under 1024 primitives is built by one thread and fills its
 * region densely from the start, so the gaps are whole pages left
 * untouched rather than holes in every page; the builders record each
 * run of filled slots (a dense subtree, a children pair above them), and
 * closing the gaps moves only those runs. Closed, the slots hold the
 * children pairs in depth-first order, left first: a build on one thread
 * fills them in that order from the root and has no gaps to close. The
 * top of the tree (the team nodes, down to depth 8) is partitioned by
 * fixed chunks, on one thread too, and on threads split a level at a time
 * by the whole team (bins do not depend on how the primitives are
 * divided), as long as a level has fewer than two nodes a thread; a
 * thread without a subtree spins a while for the next before it sleeps,
 * and the runs are moved on the threads, each once the runs whose slots
 * it overwrites have been read.
 */
#include <rtk/rtk.h>

#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Beyond this depth nodes are halved by count, which bounds the depth of
 * any input by this plus 33 levels, within the kernel's 256. */
#define SAH_HALVING_DEPTH 200
/* Largest number of pending nodes one worker holds (>= the depth bound). */
#define SAH_STACK 264
/* Subtrees of at least this many primitives go to the shared queue. */
#define SAH_SPAWN_MIN 1024
/* Nodes of at most this many primitives try every object split. */
#define SAH_SMALL 8
/* Nodes split by a team of threads (team_node), on any number of threads
 * so that the tree does not depend on it: the root of SAH_SPAWN_MIN or
 * more primitives, and the nodes down to depth SAH_TEAM_DEPTH of
 * SAH_TEAM_MIN or more. On threads the queue then starts with subtrees
 * of a few thousand primitives, so that no member waits while a node of
 * a quarter or an eighth of the scene is split on one thread. */
#define SAH_TEAM_DEPTH 8
#define SAH_TEAM_MIN 4096

typedef struct sah {
    int sweep;
    uint32_t bins, max_leaf;
    float t_node, t_tri;
} sah;

/* A primitive's bounds and index, 32 bytes, moved while partitioning. */
typedef struct ref {
    float lo[3];
    uint32_t id;
    float hi[3];
    uint32_t pad;
} ref;

#if defined(__SSE2__)
#include <emmintrin.h>

/* Four floats; lanes 0-2 are x, y, z. */
typedef __m128 v4;

static inline v4 v4_load(const float *p) { return _mm_loadu_ps(p); }
static inline void v4_store(float *p, v4 a) { _mm_storeu_ps(p, a); }
static inline v4 v4_set1(float f) { return _mm_set1_ps(f); }
static inline v4 v4_add(v4 a, v4 b) { return _mm_add_ps(a, b); }
static inline v4 v4_sub(v4 a, v4 b) { return _mm_sub_ps(a, b); }
static inline v4 v4_mul(v4 a, v4 b) { return _mm_mul_ps(a, b); }
/* a < b ? a : b per lane: exact like fminf on the kernel's finite bounds,
 * and NaN in a gives b. */
static inline v4 v4_min(v4 a, v4 b) { return _mm_min_ps(a, b); }
static inline v4 v4_max(v4 a, v4 b) { return _mm_max_ps(a, b); }
/* Truncates the lanes, of which 0-2 hold values in [0, 255] (lane 3 is
 * stored too, and ignored). */
static inline void v4_to_u32(v4 a, uint32_t out[4])
{
    _mm_storeu_si128((__m128i *)(void *)out, _mm_cvttps_epi32(a));
}
#else
typedef struct v4 {
    float f[4];
} v4;

static inline v4 v4_load(const float *p) { v4 r; memcpy(r.f, p, sizeof r.f); return r; }
static inline void v4_store(float *p, v4 a) { memcpy(p, a.f, sizeof a.f); }
static inline v4 v4_set1(float f) { return (v4){{f, f, f, f}}; }
#define V4_LANES(expr) v4 r; for (int k = 0; k < 4; k++) r.f[k] = (expr); return r
static inline v4 v4_add(v4 a, v4 b) { V4_LANES(a.f[k] + b.f[k]); }
static inline v4 v4_sub(v4 a, v4 b) { V4_LANES(a.f[k] - b.f[k]); }
static inline v4 v4_mul(v4 a, v4 b) { V4_LANES(a.f[k] * b.f[k]); }
static inline v4 v4_min(v4 a, v4 b) { V4_LANES(a.f[k] < b.f[k] ? a.f[k] : b.f[k]); }
static inline v4 v4_max(v4 a, v4 b) { V4_LANES(a.f[k] > b.f[k] ? a.f[k] : b.f[k]); }
static inline void v4_to_u32(v4 a, uint32_t out[4]) { for (int k = 0; k < 3; k++) out[k] = (uint32_t)a.f[k]; }
#undef V4_LANES
#endif

/* A ref's lower corner and upper corner as four floats each; lane 3
 * holds the id or padding bits and is ignored. */
static inline v4 ref_lo(const ref *r)
{
    return v4_load((const float *)(const void *)r);
}

static inline v4 ref_hi(const ref *r)
{
    return v4_load((const float *)(const void *)((const char *)r + 16));
}

/* A box; lane 3 is ignored. */
typedef struct vbox {
    v4 lo, hi;
} vbox;

/* A node to build: its slot, primitives [begin, end), the first of the
 * 2 (end - begin) - 2 slots its descendants own, its depth (root 1), its
 * bounds and the bounds of its centroids (doubled: lower + upper). */
typedef struct job {
    vbox geom, cent;
    uint32_t slot, begin, end, region, depth;
    uint32_t dense; /* 1: below a node under SAH_SPAWN_MIN primitives */
} job;

/* Jobs shared between workers; pending counts queued and running ones. */
typedef struct queue {
    pthread_mutex_t lock;
    pthread_cond_t wake;
    job *jobs;
    atomic_uint count, pending; /* changed under lock; read without it while spinning */
} queue;

/* Chosen split: the axis and the first bin (binned) or the first slot
 * (sweep) of the right side; axis -1 when none separates the primitives. */
typedef struct split {
    int axis;
    uint32_t at;
    float cost;
    uint8_t order[SAH_SMALL]; /* small nodes: the slots in order along axis */
} split;

/* A run of slots the tree fills on threads: a children pair above the
 * dense subtrees, or a dense subtree's nodes below its root (dense set);
 * shift: how far closing the gaps moves it down. */
typedef struct segment {
    uint32_t start, len, dense, shift;
} segment;

/* Bins of one node: a box and a count per bin and axis. */
typedef struct binning {
    vbox box[3][256];
    uint32_t count[3][256];
} binning;

/* A team node's split (team_node): the split, the first right slot and
 * the children's bounds. */
typedef struct team_split {
    split s;
    uint32_t mid;
    job sides[2];
} team_split;

struct top_levels;

/* One build: options, arguments, scratch arrays and the queue. */
typedef struct build {
    const sah *opt;
    rtk_build_args *a;
    ref *refs;        /* binned: primitives in slot order */
    const rtk_bounds *bounds; /* sweep: the primitives' boxes */
    uint32_t *ord[3]; /* sweep: primitives sorted by centroid, per axis */
    uint32_t *tmp;    /* sweep: partition scratch */
    float *area;      /* sweep: areas of suffix bounds */
    uint8_t *left;    /* sweep: side of each primitive */
    segment *segs;    /* threads: the runs of slots the tree fills (NULL: one thread) */
    atomic_uint *seg_count; /* how many: the next is taken with an atomic add */
    uint32_t dense_end; /* one thread: the slots the tree fills, [0, dense_end) */
    queue *q;         /* NULL when building on one thread */
    struct top_levels *top; /* threads, binned mode: the team's levels */
    uint32_t *lefts;  /* binned mode from SAH_SPAWN_MIN primitives: split_alone's scratch, */
    uint32_t lefts_stride; /* this many a thread */
} build;

static rtk_status sah_create(const rtk_params *params, void **state)
{
    sah *s = malloc(sizeof *s);
    if (!s)
        return rtk_error(RTK_ERR_NOMEM, "sah: out of memory");
    s->sweep = strcmp(rtk_params_string(params, "mode"), "sweep") == 0;
    s->bins = (uint32_t)rtk_params_int(params, "bins");
    s->max_leaf = (uint32_t)rtk_params_int(params, "max_leaf");
    s->t_node = (float)rtk_params_float(params, "t_node");
    s->t_tri = (float)rtk_params_float(params, "t_tri");
    *state = s;
    return RTK_OK;
}

static inline void box_empty(vbox *b)
{
    b->lo = v4_set1(INFINITY);
    b->hi = v4_set1(-INFINITY);
}

static inline void box_grow(vbox *b, v4 lo, v4 hi)
{
    b->lo = v4_min(b->lo, lo);
    b->hi = v4_max(b->hi, hi);
}

static inline void box_add_point(vbox *b, v4 p)
{
    box_grow(b, p, p);
}

/* Half the surface area of a non-empty box. */
static inline float half_area(const vbox *b)
{
    float d[4];
    v4_store(d, v4_sub(b->hi, b->lo));
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

static v4 bounds_lower(const rtk_bounds *b)
{
    const float f[4] = {b->lower.x, b->lower.y, b->lower.z, 0.0f};
    return v4_load(f);
}

static v4 bounds_upper(const rtk_bounds *b)
{
    const float f[4] = {b->upper.x, b->upper.y, b->upper.z, 0.0f};
    return v4_load(f);
}

/* Primitive i's box: the kernel's when it gives boxes (the instances of
 * a top level), else its triangle's, from the corners with the kernel's
 * operations (rtk_bvh_prepare_inputs), so the same floats either way. A
 * corner is one 4-float load: a float more follows the last vertex. */
static inline rtk_bounds prim_box(const rtk_build_args *a, uint32_t i)
{
    if (a->prim_bounds)
        return a->prim_bounds[i];
    const uint32_t *t = a->indices + 3 * (size_t)i;
    const v4 p = v4_load(a->positions + 3 * (size_t)t[0]), q = v4_load(a->positions + 3 * (size_t)t[1]),
             r = v4_load(a->positions + 3 * (size_t)t[2]);
    float lo[4], hi[4];
    v4_store(lo, v4_min(r, v4_min(q, p)));
    v4_store(hi, v4_max(r, v4_max(q, p)));
    return (rtk_bounds){{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}};
}

/* Bins of a doubled centroid c on each axis: (c - lo) * scale clamped to
 * [0, bins - 1]; NaN (0 * inf on a tiny extent) goes to bin 0. */
static inline void bins_of(v4 c, v4 lo, v4 scale, v4 last, uint32_t out[4])
{
    v4_to_u32(v4_min(v4_max(v4_mul(v4_sub(c, lo), scale), v4_set1(0.0f)), last), out);
}

/* Cost of a split over a node of half area parent holding count
 * primitives, from the sum of area times count of both sides. A flat
 * node (area 0) counts its children as large as itself. */
static float split_cost(const sah *o, float weighted, float parent, uint32_t count)
{
    float ratio = parent > 0.0f ? weighted / parent : (float)count;
    return o->t_node + o->t_tri * ratio;
}

static void write_node(rtk_bvh_node *n, const vbox *b, uint32_t offset, uint32_t count)
{
    float lo[4], hi[4];
    v4_store(lo, b->lo);
    v4_store(hi, b->hi);
    memcpy(n->lower, lo, sizeof n->lower);
    memcpy(n->upper, hi, sizeof n->upper);
    n->offset = offset;
    n->count = count;
}

/* Bins per axis of a node over count primitives: 4 + count / 20, at
 * most the option (as Embree's binner): a node of a hundred primitives
 * has little to gain from 16 bins and pays for clearing and sweeping
 * them. */
static uint32_t node_bins(const sah *o, uint32_t count)
{
    uint32_t nb = 4 + count / 20;
    return nb < o->bins ? nb : o->bins;
}

/* Per-axis binning parameters of a node: scale 0 on a flat axis. */
static void bin_setup(const sah *o, const job *j, v4 *scale, v4 *last)
{
    const uint32_t nb = node_bins(o, j->end - j->begin);
    float lo[4], hi[4], s[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    v4_store(lo, j->cent.lo);
    v4_store(hi, j->cent.hi);
    for (int k = 0; k < 3; k++) {
        float extent = hi[k] - lo[k];
        s[k] = extent > 0.0f ? (float)nb / extent : 0.0f;
    }
    *scale = v4_load(s);
    *last = v4_set1((float)(nb - 1));
}

static void binning_clear(binning *bn, uint32_t nb)
{
    for (int k = 0; k < 3; k++) {
        for (uint32_t i = 0; i < nb; i++)
            box_empty(&bn->box[k][i]);
        memset(bn->count[k], 0, sizeof bn->count[k][0] * nb);
    }
}

/* Adds nb bins of one axis (boxes and counts) to those of another. */
static void bins_add(vbox *to_box, uint32_t *to_count, const vbox *box, const uint32_t *count, uint32_t nb)
{
    for (uint32_t c = 0; c < nb; c++) {
        box_grow(&to_box[c], box[c].lo, box[c].hi);
        to_count[c] += count[c];
    }
}

/* Adds the bins of from to those of to. */
static void binning_merge(binning *to, const binning *from, uint32_t nb)
{
    for (int k = 0; k < 3; k++)
        bins_add(to->box[k], to->count[k], from->box[k], from->count[k], nb);
}

/* Adds a ref to its bins bi (one per axis) of bn. */
static inline void binning_add(binning *bn, const ref *r, const uint32_t bi[4])
{
    v4 lo = ref_lo(r), hi = ref_hi(r);
    box_grow(&bn->box[0][bi[0]], lo, hi);
    box_grow(&bn->box[1][bi[1]], lo, hi);
    box_grow(&bn->box[2][bi[2]], lo, hi);
    bn->count[0][bi[0]]++;
    bn->count[1][bi[1]]++;
    bn->count[2][bi[2]]++;
}

/* Refs binned a batch at a time: their bins first, then the adds. */
#define SAH_BIN_BATCH 32

/* Bins refs [begin, end) of node j into bn (cleared here). A batch of
 * refs gets its bins computed before any is added: were each add's
 * addresses computed from its ref's load, the loads of the bins would
 * wait on the stores before them, their addresses not yet known, and
 * the loop would run at a third of the speed (the elephant's root). Two
 * sets of bins, even and odd slots, merged at the end: neighbouring
 * primitives often share a bin, and two sets halve the chains of loads
 * and stores on one bin. The bins' boxes are minima and maxima of
 * finite bounds (the kernel refuses non-finite positions), and their
 * counts integers: any division of a node's refs into parts, merged in
 * any order, gives the same bins. */
static void bin_refs(const build *b, const job *j, uint32_t begin, uint32_t end, binning bn[2])
{
    const uint32_t nb = node_bins(b->opt, j->end - j->begin);
    v4 scale, last;
    bin_setup(b->opt, j, &scale, &last);
    const v4 clo = j->cent.lo;
    const uint32_t sets = end - begin >= 64 ? 2 : 1;
    binning_clear(&bn[0], nb);
    if (sets == 2)
        binning_clear(&bn[1], nb);
    const ref *refs = b->refs;
    uint32_t bins[SAH_BIN_BATCH][4];
    for (uint32_t first = begin; first < end; first += SAH_BIN_BATCH) {
        const uint32_t stop = end - first < SAH_BIN_BATCH ? end : first + SAH_BIN_BATCH;
        for (uint32_t i = first; i < stop; i++)
            bins_of(v4_add(ref_lo(&refs[i]), ref_hi(&refs[i])), clo, scale, last, bins[i - first]);
        for (uint32_t i = first; i < stop; i++)
            binning_add(&bn[(i - begin) & (sets - 1)], &refs[i], bins[i - first]);
    }
    if (sets == 2)
        binning_merge(&bn[0], &bn[1], nb);
}

/* The best binned split of node j from its bins, into best. */
static void best_binned(const build *b, const job *j, const binning *bn, split *best)
{
    const sah *o = b->opt;
    const uint32_t count = j->end - j->begin, nb = node_bins(o, count);
    float rweight[256];
    uint32_t rcount[256];
    float lo[4], hi[4];
    v4_store(lo, j->cent.lo);
    v4_store(hi, j->cent.hi);
    int axis = -1;
    uint32_t at = 0;
    float best_weight = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (!(hi[k] - lo[k] > 0.0f)) /* flat: bin_setup's scale 0, all in one bin */
            continue;
        const vbox *box = bn->box[k];
        const uint32_t *cnt = bn->count[k];
        vbox acc;
        box_empty(&acc);
        uint32_t n = 0;
        for (uint32_t c = nb - 1; c > 0; c--) {
            box_grow(&acc, box[c].lo, box[c].hi);
            n += cnt[c];
            rweight[c] = n ? half_area(&acc) * (float)n : 0.0f;
            rcount[c] = n;
        }
        box_empty(&acc);
        n = 0;
        for (uint32_t c = 1; c < nb; c++) {
            box_grow(&acc, box[c - 1].lo, box[c - 1].hi);
            n += cnt[c - 1];
            if (n == 0 || rcount[c] == 0)
                continue;
            float weight = half_area(&acc) * (float)n + rweight[c];
            if (weight < best_weight) {
                best_weight = weight;
                axis = k;
                at = c;
            }
        }
    }
    best->axis = axis;
    best->at = at;
    best->cost = axis >= 0 ? split_cost(o, best_weight, half_area(&j->geom), count) : INFINITY;
}

static void find_binned(const build *b, const job *j, split *best)
{
    binning bn[2];
    bin_refs(b, j, j->begin, j->end, bn);
    best_binned(b, j, &bn[0], best);
}

static inline void ref_grow(job *j, const ref *r)
{
    v4 lo = ref_lo(r), hi = ref_hi(r);
    box_grow(&j->geom, lo, hi);
    box_add_point(&j->cent, v4_add(lo, hi));
}

/* Bounds of refs [begin, end) into j. */
static void bounds_of_refs(const build *b, uint32_t begin, uint32_t end, job *j)
{
    box_empty(&j->geom), box_empty(&j->cent);
    for (uint32_t i = begin; i < end; i++)
        ref_grow(j, &b->refs[i]);
}

#if defined(__SSE2__)
/* Lomuto without branches over refs [begin, end) on axis k (a constant
 * once inlined): [begin, mid) is left, [mid, i) right. A ref moves as
 * two 16-byte vectors, its doubled centroid is their sum, lane k. */
static inline __attribute__((always_inline)) uint32_t lomuto(ref *refs, uint32_t begin, uint32_t end, int k, float clo,
                                                             float scl, float at)
{
    uint32_t mid = begin;
    for (uint32_t i = begin; i < end; i++) {
        float *x = (float *)(void *)&refs[i], *y = (float *)(void *)&refs[mid];
        const __m128 lo = _mm_loadu_ps(x), hi = _mm_loadu_ps(x + 4);
        _mm_storeu_ps(x, _mm_loadu_ps(y)), _mm_storeu_ps(x + 4, _mm_loadu_ps(y + 4));
        _mm_storeu_ps(y, lo), _mm_storeu_ps(y + 4, hi);
        const __m128 c = _mm_add_ps(lo, hi);
        const float ck = _mm_cvtss_f32(k == 0 ? c : k == 1 ? _mm_shuffle_ps(c, c, 0x55) : _mm_shuffle_ps(c, c, 0xaa));
        mid += !((ck - clo) * scl >= at);
    }
    return mid;
}
#endif

/* Moves the refs in [begin, end) whose doubled centroid on axis k falls
 * in a bin below at (bins_of(c) < at exactly when !((c - clo) * scl >=
 * at), NaN included: one lane of the same float operations) to the
 * front, in their order; returns the first slot of the others. */
static uint32_t partition_range(ref *refs, uint32_t begin, uint32_t end, int k, float clo, float scl, float at)
{
#if defined(__SSE2__)
    return k == 0 ? lomuto(refs, begin, end, 0, clo, scl, at)
         : k == 1 ? lomuto(refs, begin, end, 1, clo, scl, at)
                  : lomuto(refs, begin, end, 2, clo, scl, at);
#else
    /* Lomuto without branches: [begin, mid) is left, [mid, i) right. */
    uint32_t mid = begin;
    for (uint32_t i = begin; i < end; i++) {
        ref x = refs[i];
        refs[i] = refs[mid];
        refs[mid] = x;
        mid += !((x.lo[k] + x.hi[k] - clo) * scl >= at);
    }
    return mid;
#endif
}

/* Moves the primitives of bins below s.at to the front, as find_binned
 * binned them; fills both children's bounds. Returns the first slot of
 * the right side. */
static uint32_t partition_binned(const build *b, const job *j, const split *s, job *l, job *r)
{
    v4 scale, last;
    bin_setup(b->opt, j, &scale, &last);
    float lo[4], sc[4];
    v4_store(lo, j->cent.lo);
    v4_store(sc, scale);
    const int k = s->axis;
    const uint32_t mid = partition_range(b->refs, j->begin, j->end, k, lo[k], sc[k], (float)s->at);
    bounds_of_refs(b, j->begin, mid, l);
    bounds_of_refs(b, mid, j->end, r);
    return mid;
}

/* Orders the m refs of a small node along each axis by doubled centroid,
 * ties by primitive index: ord[k][r] is the slot (from the node's first)
 * of rank r. The centroids are compared as integers that sort like the
 * floats (a total order even for NaN, so the ranks are a permutation),
 * pairwise, without data-dependent branches. */
static void sort_small(const ref *refs, uint32_t m, uint8_t ord[3][SAH_SMALL])
{
    uint32_t rank[SAH_SMALL][4];
#if defined(__SSE2__)
    __m128i key[SAH_SMALL], r[SAH_SMALL];
    for (uint32_t i = 0; i < m; i++) {
        __m128i bits = _mm_castps_si128(_mm_add_ps(ref_lo(&refs[i]), ref_hi(&refs[i])));
        key[i] = _mm_xor_si128(bits, _mm_and_si128(_mm_srai_epi32(bits, 31), _mm_set1_epi32(0x7fffffff)));
        r[i] = _mm_setzero_si128();
    }
    const __m128i one = _mm_set1_epi32(1);
    for (uint32_t i = 0; i < m; i++) {
        for (uint32_t j = i + 1; j < m; j++) {
            __m128i id_first = _mm_set1_epi32(-(int32_t)(refs[j].id < refs[i].id));
            __m128i first = _mm_or_si128(_mm_cmplt_epi32(key[j], key[i]),
                                         _mm_and_si128(_mm_cmpeq_epi32(key[j], key[i]), id_first));
            r[i] = _mm_sub_epi32(r[i], first); /* first is all ones where j comes first */
            r[j] = _mm_add_epi32(r[j], _mm_add_epi32(first, one));
        }
    }
    for (uint32_t i = 0; i < m; i++)
        _mm_storeu_si128((__m128i *)rank[i], r[i]);
#else
    int32_t key[SAH_SMALL][3];
    for (uint32_t i = 0; i < m; i++) {
        for (int k = 0; k < 3; k++) {
            float c = refs[i].lo[k] + refs[i].hi[k];
            int32_t bits;
            memcpy(&bits, &c, sizeof bits);
            key[i][k] = bits < 0 ? bits ^ 0x7fffffff : bits;
            rank[i][k] = 0;
        }
    }
    for (uint32_t i = 0; i < m; i++) {
        for (uint32_t j = i + 1; j < m; j++) {
            uint32_t id_first = refs[j].id < refs[i].id;
            for (int k = 0; k < 3; k++) {
                uint32_t first = (key[j][k] < key[i][k]) | ((key[j][k] == key[i][k]) & id_first);
                rank[i][k] += first;
                rank[j][k] += first ^ 1;
            }
        }
    }
#endif
    for (int k = 0; k < 3; k++)
        for (uint32_t i = 0; i < m; i++)
            ord[k][rank[i][k]] = (uint8_t)i;
}

/* Exact SAH over every object split of a small node: cheaper there than
 * binning, and better. Equal costs go to the split nearest the middle. */
static void find_small(const build *b, const job *j, split *best)
{
    const sah *o = b->opt;
    const ref *refs = b->refs + j->begin;
    const uint32_t m = j->end - j->begin;
    float best_weight = INFINITY, rweight[SAH_SMALL];
    uint32_t best_skew = UINT32_MAX;
    if (m == 2) {
        /* One split, the same on every axis; the order stays. */
        vbox one = {ref_lo(&refs[0]), ref_hi(&refs[0])}, two = {ref_lo(&refs[1]), ref_hi(&refs[1])};
        best->axis = 0;
        best->at = 1;
        best->cost = split_cost(o, half_area(&one) + half_area(&two), half_area(&j->geom), m);
        return;
    }
    int axis = -1;
    uint32_t at = 0;
    uint8_t order[3][SAH_SMALL];
    sort_small(refs, m, order);
    for (int k = 0; k < 3; k++) {
        const uint8_t *ord = order[k];
        vbox acc;
        box_empty(&acc);
        for (uint32_t i = m - 1; i > 0; i--) {
            box_grow(&acc, ref_lo(&refs[ord[i]]), ref_hi(&refs[ord[i]]));
            rweight[i] = half_area(&acc) * (float)(m - i);
        }
        box_empty(&acc);
        for (uint32_t i = 1; i < m; i++) {
            box_grow(&acc, ref_lo(&refs[ord[i - 1]]), ref_hi(&refs[ord[i - 1]]));
            float weight = half_area(&acc) * (float)i + rweight[i];
            uint32_t skew = 2 * i > m ? 2 * i - m : m - 2 * i;
            if (weight < best_weight || (weight == best_weight && skew < best_skew)) {
                best_weight = weight;
                best_skew = skew;
                axis = k;
                at = i;
            }
        }
    }
    best->axis = axis;
    best->at = at;
    best->cost = split_cost(o, best_weight, half_area(&j->geom), m);
    if (axis >= 0)
        memcpy(best->order, order[axis], sizeof best->order);
}

/* Reorders the refs of j as find_small ordered them along s.axis and
 * fills both children's bounds. Returns the first slot of the right side. */
static uint32_t partition_small(const build *b, const job *j, const split *s, job *l, job *r)
{
    ref *refs = b->refs + j->begin, tmp[SAH_SMALL];
    const uint32_t m = j->end - j->begin;
    if (m > 2) {
        for (uint32_t i = 0; i < m; i++)
            tmp[i] = refs[s->order[i]];
        memcpy(refs, tmp, sizeof *refs * m);
    }
    box_empty(&l->geom), box_empty(&l->cent), box_empty(&r->geom), box_empty(&r->cent);
    for (uint32_t i = 0; i < m; i++)
        ref_grow(i < s->at ? l : r, &refs[i]);
    return j->begin + s->at;
}

static void bounds_of_ids(const build *b, const uint32_t *ids, uint32_t begin, uint32_t end, vbox *geom)
{
    box_empty(geom);
    for (uint32_t i = begin; i < end; i++) {
        const rtk_bounds *pb = &b->bounds[ids[i]];
        box_grow(geom, bounds_lower(pb), bounds_upper(pb));
    }
}

/* Best object split of the sorted orders; equal costs go to the split
 * nearest the middle, so identical primitives give a balanced tree. */
static void find_sweep(const build *b, const job *j, split *s)
{
    const sah *o = b->opt;
    const uint32_t begin = j->begin, end = j->end, count = end - begin;
    const float parent = half_area(&j->geom);
    split best = {.axis = -1, .cost = INFINITY};
    uint32_t best_skew = UINT32_MAX;
    for (int k = 0; k < 3; k++) {
        const uint32_t *ids = b->ord[k];
        vbox acc;
        box_empty(&acc);
        for (uint32_t i = end - 1; i > begin; i--) {
            const rtk_bounds *pb = &b->bounds[ids[i]];
            box_grow(&acc, bounds_lower(pb), bounds_upper(pb));
            b->area[i] = half_area(&acc);
        }
        box_empty(&acc);
        for (uint32_t i = begin + 1; i < end; i++) {
            const rtk_bounds *pb = &b->bounds[ids[i - 1]];
            box_grow(&acc, bounds_lower(pb), bounds_upper(pb));
            float cost = split_cost(o, half_area(&acc) * (float)(i - begin) + b->area[i] * (float)(end - i), parent, count);
            uint32_t skew = 2 * i > begin + end ? 2 * i - begin - end : begin + end - 2 * i;
            if (cost < best.cost || (cost == best.cost && skew < best_skew)) {
                best = (split){.axis = k, .at = i, .cost = cost};
                best_skew = skew;
            }
        }
    }
    *s = best;
}

/* Splits the sorted orders at s: the chosen axis is already split; the
 * others are partitioned stably so each side stays sorted. */
static void partition_sweep(const build *b, const job *j, const split *s)
{
    const uint32_t begin = j->begin, end = j->end;
    const uint32_t *axis = b->ord[s->axis];
    for (uint32_t i = begin; i < end; i++)
        b->left[axis[i]] = i < s->at;
    for (int k = 0; k < 3; k++) {
        if (k == s->axis)
            continue;
        uint32_t *ids = b->ord[k];
        uint32_t l = begin, r = begin;
        for (uint32_t i = begin; i < end; i++) {
            uint32_t id = ids[i];
            if (b->left[id])
                ids[l++] = id;
            else
                b->tmp[r++] = id;
        }
        memcpy(ids + l, b->tmp + begin, sizeof *ids * (r - begin));
    }
}

static void queue_push(queue *q, const job *j)
{
    pthread_mutex_lock(&q->lock);
    q->jobs[atomic_fetch_add(&q->count, 1u)] = *j;
    atomic_fetch_add(&q->pending, 1u);
    pthread_cond_signal(&q->wake);
    pthread_mutex_unlock(&q->lock);
}

/* Records a run of slots the tree fills (on threads; none on one). */
static void add_segment(const build *b, uint32_t start, uint32_t len, uint32_t dense)
{
    if (!b->segs || len == 0)
        return;
    b->segs[atomic_fetch_add(b->seg_count, 1u)] = (segment){start, len, dense, 0};
}

/* Whether a team splits node j (SAH_TEAM_DEPTH). */
static int team_node(const sah *o, const job *j)
{
    const uint32_t count = j->end - j->begin;
    return !o->sweep && count >= SAH_SPAWN_MIN && j->depth <= SAH_TEAM_DEPTH &&
           (j->depth == 1 || count >= SAH_TEAM_MIN);
}

static void split_alone(const build *b, const job *j, uint32_t *lefts, team_split *out);

/* Builds the subtree of root, handing large subtrees to the queue (on
 * threads); lefts: split_alone's scratch. Returns the next slot after a
 * dense root's subtree. A node's left child is built next in place of
 * the node (j), its right child waits on the stack, written where it
 * waits: a job's fields are stored one by one, and copying a job just
 * stored loads each 16 bytes from stores of 4, which must reach the
 * cache first (the same holds for a split, passed by pointer). */
static uint32_t build_subtree(const build *b, const job *root, uint32_t *lefts)
{
    const sah *o = b->opt;
    rtk_build_args *a = b->a;
    job stack[SAH_STACK];
    uint32_t top = 0, bump = root->dense ? root->region : 0;
    /* On threads: the dense subtree being built, [dense_start, bump),
     * done when the stack is back to dense_mark entries and the node in
     * hand is done. */
    uint32_t dense_start = UINT32_MAX, dense_mark = 0;
    job j = *root;
    for (;;) {
        const uint32_t count = j.end - j.begin;
        if (o->sweep)
            bounds_of_ids(b, b->ord[0], j.begin, j.end, &j.geom);
        split s;
        s.axis = -1;
        s.cost = INFINITY;
        /* A team node: split here as a team splits it. */
        team_split ps;
        const int team = team_node(o, &j);
        if (team) {
            split_alone(b, &j, lefts, &ps);
            s = ps.s;
        } else if (count > 1 && j.depth < SAH_HALVING_DEPTH && o->sweep)
            find_sweep(b, &j, &s);
        else if (count > 1 && j.depth < SAH_HALVING_DEPTH)
            count <= SAH_SMALL ? find_small(b, &j, &s) : find_binned(b, &j, &s);
        if (count == 1 || (count <= o->max_leaf && (s.axis < 0 || o->t_tri * (float)count <= s.cost))) {
            write_node(&a->nodes[j.slot], &j.geom, j.begin, count);
            if (!o->sweep)
                for (uint32_t i = j.begin; i < j.end; i++)
                    a->prim_order[i] = b->refs[i].id;
            if (dense_start != UINT32_MAX && top == dense_mark) {
                add_segment(b, dense_start, bump - dense_start, 1);
                dense_start = UINT32_MAX;
            }
            if (top == 0)
                break;
            j = stack[--top];
            continue;
        }
        /* A node under SAH_SPAWN_MIN primitives is built here with all
         * below it (the stack takes its subtree before anything else):
         * the subtree's nodes go densely from the start of the node's
         * region, in the order they are made, which touches about half
         * the memory the region spans. Above, children take the first
         * two slots of the region. Both rules depend on the tree alone. */
        const uint32_t dense = j.dense || count < SAH_SPAWN_MIN;
        if (dense && !j.dense) {
            bump = j.region;
            dense_start = j.region, dense_mark = top;
        } else if (!dense && b->segs) {
            add_segment(b, j.region, 2, 0);
        }
        const uint32_t first = dense ? bump : j.region;
        bump += dense ? 2 : 0;
        job l, *r = &stack[top];
        r->slot = first + 1, r->end = j.end, r->depth = j.depth + 1, r->dense = dense;
        uint32_t mid;
        if (team) {
            mid = ps.mid;
            l.geom = ps.sides[0].geom, l.cent = ps.sides[0].cent;
            r->geom = ps.sides[1].geom, r->cent = ps.sides[1].cent;
        } else if (s.axis < 0) {
            /* Nothing separates the centroids, or too deep: halve. */
            mid = j.begin + count / 2;
            if (o->sweep) {
                partition_sweep(b, &j, &(split){.axis = 0, .at = mid});
            } else {
                bounds_of_refs(b, j.begin, mid, &l);
                bounds_of_refs(b, mid, j.end, r);
            }
        } else if (o->sweep) {
            mid = s.at;
            partition_sweep(b, &j, &s);
        } else if (count <= SAH_SMALL) {
            mid = partition_small(b, &j, &s, &l, r);
        } else {
            mid = partition_binned(b, &j, &s, &l, r);
        }
        r->begin = mid;
        r->region = j.region + 2 * (mid - j.begin);
        write_node(&a->nodes[j.slot], &j.geom, first, 0);
        if (b->q && r->end - r->begin >= SAH_SPAWN_MIN)
            queue_push(b->q, r);
        else
            top++;
        /* The left child (sweep mode's bounds come from its orders). */
        if (!o->sweep)
            j.geom = l.geom, j.cent = l.cent;
        j.slot = first, j.end = mid, j.region += 2, j.depth++, j.dense = dense;
    }
    return bump;
}

/* How long a worker without a job spins before it sleeps on the queue:
 * the next job comes within microseconds of a split, a sleeping thread
 * takes tens of microseconds and more to wake (up to milliseconds on a
 * busy virtual machine: the two-thread build of a small mesh varied by
 * half its time). */
#define SAH_SPIN_NS 100000

static int64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000000000 + t.tv_nsec;
}

/* Returns when q has a job or none is pending, or after SAH_SPIN_NS. */
static void spin_for_job(queue *q)
{
    int64_t deadline = 0;
    for (uint32_t i = 1; atomic_load(&q->count) == 0 && atomic_load(&q->pending) > 0; i++) {
#if defined(__SSE2__)
        _mm_pause();
#endif
        if ((i & 63) == 0) {
            const int64_t now = now_ns();
            if (deadline == 0)
                deadline = now + SAH_SPIN_NS;
            else if (now > deadline)
                return;
        }
    }
}

/* Takes jobs from the queue until every job is done (rtk_team_fn). */
static void work(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team, (void)size;
    const build *b = ctx;
    queue *q = b->q;
    for (;;) {
        spin_for_job(q);
        pthread_mutex_lock(&q->lock);
        while (atomic_load(&q->count) == 0 && atomic_load(&q->pending) > 0)
            pthread_cond_wait(&q->wake, &q->lock);
        if (atomic_load(&q->count) == 0) {
            pthread_mutex_unlock(&q->lock);
            return;
        }
        job j = q->jobs[atomic_fetch_sub(&q->count, 1u) - 1];
        pthread_mutex_unlock(&q->lock);
        build_subtree(b, &j, b->lefts ? b->lefts + (size_t)b->lefts_stride * index : NULL);
        pthread_mutex_lock(&q->lock);
        if (atomic_fetch_sub(&q->pending, 1u) == 1)
            pthread_cond_broadcast(&q->wake);
        pthread_mutex_unlock(&q->lock);
    }
}

/* Threads worth building with: more than queued subtrees would only wait. */
static uint32_t build_threads(const rtk_build_args *a)
{
    return a->thread_count < a->prim_count / SAH_SPAWN_MIN ? a->thread_count : a->prim_count / SAH_SPAWN_MIN;
}

/* Team nodes (team_node) are partitioned by fixed chunks of
 * SAH_PART_CHUNK refs from the node's first, each partitioned as
 * partition_range does, then the right refs before the split and the
 * left refs from it swapped pairwise in slot order: an order that
 * depends on the chunks alone, so that the tree does not depend on how
 * many threads share the work. On threads one team splits the team nodes
 * of a level together, in one rtk_team_run for the top of the tree, while
 * a level has fewer than SAH_TEAM_QUEUE nodes a member; the queue takes
 * the rest, and a thread splits such a node alone (split_alone), as one
 * thread's build splits them all. The team bins each member's equal share
 * of the level's refs (its nodes' ranges one after another) into a store
 * per node and member, which the node's bins add up: any division of the
 * refs gives the same bins. */
#define SAH_PART_CHUNK 1024u
#define SAH_TEAM_QUEUE 2
/* Most team nodes at one depth: 2^(depth - 1) at most. */
#define SAH_TEAM_WIDTH (1u << (SAH_TEAM_DEPTH - 1))

static uint32_t chunks_of(const job *j)
{
    return (j->end - j->begin + SAH_PART_CHUNK - 1) / SAH_PART_CHUNK;
}

/* Chunk c of node j's misplaced refs once every chunk is partitioned
 * (lefts: each chunk's left refs): its right refs before slot split
 * (right_of 0) or its left refs from split on (right_of 1), a run of slots
 * from *first; returns how many. */
static uint32_t misplaced(const job *j, const uint32_t *lefts, uint32_t c, uint32_t split, int right_of,
                          uint32_t *first)
{
    const uint32_t cs = j->begin + c * SAH_PART_CHUNK;
    const uint32_t ce = j->end - cs < SAH_PART_CHUNK ? j->end : cs + SAH_PART_CHUNK;
    const uint32_t cm = cs + lefts[c];
    const uint32_t from = right_of ? (cs > split ? cs : split) : cm;
    const uint32_t to = right_of ? cm : (ce < split ? ce : split);
    *first = from;
    return to > from ? to - from : 0;
}

/* The slot of the k-th misplaced ref of one side, its chunk in *c and the
 * end of that chunk's run in *run_end. */
static uint32_t misplaced_at(const job *j, const uint32_t *lefts, uint32_t split, int right_of, uint32_t k, uint32_t *c,
                             uint32_t *run_end)
{
    for (*c = 0; *c < chunks_of(j); (*c)++) {
        uint32_t first, len = misplaced(j, lefts, *c, split, right_of, &first);
        if (k < len) {
            *run_end = first + len;
            return first + k;
        }
        k -= len;
    }
    *run_end = 0;
    return 0;
}

/* The first slot of one side's next run of misplaced refs after chunk
 * *c's, its chunk in *c and its end in *run_end. */
static uint32_t misplaced_next(const job *j, const uint32_t *lefts, uint32_t split, int right_of, uint32_t *c,
                               uint32_t *run_end)
{
    while (++*c < chunks_of(j)) {
        uint32_t first, len = misplaced(j, lefts, *c, split, right_of, &first);
        if (len) {
            *run_end = first + len;
            return first;
        }
    }
    return *run_end;
}

/* The first right slot of node j once its chunks are partitioned. */
static uint32_t chunked_mid(const job *j, const uint32_t *lefts)
{
    uint32_t mid = j->begin;
    for (uint32_t c = 0; c < chunks_of(j); c++)
        mid += lefts[c];
    return mid;
}

/* Node j's swaps: its right refs before the split (as many as its left
 * refs from it). */
static uint32_t chunked_swaps(const job *j, const uint32_t *lefts, uint32_t split)
{
    uint32_t swaps = 0, first;
    for (uint32_t c = 0; c < chunks_of(j); c++)
        swaps += misplaced(j, lefts, c, split, 0, &first);
    return swaps;
}

/* Swaps [k0, k1) of node j's misplaced pairs, a run of pairs at a time
 * (to the nearer end of the two runs). */
static void swap_misplaced(ref *refs, const job *j, const uint32_t *lefts, uint32_t split, uint32_t k0, uint32_t k1)
{
    if (k0 >= k1)
        return;
    uint32_t ca, cb, a_end, b_end;
    uint32_t a = misplaced_at(j, lefts, split, 0, k0, &ca, &a_end);
    uint32_t bs = misplaced_at(j, lefts, split, 1, k0, &cb, &b_end);
    for (uint32_t k = k0; k < k1;) {
        uint32_t len = a_end - a < b_end - bs ? a_end - a : b_end - bs;
        len = len < k1 - k ? len : k1 - k;
        for (uint32_t i = 0; i < len; i++) {
            const ref x = refs[a + i];
            refs[a + i] = refs[bs + i];
            refs[bs + i] = x;
        }
        k += len, a += len, bs += len;
        if (k < k1 && a == a_end)
            a = misplaced_next(j, lefts, split, 0, &ca, &a_end);
        if (k < k1 && bs == b_end)
            bs = misplaced_next(j, lefts, split, 1, &cb, &b_end);
    }
}

/* Partition parameters of node j's split s: its axis's lower centroid
 * bound and bin scale. */
static void part_params(const build *b, const job *j, const split *s, float *clo, float *scl)
{
    v4 scale, last;
    bin_setup(b->opt, j, &scale, &last);
    float lo[4], sc[4];
    v4_store(lo, j->cent.lo);
    v4_store(sc, scale);
    *clo = lo[s->axis], *scl = sc[s->axis];
}

/* Partitions chunk c of node j by split s (axis -1: halves the node by
 * count, the chunk left as it is); returns its left refs, its sides'
 * bounds and centroid bounds in side[0, 1] and side[2, 3]. */
static uint32_t part_chunk(const build *b, const job *j, const split *s, float clo, float scl, uint32_t c, vbox side[4])
{
    const uint32_t cs = j->begin + c * SAH_PART_CHUNK;
    const uint32_t ce = j->end - cs < SAH_PART_CHUNK ? j->end : cs + SAH_PART_CHUNK;
    uint32_t cm;
    if (s->axis >= 0) {
        cm = partition_range(b->refs, cs, ce, s->axis, clo, scl, (float)s->at);
    } else {
        const uint32_t half = j->begin + (j->end - j->begin) / 2;
        cm = half < cs ? cs : half > ce ? ce : half;
    }
    job part;
    bounds_of_refs(b, cs, cm, &part);
    side[0] = part.geom, side[1] = part.cent;
    bounds_of_refs(b, cm, ce, &part);
    side[2] = part.geom, side[3] = part.cent;
    return cm - cs;
}

static void grow_sides(team_split *out, const vbox side[4])
{
    box_grow(&out->sides[0].geom, side[0].lo, side[0].hi);
    box_grow(&out->sides[0].cent, side[1].lo, side[1].hi);
    box_grow(&out->sides[1].geom, side[2].lo, side[2].hi);
    box_grow(&out->sides[1].cent, side[3].lo, side[3].hi);
}

static void empty_sides(team_split *out)
{
    for (int s = 0; s < 2; s++)
        box_empty(&out->sides[s].geom), box_empty(&out->sides[s].cent);
}

/* Splits team node j on this thread alone; lefts: scratch for its chunks. */
static void split_alone(const build *b, const job *j, uint32_t *lefts, team_split *out)
{
    float clo = 0.0f, scl = 0.0f;
    find_binned(b, j, &out->s);
    if (out->s.axis >= 0)
        part_params(b, j, &out->s, &clo, &scl);
    empty_sides(out);
    for (uint32_t c = 0; c < chunks_of(j); c++) {
        vbox side[4];
        lefts[c] = part_chunk(b, j, &out->s, clo, scl, c, side);
        grow_sides(out, side);
    }
    out->mid = chunked_mid(j, lefts);
    swap_misplaced(b->refs, j, lefts, out->mid, 0, chunked_swaps(j, lefts, out->mid));
}

/* A team node of a level: its job, split and partition parameters, and
 * the level's refs and chunks before its own. */
typedef struct top_node {
    job j;
    split s;
    float clo, scl;
    uint32_t refs_before, chunks_before;
} top_node;

/* The team's levels (alternating) and scratch. */
typedef struct top_levels {
    build *b;
    top_node *level[2];
    uint32_t count[2], refs[2], chunks[2];
    binning (*member_bins)[2]; /* per member: bin_refs's two sets */
    vbox *part_box;            /* per node and member: nb_max boxes per axis */
    uint32_t *part_count;      /* and counts */
    uint32_t nb_max;
    uint32_t *lefts;           /* per chunk: its left refs */
    vbox (*sides)[4];          /* per chunk: part_chunk's bounds */
    atomic_uint next_chunk;
} top_levels;

/* The last of nodes[0, count) whose refs (or chunks) before it are at
 * most at. */
static uint32_t node_at(const top_node *nodes, uint32_t count, uint32_t at, int chunks)
{
    uint32_t lo = 0, hi = count;
    while (hi - lo > 1) {
        const uint32_t mid = (lo + hi) / 2;
        if ((chunks ? nodes[mid].chunks_before : nodes[mid].refs_before) <= at)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* Member index's share [lo, hi) of total. */
static void share_of(uint32_t total, uint32_t index, uint32_t size, uint32_t *lo, uint32_t *hi)
{
    *lo = (uint32_t)((uint64_t)total * index / size);
    *hi = (uint32_t)((uint64_t)total * (index + 1) / size);
}

/* The store of node i's part binned by member index: i + index (the
 * nodes a member's share meets come after those of the members before). */
static size_t store_at(const top_levels *t, uint32_t i, uint32_t index, int k)
{
    return (((size_t)i + index) * 3 + (size_t)k) * t->nb_max;
}

/* Bins member index's share of the level's refs. */
static void top_bin(top_levels *t, const top_node *nodes, uint32_t count, uint32_t total, uint32_t index, uint32_t size)
{
    uint32_t lo, hi;
    share_of(total, index, size, &lo, &hi);
    if (lo == hi)
        return;
    const binning *bn = &t->member_bins[index][0];
    for (uint32_t i = node_at(nodes, count, lo, 0); i < count && nodes[i].refs_before < hi; i++) {
        const job *j = &nodes[i].j;
        const uint32_t m = j->end - j->begin, at = nodes[i].refs_before, nb = node_bins(t->b->opt, m);
        const uint32_t from = lo > at ? lo - at : 0, to = hi - at < m ? hi - at : m;
        bin_refs(t->b, j, j->begin + from, j->begin + to, t->member_bins[index]);
        for (int k = 0; k < 3; k++) {
            memcpy(&t->part_box[store_at(t, i, index, k)], bn->box[k], sizeof *t->part_box * nb);
            memcpy(&t->part_count[store_at(t, i, index, k)], bn->count[k], sizeof *t->part_count * nb);
        }
    }
}

/* Member index's nodes (every size-th) get their splits from the stores
 * of every member whose share meets them. */
static void top_choose(top_levels *t, top_node *nodes, uint32_t count, uint32_t total, uint32_t index, uint32_t size)
{
    binning *bn = &t->member_bins[index][0];
    for (uint32_t i = index; i < count; i += size) {
        top_node *n = &nodes[i];
        const uint32_t m = n->j.end - n->j.begin, nb = node_bins(t->b->opt, m);
        binning_clear(bn, nb);
        for (uint32_t p = 0; p < size; p++) {
            uint32_t lo, hi;
            share_of(total, p, size, &lo, &hi);
            if ((lo > n->refs_before ? lo : n->refs_before) >= (hi < n->refs_before + m ? hi : n->refs_before + m))
                continue;
            for (int k = 0; k < 3; k++)
                bins_add(bn->box[k], bn->count[k], &t->part_box[store_at(t, i, p, k)],
                         &t->part_count[store_at(t, i, p, k)], nb);
        }
        best_binned(t->b, &n->j, bn, &n->s);
        if (n->s.axis >= 0)
            part_params(t->b, &n->j, &n->s, &n->clo, &n->scl);
    }
}

/* Partitions the level's chunks, taken one at a time. */
static void top_part(top_levels *t, const top_node *nodes, uint32_t count, uint32_t chunks)
{
    for (;;) {
        const uint32_t c = atomic_fetch_add(&t->next_chunk, 1u);
        if (c >= chunks)
            return;
        const top_node *n = &nodes[node_at(nodes, count, c, 1)];
        t->lefts[c] = part_chunk(t->b, &n->j, &n->s, n->clo, n->scl, c - n->chunks_before, t->sides[c]);
    }
}

/* Member index's share of the level's swaps, the nodes' one after another. */
static void top_swap(top_levels *t, const top_node *nodes, uint32_t count, uint32_t index, uint32_t size)
{
    uint32_t total = 0;
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t *lefts = &t->lefts[nodes[i].chunks_before];
        total += chunked_swaps(&nodes[i].j, lefts, chunked_mid(&nodes[i].j, lefts));
    }
    uint32_t lo, hi;
    share_of(total, index, size, &lo, &hi);
    for (uint32_t i = 0, before = 0; i < count && before < hi; i++) {
        const job *j = &nodes[i].j;
        const uint32_t *lefts = &t->lefts[nodes[i].chunks_before];
        const uint32_t split = chunked_mid(j, lefts), swaps = chunked_swaps(j, lefts, split);
        const uint32_t k0 = lo > before ? lo - before : 0, k1 = hi - before < swaps ? hi - before : swaps;
        swap_misplaced(t->b->refs, j, lefts, split, k0, k1);
        before += swaps;
    }
}

/* After a level's partition (the calling thread, while the others swap):
 * writes its nodes as build_subtree writes a node of SAH_SPAWN_MIN or more
 * primitives and takes their children that are team nodes into the next
 * level, unless there would be SAH_TEAM_QUEUE a member; the queue takes
 * the others. */
static void top_next(top_levels *t, uint32_t level, uint32_t size)
{
    const build *b = t->b;
    const top_node *nodes = t->level[level & 1];
    top_node *next = t->level[(level + 1) & 1];
    uint32_t count = 0, refs = 0, chunks = 0;
    for (uint32_t i = 0; i < t->count[level & 1]; i++) {
        const job *j = &nodes[i].j;
        team_split ps;
        empty_sides(&ps);
        for (uint32_t c = 0; c < chunks_of(j); c++)
            grow_sides(&ps, t->sides[nodes[i].chunks_before + c]);
        ps.mid = chunked_mid(j, &t->lefts[nodes[i].chunks_before]);
        add_segment(b, j->region, 2, 0);
        write_node(&b->a->nodes[j->slot], &j->geom, j->region, 0);
        const job kids[2] = {
            {ps.sides[0].geom, ps.sides[0].cent, j->region, j->begin, ps.mid, j->region + 2, j->depth + 1, 0},
            {ps.sides[1].geom, ps.sides[1].cent, j->region + 1, ps.mid, j->end, j->region + 2 * (ps.mid - j->begin),
             j->depth + 1, 0},
        };
        for (int k = 0; k < 2; k++) {
            if (!team_node(b->opt, &kids[k])) {
                queue_push(b->q, &kids[k]);
                continue;
            }
            next[count++] = (top_node){.j = kids[k], .refs_before = refs, .chunks_before = chunks};
            refs += kids[k].end - kids[k].begin;
            chunks += chunks_of(&kids[k]);
        }
    }
    if (count >= SAH_TEAM_QUEUE * size) {
        for (uint32_t i = 0; i < count; i++)
            queue_push(b->q, &next[i].j);
        count = 0;
    }
    t->count[(level + 1) & 1] = count, t->refs[(level + 1) & 1] = refs, t->chunks[(level + 1) & 1] = chunks;
    atomic_store(&t->next_chunk, 0u);
}

/* The top of the tree on threads, a level at a time (rtk_team_fn). */
static void top_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    top_levels *t = ctx;
    for (uint32_t level = 0; t->count[level & 1] > 0; level++) {
        top_node *nodes = t->level[level & 1];
        const uint32_t count = t->count[level & 1], refs = t->refs[level & 1], chunks = t->chunks[level & 1];
        top_bin(t, nodes, count, refs, index, size);
        rtk_team_sync(team);
        top_choose(t, nodes, count, refs, index, size);
        rtk_team_sync(team);
        top_part(t, nodes, count, chunks);
        rtk_team_sync(team);
        top_swap(t, nodes, count, index, size);
        if (index == 0)
            top_next(t, level, size);
        rtk_team_sync(team);
    }
}

static void top_free(top_levels *t)
{
    if (!t)
        return;
    free(t->level[0]), free(t->level[1]), free(t->member_bins), free(t->part_box), free(t->part_count);
    free(t->lefts), free(t->sides), free(t);
}

/* The team's scratch for up to members members, or NULL. */
static top_levels *top_new(build *b, uint32_t members)
{
    const uint32_t n = b->a->prim_count;
    const size_t stores = (size_t)SAH_TEAM_WIDTH + members;
    const size_t chunks = (n + SAH_PART_CHUNK - 1) / SAH_PART_CHUNK + (size_t)SAH_TEAM_WIDTH;
    top_levels *t = calloc(1, sizeof *t);
    if (!t)
        return NULL;
    t->b = b;
    t->nb_max = node_bins(b->opt, n);
    t->level[0] = malloc(sizeof *t->level[0] * SAH_TEAM_WIDTH);
    t->level[1] = malloc(sizeof *t->level[1] * SAH_TEAM_WIDTH);
    t->member_bins = malloc(sizeof *t->member_bins * members);
    t->part_box = malloc(sizeof *t->part_box * stores * 3 * t->nb_max);
    t->part_count = malloc(sizeof *t->part_count * stores * 3 * t->nb_max);
    t->lefts = malloc(sizeof *t->lefts * chunks);
    t->sides = malloc(sizeof *t->sides * chunks);
    if (!t->level[0] || !t->level[1] || !t->member_bins || !t->part_box || !t->part_count || !t->lefts || !t->sides) {
        top_free(t);
        return NULL;
    }
    atomic_init(&t->next_chunk, 0u);
    return t;
}

/* Builds from root on the build's threads (the caller's included). */
static rtk_status run_build(build *b, const job *root)
{
    const uint32_t threads = build_threads(b->a), n = b->a->prim_count;
    rtk_status st = RTK_OK;
    if (team_node(b->opt, root)) {
        b->lefts_stride = chunks_of(root);
        b->lefts = malloc(sizeof *b->lefts * b->lefts_stride * (threads > 1 ? threads : 1));
        if (!b->lefts || (threads > 1 && !(b->top = top_new(b, threads)))) {
            st = rtk_error(RTK_ERR_NOMEM, "sah: out of memory");
            goto done;
        }
    }
    if (threads <= 1) {
        rtk_build_phase(b->a, "sah: tree", 0);
        b->dense_end = build_subtree(b, root, b->lefts);
        goto done;
    }
    queue q;
    /* Queued jobs cover disjoint ranges of at least SAH_SPAWN_MIN, but
     * for the children of team nodes (fewer than 2^SAH_TEAM_DEPTH). */
    q.jobs = malloc(sizeof *q.jobs * (n / SAH_SPAWN_MIN + 2 * ((size_t)1 << SAH_TEAM_DEPTH)));
    if (!q.jobs) {
        st = rtk_error(RTK_ERR_NOMEM, "sah: out of memory");
        goto done;
    }
    pthread_mutex_init(&q.lock, NULL);
    pthread_cond_init(&q.wake, NULL);
    atomic_init(&q.count, 0u);
    atomic_init(&q.pending, 0u);
    b->q = &q;
    top_levels *t = b->top;
    if (t) {
        t->level[0][0] = (top_node){.j = *root};
        t->count[0] = 1, t->refs[0] = n, t->chunks[0] = chunks_of(root), t->count[1] = 0;
        rtk_build_phase(b->a, "sah: top levels", 1);
        rtk_team_run(threads, top_member, t);
    } else {
        queue_push(&q, root);
    }
    rtk_build_phase(b->a, "sah: subtrees", 1);
    rtk_team_run(threads, work, b);
    pthread_cond_destroy(&q.wake);
    pthread_mutex_destroy(&q.lock);
    free(q.jobs);
    b->q = NULL;
done:
    top_free(b->top);
    free(b->lefts);
    b->top = NULL, b->lefts = NULL;
    return st;
}

static int segment_order(const void *x, const void *y)
{
    const segment *p = x, *q = y;
    return (p->start > q->start) - (p->start < q->start);
}

/* The segment that starts at slot (one does: a child pair's first slot
 * is a pair's or a dense subtree's start). */
static const segment *segment_at(const segment *segs, uint32_t n, uint32_t slot)
{
    uint32_t lo = 0, hi = n;
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (segs[mid].start <= slot)
            lo = mid;
        else
            hi = mid;
    }
    return &segs[lo];
}

/* Moves segment g of the n in segs down by its shift, renumbering its
 * children (within a dense subtree by its own shift, elsewhere by the
 * shift of the segment their pair starts). */
static void move_segment(rtk_build_args *a, const segment *segs, uint32_t n, const segment *g)
{
    for (uint32_t slot = g->start; slot < g->start + g->len; slot++) {
        rtk_bvh_node node = a->nodes[slot];
        if (node.count == 0)
            node.offset -= g->dense ? g->shift : segment_at(segs, n, node.offset)->shift;
        a->nodes[slot - g->shift] = node;
    }
}

/* The moves on threads, taken in slot order: segment k is moved once the
 * segments it overwrites have been read, all of the first after[k]
 * (sources and destinations both ascend, so those are a prefix; moved
 * counts the segments done in a row from the first). */
typedef struct gap_job {
    rtk_build_args *a;
    const segment *segs;
    uint32_t n;
    const uint32_t *after;
    atomic_uchar *done;
    atomic_uint next, moved;
} gap_job;

static void gap_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team, (void)index, (void)size;
    gap_job *j = ctx;
    for (;;) {
        const uint32_t k = atomic_fetch_add(&j->next, 1u);
        if (k >= j->n)
            break;
        for (uint32_t i = 1; atomic_load_explicit(&j->moved, memory_order_acquire) < j->after[k]; i++) {
#if defined(__SSE2__)
            _mm_pause();
#endif
            if (i % 256 == 0)
                sched_yield();
        }
        move_segment(j->a, j->segs, j->n, &j->segs[k]);
        /* Sequentially consistent: this store and another member's advance past
         * k - 1 must each see the other (store then load on both sides), or
         * moved stops short of k and every member waiting on it spins forever. */
        atomic_store(&j->done[k], 1);
        uint32_t p = atomic_load(&j->moved);
        while (p < j->n && atomic_load(&j->done[p]))
            if (atomic_compare_exchange_weak(&j->moved, &p, p + 1))
                p++;
    }
}

/* Slots in use from which the gaps are closed on threads. */
#define SAH_GAPS_PARALLEL 16384

/* Closes the gaps between the n segments the threads filled (the root's
 * slot among them) on up to threads threads: each moves down by the
 * slots unused before it, keeping the order, so siblings stay adjacent.
 * Only slots in use are read or written; the result does not depend on
 * the threads. Sets node_count. */
static void close_gaps(rtk_build_args *a, segment *segs, uint32_t n, uint32_t threads)
{
    qsort(segs, n, sizeof *segs, segment_order);
    uint32_t total = 0;
    for (uint32_t i = 0; i < n; i++) {
        segs[i].shift = segs[i].start - total;
        total += segs[i].len;
    }
    a->node_count = total;
    uint32_t *after = threads > 1 && total >= SAH_GAPS_PARALLEL ? malloc(sizeof *after * n) : NULL;
    atomic_uchar *done = after ? malloc(sizeof *done * n) : NULL;
    if (!done) {
        free(after);
        rtk_build_phase(a, "sah: close gaps", 0);
        for (uint32_t i = 0; i < n; i++)
            move_segment(a, segs, n, &segs[i]);
        return;
    }
    for (uint32_t m = 0, reads = 0; m < n; m++) {
        const uint32_t end = segs[m].start - segs[m].shift + segs[m].len;
        while (reads < n && segs[reads].start < end)
            reads++;
        after[m] = reads < m ? reads : m;
        atomic_init(&done[m], 0);
    }
    gap_job job = {.a = a, .segs = segs, .n = n, .after = after, .done = done};
    atomic_init(&job.next, 0u);
    atomic_init(&job.moved, 0u);
    rtk_build_phase(a, "sah: close gaps", 1);
    rtk_team_run(threads, gap_member, &job);
    free(after);
    free((void *)done);
}

/* Order-preserving map of a float's bits to an unsigned key. */
static uint32_t float_key(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u >> 31 ? ~u : u | 0x80000000u;
}

/* Sorts ids[0, n) by keys, stably (LSD radix, 11 bits a pass); tmp_keys
 * and tmp_ids are scratch of n entries. */
static void radix_sort(uint32_t *keys, uint32_t *ids, uint32_t *tmp_keys, uint32_t *tmp_ids, uint32_t n)
{
    uint32_t *ks = keys, *is = ids, *kd = tmp_keys, *id = tmp_ids;
    for (int shift = 0; shift < 32; shift += 11) {
        uint32_t hist[2048] = {0};
        for (uint32_t i = 0; i < n; i++)
            hist[ks[i] >> shift & 2047]++;
        for (uint32_t d = 0, sum = 0; d < 2048; d++) {
            uint32_t c = hist[d];
            hist[d] = sum;
            sum += c;
        }
        for (uint32_t i = 0; i < n; i++) {
            uint32_t at = hist[ks[i] >> shift & 2047]++;
            kd[at] = ks[i];
            id[at] = is[i];
        }
        uint32_t *t = ks;
        ks = kd, kd = t;
        t = is;
        is = id, id = t;
    }
    if (is != ids)
        memcpy(ids, is, sizeof *ids * n);
}

/* One thread's part of the refs: filled from the triangles' corners (the
 * instances' boxes for a top level), and its boxes. */
typedef struct fill_part {
    build *b;
    uint32_t begin, end;
    job bounds;
} fill_part;

static void fill_refs(fill_part *f)
{
    const rtk_build_args *a = f->b->a;
    ref *refs = f->b->refs;
    box_empty(&f->bounds.geom), box_empty(&f->bounds.cent);
    for (uint32_t i = f->begin; i < f->end; i++) {
        const rtk_bounds pb = prim_box(a, i);
        refs[i] = (ref){{pb.lower.x, pb.lower.y, pb.lower.z}, i, {pb.upper.x, pb.upper.y, pb.upper.z}, 0};
        ref_grow(&f->bounds, &refs[i]);
    }
}

/* The parts of the refs, for a team to fill. */
typedef struct fill_job {
    fill_part *parts;
    uint32_t count;
} fill_job;

/* Member index fills parts index, index + size, ... (rtk_team_fn). */
static void fill_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team;
    const fill_job *j = ctx;
    for (uint32_t t = index; t < j->count; t += size)
        fill_refs(&j->parts[t]);
}

/* Threads filling the refs: at least this many primitives each. The
 * first touch of the array's pages is most of the work. */
#define SAH_FILL_PART 8192
#define SAH_FILL_MAX_THREADS 64

static rtk_status build_binned(build *b, job *root)
{
    rtk_build_args *a = b->a;
    const uint32_t n = a->prim_count;
    /* The refs (32 bytes a primitive) in the kernel's scratch when it has
     * room, else of their own. */
    void *scratch = rtk_build_scratch(a, sizeof *b->refs * (size_t)n);
    const int in_scratch = scratch != NULL;
    b->refs = in_scratch ? scratch : malloc(sizeof *b->refs * n);
    if (!b->refs)
        return rtk_error(RTK_ERR_NOMEM, "sah: out of memory");
    uint32_t parts = a->thread_count < SAH_FILL_MAX_THREADS ? a->thread_count : SAH_FILL_MAX_THREADS;
    if (parts > n / SAH_FILL_PART)
        parts = n / SAH_FILL_PART;
    if (parts < 1)
        parts = 1;
    fill_part fp[SAH_FILL_MAX_THREADS];
    for (uint32_t t = 0; t < parts; t++)
        fp[t] = (fill_part){.b = b, .begin = (uint32_t)((uint64_t)n * t / parts),
                            .end = (uint32_t)((uint64_t)n * (t + 1) / parts)};
    fill_job fill = {fp, parts};
    rtk_build_phase(a, "sah: refs", parts > 1);
    rtk_team_run(parts, fill_member, &fill);
    box_empty(&root->geom), box_empty(&root->cent);
    for (uint32_t t = 0; t < parts; t++) {
        box_grow(&root->geom, fp[t].bounds.geom.lo, fp[t].bounds.geom.hi);
        box_grow(&root->cent, fp[t].bounds.cent.lo, fp[t].bounds.cent.hi);
    }
    rtk_status st = run_build(b, root);
    if (!in_scratch)
        free(b->refs);
    return st;
}

static rtk_status build_sweep(build *b, job *root)
{
    rtk_build_args *a = b->a;
    const uint32_t n = a->prim_count;
    b->ord[0] = a->prim_order;
    b->ord[1] = malloc(sizeof(uint32_t) * n);
    b->ord[2] = malloc(sizeof(uint32_t) * n);
    b->tmp = malloc(sizeof(uint32_t) * n);
    b->area = malloc(sizeof(float) * n);
    b->left = malloc(n);
    uint32_t *keys = malloc(sizeof(uint32_t) * n), *tmp_keys = malloc(sizeof(uint32_t) * n);
    /* The triangles' boxes when the kernel gives none (NO_BOUNDS). */
    rtk_bounds *own = a->prim_bounds ? NULL : malloc(sizeof *own * n);
    b->bounds = a->prim_bounds ? a->prim_bounds : own;
    rtk_status st = RTK_OK;
    if (!b->ord[1] || !b->ord[2] || !b->tmp || !b->area || !b->left || !keys || !tmp_keys || !b->bounds) {
        st = rtk_error(RTK_ERR_NOMEM, "sah: out of memory");
        goto done;
    }
    rtk_build_phase(a, "sah: sort centroids", 0);
    for (uint32_t i = 0; own && i < n; i++)
        own[i] = prim_box(a, i);
    for (int k = 0; k < 3; k++) {
        for (uint32_t i = 0; i < n; i++) {
            const rtk_bounds *pb = &b->bounds[i];
            float c = k == 0 ? pb->lower.x + pb->upper.x : k == 1 ? pb->lower.y + pb->upper.y : pb->lower.z + pb->upper.z;
            keys[i] = float_key(c);
            b->ord[k][i] = i;
        }
        radix_sort(keys, b->ord[k], tmp_keys, b->tmp, n);
    }
    st = run_build(b, root);
done:
    free(b->ord[1]);
    free(b->ord[2]);
    free(b->tmp);
    free(b->area);
    free(b->left);
    free(keys);
    free(tmp_keys);
    free(own);
    return st;
}

static rtk_status sah_build(void *state, rtk_build_args *a)
{
    build b = {.opt = state, .a = a};
    job root = {.slot = 0, .begin = 0, .end = a->prim_count, .region = 1, .depth = 1};
    /* One thread builds the whole tree densely from the root, in the
     * order compaction leaves the slots (children pairs depth first, left
     * first): no slot marks, no gaps to close. */
    const int dense = build_threads(a) <= 1;
    root.dense = dense;
    atomic_uint seg_count;
    atomic_init(&seg_count, 0u);
    b.seg_count = &seg_count;
    if (!dense) {
        /* Nodes over SAH_SPAWN_MIN or more primitives, at most 2 n /
         * SAH_SPAWN_MIN, each a pair and up to two dense subtrees; and
         * the root's slot. */
        b.segs = malloc(sizeof *b.segs * (6 * ((size_t)a->prim_count / SAH_SPAWN_MIN + 1) + 1));
        if (!b.segs)
            return rtk_error(RTK_ERR_NOMEM, "sah: out of memory");
        add_segment(&b, 0, 1, 0);
    }
    rtk_status st = b.opt->sweep ? build_sweep(&b, &root) : build_binned(&b, &root);
    if (st == RTK_OK && dense) {
        a->node_count = b.dense_end;
    } else if (st == RTK_OK) {
        rtk_build_phase(a, "sah: gap plan", 0);
        close_gaps(a, b.segs, atomic_load(&seg_count), build_threads(a));
    }
    free(b.segs);
    return st;
}

static void sah_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc sah_params[] = {
    {.name = "bins", .type = RTK_PARAM_INT, .def = 16, .min = 4, .max = 256,
     .doc = "bins per axis in binned mode (a node of n primitives uses min(bins, 4 + n / 20))"},
    {.name = "mode", .type = RTK_PARAM_STRING, .def_string = "binned", .choices = "binned|sweep",
     .doc = "binned: best bin boundary, O(n) per node; sweep: best of every object split (exact SAH)"},
    {.name = "t_node", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.01, .max = 100.0,
     .doc = "SAH cost of visiting an inner node"},
    {.name = "t_tri", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.01, .max = 100.0,
     .doc = "SAH cost of one ray/triangle test"},
    {.name = "max_leaf", .type = RTK_PARAM_INT, .def = 8, .min = 1, .max = 64,
     .doc = "largest number of primitives in a leaf"},
};

static const rtk_accelerator_fns sah_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = sah_create,
    .build = sah_build,
    .destroy = sah_destroy,
    .build_flags = RTK_BUILD_NO_VERTICES | RTK_BUILD_NO_BOUNDS,
};

static const rtk_plugin sah_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_ACCELERATOR,
    .name = "sah",
    .version = "1.0",
    .summary = "surface area heuristic BVH (binned or full sweep), parallel and deterministic",
    .params = sah_params,
    .param_count = RTK_COUNTOF(sah_params),
    .functions = &sah_fns,
};

RTK_PLUGIN_ENTRY(sah_plugin)
