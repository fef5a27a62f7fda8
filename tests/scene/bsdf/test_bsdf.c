/* The BSDF service (include/rtk/bsdf.h, kernel/scene/bsdf.c), lobe by lobe
 * and in mixtures, over a grid of outgoing directions (0 to 89 degrees from
 * the normal, from either side for the rough dielectric) and roughness:
 * - sampling matches the pdf: chi-square goodness of fit over bins in
 *   (cos theta, phi) (over the sphere for lobes that transmit) plus one
 *   cell for failed samples, expected counts from the pdf integrated per
 *   bin, Sidak-corrected threshold;
 * - the pdf integrates to the probability that sample() succeeds (1 for the
 *   diffuse lobes), and sample() returns exactly eval() and pdf();
 * - eval() is the header's closed form, written again here in double,
 *   reciprocal (across a dielectric: f(wo, wi) / n_i^2 = f(wi, wo) / n_o^2),
 *   0 below the surface for reflecting lobes;
 * - white furnace: directional albedo <= 1, = 1 for Lambert, and the
 *   microfacet lobes' single-scattering loss (GGX, rough dielectric,
 *   plastic) equals the albedo integrated here from the closed form by
 *   quadrature, not through sample(); the tables are printed;
 * - mixtures: eval() is the weighted sum, pdf() the sum of p_i pdf_i with
 *   the header's p_i computed here; a delta lobe in a mixture; an empty
 *   BSDF is black; no NaN at z = 0, +-1 or the critical angle.
 * The smooth dielectric (a delta lobe) over relative indices and incidence
 * from both sides, total internal reflection included: exact mirror and
 * Snell directions, the fraction of reflections against the Fresnel
 * equations written here from s- and p-amplitudes, path weight 1.
 * It also checks rtk_frame and the chi-square p-value function itself.
 * An argument (base, rough, plastic, mixture) runs one group of tests. */
#include <rtk/rtk.h>

#include <complex.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

#define PI 3.14159265358979323846

/* Chi-square bins: NCOS in cos theta over (0, 1], NPHI in phi over (-pi, pi];
 * a lobe that transmits is binned over the sphere, 2 NCOS rows over [-1, 1]. */
#define NCOS 16
#define NPHI 32
#define NBINS_MAX (2 * NCOS * NPHI)
/* Midpoint sub-samples per bin and axis: from SUB_MIN, doubled up to SUB_MAX. */
#define SUB_MIN 8
#define SUB_MAX 1024
/* Samples per chi-square test. */
#define NSAMPLES 1000000L
/* Family-wise significance of the chi-square tests. */
#define ALPHA_FAMILY 0.01

static const float elevations[] = {0.0f, 30.0f, 60.0f, 80.0f, 89.0f};
#define NELEV ((int)(sizeof elevations / sizeof elevations[0]))
static const float ggx_alphas[] = {0.05f, 0.2f, 0.5f, 1.0f};
#define NALPHA ((int)(sizeof ggx_alphas / sizeof ggx_alphas[0]))
static const float on_sigmas[] = {0.0f, 0.5f, 1.0f};
#define NSIGMA ((int)(sizeof on_sigmas / sizeof on_sigmas[0]))
static const float plastic_f0s[] = {0.04f, 0.2f, 1.0f};
#define NF0 ((int)(sizeof plastic_f0s / sizeof plastic_f0s[0]))
/* At every elevation: Lambert, Oren-Nayar, GGX; the rough dielectric
 * from both sides and tinted; plastic; two mixtures over alpha and one of
 * three lobes. */
#define NCHI2 (NELEV * (1 + NSIGMA + NALPHA + 2 * NALPHA + 1 + NF0 * NALPHA + 2 * NALPHA + 1))

/* Azimuth of wo: off the bins' edges. */
#define PHI_O 0.7

static double sidak_threshold;

static uint64_t rng_state;

static uint64_t splitmix64(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1) with 24 bits, as a float sampler gives. */
static float uniform(void)
{
    return (float)(splitmix64() >> 40) * (1.0f / 16777216.0f);
}

/* Regularized upper incomplete gamma Q(a, x) (Numerical Recipes 6.2: series
 * below a + 1, Lentz's continued fraction above). */
static double gamma_q(double a, double x)
{
    if (x <= 0.0)
        return 1.0;
    double front = exp(-x + a * log(x) - lgamma(a));
    if (x < a + 1.0) {
        double ap = a, del = 1.0 / a, sum = del;
        for (int n = 0; n < 100000 && fabs(del) > fabs(sum) * 1e-16; n++) {
            ap += 1.0;
            del *= x / ap;
            sum += del;
        }
        return 1.0 - sum * front;
    }
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; i++) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (fabs(d) < tiny)
            d = tiny;
        c = b + an / c;
        if (fabs(c) < tiny)
            c = tiny;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1.0) < 1e-16)
            break;
    }
    return front * h;
}

static rtk_vec3 direction(double theta, double phi)
{
    return rtk_vec3_make((float)(sin(theta) * cos(phi)), (float)(sin(theta) * sin(phi)), (float)cos(theta));
}

static rtk_vec3 wo_at(float elevation_deg)
{
    return direction(elevation_deg * PI / 180.0, PHI_O);
}

static rtk_vec2 vec2(float x, float y)
{
    rtk_vec2 v = {x, y};
    return v;
}

static int is_finite_rgb(rtk_rgb c)
{
    return isfinite(c.r) && isfinite(c.g) && isfinite(c.b);
}

static void test_gamma_q(void)
{
    double worst = 0.0;
    const double xs[] = {0.05, 0.2, 1.0, 3.0, 10.0, 40.0};
    for (int i = 0; i < 6; i++) {
        double x = xs[i];
        worst = fmax(worst, fabs(gamma_q(1.0, x) - exp(-x)) / exp(-x));
        worst = fmax(worst, fabs(gamma_q(0.5, x) - erfc(sqrt(x))) / erfc(sqrt(x)));
        /* Q(2, x) = (1 + x) e^-x: the chi-square tail for 4 degrees of freedom. */
        worst = fmax(worst, fabs(gamma_q(2.0, x) - (1.0 + x) * exp(-x)) / ((1.0 + x) * exp(-x)));
    }
    check(worst < 1e-9 && gamma_q(3.0, 0.0) == 1.0,
          "regularized upper incomplete gamma matches e^-x, erfc(sqrt x), (1+x) e^-x (worst relative error %.1e)", worst);
    /* 300 degrees of freedom: the mean 300 lies near the median, p ~ 0.49. */
    double p = gamma_q(150.0, 150.0);
    check(p > 0.48 && p < 0.50, "chi-square p-value at the mean for 300 dof is %.4f", p);
}

static void test_frame(void)
{
    double worst = 0.0;
    int n = 0;
    for (int i = 0; i <= 40; i++)
        for (int j = 0; j < 16; j++, n++) {
            double theta = PI * i / 40.0, phi = 2.0 * PI * j / 16.0 + 0.1;
            rtk_vec3 nrm = rtk_vec3_normalize(direction(theta, phi));
            rtk_frame f = rtk_frame_from_normal(nrm);
            rtk_vec3 c = rtk_vec3_cross(f.s, f.t);
            rtk_vec3 v = rtk_vec3_normalize(rtk_vec3_make(0.3f, -0.5f, 0.8f));
            rtk_vec3 back = rtk_frame_to_world(&f, rtk_frame_to_local(&f, v));
            rtk_vec3 nz = rtk_frame_to_local(&f, nrm);
            double e[] = {fabs(rtk_vec3_length(f.s) - 1.0), fabs(rtk_vec3_length(f.t) - 1.0),
                          fabs(rtk_vec3_dot(f.s, f.t)), fabs(rtk_vec3_dot(f.s, nrm)), fabs(rtk_vec3_dot(f.t, nrm)),
                          rtk_vec3_length(rtk_vec3_sub(c, nrm)), rtk_vec3_length(rtk_vec3_sub(back, v)),
                          fabs(nz.x), fabs(nz.y), fabs(nz.z - 1.0)};
            for (size_t k = 0; k < sizeof e / sizeof e[0]; k++)
                worst = fmax(worst, isfinite(e[k]) ? e[k] : INFINITY);
        }
    check(worst < 1e-5,
          "rtk_frame over %d normals (poles included): orthonormal, s x t = n, to_local(n) = +z, "
          "to_world(to_local(v)) = v (worst %.1e)",
          n, worst);
}

