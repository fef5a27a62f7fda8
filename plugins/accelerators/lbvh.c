/* lbvh: linear BVH. Primitives are sorted along a Morton curve through
 * their centroids (quantised in the centroid bounds, LSD radix sort, equal
 * codes kept in index order), then each node over a sorted range splits
 * where its highest differing code bit changes, or in half by index when
 * all its codes are equal. Optionally the tree is built down to single
 * primitives and subtrees the SAH prefers as leaves are collapsed.
 *
 * Parameters:
 *   morton    string 30|63       30     code bits: 10 or 21 per axis
 *   max_leaf  int [1, 64]        8      primitives per leaf at most
 *   collapse  bool               false  build to single primitives, then make leaves of
 *                                       subtrees of <= max_leaf primitives where the SAH prefers
 *   t_node    float [0.01, 100]  1.0    SAH cost of visiting an inner node (collapse)
 *   t_tri     float [0.01, 100]  1.0    SAH cost of one ray/triangle test (collapse)
 *
 * Example: accelerator = { plugin = "lbvh"; morton = "63"; collapse = true; };
 *
 * Leaves of up to 8 by default, as Embree LOW's: lbvh is the builder for
 * when build time counts most. max_leaf = 4 gives the better trees where
 * tracing dominates.
 *
 * The sort is stable, so equal codes keep index order whichever way it
 * runs: on one thread below 2^17 primitives, least significant digit
 * first over the whole array (in cache); otherwise one pass by the top
 * digit, then each of its buckets (2048; fewer for small inputs on many
 * threads) by the remaining bits where it stays in cache: one pass over
 * memory, or between the cores' caches, instead of three.
 *
 * Depth is at most the code bits plus 33 levels of halving. The tree does
 * not depend on thread_count. Its slots hold the children pairs in
 * depth-first order, left first, which is the order a build on one
 * thread fills them from the root. On several threads the top of the
 * tree is split into subtrees of at most 4096 primitives (fewer for small
 * inputs: about 8 subtrees a thread, at least 512), a node over m
 * primitives owning the 2m - 2 slots of its region. Without collapse,
 * the threads first count each subtree's nodes (its splits alone, from
 * its codes: no bounds are read), the calling thread lays the
 * subtrees and the pairs above them out in slot order, and each subtree
 * is built where it stays: the nodes are written once, densely. With
 * collapse a subtree's size is known only once built: each fills the
 * start of its region, its inner nodes are renumbered for the slots its
 * region leaves unused before it (on the threads), and its block and the
 * pairs above it move down by as much, which leaves the same slots as one
 * thread; the moves run on the threads too, taken in slot order, each
 * once the moves whose slots it overwrites are done. Those regions are
 * nearly full (the tree goes down to single primitives), so the node
 * array may be in huge pages either way.
 */
#include <rtk/rtk.h>

#include <math.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#define PAUSE() _mm_pause()
#else
#define PAUSE() ((void)0)
#endif

/* Subtrees at most this large are built by one thread; larger ones are
 * split first (only when several threads build). Smaller inputs take a
 * grain of their size over LBVH_TASKS subtrees a thread, at least
 * LBVH_MIN_GRAIN, so that threads that finish early find work. */
#define LBVH_GRAIN 4096
#define LBVH_TASKS 8
#define LBVH_MIN_GRAIN 512
/* Fewest primitives worth a thread of their own. */
#define LBVH_PART 4096
/* Bits of the radix sort's digits. */
#define LBVH_DIGIT 11
/* From this many primitives on (their codes and ids outgrow a core's L2),
 * and at any size on threads, the sort goes over memory once, by the top
 * digit, and sorts each bucket by the rest where it stays in cache. */
#define LBVH_MSD_MIN (1u << 17)
/* The top digit has fewer bits where a thread's share of a bucket would
 * average under LBVH_RUN codes (a cache line of ids), down to
 * LBVH_MIN_TOP: threads scattering into one bucket write the lines at
 * its part boundaries both. */
#define LBVH_RUN 16
#define LBVH_MIN_TOP 4
/* Buckets a thread takes at a time, at most (fewer where there are few
 * buckets a thread); buckets at most LBVH_SMALL_BUCKET are sorted by
 * insertion, from LBVH_LARGE_BUCKET in the fewest LSD passes
 * (sort_bucket). */
#define LBVH_BUCKET_GRAB 16
#define LBVH_SMALL_BUCKET 48
#define LBVH_LARGE_BUCKET 512
/* Slots ahead whose bounds a leaf prefetches. */
#define LBVH_PREFETCH 16
/* Nodes the top-level planner keeps pending (> the depth bound, 96). */
#define LBVH_PENDING 128

typedef struct lbvh {
    uint32_t bits, max_leaf;
    int collapse;
    float t_node, t_tri;
} lbvh;

/* A subtree to build: its slot, sorted primitives [begin, end) and the
 * first of the 2 (end - begin) - 2 slots its descendants own; once built,
 * the end of the slots they fill, [region, filled), and the slots they
 * move down when the gaps close. */
typedef struct task {
    uint32_t slot, begin, end, region;
    uint32_t filled, shift;
} task;

/* A run of slots that closing the gaps moves down, [src, src + len) to
 * dst, once the moves before it that read the slots it overwrites are
 * done: all of the first `after`. */
typedef struct move {
    uint32_t src, dst, len, after;
} move;

