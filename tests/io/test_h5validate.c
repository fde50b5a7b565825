/* test_h5validate.c: the layout description and `dtx validate`: a good
 * file passes, and each of several broken files is rejected with the
 * problem named. */
#include "check.h"
#include "h5layout.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

enum { T = 6, NV = 4 };

static char *slurp(const char *path, size_t *n)
{
    FILE *fp = fopen(path, "rb");
    char *buf = NULL;
    long len;
    *n = 0;
    if (!fp)
        return NULL;
    if (fseek(fp, 0, SEEK_END) == 0 && (len = ftell(fp)) >= 0 && fseek(fp, 0, SEEK_SET) == 0) {
        buf = malloc((size_t)len + 1);
        if (buf && fread(buf, 1, (size_t)len, fp) == (size_t)len) {
            buf[len] = '\0';
            *n = (size_t)len;
        } else {
            free(buf);
            buf = NULL;
        }
    }
    fclose(fp);
    return buf;
}

/* ------------------------------------------------- the description */

static void test_description(void)
{
    size_t n = 0;
    char *file = slurp(DTX_SRC "/schemas/hdf5-layout-v1.json", &n);
    char *text = dtx_h5_layout_json();
    cJSON *j, *kinds, *k;
    int nkinds = 0;
    CHECK(file != NULL);
    CHECK(text != NULL);
    if (file && text) {
        CHECK_EQ_INT(strlen(text), n);
        CHECK(memcmp(file, text, n) == 0); /* byte for byte */
    }
    j = text ? cJSON_Parse(text) : NULL;
    CHECK(j != NULL);
    CHECK_EQ_INT(cJSON_GetObjectItemCaseSensitive(j, "format_version")->valueint, 1);
    kinds = cJSON_GetObjectItemCaseSensitive(j, "kinds");
    cJSON_ArrayForEach(k, kinds)
    {
        const char *name = cJSON_GetObjectItemCaseSensitive(k, "name")->valuestring;
        static const char *const order[] = {"meshes",          "sequences", "markers", "keypoints",
                                            "correspondences", "weights",   "results"};
        CHECK(nkinds < 7 && strcmp(name, order[nkinds]) == 0);
        CHECK(cJSON_IsObject(cJSON_GetObjectItemCaseSensitive(k, "datasets")));
        CHECK(cJSON_IsObject(cJSON_GetObjectItemCaseSensitive(k, "attributes")));
        CHECK(cJSON_IsArray(cJSON_GetObjectItemCaseSensitive(k, "checks")));
        nkinds++;
    }
    CHECK_EQ_INT(nkinds, 7);
    cJSON_Delete(j);
    free(text);
    free(file);
}

/* ---------------------------------------------------------- fixtures */

