/*
 * run_weights.c: the bounded biharmonic weights of method biharmonic, once
 * per run, shared out over the ranks and cached in the output.
 *
 * A target's plan needs the weights of its key points on the source and on
 * the target (bbw.h), the slow part of building it.  They are found, in
 * this order:
 *  - source weights of the selected key points: the key-point selection's
 *    closing evaluation already holds them (or the cache gave them with the
 *    key points, run_corr.c);
 *  - weights an earlier target of this run has with the same key;
 *  - a group /weights/<name> of OUTPUT.partial or OUTPUT whose key matches
 *    (as correspondences are found again: a re-run or a resumed run with
 *    unchanged inputs does not solve again; a changed mesh or key point
 *    changes the key);
 *  - else they are computed: the m handles of a mesh are dealt out to the
 *    ranks as each asks for its next (dtx_mpi_dealer; the programmes take
 *    unequal times, so a fixed split left one rank waiting), the rows are
 *    gathered on every rank, and every rank normalises them alike
 *    (dtx_bbw_handles_claim, dtx_bbw_normalise): bitwise what one rank
 *    computing everything would get, at any number of ranks and threads.
 * This runs before the output is created, so the new partial stores every
 * target's weights (/weights/TARGET-source, /weights/TARGET-target) for the
 * next run.
 */
#include "run_internal.h"

#include "bbw.h"
#include "mpi_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* MPI counts are ints: broadcast in pieces. */
static void bcast_doubles(double *x, size_t n, MPI_Comm comm)
{
    for (size_t off = 0; off < n; off += (size_t)1 << 30) {
        size_t k = n - off < ((size_t)1 << 30) ? n - off : ((size_t)1 << 30);
        MPI_Bcast(x + off, (int)k, MPI_DOUBLE, 0, comm);
    }
}

/* The weights (nv x m) of handles on mesh, computed by the ranks
 * together.  Collective; every rank gets the same bits or the same error.
 * The handles are dealt out as the ranks ask for them (dtx_mpi_dealer:
 * their programmes take unequal times), the rows of the others left at
 * +INFINITY, and an element-wise minimum over the ranks puts the rows
 * together: each row is the bits of the one rank that solved it. */
static dtx_status shared_bbw(run_state *r, const dtx_mesh *mesh, const int32_t *handles,
                             int32_t m, double **W, dtx_error *err)
{
    size_t nv = (size_t)mesh->nv, n = nv * (size_t)m;
    double *Wk = dtx_alloc(nv, (size_t)m * sizeof *Wk, 0);
    dtx_mpi_dealer dealer;
    dtx_status st;

    *W = dtx_alloc(nv, (size_t)m * sizeof **W, 0);
    st = Wk && *W ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto fail;
    if (r->nranks == 1) {
        st = dtx_bbw_handles(mesh, handles, m, 0, m, NULL, Wk, NULL, err);
    } else {
        for (size_t i = 0; i < n; i++)
            Wk[i] = INFINITY;
        if ((st = dtx_mpi_dealer_open(&dealer, r->comm, err)) != DTX_OK)
            goto fail;
        st = dtx_bbw_handles_claim(mesh, handles, m, dtx_mpi_dealer_claim, &dealer, NULL, Wk,
                                   NULL, err);
        dtx_mpi_dealer_close(&dealer);
    }
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto fail;
    /* MPI counts are ints: in pieces. */
    for (size_t off = 0; r->nranks > 1 && off < n; off += (size_t)1 << 30) {
        size_t k = n - off < ((size_t)1 << 30) ? n - off : ((size_t)1 << 30);
        MPI_Allreduce(MPI_IN_PLACE, Wk + off, (int)k, MPI_DOUBLE, MPI_MIN, r->comm);
    }
    st = dtx_bbw_normalise(mesh, handles, m, Wk, NULL, *W, NULL, err);
    if ((st = run_agree(r->comm, st, err)) != DTX_OK)
        goto fail;
    free(Wk);
    return DTX_OK;
fail:
    free(Wk);
    free(*W);
    *W = NULL;
    return st;
}

void run_weights_key(const dtx_mesh *mesh, const int32_t *handles, int32_t m, char out[17])
{
    /* The version names the computation (dtx_bbw with its defaults): change
     * it with anything that changes the weights' bits, or old caches would
     * be taken for new ones. */
    static const char tag[] = "dtx-bounded-biharmonic-weights-v2";
    uint64_t h = DTX_HASH_INIT, hm = dtx_mesh_hash(mesh);
    h = dtx_hash_bytes(h, tag, sizeof tag);
    h = dtx_hash_bytes(h, &hm, sizeof hm);
    h = dtx_hash_bytes(h, &m, sizeof m);
    h = dtx_hash_bytes(h, handles, (size_t)m * sizeof *handles);
    dtx_hash_hex(h, out);
}

