/* The wide BVH: any builder's binary tree collapsed into 8-wide nodes with
 * triangles packed four to a leaf block, traversed with AVX2, SSE4.1 or
 * plain C, chosen at run time. Rules for callers:
 * - rtk_wide_build runs after the binary tree and prim_ids are final (end
 *   of rtk_bvh_build, or after loading them from a cache), reading the
 *   corners from the scene (rtk_slot_corners); it replaces any previous
 *   wide tree. [main thread]
 * - Traversal reads the scene only: any thread, concurrently.
 * - Results are those of the binary traversal bit for bit: same triangle,
 *   same t, u, v, equal distances resolved to the lowest triangle id.
 * The build is bvh_wide_build.c, the traversal bvh_wide_trace.c. */
#ifndef RTK_KERNEL_BVH_WIDE_H
#define RTK_KERNEL_BVH_WIDE_H

#include "../scene/scene.h"
#include "isect.h"

#include <assert.h>
#include <float.h>
#include <math.h>

RTK_EXTERN_C_BEGIN

/* Children per node. */
#define RTK_WIDE 8
/* Triangles per leaf block. */
#define RTK_WIDE_TRIS 4
/* Deepest wide tree: the binary limit (each wide level spans at least one
 * binary level) plus levels that split oversized leaves. */
#define RTK_WIDE_MAX_DEPTH 288

/* 1 where the SSE and AVX code of the build and the traversal compiles
 * (x86, <immintrin.h>), else 0: plain C. */
#if defined(__x86_64__) || defined(__i386__)
#define RTK_HAVE_X86 1
#else
#define RTK_HAVE_X86 0
#endif


/* Traversal implementations; RTK_SIMD=binary|scalar|sse|avx2|avx512 forces
 * one. */
typedef enum rtk_simd_path {
    RTK_SIMD_BINARY = 0, /* the binary tree, one node at a time (bvh.c) */
    RTK_SIMD_SCALAR = 1, /* the wide tree in plain C */
    RTK_SIMD_SSE = 2,    /* the wide tree, SSE4.1 */
    RTK_SIMD_AVX2 = 3,   /* the wide tree, AVX2 */
    RTK_SIMD_AVX512 = 4  /* the wide tree, AVX2's loop with AVX-512F and VL */
} rtk_simd_path;
#define RTK_SIMD_PATHS 5

/* A child reference: an inner node's byte offset from the first node
 * (its index times 256), or with RTK_WIDE_LEAF set a leaf: first block <<
 * RTK_WIDE_LEAF_SHIFT | (block count - 1). Offsets below 2^31 leave room
 * for RTK_WIDE_MAX_NODES nodes (2 GiB of them, the tree of about 125
 * million triangles), the leaf's field for 2^27 blocks; a larger tree is
 * not built (rtk_wide_build says which numbers it exceeds) and the scene
 * keeps the binary traversal. */
#define RTK_WIDE_LEAF 0x80000000u
#define RTK_WIDE_LEAF_SHIFT 4
#define RTK_WIDE_LEAF_BLOCKS 16
#define RTK_WIDE_MAX_NODES (RTK_WIDE_LEAF / 256u)
/* The most nodes rtk_wide_build makes: RTK_WIDE_MAX_NODES, lowered only
 * by tests (tests/accel/wide) to reach the refusal on a small scene. */
extern uint32_t rtk_wide_node_limit;

/* One node, 256 bytes on a 64-byte boundary. bounds[2k] holds the lower
 * and bounds[2k+1] the upper coordinate on axis k of each child; an empty
 * slot has lower +inf and upper -inf, which every ray misses. */
typedef struct rtk_wide_node {
    float bounds[6][RTK_WIDE];
    uint32_t child[RTK_WIDE];
    uint32_t pad[RTK_WIDE];
} rtk_wide_node;
static_assert(sizeof(rtk_wide_node) == 256, "RTK_WIDE_MAX_NODES assumes 256-byte nodes");

/* Four triangles, structure of arrays: v[3 * corner + axis][lane]. Unused
 * lanes have prim RTK_INVALID_ID and are never reported. */
typedef struct rtk_wide_tris {
    float v[9][RTK_WIDE_TRIS];
    uint32_t prim[RTK_WIDE_TRIS];
} rtk_wide_tris;