/* The header's closed forms in double, written apart from the kernel. */
static double ref_lambda(double alpha, rtk_vec3 w)
{
    double tan2 = ((double)w.x * w.x + (double)w.y * w.y) / ((double)w.z * w.z);
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

/* GGX D of the direction h (any length, either side). */
static double ref_ggx_d(double alpha, const double h[3])
{
    double len2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
    double c2 = h[2] * h[2] / len2, s2 = (h[0] * h[0] + h[1] * h[1]) / len2;
    double a2 = alpha * alpha;
    return a2 / (PI * (s2 + a2 * c2) * (s2 + a2 * c2));
}

/* GGX f with F = 1. */
static double ref_ggx(double alpha, rtk_vec3 wo, rtk_vec3 wi)
{
    double h[3] = {(double)wo.x + wi.x, (double)wo.y + wi.y, (double)wo.z + wi.z};
    double g2 = 1.0 / (1.0 + ref_lambda(alpha, wo) + ref_lambda(alpha, wi));
    return ref_ggx_d(alpha, h) * g2 / (4.0 * wo.z * wi.z);
}

/* Fujii's Oren-Nayar with albedo 1. */
static double ref_oren_nayar(double sigma, rtk_vec3 wo, rtk_vec3 wi)
{
    double a = 1.0 / (PI + (PI / 2.0 - 2.0 / 3.0) * sigma);
    double s = (double)wi.x * wo.x + (double)wi.y * wo.y;
    double t = s > 0.0 ? fmax(wi.z, wo.z) : 1.0;
    return a * (1.0 + sigma * s / t);
}

/* A grid of directions over the upper hemisphere, grazing ones included. */
#define NGRID 15
static rtk_vec3 grid_dir(int i)
{
    static const double th[] = {5.0, 30.0, 60.0, 80.0, 89.0};
    static const double ph[] = {0.3, 2.0, 4.1};
    return direction(th[i % 5] * PI / 180.0, ph[i / 5]);
}

static double rel_diff(double a, double b)
{
    double m = fmax(fabs(a), fabs(b));
    return m > 0.0 ? fabs(a - b) / m : 0.0;
}

/* eval() equals the closed form (f = 1 lobes: white albedo, F = 1), is
 * reciprocal, and is 0 below the surface, as is pdf() and sample(). */
/* A closed form f(wo, wi) in double (white: albedo 1, F = 1 for GGX) of parameters p. */
typedef double (*ref_fn)(const double *p, rtk_vec3 wo, rtk_vec3 wi);

static void test_pointwise(const char *label, const rtk_bsdf *b, ref_fn ref, const double *param)
{
    double worst_ref = 0.0, worst_recip = 0.0;
    int below_ok = 1;
    for (int i = 0; i < NGRID; i++)
        for (int j = 0; j < NGRID; j++) {
            rtk_vec3 wo = grid_dir(i), wi = grid_dir(j);
            rtk_rgb f = rtk_bsdf_eval(b, wo, wi), g = rtk_bsdf_eval(b, wi, wo);
            if (ref)
                worst_ref = fmax(worst_ref, rel_diff(f.g, ref(param, wo, wi)));
            worst_recip = fmax(worst_recip, fmax(rel_diff(f.r, g.r), fmax(rel_diff(f.g, g.g), rel_diff(f.b, g.b))));
            rtk_vec3 below = rtk_vec3_make(wi.x, wi.y, -wi.z);
            rtk_rgb z1 = rtk_bsdf_eval(b, wo, below), z2 = rtk_bsdf_eval(b, below, wo);
            below_ok &= z1.r == 0 && z1.g == 0 && z1.b == 0 && z2.r == 0 && z2.g == 0 && z2.b == 0;
            below_ok &= rtk_bsdf_pdf(b, wo, below) == 0.0f && rtk_bsdf_pdf(b, below, wo) == 0.0f;
            rtk_bsdf_sample_out out;
            below_ok &= rtk_bsdf_sample(b, below, 0.5f, vec2(0.3f, 0.6f), &out) == 0;
        }
    if (ref)
        check(worst_ref < 1e-5, "%s: eval() is the header's closed form over %dx%d directions (worst relative %.1e)",
              label, NGRID, NGRID, worst_ref);
    check(worst_recip <= 1e-5, "%s: reciprocity f(wo, wi) = f(wi, wo) over %dx%d directions (worst relative %.1e)",
          label, NGRID, NGRID, worst_recip);
    check(below_ok, "%s: f = 0 and pdf = 0 with wi or wo below the surface, sample() fails for wo below", label);
}

static double ref_lambert(const double *unused, rtk_vec3 wo, rtk_vec3 wi)
{
    (void)unused, (void)wo, (void)wi;
    return 1.0 / PI;
}

static double ref_ggx_p(const double *p, rtk_vec3 wo, rtk_vec3 wi)
{
    return ref_ggx(p[0], wo, wi);
}

static double ref_oren_nayar_p(const double *p, rtk_vec3 wo, rtk_vec3 wi)
{
    return ref_oren_nayar(p[0], wo, wi);
}

/* A function over directions to integrate over the bins: the hemisphere,
 * or the sphere when sphere is set. */
typedef struct integrand {
    double (*fn)(const struct integrand *in, rtk_vec3 wi);
    const rtk_bsdf *b;
    rtk_vec3 wo;
    ref_fn ref;         /* fcos_integrand: the closed form */
    const double *param; /* its parameters */
    int sphere;
    int jump;            /* it jumps across the cone wi.z = jump_cos */
    double jump_cos;
} integrand;

/* Rows of bins in cos theta, and the cosine where they start. */
static int rows_of(int sphere)
{
    return sphere ? 2 * NCOS : NCOS;
}

static double cos_lo(int sphere)
{
    return sphere ? -1.0 : 0.0;
}

/* Integral of in over bin (i, j) by the midpoint rule in (theta, phi)
 * with sub x sub points (dw = sin theta dtheta dphi). */
static double bin_piece(const integrand *in, double th0, double th1, int j, int sub)
{
    double dth = (th1 - th0) / sub, dph = 2.0 * PI / NPHI / sub, ph0 = -PI + 2.0 * PI * j / NPHI;
    double sum = 0.0, cph[SUB_MAX], sph[SUB_MAX];
    for (int c = 0; c < sub; c++) {
        double ph = ph0 + (c + 0.5) * dph;
        cph[c] = cos(ph);
        sph[c] = sin(ph);
    }
    for (int a = 0; a < sub; a++) {
        double th = th0 + (a + 0.5) * dth, st = sin(th), ct = cos(th);
        for (int c = 0; c < sub; c++) {
            rtk_vec3 wi = rtk_vec3_make((float)(st * cph[c]), (float)(st * sph[c]), (float)ct);
            sum += in->fn(in, wi) * st;
        }
    }
    return sum * dth * dph;
}

/* Bin (i, j) of in, split where the integrand jumps (in->jump_cos) so that
 * the midpoint rule meets only smooth pieces. */
static double bin_integral(const integrand *in, int i, int j, int sub)
{
    double lo = cos_lo(in->sphere);
    double th0 = acos(fmin(lo + (i + 1.0) / NCOS, 1.0)), th1 = acos(lo + (double)i / NCOS);
    double tj = in->jump ? acos(in->jump_cos) : th0;
    if (tj > th0 && tj < th1)
        return bin_piece(in, th0, tj, j, sub) + bin_piece(in, tj, th1, j, sub);
    return bin_piece(in, th0, th1, j, sub);
}

/* Convergence of one bin's integral v: the change from doubling the
 * sub-samples is at most max(rel v, root sqrt(v), abs) twice in a row, or
 * once on reaching SUB_MAX (a single small change at a few sub-samples can
 * be chance where the integrand jumps inside the bin, as a rough
 * dielectric's transmission does where the half vector turns over). */
typedef struct quad_tol {
    double rel, root, abs;
} quad_tol;

typedef struct quad_result {
    double total; /* sum over the bins */
    double err;   /* sum of each bin's last change: 3 x the midpoint rule's error estimate (h^2) */
    int max_sub;  /* most sub-samples per axis a bin needed */
    int short_of; /* bins that reached SUB_MAX unconverged */
} quad_result;

/* The integral of in over each bin (into per_bin when given), the
 * sub-samples per axis doubled from SUB_MIN until tol holds or SUB_MAX. */
static quad_result integrate_bins(const integrand *in, quad_tol tol, double *per_bin)
{
    quad_result r = {0.0, 0.0, 0, 0};
    for (int i = 0; i < rows_of(in->sphere); i++)
        for (int j = 0; j < NPHI; j++) {
            int sub = SUB_MIN, small = 0;
            double prev = bin_integral(in, i, j, sub), cur;
            for (;;) {
                sub *= 2;
                cur = bin_integral(in, i, j, sub);
                double change = fabs(cur - prev), v = fabs(cur);
                small = change <= fmax(tol.rel * v, fmax(tol.root * sqrt(v), tol.abs)) ? small + 1 : 0;
                if (small == 2 || (small == 1 && sub >= SUB_MAX))
                    break;
                if (sub >= SUB_MAX) {
                    r.short_of++;
                    break;
                }
                prev = cur;
            }
            r.total += cur;
            r.err += fabs(cur - prev);
            if (per_bin)
                per_bin[i * NPHI + j] = cur;
            if (sub > r.max_sub)
                r.max_sub = sub;
        }
    return r;
}

/* The integral of in over all bins with an error estimate under target:
 * every bin at SUB_MIN, 2 and 4 x SUB_MIN sub-samples per axis, then the
 * bin with the largest estimate doubled until the estimates sum to at most
 * target (the error goes where the integrand peaks, not into every bin).
 * A bin's estimate is its last change or a quarter of the one before,
 * whichever is larger: the midpoint rule's error falls 4x a doubling, and a
 * change that comes out small by chance does not end the bin. err is the
 * estimates' sum; short_of counts the bins left at SUB_MAX above target. */
static quad_result integrate_total(const integrand *in, double target)
{
    static double cur[NBINS_MAX], last[NBINS_MAX], est[NBINS_MAX];
    static int sub[NBINS_MAX];
    const int nbins = rows_of(in->sphere) * NPHI;
    quad_result r = {0.0, 0.0, 0, 0};
    for (int k = 0; k < nbins; k++) {
        int i = k / NPHI, j = k % NPHI;
        double a = bin_integral(in, i, j, SUB_MIN), b = bin_integral(in, i, j, 2 * SUB_MIN);
        sub[k] = 4 * SUB_MIN;
        cur[k] = bin_integral(in, i, j, sub[k]);
        last[k] = fabs(cur[k] - b);
        est[k] = fmax(last[k], 0.25 * fabs(b - a));
    }
    for (;;) {
        double sum = 0.0;
        int worst = -1;
        for (int k = 0; k < nbins; k++) {
            sum += est[k];
            if (sub[k] < SUB_MAX && (worst < 0 || est[k] > est[worst]))
                worst = k;
        }
        if (sum <= target || worst < 0 || est[worst] == 0.0)
            break;
        double prev = cur[worst], prev_change = last[worst];
        sub[worst] *= 2;
        cur[worst] = bin_integral(in, worst / NPHI, worst % NPHI, sub[worst]);
        last[worst] = fabs(cur[worst] - prev);
        est[worst] = fmax(last[worst], 0.25 * prev_change);
    }
    for (int k = 0; k < nbins; k++) {
        r.total += cur[k];
        r.err += est[k];
        if (sub[k] > r.max_sub)
            r.max_sub = sub[k];
    }
    if (r.err > target)
        for (int k = 0; k < nbins; k++)
            r.short_of += sub[k] >= SUB_MAX && est[k] > 0.0;
    return r;
}

static double pdf_integrand(const integrand *in, rtk_vec3 wi)
{
    return rtk_bsdf_pdf(in->b, in->wo, wi);
}

/* f |cos| from the test's closed form. */
static double fcos_integrand(const integrand *in, rtk_vec3 wi)
{
    return in->ref(in->param, in->wo, wi) * fabs((double)wi.z);
}

static int bin_of(rtk_vec3 wi, int sphere)
{
    int i = (int)((wi.z - cos_lo(sphere)) * NCOS), rows = rows_of(sphere);
    double phi = atan2((double)wi.y, (double)wi.x);
    int j = (int)((phi + PI) / (2.0 * PI) * NPHI);
    i = i < 0 ? 0 : i >= rows ? rows - 1 : i;
    j = j < 0 ? 0 : j >= NPHI ? NPHI - 1 : j;
    return i * NPHI + j;
}

/* Chi-square test of observed (nbins bins, then the failed samples) against
 * n times mass (the failure cell expects what mass leaves of 1). Cells
 * expecting fewer than 5 are pooled into one; a pool still under 5 joins
 * the smallest other cell. */
static void chi2_test(const char *label, const long *observed, const double *mass, long n, int sphere)
{
    static double e[NBINS_MAX + 1];
    const int NBINS = rows_of(sphere) * NPHI;
    double total = 0.0;
    for (int k = 0; k < NBINS; k++) {
        e[k] = (double)n * mass[k];
        total += mass[k];
    }
    e[NBINS] = (double)n * fmax(0.0, 1.0 - total);
    long outside = 0;
    for (int k = 0; k <= NBINS; k++)
        if (e[k] == 0.0)
            outside += observed[k];
    double pool_e = 0.0, pool_o = 0.0;
    int pooled = 0, smallest = -1;
    for (int k = 0; k <= NBINS; k++)
        if (e[k] < 5.0) {
            pool_e += e[k], pool_o += (double)observed[k];
            pooled++;
        } else if (smallest < 0 || e[k] < e[smallest]) {
            smallest = k;
        }
    double chi2 = 0.0, worst_term = 0.0;
    int cells = 0, worst = -1;
    for (int k = 0; k <= NBINS; k++) {
        if (e[k] < 5.0)
            continue;
        double ek = e[k], ok = (double)observed[k];
        if (k == smallest && pool_e < 5.0)
            ek += pool_e, ok += pool_o;
        double term = (ok - ek) * (ok - ek) / ek;
        chi2 += term;
        cells++;
        if (term > worst_term)
            worst_term = term, worst = k;
    }
    if (pool_e >= 5.0 || (smallest < 0 && pooled > 0)) {
        chi2 += pool_e > 0.0 ? (pool_o - pool_e) * (pool_o - pool_e) / pool_e : (pool_o > 0.0 ? INFINITY : 0.0);
        cells++;
    }
    int dof = cells - 1;
    double p = dof > 0 ? gamma_q(0.5 * dof, 0.5 * chi2) : 0.0;
    check(outside == 0 && p >= sidak_threshold,
          "%s: chi-square N=%ld, %dx%d bins in (cos theta, phi) + 1 failure cell, %d pooled (expected < 5) -> %d "
          "cells, chi2=%.1f dof=%d p=%.3g >= %.3g; %ld samples where pdf = 0",
          label, n, rows_of(sphere), NPHI, pooled, cells, chi2, dof, p, sidak_threshold, outside);
    if (p < sidak_threshold && worst >= 0)
        printf("      largest term %.1f: cell %d (row %d of cos theta from %g, column %d), observed %ld, expected %.1f\n",
               worst_term, worst, worst / NPHI, cos_lo(sphere), worst % NPHI, observed[worst], e[worst]);
}

typedef struct furnace {
    double mean[3], se[3];
    double success; /* fraction of sample() calls that returned a direction */
} furnace;

/* Whether sample() flags are right: a subset of the BSDF's, one event, the
 * event on the side of wi (reflection: wo's side), one kind of scattering. */
static int event_flags_ok(unsigned flags, unsigned lobes, rtk_vec3 wo, rtk_vec3 wi)
{
    int same_side = (wo.z > 0.0f) == (wi.z > 0.0f);
    unsigned event = flags & (RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION);
    unsigned kind = flags & (RTK_BSDF_DIFFUSE | RTK_BSDF_GLOSSY | RTK_BSDF_DELTA);
    return (flags & ~lobes) == 0 && event == (same_side ? RTK_BSDF_REFLECTION : RTK_BSDF_TRANSMISSION) &&
           (kind == RTK_BSDF_DIFFUSE || kind == RTK_BSDF_GLOSSY || kind == RTK_BSDF_DELTA);
}

/* n samples of b for wo: each agrees with eval() and pdf(), is a unit
 * direction above the surface (anywhere off it when sphere is set) with
 * flags event_flags_ok; fills hist (bin of each, then the failures) when
 * given and returns the mean of f |cos| / pdf (0 for a failure) with its
 * standard error. */
static furnace sample_pass(const char *label, const rtk_bsdf *b, rtk_vec3 wo, long n, long *hist, int sphere)
{
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
    long succeeded = 0, mismatched = 0, bad = 0;
    unsigned flags = rtk_bsdf_flags(b);
    for (long k = 0; k < n; k++) {
        float u_lobe = uniform();
        rtk_vec2 u = vec2(uniform(), uniform());
        rtk_bsdf_sample_out out;
        if (!rtk_bsdf_sample(b, wo, u_lobe, u, &out)) {
            if (hist)
                hist[rows_of(sphere) * NPHI]++;
            continue;
        }
        succeeded++;
        float pdf = rtk_bsdf_pdf(b, wo, out.wi);
        rtk_rgb f = rtk_bsdf_eval(b, wo, out.wi);
        if (rel_diff(pdf, out.pdf) > 1e-5 || rel_diff(f.r, out.f.r) > 1e-5 || rel_diff(f.g, out.f.g) > 1e-5 ||
            rel_diff(f.b, out.f.b) > 1e-5)
            mismatched++;
        if (!(out.pdf > 0.0f) || !isfinite(out.pdf) || !is_finite_rgb(out.f) ||
            !(sphere ? out.wi.z != 0.0f : out.wi.z > 0.0f) || fabs(rtk_vec3_length(out.wi) - 1.0) > 1e-5 ||
            !event_flags_ok(out.flags, flags, wo, out.wi))
            bad++;
        double cw = fabs((double)out.wi.z) / out.pdf;
        double w[3] = {out.f.r * cw, out.f.g * cw, out.f.b * cw};
        for (int c = 0; c < 3; c++)
            sum[c] += w[c], sum2[c] += w[c] * w[c];
        if (hist)
            hist[bin_of(out.wi, sphere)]++;
    }
    check(mismatched == 0 && bad == 0,
          "%s: %ld of %ld samples succeed, each a unit wi %s with finite f, pdf > 0 and flags of one event of the "
          "BSDF's on wi's side (%ld not), f and pdf those of eval() and pdf() (%ld not)",
          label, succeeded, n, sphere ? "off the surface" : "above the surface", bad, mismatched);
    furnace r;
    for (int c = 0; c < 3; c++) {
        r.mean[c] = sum[c] / (double)n;
        double var = sum2[c] / (double)n - r.mean[c] * r.mean[c];
        r.se[c] = sqrt(fmax(var, 0.0) / (double)(n - 1));
    }
    r.success = (double)succeeded / (double)n;
    return r;
}

/* What run_case checks for one BSDF. */
typedef struct lobe_case {
    const char *name;
    const rtk_bsdf *b;
    int sphere;       /* it transmits: bins, directions and the pdf's integral over the sphere */
    int never_fails;  /* sample() always returns a direction: the pdf integrates to 1 */
    int furnace_one;  /* white furnace = 1 within 1e-3 */
    ref_fn ref;       /* closed form (albedo 1) whose f |cos| by quadrature is the reference albedo, or NULL */
    const double *param;
    float jump_ior;   /* holds a rough dielectric of this ior (else 0), whose transmission jumps to 0 where
                       * the half vector wo + eta wi turns over: at wi.z = -wo.z / eta */
} lobe_case;

/* The sampled white-furnace albedo (green) and its quadrature reference (NAN without one). */
typedef struct albedo {
    double sampled, reference;
} albedo;

/* Chi-square, normalisation, sample() consistency and the white furnace
 * for c's BSDF (white: albedo 1, F = 1 for GGX) at wo. */
static albedo run_case(const lobe_case *c, rtk_vec3 wo, const char *label)
{
    static double mass[NBINS_MAX];
    static long hist[NBINS_MAX + 1];
    const char *domain = c->sphere ? "sphere" : "hemisphere";
    /* Each bin's quadrature error under 0.05 of its count's Poisson noise
     * (n x change <= 0.05 sqrt(max(n x mass, 1))): it adds at most ~0.0025
     * to the bin's chi-square term. */
    int jump = c->jump_ior > 0.0f;
    double eta = !jump ? 1.0 : wo.z > 0.0f ? c->jump_ior : 1.0 / c->jump_ior;
    integrand pdf = {.fn = pdf_integrand, .b = c->b, .wo = wo, .sphere = c->sphere, .jump = jump,
                     .jump_cos = -wo.z / eta};
    quad_tol counts = {0.0, 0.05 / sqrt((double)NSAMPLES), 0.05 / (double)NSAMPLES};
    quad_result q = integrate_bins(&pdf, counts, mass);
    check(q.short_of == 0, "%s: pdf integrated per bin to well under the counts' noise (up to %dx%d sub-samples, "
          "%d bins short of it)", label, q.max_sub, q.max_sub, q.short_of);
    memset(hist, 0, sizeof hist);
    furnace r = sample_pass(label, c->b, wo, NSAMPLES, hist, c->sphere);
    chi2_test(label, hist, mass, NSAMPLES, c->sphere);

    /* The quadrature's own error estimate, plus 1e-5 for float rounding of the pdf values. */
    double qtol = q.err + 1e-5;
    if (c->never_fails) {
        check(fabs(q.total - 1.0) <= qtol && r.success == 1.0,
              "%s: pdf integrates to %.6f over the %s (tolerance %.1e), every sample succeeds", label, q.total,
              domain, qtol);
    } else {
        double btol = 5.0 * sqrt(r.success * (1.0 - r.success) / (double)NSAMPLES);
        check(fabs(q.total - r.success) <= qtol + btol && q.total <= 1.0 + qtol,
              "%s: pdf integrates to %.6f over the %s, the fraction of samples that succeed %.6f (tolerance "
              "%.1e quadrature + %.1e binomial)",
              label, q.total, domain, r.success, qtol, btol);
    }

    double worst = 0.0;
    for (int k = 0; k < 3; k++)
        worst = fmax(worst, r.mean[k] - 1.0 - 5.0 * r.se[k]);
    check(worst <= 0.0, "%s: white furnace albedo (%.6f %.6f %.6f) <= 1 (+5 se = %.1e)", label, r.mean[0], r.mean[1],
          r.mean[2], 5.0 * r.se[1]);
    if (c->furnace_one)
        check(fabs(r.mean[0] - 1.0) <= 1e-3 && fabs(r.mean[1] - 1.0) <= 1e-3 && fabs(r.mean[2] - 1.0) <= 1e-3,
              "%s: white furnace albedo = 1 within 1e-3 (%.7f)", label, r.mean[1]);
    albedo out = {r.mean[1], NAN};
    if (c->ref) {
        /* The reference: f |cos| integrated by quadrature, never through sample(). Over the
         * hemisphere to a tenth of the rest of the tolerance: 5 standard errors of the sampled
         * albedo and 2e-5 for float rounding of f and pdf in the kernel. Over the sphere per
         * bin to 1e-5 or 0.05 of the noise of a count of N: a transmitted peak is
         * (eta - 1) / eta as wide as the reflected one, and where it jumps inside a bin the
         * midpoint rule's error does not fall 4x a doubling. */
        integrand fcos = {.fn = fcos_integrand, .wo = wo, .ref = c->ref, .param = c->param, .sphere = c->sphere,
                          .jump = pdf.jump, .jump_cos = pdf.jump_cos};
        double rest = 5.0 * r.se[1] + 2e-5;
        quad_tol per_bin = {1e-5, 0.05 / sqrt((double)NSAMPLES), 1e-8};
        quad_result ref_q = c->sphere ? integrate_bins(&fcos, per_bin, NULL) : integrate_total(&fcos, 0.1 * rest);
        out.reference = ref_q.total;
        double tol = rest + ref_q.err;
        check(ref_q.short_of == 0,
              "%s: reference albedo converged, error estimate %.1e (up to %dx%d sub-samples per bin, %d bins short)",
              label, ref_q.err, ref_q.max_sub, ref_q.max_sub, ref_q.short_of);
        check(fabs(r.mean[1] - out.reference) <= tol,
              "%s: single-scattering loss 1 - E = %.5f (sampled %.5f +- %.1e), reference by quadrature %.5f "
              "(tolerance %.1e)",
              label, 1.0 - r.mean[1], r.mean[1], r.se[1], 1.0 - out.reference, tol);
    }
    return out;
}

/* run_case at every elevation, wo from the outside (or the inside: -z);
 * the albedos go to out[NELEV] when given. */
static void run_elevations(const lobe_case *c, int inside, albedo *out)
{
    for (int e = 0; e < NELEV; e++) {
        char label[160];
        snprintf(label, sizeof label, "%s theta_o=%g%s", c->name, elevations[e], inside ? " from inside" : "");
        rtk_vec3 wo = wo_at(elevations[e]);
        if (inside)
            wo.z = -wo.z;
        albedo a = run_case(c, wo, label);
        if (out)
            out[e] = a;
    }
}

/* The pointwise checks, then run_case at every elevation. */
static void test_lobe(const lobe_case *c)
{
    test_pointwise(c->name, c->b, c->ref, c->param);
    run_elevations(c, 0, NULL);
}

/* Fresnel through eval() at the mirror pair of angle theta (m = +z):
 * f = F D(z) G2 / (4 cos^2), D(z) = 1 / (pi alpha^2). */
static double fresnel_of(const rtk_bsdf *b, double theta, int channel)
{
    rtk_vec3 wo = direction(theta, 0.0), wi = direction(theta, PI);
    rtk_rgb f = rtk_bsdf_eval(b, wo, wi);
    double fc = channel == 0 ? f.r : channel == 1 ? f.g : f.b;
    double alpha = b->lobe[0].alpha, c = cos(theta);
    return fc * 4.0 * c * c * PI * alpha * alpha * (1.0 + 2.0 * ref_lambda(alpha, wo));
}

/* Unpolarised Fresnel reflectance of the complex index eta + i k, from
 * the complex amplitudes. */
static double ref_fresnel_conductor(double theta, double eta, double k)
{
    double complex n = eta + k * I, n2 = n * n;
    double c = cos(theta), s2 = sin(theta) * sin(theta);
    double complex root = csqrt(n2 - s2);
    double complex rs = (c - root) / (c + root), rp = (n2 * c - root) / (n2 * c + root);
    return 0.5 * (creal(rs * conj(rs)) + creal(rp * conj(rp)));
}

static void test_fresnel(void)
{
    const float eta[3] = {0.143f, 0.374f, 1.442f}, k[3] = {3.983f, 2.385f, 1.603f};
    const float f0[3] = {0.9f, 0.6f, 0.04f};
    rtk_bsdf cond =
        rtk_bsdf_of(rtk_lobe_ggx_conductor(rtk_rgb_make(eta[0], eta[1], eta[2]), rtk_rgb_make(k[0], k[1], k[2]), 0.3f));
    rtk_bsdf dielectric = rtk_bsdf_of(rtk_lobe_ggx_conductor(rtk_rgb_make(1.5f, 1.5f, 1.5f), rtk_rgb_make(0, 0, 0), 0.3f));
    rtk_bsdf sch = rtk_bsdf_of(rtk_lobe_ggx_schlick(rtk_rgb_make(f0[0], f0[1], f0[2]), 0.3f));
    double worst_c = 0.0, worst_s = 0.0;
    const double thetas[] = {0.0, 30.0, 60.0, 80.0, 89.0};
    for (int t = 0; t < 5; t++) {
        double th = thetas[t] * PI / 180.0;
        for (int c = 0; c < 3; c++) {
            worst_c = fmax(worst_c, rel_diff(fresnel_of(&cond, th, c), ref_fresnel_conductor(th, eta[c], k[c])));
            worst_c = fmax(worst_c, rel_diff(fresnel_of(&dielectric, th, c), ref_fresnel_conductor(th, 1.5, 0.0)));
            worst_s = fmax(worst_s, rel_diff(fresnel_of(&sch, th, c), f0[c] + (1.0 - f0[c]) * pow(1.0 - cos(th), 5.0)));
        }
    }
    check(worst_c < 1e-4, "GGX exact conductor Fresnel (gold, and eta 1.5 k 0) equals the complex amplitudes' "
                          "at 0-89 degrees (worst relative %.1e)", worst_c);
    check(worst_s < 1e-4, "GGX Schlick Fresnel at 0-89 degrees (worst relative %.1e)", worst_s);
}

/* alpha = 0 is clamped to RTK_GGX_ALPHA_MIN: everything stays finite and
 * the weights f cos / pdf = F G2 / G1 stay <= 1. */
static void test_smooth_limit(void)
{
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_ggx_schlick(rtk_rgb_make(1, 1, 1), 0.0f));
    long bad = 0, n = 0;
    for (int e = 0; e < NELEV; e++) {
        rtk_vec3 wo = wo_at(elevations[e]);
        rtk_vec3 mirror = rtk_vec3_make(-wo.x, -wo.y, wo.z);
        rtk_rgb fm = rtk_bsdf_eval(&b, wo, mirror);
        bad += !(is_finite_rgb(fm) && fm.g > 0.0f && isfinite(rtk_bsdf_pdf(&b, wo, mirror)));
        for (int k = 0; k < 10000; k++, n++) {
            rtk_bsdf_sample_out out;
            if (!rtk_bsdf_sample(&b, wo, uniform(), vec2(uniform(), uniform()), &out))
                continue;
            double w = out.f.g * out.wi.z / out.pdf;
            bad += !(is_finite_rgb(out.f) && isfinite(out.pdf) && out.pdf > 0.0f && w <= 1.0 + 1e-3);
        }
    }
    check(bad == 0, "GGX at alpha 0 (clamped to %g): f, pdf finite and f cos / pdf <= 1 over %ld samples at "
                    "0-89 degrees (%ld not)", (double)RTK_GGX_ALPHA_MIN, n, bad);
}

