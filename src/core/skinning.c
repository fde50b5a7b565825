/*
 * skinning.c: the rest-mesh set-up, the precomputed fit and the per-frame
 * local/global solve of the clustered ARAP skinning fit (Yang et al. 2018,
 * sections 3.2 and 3.4; see skinning.h for the energy).
 *
 * The reduced space.  Write the transforms as one 4m x 3 matrix T (row
 * 4k + a, column c holds T_k[c][a]) and M for the nv x 4m skinning matrix,
 * M[i][4k + a] = W_ik [p_i; 1]_a, so that q = M T (nv x 3).  With d_ij the
 * row M_i - M_j, every term of E is a quadratic in T:
 *
 *     E(T, R) = lambda (tr T^T K T - 2 tr T^T sum_g P_g^T R_g^T + c_p)
 *             + tr T^T G T - 2 tr T^T M^T q' + |q'|^2,
 *
 *     K = sum_spokes w_ij d_ij^T d_ij,      G = M^T M,
 *     P_g = sum_{spokes (i,j), i in g} w_ij (p_i - p_j) d_ij   (3 x 4m),
 *     c_p = sum_spokes w_ij |p_i - p_j|^2,
 *
 * and the covariance of cluster g for the current T is simply P_g T.  So a
 * local step costs O(nclusters m), a global step one solve with the
 * Cholesky factor of A = lambda K + G, and the energy changes are exact
 * quadratic forms: a local step lowers E by 2 lambda sum_g tr((R_new -
 * R_old) C_g), a global step by |L^T (T_new - T_old)|^2 (A = L L^T).  The
 * mesh enters only once per frame, to form M^T q'.
 *
 * Conditioning: the rest mesh is centred and scaled to unit RMS radius, and
 * each frame centred on its own centroid (the weights sum to one, so a
 * translation of the frame is a translation of every T_k); the transforms
 * are mapped back to the caller's coordinates at the end.
 */
#include "dtx_core.h"
#include "mat3.h"
#include "skinning_internal.h"
#include "vec3.h"

#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* A pivot of the normal matrix below this fraction of its diagonal entry
 * means the skinning basis is (numerically) linearly dependent. */
#define SKIN_PIVOT_RATIO 1e-13

/* Rows of W may miss 1 by this much (the per-frame centring relies on it). */
#define SKIN_UNITY_TOL 1e-6

void dtx_skin_params_default(dtx_skin_params *p)
{
    memset(p, 0, sizeof *p);
    p->lambda = 0.5;
    p->nclusters = 0;
    p->gamma_logr = 1.0;
    p->gamma_s = 0.1;
    p->kmeans_iters = 100;
    p->kmeans_seed = 0x5EED5EEDu;
    p->max_iters = 100;
    p->tol = 1e-5;
    p->threads = 0;
}

int dtx_skin_threads_(int threads)
{
    int n = threads > 0 ? threads : omp_get_max_threads();
    return n > 0 ? n : 1;
}

/* ================================================================== */
/* The rest mesh                                                       */
/* ================================================================== */

typedef struct {
    int64_t key;   /* lo * nv + hi */
    int64_t order; /* face * 3 + corner: a total order for equal keys */
    double w;
} edge_entry;

static int cmp_edge(const void *a, const void *b)
{
    const edge_entry *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->order > y->order) - (x->order < y->order);
}

/* cot of the angle at o between the edges to a and b, clamped for needles. */
static double cot_at(const double *o, const double *a, const double *b)
{
    double u[3], v[3], x[3], s, c, lim = 1.0 / DTX_MESH_THIN_RATIO;
    sub3(a, o, u);
    sub3(b, o, v);
    cross3(u, v, x);
    s = sqrt(dot3(x, x));
    c = dot3(u, v);
    if (s <= DTX_MESH_THIN_RATIO * sqrt(dot3(u, u) * dot3(v, v)))
        return c > 0.0 ? lim : (c < 0.0 ? -lim : 0.0);
    return c / s;
}

int32_t dtx_skin_mesh_nv(const dtx_skin_mesh *mesh) { return mesh ? mesh->nv : 0; }

void dtx_skin_mesh_free(dtx_skin_mesh **mesh)
{
    dtx_skin_mesh *m;
    if (!mesh || !*mesh)
        return;
    m = *mesh;
    free(m->V);
    free(m->F);
    free(m->P);
    free(m->spoke_start);
    free(m->spoke_j);
    free(m->spoke_w);
    free(m->spoke_we);
    free(m->vertex_we);
    free(m->Vinv);
    free(m->vf_start);
    free(m->vf_face);
    free(m->vf_w);
    free(m);
    *mesh = NULL;
}

