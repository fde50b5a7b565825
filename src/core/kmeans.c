/*
 * kmeans.c: Lloyd's k-means with k-means++ seeding (Arthur & Vassilvitskii
 * 2007) from a fixed-seed generator, for the skinning fit's rotation
 * clusters, accelerated by Hamerly's distance bounds (same labels as plain
 * Lloyd, far fewer distance evaluations once the centres settle).
 *
 * Determinism: the generator is splitmix64 of the given seed; the seeding's
 * running sums and the centre updates run serially in index order; only the
 * assignment (one independent argmin per point, lowest centre index on
 * ties) runs in parallel, so labels and centres are bitwise the same for
 * any thread count.
 */
#include "skinning.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Below this many multiply-adds per round the assignment stays serial. */
#define KMEANS_PARALLEL_WORK 200000.0

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1) with 53 random bits. */
static double uniform01(uint64_t *state)
{
    return (double)(splitmix64(state) >> 11) * (1.0 / 9007199254740992.0);
}

/* Squared distance, four partial sums in a fixed order (for speed without
 * letting the compiler reassociate). */
static double dist2(const double *a, const double *b, int32_t d)
{
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int32_t j = 0;
    for (; j + 4 <= d; j += 4) {
        double t0 = a[j] - b[j], t1 = a[j + 1] - b[j + 1], t2 = a[j + 2] - b[j + 2],
               t3 = a[j + 3] - b[j + 3];
        s0 += t0 * t0;
        s1 += t1 * t1;
        s2 += t2 * t2;
        s3 += t3 * t3;
    }
    for (; j < d; j++) {
        double t = a[j] - b[j];
        s0 += t * t;
    }
    return (s0 + s1) + (s2 + s3);
}

/* k-means++: the first centre uniformly, each next one with probability
 * proportional to the squared distance to the nearest centre so far.  D:
 * n doubles of scratch. */
static void seed_plusplus(const double *X, int32_t n, int32_t d, int32_t k, uint64_t seed, int nt,
                          double *C, double *D)
{
    uint64_t state = seed;
    int32_t first = (int32_t)(uniform01(&state) * n);
    double work = (double)n * d;
    if (first >= n)
        first = n - 1;
    memcpy(C, X + (size_t)first * d, sizeof(double) * (size_t)d);
#pragma omp parallel for schedule(static) num_threads(nt) if (work > KMEANS_PARALLEL_WORK)
    for (int32_t i = 0; i < n; i++)
        D[i] = dist2(X + (size_t)i * d, C, d);
    for (int32_t c = 1; c < k; c++) {
        double total = 0.0, r, acc = 0.0;
        int32_t pick = -1;
        const double *cc;
        for (int32_t i = 0; i < n; i++)
            total += D[i];
        if (total > 0.0) {
            r = uniform01(&state) * total;
            for (int32_t i = 0; i < n; i++) {
                acc += D[i];
                if (D[i] > 0.0 && acc > r) {
                    pick = i;
                    break;
                }
            }
            if (pick < 0) /* r rounded past the last positive entry */
                for (int32_t i = n - 1; i >= 0; i--)
                    if (D[i] > 0.0) {
                        pick = i;
                        break;
                    }
        } else {
            /* Every point sits on a centre: fewer distinct points than
             * clusters.  Take points in order; the empty clusters are
             * handled like any other. */
            pick = c % n;
        }
        memcpy(C + (size_t)c * d, X + (size_t)pick * d, sizeof(double) * (size_t)d);
        cc = C + (size_t)c * d;
#pragma omp parallel for schedule(static) num_threads(nt) if (work > KMEANS_PARALLEL_WORK)
        for (int32_t i = 0; i < n; i++) {
            double t = dist2(X + (size_t)i * d, cc, d);
            if (t < D[i])
                D[i] = t;
        }
    }
}

/* Full scan of point x over the k centres: nearest (lowest index on ties),
 * its squared distance and the squared distance to the second nearest. */
