/*
 * fuzz_h5common.h: what the two HDF5 harnesses share: a scratch folder, a
 * complete dtx file to start from, and the checks run on a file after the
 * fuzzer has changed it (validator, then every reader of the layout).
 */
#ifndef DTX_FUZZ_H5COMMON_H
#define DTX_FUZZ_H5COMMON_H

#include "fuzz_util.h"
#include "h5layout.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { FZ_T = 3, FZ_NV = 4, FZ_NV2 = 5 };

static char fz_dir[256];
static char fz_path[300];

static inline void fz_cleanup(void)
{
    char p[320];
    snprintf(p, sizeof p, "%s/base.h5", fz_dir);
    unlink(p);
    unlink(fz_path);
    rmdir(fz_dir);
}

/* A scratch folder of this process: under $DTX_FUZZ_TMP (scripts/fuzz.sh
 * sets it, and removes it after the run, so that folders of processes
 * killed for a timeout do not pile up), else /dev/shm or /tmp. */
static inline void fz_make_dir(void)
{
    const char *top = getenv("DTX_FUZZ_TMP");
    if (!top || !top[0])
        top = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    FUZZ_ASSERT(strlen(top) < sizeof fz_dir - 20);
    snprintf(fz_dir, sizeof fz_dir, "%s/dtx-fuzz-XXXXXX", top);
    FUZZ_ASSERT(mkdtemp(fz_dir) != NULL);
    snprintf(fz_path, sizeof fz_path, "%s/input.h5", fz_dir);
    atexit(fz_cleanup);
}

static inline void fz_mesh(dtx_mesh *m, int32_t nv, double scale)
{
    /* A fan around vertex 0: nv - 2 triangles. */
    FUZZ_ASSERT(dtx_mesh_alloc(m, nv, nv - 2, NULL) == DTX_OK);
    for (int32_t i = 0; i < nv; i++) {
        m->V[3 * i] = scale * cos(0.5 * i);
        m->V[3 * i + 1] = scale * sin(0.5 * i);
        m->V[3 * i + 2] = 0.1 * i;
    }
    for (int32_t f = 0; f < nv - 2; f++) {
        m->F[3 * f] = 0;
        m->F[3 * f + 1] = f + 1;
        m->F[3 * f + 2] = f + 2;
    }
}

#define FZ_OK(call)                                            \
    do {                                                       \
        dtx_error e_;                                          \
        if ((call) != DTX_OK) {                                \
            fprintf(stderr, "%s failed: %s\n", #call, e_.msg); \
            abort();                                           \
        }                                                      \
    } while (0)

/* Writes a complete file at path: two meshes, a sequence, markers, a
 * correspondence, two results (one filed under a namespace group) and an
 * interrupted one. */
static inline void fz_make_good(const char *path)
{
    dtx_mesh cat, lion;
    dtx_markers mk;
    dtx_h5_seq s;
    dtx_h5_result r;
    hid_t f;
    double X[FZ_T * FZ_NV * 3], Y[FZ_T * FZ_NV2 * 3], res[FZ_T];
    int32_t pairs[4] = {0, 0, 1, 2};
    const char *names[FZ_T] = {"a.obj", "b.obj", "c.obj"};
    dtx_h5_corr_meta meta = {"0123456789abcdef", "/meshes/cat", "/meshes/lion", "/markers/cat-lion",
                             "{\"w\": 1}"};
    dtx_h5_provenance prov = {"sp04",         "{\"dtx_job\": 1}",  "{\"w\": 1}", "/sequences/walk",
                              "/meshes/lion", "/correspondences/c"};
    fz_mesh(&cat, FZ_NV, 1.0);
    fz_mesh(&lion, FZ_NV2, 2.0);
    for (int i = 0; i < FZ_T * FZ_NV * 3; i++)
        X[i] = sin(0.1 * i);
    for (int i = 0; i < FZ_T * FZ_NV2 * 3; i++)
        Y[i] = cos(0.1 * i);
    for (int t = 0; t < FZ_T; t++)
        res[t] = 0.5 * t;
    FZ_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &e_));
    FZ_OK(dtx_h5_write_mesh(f, "/meshes/cat", &cat, "cat.obj", &e_));
    FZ_OK(dtx_h5_write_mesh(f, "/meshes/lion", &lion, "lion.obj", &e_));
    FZ_OK(dtx_h5_seq_create(f, "/sequences/walk", "/meshes/cat", FZ_T, FZ_NV, 0, 2, 1, &s, &e_));
    FZ_OK(dtx_h5_seq_write(&s, 0, FZ_T, X, 0, &e_));
    FZ_OK(dtx_h5_write_frame_names(&s, names, FZ_T, &e_));
    FZ_OK(dtx_h5_seq_commit(&s, &e_));
    dtx_h5_seq_close(&s);
    FUZZ_ASSERT(dtx_markers_alloc(&mk, 2, NULL) == DTX_OK);
    mk.src[0] = 0, mk.tgt[0] = 0, mk.src[1] = 3, mk.tgt[1] = 4;
    FZ_OK(dtx_h5_write_markers(f, "/markers/cat-lion", &mk, "/meshes/cat", "/meshes/lion", &e_));
    FZ_OK(dtx_h5_write_corr(f, "/correspondences/c", pairs, 2, cat.V, FZ_NV, &meta, &e_));
    FZ_OK(dtx_h5_result_create(f, "/results/lion", &prov, FZ_T, FZ_NV2, 0, 2, 0, &r, &e_));
    FZ_OK(dtx_h5_result_write(&r, 0, FZ_T, Y, res, 0, &e_));
    FZ_OK(dtx_h5_result_finish(&r, 0, &e_));
    dtx_h5_result_close(&r);
    FZ_OK(
        dtx_h5_result_create(f, "/results/by-target/walk", &prov, FZ_T, FZ_NV2, 1, 0, 0, &r, &e_));
    FZ_OK(dtx_h5_result_write(&r, 0, FZ_T, Y, res, 0, &e_));
    FZ_OK(dtx_h5_result_finish(&r, 0, &e_));
    dtx_h5_result_close(&r);
    FZ_OK(dtx_h5_result_create(f, "/results/lion2", &prov, FZ_T, FZ_NV2, 0, 2, 0, &r, &e_));
    FZ_OK(dtx_h5_result_write(&r, 0, 1, Y, res, 0, &e_));
    dtx_h5_result_close(&r); /* interrupted: stays as /results/.dtx-tmp-lion2 */
    FZ_OK(dtx_h5_close(&f, &e_));
    dtx_markers_free(&mk);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
}

