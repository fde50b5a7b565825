/* test_h5frames.c: frames and faces from HDF5 files other programs wrote
 * (src/io/h5frames.c).  The same 4 frames of 5 vertices are stored in each
 * of the six axis orders (float64 and float32, contiguous and chunked with
 * gzip) and as 2-D single frames; every block of frames read through each
 * order must give the values in (frame, vertex, coordinate) order.  Then the
 * rejections: a bad axis order, a coordinate axis that is not 3, integer
 * positions, a dataset never written, a missing dataset or a group; faces
 * that are floats, of another shape, out of range; and the wildcard lister
 * (datasets only, sorted, by pattern). */
#include "check.h"
#include "h5frames.h"
#include "h5layout.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

enum { NT = 4, NV = 5 };

static double value(int t, int v, int c) { return t * 100 + v * 10 + c + 0.5; }

/* Writes dataset name with the axis order `axes` (3 letters of T, V, C, or
 * 2 of V, C) holding value(t, v, c); type H5T_NATIVE_DOUBLE written into a
 * file type ftype; chunked with gzip when gzip. */
static void put(hid_t f, const char *name, const char *axes, hid_t ftype, int gzip)
{
    int nd = (int)strlen(axes), ext[3] = {NT, NV, 3};
    hsize_t dims[3];
    double buf[NT * NV * 3];
    hid_t sp, dcpl = H5Pcreate(H5P_DATASET_CREATE), d;
    for (int k = 0; k < nd; k++)
        dims[k] = (hsize_t)ext[axes[k] == 'T' ? 0 : axes[k] == 'V' ? 1 : 2];
    for (int i = 0; i < (int)(dims[0] * dims[1] * (nd == 3 ? dims[2] : 1)); i++) {
        int idx[3], rem = i, tvc[3] = {0, 0, 0};
        for (int k = nd - 1; k >= 0; k--) {
            idx[k] = rem % (int)dims[k];
            rem /= (int)dims[k];
        }
        for (int k = 0; k < nd; k++)
            tvc[axes[k] == 'T' ? 0 : axes[k] == 'V' ? 1 : 2] = idx[k];
        buf[i] = value(tvc[0], tvc[1], tvc[2]);
    }
    if (gzip) {
        hsize_t ch[3] = {2, 2, 2};
        H5Pset_chunk(dcpl, nd, ch);
        H5Pset_deflate(dcpl, 4);
    }
    sp = H5Screate_simple(nd, dims, NULL);
    d = H5Dcreate2(f, name, ftype, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    CHECK(d >= 0);
    CHECK(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) >= 0);
    H5Dclose(d);
    H5Sclose(sp);
    H5Pclose(dcpl);
}