dtx_status dtx_skin_mesh_create(const double *V, int32_t nv, const int32_t *F, int32_t nf,
                                dtx_skin_edge_weights weights, dtx_skin_mesh **out, dtx_error *err)
{
    dtx_skin_mesh *m = NULL;
    edge_entry *ed = NULL;
    double *area = NULL, *vsum = NULL;
    int64_t nuniq = 0;
    dtx_status st = DTX_OK;

    if (!out)
        return dtx_seterr(err, DTX_EINVAL, "skinning mesh: no output pointer");
    *out = NULL;
    if (!V || !F || nv < 3 || nf < 1)
        return dtx_seterr(err, DTX_EINVAL,
                          "skinning mesh: needs at least 3 vertices and 1 triangle (got %d, %d)",
                          (int)nv, (int)nf);
    if (weights != DTX_SKIN_COTAN && weights != DTX_SKIN_UNIFORM)
        return dtx_seterr(err, DTX_EINVAL, "skinning mesh: unknown edge weighting %d",
                          (int)weights);

    /* ---- validate */
    for (int64_t i = 0; i < 3 * (int64_t)nv; i++)
        if (!isfinite(V[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "skinning mesh: vertex %lld has a non-finite coordinate",
                              (long long)(i / 3));
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * f;
        for (int k = 0; k < 3; k++)
            if (t[k] < 0 || t[k] >= nv)
                return dtx_seterr(err, DTX_ERANGE,
                                  "skinning mesh: triangle %d has vertex index %d "
                                  "(mesh has %d vertices)",
                                  (int)f, (int)t[k], (int)nv);
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            return dtx_seterr(err, DTX_EMESH, "skinning mesh: triangle %d repeats a vertex",
                              (int)f);
    }

    m = calloc(1, sizeof *m);
    if (!m)
        return dtx_seterr(err, DTX_ENOMEM, "skinning mesh: out of memory");
    m->nv = nv;
    m->nf = nf;
    m->V = dtx_alloc((size_t)nv * 3, sizeof(double), 0);
    m->F = dtx_alloc((size_t)nf * 3, sizeof(int32_t), 0);
    m->P = dtx_alloc((size_t)nv * 3, sizeof(double), 0);
    m->Vinv = dtx_alloc((size_t)nf * 9, sizeof(double), 0);
    m->vf_start = dtx_alloc((size_t)nv + 1, sizeof(int64_t), 1);
    m->vf_face = dtx_alloc((size_t)nf * 3, sizeof(int32_t), 0);
    m->vf_w = dtx_alloc((size_t)nf * 3, sizeof(double), 0);
    m->spoke_start = dtx_alloc((size_t)nv + 1, sizeof(int64_t), 1);
    m->vertex_we = dtx_alloc((size_t)nv * 3, sizeof(double), 1);
    ed = dtx_alloc((size_t)nf * 3, sizeof *ed, 0);
    area = dtx_alloc((size_t)nf, sizeof *area, 0);
    vsum = dtx_alloc((size_t)nv, sizeof *vsum, 1);
    if (!m->V || !m->F || !m->P || !m->Vinv || !m->vf_start || !m->vf_face || !m->vf_w ||
        !m->spoke_start || !m->vertex_we || !ed || !area || !vsum)
        goto nomem;
    memcpy(m->V, V, sizeof(double) * 3 * (size_t)nv);
    memcpy(m->F, F, sizeof(int32_t) * 3 * (size_t)nf);

    /* ---- vertex-to-triangle incidence with rest-area weights */
    for (int32_t f = 0; f < nf; f++)
        for (int k = 0; k < 3; k++)
            m->vf_start[F[3 * f + k] + 1]++;
    for (int32_t i = 0; i < nv; i++) {
        if (m->vf_start[i + 1] == 0) {
            st = dtx_seterr(err, DTX_EMESH,
                            "skinning mesh: vertex %d is in no triangle (it has no "
                            "deformation gradient and no edges)",
                            (int)i);
            goto fail;
        }
        m->vf_start[i + 1] += m->vf_start[i];
    }
    {
        int64_t *fill = dtx_alloc((size_t)nv, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, m->vf_start, sizeof(int64_t) * (size_t)nv);
        for (int32_t f = 0; f < nf; f++) {
            double e1[3], e2[3], x[3];
            const int32_t *t = F + 3 * f;
            sub3(V + 3 * t[1], V + 3 * t[0], e1);
            sub3(V + 3 * t[2], V + 3 * t[0], e2);
            cross3(e1, e2, x);
            area[f] = 0.5 * sqrt(dot3(x, x));
            for (int k = 0; k < 3; k++) {
                m->vf_face[fill[t[k]]++] = f;
                vsum[t[k]] += area[f];
            }
        }
        free(fill);
        for (int32_t i = 0; i < nv; i++) {
            int64_t b = m->vf_start[i], e = m->vf_start[i + 1];
            for (int64_t s = b; s < e; s++)
                m->vf_w[s] = vsum[i] > 0.0 ? area[m->vf_face[s]] / vsum[i] : 1.0 / (double)(e - b);
        }
    }
    dtx_frame_inverses(V, F, nf, 0.0, m->Vinv);

    /* ---- normalisation */
    {
        double c[3] = {0, 0, 0}, r2 = 0.0;
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                c[k] += V[3 * i + k];
        for (int k = 0; k < 3; k++)
            c[k] /= nv;
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++) {
                double d = V[3 * i + k] - c[k];
                r2 += d * d;
            }
        m->scale = sqrt(r2 / nv);
        if (!(m->scale > 0.0)) {
            st = dtx_seterr(err, DTX_EMESH, "skinning mesh: all vertices at one point");
            goto fail;
        }
        memcpy(m->center, c, sizeof c);
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                m->P[3 * i + k] = (V[3 * i + k] - c[k]) / m->scale;
    }

    /* ---- undirected edges with summed weights, then spokes */
    for (int32_t f = 0; f < nf; f++) {
        const int32_t *t = F + 3 * f;
        for (int k = 0; k < 3; k++) {
            /* Corner k is opposite the edge (t[k+1], t[k+2]). */
            int32_t a = t[(k + 1) % 3], b = t[(k + 2) % 3], lo = a < b ? a : b, hi = a < b ? b : a;
            edge_entry *e = ed + 3 * (int64_t)f + k;
            e->key = (int64_t)lo * nv + hi;
            e->order = 3 * (int64_t)f + k;
            e->w =
                weights == DTX_SKIN_COTAN ? 0.5 * cot_at(V + 3 * t[k], V + 3 * a, V + 3 * b) : 1.0;
        }
    }
    qsort(ed, (size_t)nf * 3, sizeof *ed, cmp_edge);
    for (int64_t s = 0; s < 3 * (int64_t)nf;) {
        int64_t e = s + 1;
        double w = ed[s].w;
        for (; e < 3 * (int64_t)nf && ed[e].key == ed[s].key; e++)
            if (weights == DTX_SKIN_COTAN)
                w += ed[e].w;
        ed[nuniq].key = ed[s].key;
        ed[nuniq].w = w;
        nuniq++;
        s = e;
    }
    m->nspokes = 2 * nuniq;
    m->spoke_j = dtx_alloc((size_t)m->nspokes, sizeof(int32_t), 0);
    m->spoke_w = dtx_alloc((size_t)m->nspokes, sizeof(double), 0);
    m->spoke_we = dtx_alloc((size_t)m->nspokes * 3, sizeof(double), 0);
    if (!m->spoke_j || !m->spoke_w || !m->spoke_we)
        goto nomem;
    for (int64_t e = 0; e < nuniq; e++) {
        m->spoke_start[ed[e].key / nv + 1]++;
        m->spoke_start[ed[e].key % nv + 1]++;
    }
    for (int32_t i = 0; i < nv; i++)
        m->spoke_start[i + 1] += m->spoke_start[i];
    {
        int64_t *fill = dtx_alloc((size_t)nv, sizeof *fill, 0);
        if (!fill)
            goto nomem;
        memcpy(fill, m->spoke_start, sizeof(int64_t) * (size_t)nv);
        /* Edges sorted by (lo, hi): each vertex receives its lower
         * neighbours first, ascending, then its higher ones, ascending. */
        for (int64_t e = 0; e < nuniq; e++) {
            int32_t lo = (int32_t)(ed[e].key / nv), hi = (int32_t)(ed[e].key % nv);
            m->spoke_j[fill[lo]] = hi;
            m->spoke_w[fill[lo]++] = ed[e].w;
            m->spoke_j[fill[hi]] = lo;
            m->spoke_w[fill[hi]++] = ed[e].w;
        }
        free(fill);
    }
    m->cp = 0.0;
    for (int32_t i = 0; i < nv; i++)
        for (int64_t s = m->spoke_start[i]; s < m->spoke_start[i + 1]; s++) {
            double d[3], w = m->spoke_w[s];
            sub3(m->P + 3 * i, m->P + 3 * m->spoke_j[s], d);
            for (int k = 0; k < 3; k++) {
                m->spoke_we[3 * s + k] = w * d[k];
                m->vertex_we[3 * i + k] += w * d[k];
            }
            m->cp += w * dot3(d, d);
        }

    free(ed);
    free(area);
    free(vsum);
    *out = m;
    return DTX_OK;

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "skinning mesh: out of memory (%d vertices, %d triangles)",
                    (int)nv, (int)nf);
fail:
    free(ed);
    free(area);
    free(vsum);
    dtx_skin_mesh_free(&m);
    return st;
}

/* ================================================================== */
/* The precomputed fit                                                 */
/* ================================================================== */

struct dtx_skin_fit {
    const dtx_skin_mesh *mesh;
    int32_t m, n4, ncl;
    double lambda;
    double *W;       /* nv x m */
    int32_t *labels; /* nv */
    double *G;       /* n4 x n4, M^T M */
    double *L;       /* n4 x n4, lower Cholesky factor of lambda K + G */
    double *Pg;      /* ncl x 3 x n4 */
};

void dtx_skin_fit_free(dtx_skin_fit **fit)
{
    if (!fit || !*fit)
        return;
    free((*fit)->W);
    free((*fit)->labels);
    free((*fit)->G);
    free((*fit)->L);
    free((*fit)->Pg);
    free(*fit);
    *fit = NULL;
}

/* Dot product in a fixed order with four partial sums (for speed without
 * reassociation by the compiler). */
static double dot_n(const double *a, const double *b, int32_t n)
{
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int32_t i = 0;
    for (; i + 4 <= n; i += 4) {
        s0 += a[i] * b[i];
        s1 += a[i + 1] * b[i + 1];
        s2 += a[i + 2] * b[i + 2];
        s3 += a[i + 3] * b[i + 3];
    }
    for (; i < n; i++)
        s0 += a[i] * b[i];
    return (s0 + s1) + (s2 + s3);
}

