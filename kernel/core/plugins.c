/* Plugin loading: dlopen, descriptor checks, and the registry of plugin
 * directories. A plugin library, once opened, stays loaded for the life of
 * the process (descriptors point into it). */
#include "core.h"

#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

RTK_API const char *rtk_kind_name(rtk_plugin_kind kind)
{
    switch (kind) {
    case RTK_KIND_INTEGRATOR:
        return "integrator";
    case RTK_KIND_ACCELERATOR:
        return "accelerator";
    case RTK_KIND_FILTER:
        return "filter";
    }
    return "unknown kind";
}

/* The article of rtk_kind_name(kind) in messages: "a filter", "an integrator". */
static const char *kind_article(rtk_plugin_kind kind)
{
    return kind == RTK_KIND_FILTER ? "a" : "an";
}

/* Smallest function table each kind must provide: its required fields;
 * later fields are read only when the table's size covers them. */
static size_t min_table_size(rtk_plugin_kind kind)
{
    switch (kind) {
    case RTK_KIND_INTEGRATOR:
        return offsetof(rtk_integrator_fns, li_batch);
    case RTK_KIND_ACCELERATOR:
        return offsetof(rtk_accelerator_fns, closest);
    case RTK_KIND_FILTER:
        return sizeof(rtk_filter_fns);
    }
    return 0;
}

/* A device accelerator's table (ABI 3.5): attach, report, both batch
 * functions and no build or traversal of its own; a string parameter
 * "builder" names the accelerator that builds its trees. */
static rtk_status check_device(const rtk_plugin *p, const char *path)
{
    const rtk_accelerator_fns *f = p->functions;
    const char *missing = !f->create          ? "create"
                          : !f->destroy       ? "destroy"
                          : !f->attach        ? "attach"
                          : !f->report        ? "report"
                          : !f->closest_batch ? "closest_batch"
                          : !f->any_batch     ? "any_batch"
                                              : NULL;
    if (missing)
        return rtk_error(RTK_ERR_PLUGIN, "%s: device accelerator '%s' lacks the required function '%s'", path,
                         p->name, missing);
    if (f->build || f->closest || f->any)
        return rtk_error(RTK_ERR_PLUGIN, "%s: device accelerator '%s' sets '%s': a device accelerator traces the "
                         "tree another accelerator builds, and the kernel traces its single rays; leave build, "
                         "closest and any NULL", path, p->name, f->build ? "build" : f->closest ? "closest" : "any");
    for (uint32_t i = 0; i < p->param_count; i++)
        if (p->params && p->params[i].name && strcmp(p->params[i].name, "builder") == 0 &&
            p->params[i].type == RTK_PARAM_STRING)
            return RTK_OK;
    return rtk_error(RTK_ERR_PLUGIN, "%s: device accelerator '%s' declares no string parameter 'builder' (the "
                     "accelerator that builds the trees it traces)", path, p->name);
}

static rtk_status check_functions(const rtk_plugin *p, const char *path)
{
    const char *missing = NULL;
    uint32_t size = *(const uint32_t *)p->functions;
    if (size < min_table_size(p->kind))
        return rtk_error(RTK_ERR_PLUGIN,
                         "%s: %s function table is %u bytes, expected at least %zu: rebuild the "
                         "plugin against this SDK",
                         path, rtk_kind_name(p->kind), size, min_table_size(p->kind));
    if (p->kind == RTK_KIND_INTEGRATOR) {
        const rtk_integrator_fns *f = p->functions;
        missing = !f->create ? "create" : !f->needs ? "needs" : !f->li ? "li" : !f->destroy ? "destroy" : NULL;
    } else if (p->kind == RTK_KIND_ACCELERATOR) {
        const rtk_accelerator_fns *f = p->functions;
        if (size >= offsetof(rtk_accelerator_fns, report) + sizeof f->report && (f->attach || f->report))
            return check_device(p, path);
        missing = !f->create ? "create" : !f->build ? "build" : !f->destroy ? "destroy" : NULL;
        if (!missing && size >= offsetof(rtk_accelerator_fns, any) + sizeof f->any && !f->closest != !f->any)
            return rtk_error(RTK_ERR_PLUGIN, "%s: accelerator '%s' sets only one of 'closest' and 'any'; "
                             "its own traversal needs both", path, p->name);
        if (!missing && size >= offsetof(rtk_accelerator_fns, any_batch) + sizeof f->any_batch) {
            if (!f->closest_batch != !f->any_batch)
                return rtk_error(RTK_ERR_PLUGIN, "%s: accelerator '%s' sets only one of 'closest_batch' and "
                                 "'any_batch'; its batch traversal needs both", path, p->name);
            if (f->closest_batch && !f->closest)
                return rtk_error(RTK_ERR_PLUGIN, "%s: accelerator '%s' sets 'closest_batch' and 'any_batch' "
                                 "without 'closest' and 'any': batches need the plugin's own traversal",
                                 path, p->name);
        }
    } else {
        const rtk_filter_fns *f = p->functions;
        missing = !f->create      ? "create"
                  : !f->radius    ? "radius"
                  : !f->eval      ? "eval"
                  : !f->integral  ? "integral"
                  : !f->destroy   ? "destroy"
                                  : NULL;
    }
    if (missing)
        return rtk_error(RTK_ERR_PLUGIN, "%s: %s '%s' lacks the required function '%s'", path,
                         rtk_kind_name(p->kind), p->name, missing);
    return RTK_OK;
}