static inline void fz_write_file(const char *path, const void *data, size_t size)
{
    FILE *fp = fopen(path, "wb");
    FUZZ_ASSERT(fp != NULL);
    FUZZ_ASSERT(size == 0 || fwrite(data, 1, size, fp) == size);
    FUZZ_ASSERT(fclose(fp) == 0);
}

static inline void *fz_read_file(const char *path, size_t *size)
{
    FILE *fp = fopen(path, "rb");
    void *buf;
    long n;
    FUZZ_ASSERT(fp != NULL);
    FUZZ_ASSERT(fseek(fp, 0, SEEK_END) == 0 && (n = ftell(fp)) > 0 && fseek(fp, 0, SEEK_SET) == 0);
    buf = malloc((size_t)n);
    FUZZ_ASSERT(buf != NULL && fread(buf, 1, (size_t)n, fp) == (size_t)n);
    fclose(fp);
    *size = (size_t)n;
    return buf;
}

/* The groups of the good file, each with the reader that opens it. */
typedef enum { FZ_MESH, FZ_SEQ, FZ_MARKERS, FZ_CORR, FZ_RESULT } fz_kind;
static const struct {
    const char *path;
    fz_kind kind;
} fz_groups[] = {
    {"/meshes/cat", FZ_MESH},
    {"/meshes/lion", FZ_MESH},
    {"/sequences/walk", FZ_SEQ},
    {"/markers/cat-lion", FZ_MARKERS},
    {"/correspondences/c", FZ_CORR},
    {"/results/lion", FZ_RESULT},
    {"/results/by-target/walk", FZ_RESULT},
};
#define FZ_NGROUPS (sizeof fz_groups / sizeof fz_groups[0])

/* Reads group g with its reader; returns the status, checking that a
 * failure is clean.  Data is read too (bounded), as the driver would. */
