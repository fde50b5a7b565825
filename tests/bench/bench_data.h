/*
 * bench_data.h: what the benchmark programs (bench_sp04.c, bench_mc.c,
 * bench_springs.c) share: the data set they read, the error exits with the
 * program's name, the allocation that cannot fail, CPU time, and the
 * min/mean/max summary line.  Printed figures only; nothing is asserted.
 *
 * A data set directory holds source/<src>-reference.obj with poses
 * source/<src>-01.obj, -02.obj, ..., target/<tgt>-reference.obj and
 * markers.csv (0-based), as the shared sumner-cat-lion and
 * sumner-horse-camel sets do (and, optionally, paper-results/<tgt>-01.obj,
 * ...: sp04's published results).
 *
 * Messages read "NAME: ..." on stderr, NAME being what bench_set_name set
 * ("dtx_bench" unless set); every error exits with status 1.
 */
#ifndef DTX_BENCH_DATA_H
#define DTX_BENCH_DATA_H

#include "dtx_core.h"

#include <stddef.h>

typedef struct {
    char dir[1024];
    char src_name[256], tgt_name[256]; /* "cat", "lion" */
    dtx_mesh src, tgt;
    dtx_markers mk;
    int nposes;
    double *poses;   /* nposes x nv_s x 3 */
    double *results; /* nposes x nv_t x 3: paper-results, or NULL */
} bench_dataset;

/* The program name that starts every message (kept, not copied). */
void bench_set_name(const char *name);

/* CPU seconds of the whole process (all threads): unlike the wall clock,
 * not inflated when other jobs share the cores. */
double bench_cpu_seconds(void);

/* "NAME: <e->msg>" and exit(1). */
_Noreturn void bench_die(const dtx_error *e);

/* "NAME: <path>: <what>" and exit(1). */
_Noreturn void bench_die_msg(const char *what, const char *path);

/* dtx_alloc(n, size, 0), or "NAME: out of memory (...)" and exit(1). */
void *bench_xmalloc(size_t n, size_t size);

/* Loads the rest meshes, the markers and the numbered poses <src>-01.obj,
 * -02.obj, ... (as many as exist in a row; at least one); results NULL. */
void bench_load_dataset(const char *dir, bench_dataset *ds);

/* When dir/paper-results/<tgt>-01.obj exists, loads the nposes results
 * <tgt>-01.obj, -02.obj, ... into ds->results (after bench_load_dataset). */
void bench_load_paper_results(const char *dir, bench_dataset *ds);

void bench_free_dataset(bench_dataset *ds);

/* How bench_summary3 prints its line. */
typedef enum {
    BENCH_SUMMARY_F3, /* indented 2, %.3f (dtx_bench_mc) */
    BENCH_SUMMARY_G4  /* indented 4, %.4g (dtx_bench_springs) */
} bench_summary_style;

/* One line "what min .. mean .. max .. unit" of scale * v[0..n-1] on
 * stdout; nothing when n < 1. */
void bench_summary3(bench_summary_style style, const char *what, const double *v, int n,
                    double scale, const char *unit);

#endif
