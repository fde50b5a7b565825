/* test_h5inspect.c: dtx_h5_inspect on a file holding one object of every
 * kind, a complete result and one left under its temporary name with some
 * frames done, an attribute dtx does not know and a foreign top-level
 * group; an object of a layout kind it has no reading for; and its errors on a missing file, a file
 * that is not HDF5 and an HDF5 file that is not in the dtx layout.  The file must not change. */
#include "check.h"
#include "h5inspect.h"
#include "h5layout.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

/* Two separate triangles: 6 vertices, 2 faces, 2 components. */
static void two_triangles(dtx_mesh *m)
{
    static const double V[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5, 6, 5, 5, 5, 6, -2};
    static const int32_t F[6] = {0, 1, 2, 3, 4, 5};
    dtx_mesh_alloc(m, 6, 2, NULL);
    memcpy(m->V, V, sizeof V);
    memcpy(m->F, F, sizeof F);
}

static const dtx_h5_item *find(const dtx_h5_summary *s, const char *path)
{
    for (int64_t i = 0; i < s->nitems; i++)
        if (strcmp(s->items[i].path, path) == 0)
            return &s->items[i];
    fprintf(stderr, "no item %s\n", path);
    return NULL;
}

static int same_text(const char *a, const char *b)
{
    int ok = a && b && strcmp(a, b) == 0;
    if (!ok)
        fprintf(stderr, "  \"%s\" != \"%s\"\n", a ? a : "(null)", b ? b : "(null)");
    return ok;
}

static void make_file(const char *path)
{
    dtx_error err;
    hid_t f = H5I_INVALID_HID;
    dtx_mesh m;
    dtx_markers mk;
    dtx_h5_seq seq;
    dtx_h5_result res;
    dtx_h5_corr_meta cm = {"0123456789abcdef", "/meshes/two", "/meshes/two", "/markers/mk",
                           "{\"a\": 1}"};
    dtx_h5_provenance prov = {"sp04",        "{\"dtx_job\": 1}",    "{}", "x.h5:/sequences/walk",
                              "/meshes/two", "/correspondences/two"};
    double X[3 * 18], r[3] = {0.5, 0.25, 2.0};
    int32_t pairs[4] = {0, 0, 1, 1};
    two_triangles(&m);
    for (int t = 0; t < 3; t++)
        for (int i = 0; i < 18; i++)
            X[18 * t + i] = m.V[i] + 0.1 * t;

    CHECK_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &err), &err);
    CHECK_OK(dtx_h5_write_mesh(f, "/meshes/two", &m, "two.obj", &err), &err);
    CHECK_OK(dtx_h5_seq_create(f, "/sequences/walk", "/meshes/two", 3, 6, 0, 0, 0, &seq, &err),
             &err);
    CHECK_OK(dtx_h5_seq_write(&seq, 0, 3, X, 0, &err), &err);
    CHECK_OK(dtx_h5_seq_commit(&seq, &err), &err);
    dtx_h5_seq_close(&seq);
    CHECK_OK(dtx_markers_alloc(&mk, 2, &err), &err);
    mk.src[0] = 0, mk.tgt[0] = 0, mk.src[1] = 3, mk.tgt[1] = 3;
    CHECK_OK(dtx_h5_write_markers(f, "/markers/mk", &mk, "/meshes/two", "/meshes/two", &err), &err);
    dtx_markers_free(&mk);
    CHECK_OK(dtx_h5_write_corr(f, "/correspondences/two", pairs, 2, m.V, 6, &cm, &err), &err);

    /* complete result, with an attribute dtx does not know */
    CHECK_OK(dtx_h5_result_create(f, "/results/two/walk", &prov, 3, 6, 1, 0, 0, &res, &err), &err);
    CHECK_OK(dtx_h5_result_write(&res, 0, 3, X, r, 0, &err), &err);
    CHECK_OK(dtx_h5_write_attr_str(res.group, ".", "note", "made by the test", &err), &err);
    CHECK_OK(dtx_h5_result_finish(&res, 0, &err), &err);
    dtx_h5_result_close(&res);
    /* interrupted result: frames 1 and 2 of 3 done */
    CHECK_OK(dtx_h5_result_create(f, "/results/two/part", &prov, 3, 6, 0, 0, 0, &res, &err), &err);
    CHECK_OK(dtx_h5_result_write(&res, 1, 2, X, r + 1, 0, &err), &err);
    dtx_h5_result_close(&res);
    CHECK_OK(dtx_h5_create_groups(f, "/extra", &err), &err);
    CHECK_OK(dtx_h5_close(&f, &err), &err);
    dtx_mesh_free(&m);
}

