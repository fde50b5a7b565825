/* test_h5mpi.c: the MPI-IO path of the HDF5 layout.  Runs on any number
 * of ranks (ctest starts it as a singleton: MPI_Init without mpirun gives
 * one rank); frames are split among ranks on chunk boundaries, and the
 * result is read back serially and validated. */
#include "check.h"
#include "h5layout.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define PATH DTX_TEST_SCRATCH "/mpi.h5"

enum { T = 11, NV = 4, CHUNK = 2 };

static double value(int64_t t, int i, int k)
{
    return cos(0.3 * (double)t + 0.7 * i + 0.05 * k) + t;
}

/* Frames [first, first+count) of rank r of n: whole chunks, remainders to
 * the first ranks. */
static void my_frames(int r, int n, int64_t *first, int64_t *count)
{
    int64_t nchunks = (T + CHUNK - 1) / CHUNK, per = nchunks / n, extra = nchunks % n;
    int64_t c0 = r * per + (r < extra ? r : extra), nc = per + (r < extra);
    *first = c0 * CHUNK;
    *count = nc * CHUNK;
    if (*first > T)
        *first = T;
    if (*first + *count > T)
        *count = T - *first;
}

int main(int argc, char **argv)
{
    int rank = 0, size = 1;
    dtx_error e;
    dtx_mesh m;
    dtx_markers mk;
    dtx_h5_seq s;
    dtx_h5_result r;
    hid_t f = H5I_INVALID_HID;
    double X[T * NV * 3], Y[T * NV * 3], res[T];
    int64_t first, count;
    dtx_h5_provenance prov = {"sp04", "{}", "{}", "/sequences/walk", "/meshes/tet", ""};
    static const double V[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const int32_t F[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    dtx_h5_init();
    for (int64_t t = 0; t < T; t++) {
        res[t] = 0.01 * (double)t;
        for (int i = 0; i < NV; i++)
            for (int k = 0; k < 3; k++)
                X[(t * NV + i) * 3 + k] = value(t, i, k);
    }
    my_frames(rank, size, &first, &count);

    /* ------------------------------------------------------- writing */
    CHECK_OK(dtx_h5_create(PATH, MPI_COMM_WORLD, &f, &e), &e);
    CHECK_EQ_INT(dtx_h5_is_parallel(f), 1);
    dtx_mesh_alloc(&m, 4, 4, NULL);
    memcpy(m.V, V, sizeof V);
    memcpy(m.F, F, sizeof F);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/tet", &m, "tet.obj", &e), &e);
    {
        int32_t pairs[4] = {0, 1, 3, 2};
        dtx_h5_corr_meta meta = {"feedfeedfeedfeed", "/meshes/tet", "/meshes/tet", "", "{}"};
        CHECK_OK(dtx_h5_write_corr(f, "/correspondences/self", pairs, 2, V, 4, &meta, &e), &e);
    }

    /* Filters and variable-length data cannot go through MPI-IO. */
    CHECK_EQ_INT(dtx_h5_seq_create(f, "/sequences/walk", "/meshes/tet", T, NV, 0, CHUNK, 1, &s,
                                   &e),
                 DTX_EINVAL);
    CHECK(check_contains(e.msg, "gzip cannot be used on a file opened in parallel"));
    dtx_markers_alloc(&mk, 1, NULL);
    CHECK_EQ_INT(dtx_h5_write_markers(f, "/markers/m", &mk, NULL, NULL, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "markers cannot be written to a file opened in parallel"));
    dtx_markers_free(&mk);

    CHECK_OK(dtx_h5_seq_create(f, "/sequences/walk", "/meshes/tet", T, NV, 1, CHUNK, 0, &s, &e),
             &e);
    CHECK_EQ_INT(s.parallel, 1);
    CHECK_EQ_INT(dtx_h5_write_frame_names(&s, NULL, T, &e), DTX_EINVAL);
    /* Collective: every rank calls, each with its own frames. */
    CHECK_OK(dtx_h5_seq_write(&s, first, count, X + first * NV * 3, 1, &e), &e);
    /* A collective call in which no rank has data. */
    CHECK_OK(dtx_h5_seq_write(&s, 0, 0, NULL, 1, &e), &e);
    CHECK_OK(dtx_h5_seq_commit(&s, &e), &e);
    dtx_h5_seq_close(&s);

    CHECK_EQ_INT(dtx_h5_result_create(f, "/results/tet", &prov, T, NV, 0, CHUNK, 1, &r, &e),
                 DTX_EINVAL);
    CHECK(check_contains(e.msg, "gzip cannot be used for a result written in parallel"));
    CHECK_OK(dtx_h5_result_create(f, "/results/tet", &prov, T, NV, 0, CHUNK, 0, &r, &e), &e);
    /* First frame of each rank's range collectively, the rest
     * independently. */
    {
        int64_t c1 = count > 0 ? 1 : 0;
        CHECK_OK(dtx_h5_result_write(&r, first, c1, X + first * NV * 3, res + first, 1, &e),
                 &e);
        CHECK_OK(dtx_h5_result_write(&r, first + c1, count - c1, X + (first + c1) * NV * 3,
                                     res + first + c1, 0, &e),
                 &e);
    }
    CHECK_OK(dtx_h5_result_finish(&r, 0, &e), &e);
    dtx_h5_result_close(&r);

    /* A reader on one rank only (independent). */
    if (rank == 0) {
        CHECK_OK(dtx_h5_seq_open(f, "/sequences/walk", &s, &e), &e);
        CHECK_OK(dtx_h5_seq_read(&s, 0, T, Y, &e), &e);
        CHECK(memcmp(X, Y, sizeof X) == 0);
        dtx_h5_seq_close(&s);
    }
    CHECK_OK(dtx_h5_close(&f, &e), &e);
    MPI_Barrier(MPI_COMM_WORLD);

    /* -------------------------------------------- reading it serially */
    if (rank == 0) {
        double rr[T];
        char *report = NULL;
        CHECK_OK(dtx_h5_open(PATH, MPI_COMM_NULL, 0, &f, &e), &e);
        CHECK_OK(dtx_h5_result_open(f, "/results/tet", 0, &r, &e), &e);
        CHECK_OK(dtx_h5_result_read(&r, 0, T, Y, rr, &e), &e);
        {
            int exact = 1;
            for (int i = 0; i < T * NV * 3; i++)
                exact &= Y[i] == (double)(float)X[i];
            CHECK(exact);
            CHECK(memcmp(rr, res, sizeof res) == 0);
        }
        dtx_h5_result_close(&r);
        {
            dtx_h5_corr c;
            CHECK_OK(dtx_h5_read_corr(f, "/correspondences/self", 4, 4, 4, &c, &e), &e);
            CHECK(c.npairs == 2 && c.pairs[2] == 3 && c.deformed_src[3] == 1.0);
            CHECK(c.key && strcmp(c.key, "feedfeedfeedfeed") == 0);
            dtx_h5_corr_free(&c);
        }
        {
            dtx_mesh back;
            CHECK_OK(dtx_h5_read_mesh(f, "/meshes/tet", &back, &e), &e);
            CHECK(back.nv == 4 && memcmp(back.V, V, sizeof V) == 0);
            dtx_mesh_free(&back);
        }
        CHECK_OK(dtx_h5_close(&f, &e), &e);
        CHECK_OK(dtx_h5_validate(PATH, &report, &e), &e);
        CHECK(check_contains(report, "/results/tet: ok"));
        free(report);
    }
    dtx_mesh_free(&m);
    {
        int failed = check_report(), any = 0;
        MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        MPI_Finalize();
        return any;
    }
}
