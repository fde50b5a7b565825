/*
 * cmd_diff.c: `dtx diff`, the positions of one result in two files.
 *
 * Only frames marked done in both files are compared: the others hold
 * undefined values.  A frame done in one file and not in the other is a
 * difference.  A non-finite coordinate in a compared frame (NaN or Inf in
 * one file or in both) is always a difference: "same" must mean tested, and
 * NaN compares false, so every comparison that decides the verdict is
 * written as !(x <= limit).
 */
#include "cmd_diff.h"

#include "options.h"

#include "dtx_core.h"
#include "h5layout.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LIST_MAX 8 /* frames named in a message */

static int diff_usage(const char *fmt, const char *a, const char *b)
{
    fputs("dtx: diff: ", stderr);
    fprintf(stderr, fmt, a, b);
    fputc('\n', stderr);
    dtx_cli_print_usage(stderr, dtx_cli_find_name("diff"));
    return 2;
}

/* Parses --tol: a finite number >= 0 with nothing after it. */
static int parse_tol(const char *s, double *tol)
{
    char *end = NULL;
    errno = 0;
    *tol = strtod(s, &end);
    if (end == s || *end != '\0' || errno == ERANGE)
        return diff_usage("--tol \"%s\" is not a number%s", s,
                          " (want a relative tolerance >= 0, e.g. 1e-9)");
    if (!isfinite(*tol) || !(*tol >= 0))
        return diff_usage("--tol %s: want a finite relative tolerance >= 0%s", s,
                          " (e.g. 1e-9; 0 for bitwise equality)");
    return 0;
}

/* Up to LIST_MAX frame numbers "3, 4, 7, ..." of frames flagged in mark. */
static void frame_list(const unsigned char *mark, int64_t T, char *buf, size_t n)
{
    size_t used = 0;
    int shown = 0;
    buf[0] = '\0';
    for (int64_t f = 0; f < T; f++) {
        int w;
        if (!mark[f])
            continue;
        w = shown < LIST_MAX ? snprintf(buf + used, n - used, "%s%lld", shown ? ", " : "",
                                        (long long)f)
                             : snprintf(buf + used, n - used, ", ...");
        if (w < 0 || (size_t)w >= n - used)
            break;
        used += (size_t)w;
        if (shown++ == LIST_MAX)
            break;
    }
}