static void make_mesh(dtx_mesh *m, int32_t nv, double scale)
{
    /* A fan around vertex 0: nv - 2 triangles. */
    dtx_mesh_alloc(m, nv, nv - 2, NULL);
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

/* A complete file: two meshes, a sequence, markers, a correspondence, a
 * complete result and an interrupted one. */
static void make_good(const char *path)
{
    dtx_error e;
    dtx_mesh cat, lion;
    dtx_markers mk;
    dtx_h5_seq s;
    dtx_h5_result r;
    hid_t f;
    double X[T * NV * 3], res[T];
    int32_t pairs[4] = {0, 0, 1, 2};
    const char *names[T] = {"a.obj", "b.obj", "c.obj", "d.obj", "e.obj", "f.obj"};
    dtx_h5_corr_meta meta = {"0123456789abcdef", "/meshes/cat", "/meshes/lion",
                             "/markers/cat-lion", "{\"w\": 1}"};
    dtx_h5_provenance prov = {"sp04", "{\"dtx_job\": 1}", "{\"w\": 1}", "/sequences/walk",
                              "/meshes/lion", "/correspondences/c"};
    make_mesh(&cat, NV, 1.0);
    make_mesh(&lion, 5, 2.0);
    for (int i = 0; i < T * NV * 3; i++)
        X[i] = sin(0.1 * i);
    for (int t = 0; t < T; t++)
        res[t] = 0.5 * t;
    CHECK_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &e), &e);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/cat", &cat, "cat.obj", &e), &e);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/lion", &lion, "lion.obj", &e), &e);
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/walk", "/meshes/cat", T, NV, 0, 4, 1, &s, &e), &e);
    CHECK_OK(dtx_h5_seq_write(&s, 0, T, X, 0, &e), &e);
    CHECK_OK(dtx_h5_write_frame_names(&s, names, T, &e), &e);
    CHECK_OK(dtx_h5_seq_commit(&s, &e), &e);
    dtx_h5_seq_close(&s);
    dtx_markers_alloc(&mk, 2, NULL);
    mk.src[0] = 0, mk.tgt[0] = 0, mk.src[1] = 3, mk.tgt[1] = 4;
    CHECK_OK(dtx_h5_write_markers(f, "/markers/cat-lion", &mk, "/meshes/cat", "/meshes/lion",
                                  &e),
             &e);
    CHECK_OK(dtx_h5_write_corr(f, "/correspondences/c", pairs, 2, cat.V, NV, &meta, &e), &e);
    /* The result's target has 5 vertices; its frames are made up. */
    {
        double Y[T * 5 * 3];
        for (int i = 0; i < T * 5 * 3; i++)
            Y[i] = cos(0.1 * i);
        CHECK_OK(dtx_h5_result_create(f, "/results/lion", &prov, T, 5, 0, 2, 0, &r, &e), &e);
        CHECK_OK(dtx_h5_result_write(&r, 0, T, Y, res, 0, &e), &e);
        CHECK_OK(dtx_h5_result_finish(&r, 0, &e), &e);
        dtx_h5_result_close(&r);
        /* Results filed as /results/<target>/<sequence>. */
        CHECK_OK(dtx_h5_result_create(f, "/results/by-target/walk", &prov, T, 5, 1, 0, 0, &r,
                                      &e),
                 &e);
        CHECK_OK(dtx_h5_result_write(&r, 0, T, Y, res, 0, &e), &e);
        CHECK_OK(dtx_h5_result_finish(&r, 0, &e), &e);
        dtx_h5_result_close(&r);
        CHECK_OK(dtx_h5_result_create(f, "/results/lion2", &prov, T, 5, 0, 2, 0, &r, &e), &e);
        CHECK_OK(dtx_h5_result_write(&r, 0, 2, Y, res, 0, &e), &e);
        dtx_h5_result_close(&r); /* interrupted: stays as /results/.dtx-tmp-lion2 */
    }
    CHECK_OK(dtx_h5_close(&f, &e), &e);
    dtx_markers_free(&mk);
    dtx_mesh_free(&cat);
    dtx_mesh_free(&lion);
}

static hid_t reopen(const char *path)
{
    hid_t f = H5I_INVALID_HID;
    dtx_error e;
    CHECK_OK(dtx_h5_open(path, MPI_COMM_NULL, 1, &f, &e), &e);
    return f;
}