/* Unpolarised Fresnel reflectance from the s- and p-polarised amplitudes
 * of light arriving at angle theta_i in medium n1 onto medium n2; 1 under
 * total internal reflection. Snell's angle through asin, unlike the kernel. */
static double ref_fresnel_dielectric(double theta_i, double n1, double n2)
{
    double st = n1 / n2 * sin(theta_i);
    if (st >= 1.0)
        return 1.0;
    double theta_t = asin(st), ci = cos(theta_i), ct = cos(theta_t);
    double rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
    double rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* Samples per dielectric case for the reflection fraction. */
#define NDIEL 200000L

/* The smooth dielectric of relative index ior with wo at angle theta_deg
 * from the normal on the outside (+z) or the inside (-z). */
static void dielectric_case(float ior, double theta_deg, int inside)
{
    char label[128];
    snprintf(label, sizeof label, "dielectric ior=%.4g theta_o=%g from %s", ior, theta_deg,
             inside ? "inside" : "outside");
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_dielectric(ior, rtk_rgb_make(1, 1, 1)));
    double th = theta_deg * PI / 180.0;
    rtk_vec3 wo = direction(th, PHI_O);
    if (inside)
        wo.z = -wo.z;
    /* n1: the index on wo's side, n2: across; the angle from the float wo. */
    double n1 = inside ? ior : 1.0, n2 = inside ? 1.0 : ior;
    double thf = acos(fabs((double)wo.z));
    double fr = ref_fresnel_dielectric(thf, n1, n2);
    double st = n1 / n2 * sin(thf);
    int tir = st >= 1.0;
    /* Snell in double: the tangential part scales by n1 / n2 and flips, z crosses over. */
    double ct = tir ? 0.0 : sqrt(1.0 - st * st);
    double refl[3] = {-(double)wo.x, -(double)wo.y, wo.z};
    double refr[3] = {-(double)wo.x * n1 / n2, -(double)wo.y * n1 / n2, inside ? ct : -ct};

    long reflected = 0, bad_dir = 0, bad_weight = 0, bad_flags = 0, failed_n = 0;
    double sum_w = 0.0, worst_dir = 0.0, worst_pdf = 0.0;
    for (long k = 0; k < NDIEL; k++) {
        rtk_bsdf_sample_out out;
        if (!rtk_bsdf_sample(&b, wo, uniform(), vec2(uniform(), uniform()), &out)) {
            failed_n++;
            continue;
        }
        int is_refl = out.flags == (RTK_BSDF_REFLECTION | RTK_BSDF_DELTA);
        int is_refr = out.flags == (RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA);
        bad_flags += !(is_refl || is_refr);
        reflected += is_refl;
        const double *want = is_refl ? refl : refr;
        double d = fmax(fabs(out.wi.x - want[0]), fmax(fabs(out.wi.y - want[1]), fabs(out.wi.z - want[2])));
        worst_dir = fmax(worst_dir, isfinite(d) ? d : INFINITY);
        bad_dir += !(d <= 1e-5);
        /* The discrete probability of the event: F or 1 - F. */
        worst_pdf = fmax(worst_pdf, fabs(out.pdf - (is_refl ? fr : 1.0 - fr)));
        double w = out.f.g * fabs(out.wi.z) / out.pdf;
        bad_weight += !(out.pdf > 0.0f && is_finite_rgb(out.f) && out.f.r == out.f.g && out.f.g == out.f.b &&
                        fabs(w - 1.0) <= 1e-5);
        sum_w += w;
    }
    check(failed_n == 0 && bad_flags == 0 && bad_dir == 0,
          "%s: every sample is the exact mirror or Snell refraction (worst component %.1e, %ld of %ld off by "
          "> 1e-5), flagged delta + reflection or transmission (%ld not), %ld failed",
          label, worst_dir, bad_dir, NDIEL, bad_flags, failed_n);
    double frac = (double)reflected / (double)NDIEL;
    double se = sqrt(fr * (1.0 - fr) / (double)NDIEL);
    if (tir)
        check(reflected == NDIEL && bad_weight == 0 && worst_pdf == 0.0,
              "%s: beyond the critical angle (%.2f deg) all %ld samples reflect with pdf 1 and weight 1 (%ld "
              "reflect, %ld weights off)",
              label, asin(n2 / n1) * 180.0 / PI, NDIEL, reflected, bad_weight);
    else
        check(fabs(frac - fr) <= 5.0 * se, "%s: reflected fraction %.5f of N=%ld, Fresnel %.5f (5 se = %.1e)", label,
              frac, NDIEL, fr, 5.0 * se);
    double mean = sum_w / (double)(NDIEL - failed_n);
    check(fabs(mean - 1.0) <= 1e-3 && bad_weight == 0 && worst_pdf <= 1e-4 * fmax(fr, 1e-2),
          "%s: white furnace mean of f |cos| / pdf = %.7f (1 within 1e-3, each sample 1 within 1e-5: %ld not); "
          "pdf = F or 1 - F (worst %.1e)",
          label, mean, bad_weight, worst_pdf);
}