static void put_ints(hid_t f, const char *name, hid_t ftype, int rows, int cols, const int *v)
{
    hsize_t dims[2] = {(hsize_t)rows, (hsize_t)cols};
    hid_t sp = H5Screate_simple(2, dims, NULL);
    hid_t d = H5Dcreate2(f, name, ftype, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(H5Dwrite(d, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0);
    H5Dclose(d);
    H5Sclose(sp);
}

/* Every block [first, first + count) of dataset name read with axes gives
 * the values. */
static void expect_frames(hid_t f, const char *name, const char *axes, int nt)
{
    dtx_h5_frames fr;
    dtx_error err;
    double out[NT * NV * 3];
    dtx_status st = dtx_h5_frames_open(f, "t.h5", name, axes, &fr, &err);
    CHECK_EQ_INT(st, DTX_OK);
    if (st != DTX_OK) {
        fprintf(stderr, "  %s %s: %s\n", name, axes ? axes : "(default)", err.msg);
        return;
    }
    CHECK_EQ_INT(fr.nframes, nt);
    CHECK_EQ_INT(fr.nv, NV);
    for (int first = 0; first < nt; first++)
        for (int count = 1; first + count <= nt; count++) {
            int bad = -1;
            CHECK_EQ_INT(dtx_h5_frames_read(&fr, first, count, out, &err), DTX_OK);
            for (int i = 0; i < count * NV * 3 && bad < 0; i++)
                if (out[i] != value(first + i / (NV * 3), i / 3 % NV, i % 3))
                    bad = i;
            if (bad >= 0)
                fprintf(stderr, "  %s %s frames %d+%d: value %d is %g\n", name, axes, first, count,
                        bad, out[bad]);
            CHECK(bad < 0);
        }
    /* Frames beyond the end are refused, not read. */
    CHECK_EQ_INT(dtx_h5_frames_read(&fr, nt - 1, 2, out, &err), DTX_EINVAL);
    dtx_h5_frames_close(&fr);
    dtx_h5_frames_close(&fr); /* closing twice is harmless */
}

static void expect_open_fail(hid_t f, const char *name, const char *axes, const char *what)
{
    dtx_h5_frames fr;
    dtx_error err;
    dtx_status st = dtx_h5_frames_open(f, "t.h5", name, axes, &fr, &err);
    CHECK(st != DTX_OK);
    CHECK(fr.dset < 0);
    if (st != DTX_OK && !strstr(err.msg, what)) {
        CHECK(strstr(err.msg, what) != NULL);
        fprintf(stderr, "  message \"%s\" lacks \"%s\"\n", err.msg, what);
    }
}

static void expect_faces_fail(hid_t f, const char *name, const char *what)
{
    dtx_error err;
    int32_t nf = -1, *F = (int32_t *)&nf;
    dtx_status st = dtx_h5_read_faces(f, "t.h5", name, NV, &nf, &F, &err);
    CHECK(st != DTX_OK);
    CHECK(F == NULL);
    if (st != DTX_OK && !strstr(err.msg, what)) {
        CHECK(strstr(err.msg, what) != NULL);
        fprintf(stderr, "  message \"%s\" lacks \"%s\"\n", err.msg, what);
    }
}

int main(void)
{
    static const char *const orders[6] = {"TVC", "TCV", "VTC", "VCT", "CTV", "CVT"};
    char path[512], name[64];
    dtx_error err;
    hid_t f;
    dtx_h5_init();
    mkdir(DTX_TEST_SCRATCH, 0777);
    snprintf(path, sizeof path, "%s/t.h5", DTX_TEST_SCRATCH);
    f = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(f >= 0);
    for (int k = 0; k < 6; k++) {
        snprintf(name, sizeof name, "/d64_%s", orders[k]);
        put(f, name, orders[k], H5T_IEEE_F64BE, 0);
        snprintf(name, sizeof name, "/d32_%s", orders[k]);
        put(f, name, orders[k], H5T_IEEE_F32LE, 1);
    }
    put(f, "/one_VC", "VC", H5T_IEEE_F32LE, 0);
    put(f, "/one_CV", "CV", H5T_IEEE_F64LE, 0);
    {
        const int faces[6] = {0, 1, 2, 2, 3, 4}, bad[6] = {0, 1, 2, 2, 3, 5};
        const int quads[8] = {0, 1, 2, 3, 1, 2, 3, 4};
        put_ints(f, "/faces", H5T_STD_I32LE, 2, 3, faces);
        put_ints(f, "/faces_u8", H5T_STD_U8LE, 2, 3, faces);
        put_ints(f, "/faces_range", H5T_STD_I64BE, 2, 3, bad);
        put_ints(f, "/faces_quads", H5T_STD_I32LE, 2, 4, quads);
        put_ints(f, "/ints", H5T_STD_I32LE, 2, 3, faces);
    }
    {
        /* Positions declared but never written. */
        hsize_t dims[3] = {NT, NV, 3};
        hid_t sp = H5Screate_simple(3, dims, NULL);
        H5Dclose(
            H5Dcreate2(f, "/unwritten", H5T_IEEE_F32LE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
        H5Sclose(sp);
        H5Gclose(H5Gcreate2(f, "/group", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
        put(f, "/group/b_TVC", "TVC", H5T_IEEE_F32LE, 0);
        put(f, "/group/a_TVC", "TVC", H5T_IEEE_F32LE, 0);
        H5Gclose(H5Gcreate2(f, "/group/a_sub", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    }
    H5Fclose(f);

    CHECK_EQ_INT(dtx_h5_foreign_open(path, &f, &err), DTX_OK);
    /* ---- every axis order, both types, contiguous and chunked */
    for (int k = 0; k < 6; k++) {
        snprintf(name, sizeof name, "/d64_%s", orders[k]);
        expect_frames(f, name, orders[k], NT);
        snprintf(name, sizeof name, "d32_%s", orders[k]); /* relative path too */
        expect_frames(f, name, orders[k], NT);
    }
    expect_frames(f, "/d32_TVC", NULL, NT); /* default TVC */
    expect_frames(f, "/one_VC", NULL, 1);   /* default VC for 2-D */
    expect_frames(f, "/one_CV", "CV", 1);

    /* ---- rejections */
    expect_open_fail(f, "/d64_VCT", NULL,
                     "shape (5 x 3 x 4) with axis order TVC has 4 coordinates per vertex, not 3");
    expect_open_fail(f, "/d64_VCT", "VCX", "use each of T (frames), V (vertices) and C");
    expect_open_fail(f, "/d64_VCT", "VVT", "use each of T");
    expect_open_fail(f, "/d64_VCT", "VC", "has 2 letters but the dataset has 3 dimensions");
    expect_open_fail(f, "/one_VC", "VT", "V and C");
    expect_open_fail(f, "/ints", "VC",
                     "t.h5:/ints: expected floating-point positions, found integer");
    expect_open_fail(
        f, "/unwritten", NULL,
        "t.h5:/unwritten: shape 4 x 5 x 3 needs 240 bytes, but only 0 bytes are stored");
    expect_open_fail(f, "/nothing", NULL, "t.h5:/nothing: no such dataset");
    expect_open_fail(f, "/group", NULL, "t.h5:/group: not a dataset");

    /* ---- faces */
    {
        int32_t nf = 0, *F = NULL;
        CHECK_EQ_INT(dtx_h5_read_faces(f, "t.h5", "/faces", NV, &nf, &F, &err), DTX_OK);
        CHECK_EQ_INT(nf, 2);
        CHECK(F && F[0] == 0 && F[2] == 2 && F[5] == 4);
        free(F);
        F = NULL;
        CHECK_EQ_INT(dtx_h5_read_faces(f, "t.h5", "/faces_u8", NV, &nf, &F, &err), DTX_OK);
        CHECK(F && F[4] == 3);
        free(F);
    }
    expect_faces_fail(
        f, "/faces_range",
        "faces t.h5:/faces_range: face 1 (0-based): vertex index 5 out of range [0, 5)");
    expect_faces_fail(f, "/faces_quads", "shape (2 x 4): expected (faces, 3)");
    expect_faces_fail(f, "/d64_TVC",
                      "expected integer vertex indices, found floating-point values");
    expect_faces_fail(f, "/nofaces", "faces t.h5:/nofaces: no such dataset");

    /* ---- the wildcard lister: datasets only, sorted, matching */
    {
        char **p = NULL;
        int n = -1;
        CHECK_EQ_INT(dtx_h5_match_datasets(f, "t.h5", "/group", "*", &p, &n, &err), DTX_OK);
        CHECK_EQ_INT(n, 2); /* a_sub is a group */
        CHECK(n == 2 && strcmp(p[0], "/group/a_TVC") == 0 && strcmp(p[1], "/group/b_TVC") == 0);
        for (int i = 0; i < n; i++)
            free(p[i]);
        free(p);
        CHECK_EQ_INT(dtx_h5_match_datasets(f, "t.h5", "group", "b*", &p, &n, &err), DTX_OK);
        CHECK(n == 1 && strcmp(p[0], "/group/b_TVC") == 0);
        for (int i = 0; i < n; i++)
            free(p[i]);
        free(p);
        CHECK_EQ_INT(dtx_h5_match_datasets(f, "t.h5", "/", "d32_?V?", &p, &n, &err), DTX_OK);
        CHECK_EQ_INT(n, 2); /* d32_CVT, d32_TVC */
        CHECK(n == 2 && strcmp(p[0], "//d32_CVT") != 0 && strcmp(p[0], "/d32_CVT") == 0);
        for (int i = 0; i < n; i++)
            free(p[i]);
        free(p);
        CHECK_EQ_INT(dtx_h5_match_datasets(f, "t.h5", "/", "zz*", &p, &n, &err), DTX_OK);
        CHECK(n == 0 && p == NULL);
        CHECK_EQ_INT(dtx_h5_match_datasets(f, "t.h5", "/nogroup", "*", &p, &n, &err), DTX_EFORMAT);
    }
    H5Fclose(f);

    /* ---- files that cannot be opened */
    {
        char notdir[600];
        FILE *fp;
        snprintf(notdir, sizeof notdir, "%s/not.h5", DTX_TEST_SCRATCH);
        fp = fopen(notdir, "w");
        fputs("not hdf5\n", fp);
        fclose(fp);
        CHECK_EQ_INT(dtx_h5_foreign_open(notdir, &f, &err), DTX_EFORMAT);
        CHECK(strstr(err.msg, "not an HDF5 file") != NULL);
        snprintf(notdir, sizeof notdir, "%s/missing.h5", DTX_TEST_SCRATCH);
        CHECK_EQ_INT(dtx_h5_foreign_open(notdir, &f, &err), DTX_EIO);
        CHECK(strstr(err.msg, "no such file or directory") != NULL);
    }
    return check_report();
}
