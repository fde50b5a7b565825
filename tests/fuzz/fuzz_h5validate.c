/*
 * fuzz_h5validate.c: libFuzzer harness for the HDF5 layout validator
 * (dtx_h5_validate, src/io/h5validate.c) and the layout readers, by
 * structured mutation.
 *
 * Random bytes almost never make an HDF5 file, and when they do they test
 * HDF5's parser rather than dtx.  So this harness starts every run from a
 * complete, valid dtx file (built once) and reads the input as a list of
 * edits made through the HDF5 API: delete or replace datasets (any dtype,
 * rank and dims, written, unwritten, chunked or compressed), overwrite
 * single values (NaN, out-of-range indices...), replace attributes by
 * others of any type (strings of every kind, NULL strings, arrays, null
 * dataspaces), rewire links (soft, hard, external, dangling, cyclic), add,
 * copy and move groups.  The edited file is then validated and every group
 * read back (fz_check_file): clean errors only, and a file the validator
 * passes must be readable.
 */
#include "fuzz_h5common.h"

#include <errno.h>
#include <sys/wait.h>

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void *base;
static size_t base_size;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    char p[320];
    (void)argc;
    (void)argv;
    dtx_h5_init();
    fz_make_dir();
    snprintf(p, sizeof p, "%s/base.h5", fz_dir);
    fz_make_good(p);
    base = fz_read_file(p, &base_size);
    /* DTX_FUZZ_WRITE_BASE=FILE saves the starting file (a seed for h5raw). */
    if (getenv("DTX_FUZZ_WRITE_BASE"))
        fz_write_file(getenv("DTX_FUZZ_WRITE_BASE"), base, base_size);
    return 0;
}

/* ------------------------------------------------------------ the input */

typedef struct {
    const uint8_t *p;
    size_t n;
} fz_in;

static unsigned take(fz_in *in)
{
    if (in->n == 0)
        return 0;
    in->n--;
    return *in->p++;
}

static unsigned pick(fz_in *in, unsigned n) { return take(in) % n; }

static uint32_t take32(fz_in *in)
{
    uint32_t v = 0;
    for (int k = 0; k < 4; k++)
        v = v << 8 | take(in);
    return v;
}

/* An integer: small, special or raw. */
static int64_t take_int(fz_in *in)
{
    static const int64_t special[] = {
        0, 1, -1, 2, 3, 4, 5, 6, INT32_MAX, INT32_MIN, INT64_MAX, INT64_MIN, (int64_t)1 << 32};
    unsigned k = take(in);
    if (k < 128)
        return special[k % (sizeof special / sizeof special[0])];
    return (int32_t)take32(in);
}

static double take_double(fz_in *in)
{
    static const double special[] = {0.0, 1.0, -1.0, 1e300, -1e-300, 0.5};
    unsigned k = take(in);
    if (k < 40)
        return NAN;
    if (k < 80)
        return k & 1 ? INFINITY : -INFINITY;
    if (k < 160)
        return special[k % (sizeof special / sizeof special[0])];
    return (double)(int32_t)take32(in) / 16.0;
}

static const char *const paths[] = {
    "/meshes/cat",
    "/meshes/lion",
    "/sequences/walk",
    "/markers/cat-lion",
    "/correspondences/c",
    "/results/lion",
    "/results/by-target/walk",
    "/results/.dtx-tmp-lion2",
    "/results/by-target",
    "/meshes",
    "/sequences",
    "/markers",
    "/correspondences",
    "/results",
    "/",
    "/nonexistent",
    "",
    "/meshes/cat/",
    "/sequences/walk/rest",
    "/results/lion/target",
    "other.h5:/meshes/cat",
    "/meshes/lion/faces",
    "/meshes//cat",
    "/meshes/./cat",
};
#define NPATHS (sizeof paths / sizeof paths[0])

