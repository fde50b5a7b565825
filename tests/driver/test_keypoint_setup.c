/*
 * test_keypoint_setup.c: the key-point helpers of the driver
 * (keypoint_setup.h).
 *  - Training frames: evenly spaced, rounded halves up, all frames when
 *    fewer than asked, frame 0 alone; read across sequence boundaries.
 *  - The selection through a communicator (one rank here; driver.biharmonic
 *    runs two) equals the core's selection bit for bit.
 *  - Mapping onto a target: a moved copy of the source maps every key onto
 *    its own vertex; two keys on one target vertex: the later is marked.
 *  - Nearest markers, labels ("key K near L" only when near), the marker
 *    set dropping duplicates, the step errors.
 */
#include "check.h"
#include "core/meshgen.h"
#include "dtx_core.h"
#include "h5layout.h"
#include "keypoint_setup.h"
#include "mpi_util.h"

#include <mpi.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

static void test_training_frames(void)
{
    int64_t idx[16];
    static const int64_t want9_3[3] = {0, 4, 8}, want10_4[4] = {0, 3, 6, 9};
    static const int64_t want4_3[3] = {0, 2, 3}; /* 1.5 rounds up */
    CHECK_EQ_INT(dtx_training_frames(9, 3, idx), 3);
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(idx[i], want9_3[i]);
    CHECK_EQ_INT(dtx_training_frames(10, 4, idx), 4);
    for (int i = 0; i < 4; i++)
        CHECK_EQ_INT(idx[i], want10_4[i]);
    CHECK_EQ_INT(dtx_training_frames(4, 3, idx), 3);
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(idx[i], want4_3[i]);
    CHECK_EQ_INT(dtx_training_frames(5, 32, idx), 5);
    for (int i = 0; i < 5; i++)
        CHECK_EQ_INT(idx[i], i);
    CHECK_EQ_INT(dtx_training_frames(7, 1, idx), 1);
    CHECK_EQ_INT(idx[0], 0);
    CHECK_EQ_INT(dtx_training_frames(0, 3, idx), 0);
    CHECK_EQ_INT(dtx_training_frames(5, 0, NULL), 0);
    /* Large counts: no overflow, last frame exact. */
    CHECK_EQ_INT(dtx_training_frames(INT64_C(3000000000), 16, idx), 16);
    CHECK_EQ_INT(idx[15], INT64_C(2999999999));
}

/* Two sequences of 3 and 4 frames (frame f of the whole: all coordinates
 * = f); 3 training frames out of 7 are frames 0, 3, 6: the first of each
 * sequence part and the last. */
static void test_read_training(const dtx_mesh *m)
{
    hid_t f = H5I_INVALID_HID;
    dtx_h5_seq a, b;
    const dtx_h5_seq *seqs[2] = {&a, &b};
    dtx_error e;
    double *buf = malloc(sizeof *buf * 3 * (size_t)m->nv * 4), *X = NULL;
    int32_t n = 0;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    CHECK_OK(dtx_h5_create(SCRATCH "train.h5", MPI_COMM_NULL, &f, &e), &e);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/m", m, "", &e), &e);
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/a", "/meshes/m", 3, m->nv, 1, 0, 0, &a, &e), &e);
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/b", "/meshes/m", 4, m->nv, 1, 0, 0, &b, &e), &e);
    for (int fr = 0; fr < 7; fr++) {
        for (int64_t i = 0; i < 3 * (int64_t)m->nv; i++)
            buf[i] = fr;
        CHECK_OK(dtx_h5_seq_write(fr < 3 ? &a : &b, fr < 3 ? fr : fr - 3, 1, buf, 0, &e), &e);
    }
    CHECK_OK(dtx_read_training_frames(seqs, 2, 3, &n, &X, &e), &e);
    CHECK_EQ_INT(n, 3);
    for (int i = 0; X && i < 3; i++) {
        CHECK_DBL(X[(size_t)i * 3 * m->nv], ==, 3.0 * i);
        CHECK_DBL(X[(size_t)i * 3 * m->nv + 3 * (size_t)m->nv - 1], ==, 3.0 * i);
    }
    free(X);
    CHECK_EQ_INT(dtx_read_training_frames(seqs, 0, 3, &n, &X, &e), DTX_EINVAL);
    CHECK(X == NULL && n == 0);
    dtx_h5_seq_close(&a);
    dtx_h5_seq_close(&b);
    dtx_h5_close(&f, NULL);
    free(buf);
}