int dtx_cmd_diff(int argc, char **argv)
{
    const char *pos[3] = {NULL, NULL, NULL};
    int npos = 0, rc = 1;
    double tol = 1e-12, maxd = 0.0, maxv = 0.0;
    dtx_error err;
    dtx_status st;
    hid_t fa = H5I_INVALID_HID, fb = H5I_INVALID_HID;
    dtx_h5_result ra, rb;
    double *a = NULL, *b = NULL;
    uint8_t *da = NULL, *db = NULL;
    unsigned char *skip = NULL;
    int64_t T = 0, ncompared = 0, nskip = 0, nonly_a = 0, nonly_b = 0, nnone = 0;
    int64_t nonfinite = 0, nf_frames = 0, nf_first_f = -1, nf_first_v = -1;
    double nf_a = 0, nf_b = 0;
    char list[200];

    /* ------------------------------------------------------ arguments */
    for (int i = 2; i < argc; i++) {
        if (strcmp(argv[i], "--tol") == 0) {
            if (i + 1 >= argc)
                return diff_usage("--tol needs a value%s%s", "", "");
            if (parse_tol(argv[++i], &tol) != 0)
                return 2;
        } else if (argv[i][0] == '-' && argv[i][1] == '-') {
            return diff_usage("unknown option %s%s", argv[i], "");
        } else if (npos < 3) {
            pos[npos++] = argv[i];
        } else {
            return diff_usage("too many arguments (%s)%s", argv[i], "");
        }
    }
    if (npos != 3)
        return diff_usage("needs two files and a result path%s%s", "", "");

    /* ----------------------------------------------------------- open */
    memset(&ra, 0, sizeof ra);
    memset(&rb, 0, sizeof rb);
    st = dtx_h5_open(pos[0], MPI_COMM_NULL, 0, &fa, &err);
    if (st == DTX_OK)
        st = dtx_h5_open(pos[1], MPI_COMM_NULL, 0, &fb, &err);
    if (st == DTX_OK)
        st = dtx_h5_result_open(fa, pos[2], 0, &ra, &err);
    if (st == DTX_OK)
        st = dtx_h5_result_open(fb, pos[2], 0, &rb, &err);
    if (st == DTX_OK && (ra.nframes != rb.nframes || ra.nv != rb.nv))
        st = dtx_seterr(&err, DTX_EFORMAT, "%s: shapes differ (%lld x %d in %s, %lld x %d in %s)",
                        pos[2], (long long)ra.nframes, (int)ra.nv, pos[0],
                        (long long)rb.nframes, (int)rb.nv, pos[1]);
    if (st == DTX_OK) {
        T = ra.nframes;
        a = dtx_alloc((size_t)ra.nv, 3 * sizeof *a, 0);
        b = dtx_alloc((size_t)ra.nv, 3 * sizeof *b, 0);
        da = dtx_alloc((size_t)T + 1, 1, 0);
        db = dtx_alloc((size_t)T + 1, 1, 0);
        skip = dtx_alloc((size_t)T + 1, 1, 1);
        if (!a || !b || !da || !db || !skip)
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
    }
    if (st == DTX_OK)
        st = dtx_h5_result_read_done(&ra, da, &err);
    if (st == DTX_OK)
        st = dtx_h5_result_read_done(&rb, db, &err);

    /* ------------------------------------- frames done in both files */
    for (int64_t f = 0; st == DTX_OK && f < T; f++) {
        int64_t bad_here = 0;
        if (da[f] != 1 || db[f] != 1) {
            skip[f] = 1;
            nskip++;
            nonly_a += da[f] == 1;
            nonly_b += db[f] == 1;
            nnone += da[f] != 1 && db[f] != 1;
            continue;
        }
        st = dtx_h5_result_read(&ra, f, 1, a, NULL, &err);
        if (st == DTX_OK)
            st = dtx_h5_result_read(&rb, f, 1, b, NULL, &err);
        for (size_t i = 0; st == DTX_OK && i < 3 * (size_t)ra.nv; i++) {
            double d;
            if (!isfinite(a[i]) || !isfinite(b[i])) {
                if (nonfinite++ == 0) {
                    nf_first_f = f;
                    nf_first_v = (int64_t)(i / 3);
                    nf_a = a[i];
                    nf_b = b[i];
                }
                bad_here = 1;
                continue;
            }
            d = fabs(a[i] - b[i]);
            maxd = d > maxd ? d : maxd;
            maxv = fabs(a[i]) > maxv ? fabs(a[i]) : maxv;
        }
        nf_frames += bad_here;
        ncompared += st == DTX_OK;
    }
    if (st != DTX_OK) {
        fprintf(stderr, "dtx: error: %s\n", err.msg);
        goto done;
    }

    /* ------------------------------------------------------- verdict */
    printf("max difference %.3g (relative %.3g) over %lld of %lld frames (done in both)\n",
           maxd, maxv > 0 ? maxd / maxv : maxd, (long long)ncompared, (long long)T);
    rc = 0;
    if (nskip > 0) {
        frame_list(skip, T, list, sizeof list);
        printf("not compared: %lld of %lld frames not done in both (%lld done only in %s, "
               "%lld done only in %s, %lld in neither): %s\n",
               (long long)nskip, (long long)T, (long long)nonly_a, pos[0], (long long)nonly_b,
               pos[1], (long long)nnone, list);
        if (nonly_a + nonly_b > 0)
            rc = 1;
    }
    if (nonfinite > 0) {
        printf("non-finite coordinates: %lld value%s in %lld frame%s; first frame %lld "
               "(0-based), vertex %lld: %g in %s, %g in %s\n",
               (long long)nonfinite, nonfinite == 1 ? "" : "s", (long long)nf_frames,
               nf_frames == 1 ? "" : "s", (long long)nf_first_f,
               (long long)nf_first_v, nf_a, pos[0], nf_b, pos[1]);
        rc = 1;
    }
    if (ncompared == 0) {
        printf("no frame is done in both files: nothing compared\n");
        rc = 1;
    }
    if (!(maxd <= tol * (maxv > 0 ? maxv : 1.0)))
        rc = 1;
    if (rc == 0)
        printf("same: within --tol %g over the %lld frame%s done in both\n", tol,
               (long long)ncompared, ncompared == 1 ? "" : "s");
    else
        printf("differ (--tol %g)\n", tol);
done:
    free(a);
    free(b);
    free(da);
    free(db);
    free(skip);
    dtx_h5_result_close(&ra);
    dtx_h5_result_close(&rb);
    dtx_h5_close(&fa, NULL);
    dtx_h5_close(&fb, NULL);
    return rc;
}
