/*
 * h5inspect.c: the summary of a dtx file for `dtx inspect` (h5inspect.h).
 *
 * The walk mirrors the validator's (h5validate.c): a group below a kind's
 * group is an object when it holds the kind's key dataset, otherwise a
 * namespace group whose members are walked in turn (8 levels at most).
 * Unlike the validator it lists groups under a temporary name too, since
 * "how far has this run got" is a question inspect should answer.
 */
#include "h5inspect.h"

#include "h5layout.h"
#include "markers.h"
#include "mesh.h"

#include <cjson/cJSON.h>
#include <hdf5.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_DEPTH 8

/* The kinds read here in full, and the dataset whose presence makes a
 * group an object of the kind (the rest are namespace groups).  Used as
 * the list of kinds too when the layout description cannot be read. */
static const struct {
    const char *name, *group, *key;
    dtx_h5_kind kind;
} known[] = {
    {"meshes", "/meshes", "vertices", DTX_H5_KIND_MESH},
    {"sequences", "/sequences", "positions", DTX_H5_KIND_SEQUENCE},
    {"markers", "/markers", "source_vertex", DTX_H5_KIND_MARKERS},
    {"correspondences", "/correspondences", "pairs", DTX_H5_KIND_CORRESPONDENCE},
    {"results", "/results", "positions", DTX_H5_KIND_RESULT},
};
#define NKNOWN (sizeof known / sizeof *known)

typedef struct {
    hid_t f;
    dtx_h5_summary *s;
    size_t cap;
    int oom;
    cJSON *desc;            /* the layout description (NULL when unreadable) */
    const char **keys;      /* per kind: the key dataset */
    const cJSON **datasets; /* per kind: the description's datasets (or NULL) */
} ictx;

static char *dup_str(ictx *c, const char *s)
{
    size_t n = strlen(s);
    char *p = malloc(n + 1);
    if (!p) {
        c->oom = 1;
        return NULL;
    }
    memcpy(p, s, n + 1);
    return p;
}

/* ------------------------------------------------------------ listing */

/* The members of group (sorted by name); 0, or -1 when it cannot be
 * listed (l is then empty; oom noted in c). */
static int list_members(ictx *c, const char *group, dtx_h5_names *l)
{
    if (dtx_h5_list_names(c->f, group, l) < 0) {
        c->oom |= l->oom;
        return -1;
    }
    return 0;
}

static int is_group(ictx *c, const char *path)
{
    H5O_info_t info;
    if (!dtx_h5_path_exists(c->f, path))
        return 0;
    return H5Oget_info_by_name2(c->f, path, &info, H5O_INFO_BASIC, H5P_DEFAULT) >= 0 &&
           info.type == H5O_TYPE_GROUP;
}

static int join(const char *group, const char *name, char *out, size_t n)
{
    int w = snprintf(out, n, "%s/%s", strcmp(group, "/") == 0 ? "" : group, name);
    return w < 0 || (size_t)w >= n ? -1 : 0;
}

/* ------------------------------------------------------------ attributes */

typedef struct {
    ictx *c;
    hid_t loc;
    dtx_h5_attr_text *a;
    int64_t n, cap;
} attr_list;