/* One build, shared by its threads. */
typedef struct build {
    const lbvh *opt;
    rtk_build_args *a;
    float (*cbounds)[6];           /* per thread: centroid bounds of its part */
    void *codes, *codes_tmp;       /* Morton codes, sorted with ids: uint32_t (30 bits) or uint64_t */
    uint32_t *ids_tmp;             /* ids of the other sort buffer */
    uint32_t (*hist)[1 << LBVH_DIGIT]; /* per thread: digit counts */
    task *tasks;                   /* subtrees for the threads, in slot order */
    uint32_t task_count, grain;    /* subtrees of at most grain primitives */
    uint32_t gap_total;            /* the slots all subtrees leave unused */
    atomic_uint next_task, next_fix, next_bucket, next_size;
    atomic_uint planned, shifted;  /* set by member 0: tasks planned, their shifts summed */
    task *tops;                    /* inner nodes above the subtrees, parents first (slot order) */
    uint32_t top_count, task_cap, top_cap;
    int failed;                    /* set by member 0 before planned: out of memory */
    move *moves;                   /* closing the gaps, in slot order */
    uint32_t move_count;
    atomic_uint next_move, moved;  /* the next move to take; the moves all done before it */
    atomic_uchar *move_done;       /* per move */
} build;

static rtk_status lbvh_create(const rtk_params *params, void **state)
{
    lbvh *l = malloc(sizeof *l);
    if (!l)
        return rtk_error(RTK_ERR_NOMEM, "lbvh: out of memory");
    l->bits = strcmp(rtk_params_string(params, "morton"), "63") == 0 ? 63 : 30;
    l->max_leaf = (uint32_t)rtk_params_int(params, "max_leaf");
    l->collapse = rtk_params_bool(params, "collapse");
    l->t_node = (float)rtk_params_float(params, "t_node");
    l->t_tri = (float)rtk_params_float(params, "t_tri");
    *state = l;
    return RTK_OK;
}

/* Exact like fminf/fmaxf on the finite bounds the kernel passes, and a
 * single instruction where fminf is a library call. */
static inline float min_f(float a, float b)
{
    return a < b ? a : b;
}

static inline float max_f(float a, float b)
{
    return a > b ? a : b;
}

/* Spreads the low 10 bits of x to every third bit. */
static uint32_t spread10(uint32_t x)
{
    x &= 0x3ffu;
    x = (x | x << 16) & 0x030000ffu;
    x = (x | x << 8) & 0x0300f00fu;
    x = (x | x << 4) & 0x030c30c3u;
    x = (x | x << 2) & 0x09249249u;
    return x;
}

/* Spreads the low 21 bits of x to every third bit. */
static uint64_t spread21(uint64_t x)
{
    x &= 0x1fffffu;
    x = (x | x << 32) & 0x1f00000000ffffull;
    x = (x | x << 16) & 0x1f0000ff0000ffull;
    x = (x | x << 8) & 0x100f00f00f00f00full;
    x = (x | x << 4) & 0x10c30c30c30c30c3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

/* Code i of codes, 64-bit codes when wide, else 32-bit: 30-bit codes
 * sort and search in half the memory. Always inlined into functions
 * that take wide as a constant, so each has one plain loop per width. */
static inline __attribute__((always_inline)) uint64_t code_at(const void *codes, int wide, uint32_t i)
{
    return wide ? ((const uint64_t *)codes)[i] : ((const uint32_t *)codes)[i];
}

static inline __attribute__((always_inline)) void code_set(void *codes, int wide, uint32_t i, uint64_t code)
{
    if (wide)
        ((uint64_t *)codes)[i] = code;
    else
        ((uint32_t *)codes)[i] = (uint32_t)code;
}

/* Cell of v in [0, cells - 1]; NaN (0 * inf on a tiny extent) gives 0. */
static inline uint32_t quantise(float v, float lo, float scale, float last)
{
    float f = (v - lo) * scale;
    return f >= last ? (uint32_t)last : f > 0.0f ? (uint32_t)f : 0;
}

/* Part [begin, end) of n for thread t of team. */
static void part(uint32_t n, uint32_t t, uint32_t team, uint32_t *begin, uint32_t *end)
{
    *begin = (uint32_t)((uint64_t)n * t / team);
    *end = (uint32_t)((uint64_t)n * (t + 1) / team);
}

#if defined(__SSE2__)
/* A centroid as four floats, the fourth 0. */
static inline __m128 load_centroid(const rtk_vec3 *c)
{
    return _mm_movelh_ps(_mm_loadl_pi(_mm_setzero_ps(), (const __m64 *)(const void *)c), _mm_load_ss(&c->z));
}

/* spread10 on each lane. */
static inline __m128i spread10_lanes(__m128i x)
{
    x = _mm_and_si128(x, _mm_set1_epi32(0x3ff));
    x = _mm_and_si128(_mm_or_si128(x, _mm_slli_epi32(x, 16)), _mm_set1_epi32(0x030000ff));
    x = _mm_and_si128(_mm_or_si128(x, _mm_slli_epi32(x, 8)), _mm_set1_epi32(0x0300f00f));
    x = _mm_and_si128(_mm_or_si128(x, _mm_slli_epi32(x, 4)), _mm_set1_epi32(0x030c30c3));
    x = _mm_and_si128(_mm_or_si128(x, _mm_slli_epi32(x, 2)), _mm_set1_epi32(0x09249249));
    return x;
}
#endif

static void morton_codes(build *b, rtk_team *team, uint32_t t, uint32_t size)
{
    const rtk_build_args *a = b->a;
    uint32_t begin, end;
    part(a->prim_count, t, size, &begin, &end);
    float *cb = b->cbounds[t];
#if defined(__SSE2__)
    __m128 clo = _mm_set1_ps(INFINITY), chi = _mm_set1_ps(-INFINITY);
    for (uint32_t i = begin; i < end; i++) {
        const __m128 c = load_centroid(&a->centroids[i]);
        clo = _mm_min_ps(clo, c), chi = _mm_max_ps(chi, c);
    }
    float lo4[4], hi4[4];
    _mm_storeu_ps(lo4, clo), _mm_storeu_ps(hi4, chi);
    for (int k = 0; k < 3; k++)
        cb[k] = lo4[k], cb[3 + k] = hi4[k];
#else
    cb[0] = cb[1] = cb[2] = INFINITY;
    cb[3] = cb[4] = cb[5] = -INFINITY;
    for (uint32_t i = begin; i < end; i++) {
        const rtk_vec3 *c = &a->centroids[i];
        cb[0] = min_f(cb[0], c->x), cb[1] = min_f(cb[1], c->y), cb[2] = min_f(cb[2], c->z);
        cb[3] = max_f(cb[3], c->x), cb[4] = max_f(cb[4], c->y), cb[5] = max_f(cb[5], c->z);
    }
#endif
    rtk_team_sync(team);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t u = 0; u < size; u++) {
        for (int k = 0; k < 3; k++) {
            lo[k] = min_f(lo[k], b->cbounds[u][k]);
            hi[k] = max_f(hi[k], b->cbounds[u][3 + k]);
        }
    }
    const uint32_t per_axis = b->opt->bits / 3;
    const float cells = (float)(1u << per_axis), last = cells - 1.0f;
    float scale[3];
    for (int k = 0; k < 3; k++) {
        float extent = hi[k] - lo[k];
        scale[k] = extent > 0.0f ? cells / extent : 0.0f;
    }
    void *codes = b->codes;
    const int wide = per_axis != 10;
    uint32_t *ids = a->prim_order;
#if defined(__SSE2__)
    if (!wide) {
        /* quantise on the three lanes: (c - lo) * scale clamped to [0,
         * last], NaN to 0 (max returns its second operand for NaN). */
        const __m128 vlo = _mm_setr_ps(lo[0], lo[1], lo[2], 0.0f), vscale = _mm_setr_ps(scale[0], scale[1], scale[2], 0.0f);
        const __m128 vlast = _mm_set1_ps(last), zero = _mm_setzero_ps();
        for (uint32_t i = begin; i < end; i++) {
            const __m128 f = _mm_mul_ps(_mm_sub_ps(load_centroid(&a->centroids[i]), vlo), vscale);
            const __m128i q = spread10_lanes(_mm_cvttps_epi32(_mm_min_ps(_mm_max_ps(f, zero), vlast)));
            const uint32_t x = (uint32_t)_mm_cvtsi128_si32(q), y = (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(q, 1)),
                           z = (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(q, 2));
            code_set(codes, 0, i, x << 2 | y << 1 | z);
            ids[i] = i;
        }
        rtk_team_sync(team);
        return;
    }
#endif
    for (uint32_t i = begin; i < end; i++) {
        const rtk_vec3 *c = &a->centroids[i];
        uint32_t x = quantise(c->x, lo[0], scale[0], last);
        uint32_t y = quantise(c->y, lo[1], scale[1], last);
        uint32_t z = quantise(c->z, lo[2], scale[2], last);
        if (!wide)
            code_set(codes, 0, i, spread10(x) << 2 | spread10(y) << 1 | spread10(z));
        else
            code_set(codes, 1, i, spread21(x) << 2 | spread21(y) << 1 | spread21(z));
        ids[i] = i;
    }
    rtk_team_sync(team);
}

