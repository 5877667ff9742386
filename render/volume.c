#include "volume.h"

#include <math.h>
#include <string.h>

void volume_lanes_make(const medium_t *m, const double *lambda, int n, volume_lanes_t *out)
{
    out->n = n;
    out->sigma_t_max = 0.0;
    out->emissive = 0;
    out->Le_varies = medium_Le_varies(m) && medium_is_emissive(m);
    for (int j = 0; j < n; j++) {
        medium_coeffs_t c = medium_coeffs(m, lambda[j]);
        out->sigma_a[j] = c.sigma_a;
        out->sigma_s[j] = c.sigma_s;
        out->Le[j] = c.Le;
        out->lambda[j] = lambda[j];
        out->emissive |= (c.Le > 0.0 || out->Le_varies) && c.sigma_a > 0.0;
        double st = c.sigma_a + c.sigma_s;
        if (st > out->sigma_t_max)
            out->sigma_t_max = st;
    }
}

/* exp(-sigma d) for sigma >= 0 and d in [0, inf]: 1 for a clear lane over any distance. */
static double transmit(double sigma, double d)
{
    if (!(sigma > 0.0))
        return 1.0;
    double od = sigma * d;
    return od < INFINITY ? exp(-od) : 0.0;
}

/* The lanes' selection probabilities in proportion to beta_j w_j (w NULL: 1). Returns 0 when
 * no lane carries anything. */
static int lanes_share(const double *beta, const double *w, int n, double *sel)
{
    double sum = 0.0;
    for (int j = 0; j < n; j++) {
        double b = beta[j] * (w ? w[j] : 1.0);
        sum += sel[j] = b > 0.0 && b < INFINITY ? b : 0.0;
    }
    if (!(sum > 0.0) || !(sum < INFINITY))
        return 0;
    for (int j = 0; j < n; j++)
        sel[j] /= sum;
    return 1;
}

static int pick_lane(const double *sel, int n, double u)
{
    double acc = 0.0;
    int last = 0;
    for (int j = 0; j < n; j++) {
        if (!(sel[j] > 0.0))
            continue;
        last = j;
        if (u < (acc += sel[j]))
            return j;
    }
    return last;
}

static double next(rng_stream_t *rng) { return rng_stream_next(rng); }

/* An exponential step of rate sigma > 0: -ln(1 - u) / sigma, finite for u in [0, 1). */
/* The majorant of a segment whose density is at most dmax, clamped to MEDIUM_SIGMA_MAX as every
 * coefficient is (medium.h); not > 0 for a segment with nothing in it. */
static double segment_majorant(const volume_lanes_t *k, double dmax)
{
    double smaj = dmax * k->sigma_t_max;
    return smaj > MEDIUM_SIGMA_MAX ? MEDIUM_SIGMA_MAX : smaj;
}

static double exp_step(double sigma, double u) { return -log1p(-u) / sigma; }

/* Homogeneous: the joint density of "the flight's first event is at t and is a scattering"
 * for lane k is sigma_s,k exp(-sigma_t,k t), of "no event before d" exp(-sigma_t,k d), and of
 * a collision at t sigma_t,k exp(-sigma_t,k t). Choosing lane k with sel_k and sampling its
 * flight analogously draws from the mixtures q(.) = sum_k sel_k p_k(.), so lane j's estimate
 * is weighted p_j / q (Veach 1997 §9.2.4, one-sample balance heuristic). The emission is
 * integrated by the collision points: sigma_a,j Le_j exp(-sigma_t,j t) / q_collision(t). */
