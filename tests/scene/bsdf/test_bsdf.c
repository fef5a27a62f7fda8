/* The BSDF service (include/rtk/bsdf.h, kernel/scene/bsdf.c), lobe by lobe
 * over a grid of outgoing directions (0 to 89 degrees from the normal) and
 * roughness values:
 * - sampling matches the pdf: chi-square goodness of fit over bins in
 *   (cos theta, phi) plus one cell for failed samples, expected counts from
 *   the pdf integrated per bin, Sidak-corrected threshold;
 * - the pdf integrates to the probability that sample() succeeds (1 for the
 *   diffuse lobes), and sample() returns exactly eval() and pdf();
 * - eval() is the header's closed form, reciprocal, 0 below the surface;
 * - white furnace: directional albedo <= 1, = 1 for Lambert, and GGX's
 *   single-scattering loss equals a table integrated here from the closed
 *   form, not through sample().
 * The smooth dielectric (a delta lobe) over relative indices and incidence
 * from both sides, total internal reflection included: exact mirror and
 * Snell directions, the fraction of reflections against the Fresnel
 * equations written here from s- and p-amplitudes, path weight 1.
 * It also checks rtk_frame and the chi-square p-value function itself. */
#include <rtk/rtk.h>

#include <complex.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

#define PI 3.14159265358979323846

/* Chi-square bins: NCOS in cos theta over (0, 1], NPHI in phi over (-pi, pi]. */
#define NCOS 16
#define NPHI 32
#define NBINS (NCOS * NPHI)
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
/* Lambert, Oren-Nayar and GGX at every elevation. */
#define NCHI2 (NELEV * (1 + NSIGMA + NALPHA))

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