/* The dielectric over indices, sides and angles; delta, so eval() and
 * pdf() are 0 even at the exact mirror and refracted directions. */
static void test_dielectric(void)
{
    const float iors[] = {1.5f, 1.33f, 1.0f / 1.5f};
    const double thetas[] = {0.0, 30.0, 45.0, 60.0, 80.0, 89.0};
    for (int i = 0; i < 3; i++)
        for (int side = 0; side < 2; side++)
            for (int t = 0; t < 6; t++)
                dielectric_case(iors[i], thetas[t], side);

    /* The kernel's F (the reflection pdf at u.x = 0, the transmission pdf
     * near u.x = 1) against the amplitudes and the complex-index formula. */
    double worst = 0.0, worst_c = 0.0;
    int zero = 1;
    for (int i = 0; i < 3; i++)
        for (int side = 0; side < 2; side++)
            for (int t = 0; t <= 90; t++) {
                rtk_bsdf b = rtk_bsdf_of(rtk_lobe_dielectric(iors[i], rtk_rgb_make(1, 1, 1)));
                rtk_vec3 wo = direction(t * PI / 180.0, PHI_O);
                if (t == 90)
                    wo = direction(89.9 * PI / 180.0, PHI_O);
                if (side)
                    wo.z = -wo.z;
                double thf = acos(fabs((double)wo.z));
                double n1 = side ? iors[i] : 1.0, n2 = side ? 1.0 : iors[i];
                double fr = ref_fresnel_dielectric(thf, n1, n2);
                rtk_bsdf_sample_out r, tr;
                memset(&r, 0, sizeof r);
                memset(&tr, 0, sizeof tr);
                int ok_r = rtk_bsdf_sample(&b, wo, 0.0f, vec2(0.5f, 0.5f), &r);
                int ok_t = rtk_bsdf_sample(&b, wo, 1.0f - 0x1p-24f, vec2(0.5f, 0.5f), &tr);
                double fk = ok_r ? r.pdf : -1.0;
                double tk = ok_t ? (tr.flags & RTK_BSDF_TRANSMISSION ? 1.0 - tr.pdf : tr.pdf) : -1.0;
                worst = fmax(worst, fmax(rel_diff(fk, fr), fabs(tk - fr)));
                worst_c = fmax(worst_c, rel_diff(fr, ref_fresnel_conductor(thf, n2 / n1, 0.0)));
                rtk_rgb f1 = rtk_bsdf_eval(&b, wo, r.wi), f2 = rtk_bsdf_eval(&b, wo, tr.wi);
                zero &= f1.r == 0 && f1.g == 0 && f1.b == 0 && f2.r == 0 && f2.g == 0 && f2.b == 0;
                zero &= rtk_bsdf_pdf(&b, wo, r.wi) == 0.0f && rtk_bsdf_pdf(&b, wo, tr.wi) == 0.0f;
            }
    check(worst < 1e-4, "dielectric Fresnel (ior 1.5, 1.33, 1/1.5, both sides, 0-89.9 deg) equals the s- and "
                        "p-amplitude formula in double (worst relative %.1e)", worst);
    check(worst_c < 1e-9, "the test's amplitude formula equals the complex-index one at k = 0 (worst relative %.1e)",
          worst_c);
    check(zero, "dielectric: eval() and pdf() are 0 at the sampled mirror and refracted directions (delta lobe)");

    rtk_bsdf glass = rtk_bsdf_of(rtk_lobe_dielectric(1.5f, rtk_rgb_make(1, 1, 1)));
    rtk_bsdf_sample_out out;
    int rejects = rtk_bsdf_sample(&glass, rtk_vec3_make(1.0f, 0.0f, 0.0f), 0.5f, vec2(0.5f, 0.5f), &out) == 0;
    const float bad_ior[] = {0.0f, -1.5f, NAN, INFINITY};
    for (int i = 0; i < 4; i++) {
        rtk_bsdf b = rtk_bsdf_of(rtk_lobe_dielectric(bad_ior[i], rtk_rgb_make(1, 1, 1)));
        rejects &= rtk_bsdf_sample(&b, wo_at(30.0f), 0.5f, vec2(0.5f, 0.5f), &out) == 0;
    }
    check(rejects && rtk_bsdf_flags(&glass) == (RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA),
          "dielectric: sample() fails for wo in the surface and for ior 0, -1.5, NaN, inf; flags are reflection + "
          "transmission + delta");
}

