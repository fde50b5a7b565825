/*
 * keypoints.c: greedy key-point selection (keypoints.h).
 *
 * Structure: a context holds what does not depend on the key points (the
 * skinning mesh, the clustering features of the frames, the candidates);
 * a round fixes the set it starts from, its clustering and, in fast mode,
 * what the fits need besides the weights (dtx_skin_eval: the centred
 * frames, their starting rotations, the covariance map), and evaluates
 * every remaining candidate in parallel, each
 * thread with its own workspace allocated before the loop; the part's
 * errors are combined by the caller's reduce, and the smallest error wins
 * (lowest candidate index on ties).
 */
#include "keypoints.h"

#include "bbw.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

void dtx_kp_params_default(dtx_kp_params *p)
{
    memset(p, 0, sizeof *p);
    p->candidates = 100;
    p->eps = 0.03;
    p->max_keys = 40;
    p->max_sweeps = 10;
    p->exact = 0;
    dtx_skin_params_default(&p->skin);
    p->threads = 0;
    p->part_index = 0;
    p->part_count = 1;
}

void dtx_kp_result_free(dtx_kp_result *res)
{
    if (!res)
        return;
    free(res->keys);
    free(res->candidates);
    free(res->trace);
    free(res->weights);
    memset(res, 0, sizeof *res);
}

/* What does not depend on the key points. */
typedef struct {
    const dtx_mesh *src;
    int32_t nv, nframes;
    const double *X;
    dtx_skin_mesh *sm;
    double *feat;  /* nv x 9 nframes */
    double radius; /* R */
    dtx_skin_params skin;
    int exact;
    dtx_skin_eval *ev; /* the round's frames, clustering and starting rotations (fast mode) */
    /* The set generation (gen) and cluster count ev was built for (-1:
     * none): a round on the same set with as many clusters (a replacement
     * round after a rejected one) would build it again bit for bit. */
    int64_t ev_gen;
    int32_t ev_k;
    /* Fast mode: candidate i's Green's function for the handle set of
     * generation ggen[i] (-1: none) at gcache + i nv; the generation counts
     * the commits.  Every part holds every candidate's (gcache_fill: the
     * solves shared out over the parts and put together): they are solved
     * once, then carried across each commit by a rank-one
     * update (gcache_move) instead of solved again, and a candidate's
     * history, so its bits, must not depend on which part evaluates it.
     * NULL when it would take more than KP_GCACHE_MAX doubles (or memory
     * is short).  gverts: ncand, scratch for gcache_move. */
    double *gcache;
    int64_t *ggen, gen;
    int32_t *gverts;
} kp_ctx;

/* Largest Green's function cache, in doubles (256 MiB). */
#define KP_GCACHE_MAX ((size_t)1 << 25)
/* Largest piece of it put together over the parts in one reduce call. */
#define KP_REDUCE_MAX ((size_t)1 << 22)

/* Per-thread workspace for one evaluation with up to mmax key points. */
typedef struct {
    double *W;        /* nv x mmax */
    double *T;        /* nframes x mmax x 12 */
    double *Q;        /* nv x 3 */
    int32_t *labels;  /* nv */
    int32_t *handles; /* mmax */
    dtx_bbw_work *bw;
    dtx_skin_eval_work *ew; /* fast mode */
} kp_work;

static void work_free(kp_work *w)
{
    free(w->W);
    free(w->T);
    free(w->Q);
    free(w->labels);
    free(w->handles);
    dtx_bbw_work_free(&w->bw);
    dtx_skin_eval_work_free(&w->ew);
    memset(w, 0, sizeof *w);
}

static int work_alloc(kp_work *w, const kp_ctx *c, int32_t mmax, const dtx_bbw_incr *incr)
{
    memset(w, 0, sizeof *w);
    w->W = dtx_alloc((size_t)c->nv * (size_t)mmax, sizeof *w->W, 0);
    w->T = dtx_alloc((size_t)c->nframes * (size_t)mmax * 12, sizeof *w->T, 0);
    w->Q = dtx_alloc((size_t)c->nv * 3, sizeof *w->Q, 0);
    w->labels = dtx_alloc((size_t)c->nv, sizeof *w->labels, 0);
    w->handles = dtx_alloc((size_t)mmax, sizeof *w->handles, 0);
    w->bw = incr ? dtx_bbw_work_new(incr) : NULL;
    w->ew = incr && !c->exact ? dtx_skin_eval_work_new(c->sm, c->nframes, mmax, mmax) : NULL;
    if (!w->W || !w->T || !w->Q || !w->labels || !w->handles || (incr && !w->bw) ||
        (incr && !c->exact && !w->ew)) {
        work_free(w);
        return -1;
    }
    return 0;
}