static int valid_name(const char *name)
{
    if (!name || !name[0] || strlen(name) > 64)
        return 0;
    for (const char *c = name; *c; c++)
        if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
              *c == '_' || *c == '-'))
            return 0;
    return 1;
}

rtk_status rtk_plugin_check(const rtk_plugin *p, const char *path, rtk_plugin_kind expected)
{
    if (!p)
        return rtk_error(RTK_ERR_PLUGIN, "%s: rtk_plugin_entry() returned NULL", path);
    /* The 3.0 descriptor ends at functions; later fields (conform) are
     * read only where size covers them. */
    if (p->size < offsetof(rtk_plugin, conform))
        return rtk_error(RTK_ERR_PLUGIN, "%s: descriptor is %u bytes, too small to be an rtk plugin",
                         path, p->size);
    if (p->abi_major != RTK_ABI_MAJOR)
        return rtk_error(RTK_ERR_PLUGIN,
                         "%s: built for rtk plugin ABI %u.%u, this rtk has ABI %d.%d: rebuild the "
                         "plugin against this SDK",
                         path, p->abi_major, p->abi_minor, RTK_ABI_MAJOR, RTK_ABI_MINOR);
    if (p->abi_minor > RTK_ABI_MINOR)
        return rtk_error(RTK_ERR_PLUGIN,
                         "%s: built for rtk plugin ABI %u.%u, newer than this rtk's %d.%d: update "
                         "rtk or rebuild the plugin",
                         path, p->abi_major, p->abi_minor, RTK_ABI_MAJOR, RTK_ABI_MINOR);
    if (p->kind != RTK_KIND_INTEGRATOR && p->kind != RTK_KIND_ACCELERATOR && p->kind != RTK_KIND_FILTER)
        return rtk_error(RTK_ERR_PLUGIN, "%s: unknown plugin kind %d (expected integrator, accelerator or filter)",
                         path, (int)p->kind);
    if (!valid_name(p->name))
        return rtk_error(RTK_ERR_PLUGIN, "%s: plugin name is missing or not [A-Za-z0-9_-]{1,64}", path);
    if (!p->version || !p->summary)
        return rtk_error(RTK_ERR_PLUGIN, "%s: plugin '%s' has no version or summary", path, p->name);
    if (expected && p->kind != expected)
        return rtk_error(RTK_ERR_PLUGIN, "%s: plugin '%s' is %s %s, expected %s %s", path, p->name,
                         kind_article(p->kind), rtk_kind_name(p->kind), kind_article(expected),
                         rtk_kind_name(expected));
    if (p->param_count && !p->params)
        return rtk_error(RTK_ERR_PLUGIN, "%s: plugin '%s' declares %u parameters but no table", path,
                         p->name, p->param_count);
    if (!p->functions)
        return rtk_error(RTK_ERR_PLUGIN, "%s: plugin '%s' has no function table", path, p->name);
    rtk_status st = check_functions(p, path);
    if (st != RTK_OK)
        return st;
    st = rtk_params_check_schema(p);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        return rtk_error(st, "%s: %s", path, msg);
    }
    return RTK_OK;
}