/* In-place Cholesky A = L L^T of the n x n row-major A (lower triangle
 * used and overwritten; the upper triangle is zeroed).  Returns -1 on
 * success, else the failing pivot index. */
static int32_t cholesky(double *A, int32_t n)
{
    for (int32_t j = 0; j < n; j++) {
        double d = A[(size_t)j * n + j], orig = d;
        for (int32_t k = 0; k < j; k++)
            d -= A[(size_t)j * n + k] * A[(size_t)j * n + k];
        if (!(d > SKIN_PIVOT_RATIO * orig) || !(orig > 0.0))
            return j;
        d = sqrt(d);
        A[(size_t)j * n + j] = d;
        for (int32_t i = j + 1; i < n; i++) {
            double s = A[(size_t)i * n + j];
            for (int32_t k = 0; k < j; k++)
                s -= A[(size_t)i * n + k] * A[(size_t)j * n + k];
            A[(size_t)i * n + j] = s / d;
        }
        for (int32_t k = j + 1; k < n; k++)
            A[(size_t)j * n + k] = 0.0;
    }
    return -1;
}

/* Solves L L^T X = B for the n x 3 row-major B, in place. */
static void chol_solve3(const double *L, int32_t n, double *B)
{
    for (int32_t i = 0; i < n; i++) {
        const double *l = L + (size_t)i * n;
        double s0 = B[3 * i], s1 = B[3 * i + 1], s2 = B[3 * i + 2];
        for (int32_t k = 0; k < i; k++) {
            s0 -= l[k] * B[3 * k];
            s1 -= l[k] * B[3 * k + 1];
            s2 -= l[k] * B[3 * k + 2];
        }
        B[3 * i] = s0 / l[i];
        B[3 * i + 1] = s1 / l[i];
        B[3 * i + 2] = s2 / l[i];
    }
    for (int32_t i = n - 1; i >= 0; i--) {
        double s0 = B[3 * i], s1 = B[3 * i + 1], s2 = B[3 * i + 2], d = L[(size_t)i * n + i];
        for (int32_t k = i + 1; k < n; k++) {
            double l = L[(size_t)k * n + i];
            s0 -= l * B[3 * k];
            s1 -= l * B[3 * k + 1];
            s2 -= l * B[3 * k + 2];
        }
        B[3 * i] = s0 / d;
        B[3 * i + 1] = s1 / d;
        B[3 * i + 2] = s2 / d;
    }
}

/* |L^T X|_F^2 for the n x 3 X: the quadratic form tr X^T A X, never
 * negative. */
static double chol_form3(const double *L, int32_t n, const double *X)
{
    double s = 0.0;
    for (int32_t i = 0; i < n; i++) {
        double y0 = 0.0, y1 = 0.0, y2 = 0.0;
        for (int32_t k = i; k < n; k++) {
            double l = L[(size_t)k * n + i];
            y0 += l * X[3 * k];
            y1 += l * X[3 * k + 1];
            y2 += l * X[3 * k + 2];
        }
        s += y0 * y0 + y1 * y1 + y2 * y2;
    }
    return s;
}

/* The checks every fit makes of its per-vertex input, vertex by vertex:
 * each row of W (nv x m; NULL: not checked) finite and summing to 1, each
 * label (NULL: not checked) in [0, ncl).  what names the caller in the
 * message. */
static dtx_status check_rows(const char *what, int32_t nv, const double *W, int32_t m,
                             const int32_t *labels, int32_t ncl, dtx_error *err)
{
    for (int32_t i = 0; i < nv; i++) {
        double s = 0.0;
        for (int32_t k = 0; W && k < m; k++) {
            double w = W[(size_t)i * m + k];
            if (!isfinite(w))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: weight of vertex %d, handle %d is not finite", what,
                                  (int)i, (int)k);
            s += w;
        }
        if (W && fabs(s - 1.0) > SKIN_UNITY_TOL)
            return dtx_seterr(err, DTX_EINVAL,
                              "%s: the weights of vertex %d sum to %.17g, not 1 "
                              "(they must be a partition of unity)",
                              what, (int)i, s);
        if (labels && (labels[i] < 0 || labels[i] >= ncl))
            return dtx_seterr(err, DTX_ERANGE, "%s: vertex %d has cluster label %d (clusters: %d)",
                              what, (int)i, (int)labels[i], (int)ncl);
    }
    return DTX_OK;
}

dtx_status dtx_skin_fit_create(const dtx_skin_mesh *mesh, int32_t m, const double *W,
                               const int32_t *labels, int32_t nclusters, const dtx_skin_params *p,
                               dtx_skin_fit **out, dtx_error *err)
{
    dtx_skin_fit *fit = NULL;
    double *Mt = NULL, *LMt = NULL;
    int32_t nv, n4;
    int nt;
    dtx_status st = DTX_OK;

    if (!out)
        return dtx_seterr(err, DTX_EINVAL, "skinning fit: no output pointer");
    *out = NULL;
    if (!mesh || !W || !labels || !p || m < 1 || nclusters < 1)
        return dtx_seterr(err, DTX_EINVAL, "skinning fit: bad arguments (%d handles, %d clusters)",
                          (int)m, (int)nclusters);
    if (!(p->lambda >= 0.0) || !isfinite(p->lambda))
        return dtx_seterr(err, DTX_EINVAL, "skinning fit: lambda must be >= 0 (got %g)", p->lambda);
    nv = mesh->nv;
    n4 = 4 * m;
    if (m > (INT32_MAX / 4) || (double)n4 * n4 > 1e9)
        return dtx_seterr(err, DTX_EINVAL, "skinning fit: too many handles (%d)", (int)m);

    /* ---- validate the weights and labels */
    if ((st = check_rows("skinning fit", nv, W, m, labels, nclusters, err)) != DTX_OK)
        return st;

    fit = calloc(1, sizeof *fit);
    if (!fit)
        return dtx_seterr(err, DTX_ENOMEM, "skinning fit: out of memory");
    fit->mesh = mesh;
    fit->m = m;
    fit->n4 = n4;
    fit->ncl = nclusters;
    fit->lambda = p->lambda;
    fit->W = dtx_alloc((size_t)nv * m, sizeof(double), 0);
    fit->labels = dtx_alloc((size_t)nv, sizeof(int32_t), 0);
    fit->G = dtx_alloc((size_t)n4 * n4, sizeof(double), 0);
    fit->L = dtx_alloc((size_t)n4 * n4, sizeof(double), 0);
    fit->Pg = dtx_alloc((size_t)nclusters * 3 * n4, sizeof(double), 1);
    Mt = dtx_alloc((size_t)n4 * nv, sizeof(double), 0);
    LMt = dtx_alloc((size_t)n4 * nv, sizeof(double), 0);
    if (!fit->W || !fit->labels || !fit->G || !fit->L || !fit->Pg || !Mt || !LMt) {
        st = dtx_seterr(err, DTX_ENOMEM,
                        "skinning fit: out of memory (%d vertices, %d handles, %d clusters)",
                        (int)nv, (int)m, (int)nclusters);
        goto fail;
    }
    memcpy(fit->W, W, sizeof(double) * (size_t)nv * m);
    memcpy(fit->labels, labels, sizeof(int32_t) * (size_t)nv);
    nt = dtx_skin_threads_(p->threads);

    /* ---- M^T (4m x nv) and (L M)^T, L the spoke Laplacian:
     * (L M)_i = sum_j w_ij (M_i - M_j).  K = sum_spokes w d^T d = 2 M^T L M
     * since every edge is two spokes. */
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int32_t r = 0; r < n4; r++) {
        int32_t k = r / 4, a = r % 4;
        double *mt = Mt + (size_t)r * nv;
        for (int32_t i = 0; i < nv; i++)
            mt[i] = W[(size_t)i * m + k] * (a < 3 ? mesh->P[3 * i + a] : 1.0);
    }
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int32_t r = 0; r < n4; r++) {
        const double *mt = Mt + (size_t)r * nv;
        double *lmt = LMt + (size_t)r * nv;
        for (int32_t i = 0; i < nv; i++) {
            double s = 0.0;
            for (int64_t e = mesh->spoke_start[i]; e < mesh->spoke_start[i + 1]; e++)
                s += mesh->spoke_w[e] * (mt[i] - mt[mesh->spoke_j[e]]);
            lmt[i] = s;
        }
    }

    /* ---- G = M^T M and A = lambda K + G, upper triangles then mirrored */
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
    for (int32_t r = 0; r < n4; r++)
        for (int32_t c = r; c < n4; c++) {
            double g = dot_n(Mt + (size_t)r * nv, Mt + (size_t)c * nv, nv);
            double kk = 2.0 * dot_n(Mt + (size_t)r * nv, LMt + (size_t)c * nv, nv);
            fit->G[(size_t)r * n4 + c] = fit->G[(size_t)c * n4 + r] = g;
            fit->L[(size_t)r * n4 + c] = fit->L[(size_t)c * n4 + r] = p->lambda * kk + g;
        }

        /* ---- P_g[:, r] = sum_{i in g} (a_i Mt[r][i] - sum_j w_ij e_ij Mt[r][j]),
         * a_i = sum_j w_ij e_ij: column r of every P_g by one thread */
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int32_t r = 0; r < n4; r++) {
        const double *mt = Mt + (size_t)r * nv;
        for (int32_t i = 0; i < nv; i++) {
            double *pg = fit->Pg + (size_t)labels[i] * 3 * n4 + r;
            double s0 = mesh->vertex_we[3 * i] * mt[i], s1 = mesh->vertex_we[3 * i + 1] * mt[i],
                   s2 = mesh->vertex_we[3 * i + 2] * mt[i];
            for (int64_t e = mesh->spoke_start[i]; e < mesh->spoke_start[i + 1]; e++) {
                double x = mt[mesh->spoke_j[e]];
                s0 -= mesh->spoke_we[3 * e] * x;
                s1 -= mesh->spoke_we[3 * e + 1] * x;
                s2 -= mesh->spoke_we[3 * e + 2] * x;
            }
            pg[0] += s0;
            pg[n4] += s1;
            pg[2 * (size_t)n4] += s2;
        }
    }

    {
        int32_t bad = cholesky(fit->L, n4);
        if (bad >= 0) {
            st = dtx_seterr(err, DTX_ESOLVE,
                            "skinning fit: the normal matrix is not positive definite at "
                            "handle %d (coordinate %d): the weights times [p 1] are linearly "
                            "dependent (equal or proportional weight columns?)",
                            (int)(bad / 4), (int)(bad % 4));
            goto fail;
        }
    }
    free(Mt);
    free(LMt);
    *out = fit;
    return DTX_OK;