/* Radius of the rest mesh about its bounding-box centre. */
static double rest_radius(const dtx_mesh *m)
{
    double lo[3], hi[3], c[3], r2 = 0.0;
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = m->V[k];
    for (int32_t i = 1; i < m->nv; i++)
        for (int k = 0; k < 3; k++) {
            double v = m->V[3 * (size_t)i + k];
            lo[k] = v < lo[k] ? v : lo[k];
            hi[k] = v > hi[k] ? v : hi[k];
        }
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (lo[k] + hi[k]);
    for (int32_t i = 0; i < m->nv; i++) {
        const double *v = m->V + 3 * (size_t)i;
        double d2 = (v[0] - c[0]) * (v[0] - c[0]) + (v[1] - c[1]) * (v[1] - c[1]) +
                    (v[2] - c[2]) * (v[2] - c[2]);
        r2 = d2 > r2 ? d2 : r2;
    }
    return sqrt(r2);
}

/* The error of weights W (nv x m, rows summing to 1) with the clustering
 * labels (k clusters): fit every frame, skin, mean vertex distance / R. */
static dtx_status eval_weights(const kp_ctx *c, int32_t m, const double *W, const int32_t *labels,
                               int32_t k, kp_work *w, double *out, dtx_error *e)
{
    dtx_skin_params sp = c->skin;
    dtx_skin_fit *fit = NULL;
    dtx_skin_out o;
    dtx_status st;
    double sum = 0.0;
    sp.threads = 1;
    sp.nclusters = k;
    if ((st = dtx_skin_fit_create(c->sm, m, W, labels, k, &sp, &fit, e)) != DTX_OK)
        return st;
    memset(&o, 0, sizeof o);
    o.T = w->T;
    st = dtx_skin_fit_frames(fit, c->nframes, c->X, &sp, &o, e);
    dtx_skin_fit_free(&fit);
    if (st != DTX_OK)
        return st;
    for (int32_t f = 0; f < c->nframes; f++) {
        const double *x = c->X + (size_t)f * 3 * (size_t)c->nv;
        dtx_skin_apply(c->nv, m, c->src->V, W, 1, w->T + (size_t)f * (size_t)m * 12, 1, w->Q);
        for (int32_t i = 0; i < c->nv; i++) {
            const double *q = w->Q + 3 * (size_t)i, *y = x + 3 * (size_t)i;
            sum += sqrt((q[0] - y[0]) * (q[0] - y[0]) + (q[1] - y[1]) * (q[1] - y[1]) +
                        (q[2] - y[2]) * (q[2] - y[2]));
        }
    }
    *out = sum / ((double)c->nframes * (double)c->nv) / c->radius;
    return isfinite(*out) ? DTX_OK
                          : dtx_seterr(e, DTX_ENONFINITE, "key points: non-finite fit error");
}

/* Clustering of the vertices for weights W (nv x m) into k clusters. */
static dtx_status cluster(const kp_ctx *c, int32_t m, const double *W, int32_t k, int threads,
                          int32_t *labels, dtx_error *e)
{
    dtx_skin_params sp = c->skin;
    sp.nclusters = k;
    sp.threads = threads;
    return dtx_skin_cluster(c->nv, m, W, c->nframes, c->feat, &sp, labels, e);
}

/* Exact evaluation of a handle set: bounded weights, its own clustering. */
static dtx_status eval_exact(const kp_ctx *c, const int32_t *handles, int32_t m, int threads,
                             kp_work *w, double *out, dtx_error *e)
{
    dtx_status st = dtx_bbw(c->src, handles, m, NULL, w->W, NULL, e);
    if (st == DTX_OK)
        st = cluster(c, m, w->W, m, threads, w->labels, e);
    if (st == DTX_OK)
        st = eval_weights(c, m, w->W, w->labels, m, w, out, e);
    return st;
}

/* The final set's bounded weights (into w->W), its own clustering and its
 * error, as eval_exact computes them, with the handles' programmes shared
 * out over the parts: part q solves handles [m q / P, m (q + 1) / P)
 * (dtx_bbw_handles), or those p->claim hands it (dtx_bbw_handles_claim),
 * the other rows are +INFINITY, and the parts' rows are
 * put together by p->reduce (an element-wise minimum), so every part
 * normalises the same rows (dtx_bbw_normalise) and gets dtx_bbw's bits. */