/* Opened libraries by path, so a file is opened and checked once. */
typedef struct opened_lib {
    char *path;
    const rtk_plugin *plugin;
} opened_lib;

static opened_lib *opened;
static size_t opened_count;

RTK_API rtk_status rtk_plugin_open(const char *path, rtk_plugin_kind expected, const rtk_plugin **out)
{
    *out = NULL;
    char real[PATH_MAX];
    if (!realpath(path, real))
        return rtk_error(RTK_ERR_IO, "%s: cannot open plugin: %s", path, strerror(errno));
    for (size_t i = 0; i < opened_count; i++) {
        if (strcmp(opened[i].path, real) == 0) {
            rtk_status st = rtk_plugin_check(opened[i].plugin, real, expected);
            if (st == RTK_OK)
                *out = opened[i].plugin;
            return st;
        }
    }
    struct stat sb;
    if (stat(real, &sb) != 0 || !S_ISREG(sb.st_mode))
        return rtk_error(RTK_ERR_IO, "%s: not a regular file", real);
    void *lib = dlopen(real, RTLD_NOW | RTLD_LOCAL);
    if (!lib)
        return rtk_error(RTK_ERR_PLUGIN, "%s: not a loadable shared object: %s", real, dlerror());
    void *sym = dlsym(lib, RTK_PLUGIN_ENTRY_NAME);
    if (!sym) {
        dlclose(lib);
        return rtk_error(RTK_ERR_PLUGIN, "%s: not an rtk plugin (no '%s' symbol exported)", real,
                         RTK_PLUGIN_ENTRY_NAME);
    }
    rtk_plugin_entry_fn entry;
    memcpy(&entry, &sym, sizeof entry);
    const rtk_plugin *p = entry();
    rtk_status st = rtk_plugin_check(p, real, 0);
    if (st != RTK_OK) {
        dlclose(lib);
        return st;
    }
    opened_lib *grown = rtk_realloc_array(opened, opened_count + 1, sizeof *opened);
    char *copy = rtk_strdup(real);
    if (!grown || !copy) {
        free(copy);
        if (grown)
            opened = grown;
        return RTK_ERR_NOMEM;
    }
    opened = grown;
    opened[opened_count].path = copy;
    opened[opened_count].plugin = p;
    opened_count++;
    st = rtk_plugin_check(p, real, expected);
    if (st == RTK_OK)
        *out = p;
    return st;
}

typedef struct search_dir {
    char *path;
    char *origin;
} search_dir;

typedef struct found_plugin {
    rtk_plugin_info info;
    char *path;
    char *problem;
} found_plugin;

struct rtk_registry {
    search_dir *dirs;
    size_t dir_count;
    int scanned;
    found_plugin *found;
    size_t found_count;
};

static void add_dir(rtk_registry *r, const char *dir, const char *origin)
{
    for (size_t i = 0; i < r->dir_count; i++)
        if (strcmp(r->dirs[i].path, dir) == 0)
            return;
    search_dir *grown = rtk_realloc_array(r->dirs, r->dir_count + 1, sizeof *grown);
    if (!grown)
        return;
    r->dirs = grown;
    r->dirs[r->dir_count].path = rtk_strdup(dir);
    r->dirs[r->dir_count].origin = rtk_strdup(origin);
    r->dir_count++;
    r->scanned = 0;
}

/* Adds each entry of a ':'-separated list. */
static void add_dir_list(rtk_registry *r, const char *list, const char *origin)
{
    char *copy = rtk_strdup(list);
    if (!copy)
        return;
    char *save = NULL;
    for (char *d = strtok_r(copy, ":", &save); d; d = strtok_r(NULL, ":", &save))
        if (d[0])
            add_dir(r, d, origin);
    free(copy);
}

/* The real path of the file this code was loaded from (librtk.so, or a
 * test that links the kernel statically) into real; 0 when unknown. */
static int kernel_file(char real[PATH_MAX])
{
    Dl_info info;
    return dladdr((void *)&rtk_registry_create, &info) && info.dli_fname && realpath(info.dli_fname, real);
}

/* True when this code runs from the build tree rather than an install. */
int rtk_running_from_build_tree(void)
{
    char real[PATH_MAX];
    if (!kernel_file(real))
        return 0;
    size_t n = strlen(RTK_BUILD_ROOT);
    return strncmp(real, RTK_BUILD_ROOT, n) == 0 && real[n] == '/';
}