fail:
    free(Mt);
    free(LMt);
    dtx_skin_fit_free(&fit);
    return st;
}

/* ================================================================== */
/* Per-frame fit                                                       */
/* ================================================================== */

/* Per-thread scratch for one frame. */
typedef struct {
    double *q;  /* nv x 3: the frame, centred and scaled */
    double *h;  /* n4 x 3: M^T q */
    double *T;  /* n4 x 3 */
    double *Tn; /* n4 x 3 */
    double *b;  /* n4 x 3 */
    double *C;  /* ncl x 9: covariances */
    double *R;  /* ncl x 9 */
    double *Rn; /* ncl x 9 */
} frame_ws;

/* The next n doubles of a pool cut into a frame_ws's arrays. */
static double *carve(double **pool, size_t n)
{
    double *p = *pool;
    *pool += n;
    return p;
}

/* Cluster rotations maximising tr(R_g C_g): the rotation nearest C_g^T. */
static void best_rotations(const double *C, int32_t ncl, double *R)
{
    for (int32_t g = 0; g < ncl; g++) {
        const double *c = C + 9 * g;
        double Ct[9] = {c[0], c[3], c[6], c[1], c[4], c[7], c[2], c[5], c[8]};
        dtx_polar3(Ct, R + 9 * g, NULL);
    }
}

/* tr(R C) for 3x3 R, C. */
static double trace_rc(const double *R, const double *C)
{
    double s = 0.0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            s += R[3 * a + b] * C[3 * b + a];
    return s;
}

/* b = h + lambda sum_g P_g^T R_g^T: b[r][c] += lambda sum_a P_g[a][r] R_g[c][a]. */
static void arap_rhs(const dtx_skin_fit *fit, const double *h, const double *R, double *b)
{
    int32_t n4 = fit->n4;
    memcpy(b, h, sizeof(double) * 3 * (size_t)n4);
    for (int32_t g = 0; g < fit->ncl; g++) {
        const double *P = fit->Pg + (size_t)g * 3 * n4, *Rg = R + 9 * g;
        double lr[9];
        for (int k = 0; k < 9; k++)
            lr[k] = fit->lambda * Rg[k];
        for (int32_t r = 0; r < n4; r++) {
            double p0 = P[r], p1 = P[n4 + r], p2 = P[2 * n4 + r];
            for (int c = 0; c < 3; c++)
                b[3 * r + c] += p0 * lr[3 * c] + p1 * lr[3 * c + 1] + p2 * lr[3 * c + 2];
        }
    }
}

/* C_g = P_g T (3 x 3) for every cluster. */
static void covariances(const dtx_skin_fit *fit, const double *T, double *C)
{
    int32_t n4 = fit->n4;
    for (int32_t g = 0; g < fit->ncl; g++) {
        const double *P = fit->Pg + (size_t)g * 3 * n4;
        double *c = C + 9 * g;
        for (int a = 0; a < 3; a++) {
            const double *pa = P + (size_t)a * n4;
            double s0 = 0.0, s1 = 0.0, s2 = 0.0;
            for (int32_t r = 0; r < n4; r++) {
                s0 += pa[r] * T[3 * r];
                s1 += pa[r] * T[3 * r + 1];
                s2 += pa[r] * T[3 * r + 2];
            }
            c[3 * a] = s0;
            c[3 * a + 1] = s1;
            c[3 * a + 2] = s2;
        }
    }
}

/* The frame X (nv x 3) centred on its centroid cf and scaled like the
 * rest, into q (nv x 3); returns |q|^2. */
static double centre_frame(const dtx_skin_mesh *mesh, const double *X, double *q, double cf[3])
{
    int32_t nv = mesh->nv;
    double qq = 0.0;
    cf[0] = cf[1] = cf[2] = 0.0;
    for (int32_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++)
            cf[k] += X[3 * i + k];
    for (int k = 0; k < 3; k++)
        cf[k] /= nv;
    for (int32_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
            double v = (X[3 * i + k] - cf[k]) / mesh->scale;
            q[3 * i + k] = v;
            qq += v * v;
        }
    return qq;
}

/* The starting rotations R (ncl x 9): each cluster's best rotation to the
 * centred frame q itself; C (ncl x 9) is scratch. */
static void start_rotations(const dtx_skin_mesh *mesh, const int32_t *labels, int32_t ncl,
                            const double *q, double *C, double *R)
{
    memset(C, 0, sizeof(double) * 9 * (size_t)ncl);
    for (int32_t i = 0; i < mesh->nv; i++) {
        double *c = C + 9 * (size_t)labels[i];
        const double *qi = q + 3 * i;
        for (int64_t e = mesh->spoke_start[i]; e < mesh->spoke_start[i + 1]; e++) {
            const double *we = mesh->spoke_we + 3 * e, *qj = q + 3 * mesh->spoke_j[e];
            double dq[3] = {qi[0] - qj[0], qi[1] - qj[1], qi[2] - qj[2]};
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    c[3 * a + b] += we[a] * dq[b];
        }
    }
    best_rotations(C, ncl, R);
}