typedef struct rtk_wide_bvh {
    rtk_wide_node *nodes;   /* root at 0 */
    uint32_t node_count;
    rtk_wide_tris *tris;
    uint32_t tri_block_count;
    uint32_t depth;         /* levels below the root, at most */
    rtk_simd_path path;     /* what rtk_bvh_closest/any use */
    void *mem[2];           /* the blocks holding nodes and tris, to free */
} rtk_wide_bvh;

/* Collapses s's binary tree into s->wide and picks the traversal path:
 * the best the CPU supports, or RTK_SIMD. Large trees are collapsed on up
 * to threads threads; the result does not depend on their number. spare
 * (NULL, or spare_bytes of rtk_alloc_large memory whose contents are
 * dead) is taken over: the wide arrays go there when they fit, else it is
 * freed. The tree's structure must have been validated, or validate set:
 * then the plan's walks validate it as they go and set s->bvh_depth, and
 * a tree that fails gets RTK_ERR_PLUGIN with rtk_bvh_validate's message.
 * On the way every binary leaf's box is checked against its triangles'
 * corners: RTK_ERR_PLUGIN (error set as rtk_bvh_check_leaves sets it)
 * when one fails, RTK_ERR_NOMEM on other failures (the leaves, and with
 * validate maybe the structure, are then unchecked; the scene keeps the
 * binary traversal). */
rtk_status rtk_wide_build(rtk_scene *s, uint32_t threads, void *spare, size_t spare_bytes, int validate);
/* Frees s->wide and sets it to NULL. */
void rtk_wide_free(rtk_scene *s);
/* Frees a wide tree taken out of its scene (NULL: nothing). */
void rtk_wide_destroy(rtk_wide_bvh *w);

/* The best path this CPU supports. */
rtk_simd_path rtk_simd_best(void);
/* Whether this CPU can run path. */
int rtk_simd_supported(rtk_simd_path path);
/* The path RTK_SIMD asks for (clamped to what the CPU runs), else the
 * best; unknown values are reported once. */
rtk_simd_path rtk_simd_from_env(void);
/* "binary", "scalar", "sse", "avx2", "avx512". */
RTK_KERNEL_API const char *rtk_simd_name(rtk_simd_path path);

/* Closest hit / any hit on s->wide with a given path (a supported wide
 * path); ray must be valid. work, if not NULL, receives the counts. The
 * hit is filled as rtk_bvh_closest fills it. [any thread] */
int rtk_wide_closest(const rtk_scene *s, rtk_simd_path path, const rtk_ray *ray, rtk_hit *hit,
                     rtk_trace_work *work);
int rtk_wide_any(const rtk_scene *s, rtk_simd_path path, const rtk_ray *ray, rtk_trace_work *work);

/* Closest hit / any hit of count valid rays on s->wide with a supported
 * wide path, as rtk_wide_closest / rtk_wide_any give them one by one
 * (hits[i].prim RTK_INVALID_ID on a miss, occluded[i] 0 or 1): rays
 * whose directions and origins agree are traced as packets sharing each
 * node's visit, occlusion rays eight at a time from one origin as origin
 * groups, the others as streams (each node visited once for all the rays
 * that reach it). [any thread] */
void rtk_wide_closest_batch(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count,
                            rtk_hit *hits);
void rtk_wide_any_batch(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count,
                        uint8_t *occluded);
/* Rays this thread has traced in packets or streams so far (the batch
 * functions add to it): how much of a batch went other than one ray at a
 * time, for tests and the bench. */
RTK_KERNEL_API uint64_t rtk_wide_packet_rays(void);

/* The same without counts, by path (NULL for RTK_SIMD_BINARY, and for SSE
 * and the AVX paths off x86): rtk_bvh_closest / rtk_bvh_any reach a ray's traversal
 * through one indirect call instead of three calls. */
typedef int (*rtk_wide_closest_fn)(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit);
typedef int (*rtk_wide_any_fn)(const rtk_scene *s, const rtk_ray *ray);
extern rtk_wide_closest_fn const rtk_wide_closest_path[RTK_SIMD_PATHS];
extern rtk_wide_any_fn const rtk_wide_any_path[RTK_SIMD_PATHS];

/* rtk_bvh_closest / rtk_bvh_any (bvh.c) that also count the work done on
 * the path the scene uses (zero counts for a plugin's own traversal). */
RTK_KERNEL_API int rtk_bvh_closest_measure(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work);
RTK_KERNEL_API int rtk_bvh_any_measure(const rtk_scene *s, const rtk_ray *ray, rtk_trace_work *work);

RTK_EXTERN_C_END

#endif