static char *attr_value(ictx *c, hid_t loc, const char *name)
{
    hid_t a = H5Aopen(loc, name, H5P_DEFAULT), t = H5I_INVALID_HID, sp = H5I_INVALID_HID;
    H5T_class_t cls = H5T_NO_CLASS;
    hssize_t npts = -1;
    char buf[96], *v = NULL;
    if (a >= 0) {
        t = H5Aget_type(a);
        sp = H5Aget_space(a);
        cls = t >= 0 ? H5Tget_class(t) : H5T_NO_CLASS;
        npts = sp >= 0 ? H5Sget_simple_extent_npoints(sp) : -1;
    }
    if (t >= 0)
        H5Tclose(t);
    if (sp >= 0)
        H5Sclose(sp);
    if (a >= 0)
        H5Aclose(a);
    if (cls == H5T_STRING && npts == 1) {
        if (dtx_h5_read_attr_str(loc, ".", name, &v, NULL) == DTX_OK)
            return v;
        return dup_str(c, "(unreadable string)");
    }
    if (cls == H5T_INTEGER && npts == 1) {
        int64_t i;
        if (dtx_h5_read_attr_int(loc, ".", name, &i, NULL) == DTX_OK) {
            snprintf(buf, sizeof buf, "%lld", (long long)i);
            return dup_str(c, buf);
        }
    }
    if (cls == H5T_FLOAT && npts == 1) {
        double d = NAN;
        hid_t a2 = H5Aopen(loc, name, H5P_DEFAULT);
        if (a2 >= 0 && H5Aread(a2, H5T_NATIVE_DOUBLE, &d) >= 0) {
            H5Aclose(a2);
            snprintf(buf, sizeof buf, "%.17g", d);
            return dup_str(c, buf);
        }
        if (a2 >= 0)
            H5Aclose(a2);
    }
    snprintf(buf, sizeof buf, "(%lld %s)", (long long)npts,
             cls == H5T_STRING    ? "strings"
             : cls == H5T_INTEGER ? "integers"
             : cls == H5T_FLOAT   ? "floats"
                                  : "values of another type");
    return dup_str(c, buf);
}

static herr_t attr_cb(hid_t loc, const char *name, const H5A_info_t *info, void *data)
{
    attr_list *l = data;
    (void)info;
    if (l->n == l->cap) {
        int64_t cap = l->cap ? 2 * l->cap : 8;
        dtx_h5_attr_text *p = realloc(l->a, (size_t)cap * sizeof *p);
        if (!p) {
            l->c->oom = 1;
            return -1;
        }
        l->a = p;
        l->cap = cap;
    }
    l->a[l->n].name = dup_str(l->c, name);
    l->a[l->n].value = attr_value(l->c, loc, name);
    l->n++;
    return l->c->oom ? -1 : 0;
}

static void free_attrs(dtx_h5_attr_text *a, int64_t n)
{
    for (int64_t i = 0; i < n; i++) {
        free(a[i].name);
        free(a[i].value);
    }
    free(a);
}

/* Every attribute of the object at path, in name order. */
static void read_attrs(ictx *c, const char *path, dtx_h5_attr_text **out, int64_t *n)
{
    attr_list l = {c, H5I_INVALID_HID, NULL, 0, 0};
    hsize_t idx = 0;
    hid_t o = H5Oopen(c->f, path, H5P_DEFAULT);
    *out = NULL;
    *n = 0;
    if (o < 0)
        return;
    l.loc = o;
    H5Aiterate2(o, H5_INDEX_NAME, H5_ITER_INC, &idx, attr_cb, &l);
    H5Oclose(o);
    *out = l.a;
    *n = l.n;
}

const char *dtx_h5_attr_find(const dtx_h5_attr_text *attrs, int64_t n, const char *name)
{
    for (int64_t i = 0; i < n; i++)
        if (attrs[i].name && strcmp(attrs[i].name, name) == 0)
            return attrs[i].value;
    return NULL;
}

/* ------------------------------------------------------------ objects */

static void set_problem(ictx *c, dtx_h5_item *it, const dtx_error *e)
{
    if (!it->problem)
        it->problem = dup_str(c, e->msg);
}