/* The local/global iterations of one frame from h = M^T q (in ws->h) and
 * |q|^2 = qq, starting from the rotations R0 (ncl x 9, copied): the
 * transforms end in ws->T and the rotations in ws->R; returns E (normalised
 * units) and the pairs done in *iters.  trace as in dtx_skin_out (may be
 * NULL). */
static double iterate_frame(const dtx_skin_fit *fit, double qq, const double *R0, int max_iters,
                            double tol, frame_ws *ws, int *iters, double *trace)
{
    const dtx_skin_mesh *mesh = fit->mesh;
    int32_t n4 = fit->n4, ncl = fit->ncl;
    double E, floor_, s2 = mesh->scale * mesh->scale;
    double lam = fit->lambda;
    int it = 0, nt = 0;

    memcpy(ws->R, R0, sizeof(double) * 9 * (size_t)ncl);

    /* ---- first global step and the energy in full */
    arap_rhs(fit, ws->h, ws->R, ws->b);
    memcpy(ws->T, ws->b, sizeof(double) * 3 * (size_t)n4);
    chol_solve3(fit->L, n4, ws->T);
    E = lam * mesh->cp + qq + chol_form3(fit->L, n4, ws->T) - 2.0 * dot_n(ws->T, ws->b, 3 * n4);
    floor_ = 16.0 * DBL_EPSILON * (lam * mesh->cp + qq);
    if (trace)
        trace[nt++] = E * s2;

    /* ---- local/global pairs */
    for (it = 0; it < max_iters;) {
        double dl = 0.0, dg;
        covariances(fit, ws->T, ws->C);
        best_rotations(ws->C, ncl, ws->Rn);
        for (int32_t g = 0; g < ncl; g++)
            dl += trace_rc(ws->Rn + 9 * g, ws->C + 9 * g) - trace_rc(ws->R + 9 * g, ws->C + 9 * g);
        E -= 2.0 * lam * dl;
        if (trace)
            trace[nt++] = E * s2;
        arap_rhs(fit, ws->h, ws->Rn, ws->b);
        memcpy(ws->Tn, ws->b, sizeof(double) * 3 * (size_t)n4);
        chol_solve3(fit->L, n4, ws->Tn);
        for (int32_t r = 0; r < 3 * n4; r++)
            ws->T[r] = ws->Tn[r] - ws->T[r]; /* the step, for its decrease */
        dg = chol_form3(fit->L, n4, ws->T);
        E -= dg;
        if (trace)
            trace[nt++] = E * s2;
        {
            double *t = ws->T;
            ws->T = ws->Tn;
            ws->Tn = t;
            t = ws->R;
            ws->R = ws->Rn;
            ws->Rn = t;
        }
        it++;
        if (2.0 * lam * dl + dg <= tol * fabs(E) + floor_)
            break;
    }
    if (trace)
        for (int k = nt; k < 2 * max_iters + 1; k++)
            trace[k] = NAN;
    *iters = it;
    return E;
}

static void fit_one_frame(const dtx_skin_fit *fit, const double *X, int max_iters, double tol,
                          frame_ws *ws, double *Tout, double *energy,
                          double *diff, int32_t *iters, double *Rout, double *trace)
{
    const dtx_skin_mesh *mesh = fit->mesh;
    int32_t nv = mesh->nv, m = fit->m, n4 = fit->n4, ncl = fit->ncl;
    double cf[3], qq, E, s2 = mesh->scale * mesh->scale;
    int it = 0;

    /* ---- the frame, centred on its centroid and scaled like the rest */
    qq = centre_frame(mesh, X, ws->q, cf);

    /* ---- h = M^T q: block k (4 x 3) += W_ik [p_i; 1] q_i^T */
    memset(ws->h, 0, sizeof(double) * 3 * (size_t)n4);
    for (int32_t i = 0; i < nv; i++) {
        const double *pp = mesh->P + 3 * i, *qi = ws->q + 3 * i, *wi = fit->W + (size_t)i * m;
        double z[12];
        for (int a = 0; a < 4; a++) {
            double pa = a < 3 ? pp[a] : 1.0;
            for (int c = 0; c < 3; c++)
                z[3 * a + c] = pa * qi[c];
        }
        for (int32_t k = 0; k < m; k++) {
            double w = wi[k], *hk = ws->h + 12 * (size_t)k;
            for (int j = 0; j < 12; j++)
                hk[j] += w * z[j];
        }
    }

    /* ---- starting rotations: the clusters' best fit to the frame itself,
     * then the iterations */
    start_rotations(mesh, fit->labels, ncl, ws->q, ws->C, ws->Rn);
    E = iterate_frame(fit, qq, ws->Rn, max_iters, tol, ws, &it, trace);

    /* ---- outputs, back in the caller's coordinates */
    if (diff) {
        /* E_diff = tr T^T G T - 2 tr T^T h + |q|^2 */
        double tgt = 0.0;
        for (int32_t r = 0; r < n4; r++) {
            const double *g = fit->G + (size_t)r * n4;
            double y0 = 0.0, y1 = 0.0, y2 = 0.0;
            for (int32_t c = 0; c < n4; c++) {
                y0 += g[c] * ws->T[3 * c];
                y1 += g[c] * ws->T[3 * c + 1];
                y2 += g[c] * ws->T[3 * c + 2];
            }
            tgt += y0 * ws->T[3 * r] + y1 * ws->T[3 * r + 1] + y2 * ws->T[3 * r + 2];
        }
        *diff = fmax(0.0, tgt - 2.0 * dot_n(ws->T, ws->h, 3 * n4) + qq) * s2;
    }
    if (energy)
        *energy = E * s2;
    if (iters)
        *iters = it;
    if (Rout)
        memcpy(Rout, ws->R, sizeof(double) * 9 * (size_t)ncl);
    for (int32_t k = 0; k < m; k++) {
        /* q = s (A (p - c)/s + t) + cf = A p + (s t + cf - A c) */
        const double *tk = ws->T + 12 * (size_t)k;
        double *o = Tout + 12 * (size_t)k;
        for (int c = 0; c < 3; c++) {
            double a0 = tk[c], a1 = tk[3 + c], a2 = tk[6 + c], t = tk[9 + c];
            o[4 * c] = a0;
            o[4 * c + 1] = a1;
            o[4 * c + 2] = a2;
            o[4 * c + 3] = mesh->scale * t + cf[c] -
                           (a0 * mesh->center[0] + a1 * mesh->center[1] + a2 * mesh->center[2]);
        }
    }
}