static void test_select_comm(const dtx_mesh *m)
{
    enum { NF = 3 };
    double *X = malloc(sizeof *X * NF * 3 * (size_t)m->nv);
    dtx_kp_params p;
    dtx_kp_result a, b;
    dtx_error e;
    for (int f = 0; f < NF; f++)
        deform(m->V, m->nv, (f + 1) / (double)NF, X + (size_t)f * 3 * m->nv);
    dtx_kp_params_default(&p);
    p.candidates = 8;
    p.max_keys = 3;
    p.eps = 0.0;
    CHECK_OK(dtx_keypoints_select(m, NF, X, &p, &a, &e), &e);
    CHECK_OK(dtx_keypoints_select_comm(m, NF, X, &p, MPI_COMM_WORLD, &b, &e), &e);
    CHECK_EQ_INT(a.count, b.count);
    for (int k = 0; k < a.count && k < b.count; k++)
        CHECK_EQ_INT(a.keys[k], b.keys[k]);
    CHECK(a.error == b.error);
    {
        double steps[64];
        int32_t n = a.ntrace < 63 ? dtx_keypoints_steps(&a, steps) : 0;
        CHECK_EQ_INT(n, 1 + a.ntrace);
        CHECK_DBL(steps[0], ==, a.error_first);
        for (int32_t i = 1; i < n; i++)
            CHECK_DBL(steps[i], <=, steps[i - 1]); /* the error never rises */
        if (n > 0)
            CHECK_DBL(steps[n - 1], ==, a.error);
    }
    /* A bad parameter fails the same way through the communicator. */
    dtx_kp_result_free(&b);
    p.candidates = 0;
    CHECK_EQ_INT(dtx_keypoints_select_comm(m, NF, X, &p, MPI_COMM_WORLD, &b, &e), DTX_EINVAL);
    CHECK(b.keys == NULL && b.count == 0);
    dtx_kp_result_free(&a);
    dtx_kp_result_free(&b);
    free(X);
}