/* Moves (ks, is)[from, to) to (kd, id), each element to the slot
 * next[digit]++ of its digit (key >> shift) & mask: in order, so stably. */
static inline __attribute__((always_inline)) void scatter(const void *ks, const uint32_t *is, void *kd, uint32_t *id,
                                                          uint32_t from, uint32_t to, uint32_t shift, uint32_t mask,
                                                          uint32_t *next, int wide)
{
    for (uint32_t i = from; i < to; i++) {
        const uint64_t key = code_at(ks, wide, i);
        const uint32_t at = next[key >> shift & mask]++;
        code_set(kd, wide, at, key);
        id[at] = is[i];
    }
}

/* Copies (ks, is)[from, to) to the same slots of (kd, id). */
static inline __attribute__((always_inline)) void copy_codes(const void *ks, const uint32_t *is, void *kd, uint32_t *id,
                                                             uint32_t from, uint32_t to, int wide)
{
    const size_t key_bytes = wide ? sizeof(uint64_t) : sizeof(uint32_t);
    memcpy((char *)kd + key_bytes * from, (const char *)ks + key_bytes * from, key_bytes * (to - from));
    memcpy(id + from, is + from, sizeof *is * (to - from));
}

/* Counts the digits (key >> shift) & (2^width - 1) of thread t's part
 * [begin, end) of ks, waits for every thread's counts, and gives
 * thread t's first slot for each digit in offset (all smaller digits,
 * then this digit in the threads before) and, with start, each digit's
 * first slot of all. Returns the largest count of one digit. */
static inline __attribute__((always_inline)) uint32_t digit_offsets(build *b, rtk_team *team, uint32_t t,
                                                                    uint32_t size, const void *ks, uint32_t begin,
                                                                    uint32_t end, uint32_t shift, uint32_t width,
                                                                    uint32_t *offset, uint32_t *start, int wide)
{
    const uint32_t digits = 1u << width;
    uint32_t *hist = b->hist[t];
    memset(hist, 0, sizeof *hist * digits);
    for (uint32_t i = begin; i < end; i++)
        hist[code_at(ks, wide, i) >> shift & (digits - 1)]++;
    rtk_team_sync(team);
    uint32_t sum = 0, most = 0;
    for (uint32_t d = 0; d < digits; d++) {
        uint32_t total = 0;
        for (uint32_t u = 0; u < size; u++) {
            if (u == t)
                offset[d] = sum + total;
            total += b->hist[u][d];
        }
        if (start)
            start[d] = sum;
        most = total > most ? total : most;
        sum += total;
    }
    return most;
}