static void mesh_item(ictx *c, dtx_h5_item *it)
{
    dtx_mesh m;
    dtx_error e;
    int32_t *comp;
    memset(&m, 0, sizeof m);
    if (dtx_h5_read_mesh(c->f, it->path, &m, &e) != DTX_OK) {
        int32_t nv, nf;
        set_problem(c, it, &e);
        if (dtx_h5_mesh_size(c->f, it->path, &nv, &nf, &e) == DTX_OK)
            it->nv = nv, it->nf = nf;
        return;
    }
    it->nv = m.nv;
    it->nf = m.nf;
    comp = dtx_alloc((size_t)m.nv, sizeof *comp, 0);
    if (comp) {
        /* Vertices in no face count as their own components here. */
        it->components = dtx_mesh_components(&m, comp);
        free(comp);
    }
    for (int k = 0; k < 3; k++) {
        it->bounds[k] = INFINITY;
        it->bounds[3 + k] = -INFINITY;
    }
    for (int32_t i = 0; i < m.nv; i++)
        for (int k = 0; k < 3; k++) {
            double x = m.V[3 * (size_t)i + k];
            it->bounds[k] = x < it->bounds[k] ? x : it->bounds[k];
            it->bounds[3 + k] = x > it->bounds[3 + k] ? x : it->bounds[3 + k];
        }
    dtx_mesh_free(&m);
}

static void sequence_item(ictx *c, dtx_h5_item *it)
{
    dtx_h5_seq seq;
    dtx_error e;
    const char *rest = dtx_h5_attr_find(it->attrs, it->nattrs, "rest_mesh");
    memset(&seq, 0, sizeof seq);
    if (rest)
        it->mesh = dup_str(c, rest);
    if (dtx_h5_seq_open(c->f, it->path, &seq, &e) != DTX_OK) {
        set_problem(c, it, &e);
        return;
    }
    it->nframes = it->frames_done = seq.nframes;
    it->nv = seq.nv;
    it->is_f64 = seq.is_f64;
    it->chunk_frames = seq.chunk_frames;
    /* Frame names are optional (sequences written by other programs). */
    if (dtx_h5_read_frame_names(&seq, &it->frame_names, &e) != DTX_OK)
        it->frame_names = NULL;
    dtx_h5_seq_close(&seq);
}

/* The final name of a temporary path: "/a/.dtx-tmp-b" -> "/a/b". */
static void final_name(const char *tmp, char *out, size_t n)
{
    const char *last = strrchr(tmp, '/');
    size_t pl = strlen(DTX_H5_TMP_PREFIX), dir = last ? (size_t)(last - tmp) + 1 : 0;
    if (last && strncmp(last + 1, DTX_H5_TMP_PREFIX, pl) == 0)
        snprintf(out, n, "%.*s%s", (int)dir, tmp, last + 1 + pl);
    else
        snprintf(out, n, "%s", tmp);
}