/* Rank 0: the weights with this key in one cache file, or 0. */
static int lookup_in(const char *path, const char *key, int32_t nv, int32_t *m,
                     const int32_t *handles, int32_t **found_handles, double **W)
{
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    char *group = NULL;
    dtx_h5_weights w;
    int ok = 0;
    if (!path || access(path, R_OK) != 0 || dtx_h5_open(path, MPI_COMM_NULL, 0, &f, &e) != DTX_OK)
        return 0;
    /* A group that does not read back cleanly is a miss: recomputed. */
    if (dtx_h5_find_weights_by_key(f, key, &group, &e) == DTX_OK && group &&
        dtx_h5_read_weights(f, group, nv, &w, &e) == DTX_OK) {
        ok = (*m <= 0 || w.m == *m) &&
             (!handles || memcmp(handles, w.handles, (size_t)w.m * sizeof *handles) == 0);
        if (ok) {
            *m = w.m;
            *W = w.weights;
            *found_handles = w.handles;
            w.weights = NULL;
            w.handles = NULL;
        }
        dtx_h5_weights_free(&w);
    }
    free(group);
    dtx_h5_close(&f, NULL);
    return ok;
}

/* Rank 0: OUTPUT.partial first (an interrupted run's), then OUTPUT. */
static int lookup(run_state *r, const char *key, int32_t nv, int32_t *m, const int32_t *handles,
                  int32_t **found_handles, double **W)
{
    return lookup_in(r->partial, key, nv, m, handles, found_handles, W) ||
           lookup_in(r->job.output_file, key, nv, m, handles, found_handles, W);
}