/* Stable LSD radix sort of (code, id) by code; every thread scatters its
 * own part, after the others' digit counts. The result ends in codes and
 * prim_order. */
static inline __attribute__((always_inline)) void sort_codes_width(build *b, rtk_team *team, uint32_t t, uint32_t size,
                                                                   int wide)
{
    const uint32_t n = b->a->prim_count, digits = 1u << LBVH_DIGIT;
    uint32_t begin, end;
    part(n, t, size, &begin, &end);
    void *ks = b->codes, *kd = b->codes_tmp;
    uint32_t *is = b->a->prim_order, *id = b->ids_tmp;
    for (uint32_t shift = 0; shift < b->opt->bits; shift += LBVH_DIGIT) {
        uint32_t offset[1 << LBVH_DIGIT];
        if (digit_offsets(b, team, t, size, ks, begin, end, shift, LBVH_DIGIT, offset, NULL, wide) < n) {
            scatter(ks, is, kd, id, begin, end, shift, digits - 1, offset, wide);
            void *tk = ks;
            ks = kd, kd = tk;
            uint32_t *ti = is;
            is = id, id = ti;
        }
        rtk_team_sync(team);
    }
    if (ks != b->codes) {
        copy_codes(ks, is, b->codes, b->a->prim_order, begin, end, wide);
        rtk_team_sync(team);
    }
}

/* Sorts [lo, hi) of the bucket arrays (kt, it), whose keys share their
 * bits from `low` up, by their low bits, stably, into the same range of
 * (ks, is). */
static inline __attribute__((always_inline)) void sort_bucket(void *ks, uint32_t *is, void *kt, uint32_t *it,
                                                              uint32_t lo, uint32_t hi, uint32_t low, int wide)
{
    const uint32_t m = hi - lo;
    if (m <= LBVH_SMALL_BUCKET) {
        /* Insertion, stable: an element passes only greater keys. */
        for (uint32_t i = lo; i < hi; i++) {
            const uint64_t key = code_at(kt, wide, i);
            const uint32_t id = it[i];
            uint32_t j = i;
            while (j > lo && code_at(ks, wide, j - 1) > key) {
                code_set(ks, wide, j, code_at(ks, wide, j - 1));
                is[j] = is[j - 1];
                j--;
            }
            code_set(ks, wide, j, key);
            is[j] = id;
        }
        return;
    }
    /* LSD by digits of up to LBVH_DIGIT bits. A small bucket takes an
     * odd number of passes, so that the last writes (ks, is); a large one
     * the fewest, then a copy back where they are even: a pass over it
     * costs more than counting the wider digits (30-bit codes: two passes
     * of 10 bits, not three of 7). */
    uint32_t passes = (low + LBVH_DIGIT - 1) / LBVH_DIGIT;
    passes += m < LBVH_LARGE_BUCKET && passes % 2 == 0;
    const uint32_t width = (low + passes - 1) / passes, digits = 1u << width;
    uint32_t count[1 << LBVH_DIGIT];
    void *src_k = kt, *dst_k = ks;
    uint32_t *src_i = it, *dst_i = is;
    for (uint32_t p = 0, shift = 0; p < passes; p++, shift += width) {
        memset(count, 0, sizeof *count * digits);
        for (uint32_t i = lo; i < hi; i++)
            count[code_at(src_k, wide, i) >> shift & (digits - 1)]++;
        for (uint32_t d = 0, sum = lo; d < digits; d++) {
            const uint32_t c = count[d];
            count[d] = sum;
            sum += c;
        }
        scatter(src_k, src_i, dst_k, dst_i, lo, hi, shift, digits - 1, count, wide);
        void *tk = src_k;
        src_k = dst_k, dst_k = tk;
        uint32_t *ti = src_i;
        src_i = dst_i, dst_i = ti;
    }
    if (src_k != ks)
        copy_codes(src_k, src_i, ks, is, lo, hi, wide);
}

/* Bits of the top digit for n codes on size threads (LBVH_RUN). */
static uint32_t top_digit_bits(uint32_t n, uint32_t size)
{
    uint32_t width = LBVH_DIGIT;
    while (width > LBVH_MIN_TOP && n >> width < LBVH_RUN * size)
        width--;
    return width;
}

/* Buckets a thread takes at a time: about LBVH_TASKS grabs a thread. */
static uint32_t bucket_grab(uint32_t digits, uint32_t size)
{
    const uint32_t grab = digits / (LBVH_TASKS * size);
    return grab < 1 ? 1 : grab > LBVH_BUCKET_GRAB ? LBVH_BUCKET_GRAB : grab;
}

/* The same order as sort_codes_width for large inputs and on threads,
 * with one pass over memory instead of three (and a copy back): every
 * thread counts and scatters its part by the top digit (stably: a
 * thread's elements of a digit follow the earlier threads'), then the
 * threads take buckets and sort each by the lower bits in cache
 * (sort_bucket). A stable sort by the whole code gives one order, so the
 * tree is the same either way. */