/* GGX f with F = 1. */
static double ref_ggx(double alpha, rtk_vec3 wo, rtk_vec3 wi)
{
    double h[3] = {(double)wo.x + wi.x, (double)wo.y + wi.y, (double)wo.z + wi.z};
    double len = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    double cz = h[2] / len, s2 = (h[0] * h[0] + h[1] * h[1]) / (len * len);
    double a2 = alpha * alpha;
    double d = a2 / (PI * (s2 + a2 * cz * cz) * (s2 + a2 * cz * cz));
    double g2 = 1.0 / (1.0 + ref_lambda(alpha, wo) + ref_lambda(alpha, wi));
    return d * g2 / (4.0 * wo.z * wi.z);
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
static void test_pointwise(const char *label, const rtk_bsdf *b, double (*ref)(double, rtk_vec3, rtk_vec3),
                           double param)
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

static double ref_lambert(double unused, rtk_vec3 wo, rtk_vec3 wi)
{
    (void)unused, (void)wo, (void)wi;
    return 1.0 / PI;
}

/* A function over directions to integrate over the hemisphere. */
typedef struct integrand {
    double (*fn)(const struct integrand *in, rtk_vec3 wi);
    const rtk_bsdf *b;
    rtk_vec3 wo;
    double alpha;
} integrand;

/* Integral of in over bin (i, j) by the midpoint rule in (theta, phi)
 * with sub x sub points (dw = sin theta dtheta dphi). */
static double bin_integral(const integrand *in, int i, int j, int sub)
{
    double th0 = acos((i + 1.0) / NCOS), th1 = acos((double)i / NCOS);
    double dth = (th1 - th0) / sub, dph = 2.0 * PI / NPHI / sub, ph0 = -PI + 2.0 * PI * j / NPHI;
    double sum = 0.0;
    for (int a = 0; a < sub; a++) {
        double th = th0 + (a + 0.5) * dth, st = sin(th), ct = cos(th);
        for (int c = 0; c < sub; c++) {
            double ph = ph0 + (c + 0.5) * dph;
            rtk_vec3 wi = rtk_vec3_make((float)(st * cos(ph)), (float)(st * sin(ph)), (float)ct);
            sum += in->fn(in, wi) * st;
        }
    }
    return sum * dth * dph;
}

/* Convergence of one bin's integral v: the change from doubling the
 * sub-samples is at most max(rel v, root sqrt(v), abs). */
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
    for (int i = 0; i < NCOS; i++)
        for (int j = 0; j < NPHI; j++) {
            int sub = SUB_MIN;
            double prev = bin_integral(in, i, j, sub), cur;
            for (;;) {
                sub *= 2;
                cur = bin_integral(in, i, j, sub);
                double change = fabs(cur - prev), v = fabs(cur);
                if (change <= fmax(tol.rel * v, fmax(tol.root * sqrt(v), tol.abs)))
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

static double pdf_integrand(const integrand *in, rtk_vec3 wi)
{
    return rtk_bsdf_pdf(in->b, in->wo, wi);
}

/* GGX's f cos with F = 1, from the test's closed form. */
static double ggx_albedo_integrand(const integrand *in, rtk_vec3 wi)
{
    return ref_ggx(in->alpha, in->wo, wi) * wi.z;
}

static int bin_of(rtk_vec3 wi)
{
    int i = (int)(wi.z * NCOS);
    double phi = atan2((double)wi.y, (double)wi.x);
    int j = (int)((phi + PI) / (2.0 * PI) * NPHI);
    i = i < 0 ? 0 : i >= NCOS ? NCOS - 1 : i;
    j = j < 0 ? 0 : j >= NPHI ? NPHI - 1 : j;
    return i * NPHI + j;
}

/* Chi-square test of observed (NBINS bins, then the failed samples) against
 * n times mass (the failure cell expects what mass leaves of 1). Cells
 * expecting fewer than 5 are pooled into one; a pool still under 5 joins
 * the smallest other cell. */
static void chi2_test(const char *label, const long *observed, const double *mass, long n)
{
    static double e[NBINS + 1];
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
    double chi2 = 0.0;
    int cells = 0;
    for (int k = 0; k <= NBINS; k++) {
        if (e[k] < 5.0)
            continue;
        double ek = e[k], ok = (double)observed[k];
        if (k == smallest && pool_e < 5.0)
            ek += pool_e, ok += pool_o;
        chi2 += (ok - ek) * (ok - ek) / ek;
        cells++;
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
          label, n, NCOS, NPHI, pooled, cells, chi2, dof, p, sidak_threshold, outside);
}

typedef struct furnace {
    double mean[3], se[3];
    double success; /* fraction of sample() calls that returned a direction */
} furnace;

/* n samples of b for wo: each agrees with eval() and pdf(), is a unit
 * direction above the surface with b's flags; fills hist (bin of each, then
 * the failures) when given and returns the mean of f cos / pdf (0 for a
 * failure) with its standard error. */
static furnace sample_pass(const char *label, const rtk_bsdf *b, rtk_vec3 wo, long n, long *hist)
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
                hist[NBINS]++;
            continue;
        }
        succeeded++;
        float pdf = rtk_bsdf_pdf(b, wo, out.wi);
        rtk_rgb f = rtk_bsdf_eval(b, wo, out.wi);
        if (rel_diff(pdf, out.pdf) > 1e-5 || rel_diff(f.r, out.f.r) > 1e-5 || rel_diff(f.g, out.f.g) > 1e-5 ||
            rel_diff(f.b, out.f.b) > 1e-5)
            mismatched++;
        if (!(out.pdf > 0.0f) || !isfinite(out.pdf) || !is_finite_rgb(out.f) || !(out.wi.z > 0.0f) ||
            fabs(rtk_vec3_length(out.wi) - 1.0) > 1e-5 || out.flags != flags)
            bad++;
        double w[3] = {out.f.r * out.wi.z / out.pdf, out.f.g * out.wi.z / out.pdf, out.f.b * out.wi.z / out.pdf};
        for (int c = 0; c < 3; c++)
            sum[c] += w[c], sum2[c] += w[c] * w[c];
        if (hist)
            hist[bin_of(out.wi)]++;
    }
    check(mismatched == 0 && bad == 0,
          "%s: %ld of %ld samples succeed, each a unit wi above the surface with finite f, pdf > 0 and the lobe's "
          "flags (%ld not), f and pdf those of eval() and pdf() (%ld not)",
          label, succeeded, n, bad, mismatched);
    furnace r;
    for (int c = 0; c < 3; c++) {
        r.mean[c] = sum[c] / (double)n;
        double var = sum2[c] / (double)n - r.mean[c] * r.mean[c];
        r.se[c] = sqrt(fmax(var, 0.0) / (double)(n - 1));
    }
    r.success = (double)succeeded / (double)n;
    return r;
}