static dtx_status final_exact(const kp_ctx *c, const int32_t *handles, int32_t m, int threads,
                              const dtx_kp_params *p, kp_work *w, double *out, int *reduce_failed,
                              dtx_error *e)
{
    int64_t n = (int64_t)c->nv * m;
    int32_t k0, k1;
    double *Wk;
    dtx_status st;
    if (p->part_count == 1 || n > INT32_MAX)
        return eval_exact(c, handles, m, threads, w, out, e);
    k0 = (int32_t)((int64_t)m * p->part_index / p->part_count);
    k1 = (int32_t)((int64_t)m * (p->part_index + 1) / p->part_count);
    Wk = dtx_alloc((size_t)n, sizeof *Wk, 0);
    if (!Wk)
        return dtx_seterr(e, DTX_ENOMEM, "out of memory");
    for (int64_t i = 0; i < n; i++)
        Wk[i] = INFINITY;
    if (p->claim)
        st = dtx_bbw_handles_claim(c->src, handles, m, p->claim, p->claim_ctx, NULL, Wk, NULL, e);
    else
        st = dtx_bbw_handles(c->src, handles, m, k0, k1, NULL, Wk + (size_t)k0 * c->nv, NULL, e);
    if (st == DTX_OK && (st = p->reduce(p->reduce_ctx, Wk, (int32_t)n, 1, e)) != DTX_OK)
        *reduce_failed = 1;
    if (st == DTX_OK)
        st = dtx_bbw_normalise(c->src, handles, m, Wk, NULL, w->W, NULL, e);
    free(Wk);
    if (st == DTX_OK)
        st = cluster(c, m, w->W, m, threads, w->labels, e);
    if (st == DTX_OK)
        st = eval_weights(c, m, w->W, w->labels, m, w, out, e);
    return st;
}

/* The fast error of weights W (nv x m, rows summing to 1) with the round's
 * clustering and starting rotations (c->ev): mean vertex distance / R. */
static dtx_status eval_fast(const kp_ctx *c, int32_t m, const double *W, kp_work *w, double *out,
                            dtx_error *e)
{
    dtx_status st = dtx_skin_eval_error(c->ev, m, W, w->ew, out, e);
    if (st == DTX_OK)
        *out /= c->radius;
    return st;
}

/* Which of the round's candidates this part evaluates (mine[i] = 1): the
 * candidates not in the set (inset[i] == 0), numbered 0, 1, ... in index
 * order, go to the parts in turn, so the parts' counts differ by at most one
 * whatever the set holds (candidate i on part i % parts left a part with up
 * to the set's size more, and the other waiting for it at the reduction).
 * The share depends only on the set, so replacement rounds that share their
 * Green's functions (c->gcache, per part) keep the same candidates. */
static void round_share(const unsigned char *inset, int32_t ncand, const dtx_kp_params *p,
                        unsigned char *mine)
{
    int32_t j = 0;
    for (int32_t i = 0; i < ncand; i++) {
        mine[i] = !inset[i] && j % p->part_count == p->part_index;
        j += !inset[i];
    }
}

/* Fast mode with the cache: the Green's function of every candidate not
 * in the set that has none for the current set (in the first round, all
 * of them).  The solves are shared out over the parts, the j-th candidate
 * that needs one to part j % parts, and the parts' rows put together
 * through p->reduce (+INFINITY where a part did not solve), so that every
 * part ends with every candidate's function: one solve from the same
 * factor whichever part runs it, so the bits do not depend on the number
 * of parts.  flag: ncand doubles of scratch (0 solved, 1 failed).  A
 * failed solve (or a non-finite result) leaves ggen[i] = -1 on every part:
 * round_eval tries again and counts the failure.  Every part makes the
 * same reduce calls (what needs a solve is the same on every part).
 * Errors: those of p->reduce only (*reduce_failed set). */
