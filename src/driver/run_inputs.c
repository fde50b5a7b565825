/*
 * run_inputs.c: phases 1 and 2 of `dtx run`, loading the job (rank 0 reads
 * and checks it, every rank parses the same text) and reading the inputs
 * on every rank: the source mesh, the sequences (wildcards expanded), the
 * targets and their markers; then the run's key, which a partial output
 * must carry to be continued.
 */
#include "run_internal.h"

#include "file_util.h"
#include "meshfile.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* A mesh split along seams (vertices at the position of another) is welded
 * for the solve; its results keep every vertex of the asset. */
static void say_welded(run_state *r, const char *role, const char *what, const dtx_weld_ctx *w)
{
    int n = (int)(w->nv - w->nw);
    run_say(r,
            "dtx: %s mesh %s: %d %s at the position of another vertex (seams) welded for the "
            "solve; results keep its %d vertices, twins moving together",
            role, what, n, n == 1 ? "vertex" : "vertices", (int)w->nv);
}

/* ------------------------------------------------------------------ */
/* Inputs                                                              */
/* ------------------------------------------------------------------ */

static dtx_status read_mesh_from(const char *file, const char *group, dtx_mesh *m,
                                 dtx_error *err)
{
    hid_t f = H5I_INVALID_HID;
    dtx_status st = dtx_h5_open(file, MPI_COMM_NULL, 0, &f, err);
    if (st != DTX_OK)
        return st;
    st = dtx_h5_read_mesh(f, group, m, err);
    dtx_h5_close(&f, NULL);
    return st;
}

static dtx_status read_markers(const dtx_job_target *t, dtx_markers *mk, dtx_error *err)
{
    dtx_status st;
    if (t->markers.csv)
        return dtx_markers_read_csv(t->markers.csv, t->markers.index_base, mk, err);
    if (t->markers.file) {
        hid_t f = H5I_INVALID_HID;
        st = dtx_h5_open(t->markers.file, MPI_COMM_NULL, 0, &f, err);
        if (st != DTX_OK)
            return st;
        st = dtx_h5_read_markers(f, t->markers.path, mk, err);
        dtx_h5_close(&f, NULL);
        return st;
    }
    return dtx_seterr(err, DTX_EJOB, "target \"%s\": no markers given", t->name);
}

/* The cache key of a correspondence: everything that determines it.  The
 * tag names the computation: change it when the same inputs give another
 * correspondence, so that caches and stores of the old one are not reused
 * (v2: geometry normalised by dtx_rms_extent, before by the bounding-box
 * diagonal; v3: E_I and E_C weighted by area by default). */
static void corr_key(const dtx_mesh *src, const dtx_mesh *tgt, const dtx_markers *mk,
                     const char *params, char out[17])
{
    uint64_t h = DTX_HASH_INIT, hs = dtx_mesh_hash(src), ht = dtx_mesh_hash(tgt);
    static const char tag[] = "dtx-sp04-correspondence-v3";
    h = dtx_hash_bytes(h, tag, sizeof tag);
    h = dtx_hash_bytes(h, &hs, sizeof hs);
    h = dtx_hash_bytes(h, &ht, sizeof ht);
    h = dtx_hash_bytes(h, &mk->n, sizeof mk->n);
    h = dtx_hash_bytes(h, mk->src, (size_t)mk->n * sizeof *mk->src);
    h = dtx_hash_bytes(h, mk->tgt, (size_t)mk->n * sizeof *mk->tgt);
    h = dtx_hash_bytes(h, params, strlen(params));
    dtx_hash_hex(h, out);
}

/* ------------------------------------------------------------------ */
/* 1. The job                                                          */
/* ------------------------------------------------------------------ */