/* Schlick's Fresnel for a scalar f0: x^5 by products (pow() dominated the
 * quadratures' time). */
static double ref_schlick(double f0, double cos_theta)
{
    double m = 1.0 - cos_theta, m2 = m * m;
    return f0 + (1.0 - f0) * m2 * m2 * m;
}

/* Plastic of albedo 1: p = {alpha, f0}. The coat: Schlick's F at the half
 * vector times GGX; the base: (1 - F(wo.z)) (1 - F(wi.z)) / pi. */
static double ref_plastic(const double *p, rtk_vec3 wo, rtk_vec3 wi)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return 0.0;
    double alpha = p[0], f0 = p[1];
    double h[3] = {(double)wo.x + wi.x, (double)wo.y + wi.y, (double)wo.z + wi.z};
    double len = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    double c = (wo.x * h[0] + wo.y * h[1] + wo.z * h[2]) / len;
    double fo = ref_schlick(f0, wo.z), fi = ref_schlick(f0, wi.z);
    double base = (1.0 - fo) * (1.0 - fi) / PI;
    return ref_schlick(f0, c) * ref_ggx(alpha, wo, wi) + base;
}

/* Rough dielectric, white tint: p = {alpha, ior}; wo and wi on either side
 * (index 1 above, ior below). Reflection: F D G2 / (4 |wo.z| |wi.z|).
 * Transmission: Walter et al. 2007 eq. 21 with h_t = -(n_i wi + n_o wo)
 * and F at wi, times (n_i / n_o)^2 (the service leaves out the radiance
 * scale). */
static double ref_rough_dielectric(const double *p, rtk_vec3 wo, rtk_vec3 wi)
{
    if (wo.z == 0.0f || wi.z == 0.0f)
        return 0.0;
    double alpha = p[0], ior = p[1];
    double n_o = wo.z > 0.0f ? 1.0 : ior, n_i = wi.z > 0.0f ? 1.0 : ior, side = wo.z > 0.0f ? 1.0 : -1.0;
    double o[3] = {wo.x, wo.y, wo.z}, i[3] = {wi.x, wi.y, wi.z}, h[3];
    double g2 = 1.0 / (1.0 + ref_lambda(alpha, wo) + ref_lambda(alpha, wi));
    int reflect = (wo.z > 0.0f) == (wi.z > 0.0f);
    for (int k = 0; k < 3; k++)
        h[k] = reflect ? o[k] + i[k] : -(n_i * i[k] + n_o * o[k]);
    double len = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    double turn = h[2] * side < 0.0 ? -1.0 : 1.0;
    for (int k = 0; k < 3; k++)
        h[k] *= turn / len;
    double oh = o[0] * h[0] + o[1] * h[1] + o[2] * h[2], ih = i[0] * h[0] + i[1] * h[1] + i[2] * h[2];
    double d = ref_ggx_d(alpha, h);
    if (reflect) {
        double fr = ref_fresnel_dielectric(acos(fmin(oh, 1.0)), n_o, wo.z > 0.0f ? ior : 1.0);
        return oh > 0.0 ? fr * d * g2 / (4.0 * fabs(o[2]) * fabs(i[2])) : 0.0;
    }
    if (!(oh > 0.0 && ih < 0.0))
        return 0.0;
    double fr = ref_fresnel_dielectric(acos(fmin(-ih, 1.0)), n_i, n_o);
    double denom = n_i * ih + n_o * oh;
    double walter = fabs(ih) * fabs(oh) / (fabs(i[2]) * fabs(o[2])) * n_o * n_o * (1.0 - fr) * g2 * d / (denom * denom);
    return walter * (n_i / n_o) * (n_i / n_o);
}

/* A grid of directions over the sphere: grid_dir's and their mirror images below. */
static rtk_vec3 sphere_dir(int i)
{
    rtk_vec3 d = grid_dir(i % NGRID);
    if (i >= NGRID)
        d.z = -d.z;
    return d;
}

