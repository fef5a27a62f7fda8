/* The cores this process may use (kernel/core/cpus.c): cgroup CPU quotas
 * read from made-up /proc and /sys trees (v2, v1, both, nested, a
 * namespace's view, escaped mount points, broken files), and the live
 * count against the online cores and a one-CPU affinity mask. */
#include "core/core.h"
#include "check.h"

#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char base[256];

/* Makes every folder of path. */
static void make_dirs(const char *path)
{
    char p[1024];
    snprintf(p, sizeof p, "%s", path);
    for (char *s = p + 1; *s; s++)
        if (*s == '/') {
            *s = '\0';
            mkdir(p, 0755);
            *s = '/';
        }
    mkdir(p, 0755);
}

/* Writes text to root/rel, making its folders. */
static void put(const char *root, const char *rel, const char *text)
{
    char path[1024];
    snprintf(path, sizeof path, "%s%s", root, rel);
    char *slash = strrchr(path, '/');
    *slash = '\0';
    make_dirs(path);
    *slash = '/';
    FILE *f = fopen(path, "w");
    if (!f) {
        check(0, "write %s: %s", path, strerror(errno));
        return;
    }
    fputs(text, f);
    fclose(f);
}

/* A fresh root for one case. */
static const char *root_for(const char *name)
{
    static char root[512];
    snprintf(root, sizeof root, "%s/%s", base, name);
    make_dirs(root);
    return root;
}

#define V2_MOUNT "30 23 0:26 / /sys/fs/cgroup rw,nosuid - cgroup2 cgroup2 rw,nsdelegate\n"
#define V1_MOUNT "32 31 0:29 / /sys/fs/cgroup/cpu,cpuacct rw - cgroup cgroup rw,cpu,cpuacct\n"

static void expect_limit(const char *root, uint32_t want, const char *what)
{
    const uint32_t got = rtk_cgroup_cpu_limit(root);
    check(got == want, "%s: %u (got %u)", what, want, got);
}