char *rtk_installed_path(const char *subpath)
{
    char real[PATH_MAX];
    if (!kernel_file(real))
        return NULL;
    char *slash = strrchr(real, '/');
    if (!slash)
        return NULL;
    slash[slash == real ? 1 : 0] = '\0'; /* "/librtk.so" lies in "/" */
    return rtk_path_join(real, subpath);
}

RTK_API rtk_status rtk_registry_create(rtk_registry **out)
{
    rtk_registry *r = rtk_calloc(1, sizeof *r);
    if (!r)
        return RTK_ERR_NOMEM;
    if (rtk_running_from_build_tree()) {
        add_dir_list(r, RTK_BUILD_PLUGIN_DIRS, "build tree");
    } else {
        char *installed = rtk_installed_path(RTK_INSTALL_PLUGIN_SUBDIR);
        if (installed)
            add_dir(r, installed, "installed plugins");
        free(installed);
    }
    const char *env = getenv("RTK_PLUGIN_PATH");
    if (env)
        add_dir_list(r, env, "RTK_PLUGIN_PATH");
    *out = r;
    return RTK_OK;
}

static void clear_found(rtk_registry *r)
{
    for (size_t i = 0; i < r->found_count; i++) {
        free(r->found[i].path);
        free(r->found[i].problem);
    }
    free(r->found);
    r->found = NULL;
    r->found_count = 0;
}

RTK_API void rtk_registry_destroy(rtk_registry *r)
{
    if (!r)
        return;
    clear_found(r);
    for (size_t i = 0; i < r->dir_count; i++) {
        free(r->dirs[i].path);
        free(r->dirs[i].origin);
    }
    free(r->dirs);
    free(r);
}

RTK_API void rtk_registry_add_dir(rtk_registry *r, const char *dir, const char *origin)
{
    add_dir(r, dir, origin ? origin : "added");
}

static int has_suffix(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a > b && strcmp(s + a - b, suffix) == 0;
}

static int compare_found(const void *a, const void *b)
{
    const found_plugin *x = a, *y = b;
    int kx = x->info.plugin ? (int)x->info.plugin->kind : 99;
    int ky = y->info.plugin ? (int)y->info.plugin->kind : 99;
    if (kx != ky)
        return kx - ky;
    const char *nx = x->info.plugin ? x->info.plugin->name : x->path;
    const char *ny = y->info.plugin ? y->info.plugin->name : y->path;
    int c = strcmp(nx, ny);
    return c ? c : strcmp(x->path, y->path);
}

static void record(rtk_registry *r, const char *path, const rtk_plugin *p, const char *problem)
{
    found_plugin *grown = rtk_realloc_array(r->found, r->found_count + 1, sizeof *grown);
    if (!grown)
        return;
    r->found = grown;
    found_plugin *f = &r->found[r->found_count++];
    memset(f, 0, sizeof *f);
    f->path = rtk_strdup(path);
    f->problem = rtk_strdup(problem);
    f->info.path = f->path;
    f->info.plugin = p;
    f->info.problem = f->problem;
}