static dtx_status gcache_fill(kp_ctx *c, dtx_bbw_incr *incr, const int32_t *cand, int32_t ncand,
                              const unsigned char *inset, kp_work *ws, int nthreads,
                              const dtx_kp_params *p, double *flag, int64_t *solves,
                              int *reduce_failed, dtx_error *err)
{
    int32_t lo = -1, hi = -1, j = 0;
    int64_t ns = 0;
    const size_t nv = (size_t)c->nv;
    int factored;
    dtx_status st;
    dtx_error e0;
    /* What needs a solve is the same on every part: ggen changes only
     * here (through the parts' flags), in gcache_move (the same on every
     * part, or the selection fails) and never in round_eval's own solves
     * when there are several parts; so every part makes the same reduce
     * calls. */
    for (int32_t i = 0; i < ncand; i++) {
        flag[i] = !inset[i] && c->ggen[i] != c->gen ? 0.0 : 1.0;
        if (flag[i] == 0.0) {
            c->ggen[i] = -1;
            lo = lo < 0 ? i : lo;
            hi = i + 1;
        }
    }
    if (lo < 0)
        return DTX_OK;
    /* A carried commit (key_commit) left the set unfactored. */
    factored = dtx_bbw_incr_factor(incr, &e0) == DTX_OK;
    if (!factored && p->part_count == 1)
        return DTX_OK;
    /* flag[i]: -1 this part solves it, +INFINITY another part does, 0 no
     * solve needed. */
    for (int32_t i = 0; i < ncand; i++) {
        if (flag[i] != 0.0) {
            flag[i] = 0.0;
            continue;
        }
        if (j++ % p->part_count == p->part_index)
            flag[i] = -1.0;
        else {
            flag[i] = INFINITY;
            for (size_t r = 0; r < nv; r++)
                c->gcache[(size_t)i * nv + r] = INFINITY;
        }
    }
#pragma omp parallel for num_threads(nthreads) schedule(dynamic, 1) reduction(+ : ns)
    for (int32_t i = 0; i < ncand; i++) {
        double *g = c->gcache + (size_t)i * nv;
        dtx_error e;
        int ok;
        if (flag[i] != -1.0)
            continue;
        ns += factored;
        ok = factored &&
             dtx_bbw_incr_green(incr, cand[i], g, ws[omp_get_thread_num()].bw, &e) == DTX_OK;
        for (size_t r = 0; ok && r < nv; r++)
            ok = isfinite(g[r]);
        if (!ok) /* defined values for the other parts' minimum */
            for (size_t r = 0; r < nv; r++)
                g[r] = 0.0;
        flag[i] = ok ? 0.0 : 1.0;
    }
    *solves += ns;
    /* In pieces of at most KP_REDUCE_MAX doubles: the reduction may take
     * buffers of its size. */
    for (size_t o = (size_t)lo * nv, end = (size_t)hi * nv; p->part_count > 1 && o < end;) {
        size_t n = end - o < KP_REDUCE_MAX ? end - o : KP_REDUCE_MAX;
        if ((st = p->reduce(p->reduce_ctx, c->gcache + o, (int32_t)n, 1, err)) != DTX_OK) {
            *reduce_failed = 1;
            return st;
        }
        o += n;
    }
    if (p->part_count > 1 && (st = p->reduce(p->reduce_ctx, flag, ncand, 1, err)) != DTX_OK) {
        *reduce_failed = 1;
        return st;
    }
    for (int32_t i = 0; i < ncand; i++)
        if (c->ggen[i] == -1 && !inset[i])
            c->ggen[i] = flag[i] == 0.0 ? c->gen : -1;
    return DTX_OK;
}

/* Before the commit that adds candidate b (replace_j < 0) or puts it in
 * place of key replace_j: every cached Green's function of a candidate
 * that stays out of the set, and the one of the key that leaves it, is
 * carried to the new set (dtx_bbw_incr_green_move) and marked with the
 * next generation.  When that is not possible (b's own function missing,
 * a key alone in its component, memory with one part) nothing is marked,
 * and the next round's gcache_fill solves them afresh.  Errors: DTX_ENOMEM
 * with several parts. */
static dtx_status gcache_move(kp_ctx *c, const dtx_bbw_incr *incr, const int32_t *cand,
                              int32_t ncand, const unsigned char *inset, int32_t b, int replace_j,
                              int nthreads, const dtx_kp_params *p, dtx_error *err)
{
    int32_t hj = replace_j >= 0 ? dtx_bbw_incr_handles(incr)[replace_j] : -1;
    dtx_status st;
    if (!c->gcache || c->ggen[b] != c->gen)
        return DTX_OK;
    for (int32_t i = 0; i < ncand; i++) {
        c->gverts[i] = -1;
        if (i == b)
            continue;
        if (cand[i] == hj)
            c->gverts[i] = hj;
        else if (!inset[i] && c->ggen[i] == c->gen)
            c->gverts[i] = cand[i];
    }
    if ((st = dtx_bbw_incr_green_move(incr, replace_j, cand[b],
                                      c->gcache + (size_t)b * (size_t)c->nv, ncand, c->gverts,
                                      c->gcache, nthreads, err)) != DTX_OK)
        /* Out of memory on one part would leave the parts' caches
         * different (see gcache_fill): an error then; the other failures
         * are the same on every part. */
        return st == DTX_ENOMEM && p->part_count > 1 ? st : DTX_OK;
    for (int32_t i = 0; i < ncand; i++)
        if (c->gverts[i] >= 0)
            c->ggen[i] = c->gen + 1;
    return DTX_OK;
}

/* The commit of candidate b (added, or in place of key replace_j): carried
 * with b's cached Green's function when there is one (no factorisation;
 * gcache_fill factors the set if a solve is needed later), else a plain
 * commit.  Call after gcache_move, before c->gen moves on. */
static dtx_status key_commit(const kp_ctx *c, dtx_bbw_incr *incr, const int32_t *cand, int32_t b,
                             int replace_j, kp_work *ws, dtx_error *err)
{
    if (c->gcache && c->ggen[b] == c->gen)
        return dtx_bbw_incr_commit_g(incr, replace_j, cand[b],
                                     c->gcache + (size_t)b * (size_t)c->nv, ws[0].bw, err);
    return replace_j < 0 ? dtx_bbw_incr_add(incr, cand[b], err)
                         : dtx_bbw_incr_replace(incr, replace_j, cand[b], err);
}