/* The rough dielectric of index ior (and the same tinted): eval() is the
 * test's closed form, reciprocal as f(wo, wi) / n_i^2 = f(wi, wo) / n_o^2,
 * the tint scales transmission only; 0 with wo or wi in the surface. */
static void test_rough_dielectric_pointwise(float ior, float alpha)
{
    char label[96];
    snprintf(label, sizeof label, "rough dielectric ior=%.4g alpha=%g", ior, alpha);
    rtk_rgb tint = rtk_rgb_make(1.0f, 0.6f, 0.3f);
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_rough_dielectric(ior, alpha, rtk_rgb_make(1, 1, 1)));
    rtk_bsdf tinted = rtk_bsdf_of(rtk_lobe_rough_dielectric(ior, alpha, tint));
    double param[2] = {alpha, ior};
    double worst_ref = 0.0, worst_recip = 0.0, worst_tint = 0.0;
    int nonzero_t = 0, nonzero_r = 0, zero_ok = 1;
    for (int i = 0; i < 2 * NGRID; i++)
        for (int j = 0; j < 2 * NGRID; j++) {
            rtk_vec3 wo = sphere_dir(i), wi = sphere_dir(j);
            rtk_rgb f = rtk_bsdf_eval(&b, wo, wi), g = rtk_bsdf_eval(&b, wi, wo), ft = rtk_bsdf_eval(&tinted, wo, wi);
            double ref = ref_rough_dielectric(param, wo, wi);
            /* Values under 1e-6 of the lobe's scale are Fresnel's and Smith's cut-offs, compared absolutely. */
            worst_ref = fmax(worst_ref, fabs(f.g - ref) / fmax(fabs(ref), 1e-6));
            double n_o = wo.z > 0.0f ? 1.0 : ior, n_i = wi.z > 0.0f ? 1.0 : ior;
            double a = f.g / (n_i * n_i), c = g.g / (n_o * n_o);
            worst_recip = fmax(worst_recip, fabs(a - c) / fmax(fmax(fabs(a), fabs(c)), 1e-6));
            int transmits = (wo.z > 0.0f) != (wi.z > 0.0f);
            nonzero_t += transmits && f.g > 0.0f;
            nonzero_r += !transmits && f.g > 0.0f;
            rtk_rgb want = transmits ? rtk_rgb_mul(tint, f) : f;
            worst_tint = fmax(worst_tint, fmax(rel_diff(ft.r, want.r), fmax(rel_diff(ft.g, want.g), rel_diff(ft.b, want.b))));
            rtk_vec3 flat = rtk_vec3_normalize(rtk_vec3_make(wi.x, wi.y, 0.0f));
            rtk_rgb z1 = rtk_bsdf_eval(&b, wo, flat), z2 = rtk_bsdf_eval(&b, flat, wo);
            zero_ok &= z1.g == 0.0f && z2.g == 0.0f && rtk_bsdf_pdf(&b, wo, flat) == 0.0f &&
                       rtk_bsdf_pdf(&b, flat, wo) == 0.0f;
        }
    check(worst_ref < 1e-4 && nonzero_t > 0 && nonzero_r > 0,
          "%s: eval() is Walter et al.'s closed form written in the test over %dx%d directions on the sphere "
          "(worst relative %.1e; %d reflecting and %d transmitting pairs > 0)",
          label, 2 * NGRID, 2 * NGRID, worst_ref, nonzero_r, nonzero_t);
    check(worst_recip < 1e-4, "%s: reciprocity f(wo, wi) / n_i^2 = f(wi, wo) / n_o^2 (reflection: f(wo, wi) = "
          "f(wi, wo)) over %dx%d directions (worst relative %.1e)", label, 2 * NGRID, 2 * NGRID, worst_recip);
    check(worst_tint < 1e-6, "%s: tint (1, 0.6, 0.3) scales transmission only, reflection stays untinted "
          "(worst relative %.1e)", label, worst_tint);
    check(zero_ok, "%s: f = 0 and pdf = 0 with wo or wi in the surface", label);
}

/* Rec. 709 luminance, negative as 0, and the header's nominal albedos, in double. */
static double test_luminance(rtk_rgb c)
{
    double y = 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
    return y > 0.0 ? y : 0.0;
}

static double test_nominal(const rtk_lobe *l)
{
    switch (l->type) {
    case RTK_LOBE_LAMBERT:
    case RTK_LOBE_OREN_NAYAR:
        return test_luminance(l->albedo);
    case RTK_LOBE_GGX:
        if (l->fresnel == RTK_FRESNEL_CONDUCTOR)
            return 1.0;
        return test_luminance(rtk_rgb_make(l->f0.r + (1.0f - l->f0.r) / 21.0f, l->f0.g + (1.0f - l->f0.g) / 21.0f,
                                           l->f0.b + (1.0f - l->f0.b) / 21.0f));
    case RTK_LOBE_PLASTIC: {
        double fa[3] = {l->f0.r + (1.0 - l->f0.r) / 21.0, l->f0.g + (1.0 - l->f0.g) / 21.0,
                        l->f0.b + (1.0 - l->f0.b) / 21.0};
        return 0.2126 * (fa[0] + (1.0 - fa[0]) * l->albedo.r) + 0.7152 * (fa[1] + (1.0 - fa[1]) * l->albedo.g) +
               0.0722 * (fa[2] + (1.0 - fa[2]) * l->albedo.b);
    }
    default:
        return 1.0;
    }
}

/* A mixture: eval() is the weighted sum of its lobes' evals, pdf() the sum
 * of p_i pdf_i with p_i from the header's rule computed here, over the
 * sphere's grid; flags are the union. */
static void test_mixture_pointwise(const char *label, const rtk_bsdf *b)
{
    double s[RTK_BSDF_MAX_LOBES], total = 0.0;
    unsigned flags = 0;
    for (uint32_t i = 0; i < b->count; i++) {
        s[i] = test_luminance(b->weight[i]) * test_nominal(&b->lobe[i]);
        total += s[i];
        rtk_bsdf one = rtk_bsdf_of(b->lobe[i]);
        flags |= rtk_bsdf_flags(&one);
    }
    double worst_f = 0.0, worst_pdf = 0.0;
    int nonzero = 0;
    for (int i = 0; i < 2 * NGRID; i++)
        for (int j = 0; j < 2 * NGRID; j++) {
            rtk_vec3 wo = sphere_dir(i), wi = sphere_dir(j);
            double f[3] = {0, 0, 0}, pdf = 0.0;
            for (uint32_t k = 0; k < b->count; k++) {
                rtk_bsdf one = rtk_bsdf_of(b->lobe[k]);
                rtk_rgb fk = rtk_bsdf_eval(&one, wo, wi);
                f[0] += b->weight[k].r * fk.r, f[1] += b->weight[k].g * fk.g, f[2] += b->weight[k].b * fk.b;
                pdf += s[k] / total * rtk_bsdf_pdf(&one, wo, wi);
            }
            rtk_rgb fb = rtk_bsdf_eval(b, wo, wi);
            worst_f = fmax(worst_f, fmax(rel_diff(fb.r, f[0]), fmax(rel_diff(fb.g, f[1]), rel_diff(fb.b, f[2]))));
            worst_pdf = fmax(worst_pdf, rel_diff(rtk_bsdf_pdf(b, wo, wi), pdf));
            nonzero += pdf > 0.0;
        }
    check(worst_f < 1e-5 && worst_pdf < 1e-5 && nonzero > 0 && rtk_bsdf_flags(b) == flags,
          "%s: eval() = sum of weight_i f_i, pdf() = sum of p_i pdf_i with p_i ~ luminance(weight_i) x nominal "
          "albedo, over %dx%d directions on the sphere (worst relative %.1e, %.1e; %d pairs with pdf > 0); flags "
          "are the union",
          label, 2 * NGRID, 2 * NGRID, worst_f, worst_pdf, nonzero);
}

/* Lambert and a smooth dielectric, half each: a delta lobe in a mixture.
 * Its samples return weight_i f_i and p_i x the event's probability, the
 * Lambert samples eval() and pdf() (the dielectric adds nothing there);
 * white, so every path weight is 1. */
static void test_delta_mixture(void)
{
    rtk_rgb half = rtk_rgb_make(0.5f, 0.5f, 0.5f), white = rtk_rgb_make(1, 1, 1);
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_lambert(white));
    b.weight[0] = half;
    rtk_bsdf_add(&b, half, rtk_lobe_dielectric(1.5f, white));
    rtk_vec3 wo = wo_at(30.0f);
    double fr = ref_fresnel_dielectric(acos((double)wo.z), 1.0, 1.5);
    long delta = 0, bad = 0;
    double worst_w = 0.0;
    for (long k = 0; k < NDIEL; k++) {
        rtk_bsdf_sample_out out;
        if (!rtk_bsdf_sample(&b, wo, uniform(), vec2(uniform(), uniform()), &out)) {
            bad++;
            continue;
        }
        double w = out.f.g * fabs(out.wi.z) / out.pdf;
        worst_w = fmax(worst_w, fabs(w - 1.0));
        if (out.flags & RTK_BSDF_DELTA) {
            delta++;
            double event = out.flags & RTK_BSDF_REFLECTION ? fr : 1.0 - fr;
            bad += !(fabs(out.pdf - 0.5 * event) <= 1e-5 && fabs(out.f.g * fabs(out.wi.z) - 0.5 * event) <= 1e-5);
        } else {
            bad += !(rel_diff(out.pdf, rtk_bsdf_pdf(&b, wo, out.wi)) <= 1e-6 &&
                     rel_diff(out.f.g, rtk_bsdf_eval(&b, wo, out.wi).g) <= 1e-6 &&
                     rel_diff(out.f.g, 0.5 / PI) <= 1e-6 && rel_diff(out.pdf, 0.5 * out.wi.z / PI) <= 1e-5);
        }
    }
    double frac = (double)delta / (double)NDIEL, se = sqrt(0.25 / (double)NDIEL);
    rtk_vec3 mirror = rtk_vec3_make(-wo.x, -wo.y, wo.z);
    int lambert_only = rel_diff(rtk_bsdf_eval(&b, wo, mirror).g, 0.5 / PI) <= 1e-6 &&
                       rel_diff(rtk_bsdf_pdf(&b, wo, mirror), 0.5 * mirror.z / PI) <= 1e-6;
    check(fabs(frac - 0.5) <= 5.0 * se && bad == 0 && worst_w <= 1e-5 && lambert_only,
          "0.5 lambert + 0.5 smooth dielectric: the delta lobe is picked in %.4f of N=%ld (0.5, 5 se = %.1e); its "
          "samples' f |cos| = 0.5 x (F or 1 - F), pdf = 0.5 x (F or 1 - F), the others' f and pdf are eval() and "
          "pdf() = Lambert's halves (%ld not); every path weight 1 (worst %.1e); eval() and pdf() at the mirror "
          "direction are Lambert's alone",
          frac, NDIEL, 5.0 * se, bad, worst_w);
}