static void done(hid_t f)
{
    dtx_error e;
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* Overwrites a whole int32 dataset. */
static void put_i32(hid_t f, const char *path, const int32_t *v)
{
    hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
    CHECK(d >= 0 && H5Dwrite(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0);
    H5Dclose(d);
}

/* Replaces a dataset by one of another type/shape. */
static void replace_dset(hid_t f, const char *path, hid_t ftype, int rank, const hsize_t *dims,
                         int chunked)
{
    hid_t sp = H5Screate_simple(rank, dims, NULL), dcpl = H5Pcreate(H5P_DATASET_CREATE), d;
    H5Ldelete(f, path, H5P_DEFAULT);
    if (chunked)
        H5Pset_chunk(dcpl, rank, dims);
    else
        H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_EARLY);
    d = H5Dcreate2(f, path, ftype, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    CHECK(d >= 0);
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(sp);
}

/* Validates path and expects DTX_EFORMAT with `problem` in the first
 * message and `line` in the report. */
static void expect_bad(const char *path, const char *problem, const char *line)
{
    dtx_error e;
    char *report = NULL;
    CHECK_EQ_INT(dtx_h5_validate(path, &report, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, path));
    CHECK(check_contains(e.msg, problem));
    CHECK(check_contains(report, line));
    CHECK(check_contains(report, "problem"));
    free(report);
}

/* ------------------------------------------------------------- tests */

static void test_good(void)
{
    const char *path = SCRATCH "good.h5";
    dtx_error e;
    char *report = NULL;
    make_good(path);
    CHECK_OK(dtx_h5_validate(path, &report, &e), &e);
    CHECK(check_contains(report, "/: ok\n"));
    CHECK(check_contains(report, "/meshes/cat: ok\n"));
    CHECK(check_contains(report, "/meshes/lion: ok\n"));
    CHECK(check_contains(report, "/sequences/walk: ok\n"));
    CHECK(check_contains(report, "/markers/cat-lion: ok\n"));
    CHECK(check_contains(report, "/correspondences/c: ok\n"));
    CHECK(check_contains(report, "/results/lion: ok\n"));
    CHECK(check_contains(report, "/results/.dtx-tmp-lion2: note: temporary group"));
    CHECK(check_contains(report, "/results/by-target/walk: ok\n"));
    CHECK(check_contains(report, "valid dtx layout v1 (7 groups checked; 2 results, 12 of 12 frames "
                           "checked (finite); 1 sequence, 6 of 6 frames checked (finite))"));
    free(report);

    /* Extra top-level objects are noted, not rejected. */
    {
        hid_t f = reopen(path);
        CHECK_OK(dtx_h5_create_groups(f, "/extras/mine", &e), &e);
        done(f);
    }
    CHECK_OK(dtx_h5_validate(path, &report, &e), &e);
    CHECK(check_contains(report, "/extras: note: not part of the dtx layout"));
    free(report);
}

static void test_not_hdf5(void)
{
    dtx_error e;
    char *report = NULL;
    FILE *fp = fopen(SCRATCH "text.h5", "w");
    if (fp) {
        fputs("hello\n", fp);
        fclose(fp);
    }
    CHECK_EQ_INT(dtx_h5_validate(SCRATCH "text.h5", &report, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "text.h5: not an HDF5 file"));
    CHECK(check_contains(report, "not an HDF5 file"));
    free(report);
    CHECK_EQ_INT(dtx_h5_validate(SCRATCH "absent.h5", &report, &e), DTX_EIO);
    CHECK(check_contains(e.msg, "absent.h5: cannot open"));
    free(report);
}

static void test_bad_faces(void)
{
    const char *path = SCRATCH "bad-faces.h5";
    int32_t F[6] = {0, 1, 2, 0, 2, 4}; /* 4 is out of range for the 4-vertex cat */
    hid_t f;
    make_good(path);
    f = reopen(path);
    put_i32(f, "/meshes/cat/faces", F);
    done(f);
    expect_bad(path, "/meshes/cat/faces: 1 value out of range [0, 4) (nv (from dimension 0 of "
                     "vertices)); first 4 at [1, 2]",
               "/meshes/cat/faces: 1 value out of range");
}

static void test_bad_rank(void)
{
    const char *path = SCRATCH "bad-rank.h5";
    hsize_t d2[2] = {T, NV * 3};
    hid_t f;
    make_good(path);
    f = reopen(path);
    replace_dset(f, "/sequences/walk/positions", H5T_IEEE_F32LE, 2, d2, 1);
    done(f);
    expect_bad(path, "/sequences/walk/positions: expected 3 dimensions T x nv x 3, found 2",
               "/sequences/walk/positions: expected 3 dimensions");
}

static void test_bad_nv_vs_rest(void)
{
    /* The sequence's rest link and attribute point at the 5-vertex lion. */
    const char *path = SCRATCH "bad-rest.h5";
    dtx_error e;
    hid_t f;
    make_good(path);
    f = reopen(path);
    H5Ldelete(f, "/sequences/walk/rest", H5P_DEFAULT);
    CHECK(H5Lcreate_soft("/meshes/lion", f, "/sequences/walk/rest", H5P_DEFAULT,
                         H5P_DEFAULT) >= 0);
    CHECK_OK(dtx_h5_write_attr_str(f, "/sequences/walk", "rest_mesh", "/meshes/lion", &e), &e);
    done(f);
    expect_bad(path, "/sequences/walk: nv (from dimension 1 of positions) is 4, but nv of "
                     "/meshes/lion is 5",
               "/sequences/walk: nv");
}

static void test_bad_link_attr(void)
{
    const char *path = SCRATCH "bad-linkattr.h5";
    dtx_error e;
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK_OK(dtx_h5_write_attr_str(f, "/sequences/walk", "rest_mesh", "/meshes/lion", &e), &e);
    done(f);
    expect_bad(path, "attribute rest_mesh is \"/meshes/lion\", but link rest points to "
                     "/meshes/cat",
               "/sequences/walk: attribute rest_mesh");
}

static void test_bad_complete(void)
{
    const char *path = SCRATCH "bad-complete.h5";
    uint8_t done_flags[T] = {1, 1, 1, 0, 1, 0};
    hid_t f, d;
    make_good(path);
    f = reopen(path);
    d = H5Dopen2(f, "/results/lion/frame_done", H5P_DEFAULT);
    CHECK(d >= 0 &&
          H5Dwrite(d, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, done_flags) >= 0);
    H5Dclose(d);
    done(f);
    expect_bad(path, "/results/lion/frame_done: 2 of 6 entries are not 1 although complete = 1; "
                     "first at [3]",
               "/results/lion/frame_done: 2 of 6");
}

static void test_bad_dangling(void)
{
    /* The lion mesh removed: the result's target link dangles, and the
     * markers and correspondence name a path that does not exist. */
    const char *path = SCRATCH "bad-dangling.h5";
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK(H5Ldelete(f, "/meshes/lion", H5P_DEFAULT) >= 0);
    done(f);
    expect_bad(path, "/markers/cat-lion: attribute target_mesh names /meshes/lion, which does "
                     "not exist in this file",
               "/results/lion/target: soft link to /meshes/lion does not resolve");
}

static void test_bad_missing(void)
{
    const char *path = SCRATCH "bad-missing.h5";
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK(H5Adelete_by_name(f, "/meshes/lion", "nf", H5P_DEFAULT) >= 0);
    /* pairs is required (deformed_source is not: multicomponent's
     * correspondence has none, test_optional_deformed_source). */
    CHECK(H5Ldelete(f, "/correspondences/c/pairs", H5P_DEFAULT) >= 0);
    done(f);
    expect_bad(path, "/meshes/lion: missing attribute nf (int)",
               "/correspondences/c: missing dataset pairs (int P x 2)");
}

/* A correspondence without deformed_source (multicomponent's) is valid. */
static void test_optional_deformed_source(void)
{
    const char *path = SCRATCH "no-deformed-source.h5";
    char *report = NULL;
    dtx_error e;
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK(H5Ldelete(f, "/correspondences/c/deformed_source", H5P_DEFAULT) >= 0);
    done(f);
    CHECK_EQ_INT(dtx_h5_validate(path, &report, &e), DTX_OK);
    CHECK(report && check_contains(report, "/correspondences/c: ok"));
    free(report);
}

static void test_bad_dtype(void)
{
    const char *path = SCRATCH "bad-dtype.h5";
    hsize_t d[2] = {2, 3};
    hsize_t dv[2] = {NV, 3};
    hid_t f;
    make_good(path);
    f = reopen(path);
    replace_dset(f, "/meshes/cat/faces", H5T_STD_I64LE, 2, d, 0);
    replace_dset(f, "/meshes/lion/vertices", H5T_STD_I32LE, 2, dv, 0);
    done(f);
    expect_bad(path, "/meshes/cat/faces: expected 32-bit signed integer values, found 64-bit",
               "/meshes/lion/vertices: expected float values, found signed integer");
}

static void test_bad_root(void)
{
    const char *path = SCRATCH "bad-root.h5";
    dtx_error e;
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK_OK(dtx_h5_write_attr_int(f, ".", "format_version", 2, &e), &e);
    done(f);
    expect_bad(path, "/: attribute format_version is 2, expected 1", "/: attribute");
}

static void test_bad_markers(void)
{
    const char *path = SCRATCH "bad-markers.h5";
    int32_t src[2] = {0, 9};
    hid_t f;
    make_good(path);
    f = reopen(path);
    put_i32(f, "/markers/cat-lion/source_vertex", src);
    done(f);
    expect_bad(path, "/markers/cat-lion/source_vertex: 1 value out of range [0, 4) (nv of "
                     "/meshes/cat); first 9 at [1, 0]",
               "/markers/cat-lion/source_vertex");
}

static void test_bad_hash(void)
{
    const char *path = SCRATCH "bad-hash.h5";
    double V[NV * 3];
    hid_t f, d;
    make_good(path);
    f = reopen(path);
    d = H5Dopen2(f, "/meshes/cat/vertices", H5P_DEFAULT);
    CHECK(d >= 0 && H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, V) >= 0);
    V[4] += 1e-9;
    CHECK(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, V) >= 0);
    H5Dclose(d);
    done(f);
    expect_bad(path, "/meshes/cat: content_hash is", "but the data hashes to");
}