static void test_summary(void)
{
    const char *path = SCRATCH "all.h5";
    dtx_h5_summary s;
    dtx_error err;
    const dtx_h5_item *it;
    struct stat before, after;
    make_file(path);
    stat(path, &before);
    CHECK_OK(dtx_h5_inspect(path, &s, &err), &err);
    stat(path, &after);
    CHECK_EQ_INT(after.st_size, before.st_size);
    CHECK(after.st_mtime == before.st_mtime);

    CHECK(same_text(dtx_h5_attr_find(s.attrs, s.nattrs, "format"), "dtx"));
    CHECK(same_text(dtx_h5_attr_find(s.attrs, s.nattrs, "format_version"), "1"));
    CHECK_EQ_INT(s.nitems, 6);
    CHECK_EQ_INT(s.nother, 1);
    if (s.nother == 1)
        CHECK(same_text(s.other[0], "extra"));
    /* kinds: the layout's, in its order, the five read in full among them */
    CHECK_INT(s.nkinds, >=, 5);
    for (int64_t k = 0, seen = 0; k < s.nkinds; k++) {
        if (s.kinds[k].kind != DTX_H5_KIND_OTHER)
            CHECK_EQ_INT(s.kinds[k].kind, seen++);
        if (k == s.nkinds - 1)
            CHECK_EQ_INT(seen, 5);
    }
    for (int64_t i = 1; i < s.nitems; i++)
        CHECK_INT(s.items[i - 1].kind_index, <=, s.items[i].kind_index);
    for (int64_t i = 0; i < s.nitems; i++)
        CHECK_EQ_INT(s.items[i].kind, s.kinds[s.items[i].kind_index].kind);

    if ((it = find(&s, "/meshes/two")) != NULL) {
        CHECK_EQ_INT(it->kind, DTX_H5_KIND_MESH);
        CHECK_EQ_INT(it->nv, 6);
        CHECK_EQ_INT(it->nf, 2);
        CHECK_EQ_INT(it->components, 2);
        CHECK_DBL(it->bounds[0], ==, 0.0);
        CHECK_DBL(it->bounds[2], ==, -2.0);
        CHECK_DBL(it->bounds[4], ==, 6.0);
        CHECK(it->problem == NULL);
        CHECK(same_text(dtx_h5_attr_find(it->attrs, it->nattrs, "source"), "two.obj"));
    }
    if ((it = find(&s, "/sequences/walk")) != NULL) {
        CHECK_EQ_INT(it->nframes, 3);
        CHECK_EQ_INT(it->frames_done, 3);
        CHECK_EQ_INT(it->nv, 6);
        CHECK_EQ_INT(it->is_f64, 0);
        CHECK(same_text(it->mesh, "/meshes/two"));
    }
    if ((it = find(&s, "/markers/mk")) != NULL)
        CHECK_EQ_INT(it->count, 2);
    if ((it = find(&s, "/correspondences/two")) != NULL) {
        CHECK_EQ_INT(it->count, 2);
        CHECK_EQ_INT(it->nv, 6);
        CHECK(same_text(dtx_h5_attr_find(it->attrs, it->nattrs, "key"), "0123456789abcdef"));
    }
    if ((it = find(&s, "/results/two/walk")) != NULL) {
        CHECK_EQ_INT(it->temporary, 0);
        CHECK_EQ_INT(it->nframes, 3);
        CHECK_EQ_INT(it->frames_done, 3);
        CHECK_EQ_INT(it->is_f64, 1);
        CHECK_DBL(it->residual_min, ==, 0.25);
        CHECK_DBL(it->residual_max, ==, 2.0);
        CHECK_NEAR(it->residual_mean, 2.75 / 3.0, 1e-15);
        CHECK(same_text(it->mesh, "/meshes/two"));
        CHECK(same_text(dtx_h5_attr_find(it->attrs, it->nattrs, "complete"), "1"));
        CHECK(same_text(dtx_h5_attr_find(it->attrs, it->nattrs, "method"), "sp04"));
        CHECK(same_text(dtx_h5_attr_find(it->attrs, it->nattrs, "note"), "made by the test"));
    }
    if ((it = find(&s, "/results/two/" DTX_H5_TMP_PREFIX "part")) != NULL) {
        CHECK_EQ_INT(it->temporary, 1);
        CHECK_EQ_INT(it->nframes, 3);
        CHECK_EQ_INT(it->frames_done, 2);
        CHECK_DBL(it->residual_min, ==, 0.25);
        CHECK_DBL(it->residual_max, ==, 2.0);
        CHECK(same_text(dtx_h5_attr_find(it->attrs, it->nattrs, "complete"), "0"));
        CHECK(it->problem == NULL);
    }
    dtx_h5_summary_free(&s);
    CHECK(s.items == NULL && s.nitems == 0);
    dtx_h5_summary_free(NULL);
}