/* One round: errs[i] for every candidate i not in the set (flag inset[i]
 * == 0) that this part owns (round_share); +INFINITY elsewhere.
 * replace_j < 0: add the candidate; else replace handle replace_j by it.
 * Fast mode: c->ev holds the round's clustering.  mine: ncand bytes of
 * scratch. */
static void round_eval(const kp_ctx *c, const dtx_bbw_incr *incr, const int32_t *cand,
                       int32_t ncand, const unsigned char *inset, int replace_j, kp_work *ws,
                       int nthreads, const dtx_kp_params *p, unsigned char *mine, double *errs,
                       int64_t *evals, int64_t *failed, int64_t *solves)
{
    const int32_t m = dtx_bbw_incr_count(incr);
    const int32_t mm = replace_j < 0 ? m + 1 : m;
    int64_t ev = 0, fl = 0, ns = 0;
    for (int32_t i = 0; i < ncand; i++)
        errs[i] = INFINITY;
    round_share(inset, ncand, p, mine);
#pragma omp parallel for num_threads(nthreads) schedule(dynamic, 1) reduction(+ : ev, fl, ns)
    for (int32_t i = 0; i < ncand; i++) {
        kp_work *w = &ws[omp_get_thread_num()];
        dtx_error e;
        dtx_status st;
        double v = INFINITY;
        if (!mine[i])
            continue;
        ev++;
        if (c->exact) {
            memcpy(w->handles, dtx_bbw_incr_handles(incr), (size_t)m * sizeof *w->handles);
            w->handles[replace_j < 0 ? m : replace_j] = cand[i];
            st = eval_exact(c, w->handles, mm, 1, w, &v, &e);
        } else {
            const double *g = NULL;
            st = DTX_OK;
            if (c->gcache) {
                double *gi = c->gcache + (size_t)i * (size_t)c->nv;
                if (c->ggen[i] != c->gen) {
                    ns++;
                    st = dtx_bbw_incr_green(incr, cand[i], gi, w->bw, &e);
                    /* Kept by this part alone: several parts must
                     * agree on what gcache_fill solves. */
                    c->ggen[i] = st == DTX_OK && p->part_count == 1 ? c->gen : -1;
                }
                g = gi;
            }
            if (st != DTX_OK)
                ;
            else if (replace_j < 0)
                st = dtx_bbw_incr_weights_add_g(incr, cand[i], g, w->W, w->bw, &e);
            else
                st = dtx_bbw_incr_weights_replace_g(incr, replace_j, cand[i], g, w->W, w->bw, &e);
            if (st == DTX_OK && dtx_bbw_clamp_normalise(w->W, c->nv, mm, NULL) < 0)
                st = DTX_ESOLVE;
            if (st == DTX_OK)
                st = eval_fast(c, mm, w->W, w, &v, &e);
        }
        if (st != DTX_OK) {
            v = INFINITY;
            fl++;
        }
        errs[i] = v;
    }
    *evals += ev;
    *failed += fl;
    *solves += ns;
}

/* The smallest finite entry (lowest index on ties), or -1. */
static int32_t argmin(const double *v, int32_t n)
{
    int32_t b = -1;
    for (int32_t i = 0; i < n; i++)
        if (isfinite(v[i]) && (b < 0 || v[i] < v[b]))
            b = i;
    return b;
}

/* The round's clustering (fast mode): the current set's clamped weights,
 * and c->ev for it.  Kept from the round before when that one had the
 * same set and cluster count (it depends on nothing else).  Leaves
 * w->labels alone when kept. */
static dtx_status round_labels(kp_ctx *c, const dtx_bbw_incr *incr, int32_t k, int threads,
                               kp_work *w, dtx_error *e)
{
    const int32_t m = dtx_bbw_incr_count(incr);
    dtx_status st;
    if (c->ev && c->ev_gen == c->gen && c->ev_k == k)
        return DTX_OK;
    c->ev_gen = -1;
    memcpy(w->W, dtx_bbw_incr_weights(incr), (size_t)c->nv * (size_t)m * sizeof *w->W);
    if (dtx_bbw_clamp_normalise(w->W, c->nv, m, NULL) < 0)
        return dtx_seterr(e, DTX_ESOLVE, "key points: weights of the current set sum to 0");
    if ((st = cluster(c, m, w->W, k < c->nv ? k : c->nv, threads, w->labels, e)) != DTX_OK)
        return st;
    /* Every candidate of the round is fitted with this clustering, from
     * the same starting rotations. */
    dtx_skin_eval_free(&c->ev);
    if ((st = dtx_skin_eval_create(c->sm, w->labels, k, c->nframes, c->X, &c->skin, &c->ev, e)) !=
        DTX_OK)
        return st;
    c->ev_gen = c->gen;
    c->ev_k = k;
    return DTX_OK;
}