static int32_t nearest2(const double *x, const double *C, int32_t k, int32_t d, double *best,
                        double *second)
{
    double b = dist2(x, C, d), s2 = INFINITY;
    int32_t bj = 0;
    for (int32_t j = 1; j < k; j++) {
        double t = dist2(x, C + (size_t)j * d, d);
        if (t < b) {
            s2 = b;
            b = t;
            bj = j;
        } else if (t < s2) {
            s2 = t;
        }
    }
    *best = b;
    *second = s2;
    return bj;
}

dtx_status dtx_kmeans(const double *X, int32_t n, int32_t d, int32_t k, int max_iters,
                      uint64_t seed, int threads, int32_t *labels, double *centers, int *iters,
                      dtx_error *err)
{
    double *C = NULL, *Cold = NULL, *D = NULL, *sum = NULL, *up = NULL, *lo = NULL, *half = NULL,
           *shift = NULL;
    int32_t *count = NULL, *prev = NULL;
    int nt = threads > 0 ? threads : omp_get_max_threads(), rounds = 0;
    double work = (double)n * k * d;
    dtx_status st = DTX_OK;

    if (!X || !labels || n < 1 || d < 1 || k < 1 || k > n)
        return dtx_seterr(err, DTX_EINVAL,
                          "k-means: bad arguments (n = %d points, d = %d, k = %d clusters; "
                          "needs 1 <= k <= n and d >= 1)",
                          (int)n, (int)d, (int)k);
    for (size_t i = 0; i < (size_t)n * d; i++)
        if (!isfinite(X[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "k-means: point %zu has a non-finite coordinate (%zu)", i / d, i % d);
    C = dtx_alloc((size_t)k * d, sizeof *C, 0);
    Cold = dtx_alloc((size_t)k * d, sizeof *Cold, 0);
    sum = dtx_alloc((size_t)k * d, sizeof *sum, 0);
    D = dtx_alloc((size_t)n, sizeof *D, 0);
    up = dtx_alloc((size_t)n, sizeof *up, 0);
    lo = dtx_alloc((size_t)n, sizeof *lo, 0);
    half = dtx_alloc((size_t)k, sizeof *half, 0);
    shift = dtx_alloc((size_t)k, sizeof *shift, 0);
    count = dtx_alloc((size_t)k, sizeof *count, 0);
    prev = dtx_alloc((size_t)n, sizeof *prev, 0);
    if (!C || !Cold || !sum || !D || !up || !lo || !half || !shift || !count || !prev) {
        st = dtx_seterr(err, DTX_ENOMEM, "k-means: out of memory (%d points x %d dimensions)",
                        (int)n, (int)d);
        goto fail;
    }

    seed_plusplus(X, n, d, k, seed, nt, C, D);

    /* Hamerly's bounds (2010): up[i] >= distance to the own centre, lo[i] <=
     * distance to every other centre.  A point whose bounds prove its
     * centre nearest by a margin is not rescanned; every other point gets
     * the same full scan as plain Lloyd, so the labels are Lloyd's.  The
     * margin (relative 1e-9) covers the rounding of the bounds, and exact
     * ties are always rescanned (lowest index wins, as in Lloyd). */
    for (int it = 0; it < (max_iters > 0 ? max_iters : 1); it++) {
        long changed = 0;
        rounds++;

        /* ---- assignment */
        if (it == 0) {
#pragma omp parallel for schedule(static) num_threads(nt) if (work > KMEANS_PARALLEL_WORK)
            for (int32_t i = 0; i < n; i++) {
                double b, s2;
                labels[i] = nearest2(X + (size_t)i * d, C, k, d, &b, &s2);
                up[i] = sqrt(b);
                lo[i] = sqrt(s2);
            }
            changed = n;
        } else {
#pragma omp parallel for schedule(dynamic, 256) num_threads(nt) reduction(+ : changed) \
    if (work > KMEANS_PARALLEL_WORK)
            for (int32_t i = 0; i < n; i++) {
                const double *x = X + (size_t)i * d;
                double bound = fmax(half[labels[i]], lo[i]), b, s2;
                int32_t bj;
                if (up[i] < bound * (1.0 - 1e-9))
                    continue;
                up[i] = sqrt(dist2(x, C + (size_t)labels[i] * d, d));
                if (up[i] < bound * (1.0 - 1e-9))
                    continue;
                bj = nearest2(x, C, k, d, &b, &s2);
                up[i] = sqrt(b);
                lo[i] = sqrt(s2);
                if (bj != labels[i]) {
                    labels[i] = bj;
                    changed++;
                }
            }
        }
        if (it > 0 && changed == 0)
            break;

        /* ---- update.  After the first round the sums are updated by the
         * points that moved, in index order (O(moves d) instead of O(n d));
         * the first round, and any round that empties a cluster, sums
         * afresh in index order.  An empty cluster takes the point farthest
         * from its centre among clusters of 2 or more. */
        memcpy(Cold, C, sizeof(double) * (size_t)k * d);
        if (it > 0) {
            int full = 0;
            for (int32_t i = 0; i < n; i++)
                if (labels[i] != prev[i]) {
                    double *so = sum + (size_t)prev[i] * d, *sn = sum + (size_t)labels[i] * d;
                    const double *x = X + (size_t)i * d;
                    count[prev[i]]--;
                    count[labels[i]]++;
                    for (int32_t j = 0; j < d; j++) {
                        so[j] -= x[j];
                        sn[j] += x[j];
                    }
                }
            for (int32_t j = 0; j < k; j++)
                full |= count[j] == 0;
            if (!full)
                goto means;
        }
        for (int pass = 0;; pass++) {
            int32_t empty = -1;
            memset(sum, 0, sizeof(double) * (size_t)k * d);
            memset(count, 0, sizeof(int32_t) * (size_t)k);
            for (int32_t i = 0; i < n; i++) {
                double *s = sum + (size_t)labels[i] * d;
                const double *x = X + (size_t)i * d;
                count[labels[i]]++;
                for (int32_t j = 0; j < d; j++)
                    s[j] += x[j];
            }
            for (int32_t j = 0; j < k && empty < 0; j++)
                if (count[j] == 0)
                    empty = j;
            if (empty < 0)
                break;
            if (pass == 0) /* exact distances to the own centres */
                for (int32_t i = 0; i < n; i++)
                    D[i] = dist2(X + (size_t)i * d, C + (size_t)labels[i] * d, d);
            {
                int32_t far = -1;
                for (int32_t i = 0; i < n; i++)
                    if (count[labels[i]] > 1 && (far < 0 || D[i] > D[far]))
                        far = i;
                /* k <= n guarantees a cluster with 2 or more points. */
                labels[far] = empty;
                D[far] = 0.0;
                up[far] = INFINITY; /* rescan it next round */
                lo[far] = 0.0;
            }
        }
    means:
        for (int32_t j = 0; j < k; j++)
            for (int32_t c = 0; c < d; c++)
                C[(size_t)j * d + c] = sum[(size_t)j * d + c] / count[j];
        memcpy(prev, labels, sizeof(int32_t) * (size_t)n);

        /* ---- bounds: centre shifts and half distances between centres */
        {
            double m1 = 0.0, m2 = 0.0;
            int32_t j1 = -1;
            for (int32_t j = 0; j < k; j++) {
                shift[j] = sqrt(dist2(C + (size_t)j * d, Cold + (size_t)j * d, d));
                if (shift[j] > m1) {
                    m2 = m1;
                    m1 = shift[j];
                    j1 = j;
                } else if (shift[j] > m2) {
                    m2 = shift[j];
                }
                half[j] = INFINITY;
            }
            for (int32_t a = 0; a < k; a++)
                for (int32_t b = a + 1; b < k; b++) {
                    double t = 0.5 * sqrt(dist2(C + (size_t)a * d, C + (size_t)b * d, d));
                    half[a] = fmin(half[a], t);
                    half[b] = fmin(half[b], t);
                }
            for (int32_t i = 0; i < n; i++) {
                up[i] += shift[labels[i]];
                lo[i] -= labels[i] == j1 ? m2 : m1;
            }
        }
    }
    if (iters)
        *iters = rounds;
    if (centers)
        memcpy(centers, C, sizeof(double) * (size_t)k * d);

fail:
    free(C);
    free(Cold);
    free(sum);
    free(D);
    free(up);
    free(lo);
    free(half);
    free(shift);
    free(count);
    free(prev);
    return st;
}