enum lobe_kind { KIND_LAMBERT, KIND_OREN_NAYAR, KIND_GGX };

/* Chi-square, normalisation, sample() consistency and the white furnace
 * for b (white: albedo 1 or F = 1) at one elevation of wo. */
static void run_case(const char *lobe, const rtk_bsdf *b, float elevation, enum lobe_kind kind)
{
    char label[128];
    snprintf(label, sizeof label, "%s theta_o=%g", lobe, elevation);
    rtk_vec3 wo = wo_at(elevation);
    static double mass[NBINS];
    static long hist[NBINS + 1];
    /* Each bin's quadrature error under 0.05 of its count's Poisson noise
     * (n x change <= 0.05 sqrt(max(n x mass, 1))): it adds at most ~0.0025
     * to the bin's chi-square term. */
    integrand pdf = {pdf_integrand, b, wo, 0.0};
    quad_tol counts = {0.0, 0.05 / sqrt((double)NSAMPLES), 0.05 / (double)NSAMPLES};
    quad_result q = integrate_bins(&pdf, counts, mass);
    check(q.short_of == 0, "%s: pdf integrated per bin to well under the counts' noise (up to %dx%d sub-samples, "
          "%d bins short of it)", label, q.max_sub, q.max_sub, q.short_of);
    memset(hist, 0, sizeof hist);
    furnace r = sample_pass(label, b, wo, NSAMPLES, hist);
    chi2_test(label, hist, mass, NSAMPLES);

    /* The quadrature's own error estimate, plus 1e-5 for float rounding of the pdf values. */
    double qtol = q.err + 1e-5;
    if (kind == KIND_GGX) {
        double btol = 5.0 * sqrt(r.success * (1.0 - r.success) / (double)NSAMPLES);
        check(fabs(q.total - r.success) <= qtol + btol && q.total <= 1.0 + qtol,
              "%s: pdf integrates to %.6f over the hemisphere, the fraction of samples above it %.6f (tolerance "
              "%.1e quadrature + %.1e binomial)",
              label, q.total, r.success, qtol, btol);
    } else {
        check(fabs(q.total - 1.0) <= qtol, "%s: pdf integrates to %.6f over the hemisphere (tolerance %.1e)", label,
              q.total, qtol);
    }

    double worst = 0.0;
    for (int c = 0; c < 3; c++)
        worst = fmax(worst, r.mean[c] - 1.0 - 5.0 * r.se[c]);
    check(worst <= 0.0, "%s: white furnace albedo %.6f <= 1 (+5 se = %.1e)", label, r.mean[1], 5.0 * r.se[1]);
    if (kind == KIND_LAMBERT)
        check(fabs(r.mean[0] - 1.0) <= 1e-3 && fabs(r.mean[1] - 1.0) <= 1e-3 && fabs(r.mean[2] - 1.0) <= 1e-3,
              "%s: white furnace albedo = 1 within 1e-3 (%.7f)", label, r.mean[1]);
    if (kind == KIND_GGX) {
        /* The reference: f cos integrated by quadrature to 1e-5 per bin, never through sample(). */
        integrand fcos = {ggx_albedo_integrand, b, wo, b->lobe[0].alpha};
        quad_tol fine = {1e-5, 0.0, 1e-8};
        quad_result ref_q = integrate_bins(&fcos, fine, NULL);
        double ref = ref_q.total;
        /* 2e-5: float rounding of f and pdf in the kernel. */
        double tol = 5.0 * r.se[1] + ref_q.err + 2e-5;
        check(ref_q.short_of == 0, "%s: reference albedo converged (up to %dx%d sub-samples per bin, %d bins short)",
              label, ref_q.max_sub, ref_q.max_sub, ref_q.short_of);
        check(fabs(r.mean[1] - ref) <= tol,
              "%s: single-scattering loss 1 - E = %.5f (sampled %.5f +- %.1e), reference by quadrature %.5f "
              "(tolerance %.1e)",
              label, 1.0 - r.mean[1], r.mean[1], r.se[1], 1.0 - ref, tol);
    }
}