dtx_status run_load_job(MPI_Comm comm, const char *path, dtx_job *job, dtx_error *err)
{
    int rank;
    dtx_status st = DTX_OK;
    long long len = 0;
    char *text = NULL;
    MPI_Comm_rank(comm, &rank);
    memset(job, 0, sizeof *job);
    if (rank == 0) {
        st = dtx_job_load(path, job, err);
        if (st == DTX_OK)
            len = (long long)strlen(job->text);
    }
    if (run_agree(comm, st, err) != DTX_OK) {
        dtx_job_free(job);
        return err->code;
    }
    /* The other ranks parse the very text rank 0 read. */
    MPI_Bcast(&len, 1, MPI_LONG_LONG, 0, comm);
    if (rank != 0) {
        char dir[4096];
        const char *slash = strrchr(path, '/');
        size_t dn = slash ? (size_t)(slash - path) : 0;
        text = malloc((size_t)len + 1);
        if (dn >= sizeof dir)
            dn = sizeof dir - 1;
        memcpy(dir, path, dn);
        dir[dn] = '\0';
        if (!slash)
            strcpy(dir, ".");
        if (text) {
            MPI_Bcast(text, (int)len, MPI_CHAR, 0, comm);
            text[len] = '\0';
            st = dtx_job_parse(text, (size_t)len, path, dir, 0, job, err);
            if (st == DTX_OK && !job->job_path)
                job->job_path = strdup(path);
        } else {
            char dummy;
            MPI_Bcast(&dummy, 0, MPI_CHAR, 0, comm);
            st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
        }
        free(text);
    } else {
        MPI_Bcast(job->text, (int)len, MPI_CHAR, 0, comm);
    }
    if (run_agree(comm, st, err) != DTX_OK) {
        dtx_job_free(job);
        return err->code;
    }
    return DTX_OK;
}

/* ------------------------------------------------------------------ */
/* 2. Inputs (every rank, read-only)                                   */
/* ------------------------------------------------------------------ */

/* The job's sequence list with every entry whose last component is "*"
 * (a wildcard) replaced by the groups directly under its parent group, in
 * name order: r->seq_paths[0 .. r->ns). */
static dtx_status expand_sequences(run_state *r, dtx_error *err)
{
    int64_t n = 0, cap = 0;
    dtx_status st = DTX_OK;
    for (int32_t i = 0; i < r->job.nsequences && st == DTX_OK; i++) {
        const char *p = r->job.sequences[i];
        size_t len = strlen(p);
        char **names = NULL, parent[DTX_H5_PATH_MAX];
        int64_t nn = 1;
        if (len >= 2 && strcmp(p + len - 2, "/*") == 0) {
            snprintf(parent, sizeof parent, "%.*s", (int)(len - 2), p);
            if (!parent[0])
                strcpy(parent, "/");
            st = dtx_h5_list_groups(r->src_file, parent, &names, &nn, err);
            if (st == DTX_OK && nn == 0)
                st = dtx_seterr(err, DTX_EJOB, "%s: /source/sequences/%d: %s has no groups in %s",
                                r->job.job_path ? r->job.job_path : "job", (int)i, parent,
                                r->job.source_file);
            if (st != DTX_OK)
                break;
        }
        if (n + nn > cap) {
            int64_t nc = (n + nn) * 2;
            char **q = realloc(r->seq_paths, (size_t)nc * sizeof *q);
            if (!q) {
                dtx_h5_free_strings(&names, nn);
                st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
                break;
            }
            r->seq_paths = q;
            cap = nc;
        }
        for (int64_t k = 0; k < nn && st == DTX_OK; k++) {
            char full[DTX_H5_PATH_MAX];
            int plen = names ? snprintf(full, sizeof full, "%s/%s",
                                       strcmp(parent, "/") ? parent : "", names[k])
                            : snprintf(full, sizeof full, "%s", p);
            if (plen < 0 || (size_t)plen >= sizeof full)
                st = dtx_seterr(err, DTX_EJOB, "%s: sequence path %s/%s is too long",
                                r->job.source_file, parent, names ? names[k] : "");
            else if (!(r->seq_paths[n] = strdup(full)))
                st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
            else
                n++;
        }
        dtx_h5_free_strings(&names, nn);
    }
    r->ns = (int)n;
    if (st == DTX_OK && n > INT_MAX / 2)
        st = dtx_seterr(err, DTX_EJOB, "too many sequences");
    return st;
}