static void sample_homogeneous(const volume_lanes_t *k, double tmax, const double *sel,
                               rng_stream_t *rng, volume_flight_t *out)
{
    const int n = k->n;
    int h = pick_lane(sel, n, next(rng));
    double st_h = k->sigma_a[h] + k->sigma_s[h];
    double u = next(rng);
    double t = st_h > 0.0 ? exp_step(st_h, u) : INFINITY;
    if (!(t < tmax)) {
        double T[VOLUME_MAX_LANES], q = 0.0;
        for (int j = 0; j < n; j++)
            q += sel[j] * (T[j] = transmit(k->sigma_a[j] + k->sigma_s[j], tmax));
        out->event = VOLUME_PASSED;
        for (int j = 0; j < n; j++)
            out->weight[j] = q > 0.0 ? T[j] / q : 0.0;
        return;
    }
    double E[VOLUME_MAX_LANES], qc = 0.0, qs = 0.0;
    for (int j = 0; j < n; j++) {
        E[j] = transmit(k->sigma_a[j] + k->sigma_s[j], t);
        qc += sel[j] * (k->sigma_a[j] + k->sigma_s[j]) * E[j];
        qs += sel[j] * k->sigma_s[j] * E[j];
    }
    /* qc >= sel_h sigma_t,h exp(-sigma_t,h t) > 0: sigma_t,h t = -ln(1 - u) <= 37. */
    if (k->emissive && qc > 0.0)
        for (int j = 0; j < n; j++)
            out->emitted[j] += E[j] * k->sigma_a[j] * k->Le[j] / qc;
    if (!(qc > 0.0) || !(next(rng) * qc < qs)) {
        out->event = VOLUME_ABSORBED;
        return;
    }
    out->event = VOLUME_SCATTERED;
    out->t = t;
    for (int j = 0; j < n; j++)
        out->weight[j] = k->sigma_s[j] * E[j] / qs;
}

/* Grid: delta tracking (Woodcock 1965; pbrt-v4 §14.2) with tentative collisions of the grey
 * majorant sigma_maj = dmax sigma_t,max on each majorant segment. At a collision, lane j's
 * densities of absorbing, scattering and null-scattering are sigma_a,j, sigma_s,j and
 * sigma_n,j = sigma_maj - sigma_t,j (each over sigma_maj); the event is chosen by their
 * mixture over the lanes (sel in proportion to the lanes' current throughputs) and lane j
 * weighted by its own over the mixture's. The emission is sigma_a,j Le_j / sigma_maj at every
 * collision. */
static void sample_grid(const medium_t *m, const volume_lanes_t *k, vec3_t org, vec3_t dir,
                        double tmax, const double *beta, rng_stream_t *rng, volume_flight_t *out)
{
    const int n = k->n;
    double sel[VOLUME_MAX_LANES], sa[VOLUME_MAX_LANES], ss[VOLUME_MAX_LANES], sn[VOLUME_MAX_LANES];
    double *w = out->weight;
    for (int j = 0; j < n; j++)
        w[j] = 1.0;
    medium_segments_t it;
    medium_segments_begin(m, org, dir, tmax, &it);
    double t0, t1, dmax;
    uint32_t collisions = 0;
    while (medium_segments_next(&it, &t0, &t1, &dmax)) {
        double smaj = segment_majorant(k, dmax);
        if (!(smaj > 0.0))
            continue;
        double t = t0;
        for (;;) {
            t += exp_step(smaj, next(rng));
            if (!(t < t1))
                break;
            if (++collisions > VOLUME_MAX_COLLISIONS) {
                out->event = VOLUME_ABSORBED;
                return;
            }
            vec3_t at = vec3_fma(org, dir, t);
            double d = medium_density(m, at);
            double A = 0.0, S = 0.0, N = 0.0;
            if (!lanes_share(beta, w, n, sel)) {
                out->event = VOLUME_ABSORBED;
                return;
            }
            for (int j = 0; j < n; j++) {
                sa[j] = d * k->sigma_a[j];
                ss[j] = d * k->sigma_s[j];
                sn[j] = smaj - sa[j] - ss[j];
                if (!(sn[j] > 0.0))
                    sn[j] = 0.0;
                A += sel[j] * sa[j];
                S += sel[j] * ss[j];
                N += sel[j] * sn[j];
                if (k->emissive)
                    out->emitted[j] +=
                        w[j] * sa[j] * (k->Le_varies ? medium_Le_at(m, at, k->lambda[j]) : k->Le[j]) / smaj;
            }
            double x = next(rng) * (A + S + N);
            if (x < A || !(A + S + N > 0.0)) {
                out->event = VOLUME_ABSORBED;
                return;
            }
            if (x < A + S) {
                for (int j = 0; j < n; j++)
                    w[j] *= ss[j] / S;
                out->event = VOLUME_SCATTERED;
                out->t = t;
                return;
            }
            for (int j = 0; j < n; j++)
                w[j] *= sn[j] / N;
        }
    }
    out->event = VOLUME_PASSED;
}

