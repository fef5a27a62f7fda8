/* How many cores this process may use: the online cores, within its CPU
 * affinity (taskset, cpuset) and its cgroup's CPU quota (a container's
 * --cpus), so that "one thread per core" does not start threads that
 * would only take turns. */
#include "core.h"

#include <ctype.h>
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Where one cgroup hierarchy is mounted (mount) and which of its
 * folders that mount shows as its top (root), from mountinfo. */
typedef struct cgroup_mount {
    char root[1024], mount[1024];
    int found;
} cgroup_mount;

/* Copies mountinfo's field src (spaces and the like written as \ooo) to
 * dst, undoing the escapes; 0 if it does not fit. */
static int unescape(char *dst, size_t cap, const char *src)
{
    size_t n = 0;
    for (const char *s = src; *s; s++) {
        char c = *s;
        if (c == '\\' && s[1] >= '0' && s[1] <= '3' && s[2] >= '0' && s[2] <= '7' && s[3] >= '0' && s[3] <= '7') {
            c = (char)((s[1] - '0') << 6 | (s[2] - '0') << 3 | (s[3] - '0'));
            s += 3;
        }
        if (n + 1 >= cap)
            return 0;
        dst[n++] = c;
    }
    dst[n] = '\0';
    return 1;
}

/* Whether the comma-separated list has the item word. */
static int has_item(const char *list, const char *word)
{
    const size_t len = strlen(word);
    for (const char *p = list; *p;) {
        const char *end = strchr(p, ',');
        const size_t n = end ? (size_t)(end - p) : strlen(p);
        if (n == len && strncmp(p, word, len) == 0)
            return 1;
        if (!end)
            break;
        p = end + 1;
    }
    return 0;
}

/* Finds the cgroup2 mount (v2) and the v1 hierarchy with the cpu
 * controller (v1) in root's /proc/self/mountinfo. */
static void find_mounts(const char *root, cgroup_mount *v2, cgroup_mount *v1)
{
    char path[1200], line[4096];
    snprintf(path, sizeof path, "%s/proc/self/mountinfo", root);
    FILE *f = fopen(path, "r");
    if (!f)
        return;
    while (fgets(line, sizeof line, f)) {
        /* id parent dev root mount options [optional...] - type source super */
        char *field[6] = {0}, *save = NULL, *tok = strtok_r(line, " \n", &save);
        int k = 0;
        for (; tok && k < 5; tok = strtok_r(NULL, " \n", &save))
            field[k++] = tok;
        while (tok && strcmp(tok, "-") != 0)
            tok = strtok_r(NULL, " \n", &save);
        const char *type = tok ? strtok_r(NULL, " \n", &save) : NULL;
        const char *source = type ? strtok_r(NULL, " \n", &save) : NULL;
        const char *super = source ? strtok_r(NULL, " \n", &save) : NULL;
        if (k < 5 || !super)
            continue;
        cgroup_mount *m = NULL;
        if (strcmp(type, "cgroup2") == 0)
            m = v2;
        else if (strcmp(type, "cgroup") == 0 && has_item(super, "cpu"))
            m = v1;
        if (m && !m->found && unescape(m->root, sizeof m->root, field[3]) &&
            unescape(m->mount, sizeof m->mount, field[4]))
            m->found = 1;
    }
    fclose(f);
}

/* The folder of this process's cgroup under mount m: its path from
 * /proc/self/cgroup ("0::/a/b" for v2, "4:cpu,cpuacct:/a/b" for v1)
 * less the part the mount does not show. 0 if not found. */
static int cgroup_folder(const char *root, const cgroup_mount *m, int v2, char *dir, size_t cap)
{
    char path[1200], line[4096];
    snprintf(path, sizeof path, "%s/proc/self/cgroup", root);
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    int found = 0;
    while (!found && fgets(line, sizeof line, f)) {
        line[strcspn(line, "\n")] = '\0';
        char *c1 = strchr(line, ':'), *c2 = c1 ? strchr(c1 + 1, ':') : NULL;
        if (!c2)
            continue;
        *c1 = *c2 = '\0';
        const char *controllers = c1 + 1, *cg = c2 + 1;
        if (v2 ? strcmp(line, "0") != 0 || controllers[0] != '\0' : !has_item(controllers, "cpu"))
            continue;
        /* A mount of a cgroup's subtree shows paths below its root. */
        const size_t rl = strlen(m->root);
        if (strcmp(m->root, "/") != 0) {
            if (strncmp(cg, m->root, rl) == 0 && (cg[rl] == '/' || cg[rl] == '\0'))
                cg += rl;
            else
                cg = ""; /* outside the mount's view: a namespace shows its own cgroup as the top */
        }
        found = snprintf(dir, cap, "%s%s%s", root, m->mount, strcmp(cg, "/") == 0 ? "" : cg) < (int)cap;
    }
    fclose(f);
    return found;
}

