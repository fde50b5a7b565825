/*
 * cmd_view.c: `dtx view FILE.h5 [OBJECT...] -o PAGE.html` (the player) and
 * `dtx view FILE.h5 --pick /meshes/SRC /meshes/TGT -o PAGE.html` (marker
 * picking): reads the objects through h5layout.h and hands them to the page
 * writer (html_view.h).
 *
 * Objects are HDF5 paths in FILE.h5, or OTHER.h5:PATH for one in another
 * file (a result's source sequence usually lives in the job's input file).
 * Without objects the player shows every result of the file, preceded by
 * the source sequence of the first result when its provenance attribute
 * source_sequence ("FILE:PATH") can be opened (FILE as written, then
 * beside FILE.h5), else the file's own sequences.
 */
#include "cmd_view.h"

#include "cli_util.h"

#include "h5layout.h"
#include "html_view.h"
#include "options.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_PANES 16
#define MAX_FILES 8
#define DEFAULT_MAX_FRAMES 300

typedef struct {
    const char *input, *out, *markers, *keypoints, *pick_src, *pick_tgt;
    const char *objects[MAX_PANES];
    int nobjects;
    long long max_frames, stride;
} view_args;

/* Files opened so far (the input first). */
typedef struct {
    char *name[MAX_FILES];
    hid_t id[MAX_FILES];
    int n;
} file_set;

typedef struct {
    dtx_view_pane pane;
    dtx_mesh mesh;
    char *title, *info, *group;
    hid_t file;
    char path[DTX_H5_PATH_MAX];
    int is_result, is_seq;
    int64_t nframes_file;
    double *frames, *residual;
    int64_t *frame;
} pane_data;

static int usage(const char *msg)
{
    fprintf(stderr, "dtx view: %s\n", msg);
    dtx_cli_print_usage(stderr, dtx_cli_find_name("view"));
    return 2;
}

