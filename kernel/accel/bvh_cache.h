/* The on-disk BVH cache: a built tree saved next to hashes of what it was
 * built from, and loaded only after everything in the file has been
 * checked. Caching is an optimisation: nothing here ever fails a render.
 * Every problem with a cache file (stale, truncated, corrupt, unwritable)
 * is one warning that names the file and the reason, and the tree is
 * built by the plugin instead. Main thread only.
 *
 * File format 1 (all integers in the writer's byte order, which the
 * endianness marker records; a reader of the other order refuses it):
 *
 *   offset size
 *        0    8  magic "RTKBVH\0\0"
 *        8    4  format version (1)
 *       12    4  endianness marker 0x01020304
 *       16    4  header size (104)
 *       20    4  node size (32, sizeof(rtk_bvh_node))
 *       24    8  geometry hash (rtk_bvh_cache_geometry_hash)
 *       32    8  builder hash (rtk_bvh_cache_builder_hash)
 *       40    8  plugin file stamp (rtk_bvh_cache_plugin_stamp)
 *       48    4  node count, 1 .. 2 * prim count - 1
 *       52    4  tree depth
 *       56    4  prim count (the scene's triangles)
 *       60    4  zero
 *       64   40  "name version" of the builder, NUL-padded (for messages)
 *      104       node count rtk_bvh_node
 *                prim count uint32_t: leaf slot -> triangle id
 *                8  checksum: h = hash(header, RTK_BVH_CACHE_SEED),
 *                   h = hash(nodes, h), h = hash(prim ids, h)
 *
 * A file's size is exactly 104 + 32 * nodes + 4 * prims + 8. The file name
 * carries the geometry and builder hashes and the plugin key (a hash of
 * the plugin file's path), so that builds of one plugin at different
 * paths (a build tree, an install) keep a tree each instead of evicting
 * each other's. The plugin file stamp is only in the header: a plugin
 * rebuilt at its path finds its old tree refused as stale and overwrites
 * it, instead of leaving it behind. */
#ifndef RTK_KERNEL_BVH_CACHE_H
#define RTK_KERNEL_BVH_CACHE_H

#include "../scene/scene.h"
#include <time.h>

#define RTK_BVH_CACHE_VERSION 1u
#define RTK_BVH_CACHE_HEADER_SIZE 104u
#define RTK_BVH_CACHE_ENDIAN 0x01020304u
#define RTK_BVH_CACHE_SEED 0x5254cb42u

/* Byte offsets of the header fields. */
enum {
    RTK_BVH_CACHE_AT_VERSION = 8,
    RTK_BVH_CACHE_AT_ENDIAN = 12,
    RTK_BVH_CACHE_AT_HEADER_SIZE = 16,
    RTK_BVH_CACHE_AT_NODE_SIZE = 20,
    RTK_BVH_CACHE_AT_GEOMETRY = 24,
    RTK_BVH_CACHE_AT_BUILDER = 32,
    RTK_BVH_CACHE_AT_PLUGIN_FILE = 40,
    RTK_BVH_CACHE_AT_NODE_COUNT = 48,
    RTK_BVH_CACHE_AT_DEPTH = 52,
    RTK_BVH_CACHE_AT_PRIM_COUNT = 56,
    RTK_BVH_CACHE_AT_ZERO = 60,
    RTK_BVH_CACHE_AT_BUILDER_TEXT = 64
};

/* Where a render's BVH came from. */
typedef struct rtk_bvh_cache_use {
    int from_cache;  /* 1: loaded from file; 0: built by the plugin */
    char file[1024]; /* the cache file loaded or written, "" when none */
} rtk_bvh_cache_use;

/* 64-bit hash of size bytes (the XXH64 algorithm), chained through seed. */
RTK_KERNEL_API uint64_t rtk_hash64(const void *data, size_t size, uint64_t seed);