/* Reads up to two numbers (or "max", as -1) from dir/name; returns how many. */
static int read_numbers(const char *dir, const char *name, double *a, double *b)
{
    char path[2200], text[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    const size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    double v[2];
    int got = 0;
    for (char *p = text, *end; got < 2; p = end) {
        while (isspace((unsigned char)*p))
            p++;
        if (strncmp(p, "max", 3) == 0) {
            v[got++] = -1.0;
            end = p + 3;
            continue;
        }
        v[got] = strtod(p, &end);
        if (end == p)
            break;
        got++;
    }
    if (got > 0)
        *a = v[0];
    if (got > 1)
        *b = v[1];
    return got;
}

/* The quota of dir's cgroup in CPUs, 0 when it has none. */
static double folder_quota(const char *dir, int v2)
{
    double quota = -1.0, period = 0.0;
    if (v2) {
        if (read_numbers(dir, "cpu.max", &quota, &period) != 2)
            return 0.0;
    } else {
        double unused;
        if (read_numbers(dir, "cpu.cfs_quota_us", &quota, &unused) < 1 ||
            read_numbers(dir, "cpu.cfs_period_us", &period, &unused) < 1)
            return 0.0;
    }
    return quota > 0.0 && period > 0.0 ? quota / period : 0.0;
}

/* The smallest quota of dir and the cgroups above it up to top. */
static double hierarchy_quota(char *dir, size_t top, int v2)
{
    double least = 0.0;
    for (;;) {
        const double q = folder_quota(dir, v2);
        if (q > 0.0 && (least == 0.0 || q < least))
            least = q;
        char *slash = strrchr(dir, '/');
        if (!slash || (size_t)(slash - dir) < top)
            break;
        *slash = '\0';
    }
    return least;
}

uint32_t rtk_cgroup_cpu_limit(const char *root)
{
    cgroup_mount v2 = {0}, v1 = {0};
    find_mounts(root, &v2, &v1);
    double least = 0.0;
    char dir[2200];
    for (int version = 2; version >= 1; version--) {
        const cgroup_mount *m = version == 2 ? &v2 : &v1;
        if (!m->found || !cgroup_folder(root, m, version == 2, dir, sizeof dir))
            continue;
        const double q = hierarchy_quota(dir, strlen(root) + strlen(m->mount), version == 2);
        if (q > 0.0 && (least == 0.0 || q < least))
            least = q;
    }
    if (least <= 0.0)
        return 0;
    /* 1.5 CPUs' worth keeps two threads busy half the time each: round up. */
    const double cpus = ceil(least - 1e-9);
    return cpus >= 4096.0 ? 4096u : (uint32_t)cpus;
}

uint32_t rtk_core_count(void)
{
    long online = sysconf(_SC_NPROCESSORS_ONLN);
    uint32_t n = online > 0 ? (uint32_t)online : 1u;
    /* The affinity mask, large enough for any machine sysconf reports. */
    const int bits = online > 1024 ? (int)online : 1024;
    cpu_set_t *set = CPU_ALLOC(bits);
    if (set) {
        const size_t bytes = CPU_ALLOC_SIZE(bits);
        CPU_ZERO_S(bytes, set);
        if (sched_getaffinity(0, bytes, set) == 0) {
            const int allowed = CPU_COUNT_S(bytes, set);
            if (allowed > 0 && (uint32_t)allowed < n)
                n = (uint32_t)allowed;
        }
        CPU_FREE(set);
    }
    const uint32_t quota = rtk_cgroup_cpu_limit("");
    if (quota > 0 && quota < n)
        n = quota;
    return n;
}