static inline __attribute__((always_inline)) void sort_codes_msd(build *b, rtk_team *team, uint32_t t, uint32_t size,
                                                                 int wide)
{
    const uint32_t n = b->a->prim_count, width = top_digit_bits(n, size), digits = 1u << width;
    const uint32_t low = b->opt->bits - width, grab = bucket_grab(digits, size);
    uint32_t begin, end;
    part(n, t, size, &begin, &end);
    void *ks = b->codes, *kt = b->codes_tmp;
    uint32_t *is = b->a->prim_order, *it = b->ids_tmp;
    uint32_t offset[1 << LBVH_DIGIT], start[(1 << LBVH_DIGIT) + 1];
    digit_offsets(b, team, t, size, ks, begin, end, low, width, offset, start, wide);
    start[digits] = n;
    scatter(ks, is, kt, it, begin, end, low, digits - 1, offset, wide);
    rtk_team_sync(team);
    for (;;) {
        const uint32_t first = atomic_fetch_add(&b->next_bucket, grab);
        if (first >= digits)
            break;
        const uint32_t last = first + grab < digits ? first + grab : digits;
        for (uint32_t d = first; d < last; d++)
            sort_bucket(ks, is, kt, it, start[d], start[d + 1], low, wide);
    }
    rtk_team_sync(team);
}

/* The sort by the top digit first, out of line, so that it does not
 * change how the LSD sort is compiled. */
static __attribute__((noinline)) void sort_codes_top(build *b, rtk_team *team, uint32_t t, uint32_t size)
{
    if (b->opt->bits == 63)
        sort_codes_msd(b, team, t, size, 1);
    else
        sort_codes_msd(b, team, t, size, 0);
}

/* On threads every LSD pass would move each code and id between the
 * members' caches, the first pass by the top digit moves them once. */
static void sort_codes(build *b, rtk_team *team, uint32_t t, uint32_t size)
{
    if (b->a->prim_count >= LBVH_MSD_MIN || size > 1)
        sort_codes_top(b, team, t, size);
    else if (b->opt->bits == 63)
        sort_codes_width(b, team, t, size, 1);
    else
        sort_codes_width(b, team, t, size, 0);
}

/* First slot of the right half of sorted codes [begin, end), count >= 2. */
static inline __attribute__((always_inline)) uint32_t split_at_width(const void *codes, int wide, uint32_t begin,
                                                                     uint32_t end)
{
    uint64_t diff = code_at(codes, wide, begin) ^ code_at(codes, wide, end - 1);
    if (diff == 0)
        return begin + (end - begin) / 2;
    /* All codes share the bits above the highest differing one: those with
     * it clear come first. */
    uint64_t bit = 1ull << (63 - __builtin_clzll(diff));
    uint32_t lo = begin + 1, hi = end - 1;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (code_at(codes, wide, mid) & bit)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

static uint32_t split_at(const build *b, uint32_t begin, uint32_t end)
{
    return b->opt->bits == 63 ? split_at_width(b->codes, 1, begin, end) : split_at_width(b->codes, 0, begin, end);
}

static float half_area(const rtk_bvh_node *n)
{
    float dx = n->upper[0] - n->lower[0], dy = n->upper[1] - n->lower[1], dz = n->upper[2] - n->lower[2];
    return dx * dy + dy * dz + dz * dx;
}

static void node_union(rtk_bvh_node *n, const rtk_bvh_node *l, const rtk_bvh_node *r)
{
    for (int k = 0; k < 3; k++) {
        n->lower[k] = min_f(l->lower[k], r->lower[k]);
        n->upper[k] = max_f(l->upper[k], r->upper[k]);
    }
}

/* Builds the subtree at slot over sorted primitives [begin, end) with
 * its bounds, its descendants in the slots from *bump on, in the order
 * they are made (children pairs depth first, left first); returns its SAH
 * cost in units of area when collapsing (else 0). The fields are
 * separate arguments: a task passed by value went through a 16-byte
 * stack store read back as two 8-byte loads (one of them not forwarded),
 * a stall at every node. */
static float emit(const build *b, uint32_t slot, uint32_t begin, uint32_t end, uint32_t *bump)
{
    const lbvh *o = b->opt;
    rtk_build_args *a = b->a;
    rtk_bvh_node *n = &a->nodes[slot];
    const uint32_t count = end - begin;
    if (count <= (o->collapse ? 1 : o->max_leaf)) {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t i = begin; i < end; i++) {
            /* Leaves come in slot order and their primitives' bounds
             * are all over memory: ask for those of a later leaf. */
            if (i + LBVH_PREFETCH < a->prim_count)
                __builtin_prefetch(&a->prim_bounds[a->prim_order[i + LBVH_PREFETCH]]);
            const rtk_bounds *pb = &a->prim_bounds[a->prim_order[i]];
            lo[0] = min_f(lo[0], pb->lower.x), lo[1] = min_f(lo[1], pb->lower.y), lo[2] = min_f(lo[2], pb->lower.z);
            hi[0] = max_f(hi[0], pb->upper.x), hi[1] = max_f(hi[1], pb->upper.y), hi[2] = max_f(hi[2], pb->upper.z);
        }
        memcpy(n->lower, lo, sizeof lo);
        memcpy(n->upper, hi, sizeof hi);
        n->offset = begin;
        n->count = count;
        return o->collapse ? o->t_tri * (float)count * half_area(n) : 0.0f;
    }
    const uint32_t first = *bump;
    *bump += 2;
    uint32_t mid = split_at(b, begin, end);
    float cost = emit(b, first, begin, mid, bump);
    cost += emit(b, first + 1, mid, end, bump);
    node_union(n, &a->nodes[first], &a->nodes[first + 1]);
    if (!o->collapse) {
        n->offset = first;
        n->count = 0;
        return 0.0f;
    }
    float area = half_area(n), leaf = o->t_tri * (float)count * area;
    cost += o->t_node * area;
    if (count <= o->max_leaf && leaf <= cost) {
        /* The descendants are the slots [first, *bump), free again for
         * what follows. */
        *bump = first;
        n->offset = begin;
        n->count = count;
        return leaf;
    }
    n->offset = first;
    n->count = 0;
    return cost;
}

/* Appends t to the array *list of *count, growing its capacity *cap;
 * 0 when out of memory. */