static dtx_status push_trace(dtx_kp_result *r, int32_t *cap, double v, dtx_error *err)
{
    if (r->ntrace == *cap) {
        int32_t nc = *cap ? 2 * *cap : 16;
        double *t = realloc(r->trace, (size_t)nc * sizeof *t);
        if (!t)
            return dtx_seterr(err, DTX_ENOMEM, "out of memory");
        r->trace = t;
        *cap = nc;
    }
    r->trace[r->ntrace++] = v;
    return DTX_OK;
}

/* One round of the search: the error errs[i] of every candidate i with k
 * key points (candidate i added, or put in place of key replace_j >= 0),
 * reduced over the parts, and *best the candidate with the least (-1 when
 * none).  Sets *reduce_failed when the reduction over the parts failed. */
static dtx_status score_round(kp_ctx *c, dtx_bbw_incr *incr, const int32_t *cand,
                              const unsigned char *inset, int replace_j, int32_t k, kp_work *ws,
                              int nthreads, const dtx_kp_params *p, unsigned char *mine,
                              double *errs, dtx_kp_result *res, int *reduce_failed, int32_t *best,
                              dtx_error *err)
{
    dtx_status st;
    if (!c->exact && (st = round_labels(c, incr, k, nthreads, &ws[0], err)) != DTX_OK)
        return st;
    if (!c->exact && c->gcache &&
        (st = gcache_fill(c, incr, cand, res->ncand, inset, ws, nthreads, p, errs, &res->solves,
                          reduce_failed, err)) != DTX_OK)
        return st;
    round_eval(c, incr, cand, res->ncand, inset, replace_j, ws, nthreads, p, mine, errs,
               &res->evaluations, &res->failed, &res->solves);
    if (p->part_count > 1 && (st = p->reduce(p->reduce_ctx, errs, res->ncand, 1, err)) != DTX_OK) {
        *reduce_failed = 1;
        return st;
    }
    *best = argmin(errs, res->ncand);
    return DTX_OK;
}