static const char *const dsets[] = {
    "/meshes/cat/vertices",
    "/meshes/cat/faces",
    "/meshes/lion/vertices",
    "/meshes/lion/faces",
    "/sequences/walk/positions",
    "/sequences/walk/frame_names",
    "/markers/cat-lion/source_vertex",
    "/markers/cat-lion/target_vertex",
    "/markers/cat-lion/label",
    "/correspondences/c/pairs",
    "/correspondences/c/deformed_source",
    "/results/lion/positions",
    "/results/lion/residual",
    "/results/lion/frame_done",
    "/results/by-target/walk/positions",
    "/results/by-target/walk/frame_done",
    "/meshes/new/vertices",
    "/results/by-target/walk2/residual",
};
#define NDSETS (sizeof dsets / sizeof dsets[0])

static const char *const attr_names[] = {
    "source",         "nv",       "nf",          "content_hash",
    "rest_mesh",      "nframes",  "source_mesh", "target_mesh",
    "index_base",     "key",      "markers",     "parameters",
    "dtx_version",    "method",   "job",         "source_sequence",
    "correspondence", "complete", "format",      "format_version",
    "created_by",     "other",
};
#define NATTR_NAMES (sizeof attr_names / sizeof attr_names[0])

static const char *const strings[] = {
    "/meshes/cat",
    "/meshes/lion",
    "/sequences/walk",
    "/markers/cat-lion",
    "/correspondences/c",
    "/results/lion",
    "",
    "dtx",
    "other.h5:/meshes/cat",
    "{",
    "{\"a\": 1}",
    "0123456789abcdef",
    "0123456789ABCDEF",
    "/",
    "/meshes",
    "/nonexistent",
    "sp04",
    "/meshes/cat/faces",
};
#define NSTRINGS (sizeof strings / sizeof strings[0])

/* A string from the table or from the input (up to 40 bytes, any bytes,
 * NUL-terminated in out). */
static void take_string(fz_in *in, char *out, size_t outsz)
{
    unsigned k = take(in);
    if (k < 200) {
        snprintf(out, outsz, "%s", strings[k % NSTRINGS]);
    } else {
        size_t n = pick(in, 41), i;
        for (i = 0; i < n && i + 1 < outsz; i++)
            out[i] = (char)take(in);
        out[i] = '\0';
    }
}

/* ------------------------------------------------------------ the edits */

/* A file dtype for new datasets and attributes (caller closes). */
static hid_t take_type(fz_in *in)
{
    static const hid_t *const fixed[] = {
        &H5T_STD_I8LE_g,   &H5T_STD_U8LE_g,   &H5T_STD_I16BE_g,  &H5T_STD_I32LE_g,
        &H5T_STD_I32BE_g,  &H5T_STD_U32LE_g,  &H5T_STD_I64LE_g,  &H5T_STD_U64LE_g,
        &H5T_IEEE_F32LE_g, &H5T_IEEE_F32BE_g, &H5T_IEEE_F64LE_g, &H5T_IEEE_F64BE_g,
    };
    unsigned k = pick(in, 16);
    hid_t t;
    if (k < 12)
        return H5Tcopy(*fixed[k]);
    t = H5Tcopy(H5T_C_S1);
    if (k == 12) {
        H5Tset_size(t, H5T_VARIABLE);
    } else if (k == 13) {
        H5Tset_size(t, 1 + pick(in, 12));
        H5Tset_strpad(t, (H5T_str_t)pick(in, 3));
    } else if (k == 14) {
        H5Tclose(t);
        t = H5Tcreate(H5T_COMPOUND, 12);
        H5Tinsert(t, "a", 0, H5T_STD_I32LE);
        H5Tinsert(t, "b", 4, H5T_IEEE_F64LE);
    } else {
        H5Tclose(t);
        t = H5Tcreate(H5T_OPAQUE, 4);
    }
    return t;
}

static hsize_t take_dim(fz_in *in)
{
    static const hsize_t special[] = {3,
                                      4,
                                      5,
                                      6,
                                      2,
                                      (hsize_t)INT32_MAX,
                                      (hsize_t)1 << 31,
                                      ((hsize_t)1 << 32) + 3,
                                      (hsize_t)1 << 40};
    unsigned k = take(in);
    if (k < 200)
        return k % 8;
    return special[k % (sizeof special / sizeof special[0])];
}