/* The pointwise checks, then run_case at every elevation. */
static void test_lobe(const char *name, const rtk_bsdf *b, double (*ref)(double, rtk_vec3, rtk_vec3), double param,
                      enum lobe_kind kind)
{
    test_pointwise(name, b, ref, param);
    for (int e = 0; e < NELEV; e++)
        run_case(name, b, elevations[e], kind);
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

int main(void)
{
    rng_state = 0x5eed5eedull;
    sidak_threshold = 1.0 - pow(1.0 - ALPHA_FAMILY, 1.0 / NCHI2);
    printf("chi-square: %d tests of %ld samples each, %dx%d bins, family-wise alpha %g -> Sidak threshold %.4g\n",
           NCHI2, NSAMPLES, NCOS, NPHI, ALPHA_FAMILY, sidak_threshold);
    test_gamma_q();
    test_frame();
    test_fresnel();
    test_dielectric();

    rtk_rgb white = rtk_rgb_make(1, 1, 1);
    rtk_bsdf lambert = rtk_bsdf_of(rtk_lobe_lambert(white));
    test_lobe("lambert", &lambert, ref_lambert, 0.0, KIND_LAMBERT);

    for (int s = 0; s < NSIGMA; s++) {
        char name[64];
        snprintf(name, sizeof name, "oren-nayar sigma=%g", on_sigmas[s]);
        rtk_bsdf on = rtk_bsdf_of(rtk_lobe_oren_nayar(white, on_sigmas[s]));
        test_lobe(name, &on, ref_oren_nayar, on_sigmas[s], KIND_OREN_NAYAR);
    }

    for (int a = 0; a < NALPHA; a++) {
        char name[64];
        snprintf(name, sizeof name, "ggx alpha=%g", ggx_alphas[a]);
        rtk_bsdf ggx = rtk_bsdf_of(rtk_lobe_ggx_schlick(white, ggx_alphas[a]));
        test_lobe(name, &ggx, ref_ggx, ggx_alphas[a], KIND_GGX);

        /* Gold: the exact conductor Fresnel keeps the albedo under 1. */
        snprintf(name, sizeof name, "ggx gold alpha=%g", ggx_alphas[a]);
        rtk_bsdf gold = rtk_bsdf_of(rtk_lobe_ggx_conductor(rtk_rgb_make(0.143f, 0.374f, 1.442f),
                                                           rtk_rgb_make(3.983f, 2.385f, 1.603f), ggx_alphas[a]));
        test_pointwise(name, &gold, NULL, 0.0);
        for (int e = 0; e < NELEV; e++) {
            char label[96];
            snprintf(label, sizeof label, "%s theta_o=%g", name, elevations[e]);
            furnace r = sample_pass(label, &gold, wo_at(elevations[e]), 100000, NULL);
            int ok = 1;
            for (int c = 0; c < 3; c++)
                ok &= r.mean[c] <= 1.0 + 5.0 * r.se[c];
            check(ok, "%s: albedo (%.4f %.4f %.4f) <= 1 (+5 se)", label, r.mean[0], r.mean[1], r.mean[2]);
        }
    }
    test_smooth_limit();

    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