/* Hash of the scene's geometry: counts, positions and indices. */
uint64_t rtk_bvh_cache_geometry_hash(const rtk_scene *scene);

/* Hash of the builder: plugin name and version, every parameter's name,
 * type and value. */
uint64_t rtk_bvh_cache_builder_hash(const rtk_plugin *plugin, const rtk_params *params);

/* Hash of the size, modification time and inode of the file the plugin's
 * code was loaded from, so that a rebuilt or reinstalled plugin whose
 * version string did not change does not get its old trees; 0 when the
 * file is unknown. */
uint64_t rtk_bvh_cache_plugin_stamp(const rtk_plugin *plugin);

/* Hash of the real path of the file the plugin's code was loaded from:
 * which build of the plugin this is, so that two builds' trees coexist
 * in one cache; 0 when the file is unknown. */
uint64_t rtk_bvh_cache_plugin_key(const rtk_plugin *plugin);

/* $XDG_CACHE_HOME/rtk, else $HOME/.cache/rtk, else NULL. [caller frees] */
char *rtk_bvh_cache_default_dir(void);

/* "<dir>/<geometry hash>-<builder hash>-<plugin key>.bvh". [caller frees] */
char *rtk_bvh_cache_path(const char *dir, uint64_t geometry, uint64_t builder, uint64_t plugin_key);

/* Replaces scene's BVH with the one in path when every check passes
 * (size, magic, byte order, version, hashes, checksum, then the kernel's
 * structural validation against freshly computed primitive bounds) and
 * returns 1. Otherwise returns 0 with the scene's BVH cleared and, unless
 * the file does not exist, exactly one warning naming path and the reason.
 * plugin names the expected builder in messages; the wide tree is
 * collapsed on up to threads threads (0 = 1). */
int rtk_bvh_cache_load(rtk_scene *scene, const char *path, uint64_t geometry, uint64_t builder,
                       const rtk_plugin *plugin, uint32_t threads);

/* Writes scene's BVH to path through a temporary sibling and a rename, so
 * readers never see a partial file. On failure warns once and returns
 * the error; the scene is untouched either way. */
rtk_status rtk_bvh_cache_save(const rtk_scene *scene, const char *path, uint64_t geometry, uint64_t builder,
                              const rtk_plugin *plugin);

/* Keeps the cache in dir within limit bytes (0: no limit): removes its
 * tree files (<16 hex digits>-<16 hex digits>-<16 hex digits>.bvh, and
 * <16 hex>-<16 hex>.bvh without a plugin key), least recently used
 * first (a load or a save marks a file used: its modification time), until
 * the ones left take at most limit bytes. Files used at or after since
 * (the render's own) are never removed. Temporary files of saves
 * (<tree file>.tmp*) an hour old or more are removed too, whatever the
 * limit: a process that died while saving left them. Nothing else in dir
 * is touched. Returns the number of files removed and adds their bytes to
 * *freed (may be NULL). A directory that cannot be read, or a file that
 * will not go, is skipped: pruning never fails a render. */
uint32_t rtk_bvh_cache_prune(const char *dir, uint64_t limit, struct timespec since, uint64_t *freed);

/* rtk_bvh_build behind the cache in dir (NULL = caching off): loads a
 * valid cache file, else builds and saves. Accelerators with their own
 * traversal are never cached. Fails only when the build itself fails. A
 * scene with instances gets every level built (rtk_instances_build), each
 * mesh through the cache. */
RTK_KERNEL_API rtk_status rtk_bvh_build_cached(rtk_scene *scene, const rtk_plugin *accelerator, const rtk_params *params,
                                               uint32_t threads, const char *dir, rtk_bvh_cache_use *use);
/* The same for the scene's own triangles only. */
rtk_status rtk_bvh_build_cached_own(rtk_scene *scene, const rtk_plugin *accelerator, const rtk_params *params,
                                    uint32_t threads, const char *dir, rtk_bvh_cache_use *use);

#endif
