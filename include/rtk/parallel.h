/* Teams of threads for plugins and the kernel: the kernel keeps its
 * worker threads between teams, so a build that runs several parallel
 * phases does not pay for starting threads in each (on a small mesh,
 * as much as the phase's work).
 *
 * A team's members run at the same time, each on its own thread, so they
 * may wait for each other (rtk_team_sync). A member that starts a team of
 * its own gets a team of one. */
#ifndef RTK_PARALLEL_H
#define RTK_PARALLEL_H

#include <rtk/common.h>

RTK_EXTERN_C_BEGIN

/* A running team (opaque). */
typedef struct rtk_team rtk_team;

/* The work of member index of a team of size members (index 0 is the
 * thread that called rtk_team_run). */
typedef void (*rtk_team_fn)(void *ctx, rtk_team *team, uint32_t index, uint32_t size);

/* Runs fn on a team of at most wanted members (0 counts as 1; fewer when
 * threads cannot be had) and returns the team's size once every member
 * has returned. [any thread] */
RTK_API uint32_t rtk_team_run(uint32_t wanted, rtk_team_fn fn, void *ctx);

/* Returns once every member of team has called it: a barrier, reusable
 * at once. Every member must call it the same number of times.
 * [members of team] */
RTK_API void rtk_team_sync(rtk_team *team);

RTK_EXTERN_C_END

#endif