static int push_task(task **list, uint32_t *count, uint32_t *cap, task t)
{
    if (*count == *cap) {
        const uint32_t grown = *cap ? 2 * *cap : 64;
        task *more = realloc(*list, sizeof *more * grown);
        if (!more)
            return 0;
        *list = more, *cap = grown;
    }
    (*list)[(*count)++] = t;
    return 1;
}

/* Splits the top of the tree into subtrees of at most grain primitives;
 * records the inner nodes above them, parents first, and with collapse
 * makes room for the moves (one per subtree and per node above them at
 * most). 0 when out of memory. */
static int plan(build *b, uint32_t grain)
{
    task pending[LBVH_PENDING];
    uint32_t top = 0;
    b->task_count = 0;
    b->top_count = 0;
    pending[top++] = (task){.slot = 0, .begin = 0, .end = b->a->prim_count, .region = 1};
    while (top > 0) {
        task t = pending[--top];
        if (t.end - t.begin <= grain || top + 2 > LBVH_PENDING) {
            if (!push_task(&b->tasks, &b->task_count, &b->task_cap, t))
                return 0;
            continue;
        }
        uint32_t mid = split_at(b, t.begin, t.end);
        if (!push_task(&b->tops, &b->top_count, &b->top_cap, t))
            return 0;
        pending[top++] =
            (task){.slot = t.region + 1, .begin = mid, .end = t.end, .region = t.region + 2 * (mid - t.begin)};
        pending[top++] = (task){.slot = t.region, .begin = t.begin, .end = mid, .region = t.region + 2};
    }
    if (!b->opt->collapse)
        return 1;
    const size_t moves = (size_t)b->task_count + b->top_count;
    b->moves = malloc(sizeof *b->moves * moves);
    b->move_done = malloc(sizeof *b->move_done * moves);
    return b->moves && b->move_done;
}

/* Slots the descendants of a node over sorted primitives [begin, end)
 * fill when the tree is not collapsed: two for each inner node below it. */
static uint32_t slots_below(const build *b, uint32_t begin, uint32_t end)
{
    uint32_t slots = 0;
    while (end - begin > b->opt->max_leaf) {
        const uint32_t mid = split_at(b, begin, end);
        slots += 2 + slots_below(b, begin, mid);
        begin = mid;
    }
    return slots;
}

/* Where slot s of a pair above the subtrees (or the root's) lands once
 * the gaps before it are closed: down by the unused slots of the
 * subtrees whose regions come before it. */
static uint32_t closed_slot(const build *b, uint32_t s)
{
    uint32_t lo = 0, hi = b->task_count;
    while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (b->tasks[mid].region < s)
            lo = mid + 1;
        else
            hi = mid;
    }
    return s - (lo < b->task_count ? b->tasks[lo].shift : b->gap_total);
}

/* Sums the slots each subtree's region leaves unused, before it, once
 * every task's filled is known. */
static void sum_gaps(build *b)
{
    uint32_t shift = 0;
    for (uint32_t k = 0; k < b->task_count; k++) {
        task *x = &b->tasks[k];
        x->shift = shift;
        shift += x->region + 2 * (x->end - x->begin) - 2 - x->filled;
    }
    b->gap_total = shift;
}

/* The tree without collapse, on threads: each subtree's size is known
 * before it is built (slots_below, on the threads), so each is built
 * where it stays (from region - shift), the pairs above the subtrees are
 * laid out between them in slot order, and nothing moves afterwards.
 * Sets the tasks' slots to their final places, and node_count. */
static void lay_out(build *b)
{
    sum_gaps(b);
    uint32_t count = 1 + 2 * b->top_count;
    for (uint32_t k = 0; k < b->task_count; k++) {
        task *x = &b->tasks[k];
        count += x->filled - x->region;
        x->slot = closed_slot(b, x->slot);
    }
    b->a->node_count = count;
}

/* The nodes above the subtrees in their final slots, children before
 * parents, once the subtrees are built (lay_out). */
static void top_bounds(build *b)
{
    rtk_bvh_node *nodes = b->a->nodes;
    for (uint32_t i = b->top_count; i-- > 0;) {
        const task *t = &b->tops[i];
        const uint32_t slot = closed_slot(b, t->slot), first = closed_slot(b, t->region);
        node_union(&nodes[slot], &nodes[first], &nodes[first + 1]);
        nodes[slot].offset = first;
        nodes[slot].count = 0;
    }
}

/* Plans closing the gaps the subtrees left (run renumbered their nodes):
 * the nodes above them get their bounds and children, then the children
 * pairs above the subtrees and the subtrees' blocks are to move down in
 * slot order, each by the unused slots before it (run_moves). Sets
 * node_count. */
static void plan_moves(build *b)
{
    rtk_bvh_node *nodes = b->a->nodes;
    for (uint32_t i = b->top_count; i-- > 0;) { /* children before parents, all in place */
        const task *t = &b->tops[i];
        node_union(&nodes[t->slot], &nodes[t->region], &nodes[t->region + 1]);
        nodes[t->slot].count = 0;
    }
    for (uint32_t i = 0; i < b->top_count; i++) {
        task *t = &b->tops[i];
        nodes[t->slot].offset = closed_slot(b, t->region);
        t->shift = t->region - nodes[t->slot].offset;
    }
    uint32_t count = 1;
    b->move_count = 0;
    uint32_t k = 0;
    for (uint32_t i = 0; i <= b->top_count; i++) {
        const uint32_t below = i < b->top_count ? b->tops[i].region : UINT32_MAX;
        for (; k < b->task_count && b->tasks[k].region < below; k++) {
            const task *x = &b->tasks[k];
            if (x->shift && x->filled > x->region)
                b->moves[b->move_count++] = (move){x->region, x->region - x->shift, x->filled - x->region, 0};
            count += x->filled - x->region;
        }
        if (i == b->top_count)
            break;
        const task *t = &b->tops[i];
        if (t->shift)
            b->moves[b->move_count++] = (move){t->region, t->region - t->shift, 2, 0};
        count += 2;
    }
    b->a->node_count = count;
    /* Sources and destinations both ascend: the moves whose sources
     * start below a destination's end are a prefix, and a move waits for
     * those of them before it. */
    uint32_t reads = 0;
    for (uint32_t m = 0; m < b->move_count; m++) {
        move *mv = &b->moves[m];
        while (reads < b->move_count && b->moves[reads].src < mv->dst + mv->len)
            reads++;
        mv->after = reads < m ? reads : m;
        atomic_init(&b->move_done[m], 0);
    }
    atomic_init(&b->next_move, 0);
    atomic_init(&b->moved, 0);
}