/* Fills buf (n bytes) from the input for a written dataset or attribute. */
static void take_bytes(fz_in *in, void *buf, size_t n)
{
    unsigned char *b = buf;
    for (size_t i = 0; i < n; i++)
        b[i] = (unsigned char)take(in);
}

static void edit_replace_dataset(hid_t f, fz_in *in)
{
    const char *path = dsets[pick(in, NDSETS)];
    hid_t t = take_type(in), sp, dcpl, d, lcpl;
    int rank = (int)pick(in, 5), chunked = 0, gzip = 0;
    unsigned how = take(in);
    hsize_t dims[4], maxd[4], chunk[4];
    size_t npts = 1, esz = H5Tget_size(t);
    for (int k = 0; k < rank; k++) {
        dims[k] = take_dim(in);
        if (dims[k] > 0 && npts <= SIZE_MAX / dims[k])
            npts *= (size_t)dims[k];
        else if (dims[k] > 0)
            npts = SIZE_MAX;
        chunk[k] = dims[k] == 0 ? 1 : dims[k] < 4 ? dims[k] : 4;
        maxd[k] = dims[k];
    }
    if (rank == 0)
        npts = 1;
    chunked = rank > 0 && (how & 1);
    gzip = chunked && (how & 2);
    if (chunked)
        for (int k = 0; k < rank; k++)
            maxd[k] = H5S_UNLIMITED;
    if (rank > 0 && (how & 12) == 12)
        sp = H5Screate(H5S_NULL);
    else
        sp = rank == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(rank, dims, maxd);
    dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (chunked)
        H5Pset_chunk(dcpl, rank, chunk);
    if (gzip)
        H5Pset_deflate(dcpl, 1);
    /* Early allocation writes the whole dataset: only for small ones. */
    if ((how & 4) && npts <= ((size_t)1 << 20) / (esz ? esz : 1))
        H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_EARLY);
    lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    H5Ldelete(f, path, H5P_DEFAULT);
    d = H5Dcreate2(f, path, t, sp, lcpl, dcpl, H5P_DEFAULT);
    /* Write the values (from the input) when asked and small enough. */
    if (d >= 0 && (how & 16) && npts <= 512 && esz <= 16) {
        if (H5Tis_variable_str(t) > 0) {
            const char **v = calloc(npts, sizeof *v);
            char(*s)[48] = calloc(npts, sizeof *s);
            if (v && s) {
                for (size_t i = 0; i < npts; i++) {
                    take_string(in, s[i], sizeof s[i]);
                    v[i] = pick(in, 8) == 0 ? NULL : s[i];
                }
                H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
            }
            free(v);
            free(s);
        } else {
            void *buf = calloc(npts, esz);
            if (buf) {
                take_bytes(in, buf, npts * esz);
                H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
            }
            free(buf);
        }
    }
    if (d >= 0)
        H5Dclose(d);
    H5Pclose(lcpl);
    H5Pclose(dcpl);
    H5Sclose(sp);
    H5Tclose(t);
}

/* Overwrites one value of an existing numeric dataset. */
static void edit_poke(hid_t f, fz_in *in)
{
    const char *path = dsets[pick(in, NDSETS)];
    hid_t d = H5Dopen2(f, path, H5P_DEFAULT), t, sp, ms;
    hssize_t n;
    if (d < 0)
        return;
    t = H5Dget_type(d);
    sp = H5Dget_space(d);
    n = H5Sget_simple_extent_npoints(sp);
    if (n > 0 && H5Sget_simple_extent_ndims(sp) >= 1) {
        int rank = H5Sget_simple_extent_ndims(sp);
        hsize_t dims[H5S_MAX_RANK], coord[H5S_MAX_RANK], one = 1;
        H5Sget_simple_extent_dims(sp, dims, NULL);
        for (int k = 0; k < rank; k++)
            coord[k] = dims[k] ? take32(in) % dims[k] : 0;
        ms = H5Screate_simple(1, &one, NULL);
        if (H5Sselect_elements(sp, H5S_SELECT_SET, 1, coord) >= 0) {
            if (H5Tget_class(t) == H5T_INTEGER) {
                int64_t v = take_int(in);
                H5Dwrite(d, H5T_NATIVE_INT64, ms, sp, H5P_DEFAULT, &v);
            } else if (H5Tget_class(t) == H5T_FLOAT) {
                double v = take_double(in);
                H5Dwrite(d, H5T_NATIVE_DOUBLE, ms, sp, H5P_DEFAULT, &v);
            }
        }
        H5Sclose(ms);
    }
    H5Sclose(sp);
    H5Tclose(t);
    H5Dclose(d);
}