static void test_bad_json_and_pairs(void)
{
    const char *path = SCRATCH "bad-json.h5";
    dtx_error e;
    int32_t pairs[4] = {0, 0, 1, 3}; /* the lion has 3 faces */
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK_OK(dtx_h5_write_attr_str(f, "/results/lion", "parameters", "{w: 1", &e), &e);
    put_i32(f, "/correspondences/c/pairs", pairs);
    done(f);
    expect_bad(path, "/correspondences/c/pairs: 1 value out of range [0, 3) (nf of "
                     "/meshes/lion); first 3 at [1, 1]",
               "/results/lion: attribute parameters is not valid JSON");
}

static void test_bad_namespace(void)
{
    /* An empty group where objects are expected, and a dataset directly
     * in a namespace group. */
    const char *path = SCRATCH "bad-namespace.h5";
    dtx_error e;
    hsize_t d[1] = {3};
    hid_t f;
    make_good(path);
    f = reopen(path);
    CHECK_OK(dtx_h5_create_groups(f, "/meshes/empty", &e), &e);
    replace_dset(f, "/results/by-target/stray", H5T_STD_I32LE, 1, d, 0);
    done(f);
    expect_bad(path, "/meshes/empty: is empty: neither a meshes group nor a group of them",
               "/results/by-target/stray: is not a group (expected a results group)");
}