static void scan(rtk_registry *r)
{
    if (r->scanned)
        return;
    clear_found(r);
    for (size_t d = 0; d < r->dir_count; d++) {
        DIR *dir = opendir(r->dirs[d].path);
        if (!dir)
            continue;
        struct dirent *e;
        while ((e = readdir(dir)) != NULL) {
            if (!has_suffix(e->d_name, ".so"))
                continue;
            char *full = rtk_path_join(r->dirs[d].path, e->d_name);
            if (!full)
                continue;
            const rtk_plugin *p = NULL;
            rtk_status st = rtk_plugin_open(full, 0, &p);
            if (st != RTK_OK) {
                record(r, full, NULL, rtk_error_message());
            } else {
                char stem[256];
                snprintf(stem, sizeof stem, "%.*s", (int)(strlen(e->d_name) - 3), e->d_name);
                if (strcmp(stem, p->name) != 0) {
                    char msg[1024];
                    snprintf(msg, sizeof msg, "%s: file name '%s' differs from the plugin name '%s'; rename it to %s.so",
                             full, e->d_name, p->name, p->name);
                    record(r, full, p, msg);
                } else {
                    record(r, full, p, NULL);
                }
            }
            free(full);
        }
        closedir(dir);
    }
    /* The same name twice (same kind) makes both ambiguous. */
    for (size_t i = 0; i < r->found_count; i++) {
        for (size_t j = i + 1; j < r->found_count; j++) {
            const rtk_plugin *a = r->found[i].info.plugin, *b = r->found[j].info.plugin;
            if (!a || !b || a->kind != b->kind || strcmp(a->name, b->name) != 0)
                continue;
            char msg[2048];
            snprintf(msg, sizeof msg, "duplicate %s name '%s': %s and %s; remove one or take it off the plugin path",
                     rtk_kind_name(a->kind), a->name, r->found[i].path, r->found[j].path);
            free(r->found[i].problem);
            free(r->found[j].problem);
            r->found[i].problem = rtk_strdup(msg);
            r->found[j].problem = rtk_strdup(msg);
            r->found[i].info.problem = r->found[i].problem;
            r->found[j].info.problem = r->found[j].problem;
        }
    }
    if (r->found_count > 1) /* found is NULL when the search found nothing: qsort's pointer must not be */
        qsort(r->found, r->found_count, sizeof *r->found, compare_found);
    for (size_t i = 0; i < r->found_count; i++) {
        r->found[i].info.path = r->found[i].path;
        r->found[i].info.problem = r->found[i].problem;
    }
    r->scanned = 1;
}

RTK_API size_t rtk_registry_count(rtk_registry *r)
{
    scan(r);
    return r->found_count;
}

RTK_API const rtk_plugin_info *rtk_registry_at(rtk_registry *r, size_t i)
{
    scan(r);
    return i < r->found_count ? &r->found[i].info : NULL;
}

/* Appends text to buf (bounded). */
static void append(char *buf, size_t cap, const char *text)
{
    size_t n = strlen(buf);
    if (n + 1 < cap)
        snprintf(buf + n, cap - n, "%s", text);
}

RTK_API rtk_status rtk_registry_find(rtk_registry *r, rtk_plugin_kind kind, const char *name,
                                     const rtk_plugin **out)
{
    *out = NULL;
    scan(r);
    const rtk_plugin *other_kind = NULL;
    for (size_t i = 0; i < r->found_count; i++) {
        const found_plugin *f = &r->found[i];
        if (!f->info.plugin || strcmp(f->info.plugin->name, name) != 0)
            continue;
        if (f->info.plugin->kind != kind) {
            other_kind = f->info.plugin;
            continue;
        }
        if (f->problem)
            return rtk_error(RTK_ERR_PLUGIN, "%s", f->problem);
        *out = f->info.plugin;
        return RTK_OK;
    }
    char avail[1024] = "";
    for (size_t i = 0; i < r->found_count; i++) {
        const rtk_plugin *p = r->found[i].info.plugin;
        if (p && p->kind == kind) {
            append(avail, sizeof avail, avail[0] ? ", " : "");
            append(avail, sizeof avail, p->name);
        }
    }
    if (other_kind)
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s' is %s %s, not %s %s; %ss available: %s", name,
                         kind_article(other_kind->kind), rtk_kind_name(other_kind->kind), kind_article(kind),
                         rtk_kind_name(kind), rtk_kind_name(kind),
                         avail[0] ? avail : "none");
    char dirs[2048] = "";
    for (size_t i = 0; i < r->dir_count; i++) {
        append(dirs, sizeof dirs, i ? ", " : "");
        append(dirs, sizeof dirs, r->dirs[i].path);
        append(dirs, sizeof dirs, " (");
        append(dirs, sizeof dirs, r->dirs[i].origin);
        append(dirs, sizeof dirs, ")");
    }
    char broken[1024] = "";
    for (size_t i = 0; i < r->found_count; i++) {
        if (!r->found[i].info.plugin && strstr(r->found[i].path, name)) {
            append(broken, sizeof broken, "; a file that looks like it was refused: ");
            append(broken, sizeof broken, r->found[i].problem);
        }
    }
    return rtk_error(RTK_ERR_PLUGIN, "no %s plugin named '%s' (searched %s); %ss available: %s%s",
                     rtk_kind_name(kind), name, dirs[0] ? dirs : "no directories",
                     rtk_kind_name(kind), avail[0] ? avail : "none", broken);
}