dtx_status dtx_keypoints_select(const dtx_mesh *src, int32_t nframes, const double *X,
                                const dtx_kp_params *p, dtx_kp_result *res, dtx_error *err)
{
    kp_ctx c;
    dtx_bbw_incr *incr = NULL;
    kp_work *ws = NULL;
    double *radius = NULL, *errs = NULL;
    unsigned char *inset = NULL, *mine = NULL;
    int32_t *cand = NULL, nfaced = 0, tcap = 0, mmax;
    int nthreads;
    dtx_status st = DTX_OK;
    int reduce_failed = 0; /* the failure came from p->reduce: every part knows */

    memset(res, 0, sizeof *res);
    memset(&c, 0, sizeof c);
    if (!src || !X || !p || nframes < 1)
        return dtx_seterr(err, DTX_EINVAL, "key points: missing mesh or frames");
    if (p->candidates < 1 || !(p->eps >= 0.0) || p->max_keys < 1 || p->max_sweeps < 0 ||
        p->part_count < 1 || p->part_index < 0 || p->part_index >= p->part_count ||
        (p->part_count > 1 && !p->reduce))
        return dtx_seterr(err, DTX_EINVAL,
                          "key points: parameters out of range (candidates >= 1, eps >= 0, "
                          "max_keys >= 1, max_sweeps >= 0, a reduce function for several parts)");
    if ((st = dtx_mesh_validate(src, "key points: source mesh", err)) != DTX_OK)
        return st;
    for (int64_t i = 0; i < (int64_t)nframes * 3 * src->nv; i++)
        if (!isfinite(X[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "key points: frame %lld, vertex %lld: non-finite coordinate",
                              (long long)(i / (3 * (int64_t)src->nv)),
                              (long long)(i % (3 * (int64_t)src->nv) / 3));
    c.src = src;
    c.nv = src->nv;
    c.nframes = nframes;
    c.X = X;
    c.skin = p->skin;
    c.exact = p->exact;
    c.radius = rest_radius(src);
    c.ev_gen = -1;
    if (!(c.radius > 0.0))
        return dtx_seterr(err, DTX_EMESH, "key points: the source mesh has no extent");
    nthreads = p->threads > 0 ? p->threads : omp_get_max_threads();

    /* Candidates: as many as requested and the mesh has. */
    {
        unsigned char *used = dtx_alloc((size_t)src->nv, 1, 1);
        if (!used) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            goto fail;
        }
        for (int64_t i = 0; i < 3 * (int64_t)src->nf; i++)
            used[src->F[i]] = 1;
        for (int32_t i = 0; i < src->nv; i++)
            nfaced += used[i];
        free(used);
    }
    res->ncand = p->candidates < nfaced ? p->candidates : nfaced;
    mmax = (p->max_keys < res->ncand ? p->max_keys : res->ncand) + 1;
    cand = dtx_alloc((size_t)res->ncand, sizeof *cand, 0);
    radius = dtx_alloc((size_t)res->ncand, sizeof *radius, 0);
    errs = dtx_alloc((size_t)res->ncand, sizeof *errs, 0);
    inset = dtx_alloc((size_t)res->ncand, 1, 1);
    mine = dtx_alloc((size_t)res->ncand, 1, 1);
    res->keys = dtx_alloc((size_t)mmax, sizeof *res->keys, 0);
    ws = dtx_alloc((size_t)nthreads, sizeof *ws, 1);
    if (!cand || !radius || !errs || !inset || !mine || !res->keys || !ws) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        goto fail;
    }
    res->candidates = cand;
    res->radius = c.radius;
    if ((st = dtx_farthest_points(src, res->ncand, cand, radius, err)) != DTX_OK)
        goto fail;

    /* Rest mesh and clustering features. */
    c.feat =
        dtx_alloc((size_t)src->nv, (size_t)DTX_SKIN_FEAT * (size_t)nframes * sizeof *c.feat, 0);
    if (!c.feat) {
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        goto fail;
    }
    c.skin.threads = nthreads;
    if ((st = dtx_skin_mesh_create(src->V, src->nv, src->F, src->nf, DTX_SKIN_COTAN, &c.sm, err)) !=
            DTX_OK ||
        (st = dtx_skin_features(c.sm, nframes, X, &c.skin, c.feat, err)) != DTX_OK)
        goto fail;

    /* The first set: c_1, and the first candidate of every further
     * component (infinitely far from the ones before): a component without
     * a key point cannot be skinned. */
    for (int32_t i = 0; i < res->ncand; i++)
        if (i == 0 || isinf(radius[i])) {
            if (res->count + 1 >= mmax) {
                st = dtx_seterr(err, DTX_EINVAL,
                                "key points: the source has more components than max_keys (%d)",
                                (int)p->max_keys);
                goto fail;
            }
            res->keys[res->count++] = cand[i];
            inset[i] = 1;
        }
    if ((st = dtx_bbw_incr_create(src, res->keys, res->count, &incr, err)) != DTX_OK)
        goto fail;
    if (!c.exact && (size_t)res->ncand * (size_t)c.nv <= KP_GCACHE_MAX) {
        /* Zeroed: the parts put rows together over spans that may hold
         * rows nobody solved (gcache_fill), which must be defined. */
        c.gcache = dtx_alloc((size_t)res->ncand * (size_t)c.nv, sizeof *c.gcache, 1);
        c.ggen = dtx_alloc((size_t)res->ncand, sizeof *c.ggen, 0);
        c.gverts = dtx_alloc((size_t)res->ncand, sizeof *c.gverts, 0);
        if (!c.gcache || !c.ggen || !c.gverts) { /* only slower without */
            free(c.gcache);
            free(c.ggen);
            free(c.gverts);
            c.gcache = NULL;
            c.ggen = NULL;
            c.gverts = NULL;
        }
        for (int32_t i = 0; c.ggen && i < res->ncand; i++)
            c.ggen[i] = -1;
    }
    for (int t = 0; t < nthreads; t++)
        if (work_alloc(&ws[t], &c, mmax, incr) != 0) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            goto fail;
        }
    if (c.exact)
        st = eval_exact(&c, res->keys, res->count, nthreads, &ws[0], &res->error, err);
    else if ((st = round_labels(&c, incr, res->count, nthreads, &ws[0], err)) == DTX_OK)
        st = eval_fast(&c, res->count, ws[0].W, &ws[0], &res->error, err);
    if (st != DTX_OK)
        goto fail;
    res->error_first = res->error;

    /* Stage 1: add while the error is above eps and a candidate lowers it. */
    while (res->error > p->eps && res->count < p->max_keys && res->count < res->ncand) {
        int32_t b;
        if ((st = score_round(&c, incr, cand, inset, -1, res->count + 1, ws, nthreads, p, mine,
                              errs, res, &reduce_failed, &b, err)) != DTX_OK)
            goto fail;
        if (b < 0 || !(errs[b] < res->error))
            break;
        if ((st = gcache_move(&c, incr, cand, res->ncand, inset, b, -1, nthreads, p, err)) !=
            DTX_OK)
            goto fail;
        if ((st = key_commit(&c, incr, cand, b, -1, ws, err)) != DTX_OK)
            goto fail;
        c.gen++;
        res->keys[res->count++] = cand[b];
        inset[b] = 1;
        res->error = errs[b];
        if ((st = push_trace(res, &tcap, errs[b], err)) != DTX_OK)
            goto fail;
    }

    /* Stage 2: replace each key point by a better candidate, sweep until
     * nothing changes.  A round depends only on the set and j, so when the
     * last replacement was key last_j's in the previous sweep and nothing
     * changed since, the rounds of keys after last_j would repeat that
     * sweep's, which changed nothing: the sweep ends there, as it would
     * have after them. */
    for (int sweep = 0, last_j = -1; sweep < p->max_sweeps; sweep++) {
        int changed = 0;
        res->sweeps = sweep + 1;
        for (int32_t j = 0; j < res->count; j++) {
            int32_t b, old;
            if (!changed && sweep > 0 && j > last_j)
                break;
            if ((st = score_round(&c, incr, cand, inset, (int)j, res->count, ws, nthreads, p, mine,
                                  errs, res, &reduce_failed, &b, err)) != DTX_OK)
                goto fail;
            if (b < 0 || !(errs[b] < res->error))
                continue;
            if ((st = gcache_move(&c, incr, cand, res->ncand, inset, b, (int)j, nthreads, p,
                                  err)) != DTX_OK)
                goto fail;
            if ((st = key_commit(&c, incr, cand, b, (int)j, ws, err)) != DTX_OK)
                goto fail;
            c.gen++;
            old = res->keys[j];
            for (int32_t i = 0; i < res->ncand; i++)
                if (cand[i] == old)
                    inset[i] = 0;
            res->keys[j] = cand[b];
            inset[b] = 1;
            res->error = errs[b];
            res->replacements++;
            changed = 1;
            last_j = j;
            if ((st = push_trace(res, &tcap, errs[b], err)) != DTX_OK)
                goto fail;
        }
        if (!changed)
            break;
    }

    /* The final set as the paper evaluates it. */
    if (c.exact)
        res->error_exact = res->error;
    else {
        if ((st = final_exact(&c, res->keys, res->count, nthreads, p, &ws[0], &res->error_exact,
                              &reduce_failed, err)) != DTX_OK)
            goto fail;
        res->weights = dtx_alloc((size_t)c.nv, (size_t)res->count * sizeof *res->weights, 0);
        if (!res->weights) {
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            goto fail;
        }
        memcpy(res->weights, ws[0].W, (size_t)c.nv * (size_t)res->count * sizeof *res->weights);
    }
    /* The closing call: a part that failed after the last round meets it. */
    if (p->part_count > 1 && (st = p->reduce(p->reduce_ctx, NULL, 0, 1, err)) != DTX_OK) {
        reduce_failed = 1;
        goto fail;
    }
    goto done;