static void edit_attribute(hid_t f, fz_in *in)
{
    const char *obj = paths[pick(in, 15)];
    const char *name = attr_names[pick(in, NATTR_NAMES)];
    unsigned kind = pick(in, 12);
    hid_t t = H5I_INVALID_HID, sp, a;
    hsize_t two = 2;
    char s1[48], s2[48];
    H5Adelete_by_name(f, obj, name, H5P_DEFAULT);
    if (kind == 11)
        return; /* just deleted */
    sp = kind == 6 || kind == 7 ? H5Screate_simple(1, &two, NULL)
         : kind == 8            ? H5Screate(H5S_NULL)
                                : H5Screate(H5S_SCALAR);
    switch (kind) {
    case 0:
    case 6:
    case 8:
        t = H5Tcopy(H5T_STD_I32LE);
        break;
    case 1:
        t = H5Tcopy(H5T_STD_I64BE);
        break;
    case 2:
        t = H5Tcopy(H5T_STD_U8LE);
        break;
    case 3:
        t = H5Tcopy(H5T_IEEE_F64LE);
        break;
    case 4:
    case 7:
    case 9:
    case 10:
        t = H5Tcopy(H5T_C_S1);
        H5Tset_size(t, H5T_VARIABLE);
        break;
    default:
        t = H5Tcopy(H5T_C_S1);
        H5Tset_size(t, 1 + pick(in, 20));
        H5Tset_strpad(t, (H5T_str_t)pick(in, 3));
        break;
    }
    a = H5Acreate_by_name(f, obj, name, t, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (a >= 0) {
        if (kind == 0 || kind == 6) {
            int32_t v[2] = {(int32_t)take_int(in), (int32_t)take_int(in)};
            H5Awrite(a, H5T_NATIVE_INT32, v);
        } else if (kind == 1 || kind == 2) {
            int64_t v = take_int(in);
            H5Awrite(a, H5T_NATIVE_INT64, &v);
        } else if (kind == 3) {
            double v = take_double(in);
            H5Awrite(a, H5T_NATIVE_DOUBLE, &v);
        } else if (kind == 4 || kind == 7 || kind == 9 || kind == 10) {
            const char *v[2];
            take_string(in, s1, sizeof s1);
            take_string(in, s2, sizeof s2);
            v[0] = kind == 10 ? NULL : kind == 9 ? "" : s1;
            v[1] = s2;
            H5Awrite(a, t, v);
        } else if (kind == 5) {
            char buf[24];
            memset(buf, 0, sizeof buf);
            take_bytes(in, buf, H5Tget_size(t));
            H5Awrite(a, t, buf);
        }
        H5Aclose(a);
    }
    H5Tclose(t);
    H5Sclose(sp);
}

static void edit_link(hid_t f, fz_in *in)
{
    static const char *const where[] = {
        "/sequences/walk/rest",
        "/results/lion/target",
        "/results/by-target/walk/target",
        "/meshes/cat/faces",
        "/meshes/extra",
        "/results/loop",
        "/markers/m2",
        "/meshes",
        "/results/by-target/walk",
        "/correspondences/c/pairs",
    };
    const char *at = where[pick(in, sizeof where / sizeof where[0])];
    unsigned kind = pick(in, 4);
    char target[48];
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    H5Ldelete(f, at, H5P_DEFAULT);
    take_string(in, target, sizeof target);
    if (kind == 0 && target[0])
        H5Lcreate_soft(target, f, at, lcpl, H5P_DEFAULT);
    else if (kind == 1)
        H5Lcreate_hard(f, paths[pick(in, 15)], f, at, lcpl, H5P_DEFAULT);
    else if (kind == 2)
        H5Lcreate_external("other.h5", "/meshes/cat", f, at, lcpl, H5P_DEFAULT);
    /* kind 3: deleted only */
    H5Pclose(lcpl);
}

static void edit_group(hid_t f, fz_in *in)
{
    static const char *const kinds[] = {"/meshes",          "/sequences", "/markers",
                                        "/correspondences", "/results",   "/other"};
    static const char *const names[] = {"new",      ".dtx-tmp-x", "a/b/c", "a/b/c/d/e/f/g/h/i/j",
                                        "vertices", "positions"};
    char path[128];
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE), g;
    snprintf(path, sizeof path, "%s/%s", kinds[pick(in, 6)], names[pick(in, 6)]);
    H5Pset_create_intermediate_group(lcpl, 1);
    g = H5Gcreate2(f, path, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    if (g >= 0)
        H5Gclose(g);
    H5Pclose(lcpl);
}

static void edit_copy_move(hid_t f, fz_in *in)
{
    static const char *const to[] = {"/sequences/cat2", "/meshes/walk", "/results/c",
                                     "/markers/lion",   "/meshes/cat",  "/results/by-target/x/y"};
    const char *from = paths[pick(in, 15)], *dest = to[pick(in, 6)];
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    if (take(in) & 1) {
        H5Ldelete(f, dest, H5P_DEFAULT);
        H5Ocopy(f, from, f, dest, H5P_DEFAULT, lcpl);
    } else {
        H5Lmove(f, from, f, dest, lcpl, H5P_DEFAULT);
    }
    H5Pclose(lcpl);
}

static void edit_delete(hid_t f, fz_in *in)
{
    unsigned k = take(in);
    H5Ldelete(f, k & 1 ? dsets[(k >> 1) % NDSETS] : paths[(k >> 1) % 15], H5P_DEFAULT);
}

/* Makes the edits the input asks for on the file at fz_path; 0 when HDF5
 * closed the edited file cleanly. */
static int apply_edits(const uint8_t *data, size_t size)
{
    fz_in in = {data, size};
    int nedits = 0;
    hid_t f = H5Fopen(fz_path, H5F_ACC_RDWR, H5P_DEFAULT);
    if (f < 0)
        return -1;
    while (in.n > 0 && nedits++ < 12) {
        switch (pick(&in, 8)) {
        case 0:
            edit_replace_dataset(f, &in);
            break;
        case 1:
            edit_poke(f, &in);
            break;
        case 2:
        case 3:
            edit_attribute(f, &in);
            break;
        case 4:
            edit_link(f, &in);
            break;
        case 5:
            edit_group(f, &in);
            break;
        case 6:
            edit_copy_move(f, &in);
            break;
        default:
            edit_delete(f, &in);
            break;
        }
    }
    return H5Fclose(f) < 0 ? -1 : 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pid_t pid;
    int status = 0;

    fz_write_file(fz_path, base, base_size);
    /* The edits are the harness's own HDF5 calls, made in a child process:
     * some edit sequences leave a file HDF5 1.10.8 cannot close, and HDF5
     * then keeps it in its tables, leaks it and crashes closing it again at
     * exit.  That is the harness's doing, not an input dtx ever sees: the
     * child's HDF5 state dies with it, and such inputs are dropped from the
     * corpus.  The child leaves without exit handlers (no leak check, no
     * HDF5 shutdown, nothing of the parent's flushed twice). */
    fflush(NULL);
    pid = fork();
    FUZZ_ASSERT(pid >= 0);
    if (pid == 0)
        _exit(apply_edits(data, size) == 0 ? 0 : 1);
    while (waitpid(pid, &status, 0) < 0)
        FUZZ_ASSERT(errno == EINTR);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        return -1;
    fz_check_file(fz_path, 1);
    return 0;
}
