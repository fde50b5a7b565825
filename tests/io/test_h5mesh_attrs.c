/* test_h5mesh_attrs.c: a mesh's optional attributes in the HDF5 layout
 * (io/h5mesh_attrs.c) and their check in `dtx validate`: a good set round
 * trips and validates; each malformed set (index out of range, data
 * without its indices, a material without names or beyond them, colours
 * out of [0, 1], non-finite normals, a wrong shape) is reported with the
 * dataset and the problem named. */
#include "check.h"
#include "h5layout.h"
#include "h5mesh_attrs.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

/* A quad split in two triangles, with a UV seam (4 vertices, 5 UVs: the
 * corner of face 1 at vertex 0 uses its own UV), a normal per vertex,
 * two materials and RGBA colours. */
static double V[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static int32_t F[6] = {0, 1, 2, 0, 2, 3};
static double UV[10] = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5};
static int32_t UVF[6] = {0, 1, 2, 4, 2, 3};
static double N[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
static int32_t NF[6] = {0, 1, 2, 0, 2, 3};
static int32_t MAT[2] = {0, 1};
static double COL[16] = {1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1, 1, 1, 1, 0.5};

static void make(const char *path)
{
    static char m0[] = "skin", m1[] = "fur", lib[] = "quad.mtl";
    char *names[2] = {m0, m1};
    dtx_mesh m = {0};
    dtx_mesh_attrs a = {0};
    dtx_error e;
    hid_t f;
    m.nv = 4, m.nf = 2, m.V = V, m.F = F;
    a.nuv = 5, a.uv = UV, a.uv_faces = UVF;
    a.nn = 4, a.normals = N, a.normal_faces = NF;
    a.nmat = 2, a.material = MAT, a.material_names = names, a.mtllib = lib;
    a.ncolor = 4, a.colors = COL;
    CHECK_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &e), &e);
    CHECK_OK(dtx_h5_write_mesh_with(f, "/meshes/quad", &m, &a, "quad.obj", &e), &e);
    CHECK_OK(dtx_h5_close(&f, &e), &e);
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

/* Replaces group/name by a float64 or int32 dataset of the given shape. */
static void put(hid_t f, const char *name, int is_int, int rank, hsize_t r, hsize_t c,
                const void *data)
{
    char path[128];
    hsize_t d[2] = {r, c};
    hid_t sp, ds;
    snprintf(path, sizeof path, "/meshes/quad/%s", name);
    if (H5Lexists(f, path, H5P_DEFAULT) > 0)
        CHECK(H5Ldelete(f, path, H5P_DEFAULT) >= 0);
    sp = H5Screate_simple(rank, d, NULL);
    ds = H5Dcreate2(f, path, is_int ? H5T_STD_I32LE : H5T_IEEE_F64LE, sp, H5P_DEFAULT,
                    H5P_DEFAULT, H5P_DEFAULT);
    CHECK(ds >= 0);
    CHECK(H5Dwrite(ds, is_int ? H5T_NATIVE_INT32 : H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL,
                   H5P_DEFAULT, data) >= 0);
    H5Dclose(ds);
    H5Sclose(sp);
}

static void expect_bad(const char *path, const char *what)
{
    dtx_error e;
    char *report = NULL;
    CHECK_EQ_INT(dtx_h5_validate(path, &report, &e), DTX_EFORMAT);
    CHECK(check_contains(e.msg, path));
    CHECK(check_contains(e.msg, "/meshes/quad"));
    CHECK(check_contains(e.msg, what));
    CHECK(check_contains(report, "problem"));
    free(report);
}