fail:
    if (p->part_count > 1 && !reduce_failed) {
        /* Failed here alone (or everywhere alike): tell the other parts,
         * which wait in their next call, and stop with this part's error. */
        dtx_error e2;
        p->reduce(p->reduce_ctx, NULL, 0, 0, &e2);
    }
    res->candidates = NULL;
    free(cand);
    cand = NULL;
    dtx_kp_result_free(res);
done:
    if (st == DTX_OK)
        cand = NULL; /* owned by res */
    free(cand);
    for (int t = 0; ws && t < nthreads; t++)
        work_free(&ws[t]);
    free(ws);
    free(radius);
    free(errs);
    free(inset);
    free(mine);
    free(c.feat);
    dtx_skin_eval_free(&c.ev);
    free(c.gcache);
    free(c.ggen);
    free(c.gverts);
    dtx_skin_mesh_free(&c.sm);
    dtx_bbw_incr_free(&incr);
    return st;
}

dtx_status dtx_keypoints_error(const dtx_mesh *src, int32_t nframes, const double *X,
                               const int32_t *keys, int32_t m, const dtx_skin_params *skin,
                               double *error, dtx_error *err)
{
    kp_ctx c;
    kp_work w;
    dtx_status st;
    memset(&c, 0, sizeof c);
    if (!src || !X || !keys || m < 1 || nframes < 1 || !skin)
        return dtx_seterr(err, DTX_EINVAL, "key points: missing mesh, frames or key points");
    if ((st = dtx_mesh_validate(src, "key points: source mesh", err)) != DTX_OK)
        return st;
    c.src = src;
    c.nv = src->nv;
    c.nframes = nframes;
    c.X = X;
    c.skin = *skin;
    c.exact = 1;
    c.radius = rest_radius(src);
    if (!(c.radius > 0.0))
        return dtx_seterr(err, DTX_EMESH, "key points: the source mesh has no extent");
    if (work_alloc(&w, &c, m, NULL) != 0)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    c.feat =
        dtx_alloc((size_t)src->nv, (size_t)DTX_SKIN_FEAT * (size_t)nframes * sizeof *c.feat, 0);
    if (!c.feat)
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    else if ((st = dtx_skin_mesh_create(src->V, src->nv, src->F, src->nf, DTX_SKIN_COTAN, &c.sm,
                                        err)) == DTX_OK &&
             (st = dtx_skin_features(c.sm, nframes, X, &c.skin, c.feat, err)) == DTX_OK)
        st = eval_exact(&c, keys, m, c.skin.threads, &w, error, err);
    work_free(&w);
    free(c.feat);
    dtx_skin_mesh_free(&c.sm);
    return st;
}