static dtx_status read_sequences(run_state *r, dtx_error *err)
{
    dtx_status st = expand_sequences(r, err);
    if (st == DTX_OK && !(r->sq = calloc((size_t)r->ns, sizeof *r->sq)))
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK && !(r->rs = dtx_alloc((size_t)r->nt * (size_t)r->ns, sizeof *r->rs, 1)))
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int s = 0; s < r->ns && st == DTX_OK; s++) {
        seq_ctx *sc = &r->sq[s];
        sc->path = r->seq_paths[s];
        sc->name = dtx_path_base_name(sc->path);
        for (int s2 = 0; s2 < s; s2++)
            if (strcmp(r->sq[s2].name, sc->name) == 0)
                return dtx_seterr(err, DTX_EJOB,
                                  "%s: /source/sequences: %s and %s would both give results "
                                  "named \"%s\" (results are named after the last component "
                                  "of the sequence path)",
                                  r->job.job_path ? r->job.job_path : "job", r->sq[s2].path,
                                  sc->path, sc->name);
        st = dtx_h5_seq_open(r->src_file, sc->path, &sc->seq, err);
        if (st != DTX_OK)
            break;
        sc->open = 1;
        if (sc->seq.nframes < 1)
            st = dtx_seterr(err, DTX_EFORMAT, "%s: %s has no frames (0 frames); a sequence needs "
                            "at least 1", r->job.source_file, sc->path);
        else if (sc->seq.nv != r->src_weld.nv)
            st = dtx_seterr(err, DTX_EFORMAT,
                            "%s: %s has %d vertices per frame but the source mesh %s has %d",
                            r->job.source_file, sc->path, (int)sc->seq.nv, r->job.source_mesh,
                            (int)r->src_weld.nv);
    }
    return st;
}

/* Mesh checks beyond dtx_mesh_validate (which the reader ran): what sp04
 * cannot use is an error, what it accepts but a user may not expect is a
 * warning from rank 0.  Every rank checks, so every rank fails alike.  A
 * target must be one connected piece: sp04 fixes a single translation, so a
 * second piece would float (a singular system), and saying so here is
 * cheaper than failing after the correspondence. */
static dtx_status check_mesh(run_state *r, const char *file, const char *path,
                             const dtx_mesh *m, int is_target, dtx_error *err)
{
    dtx_mesh_report rep;
    char notes[1024], seams[200] = "";
    dtx_status st = dtx_mesh_inspect(m, &rep, err);
    if (st != DTX_OK)
        return st;
    if (rep.duplicate_positions > 0)
        snprintf(seams, sizeof seams,
                 "; %d of its vertices sit at the position of another vertex (vertices %d and "
                 "%d first): split along seams? a weld_tolerance >= 0 welds them",
                 (int)rep.duplicate_positions, (int)rep.dup_vertex[0], (int)rep.dup_vertex[1]);
    /* A method that takes several pieces may still need sp04's
     * correspondence, which does not (biharmonic's keypoints "auto"). */
    if (is_target && rep.components > 1 && r->method->multi_component_target &&
        r->method->correspondence == DTX_TRANSFER_CORR_SP04 && run_uses_correspondence(r))
        return dtx_seterr(err, DTX_EMESH,
                          "%s:%s: the target mesh has %d connected components (vertex %d is not "
                          "connected to vertex %d) and the sp04 correspondence that maps "
                          "keypoints \"auto\" needs one (give every piece key points with "
                          "keypoints \"markers\")%s",
                          file, path, (int)rep.components, (int)rep.other_component,
                          (int)m->F[0], seams);
    if (is_target && rep.components > 1 && !r->method->multi_component_target)
        return dtx_seterr(err, DTX_EMESH,
                          "%s:%s: the target mesh has %d connected components (vertex %d is not "
                          "connected to vertex %d) and method %s needs one (separate pieces "
                          "need method \"multicomponent\", or one target per piece)%s",
                          file, path, (int)rep.components, (int)rep.other_component, (int)m->F[0],
                          r->method->name, seams);
    if (dtx_mesh_report_notes(&rep, notes, sizeof notes) > 0)
        run_say(r, "dtx: warning: %s mesh %s:%s: %s; accepted", is_target ? "target" : "source",
                file, path, notes);
    return DTX_OK;
}