static inline dtx_status fz_read_group(hid_t f, size_t g, dtx_error *e)
{
    static const dtx_status allowed[] = {DTX_EFORMAT, DTX_ERANGE,     DTX_EIO,
                                         DTX_EPARSE,  DTX_ENONFINITE, DTX_EINVAL,
                                         DTX_EMESH,   DTX_ENOMEM,     DTX_OK};
    const char *path = fz_groups[g].path;
    dtx_status st = DTX_OK;
    char fname[256];
    dtx_h5_filename(f, fname, sizeof fname);
    memset(e, 0, sizeof *e);
    switch (fz_groups[g].kind) {
    case FZ_MESH: {
        dtx_mesh m;
        int32_t nv, nf;
        memset(&m, 0, sizeof m);
        st = dtx_h5_mesh_size(f, path, &nv, &nf, e);
        if (st == DTX_OK)
            st = dtx_h5_read_mesh(f, path, &m, e);
        if (st == DTX_OK) {
            FUZZ_ASSERT(m.nv == nv && m.nf == nf);
            FUZZ_ASSERT(dtx_mesh_validate(&m, path, e) == DTX_OK);
        }
        dtx_mesh_free(&m);
        break;
    }
    case FZ_SEQ: {
        dtx_h5_seq s;
        char **names = NULL;
        memset(&s, 0, sizeof s);
        st = dtx_h5_seq_open(f, path, &s, e);
        if (st == DTX_OK) {
            FUZZ_ASSERT(s.nframes >= 0 && s.nv >= 0);
            if (s.nframes > 0 && s.nv > 0 && s.nv <= 4096) {
                double *buf = malloc((size_t)s.nv * 3 * sizeof *buf);
                FUZZ_ASSERT(buf != NULL);
                st = dtx_h5_seq_read(&s, s.nframes - 1, 1, buf, e);
                free(buf);
            }
            if (st == DTX_OK) {
                st = dtx_h5_read_frame_names(&s, &names, e);
                if (st == DTX_OK)
                    dtx_h5_free_strings(&names, s.nframes);
            }
        }
        dtx_h5_seq_close(&s);
        break;
    }
    case FZ_MARKERS: {
        dtx_markers mk;
        st = dtx_h5_read_markers(f, path, &mk, e);
        if (st == DTX_OK) {
            for (int32_t i = 0; i < mk.n; i++)
                FUZZ_ASSERT(mk.src[i] >= 0 && mk.tgt[i] >= 0 && mk.labels[i]);
            dtx_markers_free(&mk);
        }
        break;
    }
    case FZ_CORR: {
        dtx_h5_corr c;
        st = dtx_h5_read_corr(f, path, -1, -1, -1, &c, e);
        if (st == DTX_OK)
            dtx_h5_corr_free(&c);
        break;
    }
    case FZ_RESULT: {
        dtx_h5_result r;
        memset(&r, 0, sizeof r);
        st = dtx_h5_result_open(f, path, 0, &r, e);
        if (st == DTX_OK && r.nframes > 0 && r.nv > 0 && r.nv <= 4096) {
            double *buf = malloc((size_t)r.nv * 3 * sizeof *buf), resid;
            uint8_t *done = malloc((size_t)r.nframes);
            FUZZ_ASSERT(buf != NULL && done != NULL);
            st = dtx_h5_result_read(&r, 0, 1, buf, &resid, e);
            if (st == DTX_OK)
                st = dtx_h5_result_read_done(&r, done, e);
            free(buf);
            free(done);
        }
        dtx_h5_result_close(&r);
        break;
    }
    }
    if (st != DTX_OK)
        fuzz_check_error(st, e, fname, allowed);
    return st;
}

/* Validates the file at path and then opens it and reads every group of
 * the good file.  Properties: the validator fails cleanly (a report and a
 * message naming the file), and when it passes the file, every reader
 * accepts the groups it checked. */
static inline void fz_check_file(const char *path, int expect_hdf5)
{
    static const dtx_status vallowed[] = {DTX_EFORMAT, DTX_EIO, DTX_ENOMEM, DTX_OK};
    char *report = NULL;
    dtx_error e;
    dtx_status st;
    hid_t f = H5I_INVALID_HID;

    memset(&e, 0, sizeof e);
    st = dtx_h5_validate(path, &report, &e);
    if (st != DTX_OK)
        fuzz_check_error(st, &e, path, vallowed);
    FUZZ_ASSERT(report != NULL || st == DTX_EIO || st == DTX_ENOMEM);
    FUZZ_ASSERT(st != DTX_OK || strstr(report, "valid dtx layout") != NULL);
    if (expect_hdf5)
        FUZZ_ASSERT(st != DTX_EIO);
    if (getenv("DTX_FUZZ_VERBOSE")) /* to see what the inputs exercise */
        fprintf(stderr, "validate: %s: %s\n", dtx_status_name(st), st ? e.msg : "ok");
    free(report);

    if (dtx_h5_open(path, MPI_COMM_NULL, 0, &f, &e) != DTX_OK) {
        FUZZ_ASSERT(st != DTX_OK);
        return;
    }
    for (size_t g = 0; g < FZ_NGROUPS; g++) {
        dtx_status rs;
        if (!dtx_h5_path_exists(f, fz_groups[g].path))
            continue;
        rs = fz_read_group(f, g, &e);
        if (getenv("DTX_FUZZ_VERBOSE"))
            fprintf(stderr, "  read %s: %s: %s\n", fz_groups[g].path, dtx_status_name(rs),
                    rs ? e.msg : "ok");
        if (st == DTX_OK && rs != DTX_OK) {
            fprintf(stderr, "validator passed the file but the reader says: %s\n", e.msg);
            FUZZ_ASSERT(!"validator and reader disagree");
        }
    }
    FUZZ_ASSERT(dtx_h5_close(&f, &e) == DTX_OK);
}

#endif /* DTX_FUZZ_H5COMMON_H */
