/*
 * bench_keypoints.c: time of automatic key-point selection (keypoints.h) on
 * a rest mesh and its deformed frames (OBJ, PLY or OFF files).
 *
 *   dtx_bench_keypoints [--candidates N] [--threads T] [--eps E] [--max K]
 *                       [--sweeps S] [--exact] REST FRAME...
 *
 * Prints one line: vertices, frames, threads, mode, seconds, key points,
 * errors (first point alone, final, final with bounded weights), evaluations,
 * and the chosen vertices.  Run by scripts/bench-keypoints.sh.
 */
#include "dtx_core.h"
#include "keypoints.h"
#include "meshfile.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv)
{
    dtx_kp_params p;
    dtx_kp_result r;
    dtx_mesh rest = {0};
    dtx_error err;
    double *X = NULL, t0;
    int i = 1, nfr;
    dtx_kp_params_default(&p);
    p.threads = 1;
    for (; i < argc && argv[i][0] == '-'; i++) {
        if (strcmp(argv[i], "--exact") == 0)
            p.exact = 1;
        else if (i + 1 < argc && strcmp(argv[i], "--candidates") == 0)
            p.candidates = atoi(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--threads") == 0)
            p.threads = atoi(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--eps") == 0)
            p.eps = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--max") == 0)
            p.max_keys = atoi(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--sweeps") == 0)
            p.max_sweeps = atoi(argv[++i]);
        else {
            fprintf(stderr, "dtx_bench_keypoints: unknown option %s\n", argv[i]);
            return 2;
        }
    }
    if (argc - i < 2) {
        fprintf(stderr, "usage: dtx_bench_keypoints [options] REST FRAME...\n");
        return 2;
    }
    if (dtx_mesh_read(argv[i], &rest, NULL, &err) != DTX_OK) {
        fprintf(stderr, "dtx_bench_keypoints: %s\n", err.msg);
        return 1;
    }
    nfr = argc - i - 1;
    X = malloc(sizeof *X * 3 * (size_t)rest.nv * (size_t)nfr);
    for (int f = 0; f < nfr; f++) {
        dtx_mesh m = {0};
        if (dtx_mesh_read(argv[i + 1 + f], &m, NULL, &err) != DTX_OK || m.nv != rest.nv) {
            fprintf(stderr, "dtx_bench_keypoints: %s: %s\n", argv[i + 1 + f],
                    m.nv != rest.nv ? "vertex count differs from the rest mesh" : err.msg);
            return 1;
        }
        memcpy(X + (size_t)f * 3 * rest.nv, m.V, sizeof *X * 3 * (size_t)rest.nv);
        dtx_mesh_free(&m);
    }
    t0 = omp_get_wtime();
    if (dtx_keypoints_select(&rest, nfr, X, &p, &r, &err) != DTX_OK) {
        fprintf(stderr, "dtx_bench_keypoints: %s\n", err.msg);
        return 1;
    }
    printf("vertices %d frames %d threads %d mode %s candidates %d: %.2f s, %d key points, "
           "error %.4f (first %.4f, bounded weights %.4f), %d replacements, %lld evaluations; "
           "keys",
           (int)rest.nv, nfr, p.threads, p.exact ? "exact" : "fast", (int)r.ncand,
           omp_get_wtime() - t0, (int)r.count, r.error, r.error_first, r.error_exact,
           (int)r.replacements, (long long)r.evaluations);
    for (int32_t k = 0; k < r.count; k++)
        printf(" %d", (int)r.keys[k]);
    printf("\n");
    dtx_kp_result_free(&r);
    free(X);
    dtx_mesh_free(&rest);
    return 0;
}