int main(void)
{
    snprintf(base, sizeof base, "/tmp/rtk-test-cpus-%ld", (long)getpid());
    make_dirs(base);
    const char *r;

    r = root_for("v2");
    put(r, "/proc/self/mountinfo", "22 1 8:1 / / rw - ext4 /dev/sda1 rw\n" V2_MOUNT);
    put(r, "/proc/self/cgroup", "0::/user.slice/job\n");
    put(r, "/sys/fs/cgroup/user.slice/job/cpu.max", "150000 100000\n");
    expect_limit(r, 2, "v2 cpu.max 150000 100000 is 1.5 CPUs, rounded up");
    put(r, "/sys/fs/cgroup/user.slice/job/cpu.max", "50000 100000\n");
    expect_limit(r, 1, "v2 half a CPU rounds up to one");
    put(r, "/sys/fs/cgroup/user.slice/job/cpu.max", "max 100000\n");
    expect_limit(r, 0, "v2 'max' is no quota");
    put(r, "/sys/fs/cgroup/user.slice/cpu.max", "300000 100000\n");
    expect_limit(r, 3, "v2 a parent's quota limits its children");
    put(r, "/sys/fs/cgroup/user.slice/job/cpu.max", "200000 100000\n");
    expect_limit(r, 2, "v2 the least quota along the ancestors");
    put(r, "/sys/fs/cgroup/user.slice/job/cpu.max", "1600000 100000\n");
    expect_limit(r, 3, "v2 a child's larger quota does not lift its parent's");

    r = root_for("namespace");
    put(r, "/proc/self/mountinfo", "30 23 0:26 /docker/abc /sys/fs/cgroup rw - cgroup2 cgroup2 rw\n");
    put(r, "/proc/self/cgroup", "0::/docker/abc/inner\n");
    put(r, "/sys/fs/cgroup/inner/cpu.max", "max 100000\n");
    put(r, "/sys/fs/cgroup/cpu.max", "400000 100000\n");
    expect_limit(r, 4, "v2 mounted from a subtree: paths below its root, its top's quota counts");
    put(r, "/proc/self/cgroup", "0::/\n");
    expect_limit(r, 4, "v2 a namespace's own cgroup shown as '/'");

    r = root_for("v1");
    put(r, "/proc/self/mountinfo",
        "31 23 0:28 / /sys/fs/cgroup ro - tmpfs tmpfs ro,mode=755\n" V1_MOUNT
        "33 31 0:30 / /sys/fs/cgroup/memory rw - cgroup cgroup rw,memory\n");
    put(r, "/proc/self/cgroup", "4:memory:/a\n3:cpu,cpuacct:/a\n0::/\n");
    put(r, "/sys/fs/cgroup/cpu,cpuacct/a/cpu.cfs_quota_us", "200000\n");
    put(r, "/sys/fs/cgroup/cpu,cpuacct/a/cpu.cfs_period_us", "100000\n");
    expect_limit(r, 2, "v1 cfs_quota_us 200000 over cfs_period_us 100000");
    put(r, "/sys/fs/cgroup/cpu,cpuacct/a/cpu.cfs_quota_us", "-1\n");
    expect_limit(r, 0, "v1 quota -1 is no quota");

    r = root_for("hybrid");
    put(r, "/proc/self/mountinfo",
        "32 31 0:29 / /sys/fs/cgroup/cpu rw - cgroup cgroup rw,cpu\n"
        "33 31 0:30 / /sys/fs/cgroup/cpuacct rw - cgroup cgroup rw,cpuacct\n"
        "41 31 0:38 / /sys/fs/cgroup/unified rw - cgroup2 cgroup2 rw\n");
    put(r, "/proc/self/cgroup", "2:cpuacct:/\n1:cpu:/\n0::/\n");
    put(r, "/sys/fs/cgroup/cpu/cpu.cfs_quota_us", "-1\n");
    put(r, "/sys/fs/cgroup/cpu/cpu.cfs_period_us", "100000\n");
    put(r, "/sys/fs/cgroup/unified/cgroup.controllers", "\n");
    expect_limit(r, 0, "hybrid: 'cpuacct' is not 'cpu', v2 has no cpu.max, v1 unlimited");
    put(r, "/sys/fs/cgroup/cpu/cpu.cfs_quota_us", "250000\n");
    expect_limit(r, 3, "hybrid: the v1 cpu hierarchy's quota");

    r = root_for("both");
    put(r, "/proc/self/mountinfo", V2_MOUNT V1_MOUNT);
    put(r, "/proc/self/cgroup", "3:cpu,cpuacct:/b\n0::/b\n");
    put(r, "/sys/fs/cgroup/b/cpu.max", "500000 100000\n");
    put(r, "/sys/fs/cgroup/cpu,cpuacct/b/cpu.cfs_quota_us", "300000\n");
    put(r, "/sys/fs/cgroup/cpu,cpuacct/b/cpu.cfs_period_us", "100000\n");
    expect_limit(r, 3, "v1 and v2 both limited: the smaller");

    r = root_for("escaped");
    put(r, "/proc/self/mountinfo", "30 23 0:26 / /mnt/cg\\040two rw - cgroup2 cgroup2 rw\n");
    put(r, "/proc/self/cgroup", "0::/x\n");
    put(r, "/mnt/cg two/x/cpu.max", "700000 100000");
    expect_limit(r, 7, "a mount point with a space, written \\040 in mountinfo");

    r = root_for("broken");
    expect_limit(r, 0, "no mountinfo: no quota");
    put(r, "/proc/self/mountinfo", "garbage\n\n- - -\n30 23 0:26 / /sys/fs/cgroup rw - cgroup2\n" V2_MOUNT);
    expect_limit(r, 0, "mountinfo without this process's cgroup file: no quota");
    put(r, "/proc/self/cgroup", "nonsense\n0:\n0::/c\n");
    put(r, "/sys/fs/cgroup/c/cpu.max", "lots\n");
    expect_limit(r, 0, "cpu.max that is not numbers: no quota");
    put(r, "/sys/fs/cgroup/c/cpu.max", "100000\n");
    expect_limit(r, 0, "cpu.max without a period: no quota");
    put(r, "/sys/fs/cgroup/c/cpu.max", "-5 100000\n");
    expect_limit(r, 0, "a negative quota: no quota");
    put(r, "/sys/fs/cgroup/c/cpu.max", "100000 0\n");
    expect_limit(r, 0, "a zero period: no quota");
    put(r, "/sys/fs/cgroup/c/cpu.max", "1e30 1\n");
    expect_limit(r, 4096, "an absurd quota is capped at 4096");

    /* The live count: within the online cores and the affinity mask. */
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    const uint32_t live = rtk_core_count();
    check(live >= 1 && (online < 1 || live <= (uint32_t)online), "rtk_core_count() %u is in [1, %ld online]", live,
          online);
    cpu_set_t all, one;
    if (sched_getaffinity(0, sizeof all, &all) == 0) {
        int first = 0;
        while (first < CPU_SETSIZE && !CPU_ISSET(first, &all))
            first++;
        CPU_ZERO(&one);
        CPU_SET(first, &one);
        if (sched_setaffinity(0, sizeof one, &one) == 0) {
            const uint32_t pinned = rtk_core_count();
            check(pinned == 1, "pinned to CPU %d: 1 core (got %u)", first, pinned);
            sched_setaffinity(0, sizeof all, &all);
        } else {
            printf("skip  cannot set this thread's affinity: %s\n", strerror(errno));
        }
        check(rtk_core_count() == live, "the mask restored: %u again", live);
    }

    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", base);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", base);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
