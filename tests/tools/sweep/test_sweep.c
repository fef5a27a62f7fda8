/* Tests for the arithmetic of tools/sweep/sweep.c through the public API: the
 * log-log slope fit and the time-to-error interpolation, on synthetic
 * points whose answers are exact (power laws, and a three-point fit worked
 * out by hand), and every case where no answer may be made up. */
#include <rtk/host.h>

#include "tools.h"

#include <math.h>
#include <stdio.h>

static int failures;

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            failures++;                                                                            \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);                        \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fputc('\n', stderr);                                                                   \
        }                                                                                          \
    } while (0)

/* got equals want up to a few ulps of the logs and exps involved. */
#define NEAR(got, want) CHECK(fabs((got) - (want)) <= 1e-12 * fabs(want), "%s = %.17g, expected %.17g", #got, \
                              (double)(got), (double)(want))

static void test_slope(void)
{
    double spp[] = {1, 2, 4, 8, 16};
    double rmse[5], relmse[5];
    for (int i = 0; i < 5; i++) {
        rmse[i] = 0.3 * pow(spp[i], -0.5);
        relmse[i] = 2e-2 * pow(spp[i], -1.5);
    }
    double slope = 0.0;
    CHECK(rtk_sweep_fit_slope(spp, rmse, 5, &slope) == RTK_OK, "%s", rtk_error_message());
    NEAR(slope, -0.5);
    CHECK(rtk_sweep_fit_slope(spp + 2, relmse + 2, 3, &slope) == RTK_OK, "%s", rtk_error_message());
    NEAR(slope, -1.5);

    /* log2 x = 0, 1, 2 and log2 y = 0, -1, -1: mean (1, -2/3),
     * sxy = -1 * 2/3 + 1 * -1/3 = -1, sxx = 2, slope -1/2. */
    double x[] = {1, 2, 4}, y[] = {1, 0.5, 0.5};
    CHECK(rtk_sweep_fit_slope(x, y, 3, &slope) == RTK_OK, "%s", rtk_error_message());
    NEAR(slope, -0.5);

    double zero[] = {1, 0}, nan_y[] = {1, NAN}, same[] = {2, 2};
    slope = 42.0;
    CHECK(rtk_sweep_fit_slope(x, y, 1, &slope) == RTK_ERR_INVALID, "one point");
    CHECK(rtk_sweep_fit_slope(zero, y, 2, &slope) == RTK_ERR_INVALID, "x = 0");
    CHECK(rtk_sweep_fit_slope(x, zero, 2, &slope) == RTK_ERR_INVALID, "y = 0");
    CHECK(rtk_sweep_fit_slope(x, nan_y, 2, &slope) == RTK_ERR_INVALID, "y NaN");
    CHECK(rtk_sweep_fit_slope(same, y, 2, &slope) == RTK_ERR_INVALID, "x all equal");
    CHECK(slope == 42.0, "slope written on failure: %g", slope);
}

static void test_time_to_error(void)
{
    /* seconds = 0.1 spp, relMSE = 0.1 / spp: error = 0.01 / seconds, a
     * straight line in log-log that interpolation follows exactly. */
    double t[] = {0.1, 0.2, 0.4, 0.8}, e[] = {0.1, 0.05, 0.025, 0.0125};
    double got = -1.0;
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.03, &got) == RTK_SWEEP_REACHED, "0.03 is inside");
    NEAR(got, 0.01 / 0.03);
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.0125, &got) == RTK_SWEEP_REACHED, "the last point");
    NEAR(got, 0.8);
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.05, &got) == RTK_SWEEP_REACHED, "a measured point");
    NEAR(got, 0.2);

    /* Time growing as spp^1 while error falls as spp^-1/2 between two
     * points: target at the geometric mean of the errors is reached at
     * the geometric mean of the times. */
    double t2[] = {1.0, 4.0}, e2[] = {1e-2, 5e-3};
    CHECK(rtk_sweep_time_to_error(t2, e2, 2, sqrt(1e-2 * 5e-3), &got) == RTK_SWEEP_REACHED, "midpoint");
    NEAR(got, 2.0);

    got = -1.0;
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.001, &got) == RTK_SWEEP_NOT_REACHED, "below every error");
    CHECK(got == -1.0, "not reached, yet a time was written: %g", got);
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.2, &got) == RTK_SWEEP_AT_FIRST, "above every error");
    NEAR(got, 0.1);
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.1, &got) == RTK_SWEEP_AT_FIRST, "at the first point");
    NEAR(got, 0.1);

    /* Noisy: the first crossing counts, not a later one. */
    double en[] = {0.1, 0.02, 0.05, 0.01};
    CHECK(rtk_sweep_time_to_error(t, en, 4, 0.03, &got) == RTK_SWEEP_REACHED, "noisy");
    double f = (log(0.03) - log(0.1)) / (log(0.02) - log(0.1));
    NEAR(got, exp(log(0.1) + f * (log(0.2) - log(0.1))));

    /* An exact image at the step's end: that point's time. */
    double ez[] = {0.1, 0.0};
    CHECK(rtk_sweep_time_to_error(t, ez, 2, 0.03, &got) == RTK_SWEEP_REACHED, "error 0");
    NEAR(got, 0.2);

    double tbad[] = {0.1, 0.0}, ebad[] = {0.1, NAN};
    CHECK(rtk_sweep_time_to_error(t, e, 0, 0.03, &got) == RTK_SWEEP_NO_DATA, "no points");
    CHECK(rtk_sweep_time_to_error(tbad, e, 2, 0.03, &got) == RTK_SWEEP_NO_DATA, "zero seconds");
    CHECK(rtk_sweep_time_to_error(t, ebad, 2, 0.03, &got) == RTK_SWEEP_NO_DATA, "NaN error");
    CHECK(rtk_sweep_time_to_error(t, e, 4, 0.0, &got) == RTK_SWEEP_NO_DATA, "target 0");
}

int main(void)
{
    test_slope();
    test_time_to_error();
    if (failures) {
        fprintf(stderr, "%d failure%s\n", failures, failures == 1 ? "" : "s");
        return 1;
    }
    printf("sweep arithmetic: all checks passed\n");
    return 0;
}