static void result_item(ictx *c, dtx_h5_item *it)
{
    dtx_h5_result res;
    dtx_error e;
    char final[DTX_H5_PATH_MAX];
    const char *tgt = dtx_h5_attr_find(it->attrs, it->nattrs, "target_mesh");
    uint8_t *done = NULL;
    double *r = NULL, sum = 0.0;
    int32_t *fs = NULL;
    int64_t nr = 0;
    memset(&res, 0, sizeof res);
    if (tgt)
        it->mesh = dup_str(c, tgt);
    final_name(it->path, final, sizeof final);
    if (dtx_h5_result_open(c->f, it->temporary ? final : it->path, it->temporary, &res, &e) !=
        DTX_OK) {
        set_problem(c, it, &e);
        return;
    }
    it->nframes = res.nframes;
    it->nv = res.nv;
    it->is_f64 = res.is_f64;
    it->chunk_frames = res.chunk_frames;
    done = dtx_alloc((size_t)res.nframes, 1, 0);
    r = dtx_alloc((size_t)res.nframes, sizeof *r, 0);
    if (!done || !r) {
        c->oom = 1;
        goto out;
    }
    if (dtx_h5_result_read_done(&res, done, &e) != DTX_OK) {
        set_problem(c, it, &e);
        goto out;
    }
    it->frames_done = 0;
    for (int64_t i = 0; i < res.nframes; i++)
        it->frames_done += done[i] != 0;
    if (res.nframes > 0 &&
        H5Dread(res.residual, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r) >= 0) {
        for (int64_t i = 0; i < res.nframes; i++) {
            if (!done[i] || !isfinite(r[i]))
                continue;
            if (nr == 0 || r[i] < it->residual_min)
                it->residual_min = r[i];
            if (nr == 0 || r[i] > it->residual_max)
                it->residual_max = r[i];
            sum += r[i];
            nr++;
        }
        if (nr > 0)
            it->residual_mean = sum / (double)nr;
    }
    if (res.frame_stats >= 0) {
        fs = dtx_alloc((size_t)res.nframes, DTX_H5_FRAME_STATS * sizeof *fs, 0);
        if (!fs) {
            c->oom = 1;
            goto out;
        }
        if (dtx_h5_result_read_frame_stats(&res, 0, res.nframes, fs, &e) == DTX_OK) {
            it->frames_converged = 0;
            for (int64_t i = 0; i < res.nframes; i++)
                it->frames_converged += done[i] && fs[DTX_H5_FRAME_STATS * i + 1] == 1;
        } else {
            free(fs);
            fs = NULL;
        }
    }
    /* The largest as dtx report finds it (a NaN in a frame done counts as
     * the largest, not skipped). */
    if (res.frame_grad_norm >= 0 &&
        dtx_h5_result_read_frame_grad_norm(&res, 0, res.nframes, r, &e) == DTX_OK &&
        (it->grad_norm_max_frame = dtx_h5_grad_norm_max_frame(r, fs, done, res.nframes)) >= 0)
        it->grad_norm_max = r[it->grad_norm_max_frame];
out:
    free(done);
    free(r);
    free(fs);
    dtx_h5_result_close(&res);
}

static void markers_item(ictx *c, dtx_h5_item *it)
{
    dtx_markers mk;
    dtx_error e;
    memset(&mk, 0, sizeof mk);
    if (dtx_h5_read_markers(c->f, it->path, &mk, &e) != DTX_OK) {
        set_problem(c, it, &e);
        return;
    }
    it->count = mk.n;
    dtx_markers_free(&mk);
}

static void corr_item(ictx *c, dtx_h5_item *it)
{
    dtx_h5_corr corr;
    dtx_error e;
    memset(&corr, 0, sizeof corr);
    if (dtx_h5_read_corr(c->f, it->path, -1, -1, -1, &corr, &e) != DTX_OK) {
        set_problem(c, it, &e);
        return;
    }
    it->count = corr.npairs;
    it->nv = corr.nv_s;
    dtx_h5_corr_free(&corr);
}

/* An object of a kind without a reading of its own: the shapes of the
 * datasets the layout names for the kind. */
static void other_item(ictx *c, dtx_h5_item *it, const cJSON *datasets)
{
    char text[1024] = "";
    size_t used = 0;
    const cJSON *d;
    cJSON_ArrayForEach(d, datasets)
    {
        char dpath[DTX_H5_PATH_MAX], dims_text[128] = "";
        hsize_t dims[H5S_MAX_RANK];
        hid_t ds, sp;
        int rank = -1, w;
        if (!d->string || join(it->path, d->string, dpath, sizeof dpath) != 0 ||
            H5Lexists(c->f, dpath, H5P_DEFAULT) <= 0)
            continue;
        ds = H5Dopen2(c->f, dpath, H5P_DEFAULT);
        sp = ds >= 0 ? H5Dget_space(ds) : H5I_INVALID_HID;
        if (sp >= 0)
            rank = H5Sget_simple_extent_dims(sp, dims, NULL);
        if (sp >= 0)
            H5Sclose(sp);
        if (ds >= 0)
            H5Dclose(ds);
        for (int k = 0; k < rank; k++) {
            size_t l = strlen(dims_text);
            snprintf(dims_text + l, sizeof dims_text - l, "%s%llu", k ? " x " : "",
                     (unsigned long long)dims[k]);
        }
        if (rank > 0 && it->count < 0)
            it->count = (int64_t)dims[0];
        w = snprintf(text + used, sizeof text - used, "%s%s (%s)", used ? ", " : "", d->string,
                     rank < 0 ? "unreadable" : dims_text);
        if (w < 0 || (size_t)w >= sizeof text - used)
            break;
        used += (size_t)w;
    }
    it->datasets = dup_str(c, text);
}