static int parse_count(const char *s, long long lo, long long hi, long long *out)
{
    char *end;
    long long v = strtoll(s, &end, 10);
    if (end == s || *end || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

static int parse_args(int argc, char **argv, view_args *a)
{
    memset(a, 0, sizeof *a);
    a->max_frames = DEFAULT_MAX_FRAMES;
    for (int i = 2; i < argc; i++) {
        const char *s = argv[i];
        if (strcmp(s, "-o") == 0 && i + 1 < argc)
            a->out = argv[++i];
        else if (strcmp(s, "--markers") == 0 && i + 1 < argc)
            a->markers = argv[++i];
        else if (strcmp(s, "--keypoints") == 0 && i + 1 < argc)
            a->keypoints = argv[++i];
        else if (strcmp(s, "--pick") == 0) {
            if (i + 2 >= argc)
                return usage("--pick needs two meshes: --pick /meshes/SRC /meshes/TGT");
            a->pick_src = argv[++i];
            a->pick_tgt = argv[++i];
        } else if (strcmp(s, "--max-frames") == 0 && i + 1 < argc) {
            if (parse_count(argv[++i], 1, 100000, &a->max_frames))
                return usage("--max-frames must be a number of frames in 1..100000");
        } else if (strcmp(s, "--stride") == 0 && i + 1 < argc) {
            if (parse_count(argv[++i], 1, 1000000000, &a->stride))
                return usage("--stride must be a whole number >= 1");
        } else if (s[0] == '-' && s[1])
            return usage("unknown option or missing value");
        else if (!a->input)
            a->input = s;
        else if (a->nobjects < MAX_PANES - 1)
            a->objects[a->nobjects++] = s;
        else
            return usage("too many objects (at most 15)");
    }
    if (!a->input)
        return usage("needs FILE.h5");
    if (!a->out)
        return usage("needs -o PAGE.html");
    if (a->pick_src && a->nobjects)
        return usage("--pick takes its two meshes only, no other objects");
    return 0;
}

/* ------------------------------------------------------------ files */

/* Opens name (or returns it when open already). */
static dtx_status open_file(file_set *fs, const char *name, hid_t *id, dtx_error *err)
{
    dtx_status st;
    for (int i = 0; i < fs->n; i++)
        if (strcmp(fs->name[i], name) == 0) {
            *id = fs->id[i];
            return DTX_OK;
        }
    if (fs->n == MAX_FILES)
        return dtx_seterr(err, DTX_EINVAL, "%s: more than %d files", name, MAX_FILES);
    if ((st = dtx_h5_open(name, MPI_COMM_NULL, 0, id, err)) != DTX_OK)
        return st;
    if (!(fs->name[fs->n] = strdup(name))) {
        dtx_h5_close(id, err);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    fs->id[fs->n++] = *id;
    return DTX_OK;
}

/* Splits "OTHER.h5:PATH" (or "PATH" in the input file) into a file and a
 * path. */
static dtx_status resolve(file_set *fs, const char *spec, hid_t *file, char *path,
                          dtx_error *err)
{
    const char *colon = NULL;
    char name[4096];
    /* The last ":/" splits FILE from PATH, unless the whole is an HDF5 path
     * (starting with '/') and what precedes it is not an existing file. */
    for (const char *p = strstr(spec, ":/"); p; p = strstr(p + 1, ":/"))
        colon = p;
    if (colon && spec[0] == '/' && (size_t)(colon - spec) < sizeof name) {
        memcpy(name, spec, (size_t)(colon - spec));
        name[colon - spec] = 0;
        if (access(name, F_OK) != 0)
            colon = NULL;
    }
    if (!colon || colon == spec) {
        *file = fs->id[0];
        if (strlen(spec) >= DTX_H5_PATH_MAX)
            return dtx_seterr(err, DTX_EINVAL, "%s: path too long", spec);
        strcpy(path, spec);
        return DTX_OK;
    }
    if ((size_t)(colon - spec) >= sizeof name || strlen(colon + 1) >= DTX_H5_PATH_MAX)
        return dtx_seterr(err, DTX_EINVAL, "%s: name too long", spec);
    memcpy(name, spec, (size_t)(colon - spec));
    name[colon - spec] = 0;
    strcpy(path, colon + 1);
    return open_file(fs, name, file, err);
}

/* ------------------------------------------------------------ panes */

static char *dupf(const char *a, const char *b)
{
    size_t n = strlen(a) + strlen(b) + 1;
    char *s = malloc(n);
    if (s)
        snprintf(s, n, "%s%s", a, b);
    return s;
}

/* Opens the object's mesh and counts its frames. */
static dtx_status pane_open(pane_data *d, const file_set *fs, dtx_error *err)
{
    char sub[DTX_H5_PATH_MAX + 16], *attr = NULL;
    dtx_status st;
    char fname[512];
    dtx_h5_filename(d->file, fname, sizeof fname);
    snprintf(sub, sizeof sub, "%s/frame_done", d->path);
    d->is_result = dtx_h5_path_exists(d->file, sub);
    snprintf(sub, sizeof sub, "%s/positions", d->path);
    d->is_seq = !d->is_result && dtx_h5_path_exists(d->file, sub);
    d->title = d->file == fs->id[0] ? dupf(d->path, "") : dupf(fname, "");
    if (d->title && d->file != fs->id[0]) {
        char *t = d->title;
        d->title = dupf(t, ":");
        free(t);
        t = d->title;
        d->title = t ? dupf(t, d->path) : NULL;
        free(t);
    }
    if (!d->title)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (d->is_result) {
        dtx_h5_result res;
        memset(&res, 0, sizeof res);
        if ((st = dtx_h5_result_open(d->file, d->path, 0, &res, err)) != DTX_OK)
            return st;
        d->nframes_file = res.nframes;
        dtx_h5_result_close(&res);
        snprintf(sub, sizeof sub, "%s/target", d->path);
        if ((st = dtx_h5_read_mesh(d->file, sub, &d->mesh, err)) != DTX_OK)
            return st;
        if (dtx_h5_read_attr_str(d->file, d->path, "method", &attr, err) == DTX_OK) {
            d->info = dupf("method ", attr);
            free(attr);
        }
        d->pane.kind = "result";
        d->pane.marker_side = 2;
    } else if (d->is_seq) {
        dtx_h5_seq seq;
        memset(&seq, 0, sizeof seq);
        if ((st = dtx_h5_seq_open(d->file, d->path, &seq, err)) != DTX_OK)
            return st;
        d->nframes_file = seq.nframes;
        dtx_h5_seq_close(&seq);
        snprintf(sub, sizeof sub, "%s/rest", d->path);
        if ((st = dtx_h5_read_mesh(d->file, sub, &d->mesh, err)) != DTX_OK)
            return st;
        d->pane.kind = "sequence";
        d->pane.marker_side = 1;
    } else {
        if ((st = dtx_h5_read_mesh(d->file, d->path, &d->mesh, err)) != DTX_OK)
            return st;
        d->pane.kind = "mesh";
    }
    /* Panes on the same mesh (by content, whichever file holds it) can be
     * compared vertex by vertex. */
    {
        char hex[17];
        dtx_hash_hex(dtx_mesh_hash(&d->mesh), hex);
        if (!(d->group = dupf("mesh ", hex)))
            return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    return DTX_OK;
}

/* Reads frames 0, stride, 2 stride, ... (n of them). */
static dtx_status pane_read(pane_data *d, int64_t stride, int64_t n, dtx_error *err)
{
    size_t nc = (size_t)d->mesh.nv * 3;
    dtx_status st = DTX_OK;
    dtx_h5_result res;
    dtx_h5_seq seq;
    memset(&res, 0, sizeof res);
    memset(&seq, 0, sizeof seq);
    if (n <= 0)
        return DTX_OK;
    d->frames = malloc((size_t)n * nc * sizeof(double));
    d->frame = malloc((size_t)n * sizeof(int64_t));
    d->residual = d->is_result ? malloc((size_t)n * sizeof(double)) : NULL;
    if (!d->frames || !d->frame || (d->is_result && !d->residual))
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %lld frames", d->path,
                          (long long)n);
    st = d->is_result ? dtx_h5_result_open(d->file, d->path, 0, &res, err)
                      : dtx_h5_seq_open(d->file, d->path, &seq, err);
    for (int64_t t = 0; st == DTX_OK && t < n; t++) {
        d->frame[t] = t * stride;
        st = d->is_result ? dtx_h5_result_read(&res, t * stride, 1, d->frames + (size_t)t * nc,
                                               d->residual + t, err)
                          : dtx_h5_seq_read(&seq, t * stride, 1, d->frames + (size_t)t * nc, err);
    }
    dtx_h5_result_close(&res);
    dtx_h5_seq_close(&seq);
    d->pane.nframes = n;
    d->pane.frame = d->frame;
    d->pane.frames = d->frames;
    d->pane.residual = d->residual;
    return st;
}

static void pane_free(pane_data *d)
{
    dtx_mesh_free(&d->mesh);
    free(d->title);
    free(d->info);
    free(d->group);
    free(d->frames);
    free(d->frame);
    free(d->residual);
}

/* The objects shown when none are named: every result, the first one's
 * source sequence before them. */
static dtx_status default_objects(file_set *fs, const char *input, char ***specs, int *n,
                                  dtx_error *err)
{
    char **rn = NULL, **tn = NULL;
    int64_t nr = 0, nt = 0;
    dtx_status st = DTX_OK;
    hid_t f = fs->id[0];
    char **out = calloc(MAX_PANES, sizeof *out);
    *n = 0;
    if (!out)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    *specs = out;
    if (dtx_h5_path_exists(f, "/results"))
        st = dtx_h5_list_groups(f, "/results", &tn, &nt, err);
    for (int64_t i = 0; st == DTX_OK && i < nt; i++) {
        char tp[DTX_H5_PATH_MAX];
        snprintf(tp, sizeof tp, "/results/%s", tn[i]);
        st = dtx_h5_list_groups(f, tp, &rn, &nr, err);
        for (int64_t j = 0; st == DTX_OK && j < nr; j++) {
            char rp[DTX_H5_PATH_MAX * 2];
            snprintf(rp, sizeof rp, "%s/%s", tp, rn[j]);
            if (*n == 0) {
                /* The source sequence first, when it can be found. */
                char *src = NULL;
                if (dtx_h5_read_attr_str(f, rp, "source_sequence", &src, err) == DTX_OK) {
                    char *colon = strrchr(src, ':');
                    hid_t other;
                    dtx_error e2;
                    if (colon && colon != src) {
                        *colon = 0;
                        if (open_file(fs, src, &other, &e2) == DTX_OK &&
                            dtx_h5_path_exists(other, colon + 1)) {
                            *colon = ':';
                            out[(*n)++] = strdup(src);
                        } else if (dtx_h5_path_exists(f, colon + 1))
                            out[(*n)++] = strdup(colon + 1);
                    } else if (colon == NULL && dtx_h5_path_exists(f, src))
                        out[(*n)++] = strdup(src);
                    free(src);
                }
            }
            if (*n < MAX_PANES)
                out[(*n)++] = strdup(rp);
        }
        dtx_h5_free_strings(&rn, nr);
    }
    dtx_h5_free_strings(&tn, nt);
    if (st == DTX_OK && *n == 0 && dtx_h5_path_exists(f, "/sequences")) {
        st = dtx_h5_list_groups(f, "/sequences", &tn, &nt, err);
        for (int64_t i = 0; st == DTX_OK && i < nt && *n < MAX_PANES; i++)
            out[(*n)++] = dupf("/sequences/", tn[i]);
        dtx_h5_free_strings(&tn, nt);
    }
    for (int i = 0; i < *n; i++)
        if (!out[i])
            return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    if (st == DTX_OK && *n == 0)
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: nothing to show: no results and no sequences (name objects, or "
                          "use --pick /meshes/SRC /meshes/TGT)",
                          input);
    return st;
}

/* The key points of the source mesh src, when the file has some (named,
 * or the first /keypoints group whose source_mesh is src). */
static dtx_status find_keypoints(hid_t f, const char *named, const char *src,
                                 dtx_h5_keypoints *kp, char *where, dtx_error *err)
{
    char **names = NULL;
    int64_t n = 0;
    dtx_status st;
    if (named) {
        snprintf(where, DTX_H5_PATH_MAX, "%s", named);
        return dtx_h5_read_keypoints(f, named, kp, err);
    }
    if (!dtx_h5_path_exists(f, "/keypoints"))
        return DTX_OK;
    if ((st = dtx_h5_list_groups(f, "/keypoints", &names, &n, err)) != DTX_OK)
        return st;
    for (int64_t i = 0; i < n; i++) {
        snprintf(where, DTX_H5_PATH_MAX, "/keypoints/%s", names[i]);
        if ((st = dtx_h5_read_keypoints(f, where, kp, err)) != DTX_OK)
            break;
        if (kp->source_mesh && strcmp(kp->source_mesh, src) == 0)
            break;
        dtx_h5_keypoints_free(kp);
    }
    dtx_h5_free_strings(&names, n);
    return st;
}

/* ------------------------------------------------------------ command */

static int view_run(const view_args *ap, const char *report);

int dtx_cmd_view(int argc, char **argv)
{
    view_args a;
    int rc = parse_args(argc, argv, &a);
    return rc ? rc : view_run(&a, NULL);
}

int dtx_view_report(const char *input, const char *out, const char *markdown)
{
    view_args a;
    memset(&a, 0, sizeof a);
    a.input = input;
    a.out = out;
    a.max_frames = DEFAULT_MAX_FRAMES;
    return view_run(&a, markdown);
}

/* Reads what a names and writes the page (with the report text, when not
 * NULL).  Returns the exit status. */
static int view_run(const view_args *ap, const char *report)
{
    view_args a = *ap;
    file_set fs;
    dtx_error err;
    dtx_status st = DTX_OK;
    pane_data pd[MAX_PANES];
    dtx_view_pane panes[MAX_PANES];
    dtx_view_page pg;
    dtx_markers mk;
    dtx_h5_keypoints kp;
    char **specs = NULL, kp_where[DTX_H5_PATH_MAX] = "", mk_path[DTX_H5_PATH_MAX];
    int nspecs = 0, npd = 0;
    int64_t tmax = 0, stride = 1, nemb = 0;

    memset(&fs, 0, sizeof fs);
    memset(pd, 0, sizeof pd);
    memset(&pg, 0, sizeof pg);
    memset(&mk, 0, sizeof mk);
    memset(&kp, 0, sizeof kp);
    if (!dtx_view_available()) {
        dtx_seterr(&err, DTX_EINVAL,
                   "%s: this dtx was built without three.js, which `dtx view` needs: run "
                   "scripts/setup.sh (it installs three into build-tools/), then rebuild",
                   a.out);
        st = DTX_EINVAL;
        goto done;
    }
    if ((st = open_file(&fs, a.input, &(hid_t){0}, &err)) != DTX_OK)
        goto done;

    /* ---- which objects */
    if (a.pick_src) {
        specs = calloc(2, sizeof *specs);
        if (!specs || !(specs[0] = strdup(a.pick_src)) || !(specs[1] = strdup(a.pick_tgt))) {
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
            goto done;
        }
        nspecs = 2;
    } else if (a.nobjects) {
        specs = calloc((size_t)a.nobjects, sizeof *specs);
        if (!specs) {
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
            goto done;
        }
        for (int i = 0; i < a.nobjects; i++)
            if (!(specs[nspecs++] = strdup(a.objects[i]))) {
                st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
                goto done;
            }
    } else if ((st = default_objects(&fs, a.input, &specs, &nspecs, &err)) != DTX_OK)
        goto done;

    /* ---- open them */
    for (int i = 0; i < nspecs; i++) {
        pane_data *d = &pd[npd++];
        if ((st = resolve(&fs, specs[i], &d->file, d->path, &err)) != DTX_OK)
            goto done;
        if (!dtx_h5_path_exists(d->file, d->path)) {
            char fname[512];
            st = dtx_seterr(&err, DTX_EINVAL, "%s: %s: no such object",
                            dtx_h5_filename(d->file, fname, sizeof fname), d->path);
            goto done;
        }
        if ((st = pane_open(d, &fs, &err)) != DTX_OK)
            goto done;
        if (a.pick_src && (d->is_result || d->is_seq)) {
            st = dtx_seterr(&err, DTX_EINVAL, "%s: --pick takes meshes (/meshes/NAME)", specs[i]);
            goto done;
        }
        if (a.pick_src)
            d->pane.marker_side = i + 1;
        tmax = d->nframes_file > tmax ? d->nframes_file : tmax;
    }

    /* ---- the frame budget */
    if (tmax > 0) {
        stride = a.stride ? a.stride : (tmax + a.max_frames - 1) / a.max_frames;
        nemb = (tmax + stride - 1) / stride;
        if (nemb > a.max_frames) {
            st = dtx_seterr(&err, DTX_EINVAL,
                            "%s: --stride %lld gives %lld frames, more than --max-frames %lld",
                            a.input, a.stride, (long long)nemb, a.max_frames);
            goto done;
        }
    }
    for (int i = 0; i < npd; i++) {
        pane_data *d = &pd[i];
        if (d->nframes_file > 0 &&
            (st = pane_read(d, stride, (d->nframes_file + stride - 1) / stride, &err)) != DTX_OK)
            goto done;
        d->pane.title = d->title;
        d->pane.info = d->info;
        d->pane.group = d->group;
        d->pane.mesh = &d->mesh;
        panes[i] = d->pane;
    }

    /* ---- markers and key points */
    if (a.markers) {
        hid_t mf;
        if ((st = resolve(&fs, a.markers, &mf, mk_path, &err)) != DTX_OK ||
            (st = dtx_h5_read_markers(mf, mk_path, &mk, &err)) != DTX_OK)
            goto done;
        pg.markers = &mk;
        pg.markers_name = a.markers;
    } else
        for (int i = 0; i < npd; i++)
            panes[i].marker_side = 0;
    if (a.pick_src || a.keypoints) {
        hid_t kf = fs.id[0];
        char kpath[DTX_H5_PATH_MAX];
        if (a.keypoints && (st = resolve(&fs, a.keypoints, &kf, kpath, &err)) != DTX_OK)
            goto done;
        if ((st = find_keypoints(kf, a.keypoints ? kpath : NULL, pd[0].path, &kp, kp_where,
                                 &err)) != DTX_OK)
            goto done;
        pg.keypoints = kp.vertex;
        pg.keypoint_labels = kp.label;
        pg.nkeypoints = kp.vertex ? kp.n : 0;
        pg.keypoints_name = kp_where;
    }

    pg.pick = a.pick_src != NULL;
    pg.file = a.input;
    pg.panes = panes;
    pg.npanes = npd;
    pg.file_frames = tmax;
    pg.stride = stride;
    pg.max_frames = a.max_frames;
    pg.report = report;
    st = dtx_view_write(a.out, &pg, &err);

done:
    for (int i = 0; i < npd; i++)
        pane_free(&pd[i]);
    for (int i = 0; i < nspecs; i++)
        free(specs[i]);
    free(specs);
    dtx_markers_free(&mk);
    dtx_h5_keypoints_free(&kp);
    for (int i = 0; i < fs.n; i++) {
        dtx_error e2;
        dtx_h5_close(&fs.id[i], &e2);
        free(fs.name[i]);
    }
    return st == DTX_OK ? 0 : dtx_cli_fail(&err);
}