/* A member's share of the moves plan_moves planned: each taken in slot
 * order, made once the moves it overwrites have read their slots. The
 * destination's pages are mostly touched for the first time here, which
 * is most of the cost, so every member shares it. */
static void run_moves(build *b)
{
    rtk_bvh_node *nodes = b->a->nodes;
    for (;;) {
        uint32_t k = atomic_fetch_add(&b->next_move, 1);
        if (k >= b->move_count)
            break;
        const move *mv = &b->moves[k];
        while (atomic_load(&b->moved) < mv->after)
            PAUSE();
        memmove(nodes + mv->dst, nodes + mv->src, sizeof *nodes * mv->len);
        /* Moves done in a row from the first: advance the count. Sequentially
         * consistent, as sah.c's gap_member: release and acquire would let this
         * store and another member's advance past k - 1 miss each other. */
        atomic_store(&b->move_done[k], 1);
        uint32_t p = atomic_load(&b->moved);
        while (p < b->move_count && atomic_load(&b->move_done[p]))
            if (atomic_compare_exchange_weak(&b->moved, &p, p + 1))
                p++;
    }
}

/* Waits until member 0 has set flag (a wait only the others make: member
 * 0, which runs the serial steps, never waits for a member still waking
 * from the last sync). */
static void wait_for(atomic_uint *flag)
{
    for (uint32_t i = 1; !atomic_load_explicit(flag, memory_order_acquire); i++) {
        PAUSE();
        if (i % 256 == 0)
            sched_yield();
    }
}

/* Member t's share of the subtrees without collapse: their sizes, their
 * layout (member 0), then each built in its final slots (lay_out). */
static void run_dense(build *b, rtk_team *team, uint32_t t, uint32_t size)
{
    const int many = size > 1;
    if (b->task_count > 1) {
        if (t == 0)
            rtk_build_phase(b->a, "lbvh: subtree sizes", many);
        for (;;) {
            const uint32_t k = atomic_fetch_add(&b->next_size, 1);
            if (k >= b->task_count)
                break;
            task *x = &b->tasks[k];
            x->filled = x->region + slots_below(b, x->begin, x->end);
        }
        rtk_team_sync(team);
        if (t == 0) {
            rtk_build_phase(b->a, "lbvh: layout", 0);
            lay_out(b);
            atomic_store_explicit(&b->shifted, 1, memory_order_release);
        } else {
            wait_for(&b->shifted);
        }
    }
    if (t == 0)
        rtk_build_phase(b->a, "lbvh: subtrees", many);
    for (;;) {
        const uint32_t k = atomic_fetch_add(&b->next_task, 1);
        if (k >= b->task_count)
            break;
        task *x = &b->tasks[k];
        uint32_t bump = x->region - x->shift;
        emit(b, x->slot, x->begin, x->end, &bump);
        if (b->task_count == 1)
            b->a->node_count = bump;
    }
    rtk_team_sync(team);
    if (t == 0 && b->top_count > 0) {
        rtk_build_phase(b->a, "lbvh: top bounds", 0);
        top_bounds(b);
    }
}

/* Member t's share of the subtrees with collapse, whose sizes are known
 * only once built: each fills the start of its region, then its inner
 * nodes are renumbered for the gaps before it and the blocks move down
 * (plan_moves, run_moves). */
static void run_collapsed(build *b, rtk_team *team, uint32_t t, uint32_t size)
{
    const int many = size > 1;
    if (t == 0)
        rtk_build_phase(b->a, "lbvh: subtrees", many);
    for (;;) {
        uint32_t k = atomic_fetch_add(&b->next_task, 1);
        if (k >= b->task_count)
            break;
        task *x = &b->tasks[k];
        uint32_t bump = x->region;
        emit(b, x->slot, x->begin, x->end, &bump);
        x->filled = bump;
    }
    rtk_team_sync(team);
    if (t == 0) {
        rtk_build_phase(b->a, "lbvh: gaps", 0);
        sum_gaps(b);
        atomic_store_explicit(&b->shifted, 1, memory_order_release);
        /* Beside the others' renumbering, which touches other nodes (the
         * subtrees') or other fields of them (their roots' offsets, where
         * this reads bounds). */
        rtk_build_phase(b->a, "lbvh: top bounds and moves plan", 0);
        plan_moves(b);
        rtk_build_phase(b->a, "lbvh: renumber", many);
    } else {
        wait_for(&b->shifted);
    }
    /* Each subtree's inner nodes (the root's children included) point
     * where their children will be. */
    rtk_bvh_node *nodes = b->a->nodes;
    for (;;) {
        uint32_t k = atomic_fetch_add(&b->next_fix, 1);
        if (k >= b->task_count)
            break;
        const task *x = &b->tasks[k];
        if (x->shift == 0)
            continue;
        if (nodes[x->slot].count == 0)
            nodes[x->slot].offset -= x->shift;
        for (uint32_t i = x->region; i < x->filled; i++)
            if (nodes[i].count == 0)
                nodes[i].offset -= x->shift;
    }
    rtk_team_sync(team);
    if (t == 0)
        rtk_build_phase(b->a, "lbvh: moves", many);
    run_moves(b);
}