static void test_bad_unwritten(void)
{
    /* Faces with a shape but no data stored. */
    const char *path = SCRATCH "bad-unwritten.h5";
    hsize_t d[2] = {1024, 3};
    hid_t f;
    make_good(path);
    f = reopen(path);
    replace_dset(f, "/meshes/lion/faces", H5T_STD_I32LE, 2, d, 1);
    done(f);
    expect_bad(path, "/meshes/lion: attribute nf is 3, but nf is 1024 (from dimension 0 of "
                     "faces)",
               "/meshes/lion/faces: needs 12288 bytes, but only 0 bytes are stored");
}

/* Sets coordinate k of vertex v in frame t of a T x nv x 3 dataset. */
static void put_coord(hid_t f, const char *path, hsize_t t, hsize_t v, hsize_t k, double x)
{
    hsize_t at[3] = {t, v, k}, one = 1;
    hid_t d = H5Dopen2(f, path, H5P_DEFAULT), fs = H5Dget_space(d);
    hid_t ms = H5Screate_simple(1, &one, NULL);
    CHECK(H5Sselect_elements(fs, H5S_SELECT_SET, 1, at) >= 0);
    CHECK(H5Dwrite(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, &x) >= 0);
    H5Sclose(ms);
    H5Sclose(fs);
    H5Dclose(d);
}

