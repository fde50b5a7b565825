/* frame_normals.c: per-frame normals that keep the asset's smoothing
 * (frame_normals.h). */
#include "frame_normals.h"

#include "weld.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* cos(0.8 degrees): corners whose asset normals are closer than this are
 * in one smoothing group (authored normals of a smooth surface are equal up
 * to rounding; a hard edge differs by far more). */
#define SAME_GROUP_COS 0.9999

void dtx_frame_normals_free(dtx_frame_normals *p)
{
    if (!p)
        return;
    free(p->out_faces);
    free(p->start);
    free(p->faces);
    free(p->fallback);
    free(p->out_group);
    free(p->sum);
    memset(p, 0, sizeof *p);
}

static void unit(const double *n, double *u)
{
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (l > 0) {
        u[0] = n[0] / l, u[1] = n[1] / l, u[2] = n[2] / l;
    } else {
        u[0] = u[1] = u[2] = 0;
    }
}

static int same_group(const double *a, const double *b)
{
    double ua[3], ub[3];
    unit(a, ua);
    unit(b, ub);
    if (ua[0] == 0 && ua[1] == 0 && ua[2] == 0)
        return ub[0] == 0 && ub[1] == 0 && ub[2] == 0;
    return ua[0] * ub[0] + ua[1] * ub[1] + ua[2] * ub[2] >= SAME_GROUP_COS;
}

/* Corners sorted by (vertex, normal index). */
typedef struct {
    int32_t v, j, c;
} corner_key;

static int cmp_key(const void *pa, const void *pb)
{
    const corner_key *a = pa, *b = pb;
    if (a->v != b->v)
        return a->v < b->v ? -1 : 1;
    if (a->j != b->j)
        return a->j < b->j ? -1 : 1;
    return a->c < b->c ? -1 : a->c > b->c;
}

