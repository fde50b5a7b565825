/* test_h5layout.c: the dtx HDF5 layout, serial: round trips of every
 * object, storage settings, and rejection of malformed files. */
#include "check.h"
#include "h5check.h"
#include "h5layout.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

/* A tetrahedron: 4 vertices, 4 faces. */
static void make_tet(dtx_mesh *m, double scale)
{
    static const double V[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const int32_t F[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    dtx_mesh_alloc(m, 4, 4, NULL);
    for (int i = 0; i < 12; i++)
        m->V[i] = V[i] * scale + 0.1 * i;
    memcpy(m->F, F, sizeof F);
}

/* Frame t of a test animation: irrational-ish values that float32 cannot
 * hold exactly. */
static double frame_value(int64_t t, int32_t i, int k)
{
    return sin(0.37 * (double)t + 1.3 * i + 0.11 * k) * 3.0 + 1.0 / 3.0;
}

/* Open HDF5 identifiers: every sub-test must leave as many open as it
 * found (valgrind cannot see leaked ids: HDF5 frees them at exit).  Files,
 * groups, datasets and attributes are counted by HDF5; dataspaces,
 * datatypes and property lists by probing every serial number below a
 * fresh identifier of that type (an hid_t is the type in the top bits and
 * a serial number below). */
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

static void run(void (*test)(void), const char *name)
{
    static const char *const what[4] = {"file objects", "dataspaces", "datatypes",
                                        "property lists"};
    long before[4], after[4];
    count_ids(before);
    test();
    count_ids(after);
    for (int i = 0; i < 4; i++) {
        if (before[i] != after[i])
            fprintf(stderr, "%s: %ld %s left open\n", name, after[i] - before[i], what[i]);
        CHECK_EQ_INT(after[i], before[i]);
    }
}

/* ------------------------------------------------------------- hashing */

static void test_hash(void)
{
    dtx_mesh m, m2;
    char hex[17];
    uint64_t h;
    CHECK(dtx_hash_bytes(DTX_HASH_INIT, "", 0) == DTX_HASH_INIT);
    /* Published FNV-1a 64 test vectors. */
    CHECK(dtx_hash_bytes(DTX_HASH_INIT, "a", 1) == UINT64_C(0xaf63dc4c8601ec8c));
    CHECK(dtx_hash_bytes(DTX_HASH_INIT, "foobar", 6) == UINT64_C(0x85944171f73967e8));
    make_tet(&m, 1.0);
    dtx_mesh_copy(&m, &m2, NULL);
    h = dtx_mesh_hash(&m);
    CHECK(h == dtx_mesh_hash(&m2));
    m2.V[5] = nextafter(m2.V[5], 10.0);
    CHECK(h != dtx_mesh_hash(&m2));
    m2.V[5] = m.V[5];
    m2.F[0] = 1, m2.F[1] = 0; /* same set of indices, different order */
    CHECK(h != dtx_mesh_hash(&m2));
    {
        /* The definition: bytes of V then bytes of F (little-endian host). */
        const uint16_t one = 1;
        if (*(const unsigned char *)&one == 1) {
            uint64_t r = dtx_hash_bytes(DTX_HASH_INIT, m.V, sizeof(double) * 12);
            r = dtx_hash_bytes(r, m.F, sizeof(int32_t) * 12);
            CHECK(r == h);
        }
    }
    dtx_hash_hex(UINT64_C(0x00ab), hex);
    CHECK(strcmp(hex, "00000000000000ab") == 0);
    dtx_mesh_free(&m);
    dtx_mesh_free(&m2);
}

/* -------------------------------------------------------------- paths */

static void test_paths(void)
{
    char tmp[DTX_H5_PATH_MAX];
    dtx_error e;
    hid_t f = h5check_new_file(SCRATCH "paths.h5"), g;
    CHECK_OK(dtx_h5_tmp_path("/meshes/lion", tmp, sizeof tmp, &e), &e);
    CHECK(strcmp(tmp, "/meshes/.dtx-tmp-lion") == 0);
    CHECK_OK(dtx_h5_tmp_path("/x", tmp, sizeof tmp, &e), &e);
    CHECK(strcmp(tmp, "/.dtx-tmp-x") == 0);
    CHECK_EQ_INT(dtx_h5_tmp_path("meshes/lion", tmp, sizeof tmp, &e), DTX_EINVAL);
    CHECK_EQ_INT(dtx_h5_tmp_path("/meshes/", tmp, sizeof tmp, &e), DTX_EINVAL);
    CHECK_EQ_INT(dtx_h5_tmp_path("/meshes/lion", tmp, 10, &e), DTX_EINVAL);

    CHECK_EQ_INT(dtx_h5_path_exists(f, "/"), 1);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/a/b/c"), 0);
    CHECK_OK(dtx_h5_create_groups(f, "/a/b/c", &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/a/b/c"), 1);
    CHECK_OK(dtx_h5_create_groups(f, "/a/b/c", &e), &e); /* existing is fine */
    CHECK_EQ_INT(dtx_h5_create_groups(f, "a/b", &e), DTX_EINVAL);

    /* Commit: tmp -> final, then no tmp remains. */
    CHECK_OK(dtx_h5_create_groups(f, "/things/.dtx-tmp-one", &e), &e);
    CHECK_OK(dtx_h5_write_attr_int(f, "/things/.dtx-tmp-one", "marker", 11, &e), &e);
    CHECK_OK(dtx_h5_commit_group(f, "/things/.dtx-tmp-one", "/things/one", 0, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/things/.dtx-tmp-one"), 0);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/things/one"), 1);
    /* Committing over an existing object needs replace. */
    CHECK_OK(dtx_h5_create_groups(f, "/things/.dtx-tmp-one", &e), &e);
    CHECK_OK(dtx_h5_write_attr_int(f, "/things/.dtx-tmp-one", "marker", 22, &e), &e);
    CHECK_EQ_INT(dtx_h5_commit_group(f, "/things/.dtx-tmp-one", "/things/one", 0, &e),
                 DTX_EINVAL);
    CHECK(check_contains(e.msg, "already exists"));
    CHECK(check_contains(e.msg, "paths.h5: /things/one"));
    CHECK_OK(dtx_h5_commit_group(f, "/things/.dtx-tmp-one", "/things/one", 1, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/things/.dtx-tmp-one"), 0);
    {
        int64_t v = 0;
        CHECK_OK(dtx_h5_read_attr_int(f, "/things/one", "marker", &v, &e), &e);
        CHECK_EQ_INT(v, 22);
    }
    /* Commit into a parent that does not exist yet. */
    CHECK_OK(dtx_h5_create_groups(f, "/.dtx-tmp-z", &e), &e);
    CHECK_OK(dtx_h5_commit_group(f, "/.dtx-tmp-z", "/new/parent/z", 0, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/new/parent/z"), 1);
    CHECK_EQ_INT(dtx_h5_commit_group(f, "/nothing", "/new/x", 0, &e), DTX_EINVAL);

    CHECK_OK(dtx_h5_remove(f, "/things/one", &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/things/one"), 0);
    CHECK_OK(dtx_h5_remove(f, "/things/one", &e), &e); /* absent: no-op */

    /* A dangling soft link does not "exist". */
    g = H5Gopen2(f, "/things", H5P_DEFAULT);
    CHECK(g >= 0);
    CHECK(H5Lcreate_soft("/nowhere", g, "dangling", H5P_DEFAULT, H5P_DEFAULT) >= 0);
    H5Gclose(g);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/things/dangling"), 0);

    /* Listing: groups only, sorted, temporary names and datasets skipped. */
    {
        char **names = NULL;
        int64_t n = -1;
        hsize_t dim = 1;
        hid_t sp = H5Screate_simple(1, &dim, NULL), d;
        CHECK_OK(dtx_h5_create_groups(f, "/list/walk", &e), &e);
        CHECK_OK(dtx_h5_create_groups(f, "/list/gallop", &e), &e);
        CHECK_OK(dtx_h5_create_groups(f, "/list/.dtx-tmp-run", &e), &e);
        CHECK_OK(dtx_h5_create_groups(f, "/list/Zebra", &e), &e);
        d = H5Dcreate2(f, "/list/data", H5T_NATIVE_INT, sp, H5P_DEFAULT, H5P_DEFAULT,
                       H5P_DEFAULT);
        CHECK(d >= 0);
        H5Dclose(d);
        H5Sclose(sp);
        CHECK_OK(dtx_h5_list_groups(f, "/list", &names, &n, &e), &e);
        CHECK_EQ_INT(n, 3);
        if (n == 3) {
            CHECK(strcmp(names[0], "Zebra") == 0);
            CHECK(strcmp(names[1], "gallop") == 0);
            CHECK(strcmp(names[2], "walk") == 0);
        }
        dtx_h5_free_strings(&names, n);
        CHECK(names == NULL);
        CHECK_OK(dtx_h5_list_groups(f, "/list/walk", &names, &n, &e), &e);
        CHECK_EQ_INT(n, 0);
        CHECK(names == NULL);
        CHECK_EQ_INT(dtx_h5_list_groups(f, "/list/data", &names, &n, &e), DTX_EFORMAT);
        CHECK(check_contains(e.msg, "/list/data"));
        CHECK_EQ_INT(dtx_h5_list_groups(f, "/absent", &names, &n, &e), DTX_EFORMAT);
    }
    CHECK_OK(dtx_h5_close(&f, &e), &e);
    CHECK(f < 0);
    CHECK_OK(dtx_h5_close(&f, &e), &e); /* closing twice is a no-op */
}

/* --------------------------------------------------------- attributes */

static void test_attributes(void)
{
    dtx_error e;
    hid_t f = h5check_new_file(SCRATCH "attrs.h5");
    char *s = NULL;
    int64_t v = 0;
    CHECK_OK(dtx_h5_read_attr_str(f, ".", "format", &s, &e), &e);
    CHECK(s && strcmp(s, "dtx") == 0);
    free(s);
    CHECK_OK(dtx_h5_read_attr_int(f, ".", "format_version", &v, &e), &e);
    CHECK_EQ_INT(v, 1);
    CHECK_OK(dtx_h5_read_attr_str(f, ".", "created_by", &s, &e), &e);
    CHECK(s && strcmp(s, "dtx " DTX_VERSION) == 0);
    free(s);

    /* Replacing an attribute, also with another type. */
    CHECK_OK(dtx_h5_write_attr_str(f, ".", "x", "first", &e), &e);
    CHECK_OK(dtx_h5_write_attr_str(f, ".", "x", "second, longer \xc3\xa9", &e), &e);
    CHECK_OK(dtx_h5_read_attr_str(f, ".", "x", &s, &e), &e);
    CHECK(s && strcmp(s, "second, longer \xc3\xa9") == 0);
    free(s);
    CHECK_OK(dtx_h5_write_attr_int(f, ".", "x", -7, &e), &e);
    CHECK_OK(dtx_h5_read_attr_int(f, ".", "x", &v, &e), &e);
    CHECK_EQ_INT(v, -7);
    CHECK_EQ_INT(dtx_h5_write_attr_int(f, ".", "big", INT64_C(1) << 40, &e), DTX_ERANGE);
    /* Wrong kind and missing. */
    CHECK_EQ_INT(dtx_h5_read_attr_str(f, ".", "x", &s, &e), DTX_EFORMAT);
    CHECK(s == NULL);
    CHECK(check_contains(e.msg, "attribute x: expected a string, found integer"));
    CHECK_EQ_INT(dtx_h5_read_attr_int(f, ".", "nope", &v, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "attrs.h5: /: has no attribute nope"));

    /* Fixed-length, space-padded strings and 64-bit integers (as other
     * writers, h5py with numpy types, produce them) are accepted. */
    {
        hid_t t = H5Tcopy(H5T_C_S1), sp = H5Screate(H5S_SCALAR), a;
        int64_t big = 123456789;
        H5Tset_size(t, 8);
        H5Tset_strpad(t, H5T_STR_SPACEPAD);
        a = H5Acreate2(f, "fixed", t, sp, H5P_DEFAULT, H5P_DEFAULT);
        CHECK(a >= 0 && H5Awrite(a, t, "abc     ") >= 0);
        H5Aclose(a);
        a = H5Acreate2(f, "i64", H5T_STD_I64LE, sp, H5P_DEFAULT, H5P_DEFAULT);
        CHECK(a >= 0 && H5Awrite(a, H5T_NATIVE_INT64, &big) >= 0);
        H5Aclose(a);
        H5Sclose(sp);
        H5Tclose(t);
        CHECK_OK(dtx_h5_read_attr_str(f, ".", "fixed", &s, &e), &e);
        CHECK(s && strcmp(s, "abc") == 0);
        free(s);
        CHECK_OK(dtx_h5_read_attr_int(f, ".", "i64", &v, &e), &e);
        CHECK_EQ_INT(v, 123456789);
    }
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* ---------------------------------------------------------- open/create */

static void write_text(const char *path, const char *text)
{
    FILE *fp = fopen(path, "w");
    CHECK(fp != NULL);
    if (fp) {
        fputs(text, fp);
        fclose(fp);
    }
}

static void test_open(void)
{
    dtx_error e;
    hid_t f = H5I_INVALID_HID;
    hid_t raw;

    /* A plain HDF5 file without the root attributes. */
    raw = H5Fcreate(SCRATCH "plain.h5", H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(raw >= 0);
    H5Fclose(raw);
    CHECK_EQ_INT(dtx_h5_open(SCRATCH "plain.h5", MPI_COMM_NULL, 0, &f, &e), DTX_EFORMAT);
    CHECK(f < 0);
    CHECK(check_contains(e.msg, "plain.h5: not a dtx file"));
    CHECK(check_contains(e.msg, "no attribute 'format'"));

    /* Another format name. */
    f = h5check_new_file(SCRATCH "other.h5");
    CHECK_OK(dtx_h5_write_attr_str(f, ".", "format", "mdx", &e), &e);
    dtx_h5_close(&f, &e);
    CHECK_EQ_INT(dtx_h5_open(SCRATCH "other.h5", MPI_COMM_NULL, 0, &f, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "format is \"mdx\", expected \"dtx\""));

    /* A future version. */
    f = h5check_new_file(SCRATCH "v2.h5");
    CHECK_OK(dtx_h5_write_attr_int(f, ".", "format_version", 2, &e), &e);
    dtx_h5_close(&f, &e);
    CHECK_EQ_INT(dtx_h5_open(SCRATCH "v2.h5", MPI_COMM_NULL, 0, &f, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "v2.h5: format_version is 2, but this dtx reads version 1 only"));

    /* Not HDF5 at all, and missing. */
    write_text(SCRATCH "text.h5", "this is not HDF5\n");
    CHECK_EQ_INT(dtx_h5_open(SCRATCH "text.h5", MPI_COMM_NULL, 0, &f, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "text.h5: not an HDF5 file"));
    CHECK_EQ_INT(dtx_h5_open(SCRATCH "missing.h5", MPI_COMM_NULL, 0, &f, &e), DTX_EIO);
    CHECK(check_contains(e.msg, "missing.h5: cannot open: No such file or directory"));
    CHECK_EQ_INT(dtx_h5_create(SCRATCH "no/such/dir/x.h5", MPI_COMM_NULL, &f, &e), DTX_EIO);
    CHECK(check_contains(e.msg, "x.h5: cannot create the file"));

    /* A good file opens read-only and read-write. */
    f = h5check_new_file(SCRATCH "good.h5");
    dtx_h5_close(&f, &e);
    CHECK_OK(dtx_h5_open(SCRATCH "good.h5", MPI_COMM_NULL, 0, &f, &e), &e);
    CHECK_EQ_INT(dtx_h5_is_parallel(f), 0);
    dtx_h5_close(&f, &e);
    CHECK_OK(dtx_h5_open(SCRATCH "good.h5", MPI_COMM_NULL, 1, &f, &e), &e);
    dtx_h5_close(&f, &e);
}

/* --------------------------------------------------------------- meshes */

static void test_mesh_roundtrip(void)
{
    dtx_error e;
    dtx_mesh m, r;
    hid_t f = h5check_new_file(SCRATCH "mesh.h5");
    char *s = NULL, hex[17];
    int64_t v;
    int32_t nv = 0, nf = 0;
    make_tet(&m, 2.0);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/tet", &m, "tet.obj", &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/meshes/.dtx-tmp-tet"), 0);
    CHECK_OK(dtx_h5_read_mesh(f, "/meshes/tet", &r, &e), &e);
    CHECK_EQ_INT(r.nv, 4);
    CHECK_EQ_INT(r.nf, 4);
    CHECK(r.V && memcmp(r.V, m.V, sizeof(double) * 12) == 0);
    CHECK(r.F && memcmp(r.F, m.F, sizeof(int32_t) * 12) == 0);
    dtx_mesh_free(&r);
    CHECK_OK(dtx_h5_mesh_size(f, "/meshes/tet", &nv, &nf, &e), &e);
    CHECK_EQ_INT(nv, 4);
    CHECK_EQ_INT(nf, 4);
    CHECK_OK(dtx_h5_read_attr_str(f, "/meshes/tet", "source", &s, &e), &e);
    CHECK(s && strcmp(s, "tet.obj") == 0);
    free(s);
    CHECK_OK(dtx_h5_read_attr_int(f, "/meshes/tet", "nv", &v, &e), &e);
    CHECK_EQ_INT(v, 4);
    CHECK_OK(dtx_h5_read_attr_int(f, "/meshes/tet", "nf", &v, &e), &e);
    CHECK_EQ_INT(v, 4);
    CHECK_OK(dtx_h5_read_attr_str(f, "/meshes/tet", "content_hash", &s, &e), &e);
    dtx_hash_hex(dtx_mesh_hash(&m), hex);
    CHECK(s && strcmp(s, hex) == 0);
    free(s);
    /* Storage types as documented. */
    {
        hid_t d = H5Dopen2(f, "/meshes/tet/vertices", H5P_DEFAULT), t = H5Dget_type(d);
        CHECK(H5Tequal(t, H5T_IEEE_F64LE) > 0);
        H5Tclose(t);
        H5Dclose(d);
        d = H5Dopen2(f, "/meshes/tet/faces", H5P_DEFAULT);
        t = H5Dget_type(d);
        CHECK(H5Tequal(t, H5T_STD_I32LE) > 0);
        H5Tclose(t);
        H5Dclose(d);
    }
    /* No overwriting; a stale temporary group is cleared. */
    CHECK_EQ_INT(dtx_h5_write_mesh(f, "/meshes/tet", &m, "x", &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "mesh.h5: /meshes/tet: already exists"));
    CHECK_OK(dtx_h5_create_groups(f, "/meshes/.dtx-tmp-tet2", &e), &e);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/tet2", &m, NULL, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/meshes/.dtx-tmp-tet2"), 0);
    CHECK_OK(dtx_h5_read_attr_str(f, "/meshes/tet2", "source", &s, &e), &e);
    CHECK(s && s[0] == '\0');
    free(s);
    /* Missing group. */
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/none", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "mesh.h5: /meshes/none: missing"));
    CHECK(r.V == NULL && r.nv == 0);
    dtx_mesh_free(&m);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* Writes a raw dataset (any type/shape) into group g, optionally chunked
 * and left unwritten. */
static void raw_dset(hid_t f, const char *path, hid_t ftype, hid_t mtype, int rank,
                     const hsize_t *dims, const void *data, int chunked)
{
    hid_t sp = H5Screate_simple(rank, dims, NULL), dcpl = H5Pcreate(H5P_DATASET_CREATE), d;
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    if (chunked) {
        hsize_t ch[3] = {1, 1, 1};
        for (int k = 0; k < rank; k++)
            ch[k] = dims[k] < 16 ? (dims[k] ? dims[k] : 1) : 16;
        H5Pset_chunk(dcpl, rank, ch);
    }
    d = H5Dcreate2(f, path, ftype, sp, lcpl, dcpl, H5P_DEFAULT);
    CHECK(d >= 0);
    if (data)
        CHECK(H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0);
    H5Dclose(d);
    H5Pclose(lcpl);
    H5Pclose(dcpl);
    H5Sclose(sp);
}

static void test_mesh_rejects(void)
{
    dtx_error e;
    dtx_mesh m, r;
    hid_t f = h5check_new_file(SCRATCH "badmesh.h5");
    double V[12];
    int32_t F[12], Vi[12];
    hsize_t d43[2] = {4, 3}, d44[2] = {4, 4}, d12[1] = {12};
    make_tet(&m, 1.0);
    memcpy(V, m.V, sizeof V);
    memcpy(F, m.F, sizeof F);
    for (int i = 0; i < 12; i++)
        Vi[i] = (int32_t)i;

    /* Integer vertices. */
    raw_dset(f, "/meshes/intv/vertices", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, Vi, 0);
    raw_dset(f, "/meshes/intv/faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, F, 0);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/intv", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "badmesh.h5: /meshes/intv/vertices: expected float values, found "
                          "integer"));
    /* Rank 1. */
    raw_dset(f, "/meshes/r1/vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, d12, V, 0);
    raw_dset(f, "/meshes/r1/faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, F, 0);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/r1", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/meshes/r1/vertices: expected 2 dimensions nv x 3, found 1"));
    /* Four columns. */
    raw_dset(f, "/meshes/c4/vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, d44,
             (double[16]){0}, 0);
    raw_dset(f, "/meshes/c4/faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, F, 0);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/c4", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/meshes/c4/vertices: expected shape nv x 3, found 4 x 4"));
    /* Face index out of range. */
    F[7] = 4;
    raw_dset(f, "/meshes/oor/vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, d43, V, 0);
    raw_dset(f, "/meshes/oor/faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, F, 0);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/oor", &r, &e), DTX_ERANGE);
    CHECK(check_contains(e.msg, "badmesh.h5: /meshes/oor: face 2 (0-based) has vertex index 4 out "
                          "of range [0, 4)"));
    F[7] = m.F[7];
    /* Missing faces. */
    raw_dset(f, "/meshes/nof/vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, d43, V, 0);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/nof", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/meshes/nof/faces: missing"));
    /* Absurd dims, no data: 2^40 x 3 must fail before allocating. */
    {
        hsize_t huge[2] = {(hsize_t)1 << 40, 3}, big[2] = {(hsize_t)1 << 28, 3};
        raw_dset(f, "/meshes/huge/vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, huge, NULL,
                 1);
        raw_dset(f, "/meshes/huge/faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, F, 0);
        CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/huge", &r, &e), DTX_ERANGE);
        CHECK(check_contains(e.msg, "/meshes/huge/vertices: dimension 0 is 1099511627776, more than "
                              "the 2147483647 dtx supports"));
        /* 2^28 x 3 doubles (6 GiB) fits int32 but was never written. */
        raw_dset(f, "/meshes/big/vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, big, NULL, 1);
        raw_dset(f, "/meshes/big/faces", H5T_STD_I32LE, H5T_NATIVE_INT32, 2, d43, F, 0);
        CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/big", &r, &e), DTX_EFORMAT);
        CHECK(check_contains(e.msg, "/meshes/big/vertices: shape 268435456 x 3 needs 6442450944 "
                              "bytes, but only 0 bytes are stored"));
        /* The same through a compressed dataset: within gzip's ratio? no. */
        {
            hid_t sp = H5Screate_simple(2, big, NULL), dcpl = H5Pcreate(H5P_DATASET_CREATE);
            hsize_t ch[2] = {1024, 3};
            double row[3072];
            hid_t d, ms, fs;
            hsize_t start[2] = {0, 0}, cnt[2] = {1024, 3};
            memset(row, 0, sizeof row);
            H5Pset_chunk(dcpl, 2, ch);
            H5Pset_deflate(dcpl, 9);
            d = H5Dcreate2(f, "/meshes/big/gz", H5T_IEEE_F64LE, sp, H5P_DEFAULT, dcpl,
                           H5P_DEFAULT);
            ms = H5Screate_simple(2, cnt, NULL);
            fs = H5Dget_space(d);
            H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, cnt, NULL);
            CHECK(H5Dwrite(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, row) >= 0);
            H5Sclose(fs);
            H5Sclose(ms);
            H5Dclose(d);
            H5Pclose(dcpl);
            H5Sclose(sp);
            CHECK_OK(dtx_h5_remove(f, "/meshes/big/vertices", &e), &e);
            CHECK(H5Lmove(f, "/meshes/big/gz", f, "/meshes/big/vertices", H5P_DEFAULT,
                          H5P_DEFAULT) >= 0);
            CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/big", &r, &e), DTX_EFORMAT);
            CHECK(check_contains(e.msg, "compressed bytes are stored"));
        }
    }
    /* Redundant counts and the content hash must agree with the data. */
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/ok", &m, "ok.obj", &e), &e);
    CHECK_OK(dtx_h5_write_attr_int(f, "/meshes/ok", "nv", 5, &e), &e);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/ok", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "/meshes/ok: attribute nv is 5, but vertices has 4"));
    CHECK_OK(dtx_h5_write_attr_int(f, "/meshes/ok", "nv", 4, &e), &e);
    CHECK_OK(dtx_h5_write_attr_str(f, "/meshes/ok", "content_hash", "0123456789abcdef", &e),
             &e);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/ok", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "content_hash is \"0123456789abcdef\" but the data hashes to"));
    /* A repeated vertex is caught by dtx_mesh_validate. */
    m.F[1] = m.F[0];
    CHECK_EQ_INT(dtx_h5_write_mesh(f, "/meshes/rep", &m, NULL, &e), DTX_OK);
    CHECK_EQ_INT(dtx_h5_read_mesh(f, "/meshes/rep", &r, &e), DTX_EMESH);
    CHECK(check_contains(e.msg, "badmesh.h5: /meshes/rep: face 0 (0-based) repeats a vertex"));
    CHECK(r.V == NULL);
    dtx_mesh_free(&m);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* ------------------------------------------------------------ sequences */

static void fill_frames(double *X, int64_t first, int64_t count, int32_t nv)
{
    for (int64_t t = 0; t < count; t++)
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                X[(t * nv + i) * 3 + k] = frame_value(first + t, i, k);
}

static void check_dcpl(hid_t dset, hsize_t cf, int32_t nv, int gzip)
{
    hid_t dcpl = H5Dget_create_plist(dset);
    hsize_t ch[3] = {0, 0, 0};
    CHECK_EQ_INT(H5Pget_layout(dcpl), H5D_CHUNKED);
    CHECK_EQ_INT(H5Pget_chunk(dcpl, 3, ch), 3);
    CHECK_EQ_INT(ch[0], cf);
    CHECK_EQ_INT(ch[1], nv);
    CHECK_EQ_INT(ch[2], 3);
    if (gzip) {
        unsigned flags, cd[4] = {0};
        size_t ncd = 4;
        char name[64];
        CHECK_EQ_INT(H5Pget_nfilters(dcpl), 2);
        CHECK_EQ_INT(H5Pget_filter2(dcpl, 0, &flags, &ncd, cd, sizeof name, name, NULL),
                     H5Z_FILTER_SHUFFLE);
        ncd = 4;
        CHECK_EQ_INT(H5Pget_filter2(dcpl, 1, &flags, &ncd, cd, sizeof name, name, NULL),
                     H5Z_FILTER_DEFLATE);
        CHECK_EQ_INT(cd[0], 4);
    } else {
        CHECK_EQ_INT(H5Pget_nfilters(dcpl), 0);
    }
    H5Pclose(dcpl);
}

static void test_sequences(void)
{
    enum { T = 20, NV = 4 };
    dtx_error e;
    dtx_mesh m;
    dtx_h5_seq s, s2;
    hid_t f = h5check_new_file(SCRATCH "seq.h5");
    double X[T * NV * 3], Y[T * NV * 3];
    const char *names[T];
    char namebuf[T][16], **rn = NULL, *str = NULL;
    int64_t v;
    make_tet(&m, 1.0);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/tet", &m, "tet.obj", &e), &e);
    fill_frames(X, 0, T, NV);
    for (int t = 0; t < T; t++) {
        snprintf(namebuf[t], sizeof namebuf[t], "pose-%02d.obj", t);
        names[t] = namebuf[t];
    }
    names[3] = NULL; /* stored as "" */

    /* float32, default chunking (16 frames), gzip. */
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/walk", "/meshes/tet", T, NV, 0, 0, 1, &s, &e),
             &e);
    CHECK_EQ_INT(s.chunk_frames, 16);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/walk"), 0); /* not yet visible */
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/.dtx-tmp-walk/positions"), 1);
    CHECK_OK(dtx_h5_seq_write(&s, 0, 7, X, 0, &e), &e);
    CHECK_OK(dtx_h5_seq_write(&s, 7, 13, X + 7 * NV * 3, 0, &e), &e);
    CHECK_OK(dtx_h5_seq_write(&s, 20, 0, NULL, 0, &e), &e);
    CHECK_EQ_INT(dtx_h5_seq_write(&s, 15, 6, X, 0, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "frames [15, 21) are outside the 20 frames"));
    CHECK_EQ_INT(dtx_h5_write_frame_names(&s, names, T - 1, &e), DTX_EINVAL);
    CHECK_OK(dtx_h5_write_frame_names(&s, names, T, &e), &e);
    CHECK_OK(dtx_h5_seq_commit(&s, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/.dtx-tmp-walk"), 0);
    CHECK(strcmp(s.path, "/sequences/walk") == 0);
    dtx_h5_seq_close(&s);
    dtx_h5_seq_close(&s); /* twice is fine */

    CHECK_OK(dtx_h5_seq_open(f, "/sequences/walk", &s, &e), &e);
    CHECK_EQ_INT(s.nframes, T);
    CHECK_EQ_INT(s.nv, NV);
    CHECK_EQ_INT(s.is_f64, 0);
    CHECK_EQ_INT(s.chunk_frames, 16);
    check_dcpl(s.dset, 16, NV, 1);
    CHECK_OK(dtx_h5_seq_read(&s, 0, T, Y, &e), &e);
    {
        int exact = 1;
        double maxrel = 0;
        for (int i = 0; i < T * NV * 3; i++) {
            exact &= Y[i] == (double)(float)X[i];
            if (fabs(Y[i] - X[i]) > maxrel * fabs(X[i]))
                maxrel = fabs(Y[i] - X[i]) / fabs(X[i]);
        }
        CHECK(exact); /* the float32 rounding of each value, nothing worse */
        CHECK_DBL(maxrel, <=, FLT_EPSILON);
    }
    CHECK_OK(dtx_h5_seq_read(&s, 5, 3, Y, &e), &e);
    CHECK(Y[0] == (double)(float)X[5 * NV * 3]);
    CHECK_EQ_INT(dtx_h5_seq_read(&s, -1, 2, Y, &e), DTX_EINVAL);
    CHECK_OK(dtx_h5_read_frame_names(&s, &rn, &e), &e);
    CHECK(rn && strcmp(rn[0], "pose-00.obj") == 0 && strcmp(rn[19], "pose-19.obj") == 0 &&
          rn[3][0] == '\0');
    dtx_h5_free_strings(&rn, s.nframes);
    CHECK(rn == NULL);
    CHECK_OK(dtx_h5_read_attr_str(f, "/sequences/walk", "rest_mesh", &str, &e), &e);
    CHECK(str && strcmp(str, "/meshes/tet") == 0);
    free(str);
    CHECK_OK(dtx_h5_read_attr_int(f, "/sequences/walk", "nframes", &v, &e), &e);
    CHECK_EQ_INT(v, T);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/walk/rest/faces"), 1);
    {
        H5L_info_t li;
        CHECK(H5Lget_info(f, "/sequences/walk/rest", &li, H5P_DEFAULT) >= 0);
        CHECK_EQ_INT(li.type, H5L_TYPE_SOFT);
    }
    dtx_h5_seq_close(&s);

    /* float64, 5-frame chunks, no filter: exact. */
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/walk64", "/meshes/tet", T, NV, 1, 5, 0, &s, &e),
             &e);
    CHECK_OK(dtx_h5_seq_write(&s, 0, T, X, 0, &e), &e);
    CHECK_OK(dtx_h5_seq_commit(&s, &e), &e);
    dtx_h5_seq_close(&s);
    CHECK_OK(dtx_h5_seq_open(f, "/sequences/walk64", &s2, &e), &e);
    CHECK_EQ_INT(s2.is_f64, 1);
    check_dcpl(s2.dset, 5, NV, 0);
    CHECK_OK(dtx_h5_seq_read(&s2, 0, T, Y, &e), &e);
    CHECK(memcmp(X, Y, sizeof X) == 0);
    CHECK_OK(dtx_h5_read_frame_names(&s2, &rn, &e), &e);
    CHECK(rn == NULL); /* none written */
    dtx_h5_seq_close(&s2);

    /* Chunk larger than T is clamped. */
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/short", "/meshes/tet", 3, NV, 0, 64, 0, &s, &e),
             &e);
    CHECK_EQ_INT(s.chunk_frames, 3);
    dtx_h5_seq_close(&s); /* never committed: stays temporary */
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/short"), 0);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/.dtx-tmp-short"), 1);

    /* Bad arguments and a mismatched rest mesh. */
    CHECK_EQ_INT(dtx_h5_seq_create(f, "/sequences/bad", "/meshes/tet", T, 5, 0, 0, 0, &s, &e),
                 DTX_EINVAL);
    CHECK(check_contains(e.msg, "seq.h5: /sequences/bad: rest mesh /meshes/tet has 4 vertices, but "
                          "the data has 5"));
    CHECK_EQ_INT(dtx_h5_seq_create(f, "/sequences/bad", "/meshes/none", T, 4, 0, 0, 0, &s, &e),
                 DTX_EFORMAT);
    CHECK(check_contains(e.msg, "seq.h5: /sequences/bad: rest mesh /meshes/none cannot be used: "
                          "/meshes/none: missing (no such mesh group)"));
    CHECK_EQ_INT(dtx_h5_seq_create(f, "/sequences/bad", "/meshes/tet", 0, 4, 0, 0, 0, &s, &e),
                 DTX_EINVAL);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/.dtx-tmp-bad"), 0);

    /* Wrong rank of positions. */
    {
        hsize_t d2[2] = {T, NV * 3};
        raw_dset(f, "/sequences/flat/positions", H5T_IEEE_F32LE, H5T_NATIVE_DOUBLE, 2, d2, X,
                 0);
        CHECK_EQ_INT(dtx_h5_seq_open(f, "/sequences/flat", &s, &e), DTX_EFORMAT);
        CHECK(check_contains(e.msg, "seq.h5: /sequences/flat/positions: expected 3 dimensions "
                              "T x nv x 3, found 2"));
        CHECK_EQ_INT(dtx_h5_seq_open(f, "/sequences/none", &s, &e), DTX_EFORMAT);
        CHECK(check_contains(e.msg, "/sequences/none: missing"));
    }
    dtx_mesh_free(&m);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* Reads of float32 frames larger than the pieces they are widened in
 * (1,024 values): every value of a 9-frame, 150-vertex sequence (4,050
 * values) and of a read from frame 2 is the float32 rounding of what was
 * written, in the right place; a float64 sequence reads back exactly. */
static void test_sequence_big_reads(void)
{
    enum { T = 9, NV = 150 };
    static double X[T * NV * 3], Y[T * NV * 3];
    dtx_error e;
    dtx_mesh m;
    dtx_h5_seq s;
    hid_t f = h5check_new_file(SCRATCH "seq-big.h5");
    dtx_mesh_alloc(&m, NV, 1, NULL);
    for (int i = 0; i < NV * 3; i++)
        m.V[i] = frame_value(0, i / 3, i % 3);
    m.F[0] = 0, m.F[1] = 1, m.F[2] = 2;
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/strip", &m, "strip.obj", &e), &e);
    fill_frames(X, 0, T, NV);
    for (int f64 = 0; f64 <= 1; f64++) {
        const char *path = f64 ? "/sequences/big64" : "/sequences/big32";
        int exact = 1, exact_from2 = 1;
        CHECK_OK(dtx_h5_seq_create(f, path, "/meshes/strip", T, NV, f64, 0, 0, &s, &e), &e);
        CHECK_OK(dtx_h5_seq_write(&s, 0, T, X, 0, &e), &e);
        CHECK_OK(dtx_h5_seq_commit(&s, &e), &e);
        dtx_h5_seq_close(&s);
        CHECK_OK(dtx_h5_seq_open(f, path, &s, &e), &e);
        CHECK_EQ_INT(s.is_f64, f64);
        CHECK_OK(dtx_h5_seq_read(&s, 0, T, Y, &e), &e);
        for (int i = 0; i < T * NV * 3; i++)
            exact &= Y[i] == (f64 ? X[i] : (double)(float)X[i]);
        CHECK(exact);
        CHECK_OK(dtx_h5_seq_read(&s, 2, 5, Y, &e), &e);
        for (int i = 0; i < 5 * NV * 3; i++) {
            const double x = X[2 * NV * 3 + i];
            exact_from2 &= Y[i] == (f64 ? x : (double)(float)x);
        }
        CHECK(exact_from2);
        dtx_h5_seq_close(&s);
    }
    dtx_mesh_free(&m);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* -------------------------------------------------------------- markers */

static void test_markers(void)
{
    dtx_error e;
    dtx_markers mk, r;
    hid_t f = h5check_new_file(SCRATCH "markers.h5");
    char *s = NULL;
    int64_t v;
    CHECK_OK(dtx_markers_alloc(&mk, 3, &e), &e);
    for (int i = 0; i < 3; i++) {
        mk.src[i] = i;
        mk.tgt[i] = 10 + 2 * i;
    }
    mk.labels[0] = malloc(8);
    strcpy(mk.labels[0], "nose");
    mk.labels[2] = malloc(8);
    strcpy(mk.labels[2], "tail");
    CHECK_OK(dtx_h5_write_markers(f, "/markers/cat-lion", &mk, "/meshes/cat", NULL, &e), &e);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/markers/.dtx-tmp-cat-lion"), 0);
    CHECK_OK(dtx_h5_read_markers(f, "/markers/cat-lion", &r, &e), &e);
    CHECK_EQ_INT(r.n, 3);
    CHECK(memcmp(r.src, mk.src, 3 * sizeof(int32_t)) == 0);
    CHECK(memcmp(r.tgt, mk.tgt, 3 * sizeof(int32_t)) == 0);
    CHECK(r.labels && strcmp(r.labels[0], "nose") == 0 && r.labels[1][0] == '\0' &&
          strcmp(r.labels[2], "tail") == 0);
    dtx_markers_free(&r);
    CHECK_OK(dtx_h5_read_attr_int(f, "/markers/cat-lion", "index_base", &v, &e), &e);
    CHECK_EQ_INT(v, 0);
    CHECK_OK(dtx_h5_read_attr_str(f, "/markers/cat-lion", "source_mesh", &s, &e), &e);
    CHECK(s && strcmp(s, "/meshes/cat") == 0);
    free(s);
    CHECK_OK(dtx_h5_read_attr_str(f, "/markers/cat-lion", "target_mesh", &s, &e), &e);
    CHECK(s && s[0] == '\0');
    free(s);

    /* 1-based sets are refused; so are negative indices and length
     * mismatches. */
    CHECK_OK(dtx_h5_write_markers(f, "/markers/b1", &mk, NULL, NULL, &e), &e);
    CHECK_OK(dtx_h5_write_attr_int(f, "/markers/b1", "index_base", 1, &e), &e);
    CHECK_EQ_INT(dtx_h5_read_markers(f, "/markers/b1", &r, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "markers.h5: /markers/b1: index_base is 1"));
    mk.tgt[1] = -3;
    CHECK_OK(dtx_h5_write_markers(f, "/markers/neg", &mk, NULL, NULL, &e), &e);
    CHECK_EQ_INT(dtx_h5_read_markers(f, "/markers/neg", &r, &e), DTX_ERANGE);
    CHECK(check_contains(e.msg, "/markers/neg/target_vertex: entry 1 is -3"));
    CHECK(r.src == NULL);
    {
        hsize_t d2[1] = {2};
        int32_t two[2] = {1, 2};
        raw_dset(f, "/markers/short/source_vertex", H5T_STD_I32LE, H5T_NATIVE_INT32, 1,
                 (hsize_t[1]){3}, mk.src, 0);
        raw_dset(f, "/markers/short/target_vertex", H5T_STD_I32LE, H5T_NATIVE_INT32, 1, d2, two,
                 0);
        CHECK_EQ_INT(dtx_h5_read_markers(f, "/markers/short", &r, &e), DTX_EFORMAT);
        CHECK(check_contains(e.msg, "/markers/short/target_vertex: has 2 entries, expected 3"));
    }
    dtx_markers_free(&mk);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* ------------------------------------------------------ correspondences */

static void test_corr(void)
{
    dtx_error e;
    dtx_h5_corr c;
    hid_t f = h5check_new_file(SCRATCH "corr.h5");
    int32_t pairs[10] = {0, 1, 1, 1, 2, 0, 3, 3, 3, 2};
    double def[12];
    char *g = NULL;
    dtx_h5_corr_meta meta = {"00ff00ff00ff00ff", "/meshes/cat", "/meshes/lion",
                             "/markers/cat-lion", "{\"w_smooth\": 1.0}"};
    for (int i = 0; i < 12; i++)
        def[i] = 0.25 * i - 1.0 / 7.0;
    CHECK_OK(dtx_h5_write_corr(f, "/correspondences/c1", pairs, 5, def, 4, &meta, &e), &e);
    CHECK_OK(dtx_h5_read_corr(f, "/correspondences/c1", 4, 4, 4, &c, &e), &e);
    CHECK_EQ_INT(c.npairs, 5);
    CHECK_EQ_INT(c.nv_s, 4);
    CHECK(c.pairs && memcmp(c.pairs, pairs, sizeof pairs) == 0);
    CHECK(c.deformed_src && memcmp(c.deformed_src, def, sizeof def) == 0);
    CHECK(c.key && strcmp(c.key, meta.key) == 0);
    CHECK(c.source_mesh && strcmp(c.source_mesh, "/meshes/cat") == 0);
    CHECK(c.target_mesh && strcmp(c.target_mesh, "/meshes/lion") == 0);
    CHECK(c.markers && strcmp(c.markers, "/markers/cat-lion") == 0);
    CHECK(c.parameters && strcmp(c.parameters, meta.parameters) == 0);
    CHECK(c.dtx_version && strcmp(c.dtx_version, DTX_VERSION) == 0);
    dtx_h5_corr_free(&c);
    CHECK(c.pairs == NULL);
    dtx_h5_corr_free(&c);

    /* Lookup by key. */
    meta.key = "1111222233334444";
    CHECK_OK(dtx_h5_write_corr(f, "/correspondences/c2", pairs, 5, def, 4, &meta, &e), &e);
    CHECK_OK(dtx_h5_find_corr_by_key(f, "00ff00ff00ff00ff", &g, &e), &e);
    CHECK(g && strcmp(g, "/correspondences/c1") == 0);
    free(g);
    CHECK_OK(dtx_h5_find_corr_by_key(f, "1111222233334444", &g, &e), &e);
    CHECK(g && strcmp(g, "/correspondences/c2") == 0);
    free(g);
    CHECK_OK(dtx_h5_find_corr_by_key(f, "nope", &g, &e), &e);
    CHECK(g == NULL);

    /* Range checks against the meshes' sizes. */
    CHECK_EQ_INT(dtx_h5_read_corr(f, "/correspondences/c1", 4, 3, 4, &c, &e), DTX_ERANGE);
    CHECK(check_contains(e.msg, "corr.h5: /correspondences/c1/pairs: pair 3 (3, 3) is out of range"));
    CHECK_EQ_INT(dtx_h5_read_corr(f, "/correspondences/c1", 5, -1, -1, &c, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, "deformed_source: has 4 rows, but the source mesh has 5"));
    CHECK_OK(dtx_h5_read_corr(f, "/correspondences/c1", -1, -1, -1, &c, &e), &e);
    dtx_h5_corr_free(&c);
    CHECK_OK(dtx_h5_close(&f, &e), &e);

    /* A file without correspondences. */
    f = h5check_new_file(SCRATCH "corr-none.h5");
    CHECK_OK(dtx_h5_find_corr_by_key(f, "x", &g, &e), &e);
    CHECK(g == NULL);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* -------------------------------------------------------------- results */

static void test_results(void)
{
    enum { T = 10, NV = 4 };
    dtx_error e;
    dtx_mesh m;
    dtx_h5_result r;
    hid_t f = h5check_new_file(SCRATCH "result.h5");
    double X[T * NV * 3], Y[T * NV * 3], res[T], rr[T];
    uint8_t done[T];
    int64_t v;
    char *s = NULL;
    dtx_h5_provenance prov = {"sp04", "{\"dtx_job\": 1}", "{\"w_smooth\": 1}",
                              "cat.h5:/sequences/walk", "/meshes/lion", ""};
    make_tet(&m, 3.0);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/lion", &m, "lion.obj", &e), &e);
    fill_frames(X, 0, T, NV);
    for (int t = 0; t < T; t++)
        res[t] = 1e-3 * t;

    CHECK_OK(dtx_h5_result_create(f, "/results/lion", &prov, T, NV, 0, 4, 0, &r, &e), &e);
    CHECK_EQ_INT(r.chunk_frames, 4);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/results/lion"), 0);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/results/.dtx-tmp-lion/target/vertices"), 1);
    check_dcpl(r.positions, 4, NV, 0);
    /* Nothing written yet: frame_done 0, residual NaN. */
    CHECK_OK(dtx_h5_result_read_done(&r, done, &e), &e);
    CHECK_EQ_INT(done[0] + done[9], 0);
    /* Per-frame solver figures: absent until added, -1 until written. */
    {
        int32_t fs[T * DTX_H5_FRAME_STATS], got[T * DTX_H5_FRAME_STATS];
        for (int i = 0; i < T * DTX_H5_FRAME_STATS; i++)
            fs[i] = 100 + i;
        CHECK(r.frame_stats < 0);
        CHECK_EQ_INT(dtx_h5_result_write_frame_stats(&r, 0, 1, fs, 0, &e), DTX_EINVAL);
        CHECK_OK(dtx_h5_result_add_frame_stats(&r, &e), &e);
        CHECK_EQ_INT(dtx_h5_result_add_frame_stats(&r, &e), DTX_EINVAL);
        CHECK_OK(dtx_h5_result_read_frame_stats(&r, 0, T, got, &e), &e);
        CHECK(got[0] == -1 && got[T * DTX_H5_FRAME_STATS - 1] == -1);
        CHECK_OK(dtx_h5_result_write_frame_stats(&r, 2, 3, fs, 0, &e), &e);
        CHECK_EQ_INT(dtx_h5_result_write_frame_stats(&r, 9, 2, fs, 0, &e), DTX_EINVAL);
        CHECK_OK(dtx_h5_result_read_frame_stats(&r, 1, 5, got, &e), &e);
        CHECK(got[0] == -1 && got[3] == 100 && got[11] == 108 && got[12] == -1);
        CHECK_OK(dtx_h5_read_attr_str(r.group, "frame_stats", "columns", &s, &e), &e);
        CHECK(s && strcmp(s, "iterations converged inverted") == 0);
        free(s);
        s = NULL;
    }
    /* The final gradient norms likewise: absent until added, NaN until
     * written. */
    {
        double g[T], gotg[T];
        for (int i = 0; i < T; i++)
            g[i] = 0.25 * i;
        CHECK(r.frame_grad_norm < 0);
        CHECK_EQ_INT(dtx_h5_result_write_frame_grad_norm(&r, 0, 1, g, 0, &e), DTX_EINVAL);
        CHECK_EQ_INT(dtx_h5_result_read_frame_grad_norm(&r, 0, 1, gotg, &e), DTX_EINVAL);
        CHECK_OK(dtx_h5_result_add_frame_grad_norm(&r, &e), &e);
        CHECK_EQ_INT(dtx_h5_result_add_frame_grad_norm(&r, &e), DTX_EINVAL);
        CHECK_OK(dtx_h5_result_read_frame_grad_norm(&r, 0, T, gotg, &e), &e);
        CHECK(isnan(gotg[0]) && isnan(gotg[T - 1]));
        CHECK_OK(dtx_h5_result_write_frame_grad_norm(&r, 2, 3, g, 0, &e), &e);
        CHECK_EQ_INT(dtx_h5_result_write_frame_grad_norm(&r, 9, 2, g, 0, &e), DTX_EINVAL);
        CHECK_OK(dtx_h5_result_read_frame_grad_norm(&r, 1, 5, gotg, &e), &e);
        CHECK(isnan(gotg[0]) && gotg[1] == 0.0 && gotg[3] == 0.5 && isnan(gotg[4]));
    }
    CHECK_OK(dtx_h5_result_write(&r, 0, 4, X, res, 0, &e), &e);
    CHECK_OK(dtx_h5_result_write(&r, 4, 4, X + 4 * NV * 3, NULL, 0, &e), &e);
    CHECK_OK(dtx_h5_result_read_done(&r, done, &e), &e);
    CHECK(done[0] == 1 && done[7] == 1 && done[8] == 0 && done[9] == 0);
    CHECK_OK(dtx_h5_read_attr_int(r.group, ".", "complete", &v, &e), &e);
    CHECK_EQ_INT(v, 0);
    /* Finishing with frames missing is refused. */
    CHECK_EQ_INT(dtx_h5_result_finish(&r, 0, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "result.h5: /results/.dtx-tmp-lion: cannot mark the result complete: "
                          "frame 8 (0-based) was not written"));
    dtx_h5_result_close(&r);

    /* Resume: the interrupted result is found under its temporary name. */
    CHECK_EQ_INT(dtx_h5_result_open(f, "/results/lion", 0, &r, &e), DTX_EFORMAT);
    CHECK_OK(dtx_h5_result_open(f, "/results/lion", 1, &r, &e), &e);
    CHECK_EQ_INT(r.nframes, T);
    CHECK_EQ_INT(r.nv, NV);
    CHECK_EQ_INT(r.chunk_frames, 4);
    CHECK_EQ_INT(r.committed, 0);
    CHECK(r.frame_stats >= 0); /* reopened with the result */
    {
        int32_t got[DTX_H5_FRAME_STATS];
        CHECK_OK(dtx_h5_result_read_frame_stats(&r, 4, 1, got, &e), &e);
        CHECK(got[0] == 106 && got[2] == 108);
    }
    CHECK(r.frame_grad_norm >= 0);
    {
        double gotg[1];
        CHECK_OK(dtx_h5_result_read_frame_grad_norm(&r, 3, 1, gotg, &e), &e);
        CHECK(gotg[0] == 0.25);
    }
    CHECK_OK(dtx_h5_result_read_done(&r, done, &e), &e);
    CHECK(done[7] == 1 && done[8] == 0);
    CHECK_OK(dtx_h5_result_write(&r, 8, 2, X + 8 * NV * 3, res + 8, 0, &e), &e);
    CHECK_EQ_INT(dtx_h5_result_write(&r, 8, 3, X, NULL, 0, &e), DTX_EINVAL);
    CHECK_OK(dtx_h5_result_finish(&r, 0, &e), &e);
    CHECK_EQ_INT(r.committed, 1);
    CHECK(strcmp(r.path, "/results/lion") == 0);
    dtx_h5_result_close(&r);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/results/.dtx-tmp-lion"), 0);

    /* Several at once: nothing is marked or moved while one is incomplete. */
    {
        dtx_h5_result a, b;
        dtx_h5_result *both[2] = {&a, &b};
        CHECK_OK(dtx_h5_result_create(f, "/results/many/a", &prov, 3, NV, 0, 4, 0, &a, &e), &e);
        CHECK_OK(dtx_h5_result_create(f, "/results/many/b", &prov, 3, NV, 1, 4, 0, &b, &e), &e);
        CHECK_OK(dtx_h5_result_write(&a, 0, 3, X, res, 0, &e), &e);
        CHECK_OK(dtx_h5_result_write(&b, 0, 2, X, res, 0, &e), &e);
        CHECK_EQ_INT(dtx_h5_results_finish(both, 2, 0, &e), DTX_EINVAL);
        CHECK(check_contains(e.msg, "/results/many/.dtx-tmp-b: cannot mark the result complete: "
                              "frame 2 (0-based) was not written"));
        CHECK_EQ_INT(dtx_h5_path_exists(f, "/results/many/a"), 0);
        CHECK_OK(dtx_h5_read_attr_int(a.group, ".", "complete", &v, &e), &e);
        CHECK_EQ_INT(v, 0);
        CHECK_OK(dtx_h5_result_write(&b, 2, 1, X, res, 0, &e), &e);
        CHECK_OK(dtx_h5_results_finish(both, 2, 0, &e), &e);
        CHECK_EQ_INT(a.committed + b.committed, 2);
        dtx_h5_result_close(&a);
        dtx_h5_result_close(&b);
        CHECK_OK(dtx_h5_read_attr_int(f, "/results/many/a", "complete", &v, &e), &e);
        CHECK_EQ_INT(v, 1);
        CHECK_OK(dtx_h5_read_attr_int(f, "/results/many/b", "complete", &v, &e), &e);
        CHECK_EQ_INT(v, 1);
        CHECK_OK(dtx_h5_results_finish(both, 0, 0, &e), &e); /* none: a no-op */
    }

    /* Read back. */
    CHECK_OK(dtx_h5_result_open(f, "/results/lion", 0, &r, &e), &e);
    CHECK_EQ_INT(r.is_f64, 0);
    CHECK_OK(dtx_h5_result_read(&r, 0, T, Y, rr, &e), &e);
    {
        int exact = 1;
        for (int i = 0; i < T * NV * 3; i++)
            exact &= Y[i] == (double)(float)X[i];
        CHECK(exact);
    }
    CHECK(rr[0] == res[0] && rr[3] == res[3] && rr[8] == res[8] && rr[9] == res[9]);
    CHECK(isnan(rr[4]) && isnan(rr[7])); /* written without residuals */
    CHECK_OK(dtx_h5_read_attr_int(f, "/results/lion", "complete", &v, &e), &e);
    CHECK_EQ_INT(v, 1);
    {
        static const char *const names[] = {"method", "job", "parameters", "source_sequence",
                                            "target_mesh", "correspondence", "dtx_version"};
        const char *want[] = {prov.method, prov.job, prov.parameters, prov.source_sequence,
                              prov.target_mesh, prov.correspondence, DTX_VERSION};
        for (int i = 0; i < 7; i++) {
            CHECK_OK(dtx_h5_read_attr_str(f, "/results/lion", names[i], &s, &e), &e);
            CHECK(s && strcmp(s, want[i]) == 0);
            free(s);
        }
    }
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/results/lion/target/faces"), 1);
    dtx_h5_result_close(&r);

    /* Replacing a finished result; float64 and gzip. */
    CHECK_OK(dtx_h5_result_create(f, "/results/lion", &prov, T, NV, 1, 0, 1, &r, &e), &e);
    CHECK_EQ_INT(r.chunk_frames, T);
    check_dcpl(r.positions, T, NV, 1);
    CHECK_OK(dtx_h5_result_write(&r, 0, T, X, res, 0, &e), &e);
    CHECK_EQ_INT(dtx_h5_result_finish(&r, 0, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "/results/lion: already exists"));
    CHECK_OK(dtx_h5_result_finish(&r, 1, &e), &e);
    dtx_h5_result_close(&r);
    CHECK_OK(dtx_h5_result_open(f, "/results/lion", 0, &r, &e), &e);
    CHECK_EQ_INT(r.is_f64, 1);
    CHECK_OK(dtx_h5_result_read(&r, 0, T, Y, NULL, &e), &e);
    CHECK(memcmp(X, Y, sizeof X) == 0);
    dtx_h5_result_close(&r);

    /* The target must exist with the right size. */
    prov.target_mesh = "/meshes/none";
    CHECK_EQ_INT(dtx_h5_result_create(f, "/results/x", &prov, T, NV, 0, 0, 0, &r, &e),
                 DTX_EFORMAT);
    CHECK(check_contains(e.msg, "result.h5: /results/x: target mesh /meshes/none cannot be used"));
    prov.target_mesh = "/meshes/lion";
    CHECK_EQ_INT(dtx_h5_result_create(f, "/results/x", &prov, T, NV + 1, 0, 0, 0, &r, &e),
                 DTX_EINVAL);
    CHECK(check_contains(e.msg, "target mesh /meshes/lion has 4 vertices, but the data has 5"));
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/results/.dtx-tmp-x"), 0);
    dtx_mesh_free(&m);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

/* One name rule (dtx_h5_check_name) and every writer applies it to the
 * last part of its group path before creating anything. */
/* float32 frames written in strips (write_frames): frames of 360 KB,
 * chunks of 3 frames, one call of 11 frames (strips of whole chunks and a
 * short last chunk) and a call starting inside the dataset; every value
 * reads back (whole, and from inside the dataset: read_frames' strips) as
 * the float32 of what was written, frame_done all set. */
static void test_result_strips(void)
{
    enum { T = 14, NV = 30000 };
    dtx_error e;
    dtx_mesh m;
    dtx_h5_result r;
    hid_t f = h5check_new_file(SCRATCH "strips.h5");
    double *X = malloc(sizeof *X * T * NV * 3), *Y = malloc(sizeof *Y * T * NV * 3);
    double res[T];
    uint8_t done[T];
    long bad = 0;
    dtx_h5_provenance prov = {"sp04", "{\"dtx_job\": 1}", "{}", "a.h5:/sequences/s", "/meshes/m",
                              ""};
    CHECK(X && Y);
    /* NV / 3 separate triangles. */
    CHECK_OK(dtx_mesh_alloc(&m, NV, NV / 3, &e), &e);
    for (int32_t i = 0; i < NV; i++) {
        m.V[3 * i] = i / 3 + (i % 3 == 1);
        m.V[3 * i + 1] = i % 3 == 2;
        m.V[3 * i + 2] = 0.0;
        m.F[i] = i;
    }
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/m", &m, "m.obj", &e), &e);
    fill_frames(X, 0, T, NV);
    for (int t = 0; t < T; t++)
        res[t] = t;
    CHECK_OK(dtx_h5_result_create(f, "/results/m", &prov, T, NV, 0, 3, 0, &r, &e), &e);
    CHECK_OK(dtx_h5_result_write(&r, 0, 11, X, res, 0, &e), &e);
    CHECK_OK(dtx_h5_result_write(&r, 11, 3, X + (size_t)11 * NV * 3, res + 11, 0, &e), &e);
    CHECK_OK(dtx_h5_result_read(&r, 0, T, Y, NULL, &e), &e);
    for (size_t i = 0; i < (size_t)T * NV * 3; i++)
        bad += Y[i] != (double)(float)X[i];
    if (bad)
        fprintf(stderr, "  %ld values differ from their float32\n", bad);
    CHECK(bad == 0);
    /* Read back in strips too (read_frames): a call starting inside a
     * strip (a first strip of 1 frame, then 3, 3, 3 and 2), into a buffer
     * of NaNs, so that a frame left out or widened from floats already
     * overwritten would show. */
    for (size_t i = 0; i < (size_t)T * NV * 3; i++)
        Y[i] = NAN;
    CHECK_OK(dtx_h5_result_read(&r, 2, T - 2, Y, NULL, &e), &e);
    for (size_t i = 0; i < (size_t)(T - 2) * NV * 3; i++)
        bad += !(Y[i] == (double)(float)X[(size_t)2 * NV * 3 + i]);
    if (bad)
        fprintf(stderr, "  %ld values of frames [2, %d) differ from their float32\n", bad, T);
    CHECK(bad == 0);
    CHECK_OK(dtx_h5_result_read_done(&r, done, &e), &e);
    for (int t = 0; t < T; t++)
        CHECK(done[t] == 1);
    CHECK_OK(dtx_h5_result_finish(&r, 0, &e), &e);
    dtx_h5_result_close(&r);
    dtx_mesh_free(&m);
    free(X);
    free(Y);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

static void test_names(void)
{
    static const char *const good[] = {"lion", "a", "...", "..x", ".x", ".dtx", ".dtxtmp",
                                       "big lion", "cat-poses.01", "\xc3\xa9t\xc3\xa9"};
    static const struct {
        const char *name, *why;
    } bad[] = {{"", "it is empty"},
               {"a/b", "contains '/'"},
               {".", "current and the parent group"},
               {"..", "current and the parent group"},
               {".dtx-", "reserved"},
               {".dtx-tmp-x", "reserved"},
               {".dtx-lock", "reserved"},
               {"tab\there", "control character 0x09 (byte 3)"},
               {"del\x7f", "control character 0x7f"}};
    char longname[DTX_H5_NAME_MAX + 2];
    dtx_error e;
    dtx_mesh m;
    hid_t f = h5check_new_file(SCRATCH "names.h5");
    dtx_h5_seq s;
    for (size_t i = 0; i < sizeof good / sizeof *good; i++)
        CHECK_OK(dtx_h5_check_name(good[i], &e), &e);
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        CHECK_EQ_INT(dtx_h5_check_name(bad[i].name, &e), DTX_EINVAL);
        CHECK(check_contains(e.msg, "cannot name an HDF5 object"));
        CHECK(check_contains(e.msg, bad[i].why));
    }
    CHECK(strchr(e.msg, 0x7f) == NULL); /* shown as '?' */
    memset(longname, 'n', DTX_H5_NAME_MAX);
    longname[DTX_H5_NAME_MAX] = '\0';
    CHECK_OK(dtx_h5_check_name(longname, &e), &e);
    longname[DTX_H5_NAME_MAX] = 'n';
    longname[DTX_H5_NAME_MAX + 1] = '\0';
    CHECK_EQ_INT(dtx_h5_check_name(longname, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "256 bytes long, more than 255"));

    /* The writers: refused before anything is created. */
    make_tet(&m, 1.0);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/tet", &m, "tet.obj", &e), &e);
    CHECK_EQ_INT(dtx_h5_write_mesh(f, "/meshes/..", &m, NULL, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "names.h5: /meshes/..: \"..\" cannot name an HDF5 object"));
    CHECK_EQ_INT(dtx_h5_write_mesh(f, "/meshes/.dtx-tmp-x", &m, NULL, &e), DTX_EINVAL);
    CHECK(check_contains(e.msg, "reserved"));
    CHECK_EQ_INT(dtx_h5_seq_create(f, "/sequences/.", "/meshes/tet", 3, 4, 0, 0, 0, &s, &e),
                 DTX_EINVAL);
    dtx_h5_seq_close(&s);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/meshes/.dtx-tmp-.."), 0);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/meshes/.dtx-tmp-.dtx-tmp-x"), 0);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences/.dtx-tmp-."), 0);
    CHECK_EQ_INT(dtx_h5_path_exists(f, "/sequences"), 0);
    dtx_mesh_free(&m);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
}

int main(void)
{
    dtx_h5_init();
    run(test_hash, "hash");
    run(test_paths, "paths");
    run(test_attributes, "attributes");
    run(test_open, "open");
    run(test_mesh_roundtrip, "mesh_roundtrip");
    run(test_mesh_rejects, "mesh_rejects");
    run(test_sequences, "sequences");
    run(test_sequence_big_reads, "sequence_big_reads");
    run(test_markers, "markers");
    run(test_corr, "corr");
    run(test_results, "results");
    run(test_result_strips, "result_strips");
    run(test_names, "names");
    return check_report();
}