static void put_done(hid_t f, const char *path, const uint8_t *flags)
{
    hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
    CHECK(d >= 0 && H5Dwrite(d, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, flags) >= 0);
    H5Dclose(d);
}

/* A NaN in a frame marked done: the result is not valid, and the problem
 * names the frame and the vertex.  (Before, the validator read no result
 * positions at all and called such a file valid.) */
static void test_bad_nan_result(void)
{
    const char *path = SCRATCH "bad-nan.h5";
    hid_t f;
    make_good(path);
    f = reopen(path);
    put_coord(f, "/results/lion/positions", 3, 2, 1, NAN);
    put_coord(f, "/results/lion/positions", 5, 0, 0, -INFINITY);
    done(f);
    expect_bad(path, "/results/lion/positions: 2 of 6 frames marked done hold non-finite "
                     "coordinates; first frame 3 (0-based), vertex 2 (nan)",
               "2 results, 12 of 12 frames checked (finite)");
}

/* Marks /results/lion's frames by flags (frame_done) and the result not
 * complete. */
static void mark_not_done(hid_t f, const uint8_t *flags)
{
    dtx_error e;
    put_done(f, "/results/lion/frame_done", flags);
    CHECK(H5Adelete_by_name(f, "/results/lion", "complete", H5P_DEFAULT) >= 0);
    CHECK_OK(dtx_h5_write_attr_int(f, "/results/lion", "complete", 0, &e), &e);
}

/* A NaN in a frame not done (complete = 0) is allowed: such frames hold
 * undefined values.  The summary says how many frames were checked. */
static void test_nan_not_done(void)
{
    const char *path = SCRATCH "nan-not-done.h5";
    uint8_t flags[T] = {1, 1, 1, 0, 1, 1};
    dtx_error e;
    char *report = NULL;
    hid_t f;
    make_good(path);
    f = reopen(path);
    put_coord(f, "/results/lion/positions", 3, 2, 1, NAN);
    mark_not_done(f, flags);
    done(f);
    CHECK_OK(dtx_h5_validate(path, &report, &e), &e);
    CHECK(check_contains(report, "/results/lion: ok\n"));
    CHECK(check_contains(report, "2 results, 11 of 12 frames checked (finite; 1 not done)"));
    free(report);
}

/* Adds frame_grad_norm to /results/lion of a good file, with values g
 * (T entries). */
static void put_grad_norm(const char *path, const double *g)
{
    dtx_h5_result r;
    dtx_error e;
    hid_t f = reopen(path);
    CHECK_OK(dtx_h5_result_open(f, "/results/lion", 0, &r, &e), &e);
    CHECK_OK(dtx_h5_result_add_frame_grad_norm(&r, &e), &e);
    CHECK_OK(dtx_h5_result_write_frame_grad_norm(&r, 0, T, g, 0, &e), &e);
    dtx_h5_result_close(&r);
    done(f);
}

/* frame_grad_norm (optional): T finite entries >= 0 in the frames done;
 * NaN there, a negative norm or the wrong shape is a problem, NaN in a
 * frame not done (the fill) is not. */