dtx_status dtx_skin_fit_frames(const dtx_skin_fit *fit, int32_t nframes, const double *X,
                               const dtx_skin_params *p, dtx_skin_out *out, dtx_error *err)
{
    frame_ws *ws = NULL;
    double *pool = NULL;
    int32_t nv, n4, ncl;
    int nt, max_iters;
    size_t per;
    dtx_status st = DTX_OK;

    if (!fit || !p || !out || !out->T || nframes < 0 || (nframes > 0 && !X))
        return dtx_seterr(err, DTX_EINVAL, "skinning fit: bad arguments");
    if (p->max_iters < 0 || !(p->tol >= 0.0))
        return dtx_seterr(err, DTX_EINVAL,
                          "skinning fit: max_iters must be >= 0 and tol >= 0 (got %d, %g)",
                          p->max_iters, p->tol);
    nv = fit->mesh->nv;
    n4 = fit->n4;
    ncl = fit->ncl;
    max_iters = p->max_iters;
    for (int64_t i = 0; i < (int64_t)nframes * nv * 3; i++)
        if (!isfinite(X[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "skinning fit: frame %lld, vertex %lld has a non-finite coordinate",
                              (long long)(i / (3 * (int64_t)nv)), (long long)(i / 3 % nv));
    if (nframes == 0)
        return DTX_OK;

    nt = dtx_skin_threads_(p->threads);
    if (nt > nframes)
        nt = nframes;
    per = (size_t)nv * 3 + 4 * (size_t)n4 * 3 + 3 * (size_t)ncl * 9;
    ws = calloc((size_t)nt, sizeof *ws);
    pool = dtx_alloc((size_t)nt, per * sizeof(double), 0);
    if (!ws || !pool) {
        st = dtx_seterr(err, DTX_ENOMEM, "skinning fit: out of memory for %d workspaces", nt);
        goto done;
    }
    for (int t = 0; t < nt; t++) {
        double *b = pool + (size_t)t * per;
        ws[t].q = carve(&b, (size_t)nv * 3);
        ws[t].h = carve(&b, (size_t)n4 * 3);
        ws[t].T = carve(&b, (size_t)n4 * 3);
        ws[t].Tn = carve(&b, (size_t)n4 * 3);
        ws[t].b = carve(&b, (size_t)n4 * 3);
        ws[t].C = carve(&b, (size_t)ncl * 9);
        ws[t].R = carve(&b, (size_t)ncl * 9);
        ws[t].Rn = carve(&b, (size_t)ncl * 9);
    }

#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
    for (int32_t f = 0; f < nframes; f++) {
        frame_ws *w = ws + omp_get_thread_num();
        fit_one_frame(fit, X + (size_t)f * nv * 3, max_iters, p->tol, w,
                      out->T + (size_t)f * fit->m * 12, out->energy ? out->energy + f : NULL,
                      out->diff ? out->diff + f : NULL, out->iters ? out->iters + f : NULL,
                      out->R ? out->R + (size_t)f * ncl * 9 : NULL,
                      out->trace ? out->trace + (size_t)f * (2 * (size_t)max_iters + 1) : NULL);
    }

done:
    free(ws);
    free(pool);
    return st;
}

/* ================================================================== */
/* Direct evaluation and the skinning itself                           */
/* ================================================================== */

static void skin_vertex(const double *p, const double *w, int32_t m, const double *T, double *q)
{
    double d[3] = {0, 0, 0};
    for (int32_t k = 0; k < m; k++) {
        const double *t = T + 12 * (size_t)k;
        double wk = w[k];
        if (wk == 0.0)
            continue;
        for (int r = 0; r < 3; r++)
            d[r] += wk * ((t[4 * r] - (r == 0)) * p[0] + (t[4 * r + 1] - (r == 1)) * p[1] +
                          (t[4 * r + 2] - (r == 2)) * p[2] + t[4 * r + 3]);
    }
    for (int r = 0; r < 3; r++)
        q[r] = p[r] + d[r];
}

void dtx_skin_apply(int32_t nv, int32_t m, const double *V, const double *W, int32_t nframes,
                    const double *T, int threads, double *Q)
{
    int nt = dtx_skin_threads_(threads);
#pragma omp parallel for schedule(static) num_threads(nt) if (nframes > 1)
    for (int32_t f = 0; f < nframes; f++)
        for (int32_t i = 0; i < nv; i++)
            skin_vertex(V + 3 * (size_t)i, W + (size_t)i * m, m, T + (size_t)f * m * 12,
                        Q + ((size_t)f * nv + i) * 3);
}

dtx_status dtx_skin_energy(const dtx_skin_fit *fit, const double *X, const double *T,
                           const double *R, double *energy, double *diff, dtx_error *err)
{
    const dtx_skin_mesh *mesh;
    double *q, ea = 0.0, ed = 0.0;
    if (!fit || !X || !T || !R)
        return dtx_seterr(err, DTX_EINVAL, "skinning energy: bad arguments");
    mesh = fit->mesh;
    q = dtx_alloc((size_t)mesh->nv * 3, sizeof *q, 0);
    if (!q)
        return dtx_seterr(err, DTX_ENOMEM, "skinning energy: out of memory");
    dtx_skin_apply(mesh->nv, fit->m, mesh->V, fit->W, 1, T, 1, q);
    for (int32_t i = 0; i < mesh->nv; i++) {
        const double *Rg = R + 9 * (size_t)fit->labels[i];
        double d[3];
        sub3(q + 3 * i, X + 3 * i, d);
        ed += dot3(d, d);
        for (int64_t e = mesh->spoke_start[i]; e < mesh->spoke_start[i + 1]; e++) {
            int32_t j = mesh->spoke_j[e];
            double dp[3], dq[3], r[3];
            sub3(mesh->V + 3 * i, mesh->V + 3 * j, dp);
            sub3(q + 3 * i, q + 3 * j, dq);
            for (int a = 0; a < 3; a++)
                r[a] = dq[a] - (Rg[3 * a] * dp[0] + Rg[3 * a + 1] * dp[1] + Rg[3 * a + 2] * dp[2]);
            ea += mesh->spoke_w[e] * dot3(r, r);
        }
    }
    free(q);
    if (energy)
        *energy = fit->lambda * ea + ed;
    if (diff)
        *diff = ed;
    return DTX_OK;
}

/* ================================================================== */
/* Fit errors of many weight sets (the key-point selection's rounds)   */
/* ================================================================== */

/* BLAS (Fortran interface): C = alpha op(A) op(B) + beta C, column-major. */
extern void dgemm_(const char *transa, const char *transb, const int *m, const int *n,
                   const int *k, const double *alpha, const double *a, const int *lda,
                   const double *b, const int *ldb, const double *beta, double *c,
                   const int *ldc);

struct dtx_skin_eval {
    const dtx_skin_mesh *mesh;
    int32_t nframes, ncl;
    double lambda, tol;
    int max_iters;
    double *Qh; /* nv x 3 nframes: frame f centred and scaled, at [i][3 f + c] */
    double *qq; /* nframes: |q|^2 of each centred, scaled frame */
    double *R0; /* nframes x ncl x 9: the starting rotations */
    /* P_g[a][r] = sum_j D_g[a][j] M^T[r][j], D stored by vertex j:
     * entries dstart[j] .. dstart[j + 1] - 1, cluster dg[e], coefficients
     * dw[3 e .. 3 e + 2]. */
    int64_t *dstart; /* nv + 1 */
    int32_t *dg;
    double *dw;
};

struct dtx_skin_eval_work {
    int32_t mmax, nclmax, nframes;
    double *M;   /* nv x 4 m (row-major, m the call's handles): M[i][4 k + a] */
    double *B;   /* nv x 4 m: M + 2 lambda L M */
    double *Qf;  /* nv x 3 nframes: the skinned frames */
    double *Hc;  /* 3 nframes x 4 mmax, column-major: M^T q of every frame */
    double *Tc;  /* 3 nframes x 4 mmax, column-major: the fitted transforms */
    double *A;   /* (4 mmax)^2 */
    double *Pg;  /* nclmax x 3 x 4 mmax */
    double *pool;
    frame_ws fw;
};

void dtx_skin_eval_free(dtx_skin_eval **ev)
{
    if (!ev || !*ev)
        return;
    free((*ev)->Qh);
    free((*ev)->qq);
    free((*ev)->R0);
    free((*ev)->dstart);
    free((*ev)->dg);
    free((*ev)->dw);
    free(*ev);
    *ev = NULL;
}

dtx_status dtx_skin_eval_create(const dtx_skin_mesh *mesh, const int32_t *labels,
                                int32_t nclusters, int32_t nframes, const double *X,
                                const dtx_skin_params *p, dtx_skin_eval **out, dtx_error *err)
{
    dtx_skin_eval *ev;
    double *q = NULL, *C = NULL, cf[3];
    int32_t nv, *cnt = NULL;
    size_t w3;
    dtx_status st = DTX_OK;

    if (!out)
        return dtx_seterr(err, DTX_EINVAL, "skinning errors: no output pointer");
    *out = NULL;
    if (!mesh || !labels || !p || nclusters < 1 || nframes < 1 || !X)
        return dtx_seterr(err, DTX_EINVAL, "skinning errors: bad arguments");
    if (!(p->lambda >= 0.0) || !isfinite(p->lambda) || p->max_iters < 0 || !(p->tol >= 0.0))
        return dtx_seterr(err, DTX_EINVAL,
                          "skinning errors: lambda >= 0, max_iters >= 0 and tol >= 0 needed "
                          "(got %g, %d, %g)",
                          p->lambda, p->max_iters, p->tol);
    nv = mesh->nv;
    if ((st = check_rows("skinning errors", nv, NULL, 0, labels, nclusters, err)) != DTX_OK)
        return st;
    for (int64_t i = 0; i < (int64_t)nframes * nv * 3; i++)
        if (!isfinite(X[i]))
            return dtx_seterr(err, DTX_ENONFINITE,
                              "skinning errors: frame %lld, vertex %lld has a non-finite "
                              "coordinate",
                              (long long)(i / (3 * (int64_t)nv)), (long long)(i / 3 % nv));
    ev = calloc(1, sizeof *ev);
    if (!ev)
        return dtx_seterr(err, DTX_ENOMEM, "skinning errors: out of memory");
    ev->mesh = mesh;
    ev->nframes = nframes;
    ev->ncl = nclusters;
    ev->lambda = p->lambda;
    ev->tol = p->tol;
    ev->max_iters = p->max_iters;
    w3 = 3 * (size_t)nframes;
    ev->Qh = dtx_alloc((size_t)nv, w3 * sizeof *ev->Qh, 0);
    ev->qq = dtx_alloc((size_t)nframes, sizeof *ev->qq, 0);
    ev->R0 = dtx_alloc((size_t)nframes * (size_t)nclusters, 9 * sizeof *ev->R0, 0);
    ev->dstart = dtx_alloc((size_t)nv + 1, sizeof *ev->dstart, 0);
    ev->dg = dtx_alloc((size_t)(nv + mesh->nspokes), sizeof *ev->dg, 0);
    ev->dw = dtx_alloc((size_t)(nv + mesh->nspokes), 3 * sizeof *ev->dw, 0);
    q = dtx_alloc((size_t)nv, 3 * sizeof *q, 0);
    C = dtx_alloc((size_t)nclusters, 9 * sizeof *C, 0);
    cnt = dtx_alloc((size_t)nv, sizeof *cnt, 1);
    if (!ev->Qh || !ev->qq || !ev->R0 || !ev->dstart || !ev->dg || !ev->dw || !q || !C || !cnt) {
        st = dtx_seterr(err, DTX_ENOMEM, "skinning errors: out of memory (%d vertices, %d frames)",
                        (int)nv, (int)nframes);
        goto done;
    }

    /* ---- the frames, centred and scaled, and their starting rotations, as
     * dtx_skin_fit_frames computes them */
    for (int32_t f = 0; f < nframes; f++) {
        ev->qq[f] = centre_frame(mesh, X + (size_t)f * nv * 3, q, cf);
        start_rotations(mesh, labels, nclusters, q, C, ev->R0 + (size_t)f * nclusters * 9);
        for (int32_t i = 0; i < nv; i++)
            for (int c = 0; c < 3; c++)
                ev->Qh[(size_t)i * w3 + 3 * (size_t)f + c] = q[3 * i + c];
    }

    /* ---- D by vertex j: vertex i of cluster g puts vertex_we[i] on j = i
     * and -spoke_we[e] on j = spoke_j[e] for each of its spokes e; entries
     * of one (j, g) are merged, in the order the spokes come. */
    for (int32_t i = 0; i < nv; i++) {
        cnt[i]++;
        for (int64_t e = mesh->spoke_start[i]; e < mesh->spoke_start[i + 1]; e++)
            cnt[mesh->spoke_j[e]]++;
    }
    ev->dstart[0] = 0;
    for (int32_t j = 0; j < nv; j++)
        ev->dstart[j + 1] = ev->dstart[j] + cnt[j];
    for (int32_t j = 0; j < nv; j++)
        cnt[j] = 0; /* entries of j so far */
    for (int32_t i = 0; i < nv; i++) {
        for (int64_t e = mesh->spoke_start[i] - 1; e < mesh->spoke_start[i + 1]; e++) {
            int own = e < mesh->spoke_start[i];
            int32_t j = own ? i : mesh->spoke_j[e];
            const double *d = own ? mesh->vertex_we + 3 * (size_t)i : mesh->spoke_we + 3 * e;
            double s = own ? 1.0 : -1.0;
            int64_t b = ev->dstart[j], x = b;
            while (x < b + cnt[j] && ev->dg[x] != labels[i])
                x++;
            if (x == b + cnt[j]) {
                ev->dg[x] = labels[i];
                ev->dw[3 * x] = ev->dw[3 * x + 1] = ev->dw[3 * x + 2] = 0.0;
                cnt[j]++;
            }
            for (int a = 0; a < 3; a++)
                ev->dw[3 * x + a] += s * d[a];
        }
    }
    /* Compact: entries of j are dstart[j] .. dstart[j] + cnt[j] - 1. */
    {
        int64_t o = 0;
        for (int32_t j = 0; j < nv; j++) {
            int64_t b = ev->dstart[j];
            ev->dstart[j] = o;
            for (int32_t t = 0; t < cnt[j]; t++, o++) {
                ev->dg[o] = ev->dg[b + t];
                for (int a = 0; a < 3; a++)
                    ev->dw[3 * o + a] = ev->dw[3 * (b + t) + a];
            }
        }
        ev->dstart[nv] = o;
    }

done:
    free(q);
    free(C);
    free(cnt);
    if (st != DTX_OK)
        dtx_skin_eval_free(&ev);
    *out = ev;
    return st;
}

void dtx_skin_eval_work_free(dtx_skin_eval_work **work)
{
    dtx_skin_eval_work *w;
    if (!work || !*work)
        return;
    w = *work;
    free(w->M);
    free(w->B);
    free(w->Qf);
    free(w->Hc);
    free(w->Tc);
    free(w->A);
    free(w->Pg);
    free(w->pool);
    free(w);
    *work = NULL;
}

dtx_skin_eval_work *dtx_skin_eval_work_new(const dtx_skin_mesh *mesh, int32_t nframes,
                                           int32_t mmax, int32_t nclmax)
{
    dtx_skin_eval_work *w;
    size_t nv, n4, w3;
    double *b;
    if (!mesh || nframes < 1 || mmax < 1 || nclmax < 1 || mmax > (INT32_MAX / 4) ||
        (double)mmax * 4 * mesh->nv > (double)INT32_MAX ||
        (double)nframes * 3 * mesh->nv > (double)INT32_MAX)
        return NULL;
    w = calloc(1, sizeof *w);
    if (!w)
        return NULL;
    nv = (size_t)mesh->nv;
    n4 = 4 * (size_t)mmax;
    w3 = 3 * (size_t)nframes;
    w->mmax = mmax;
    w->nclmax = nclmax;
    w->nframes = nframes;
    w->M = dtx_alloc(n4, nv * sizeof *w->M, 0);
    w->B = dtx_alloc(n4, nv * sizeof *w->B, 0);
    w->Qf = dtx_alloc(nv, w3 * sizeof *w->Qf, 0);
    w->Hc = dtx_alloc(w3, n4 * sizeof *w->Hc, 0);
    w->Tc = dtx_alloc(w3, n4 * sizeof *w->Tc, 0);
    w->A = dtx_alloc(n4, n4 * sizeof *w->A, 0);
    w->Pg = dtx_alloc((size_t)nclmax * 3, n4 * sizeof *w->Pg, 0);
    w->pool = dtx_alloc(5 * n4 * 3 + 3 * (size_t)nclmax * 9, sizeof *w->pool, 0);
    if (!w->M || !w->B || !w->Qf || !w->Hc || !w->Tc || !w->A || !w->Pg || !w->pool) {
        dtx_skin_eval_work_free(&w);
        return NULL;
    }
    b = w->pool;
    w->fw.q = NULL; /* the frames are centred once, in the dtx_skin_eval */
    w->fw.h = carve(&b, n4 * 3);
    w->fw.T = carve(&b, n4 * 3);
    w->fw.Tn = carve(&b, n4 * 3);
    w->fw.b = carve(&b, n4 * 3);
    w->fw.C = carve(&b, (size_t)nclmax * 9);
    w->fw.R = carve(&b, (size_t)nclmax * 9);
    w->fw.Rn = carve(&b, (size_t)nclmax * 9);
    return w;
}

dtx_status dtx_skin_eval_error(const dtx_skin_eval *ev, int32_t m, const double *W,
                               dtx_skin_eval_work *w, double *mean_dist, dtx_error *err)
{
    const dtx_skin_mesh *mesh;
    dtx_skin_fit fit;
    int32_t nv, n4, nf, ncl;
    int in4, inv, iw3;
    size_t w3;
    const double one = 1.0, zero = 0.0;
    double sum = 0.0;
    dtx_status st;

    if (!ev || !W || !w || !mean_dist || m < 1)
        return dtx_seterr(err, DTX_EINVAL, "skinning errors: bad arguments");
    mesh = ev->mesh;
    nv = mesh->nv;
    nf = ev->nframes;
    ncl = ev->ncl;
    n4 = 4 * m;
    if (m > w->mmax || ncl > w->nclmax || nf > w->nframes)
        return dtx_seterr(err, DTX_EINVAL,
                          "skinning errors: workspace for %d handles, %d clusters, %d frames "
                          "used with %d, %d, %d",
                          (int)w->mmax, (int)w->nclmax, (int)w->nframes, (int)m, (int)ncl, (int)nf);
    w3 = 3 * (size_t)nf;
    in4 = (int)n4;
    inv = (int)nv;
    iw3 = (int)w3;

    /* ---- M from the weights, checked as dtx_skin_fit_create does */
    if ((st = check_rows("skinning errors", nv, W, m, NULL, 0, err)) != DTX_OK)
        return st;
    for (int32_t i = 0; i < nv; i++) {
        const double *wi = W + (size_t)i * m, *pp = mesh->P + 3 * (size_t)i;
        double *mi = w->M + (size_t)i * n4;
        for (int32_t k = 0; k < m; k++) {
            double x = wi[k];
            mi[4 * k] = x * pp[0];
            mi[4 * k + 1] = x * pp[1];
            mi[4 * k + 2] = x * pp[2];
            mi[4 * k + 3] = x;
        }
    }

    /* ---- B = M + 2 lambda L M (L the spoke Laplacian), row by row, then
     * A = lambda K + G = M^T B and its Cholesky factor.  Row-major M and B
     * are column-major n4 x nv; A = M^T B lands row-major as B^T M, whose
     * lower triangle cholesky() reads: the upper triangle of M^T B, as
     * dtx_skin_fit_create computes it. */
    for (int32_t i = 0; i < nv; i++) {
        const double *mi = w->M + (size_t)i * n4;
        double *bi = w->B + (size_t)i * n4, c = 2.0 * ev->lambda, d = 0.0;
        for (int32_t r = 0; r < n4; r++)
            bi[r] = 0.0;
        for (int64_t e = mesh->spoke_start[i]; e < mesh->spoke_start[i + 1]; e++) {
            const double *mj = w->M + (size_t)mesh->spoke_j[e] * n4;
            double we = mesh->spoke_w[e];
            d += we;
            for (int32_t r = 0; r < n4; r++)
                bi[r] -= we * mj[r];
        }
        for (int32_t r = 0; r < n4; r++)
            bi[r] = mi[r] + c * (d * mi[r] + bi[r]);
    }
    dgemm_("N", "T", &in4, &in4, &inv, &one, w->M, &in4, w->B, &in4, &zero, w->A, &in4);
    if (cholesky(w->A, n4) >= 0)
        return dtx_seterr(err, DTX_ESOLVE,
                          "skinning errors: the normal matrix is not positive definite (the "
                          "weights times [p 1] are linearly dependent)");

    /* ---- P_g = D_g M (3 x n4 per cluster) */
    memset(w->Pg, 0, sizeof(double) * (size_t)ncl * 3 * (size_t)n4);
    for (int32_t j = 0; j < nv; j++) {
        const double *mj = w->M + (size_t)j * n4;
        for (int64_t x = ev->dstart[j]; x < ev->dstart[j + 1]; x++) {
            double *pg = w->Pg + (size_t)ev->dg[x] * 3 * n4;
            const double *d = ev->dw + 3 * x;
            for (int a = 0; a < 3; a++)
                for (int32_t r = 0; r < n4; r++)
                    pg[(size_t)a * n4 + r] += d[a] * mj[r];
        }
    }

    /* ---- every frame's M^T q at once: Hc (3 nf x n4) = Qh^T M */
    dgemm_("N", "T", &iw3, &in4, &inv, &one, ev->Qh, &iw3, w->M, &in4, &zero, w->Hc, &iw3);

    /* ---- the local/global fit of each frame */
    memset(&fit, 0, sizeof fit);
    fit.mesh = mesh;
    fit.m = m;
    fit.n4 = n4;
    fit.ncl = ncl;
    fit.lambda = ev->lambda;
    fit.L = w->A;
    fit.Pg = w->Pg;
    for (int32_t f = 0; f < nf; f++) {
        int it;
        for (int32_t r = 0; r < n4; r++)
            for (int c = 0; c < 3; c++)
                w->fw.h[3 * r + c] = w->Hc[(size_t)r * w3 + 3 * (size_t)f + c];
        iterate_frame(&fit, ev->qq[f], ev->R0 + (size_t)f * ncl * 9, ev->max_iters, ev->tol, &w->fw,
                      &it, NULL);
        for (int32_t r = 0; r < n4; r++)
            for (int c = 0; c < 3; c++)
                w->Tc[(size_t)r * w3 + 3 * (size_t)f + c] = w->fw.T[3 * r + c];
    }

    /* ---- the skinned frames Qf (nv x 3 nf) = M T, and the distances */
    dgemm_("N", "N", &iw3, &inv, &in4, &one, w->Tc, &iw3, w->M, &in4, &zero, w->Qf, &iw3);
    for (size_t i = 0; i < (size_t)nv; i++) {
        const double *q = w->Qf + i * w3, *y = ev->Qh + i * w3;
        for (size_t t = 0; t < w3; t += 3)
            sum += sqrt((q[t] - y[t]) * (q[t] - y[t]) + (q[t + 1] - y[t + 1]) * (q[t + 1] - y[t + 1]) +
                        (q[t + 2] - y[t + 2]) * (q[t + 2] - y[t + 2]));
    }
    *mean_dist = sum * mesh->scale / ((double)nf * (double)nv);
    return isfinite(*mean_dist)
               ? DTX_OK
               : dtx_seterr(err, DTX_ENONFINITE, "skinning errors: non-finite fit error");
}