/* A zero-initialised BSDF is black; rtk_bsdf_add refuses black weights and
 * a fifth lobe. */
static void test_black(void)
{
    rtk_bsdf zero;
    memset(&zero, 0, sizeof zero);
    rtk_vec3 wo = wo_at(30.0f), wi = direction(0.5, 2.0);
    rtk_bsdf_sample_out out;
    rtk_rgb f = rtk_bsdf_eval(&zero, wo, wi);
    int empty_ok = f.r == 0.0f && f.g == 0.0f && f.b == 0.0f && rtk_bsdf_pdf(&zero, wo, wi) == 0.0f &&
                   rtk_bsdf_flags(&zero) == 0 && rtk_bsdf_sample(&zero, wo, 0.5f, vec2(0.5f, 0.5f), &out) == 0;
    check(empty_ok, "a zero-initialised rtk_bsdf (count 0): eval 0, pdf 0, flags 0, sample fails");

    rtk_rgb white = rtk_rgb_make(1, 1, 1);
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_lambert(white));
    int black = rtk_bsdf_add(&b, rtk_rgb_make(0, 0, 0), rtk_lobe_lambert(white));
    int negative = rtk_bsdf_add(&b, rtk_rgb_make(-1, 0, -0.5f), rtk_lobe_lambert(white));
    int added = 0;
    for (int k = 0; k < 3; k++)
        added += rtk_bsdf_add(&b, rtk_rgb_make(0, 0.1f, 0), rtk_lobe_ggx_schlick(white, 0.3f));
    int fifth = rtk_bsdf_add(&b, white, rtk_lobe_lambert(white));
    check(black == 0 && negative == 0 && added == 3 && fifth == 0 && b.count == RTK_BSDF_MAX_LOBES,
          "rtk_bsdf_add: a black or negative weight adds nothing (%d, %d), three lobes join (%d), a fifth is refused "
          "(%d), count %u",
          black, negative, added, fifth, b.count);
}

/* No NaN or infinity out of any function for wo and wi at z = 0, +-1,
 * exactly at the critical angle from either side, grazing, and u at 0
 * and just under 1. */
static void test_nan_safety(void)
{
    rtk_rgb white = rtk_rgb_make(1, 1, 1), tint = rtk_rgb_make(1.0f, 0.6f, 0.3f);
    float sc = 1.0f / 1.5f, cc = sqrtf(1.0f - sc * sc);
    const rtk_vec3 dirs[] = {
        {0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0}, {sc, 0, -cc}, {-sc, 0, cc}, {sc, 0, cc}, {-sc, 0, -cc},
        {0.99999f, 0, 0.0044721f}, {0.6f, 0, -0.8f}, {0.48f, 0.64f, 0.6f},
    };
    const int ndirs = (int)(sizeof dirs / sizeof dirs[0]);
    rtk_bsdf bs[12];
    const char *names = "lambert, oren-nayar, ggx, gold, dielectric, rough dielectric 1.5 and 1/1.5 (tinted), "
                        "rough at alpha 0, ior 1.0005, plastic, plastic f0 = 1, mixture";
    bs[0] = rtk_bsdf_of(rtk_lobe_lambert(white));
    bs[1] = rtk_bsdf_of(rtk_lobe_oren_nayar(white, 1.0f));
    bs[2] = rtk_bsdf_of(rtk_lobe_ggx_schlick(white, 0.2f));
    bs[3] = rtk_bsdf_of(rtk_lobe_ggx_conductor(rtk_rgb_make(0.143f, 0.374f, 1.442f), rtk_rgb_make(3.983f, 2.385f, 1.603f), 0.0f));
    bs[4] = rtk_bsdf_of(rtk_lobe_dielectric(1.5f, tint));
    bs[5] = rtk_bsdf_of(rtk_lobe_rough_dielectric(1.5f, 0.3f, tint));
    bs[6] = rtk_bsdf_of(rtk_lobe_rough_dielectric(1.0f / 1.5f, 0.3f, tint));
    bs[7] = rtk_bsdf_of(rtk_lobe_rough_dielectric(1.5f, 0.0f, white));
    bs[8] = rtk_bsdf_of(rtk_lobe_rough_dielectric(1.0005f, 0.3f, white));
    bs[9] = rtk_bsdf_of(rtk_lobe_plastic(white, rtk_rgb_make(0.04f, 0.04f, 0.04f), 0.2f));
    bs[10] = rtk_bsdf_of(rtk_lobe_plastic(white, white, 0.0f));
    bs[11] = rtk_bsdf_of(rtk_lobe_plastic(white, rtk_rgb_make(0.0f, 0.0f, 0.0f), 0.5f));
    rtk_bsdf_add(&bs[11], white, rtk_lobe_dielectric(1.5f, white));
    rtk_bsdf_add(&bs[11], white, rtk_lobe_rough_dielectric(1.5f, 0.2f, white));
    const float us[] = {0.0f, 0.5f, 1.0f - 0x1p-24f};
    long calls = 0, bad = 0;
    for (int k = 0; k < 12; k++)
        for (int i = 0; i < ndirs; i++) {
            rtk_vec3 wo = dirs[i];
            for (int j = 0; j < ndirs; j++) {
                rtk_rgb f = rtk_bsdf_eval(&bs[k], wo, dirs[j]);
                float pdf = rtk_bsdf_pdf(&bs[k], wo, dirs[j]);
                bad += !(is_finite_rgb(f) && f.r >= 0.0f && f.g >= 0.0f && f.b >= 0.0f && isfinite(pdf) && pdf >= 0.0f);
                calls += 2;
            }
            for (int a = 0; a < 27; a++) {
                rtk_bsdf_sample_out out;
                calls++;
                if (!rtk_bsdf_sample(&bs[k], wo, us[a % 3], vec2(us[a / 3 % 3], us[a / 9]), &out))
                    continue;
                bad += !(is_finite_rgb(out.f) && out.f.r >= 0.0f && out.f.g >= 0.0f && out.f.b >= 0.0f &&
                         isfinite(out.pdf) && out.pdf > 0.0f && fabs(rtk_vec3_length(out.wi) - 1.0) <= 1e-5);
            }
        }
    check(bad == 0, "no NaN or infinity, f >= 0, pdf >= 0 (sample: > 0, unit wi) from %ld calls of eval, pdf and "
          "sample on %s with wo, wi at z = 0, +-1, the critical angle of 1.5 from either side, grazing, and u at 0, "
          "0.5, 1 - 2^-24 (%ld bad)", calls, names, bad);
}

/* A rough dielectric of index within 1e-3 of 1 is the smooth one: delta,
 * straight through with weight 1 (F ~ 6e-8). */
static void test_rough_index_one(void)
{
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_rough_dielectric(1.0005f, 0.3f, rtk_rgb_make(1, 1, 1)));
    rtk_vec3 wo = wo_at(30.0f);
    long bad = 0;
    for (int k = 0; k < 1000; k++) {
        rtk_bsdf_sample_out out;
        if (!rtk_bsdf_sample(&b, wo, uniform(), vec2(uniform(), uniform()), &out)) {
            bad++;
            continue;
        }
        double w = out.f.g * fabs(out.wi.z) / out.pdf;
        bad += !(out.flags == (RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA) && fabs(w - 1.0) <= 1e-5 &&
                 rtk_vec3_length(rtk_vec3_add(out.wi, wo)) <= 1e-3);
    }
    check(bad == 0 && rtk_bsdf_flags(&b) == (RTK_BSDF_REFLECTION | RTK_BSDF_TRANSMISSION | RTK_BSDF_DELTA),
          "rough dielectric at ior 1.0005: a delta lobe passing wo straight through (wi = -wo to 1e-3) with weight "
          "1 over 1000 samples (%ld not)", bad);
}

/* The smooth dielectric's tint colours the refracted light only. */
static void test_dielectric_tint(void)
{
    rtk_rgb tint = rtk_rgb_make(1.0f, 0.6f, 0.3f);
    rtk_bsdf b = rtk_bsdf_of(rtk_lobe_dielectric(1.5f, tint));
    rtk_vec3 wo = wo_at(30.0f);
    rtk_bsdf_sample_out r, t;
    int ok = rtk_bsdf_sample(&b, wo, 0.0f, vec2(0.5f, 0.5f), &r) && rtk_bsdf_sample(&b, wo, 1.0f - 0x1p-24f, vec2(0.5f, 0.5f), &t);
    double fr = ref_fresnel_dielectric(acos((double)wo.z), 1.0, 1.5);
    double lum = 0.2126 * 1.0 + 0.7152 * 0.6 + 0.0722 * 0.3, pr = fr / (fr + (1.0 - fr) * lum);
    ok = ok && (r.flags & RTK_BSDF_REFLECTION) && (t.flags & RTK_BSDF_TRANSMISSION);
    ok = ok && r.f.r == r.f.g && r.f.g == r.f.b && rel_diff(r.pdf, pr) <= 1e-5 && rel_diff(t.pdf, 1.0 - pr) <= 1e-5;
    ok = ok && rel_diff(t.f.g / t.f.r, 0.6) <= 1e-6 && rel_diff(t.f.b / t.f.r, 0.3) <= 1e-6 &&
         rel_diff(t.f.r * fabs(t.wi.z), 1.0 - fr) <= 1e-5;
    check(ok, "smooth dielectric tint (1, 0.6, 0.3): reflection grey, transmission scaled by the tint, reflected "
          "with probability F / (F + (1 - F) luminance(tint)) = %.4f", pr);
}

/* The rough dielectric over alpha, elevations and both sides, with the
 * single-scattering loss table against the quadrature; tinted at 0.2. */