static void test_grad_norm(void)
{
    const char *path = SCRATCH "grad-norm.h5";
    const double good[T] = {0.0, 1e-9, 0.5, 3.0, 1e6, 2e-3};
    double g[T];
    uint8_t flags[T] = {1, 1, 1, 0, 1, 1};
    dtx_error e;
    char *report = NULL;
    hid_t f;

    make_good(path);
    put_grad_norm(path, good);
    CHECK_OK(dtx_h5_validate(path, &report, &e), &e);
    CHECK(check_contains(report, "/results/lion: ok\n"));
    free(report);
    report = NULL;

    memcpy(g, good, sizeof g);
    g[4] = NAN;
    make_good(path);
    put_grad_norm(path, g);
    expect_bad(path,
               "/results/lion/frame_grad_norm: value at [4] is not finite (nan) although "
               "frame_done[4] = 1",
               "/results/lion/frame_grad_norm: value at [4] is not finite");

    g[4] = 1.0;
    g[2] = -0.5;
    make_good(path);
    put_grad_norm(path, g);
    expect_bad(path, "/results/lion/frame_grad_norm: value at [2, 0] is -0.5, below 0",
               "/results/lion/frame_grad_norm: value at [2, 0] is -0.5");

    /* The fill of a frame not done is NaN: not a problem. */
    memcpy(g, good, sizeof g);
    g[3] = NAN;
    make_good(path);
    put_grad_norm(path, g);
    f = reopen(path);
    mark_not_done(f, flags);
    done(f);
    CHECK_OK(dtx_h5_validate(path, &report, &e), &e);
    CHECK(check_contains(report, "/results/lion: ok\n"));
    free(report);

    /* The shape: T entries of float64. */
    make_good(path);
    put_grad_norm(path, good);
    f = reopen(path);
    {
        const hsize_t d[1] = {T + 1};
        replace_dset(f, "/results/lion/frame_grad_norm", H5T_IEEE_F64LE, 1, d, 0);
    }
    {
        /* The reader refuses it too, naming it. */
        dtx_h5_result r;
        CHECK_EQ_INT(dtx_h5_result_open(f, "/results/lion", 0, &r, &e), DTX_EFORMAT);
        CHECK(check_contains(e.msg, "/results/lion/frame_grad_norm: has 7 entries for 6 frames"));
    }
    done(f);
    expect_bad(path, "/results/lion/frame_grad_norm", "/results/lion/frame_grad_norm");
    make_good(path);
    put_grad_norm(path, good);
    f = reopen(path);
    {
        const hsize_t d[1] = {T};
        replace_dset(f, "/results/lion/frame_grad_norm", H5T_STD_I32LE, 1, d, 0);
    }
    done(f);
    expect_bad(path, "/results/lion/frame_grad_norm: expected float",
               "/results/lion/frame_grad_norm: expected float");
}

/* frame_done holds flags: 0 or 1. */
static void test_bad_flags(void)
{
    const char *path = SCRATCH "bad-flags.h5";
    uint8_t flags[T] = {1, 1, 7, 1, 1, 1};
    hid_t f;
    make_good(path);
    f = reopen(path);
    put_done(f, "/results/lion/frame_done", flags);
    done(f);
    expect_bad(path, "/results/lion/frame_done: 1 value out of range [0, 2) (at most 1); "
                     "first 7 at [2, 0]",
               "/results/lion/frame_done: 1 value out of range");
}

/* Every frame of a sequence is checked. */
static void test_bad_nan_sequence(void)
{
    const char *path = SCRATCH "bad-nan-seq.h5";
    hid_t f;
    make_good(path);
    f = reopen(path);
    put_coord(f, "/sequences/walk/positions", 5, 3, 2, INFINITY);
    done(f);
    expect_bad(path, "/sequences/walk/positions: 1 of 6 frames holds non-finite coordinates; "
                     "first frame 5 (0-based), vertex 3 (inf)",
               "1 sequence, 6 of 6 frames checked (finite)");
}

/* A result with frames larger than the validator's block (2^21 values):
 * frames are read a few at a time, and a NaN in the last block, after
 * blocks without one and a block of frames not done, is found. */