static void test_map_and_labels(const dtx_mesh *m)
{
    dtx_mesh t = {0};
    dtx_markers mk = {0}, set = {0};
    dtx_error e;
    double *def = malloc(sizeof *def * 3 * (size_t)m->nv), R[9], tr[3] = {1, 2, 3};
    int32_t keys[4] = {5, 40, 100, 41}, tv[4], dup[4], marker[4];
    double dist[4], edge = dtx_mesh_mean_edge(m);
    char label[128];

    /* The target: the source rotated and moved; the "deformed source" is
     * the same motion, so every key lands on its own vertex. */
    CHECK_OK(dtx_mesh_copy(m, &t, &e), &e);
    rotation(0.4, R);
    dtx_similarity_apply(R, tr, 1.3, t.V, t.nv);
    memcpy(def, t.V, sizeof *def * 3 * (size_t)m->nv);
    CHECK_OK(dtx_keypoints_map(def, m->nv, &t, keys, 4, tv, dup, &e), &e);
    for (int k = 0; k < 4; k++) {
        CHECK_EQ_INT(tv[k], keys[k]);
        CHECK_EQ_INT(dup[k], -1);
    }
    /* Key 4 deformed onto key 2's place: marked as its duplicate. */
    memcpy(def + 3 * 41, def + 3 * 40, 3 * sizeof *def);
    CHECK_OK(dtx_keypoints_map(def, m->nv, &t, keys, 4, tv, dup, &e), &e);
    CHECK_EQ_INT(tv[3], 40);
    CHECK_EQ_INT(dup[3], 1);
    keys[0] = m->nv;
    CHECK_EQ_INT(dtx_keypoints_map(def, m->nv, &t, keys, 4, tv, dup, &e), DTX_ERANGE);
    CHECK(strstr(e.msg, "key point 1: vertex") != NULL);
    keys[0] = 5;

    /* Markers at vertices 5 (labelled) and 101 (no label). */
    CHECK_OK(dtx_markers_alloc(&mk, 2, &e), &e);
    mk.src[0] = 5, mk.tgt[0] = 5, mk.labels[0] = strdup("nose");
    mk.src[1] = 101, mk.tgt[1] = 101, mk.labels[1] = strdup("");
    dtx_keypoints_nearest_markers(m, &mk, keys, 4, marker, dist);
    CHECK_EQ_INT(marker[0], 0);
    CHECK_DBL(dist[0], ==, 0.0);
    dtx_keypoint_label(0, &mk, marker[0], dist[0], 3 * edge, label, sizeof label);
    CHECK(strcmp(label, "key 1 near nose") == 0);
    dtx_keypoint_label(2, &mk, 1, 0.0, 3 * edge, label, sizeof label);
    CHECK(strcmp(label, "key 3") == 0); /* an empty marker label adds nothing */
    dtx_keypoint_label(0, &mk, 0, 10 * edge, 3 * edge, label, sizeof label);
    CHECK(strcmp(label, "key 1") == 0); /* too far */
    dtx_keypoints_nearest_markers(m, NULL, keys, 4, marker, dist);
    CHECK_EQ_INT(marker[0], -1);

    /* The marker set: duplicates dropped, labels numbered by key. */
    CHECK_OK(dtx_keypoints_marker_set(m, keys, tv, dup, 4, &mk, &set, &e), &e);
    CHECK_EQ_INT(set.n, 3);
    if (set.n == 3) {
        CHECK_EQ_INT(set.src[2], 100);
        CHECK_EQ_INT(set.tgt[2], 100);
        CHECK(strcmp(set.labels[0], "key 1 near nose") == 0);
        CHECK(strncmp(set.labels[2], "key 3", 5) == 0);
    }
    dtx_markers_free(&set);
    CHECK_OK(dtx_keypoints_marker_set(m, keys, NULL, NULL, 4, NULL, &set, &e), &e);
    CHECK(set.n == 4 && set.tgt[0] == -1 && strcmp(set.labels[3], "key 4") == 0);
    dtx_markers_free(&set);

    /* The table prints every key (to a scratch file). */
    {
        FILE *f = fopen(SCRATCH "table.txt", "w+");
        char line[512];
        int rows = 0;
        CHECK(f != NULL);
        if (f) {
            dtx_keypoints_print_table(f, "> ", m, keys, 4, &mk, tv, dup);
            rewind(f);
            while (fgets(line, sizeof line, f))
                rows += strncmp(line, ">    ", 5) == 0;
            CHECK_EQ_INT(rows, 4);
            fclose(f);
        }
    }
    dtx_markers_free(&mk);
    dtx_mesh_free(&t);
    free(def);
}

/* The dealer hands out every item exactly once, in batches of at most
 * what is asked, then nothing (one rank here; driver.biharmonic runs it on
 * two, where the results must not depend on who got which). */
static void test_dealer(void)
{
    dtx_mpi_dealer d;
    dtx_error e;
    int32_t k0 = -1, got[7] = {0}, n, total = 0;
    CHECK_OK(dtx_mpi_dealer_open(&d, MPI_COMM_WORLD, &e), &e);
    while ((n = dtx_mpi_dealer_claim(&d, 7, 3, &k0)) > 0) {
        CHECK_INT(n, <=, 3);
        CHECK(k0 >= 0 && k0 + n <= 7);
        for (int32_t k = k0; k < k0 + n && k < 7; k++)
            got[k]++;
        total += n;
        if (total > 7)
            break;
    }
    CHECK_EQ_INT(total, 7);
    for (int k = 0; k < 7; k++)
        CHECK_EQ_INT(got[k], 1);
    CHECK_EQ_INT(dtx_mpi_dealer_claim(&d, 7, 1, &k0), 0);
    dtx_mpi_dealer_close(&d);
    dtx_mpi_dealer_close(&d); /* closing twice is harmless */
    CHECK_EQ_INT(dtx_mpi_dealer_claim(&d, 7, 1, &k0), 0);
}

int main(int argc, char **argv)
{
    dtx_mesh m = {0};
    dtx_error e;
    int provided;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    dtx_h5_init();
    test_training_frames();
    test_dealer();
    CHECK_OK(gen_capsule(16, 10, 2.0, &m), &e);
    test_read_training(&m);
    test_map_and_labels(&m);
    test_select_comm(&m);
    dtx_mesh_free(&m);
    MPI_Finalize();
    return check_report();
}