void volume_sample(const medium_t *m, const volume_lanes_t *k, vec3_t org, vec3_t dir, double tmax,
                   const double *beta, rng_stream_t *rng, volume_flight_t *out)
{
    const int n = k->n;
    out->t = 0.0;
    memset(out->emitted, 0, (size_t)n * sizeof out->emitted[0]);
    double sel[VOLUME_MAX_LANES];
    if (!lanes_share(beta, NULL, n, sel)) {
        out->event = VOLUME_ABSORBED;
        return;
    }
    if (medium_kind(m) == MEDIUM_HOMOGENEOUS)
        sample_homogeneous(k, tmax, sel, rng, out);
    else
        sample_grid(m, k, org, dir, tmax, beta, rng, out);
}

double volume_scatter_pdf(const volume_lanes_t *k, const double *beta, double t)
{
    double sel[VOLUME_MAX_LANES], q = 0.0;
    if (!lanes_share(beta, NULL, k->n, sel))
        return 0.0;
    for (int j = 0; j < k->n; j++)
        q += sel[j] * k->sigma_s[j] * transmit(k->sigma_a[j] + k->sigma_s[j], t);
    return q;
}

/* Ratio tracking (Novák et al. 2014): each tentative collision of the grey majorant multiplies
 * lane j by its null-collision probability sigma_n,j / sigma_maj, an unbiased estimate of
 * exp(-int sigma_t,j) whatever the majorant. */
void volume_transmittance(const medium_t *m, const volume_lanes_t *k, vec3_t org, vec3_t dir,
                          double tmax, rng_stream_t *rng, double *T)
{
    const int n = k->n;
    if (medium_kind(m) == MEDIUM_HOMOGENEOUS) {
        for (int j = 0; j < n; j++)
            T[j] *= transmit(k->sigma_a[j] + k->sigma_s[j], tmax);
        return;
    }
    medium_segments_t it;
    medium_segments_begin(m, org, dir, tmax, &it);
    double t0, t1, dmax;
    uint32_t collisions = 0;
    while (medium_segments_next(&it, &t0, &t1, &dmax)) {
        double smaj = segment_majorant(k, dmax);
        if (!(smaj > 0.0))
            continue;
        double t = t0;
        for (;;) {
            t += exp_step(smaj, next(rng));
            if (!(t < t1))
                break;
            double d = medium_density(m, vec3_fma(org, dir, t));
            double mx = 0.0;
            for (int j = 0; j < n; j++) {
                double sn = smaj - d * (k->sigma_a[j] + k->sigma_s[j]);
                T[j] *= sn > 0.0 ? sn / smaj : 0.0;
                if (T[j] > mx)
                    mx = T[j];
            }
            if (!(mx > 0.0) || ++collisions > VOLUME_MAX_COLLISIONS) {
                for (int j = 0; j < n; j++)
                    T[j] = 0.0;
                return;
            }
            if (mx < VOLUME_RR_THRESHOLD) {
                if (next(rng) >= VOLUME_RR_SURVIVE) {
                    for (int j = 0; j < n; j++)
                        T[j] = 0.0;
                    return;
                }
                for (int j = 0; j < n; j++)
                    T[j] /= VOLUME_RR_SURVIVE;
            }
        }
    }
}