static void test_rough_dielectric(void)
{
    const float ior = 1.5f;
    albedo table[2][NALPHA][NELEV];
    for (int a = 0; a < NALPHA; a++) {
        test_rough_dielectric_pointwise(ior, ggx_alphas[a]);
        test_rough_dielectric_pointwise(1.0f / ior, ggx_alphas[a]);
        char name[64];
        snprintf(name, sizeof name, "rough dielectric ior=1.5 alpha=%g", ggx_alphas[a]);
        rtk_bsdf b = rtk_bsdf_of(rtk_lobe_rough_dielectric(ior, ggx_alphas[a], rtk_rgb_make(1, 1, 1)));
        double param[2] = {ggx_alphas[a], ior};
        lobe_case c = {name, &b, 1, 0, 0, ref_rough_dielectric, param, ior};
        for (int side = 0; side < 2; side++)
            run_elevations(&c, side, table[side][a]);
    }
    for (int side = 0; side < 2; side++) {
        printf("rough dielectric ior 1.5, wo from %s: single-scattering loss 1 - E, reflection + transmission, "
               "sampled (quadrature)\n  alpha ", side ? "inside" : "outside");
        for (int e = 0; e < NELEV; e++)
            printf(" | theta_o=%-2g          ", elevations[e]);
        printf("\n");
        for (int a = 0; a < NALPHA; a++) {
            printf("  %-5g ", ggx_alphas[a]);
            for (int e = 0; e < NELEV; e++)
                printf(" | %.4f (%.4f)", 1.0 - table[side][a][e].sampled, 1.0 - table[side][a][e].reference);
            printf("\n");
        }
    }
    rtk_bsdf tinted = rtk_bsdf_of(rtk_lobe_rough_dielectric(ior, 0.2f, rtk_rgb_make(1.0f, 0.6f, 0.3f)));
    lobe_case c = {"rough dielectric ior=1.5 alpha=0.2 tint=(1,0.6,0.3)", &tinted, 1, 0, 0, NULL, NULL, ior};
    run_elevations(&c, 0, NULL);
}

/* Plastic over f0, alpha and elevations, with its albedo table. */
static void test_plastic(void)
{
    rtk_rgb white = rtk_rgb_make(1, 1, 1);
    albedo table[NF0][NALPHA][NELEV];
    for (int f = 0; f < NF0; f++)
        for (int a = 0; a < NALPHA; a++) {
            char name[64];
            float f0 = plastic_f0s[f];
            snprintf(name, sizeof name, "plastic f0=%g alpha=%g", f0, ggx_alphas[a]);
            rtk_bsdf b = rtk_bsdf_of(rtk_lobe_plastic(white, rtk_rgb_make(f0, f0, f0), ggx_alphas[a]));
            double param[2] = {ggx_alphas[a], f0};
            lobe_case c = {name, &b, 0, 0, 0, ref_plastic, param, 0.0f};
            test_pointwise(name, &b, ref_plastic, param);
            run_elevations(&c, 0, table[f][a]);
        }
    printf("plastic, albedo 1: white-furnace albedo E, sampled (quadrature)\n  f0    alpha ");
    for (int e = 0; e < NELEV; e++)
        printf(" | theta_o=%-2g          ", elevations[e]);
    printf("\n");
    for (int f = 0; f < NF0; f++)
        for (int a = 0; a < NALPHA; a++) {
            printf("  %-5g %-5g ", plastic_f0s[f], ggx_alphas[a]);
            for (int e = 0; e < NELEV; e++)
                printf(" | %.4f (%.4f)", table[f][a][e].sampled, table[f][a][e].reference);
            printf("\n");
        }
}

/* Mixtures of two and three lobes: pointwise sums, then chi-square and
 * the furnace like single lobes. */
static void test_mixtures(void)
{
    rtk_rgb white = rtk_rgb_make(1, 1, 1), f0 = rtk_rgb_make(0.04f, 0.04f, 0.04f);
    for (int a = 0; a < NALPHA; a++) {
        float alpha = ggx_alphas[a];
        char name[96];
        snprintf(name, sizeof name, "mixture 0.3 ggx + 0.7 plastic alpha=%g", alpha);
        rtk_bsdf m1 = rtk_bsdf_of(rtk_lobe_ggx_schlick(rtk_rgb_make(0.9f, 0.6f, 0.3f), alpha));
        m1.weight[0] = rtk_rgb_make(0.3f, 0.3f, 0.3f);
        rtk_bsdf_add(&m1, rtk_rgb_make(0.7f, 0.7f, 0.7f), rtk_lobe_plastic(rtk_rgb_make(0.8f, 0.5f, 0.2f), f0, alpha));
        lobe_case c1 = {name, &m1, 0, 0, 0, NULL, NULL, 0.0f};
        test_mixture_pointwise(name, &m1);
        test_lobe(&c1);

        snprintf(name, sizeof name, "mixture 0.5 plastic + 0.5 rough dielectric alpha=%g", alpha);
        rtk_bsdf m2 = rtk_bsdf_of(rtk_lobe_plastic(white, f0, alpha));
        m2.weight[0] = rtk_rgb_make(0.5f, 0.5f, 0.5f);
        rtk_bsdf_add(&m2, rtk_rgb_make(0.5f, 0.5f, 0.5f), rtk_lobe_rough_dielectric(1.5f, alpha, white));
        lobe_case c2 = {name, &m2, 1, 0, 0, NULL, NULL, 1.5f};
        test_mixture_pointwise(name, &m2);
        run_elevations(&c2, 0, NULL);
    }
    rtk_bsdf m3 = rtk_bsdf_of(rtk_lobe_lambert(white));
    m3.weight[0] = rtk_rgb_make(0.2f, 0.2f, 0.2f);
    rtk_bsdf_add(&m3, rtk_rgb_make(0.3f, 0.3f, 0.3f), rtk_lobe_ggx_schlick(white, 0.2f));
    rtk_bsdf_add(&m3, rtk_rgb_make(0.5f, 0.5f, 0.5f), rtk_lobe_rough_dielectric(1.5f, 0.2f, rtk_rgb_make(1.0f, 0.6f, 0.3f)));
    const char *name3 = "mixture 0.2 lambert + 0.3 ggx + 0.5 tinted rough dielectric alpha=0.2";
    lobe_case c3 = {name3, &m3, 1, 0, 0, NULL, NULL, 1.5f};
    test_mixture_pointwise(name3, &m3);
    run_elevations(&c3, 0, NULL);
    test_delta_mixture();
}

/* The frame, the p-value function, the smooth dielectric, the existing lobes and the edge cases. */
static void test_base(void)
{
    test_gamma_q();
    test_frame();
    test_fresnel();
    test_dielectric();

    test_dielectric_tint();
    test_black();
    test_nan_safety();
    test_rough_index_one();

    rtk_rgb white = rtk_rgb_make(1, 1, 1);
    rtk_bsdf lambert = rtk_bsdf_of(rtk_lobe_lambert(white));
    lobe_case lc = {"lambert", &lambert, 0, 1, 1, ref_lambert, NULL, 0.0f};
    test_lobe(&lc);

    for (int s = 0; s < NSIGMA; s++) {
        char name[64];
        snprintf(name, sizeof name, "oren-nayar sigma=%g", on_sigmas[s]);
        rtk_bsdf on = rtk_bsdf_of(rtk_lobe_oren_nayar(white, on_sigmas[s]));
        double sigma = on_sigmas[s];
        lobe_case c = {name, &on, 0, 1, 0, ref_oren_nayar_p, &sigma, 0.0f};
        test_lobe(&c);
    }

    for (int a = 0; a < NALPHA; a++) {
        char name[64];
        snprintf(name, sizeof name, "ggx alpha=%g", ggx_alphas[a]);
        rtk_bsdf ggx = rtk_bsdf_of(rtk_lobe_ggx_schlick(white, ggx_alphas[a]));
        double alpha = ggx_alphas[a];
        lobe_case c = {name, &ggx, 0, 0, 0, ref_ggx_p, &alpha, 0.0f};
        test_lobe(&c);

        /* Gold: the exact conductor Fresnel keeps the albedo under 1. */
        snprintf(name, sizeof name, "ggx gold alpha=%g", ggx_alphas[a]);
        rtk_bsdf gold = rtk_bsdf_of(rtk_lobe_ggx_conductor(rtk_rgb_make(0.143f, 0.374f, 1.442f),
                                                           rtk_rgb_make(3.983f, 2.385f, 1.603f), ggx_alphas[a]));
        test_pointwise(name, &gold, NULL, NULL);
        for (int e = 0; e < NELEV; e++) {
            char label[96];
            snprintf(label, sizeof label, "%s theta_o=%g", name, elevations[e]);
            furnace r = sample_pass(label, &gold, wo_at(elevations[e]), 100000, NULL, 0);
            int ok = 1;
            for (int c = 0; c < 3; c++)
                ok &= r.mean[c] <= 1.0 + 5.0 * r.se[c];
            check(ok, "%s: albedo (%.4f %.4f %.4f) <= 1 (+5 se)", label, r.mean[0], r.mean[1], r.mean[2]);
        }
    }
    test_smooth_limit();
}

/* Whether to run test group name: all without an argument, else the one named (base, rough, plastic, mixture). */
static int wanted(int argc, char **argv, const char *name)
{
    return argc < 2 || strcmp(argv[1], name) == 0;
}

int main(int argc, char **argv)
{
    static const char *const groups[] = {"base", "rough", "plastic", "mixture"};
    int known = argc < 2;
    for (int g = 0; g < 4 && !known; g++)
        known = strcmp(argv[1], groups[g]) == 0;
    if (!known || argc > 2) {
        fprintf(stderr, "usage: test_bsdf [base|rough|plastic|mixture] (no argument: all groups)\n");
        return 2;
    }
    rng_state = 0x5eed5eedull;
    sidak_threshold = 1.0 - pow(1.0 - ALPHA_FAMILY, 1.0 / NCHI2);
    printf("chi-square: %d tests of %ld samples each, %dx%d bins, family-wise alpha %g -> Sidak threshold %.4g\n",
           NCHI2, NSAMPLES, NCOS, NPHI, ALPHA_FAMILY, sidak_threshold);
    if (wanted(argc, argv, "base"))
        test_base();
    if (wanted(argc, argv, "rough"))
        test_rough_dielectric();
    if (wanted(argc, argv, "plastic"))
        test_plastic();
    if (wanted(argc, argv, "mixture"))
        test_mixtures();

    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