static void test_blocks(void)
{
    enum { BT = 8, BNV = 300000 };
    const char *path = SCRATCH "blocks.h5";
    dtx_h5_provenance prov = {"sp04", "{}", "{}", "", "/meshes/big", ""};
    uint8_t flags[BT] = {1, 1, 1, 0, 0, 0, 1, 1};
    dtx_error e;
    dtx_mesh m;
    dtx_h5_result r;
    double *Y = dtx_alloc((size_t)BT * BNV, 3 * sizeof(double), 0);
    char *report = NULL;
    hid_t f;
    CHECK(Y != NULL);
    if (!Y)
        return;
    for (size_t i = 0; i < (size_t)BT * BNV * 3; i++)
        Y[i] = (double)(i % 1000) * 1e-3;
    make_mesh(&m, BNV, 1.0);
    CHECK_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &e), &e);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/big", &m, "big.obj", &e), &e);
    CHECK_OK(dtx_h5_result_create(f, "/results/big", &prov, BT, BNV, 0, 1, 0, &r, &e), &e);
    CHECK_OK(dtx_h5_result_write(&r, 0, BT, Y, NULL, 0, &e), &e);
    dtx_h5_result_close(&r);
    /* Mark frames 3-5 not done and hide a NaN in frame 4 (not done) and
     * in frame 7 (done), then commit by hand under the final name. */
    CHECK(H5Lmove(f, "/results/.dtx-tmp-big", f, "/results/big", H5P_DEFAULT, H5P_DEFAULT) >=
          0);
    put_done(f, "/results/big/frame_done", flags);
    put_coord(f, "/results/big/positions", 4, 10, 0, NAN);
    put_coord(f, "/results/big/positions", 7, BNV - 1, 2, NAN);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
    CHECK_EQ_INT(dtx_h5_validate(path, &report, &e), DTX_EFORMAT);
    CHECK(check_contains(report, "/results/big/positions: 1 of 5 frames marked done holds non-finite "
                           "coordinates; first frame 7 (0-based), vertex 299999 (nan)"));
    CHECK(check_contains(report, "1 result, 5 of 8 frames checked (finite; 3 not done)"));
    free(report);
    free(Y);
    dtx_mesh_free(&m);
}

/* Open HDF5 identifiers (see test_h5layout.c). */
static long count_valid_below(hid_t probe)
{
    const hid_t mask = ((hid_t)1 << 56) - 1;
    long n = 0;
    for (hid_t i = 0; i < (probe & mask); i++)
        n += H5Iis_valid((probe & ~mask) | i) > 0;
    return n;
}

static void count_ids(long n[4])
{
    hid_t p;
    n[0] = (long)H5Fget_obj_count((hid_t)H5F_OBJ_ALL, H5F_OBJ_ALL);
    p = H5Screate(H5S_SCALAR);
    n[1] = count_valid_below(p);
    H5Sclose(p);
    p = H5Tcopy(H5T_NATIVE_INT);
    n[2] = count_valid_below(p);
    H5Tclose(p);
    p = H5Pcreate(H5P_DATASET_XFER);
    n[3] = count_valid_below(p);
    H5Pclose(p);
}

int main(void)
{
    long before[4], after[4];
    dtx_h5_init();
    test_description();
    count_ids(before);
    test_good();
    test_not_hdf5();
    test_bad_faces();
    test_bad_rank();
    test_bad_nv_vs_rest();
    test_bad_link_attr();
    test_bad_complete();
    test_bad_dangling();
    test_bad_missing();
    test_optional_deformed_source();
    test_bad_dtype();
    test_bad_root();
    test_bad_markers();
    test_bad_hash();
    test_bad_json_and_pairs();
    test_bad_unwritten();
    test_bad_namespace();
    test_bad_nan_result();
    test_nan_not_done();
    test_bad_flags();
    test_grad_norm();
    test_bad_nan_sequence();
    test_blocks();
    count_ids(after);
    for (int i = 0; i < 4; i++)
        CHECK_EQ_INT(after[i], before[i]);
    return check_report();
}