dtx_status run_weights_fetch(run_state *r, const char *key, int32_t nv, int32_t *m,
                             const int32_t *handles, int32_t **found_handles, double **W,
                             int *found, dtx_error *err)
{
    int32_t hdr[2] = {0, *m};
    dtx_status st = DTX_OK;
    *found = 0;
    *found_handles = NULL;
    *W = NULL;
    if (r->rank == 0)
        hdr[0] = lookup(r, key, nv, &hdr[1], handles, found_handles, W);
    MPI_Bcast(hdr, 2, MPI_INT32_T, 0, r->comm);
    if (!hdr[0])
        return DTX_OK;
    if (r->rank != 0) {
        *found_handles = dtx_alloc((size_t)hdr[1], sizeof **found_handles, 0);
        *W = dtx_alloc((size_t)nv, (size_t)hdr[1] * sizeof **W, 0);
        if (!*found_handles || !*W)
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    if ((st = run_agree(r->comm, st, err)) != DTX_OK) {
        free(*found_handles);
        free(*W);
        *found_handles = NULL;
        *W = NULL;
        return st;
    }
    MPI_Bcast(*found_handles, (int)hdr[1], MPI_INT32_T, 0, r->comm);
    bcast_doubles(*W, (size_t)nv * (size_t)hdr[1], r->comm);
    *m = hdr[1];
    *found = 1;
    return DTX_OK;
}

static int same_keys(const int32_t *a, int32_t na, const int32_t *b, int32_t nb)
{
    return a && b && na == nb && memcmp(a, b, (size_t)na * sizeof *a) == 0;
}

static double *copy_of(const double *W, size_t n)
{
    double *c = dtx_alloc(n, sizeof *c, 0);
    if (c)
        memcpy(c, W, n * sizeof *c);
    return c;
}

/* The weights of handles (m) on mesh with this key, into *W: an earlier
 * target's (earlier[t].key equal), a cache file's, or computed.  *from
 * says which. */
static dtx_status weights_of(run_state *r, int t, int source, const dtx_mesh *mesh,
                             const int32_t *handles, int32_t m, const char *key, double **W,
                             int *cached, const char **from, dtx_error *err)
{
    size_t n = (size_t)mesh->nv * (size_t)m;
    int32_t mm = m, *fh = NULL;
    int found;
    dtx_status st;
    *cached = 0;
    for (int u = 0; u < t; u++) {
        const target_ctx *o = &r->tg[u];
        const char *k = source ? o->ws_key : o->wt_key;
        const double *w = source ? o->Ws : o->Wt;
        if (w && strcmp(k, key) == 0) {
            *W = copy_of(w, n);
            *cached = source ? o->ws_cached : o->wt_cached;
            *from = "as for an earlier target";
            return run_agree(r->comm, *W ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"),
                             err);
        }
    }
    if ((st = run_weights_fetch(r, key, mesh->nv, &mm, handles, &fh, W, &found, err)) != DTX_OK)
        return st;
    free(fh);
    if (found) {
        *cached = 1;
        *from = "reused from the output's cache";
        return DTX_OK;
    }
    *from = "computed";
    return shared_bbw(r, mesh, handles, m, W, err);
}

dtx_status run_bh_weights(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    if (!r->method->uses_keypoints)
        return DTX_OK;
    for (int t = 0; t < r->nt; t++) {
        target_ctx *tc = &r->tg[t];
        int32_t m = tc->keys.n;
        double t0 = run_wtime();
        const char *src_from = "computed", *tgt_from = "computed";
        int selected = same_keys(tc->keys.src, m, r->kp.keys, r->kp.count);
        if (selected)
            memcpy(tc->ws_key, r->kp_key, sizeof tc->ws_key);
        else
            run_weights_key(&r->src, tc->keys.src, m, tc->ws_key);
        run_weights_key(&tc->mesh, tc->keys.tgt, m, tc->wt_key);
        if (selected && r->kp.weights) {
            tc->Ws = copy_of(r->kp.weights, (size_t)r->src.nv * (size_t)m);
            tc->ws_cached = r->kp_cached;
            src_from = r->kp_cached ? "reused from the output's cache with the key points"
                                    : "from the key-point selection";
            st = run_agree(r->comm,
                           tc->Ws ? DTX_OK : dtx_seterr(err, DTX_ENOMEM, "out of memory"), err);
        } else {
            st = weights_of(r, t, 1, &r->src, tc->keys.src, m, tc->ws_key, &tc->Ws,
                            &tc->ws_cached, &src_from, err);
        }
        if (st != DTX_OK) {
            dtx_error_prefix(err, "target %s: biharmonic: source weights", tc->tj->name);
            return st;
        }
        st = weights_of(r, t, 0, &tc->mesh, tc->keys.tgt, m, tc->wt_key, &tc->Wt,
                        &tc->wt_cached, &tgt_from, err);
        if (st != DTX_OK) {
            dtx_error_prefix(err, "target %s: biharmonic: target weights", tc->tj->name);
            return st;
        }
        r->tm.factor += run_wtime() - t0;
        run_say(r,
                "dtx: target %s: bounded biharmonic weights of %d key points in %.2f s (source "
                "%s, target %s; handles shared over %d rank(s) x %d thread(s))",
                tc->tj->name, (int)m, run_wtime() - t0, src_from, tgt_from, r->nranks,
                r->nthreads);
    }
    return DTX_OK;
}

dtx_status run_weights_write(run_state *r, hid_t f, dtx_error *err)
{
    char srcdesc[4200];
    dtx_status st = DTX_OK;
    /* The meshes the weights are on, as the job names them (a target in
     * the output is its asset, which may have more vertices than the
     * welded mesh the weights are on). */
    snprintf(srcdesc, sizeof srcdesc, "%s:%s", r->job.source_file, r->job.source_mesh);
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        const target_ctx *tc = &r->tg[t];
        char path[DTX_H5_PATH_MAX], tgtdesc[4200];
        snprintf(tgtdesc, sizeof tgtdesc, "%s:%s", tc->tj->file, tc->tj->mesh);
        if (!tc->Ws || !tc->Wt)
            continue;
        snprintf(path, sizeof path, "/weights/%s-source", tc->tj->name);
        st = dtx_h5_write_weights(f, path, tc->keys.src, tc->keys.n, tc->Ws, r->src.nv,
                                  tc->ws_key, srcdesc, err);
        snprintf(path, sizeof path, "/weights/%s-target", tc->tj->name);
        if (st == DTX_OK)
            st = dtx_h5_write_weights(f, path, tc->keys.tgt, tc->keys.n, tc->Wt, tc->mesh.nv,
                                      tc->wt_key, tgtdesc, err);
    }
    return st;
}

void run_bh_weights_free(run_state *r)
{
    for (int t = 0; r->tg && t < r->nt; t++) {
        free(r->tg[t].Ws);
        free(r->tg[t].Wt);
        r->tg[t].Ws = r->tg[t].Wt = NULL;
    }
}
