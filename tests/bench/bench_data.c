/*
 * bench_data.c: the helpers the benchmark programs share (see
 * bench_data.h): the data set loader, error exits, allocation, CPU time and
 * the summary line.
 */
#include "bench_data.h"

#include "meshfile.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const char *bench_name = "dtx_bench";

void bench_set_name(const char *name) { bench_name = name; }

double bench_cpu_seconds(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts) != 0)
        return 0.0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void bench_die(const dtx_error *e)
{
    fprintf(stderr, "%s: %s\n", bench_name, e->msg);
    exit(1);
}

void bench_die_msg(const char *what, const char *path)
{
    fprintf(stderr, "%s: %s: %s\n", bench_name, path, what);
    exit(1);
}

void *bench_xmalloc(size_t n, size_t size)
{
    void *p = dtx_alloc(n, size, 0);
    if (!p) {
        fprintf(stderr, "%s: out of memory (%zu x %zu bytes)\n", bench_name, n, size);
        exit(1);
    }
    return p;
}

static void load(const char *path, dtx_mesh *m)
{
    dtx_error e;
    if (dtx_obj_read(path, m, NULL, &e) != DTX_OK)
        bench_die(&e);
}

/* The name before "-reference.obj" of the one such file in dir/sub. */
static void find_reference(const char *dir, const char *sub, char *name, size_t size)
{
    static const char suffix[] = "-reference.obj";
    char path[1200];
    DIR *d;
    struct dirent *ent;
    int found = 0;
    snprintf(path, sizeof path, "%s/%s", dir, sub);
    d = opendir(path);
    if (!d)
        bench_die_msg("cannot open the directory", path);
    while ((ent = readdir(d)) != NULL) {
        size_t n = strlen(ent->d_name), ns = sizeof suffix - 1;
        if (n > ns && n - ns < size && strcmp(ent->d_name + n - ns, suffix) == 0) {
            if (found++)
                bench_die_msg("more than one *-reference.obj", path);
            memcpy(name, ent->d_name, n - ns);
            name[n - ns] = '\0';
        }
    }
    closedir(d);
    if (!found)
        bench_die_msg("no *-reference.obj", path);
}

/* Loads the n meshes dir/sub/<name>-01.obj ... -<n>.obj, each of nv
 * vertices (else "<path>: vertex count differs from <than>" and exit), into
 * a new array of n x nv x 3 positions. */
static double *load_numbered(const char *dir, const char *sub, const char *name, int n,
                             int32_t nv, const char *than)
{
    char path[1600], msg[128];
    double *out = bench_xmalloc((size_t)n * 3 * nv, sizeof *out);
    snprintf(msg, sizeof msg, "vertex count differs from %s", than);
    for (int k = 0; k < n; k++) {
        dtx_mesh m;
        snprintf(path, sizeof path, "%s/%s/%s-%02d.obj", dir, sub, name, k + 1);
        load(path, &m);
        if (m.nv != nv)
            bench_die_msg(msg, path);
        memcpy(out + (size_t)k * 3 * nv, m.V, sizeof(double) * 3 * m.nv);
        dtx_mesh_free(&m);
    }
    return out;
}

void bench_load_dataset(const char *dir, bench_dataset *ds)
{
    char path[1600];
    dtx_error e;
    memset(ds, 0, sizeof *ds);
    snprintf(ds->dir, sizeof ds->dir, "%s", dir);
    find_reference(dir, "source", ds->src_name, sizeof ds->src_name);
    find_reference(dir, "target", ds->tgt_name, sizeof ds->tgt_name);
    snprintf(path, sizeof path, "%s/source/%s-reference.obj", dir, ds->src_name);
    load(path, &ds->src);
    snprintf(path, sizeof path, "%s/target/%s-reference.obj", dir, ds->tgt_name);
    load(path, &ds->tgt);
    snprintf(path, sizeof path, "%s/markers.csv", dir);
    if (dtx_markers_read_csv(path, 0, &ds->mk, &e) != DTX_OK)
        bench_die(&e);
    for (;;) {
        FILE *f;
        snprintf(path, sizeof path, "%s/source/%s-%02d.obj", dir, ds->src_name, ds->nposes + 1);
        if (!(f = fopen(path, "r")))
            break;
        fclose(f);
        ds->nposes++;
    }
    if (ds->nposes == 0) {
        snprintf(path, sizeof path, "%s/source/%s-01.obj", dir, ds->src_name);
        bench_die_msg("no numbered poses (expected this file and following ones)", path);
    }
    ds->poses =
        load_numbered(dir, "source", ds->src_name, ds->nposes, ds->src.nv, "the reference");
}

void bench_load_paper_results(const char *dir, bench_dataset *ds)
{
    char path[1600];
    FILE *f;
    snprintf(path, sizeof path, "%s/paper-results/%s-01.obj", dir, ds->tgt_name);
    if ((f = fopen(path, "r")) == NULL)
        return;
    fclose(f);
    ds->results =
        load_numbered(dir, "paper-results", ds->tgt_name, ds->nposes, ds->tgt.nv, "the target");
}

void bench_free_dataset(bench_dataset *ds)
{
    dtx_mesh_free(&ds->src);
    dtx_mesh_free(&ds->tgt);
    dtx_markers_free(&ds->mk);
    free(ds->poses);
    free(ds->results);
}

void bench_summary3(bench_summary_style style, const char *what, const double *v, int n,
                    double scale, const char *unit)
{
    double lo, hi, s = 0.0;
    if (n < 1)
        return;
    lo = hi = v[0];
    for (int i = 0; i < n; i++) {
        lo = v[i] < lo ? v[i] : lo;
        hi = v[i] > hi ? v[i] : hi;
        s += v[i];
    }
    if (style == BENCH_SUMMARY_G4)
        printf("    %-34s min %.4g  mean %.4g  max %.4g %s\n", what, scale * lo, scale * s / n,
               scale * hi, unit);
    else
        printf("  %-34s min %.3f  mean %.3f  max %.3f %s\n", what, scale * lo, scale * s / n,
               scale * hi, unit);
}