dtx_status dtx_frame_normals_plan(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                                  const double *normals, int32_t nn,
                                  const int32_t *normal_faces, dtx_frame_normals *p,
                                  dtx_error *err)
{
    int64_t nc = 3 * (int64_t)nf;
    int32_t *map = NULL, *rep = NULL, *pstart = NULL, *pcorner = NULL, *rep_v = NULL,
            *rep_j = NULL, nw = 0;
    int32_t *grep_n = NULL, *cgroup = NULL;
    corner_key *keys = NULL;
    int pervertex = 1;
    dtx_status st;

    memset(p, 0, sizeof *p);
    if (nv < 0 || nf < 0 || nn < 0 || nc > INT32_MAX)
        return dtx_seterr(err, DTX_EINVAL, "frame normals: bad counts (nv %d, nf %d, nn %d)",
                          (int)nv, (int)nf, (int)nn);
    for (int64_t c = 0; c < nc && pervertex; c++)
        pervertex = normal_faces[c] == F[c];
    p->nf = nf;
    map = malloc(((size_t)nv + 1) * sizeof *map);
    rep = malloc(((size_t)nv + 1) * sizeof *rep);
    p->out_faces = malloc(((size_t)nc + 1) * sizeof *p->out_faces);
    keys = malloc(((size_t)nc + 1) * sizeof *keys);
    if (!map || !rep || !p->out_faces || !keys)
        goto oom;
    if ((st = dtx_weld_map(V, nv, 0.0, map, rep, &nw, err)) != DTX_OK)
        goto fail;

    /* ---- output normals: one per (vertex, asset normal) pair */
    if (pervertex) {
        p->nout = nv;
        memcpy(p->out_faces, F, (size_t)nc * sizeof *F);
    } else {
        for (int64_t c = 0; c < nc; c++)
            keys[c] = (corner_key){F[c], normal_faces[c], (int32_t)c};
        qsort(keys, (size_t)nc, sizeof *keys, cmp_key);
        for (int64_t i = 0; i < nc; i++) {
            if (i == 0 || keys[i].v != keys[i - 1].v || keys[i].j != keys[i - 1].j)
                p->nout++;
            p->out_faces[keys[i].c] = p->nout - 1;
        }
    }
    rep_v = malloc(((size_t)p->nout + 1) * sizeof *rep_v);
    rep_j = malloc(((size_t)p->nout + 1) * sizeof *rep_j);
    p->fallback = malloc(((size_t)p->nout + 1) * 3 * sizeof *p->fallback);
    if (!rep_v || !rep_j || !p->fallback)
        goto oom;
    for (int32_t o = 0; o < p->nout; o++)
        rep_v[o] = o, rep_j[o] = pervertex && o < nn ? o : -1;
    for (int64_t c = 0; c < nc; c++) {
        rep_v[p->out_faces[c]] = F[c];
        rep_j[p->out_faces[c]] = normal_faces[c];
    }
    for (int32_t o = 0; o < p->nout; o++) {
        double *fb = p->fallback + 3 * (size_t)o;
        if (rep_j[o] >= 0)
            unit(normals + 3 * (size_t)rep_j[o], fb);
        else
            fb[0] = fb[1] = fb[2] = 0;
        if (fb[0] == 0 && fb[1] == 0 && fb[2] == 0)
            fb[2] = 1;
    }

    /* ---- corners by position (twins together) */
    pstart = calloc((size_t)nw + 2, sizeof *pstart);
    pcorner = malloc(((size_t)nc + 1) * sizeof *pcorner);
    if (!pstart || !pcorner)
        goto oom;
    for (int64_t c = 0; c < nc; c++)
        pstart[map[F[c]] + 2]++;
    for (int32_t w = 0; w < nw; w++)
        pstart[w + 2] += pstart[w + 1];
    for (int64_t c = 0; c < nc; c++)
        pcorner[pstart[map[F[c]] + 1]++] = (int32_t)c;

    /* ---- smoothing groups: the corners at one position whose asset
     * normals agree (greedy, against each group's first normal), so that
     * outputs sharing a group share its face list (memory O(corners) even
     * where one position has many corners, as in a per-corner FBX mesh) */
    grep_n = malloc(((size_t)nc + 1) * sizeof *grep_n);
    cgroup = malloc(((size_t)nc + 1) * sizeof *cgroup);
    if (!grep_n || !cgroup)
        goto oom;
    for (int32_t w = 0; w < nw; w++) {
        int32_t first = p->ngroup;
        for (int32_t i = pstart[w]; i < pstart[w + 1]; i++) {
            int32_t c = pcorner[i], g = first;
            while (g < p->ngroup && !same_group(normals + 3 * (size_t)normal_faces[c],
                                                normals + 3 * (size_t)grep_n[g]))
                g++;
            if (g == p->ngroup)
                grep_n[p->ngroup++] = normal_faces[c];
            cgroup[c] = g;
        }
    }
    p->start = calloc((size_t)p->ngroup + 2, sizeof *p->start);
    p->faces = malloc(((size_t)nc + 1) * sizeof *p->faces);
    p->sum = malloc(((size_t)p->ngroup + 1) * 3 * sizeof *p->sum);
    p->out_group = malloc(((size_t)p->nout + 1) * sizeof *p->out_group);
    if (!p->start || !p->faces || !p->sum || !p->out_group)
        goto oom;
    for (int64_t c = 0; c < nc; c++)
        p->start[cgroup[c] + 2]++;
    for (int32_t g = 0; g < p->ngroup; g++)
        p->start[g + 2] += p->start[g + 1];
    for (int64_t c = 0; c < nc; c++)
        p->faces[p->start[cgroup[c] + 1]++] = (int32_t)(c / 3);
    for (int32_t o = 0; o < p->nout; o++)
        p->out_group[o] = -1;
    for (int64_t c = 0; c < nc; c++)
        p->out_group[p->out_faces[c]] = cgroup[c];
    st = DTX_OK;
    goto done;
oom:
    st = dtx_seterr(err, DTX_ENOMEM, "frame normals: out of memory");
fail:
    dtx_frame_normals_free(p);
done:
    free(grep_n);
    free(cgroup);
    free(map);
    free(rep);
    free(keys);
    free(rep_v);
    free(rep_j);
    free(pstart);
    free(pcorner);
    return st;
}

static void get(const double *X, const float *Xf, int32_t i, double *x)
{
    for (int k = 0; k < 3; k++)
        x[k] = X ? X[3 * (size_t)i + k] : (double)Xf[3 * (size_t)i + k];
}

void dtx_frame_normals_apply(const dtx_frame_normals *p, const double *X, const float *Xf,
                             const int32_t *F, double *N)
{
    for (int32_t g = 0; g < p->ngroup; g++) {
        double *s = p->sum + 3 * (size_t)g;
        s[0] = s[1] = s[2] = 0;
        for (int32_t i = p->start[g]; i < p->start[g + 1]; i++) {
            const int32_t *t = F + 3 * (size_t)p->faces[i];
            double a[3], b[3], c[3], e1[3], e2[3];
            get(X, Xf, t[0], a);
            get(X, Xf, t[1], b);
            get(X, Xf, t[2], c);
            for (int k = 0; k < 3; k++)
                e1[k] = b[k] - a[k], e2[k] = c[k] - a[k];
            s[0] += e1[1] * e2[2] - e1[2] * e2[1];
            s[1] += e1[2] * e2[0] - e1[0] * e2[2];
            s[2] += e1[0] * e2[1] - e1[1] * e2[0];
        }
    }
    for (int32_t o = 0; o < p->nout; o++) {
        const double *s = p->out_group[o] >= 0 ? p->sum + 3 * (size_t)p->out_group[o] : NULL;
        double l = s ? sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]) : 0;
        if (l > 0 && isfinite(l)) {
            for (int k = 0; k < 3; k++)
                N[3 * (size_t)o + k] = s[k] / l;
        } else {
            memcpy(N + 3 * (size_t)o, p->fallback + 3 * (size_t)o, 3 * sizeof *N);
        }
    }
}