/* 1 when tgt has src's vertex count and the same faces in the same order. */
static int same_connectivity(const dtx_mesh *src, const dtx_mesh *tgt)
{
    return src->nv == tgt->nv && src->nf == tgt->nf &&
           memcmp(src->F, tgt->F, (size_t)src->nf * 3 * sizeof *src->F) == 0;
}

static dtx_status read_targets(run_state *r, const char *params, dtx_error *err)
{
    dtx_status st = DTX_OK;
    for (int t = 0; t < r->nt && st == DTX_OK; t++) {
        target_ctx *tc = &r->tg[t];
        char what[4400];
        tc->tj = &r->job.targets[t];
        snprintf(tc->mesh_path, sizeof tc->mesh_path, "/meshes/%s", tc->tj->name);
        snprintf(tc->corr_path, sizeof tc->corr_path, "/correspondences/%s", tc->tj->name);
        /* Messages about the markers name where they came from. */
        if (tc->tj->markers.csv)
            snprintf(what, sizeof what, "%s (markers of target \"%s\")", tc->tj->markers.csv,
                     tc->tj->name);
        else
            snprintf(what, sizeof what, "%s:%s (markers of target \"%s\")",
                     tc->tj->markers.file ? tc->tj->markers.file : "?",
                     tc->tj->markers.path ? tc->tj->markers.path : "?", tc->tj->name);
        st = read_mesh_from(tc->tj->file, tc->tj->mesh, &tc->mesh, err);
        if (st == DTX_OK) {
            char wwhat[4400];
            snprintf(wwhat, sizeof wwhat, "%s:%s", tc->tj->file, tc->tj->mesh);
            st = dtx_weld_setup(&tc->mesh, tc->tj->weld_tolerance, wwhat, &tc->weld, err);
            if (st == DTX_OK && tc->weld.nw < tc->weld.nv)
                say_welded(r, "target", wwhat, &tc->weld);
        }
        if (st == DTX_OK)
            st = check_mesh(r, tc->tj->file, tc->tj->mesh, &tc->mesh, 1, err);
        if (st == DTX_OK && r->method->uses_proxy) {
            tc->same_conn = same_connectivity(&r->src, &tc->mesh);
            if (tc->same_conn) {
                /* The paper's setting: vertex i of the target is vertex i
                 * of the source; markers would add nothing. */
                if (tc->tj->markers.csv || tc->tj->markers.file)
                    run_say(r,
                            "dtx: target %s has the source's vertices and faces: its markers "
                            "are not needed and not used",
                            tc->tj->name);
                corr_key(&r->src, &tc->mesh, &tc->mk, params, tc->key);
                continue;
            }
            if (!tc->tj->markers.csv && !tc->tj->markers.file)
                st = dtx_seterr(err, DTX_EJOB,
                                "%s: target \"%s\" (%s:%s): has %d vertices and %d faces, not "
                                "the source's %d and %d with the same faces, so method %s "
                                "needs its markers (for the sp04 correspondence that deforms "
                                "the source into a proxy of the target)",
                                r->job.job_path ? r->job.job_path : "job", tc->tj->name,
                                tc->tj->file, tc->tj->mesh, (int)tc->mesh.nv, (int)tc->mesh.nf,
                                (int)r->src.nv, (int)r->src.nf, r->method->name);
        }
        if (st == DTX_OK)
            st = read_markers(tc->tj, &tc->mk, err);
        if (st == DTX_OK)
            st = dtx_markers_validate(&tc->mk, r->src_weld.nv, tc->weld.nv, what, err);
        if (st == DTX_OK) /* markers name the assets' vertices */
            dtx_weld_markers(&tc->mk, &r->src_weld, &tc->weld);
        if (st == DTX_OK)
            st = dtx_markers_check_referenced(&tc->mk, &r->src, what, err);
        if (st == DTX_OK)
            corr_key(&r->src, &tc->mesh, &tc->mk, params, tc->key);
    }
    return st;
}