static void add_item(ictx *c, int64_t kind_index, const char *path, int temporary)
{
    dtx_h5_summary *s = c->s;
    dtx_h5_kind kind = s->kinds[kind_index].kind;
    dtx_h5_item *it;
    if ((size_t)s->nitems == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 16;
        dtx_h5_item *p = realloc(s->items, cap * sizeof *p);
        if (!p) {
            c->oom = 1;
            return;
        }
        s->items = p;
        c->cap = cap;
    }
    it = &s->items[s->nitems++];
    memset(it, 0, sizeof *it);
    it->kind = kind;
    it->kind_index = (int)kind_index;
    it->temporary = temporary;
    it->nv = it->nf = it->components = -1;
    it->nframes = it->frames_done = it->count = -1;
    it->chunk_frames = -1;
    it->residual_min = it->residual_max = it->residual_mean = NAN;
    it->frames_converged = it->grad_norm_max_frame = -1;
    it->grad_norm_max = NAN;
    for (int k = 0; k < 6; k++)
        it->bounds[k] = NAN;
    it->path = dup_str(c, path);
    if (!it->path)
        return;
    read_attrs(c, path, &it->attrs, &it->nattrs);
    switch (kind) {
    case DTX_H5_KIND_MESH:
        mesh_item(c, it);
        break;
    case DTX_H5_KIND_SEQUENCE:
        sequence_item(c, it);
        break;
    case DTX_H5_KIND_MARKERS:
        markers_item(c, it);
        break;
    case DTX_H5_KIND_CORRESPONDENCE:
        corr_item(c, it);
        break;
    case DTX_H5_KIND_RESULT:
        result_item(c, it);
        break;
    default:
        other_item(c, it, c->datasets[kind_index]);
        break;
    }
}

static void walk(ictx *c, int64_t kind_index, const char *gpath, int depth)
{
    size_t tl = strlen(DTX_H5_TMP_PREFIX);
    dtx_h5_names l;
    if (list_members(c, gpath, &l) < 0)
        return;
    for (size_t i = 0; i < l.n && !c->oom; i++) {
        char path[DTX_H5_PATH_MAX], key[DTX_H5_PATH_MAX];
        int tmp = strncmp(l.names[i], DTX_H5_TMP_PREFIX, tl) == 0;
        if (join(gpath, l.names[i], path, sizeof path) != 0 || !is_group(c, path))
            continue;
        if (join(path, c->keys[kind_index], key, sizeof key) == 0 &&
            H5Lexists(c->f, key, H5P_DEFAULT) > 0)
            add_item(c, kind_index, path, tmp);
        else if (depth < MAX_DEPTH)
            walk(c, kind_index, path, depth + 1);
    }
    dtx_h5_names_free(&l);
}

/* ------------------------------------------------------------ kinds */

static void add_kind(ictx *c, const char *name, const char *group, const char *key,
                     const cJSON *datasets)
{
    dtx_h5_summary *s = c->s;
    dtx_h5_kind_info *k = &s->kinds[s->nkinds];
    k->kind = DTX_H5_KIND_OTHER;
    for (size_t i = 0; i < NKNOWN; i++)
        if (strcmp(group, known[i].group) == 0) {
            k->kind = known[i].kind;
            key = known[i].key;
        }
    k->name = dup_str(c, name);
    k->group = dup_str(c, group);
    c->keys[s->nkinds] = key;
    c->datasets[s->nkinds] = datasets;
    s->nkinds++;
}

/* The kinds of the layout description, in its order (the known ones
 * alone when it cannot be read). */