/* Member t's share of the whole build (rtk_team_fn). Member 0, the
 * thread that called build, runs the serial steps and marks the phases:
 * each ends at a sync or a flag, or at member 0's own share of a pass. */
static void run(void *ctx, rtk_team *team, uint32_t t, uint32_t size)
{
    build *b = ctx;
    const int many = size > 1;
    if (t == 0)
        rtk_build_phase(b->a, "lbvh: morton codes", many);
    morton_codes(b, team, t, size);
    if (t == 0)
        rtk_build_phase(b->a, "lbvh: sort", many);
    sort_codes(b, team, t, size);
    if (t == 0) {
        rtk_build_phase(b->a, "lbvh: top splits", 0);
        b->failed = !plan(b, size > 1 ? b->grain : UINT32_MAX);
        atomic_store_explicit(&b->planned, 1, memory_order_release);
    } else {
        wait_for(&b->planned);
    }
    if (b->failed)
        return;
    if (b->opt->collapse)
        run_collapsed(b, team, t, size);
    else
        run_dense(b, team, t, size);
}

static rtk_status lbvh_build(void *state, rtk_build_args *a)
{
    const uint32_t n = a->prim_count;
    /* Each thread gets a part of at least LBVH_PART primitives. */
    uint32_t threads = a->thread_count;
    if (threads > n / LBVH_PART)
        threads = n / LBVH_PART;
    if (threads < 1)
        threads = 1;
    uint32_t grain = n / (LBVH_TASKS * threads);
    grain = grain < LBVH_MIN_GRAIN ? LBVH_MIN_GRAIN : grain > LBVH_GRAIN ? LBVH_GRAIN : grain;
    build b = {.opt = state, .a = a, .grain = grain};
    b.cbounds = malloc(sizeof *b.cbounds * threads);
    b.hist = malloc(sizeof *b.hist * threads);
    /* The sort's arrays (12 or 20 bytes a primitive) in the kernel's scratch
     * when it has room, else of their own. */
    const size_t key_bytes = b.opt->bits == 63 ? sizeof(uint64_t) : sizeof(uint32_t);
    void *scratch = rtk_build_scratch(a, (2 * key_bytes + sizeof *b.ids_tmp) * (size_t)n);
    const int in_scratch = scratch != NULL;
    if (in_scratch) {
        b.codes = scratch;
        b.codes_tmp = (char *)scratch + key_bytes * n;
        b.ids_tmp = (uint32_t *)(void *)((char *)scratch + 2 * key_bytes * n);
    } else {
        b.codes = malloc(key_bytes * n);
        b.codes_tmp = malloc(key_bytes * n);
        b.ids_tmp = malloc(sizeof *b.ids_tmp * n);
    }
    atomic_init(&b.next_task, 0);
    atomic_init(&b.next_fix, 0);
    atomic_init(&b.next_bucket, 0);
    atomic_init(&b.next_size, 0);
    atomic_init(&b.planned, 0);
    atomic_init(&b.shifted, 0);
    rtk_status st = RTK_OK;
    if (!b.cbounds || !b.hist || !b.codes || !b.codes_tmp || !b.ids_tmp) {
        st = rtk_error(RTK_ERR_NOMEM, "lbvh: out of memory");
        goto done;
    }
    rtk_team_run(threads, run, &b);
    if (b.failed)
        st = rtk_error(RTK_ERR_NOMEM, "lbvh: out of memory planning the subtrees");
done:
    free(b.cbounds);
    free(b.hist);
    if (!in_scratch) {
        free(b.codes);
        free(b.codes_tmp);
        free(b.ids_tmp);
    }
    free(b.tasks);
    free(b.tops);
    free(b.moves);
    free((void *)b.move_done);
    return st;
}

static void lbvh_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc lbvh_params[] = {
    {.name = "morton", .type = RTK_PARAM_STRING, .def_string = "30", .choices = "30|63",
     .doc = "Morton code bits: 30 (10 per axis) or 63 (21 per axis)"},
    {.name = "max_leaf", .type = RTK_PARAM_INT, .def = 8, .min = 1, .max = 64,
     .doc = "largest number of primitives in a leaf (8: fast builds; 4: faster AO rays)"},
    {.name = "collapse", .type = RTK_PARAM_BOOL, .def = 0,
     .doc = "build down to single primitives, then make leaves of subtrees (<= max_leaf) the SAH prefers"},
    {.name = "t_node", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.01, .max = 100.0,
     .doc = "SAH cost of visiting an inner node (collapse)"},
    {.name = "t_tri", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.01, .max = 100.0,
     .doc = "SAH cost of one ray/triangle test (collapse)"},
};

static const rtk_accelerator_fns lbvh_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = lbvh_create,
    .build = lbvh_build,
    .destroy = lbvh_destroy,
    .build_flags = RTK_BUILD_NO_VERTICES,
};

static const rtk_plugin lbvh_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_ACCELERATOR,
    .name = "lbvh",
    .version = "1.0",
    .summary = "linear BVH on Morton codes (radix sort, top-down bit splits, optional SAH collapse)",
    .params = lbvh_params,
    .param_count = RTK_COUNTOF(lbvh_params),
    .functions = &lbvh_fns,
};

RTK_PLUGIN_ENTRY(lbvh_plugin)