/* A kind of the layout description without a reading of its own (such as
 * /keypoints) is listed with its datasets' shapes; skipped when the layout
 * has no such kind. */
static void test_other_kind(void)
{
    const char *path = SCRATCH "other.h5";
    static const char *const five[] = {"/meshes", "/sequences", "/markers", "/correspondences",
                                       "/results"};
    char *text = dtx_h5_layout_json(), obj[256], dset[512], want[300];
    cJSON *desc = text ? cJSON_Parse(text) : NULL;
    const cJSON *k, *found = NULL;
    const char *group = NULL, *first = NULL;
    dtx_h5_summary s;
    dtx_error err;
    hid_t f = H5I_INVALID_HID, sp, ds;
    hsize_t dims[2] = {4, 3};
    int32_t zeros[12] = {0};
    free(text);
    cJSON_ArrayForEach(k, cJSON_GetObjectItemCaseSensitive(desc, "kinds"))
    {
        const char *g = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(k, "group"));
        const cJSON *d = cJSON_GetObjectItemCaseSensitive(k, "datasets");
        int is_known = 0;
        for (int i = 0; g && i < 5; i++)
            is_known |= strcmp(g, five[i]) == 0;
        if (g && !is_known && d && d->child && d->child->string && !found) {
            found = k;
            group = g;
            first = d->child->string;
        }
    }
    if (!found) {
        printf("note: the layout has no kind besides the five; other kinds not tested\n");
        cJSON_Delete(desc);
        return;
    }
    snprintf(obj, sizeof obj, "%s/x", group);
    snprintf(dset, sizeof dset, "%s/%s", obj, first);
    CHECK_OK(dtx_h5_create(path, MPI_COMM_NULL, &f, &err), &err);
    CHECK_OK(dtx_h5_create_groups(f, obj, &err), &err);
    sp = H5Screate_simple(2, dims, NULL);
    ds = H5Dcreate2(f, dset, H5T_STD_I32LE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(ds >= 0);
    H5Dwrite(ds, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, zeros);
    H5Dclose(ds);
    H5Sclose(sp);
    CHECK_OK(dtx_h5_close(&f, &err), &err);
    CHECK_OK(dtx_h5_inspect(path, &s, &err), &err);
    CHECK_EQ_INT(s.nitems, 1);
    CHECK_EQ_INT(s.nother, 0);
    if (s.nitems == 1) {
        snprintf(want, sizeof want, "%s (4 x 3)", first);
        CHECK_EQ_INT(s.items[0].kind, DTX_H5_KIND_OTHER);
        CHECK(same_text(s.items[0].path, obj));
        CHECK(same_text(s.kinds[s.items[0].kind_index].group, group));
        CHECK_EQ_INT(s.items[0].count, 4);
        CHECK(s.items[0].datasets && strstr(s.items[0].datasets, want) != NULL);
    }
    dtx_h5_summary_free(&s);
    cJSON_Delete(desc);
}

static void test_errors(void)
{
    dtx_h5_summary s;
    dtx_error err;
    FILE *f;
    hid_t h;
    CHECK_EQ_INT(dtx_h5_inspect(SCRATCH "missing.h5", &s, &err), DTX_EIO);
    CHECK(strstr(err.msg, "missing.h5") != NULL);
    CHECK(s.nitems == 0 && s.items == NULL);

    f = fopen(SCRATCH "text.h5", "w");
    fputs("not hdf5\n", f);
    fclose(f);
    CHECK(dtx_h5_inspect(SCRATCH "text.h5", &s, &err) != DTX_OK);
    CHECK(strstr(err.msg, "not an HDF5 file") != NULL);

    h = H5Fcreate(SCRATCH "plain.h5", H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(h >= 0);
    H5Fclose(h);
    CHECK_EQ_INT(dtx_h5_inspect(SCRATCH "plain.h5", &s, &err), DTX_EFORMAT);
    CHECK(strstr(err.msg, "not a dtx file") != NULL);
    if (!strstr(err.msg, "not a dtx file"))
        fprintf(stderr, "  message: %s\n", err.msg);
}

int main(void)
{
    dtx_h5_init();
    test_summary();
    test_other_kind();
    test_errors();
    CHECK_EQ_INT(H5Fget_obj_count((hid_t)H5F_OBJ_ALL, H5F_OBJ_ALL), 0);
    return check_report();
}