static void load_kinds(ictx *c)
{
    char *text = dtx_h5_layout_json();
    const cJSON *kinds, *k;
    size_t n;
    c->desc = text ? cJSON_Parse(text) : NULL;
    free(text);
    kinds = cJSON_GetObjectItemCaseSensitive(c->desc, "kinds");
    n = (cJSON_IsArray(kinds) ? (size_t)cJSON_GetArraySize(kinds) : 0) + NKNOWN;
    c->s->kinds = calloc(n, sizeof *c->s->kinds);
    c->keys = calloc(n, sizeof *c->keys);
    c->datasets = calloc(n, sizeof *c->datasets);
    if (!c->s->kinds || !c->keys || !c->datasets) {
        c->oom = 1;
        return;
    }
    cJSON_ArrayForEach(k, kinds)
    {
        const char *name = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(k, "name")),
                   *group = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(k, "group"));
        const cJSON *ds = cJSON_GetObjectItemCaseSensitive(k, "datasets");
        if (name && group && group[0] == '/' && cJSON_IsObject(ds) && ds->child &&
            ds->child->string)
            add_kind(c, name, group, ds->child->string, ds);
    }
    if (c->s->nkinds == 0)
        for (size_t i = 0; i < NKNOWN; i++)
            add_kind(c, known[i].name, known[i].group, known[i].key, NULL);
}

/* ------------------------------------------------------------ entry */

dtx_status dtx_h5_inspect(const char *path, dtx_h5_summary *out, dtx_error *err)
{
    ictx c;
    dtx_h5_names top;
    dtx_status st;
    memset(out, 0, sizeof *out);
    memset(&c, 0, sizeof c);
    c.s = out;
    c.f = H5I_INVALID_HID;
    st = dtx_h5_open(path, MPI_COMM_NULL, 0, &c.f, err);
    if (st != DTX_OK)
        return st;
    load_kinds(&c);
    if (!c.oom)
        read_attrs(&c, "/", &out->attrs, &out->nattrs);
    for (int64_t k = 0; k < out->nkinds && !c.oom; k++)
        if (is_group(&c, out->kinds[k].group))
            walk(&c, k, out->kinds[k].group, 0);
    if (!c.oom && list_members(&c, "/", &top) == 0) {
        for (size_t i = 0; i < top.n && !c.oom; i++) {
            int is_kind = 0;
            for (int64_t k = 0; k < out->nkinds; k++)
                is_kind |=
                    out->kinds[k].group && strcmp(out->kinds[k].group + 1, top.names[i]) == 0;
            if (is_kind)
                continue;
            if (!out->other) {
                out->other = calloc(top.n, sizeof *out->other);
                if (!out->other) {
                    c.oom = 1;
                    break;
                }
            }
            out->other[out->nother] = dup_str(&c, top.names[i]);
            if (out->other[out->nother])
                out->nother++;
        }
        dtx_h5_names_free(&top);
    }
    dtx_h5_close(&c.f, NULL);
    cJSON_Delete(c.desc);
    free(c.keys);
    free(c.datasets);
    if (c.oom) {
        dtx_h5_summary_free(out);
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory while inspecting", path);
    }
    return DTX_OK;
}

void dtx_h5_summary_free(dtx_h5_summary *s)
{
    if (!s)
        return;
    for (int64_t k = 0; k < s->nkinds; k++) {
        free(s->kinds[k].name);
        free(s->kinds[k].group);
    }
    free(s->kinds);
    free_attrs(s->attrs, s->nattrs);
    for (int64_t i = 0; i < s->nitems; i++) {
        dtx_h5_item *it = &s->items[i];
        free(it->path);
        free(it->problem);
        free(it->mesh);
        free(it->datasets);
        if (it->frame_names)
            dtx_h5_free_strings(&it->frame_names, it->nframes);
        free_attrs(it->attrs, it->nattrs);
    }
    free(s->items);
    for (int64_t i = 0; i < s->nother; i++)
        free(s->other[i]);
    free(s->other);
    memset(s, 0, sizeof *s);
}