static void test_good(void)
{
    const char *path = SCRATCH "attrs-good.h5";
    dtx_mesh_attrs a;
    dtx_error e;
    char *report = NULL;
    hid_t f;
    make(path);
    CHECK_OK(dtx_h5_validate(path, &report, &e), &e);
    CHECK(check_contains(report, "/meshes/quad: ok\n"));
    free(report);
    f = reopen(path);
    CHECK_OK(dtx_h5_check_mesh_attrs(f, "/meshes/quad", &e), &e);
    CHECK_OK(dtx_h5_read_mesh_attrs(f, "/meshes/quad", 4, 2, &a, &e), &e);
    CHECK_EQ_INT(a.nuv, 5);
    CHECK_EQ_INT(a.nn, 4);
    CHECK_EQ_INT(a.nmat, 2);
    CHECK_EQ_INT(a.ncolor, 4);
    CHECK(a.uv && memcmp(a.uv, UV, sizeof UV) == 0);
    CHECK(a.uv_faces && memcmp(a.uv_faces, UVF, sizeof UVF) == 0);
    CHECK(a.normal_faces && memcmp(a.normal_faces, NF, sizeof NF) == 0);
    CHECK(a.colors && memcmp(a.colors, COL, sizeof COL) == 0);
    CHECK(a.material_names && strcmp(a.material_names[1], "fur") == 0);
    CHECK(a.mtllib && strcmp(a.mtllib, "quad.mtl") == 0);
    dtx_mesh_attrs_free(&a);
    done(f);
}

/* Each case: make the good file, break one thing, validate. */
static void test_bad(void)
{
    const char *path = SCRATCH "attrs-bad.h5";
    hid_t f;
    /* A uv index beyond the uv rows: the layout's range check. */
    {
        int32_t bad[6] = {0, 1, 2, 4, 2, 5};
        make(path);
        f = reopen(path);
        put(f, "uv_faces", 1, 2, 2, 3, bad);
        done(f);
        expect_bad(path, "uv_faces");
        expect_bad(path, "out of range [0, 5)");
    }
    /* A negative normal index. */
    {
        int32_t bad[6] = {0, 1, 2, 0, -1, 3};
        make(path);
        f = reopen(path);
        put(f, "normal_faces", 1, 2, 2, 3, bad);
        done(f);
        expect_bad(path, "normal_faces");
    }
    /* uv without uv_faces. */
    make(path);
    f = reopen(path);
    CHECK(H5Ldelete(f, "/meshes/quad/uv_faces", H5P_DEFAULT) >= 0);
    done(f);
    expect_bad(path, "without its data");
    /* uv_faces of the wrong row count. */
    make(path);
    f = reopen(path);
    put(f, "uv_faces", 1, 2, 1, 3, UVF);
    done(f);
    expect_bad(path, "uv_faces");
    /* uv with three columns. */
    make(path);
    f = reopen(path);
    put(f, "uv", 0, 2, 5, 3, (double[15]){0});
    done(f);
    expect_bad(path, "expected shape");
    /* A non-finite normal. */
    {
        double bad[12];
        memcpy(bad, N, sizeof bad);
        bad[7] = NAN;
        make(path);
        f = reopen(path);
        put(f, "normals", 0, 2, 4, 3, bad);
        done(f);
        expect_bad(path, "not finite");
    }
    /* A material beyond its names: only the attributes' own check knows
     * the count of names. */
    {
        int32_t bad[2] = {0, 2};
        make(path);
        f = reopen(path);
        put(f, "material", 1, 1, 2, 0, bad);
        /* the replaced dataset lost its names: put them back */
        {
            dtx_error e;
            CHECK_OK(dtx_h5_write_attr_str(f, "/meshes/quad/material", "material_names",
                                           "skin\nfur", &e),
                     &e);
        }
        done(f);
        expect_bad(path, "material entry 1 (0-based) is 2, out of range [-1, 2)");
    }
    /* A material without names. */
    make(path);
    f = reopen(path);
    CHECK(H5Adelete_by_name(f, "/meshes/quad/material", "material_names", H5P_DEFAULT) >= 0);
    done(f);
    expect_bad(path, "material_names");
    /* A colour out of [0, 1]. */
    {
        double bad[16];
        memcpy(bad, COL, sizeof bad);
        bad[5] = 2.0;
        make(path);
        f = reopen(path);
        put(f, "colors", 0, 2, 4, 4, bad);
        done(f);
        expect_bad(path, "not in [0, 1]");
    }
    /* Two colour channels. */
    make(path);
    f = reopen(path);
    put(f, "colors", 0, 2, 4, 2, COL);
    done(f);
    expect_bad(path, "colors");
}

int main(void)
{
    dtx_h5_init();
    test_good();
    test_bad();
    return check_report();
}