/* The key of the whole run: the job text and everything read from the
 * inputs.  A partial output continues only a run with the same key. */
static void compute_run_key(run_state *r)
{
    static const char tag[] = "dtx-run-v1";
    uint64_t h = DTX_HASH_INIT, hs = dtx_mesh_hash(&r->src);
    struct stat sb;
    h = dtx_hash_bytes(h, tag, sizeof tag);
    h = dtx_hash_bytes(h, r->job.text, strlen(r->job.text));
    h = dtx_hash_bytes(h, &hs, sizeof hs);
    for (int t = 0; t < r->nt; t++)
        h = dtx_hash_bytes(h, r->tg[t].key, 16);
    for (int s = 0; s < r->ns; s++) {
        int64_t shape[2] = {r->sq[s].seq.nframes, r->sq[s].seq.nv};
        h = dtx_hash_bytes(h, r->sq[s].path, strlen(r->sq[s].path) + 1);
        h = dtx_hash_bytes(h, shape, sizeof shape);
    }
    /* The frames themselves are not hashed (too big): a source file that
     * was rewritten since shows in its size and modification time. */
    if (stat(r->job.source_file, &sb) == 0) {
        int64_t id[3] = {(int64_t)sb.st_size, (int64_t)sb.st_mtim.tv_sec,
                         (int64_t)sb.st_mtim.tv_nsec};
        h = dtx_hash_bytes(h, id, sizeof id);
    }
    dtx_hash_hex(h, r->run_key);
}

dtx_status run_read_inputs(run_state *r, dtx_error *err)
{
    dtx_status st = DTX_OK;
    double t0 = run_wtime();
    char *params;
    /* The cache key of a correspondence covers its own parameters only
     * (sp04's for the methods that build on sp04's correspondence), so
     * changing a method's own parameters does not recompute it. */
    params = dtx_job_corr_params_json(&r->job, r->method->correspondence);
    r->nt = r->job.ntargets;
    r->tg = calloc((size_t)r->nt, sizeof *r->tg);
    if (!params || !r->tg)
        st = dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK)
        st = dtx_h5_open(r->job.source_file, MPI_COMM_NULL, 0, &r->src_file, err);
    if (st == DTX_OK)
        st = dtx_h5_read_mesh(r->src_file, r->job.source_mesh, &r->src, err);
    if (st == DTX_OK) {
        char wwhat[4400];
        snprintf(wwhat, sizeof wwhat, "%s:%s", r->job.source_file, r->job.source_mesh);
        st = dtx_weld_setup(&r->src, r->job.source_weld_tolerance, wwhat, &r->src_weld, err);
        if (st == DTX_OK && r->src_weld.nw < r->src_weld.nv)
            say_welded(r, "source", wwhat, &r->src_weld);
    }
    if (st == DTX_OK)
        st = check_mesh(r, r->job.source_file, r->job.source_mesh, &r->src, 0, err);
    if (st == DTX_OK)
        st = read_targets(r, params, err);
    if (st == DTX_OK)
        st = read_sequences(r, err);
    if (st == DTX_OK)
        compute_run_key(r);
    if (st == DTX_OK)
        st = run_injected_fault(r, "read", err);
    free(params);
    r->tm.read += run_wtime() - t0;
    return run_agree(r->comm, st, err);
}
