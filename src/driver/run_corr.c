/*
 * run_corr.c: phases 3b and 4 of `dtx run`: the key points of method
 * biharmonic (training frames, selection across the ranks), each target's
 * correspondence (found in the partial's or the old output's cache by its
 * key, else computed on the rank that owns the target, then broadcast)
 * and each target's key points through it.
 */
#include "run_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void corr_params_from_job(const dtx_job *job, dtx_corr_params *p)
{
    dtx_corr_params_default(p);
    p->w_smooth = job->sp04.w_smooth;
    p->w_identity = job->sp04.w_identity;
    p->n_closest = job->sp04.n_closest;
    for (int i = 0; i < job->sp04.n_closest && i < 16; i++)
        p->w_closest[i] = job->sp04.w_closest[i];
    p->max_distance = job->sp04.max_distance;
    p->max_angle_deg = job->sp04.max_angle_deg;
    p->weights = job->sp04.weights;
}

/* Broadcast of a correspondence from root (the other ranks allocate). */
static dtx_status bcast_corr(MPI_Comm comm, int root, dtx_corr *c, int32_t nv_s, dtx_error *err)
{
    int rank, has_def = c->deformed_src != NULL;
    long long np = c->npairs;
    int ok = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Bcast(&np, 1, MPI_LONG_LONG, root, comm);
    /* The multicomponent correspondence deforms the target instead; the
     * transfer needs only the pairs. */
    MPI_Bcast(&has_def, 1, MPI_INT, root, comm);
    if (rank != root) {
        dtx_corr_free(c);
        memset(c, 0, sizeof *c);
        c->npairs = np;
        c->nv_src = nv_s;
        c->pairs = dtx_alloc((size_t)np, 2 * sizeof *c->pairs, 0);
        c->deformed_src =
            has_def ? dtx_alloc((size_t)nv_s, 3 * sizeof *c->deformed_src, 0) : NULL;
        ok = c->pairs && (c->deformed_src || !has_def);
    }
    if (run_agree(comm, ok ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"), err) != DTX_OK)
        return err->code;
    /* Chunks below 2^31 elements for MPI's int counts. */
    for (long long off = 0; off < 2 * np; off += 1 << 30) {
        long long n = 2 * np - off < (1 << 30) ? 2 * np - off : (1 << 30);
        MPI_Bcast(c->pairs + off, (int)n, MPI_INT32_T, root, comm);
    }
    if (has_def)
        MPI_Bcast(c->deformed_src, 3 * nv_s, MPI_DOUBLE, root, comm);
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* 3b. Key points (method biharmonic)                                  */
/* ------------------------------------------------------------------ */

/* The cache key of a selection: everything that determines the key points
 * (and so their source weights, which the cache keeps with them). */
static void selection_key(const run_state *r, const dtx_kp_params *kp, char out[17])
{
    /* The version names the selection and the bounded weights it keeps:
     * change it with anything that changes their bits. */
    static const char tag[] = "dtx-keypoint-selection-v2";
    uint64_t h = DTX_HASH_INIT, hm = dtx_mesh_hash(&r->src);
    const dtx_skin_params *s = &kp->skin;
    h = dtx_hash_bytes(h, tag, sizeof tag);
    h = dtx_hash_bytes(h, &hm, sizeof hm);
    h = dtx_hash_bytes(h, &r->ntrain, sizeof r->ntrain);
    h = dtx_hash_bytes(h, r->Xtrain, (size_t)r->ntrain * 3 * (size_t)r->src.nv * sizeof *r->Xtrain);
    h = dtx_hash_bytes(h, &kp->candidates, sizeof kp->candidates);
    h = dtx_hash_bytes(h, &kp->eps, sizeof kp->eps);
    h = dtx_hash_bytes(h, &kp->max_keys, sizeof kp->max_keys);
    h = dtx_hash_bytes(h, &kp->max_sweeps, sizeof kp->max_sweeps);
    h = dtx_hash_bytes(h, &kp->exact, sizeof kp->exact);
    h = dtx_hash_bytes(h, &s->lambda, sizeof s->lambda);
    h = dtx_hash_bytes(h, &s->nclusters, sizeof s->nclusters);
    h = dtx_hash_bytes(h, &s->gamma_logr, sizeof s->gamma_logr);
    h = dtx_hash_bytes(h, &s->gamma_s, sizeof s->gamma_s);
    h = dtx_hash_bytes(h, &s->kmeans_iters, sizeof s->kmeans_iters);
    h = dtx_hash_bytes(h, &s->kmeans_seed, sizeof s->kmeans_seed);
    h = dtx_hash_bytes(h, &s->max_iters, sizeof s->max_iters);
    h = dtx_hash_bytes(h, &s->tol, sizeof s->tol);
    dtx_hash_hex(h, out);
}

/* A selection found in the cache: the key points are the handles of the
 * source weights stored under the selection's key (run_weights.c). */
static dtx_status cached_selection(run_state *r, int *found, dtx_error *err)
{
    int32_t m = 0, *keys = NULL;
    double *W = NULL;
    dtx_status st = run_weights_fetch(r, r->kp_key, r->src.nv, &m, NULL, &keys, &W, found, err);
    if (st != DTX_OK || !*found)
        return st;
    /* Distinct vertices of the source (the read checked the range). */
    for (int32_t i = 0; i < m && *found; i++)
        for (int32_t j = 0; j < i && *found; j++)
            *found = keys[i] != keys[j];
    if (!*found) {
        free(keys);
        free(W);
        return DTX_OK;
    }
    memset(&r->kp, 0, sizeof r->kp);
    r->kp.count = m;
    r->kp.keys = keys;
    r->kp.weights = W;
    r->kp_cached = 1;
    return DTX_OK;
}

/* Every rank reads the training frames (the clustering features of the
 * fit); with keypoints "auto" the ranks then select the key points on them
 * together, each evaluating its share of the candidates, unless the
 * partial or the old output holds the selection for the same inputs (the
 * source mesh, the training frames, the parameters): then the key points
 * and their source weights are read from there. */
dtx_status run_select_keypoints(run_state *r, dtx_error *err)
{
    double t0 = run_wtime();
    const dtx_h5_seq **seqs;
    const dtx_bh_job_params *bh = &r->job.bh;
    dtx_kp_params kp;
    dtx_status st = DTX_OK;
    if (!r->method->uses_keypoints)
        return DTX_OK;
    seqs = dtx_alloc((size_t)r->ns, sizeof *seqs, 0);
    if (!seqs)
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int s = 0; seqs && s < r->ns; s++)
        seqs[s] = &r->sq[s].seq;
    if (st == DTX_OK)
        st = dtx_read_training_frames(seqs, r->ns, bh->training_frames, &r->ntrain, &r->Xtrain,
                                      err);
    if (st == DTX_OK)
        dtx_weld_source_frames(&r->src_weld, r->Xtrain, r->ntrain);
    free(seqs);
    if (st != DTX_OK)
        dtx_error_prefix(err, "%s: training frames", r->job.source_file);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        return st;
    if (bh->keypoints != DTX_BH_KEYS_AUTO) {
        r->tm.keypoints += run_wtime() - t0;
        return DTX_OK;
    }
    dtx_kp_params_default(&kp);
    kp.candidates = bh->candidates;
    kp.eps = bh->eps;
    kp.max_keys = bh->max_keypoints;
    kp.skin.lambda = bh->transfer.skin.lambda;
    kp.skin.gamma_logr = bh->transfer.skin.gamma_logr;
    kp.skin.gamma_s = bh->transfer.skin.gamma_s;
    selection_key(r, &kp, r->kp_key);
    {
        int found = 0;
        if ((st = cached_selection(r, &found, err)) != DTX_OK)
            return st;
        if (found) {
            r->tm.keypoints += run_wtime() - t0;
            run_say(r,
                    "dtx: %d key points on %s:%s and their weights reused from the output's "
                    "cache (same source, training frames and parameters)",
                    (int)r->kp.count, r->job.source_file, r->job.source_mesh);
            return DTX_OK;
        }
    }
    run_say(r,
            "dtx: selecting key points on %s:%s from %d training frames (%d candidates, %d "
            "rank(s) x %d thread(s))",
            r->job.source_file, r->job.source_mesh, (int)r->ntrain, (int)kp.candidates, r->nranks,
            r->nthreads);
    st = dtx_keypoints_select_comm(&r->src, r->ntrain, r->Xtrain, &kp, r->comm, &r->kp, err);
    if (st != DTX_OK) {
        /* Every rank holds the same message: prefix it alike. */
        dtx_error_prefix(err, "%s:%s: key points", r->job.source_file, r->job.source_mesh);
        return st;
    }
    r->tm.keypoints += run_wtime() - t0;
    run_say(r, "dtx: key points selected in %.2f s", r->tm.keypoints);
    if (r->rank == 0 && !r->opts->quiet)
        dtx_keypoints_print_steps(stderr, "dtx:   ", &r->kp, bh->eps);
    return DTX_OK;
}

static dtx_status copy_markers(const dtx_markers *a, dtx_markers *b, dtx_error *err)
{
    dtx_status st = dtx_markers_alloc(b, a->n, err);
    for (int32_t i = 0; st == DTX_OK && i < a->n; i++) {
        const char *l = a->labels && a->labels[i] ? a->labels[i] : "";
        b->src[i] = a->src[i];
        b->tgt[i] = a->tgt[i];
        if (!(b->labels[i] = strdup(l)))
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    if (st != DTX_OK)
        dtx_markers_free(b);
    return st;
}

/* The key points of each target (every rank: cheap, and the same on
 * every rank): its markers (keypoints "markers"), or the selected key
 * points moved to the target vertex nearest to where the correspondence's
 * deformed source puts them (keypoints "auto"; a key point landing on a
 * target vertex already taken is dropped, with a warning).  Rank 0 prints
 * them as a table a user can check and edit. */
dtx_status run_target_keys(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    if (!r->method->uses_keypoints)
        return DTX_OK;
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        int32_t m = r->kp.count, *tv = NULL, *dup = NULL;
        snprintf(tc->kp_path, sizeof tc->kp_path, "/markers/%s-keypoints", tc->tj->name);
        if (r->job.bh.keypoints == DTX_BH_KEYS_MARKERS) {
            st = copy_markers(&tc->mk, &tc->keys, err);
            run_say(r, "dtx: target %s: its %d markers are the key points", tc->tj->name,
                    (int)tc->mk.n);
            continue;
        }
        tv = dtx_alloc((size_t)m, sizeof *tv, 0);
        dup = dtx_alloc((size_t)m, sizeof *dup, 0);
        st = tv && dup ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
        if (st == DTX_OK && !tc->corr.deformed_src)
            st = dtx_seterr(err, DTX_EINVAL, "no deformed source to map the key points with");
        if (st == DTX_OK)
            st = dtx_keypoints_map(tc->corr.deformed_src, r->src.nv, &tc->mesh, r->kp.keys, m,
                                   tv, dup, err);
        if (st == DTX_OK)
            st = dtx_keypoints_marker_set(&r->src, r->kp.keys, tv, dup, m, &tc->mk, &tc->keys,
                                          err);
        if (st == DTX_OK && r->rank == 0 && !r->opts->quiet) {
            for (int32_t k = 0; k < m; k++)
                if (dup[k] >= 0)
                    run_say(r,
                            "dtx: warning: target %s: key points %d and %d both map to target "
                            "vertex %d; key point %d is dropped",
                            tc->tj->name, (int)dup[k] + 1, (int)k + 1, (int)tv[k], (int)k + 1);
            fprintf(stderr,
                    "dtx: target %s: key points mapped through the sp04 correspondence "
                    "(stored as marker set %s; edit and use it with keypoints \"markers\"):\n",
                    tc->tj->name, tc->kp_path);
            dtx_keypoints_print_table(stderr, "dtx:   ", &r->src, r->kp.keys, m, &tc->mk, tv,
                                      dup);
        }
        free(tv);
        free(dup);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tc->tj->name, tc->tj->file,
                             tc->tj->mesh);
    }
    return run_agree(r->comm, st, err);
}

/* ------------------------------------------------------------------ */
/* 4. Correspondences                                                  */
/* ------------------------------------------------------------------ */

/* Rank 0: correspondences whose key matches one in the cache file. */
static void find_cached(run_state *r, const char *cache, int *reused)
{
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    if (!cache || access(cache, R_OK) != 0 ||
        dtx_h5_open(cache, MPI_COMM_NULL, 0, &f, &e) != DTX_OK)
        return;
    for (int t = 0; t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        char *group = NULL;
        dtx_h5_corr c;
        if (reused[t])
            continue;
        memset(&c, 0, sizeof c);
        if (dtx_h5_find_corr_by_key(f, tc->key, &group, &e) == DTX_OK && group &&
            dtx_h5_read_corr(f, group, r->src.nv, r->src.nf, tc->mesh.nf, &c, &e) == DTX_OK &&
            c.deformed_src) {
            memset(&tc->corr, 0, sizeof tc->corr);
            tc->corr.npairs = c.npairs;
            tc->corr.pairs = c.pairs;
            tc->corr.deformed_src = c.deformed_src;
            tc->corr.nv_src = c.nv_s;
            c.pairs = NULL;
            c.deformed_src = NULL;
            reused[t] = 1;
        }
        dtx_h5_corr_free(&c); /* what was not taken (none when the read failed) */
        free(group);
    }
    dtx_h5_close(&f, NULL);
}

/* Targets to compute go to ranks biggest first, each onto the rank with the
 * least work so far (ties: the lowest rank), so several targets are
 * corresponded at once. */
static void assign_owners(run_state *r, const int *reused)
{
    double *load = calloc((size_t)r->nranks, sizeof *load);
    int *done = calloc((size_t)r->nt, sizeof *done);
    for (int t = 0; t < r->nt; t++)
        r->tg[t].owner = 0;
    if (!load || !done) {
        free(load);
        free(done);
        return; /* everything on rank 0: slower, still right */
    }
    for (;;) {
        int best = -1, q = 0;
        double cost = 0;
        for (int t = 0; t < r->nt; t++) {
            double c = (double)r->tg[t].mesh.nf + (double)r->src.nf;
            if (!reused[t] && !done[t] && (best < 0 || c > cost)) {
                best = t;
                cost = c;
            }
        }
        if (best < 0)
            break;
        for (int k = 1; k < r->nranks; k++)
            if (load[k] < load[q])
                q = k;
        r->tg[best].owner = q;
        load[q] += cost;
        done[best] = 1;
    }
    free(load);
    free(done);
}

dtx_status run_correspondences(run_state *r, dtx_error *err)
{
    double t0 = run_wtime();
    dtx_status st = DTX_OK;
    dtx_corr_params prm;
    int *reused, ncomputed = 0;
    char use[200] = "";
    /* Markers as key points need no correspondence. */
    if (!run_uses_correspondence(r))
        return DTX_OK;
    reused = calloc((size_t)r->nt, sizeof *reused);
    if (run_agree(r->comm, reused ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"), err) !=
        DTX_OK) {
        free(reused);
        return err->code;
    }
    /* reused[t]: 0 to compute, 1 found in a cache, 2 not needed (springs
     * onto a target of the source's connectivity), 3 (RUN_CORR_STORE) taken
     * from the correspondence store (run_store.c). */
    for (int t = 0; t < r->nt; t++)
        reused[t] = r->tg[t].same_conn ? 2 : 0;
    /* The partial of an interrupted run holds correspondences too, even
     * when it is discarded.  Only sp04's are looked up: a cached one is
     * read with its deformed source, which the multicomponent one has
     * not (the store, looked up next, holds both kinds). */
    if (r->rank == 0 && r->method->correspondence == DTX_TRANSFER_CORR_SP04) {
        find_cached(r, r->partial, reused);
        find_cached(r, r->job.output_file, reused);
    }
    run_store_lookup(r, reused);
    MPI_Bcast(reused, r->nt, MPI_INT, 0, r->comm);
    assign_owners(r, reused);
    corr_params_from_job(&r->job, &prm);
    st = run_injected_fault(r, "correspondence", err);
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        tc->reused = reused[t] == 2 ? RUN_CORR_COMPUTED : reused[t];
        ncomputed += !reused[t];
        if (reused[t] || tc->owner != r->rank)
            continue;
        if (r->method->correspondence == DTX_TRANSFER_CORR_MULTICOMPONENT)
            st = dtx_mc_correspond(&r->src, &tc->mesh, &tc->mk, &prm, r->job.mc.eps_factor,
                                   &tc->corr, err);
        else
            st = dtx_sp04_correspond(&r->src, &tc->mesh, &tc->mk, &prm, &tc->corr, err);
        if (st != DTX_OK)
            dtx_error_prefix(err, "target \"%s\" (%s:%s)", tc->tj->name, tc->tj->file,
                             tc->tj->mesh);
    }
    free(reused);
    if (run_agree(r->comm, st, err) != DTX_OK)
        return err->code;
    for (int t = 0; t < r->nt; t++)
        if (!r->tg[t].same_conn &&
            (st = bcast_corr(r->comm, r->tg[t].owner, &r->tg[t].corr, r->src.nv, err)) != DTX_OK)
            return st;
    r->tm.correspond += run_wtime() - t0;
    if (r->method->uses_proxy)
        snprintf(use, sizeof use,
                 " (the %s solve on the source deformed by it, a proxy of the target)",
                 r->method->name);
    for (int t = 0; t < r->nt; t++)
        if (r->tg[t].same_conn)
            run_say(r, "dtx: target %s: the source's vertices and faces: no correspondence needed",
                    r->tg[t].tj->name);
        else
            run_say(r, "dtx: target %s: correspondence %s: %lld triangle pairs%s",
                    r->tg[t].tj->name,
                    r->tg[t].reused == RUN_CORR_STORE    ? "taken from the store"
                    : r->tg[t].reused == RUN_CORR_CACHED ? "reused from the output's cache"
                                                         : "computed",
                    (long long)r->tg[t].corr.npairs, use);
    if (ncomputed > 1 && r->nranks > 1)
        run_say(r, "dtx: %d correspondences computed on %d ranks in %.2f s", ncomputed,
                ncomputed < r->nranks ? ncomputed : r->nranks, r->tm.correspond);
    return run_store_save(r, err);
}
