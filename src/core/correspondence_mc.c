/*
 * correspondence_mc.c: triangle correspondence for targets made of several
 * components (Zhou, Xu, Tong & Desbrun 2010, section 2.2).
 *
 * Unlike Sumner & Popovic, the *target* is deformed into the source: it is
 * the mesh whose pieces must be kept together.  Its vertices (and one fourth
 * vertex per triangle) minimise
 *     w_S E_S + w_I E_I + w_C E_C + E_R
 * with the marked target vertices held at their source markers' positions,
 * the closest valid points taken on the source surface, and E_R tying the
 * components together: for every proximity pair (i, j) of the target
 * (proximity.h) the triangles t_a around i and t_b around j that are the
 * furthest apart along their normals each get a tetrahedron closed by a
 * vertex of the other triangle (the one furthest from its plane), and
 *     w_S |T_a - T_b|^2 + w_I |T_a - I|^2 + w_I |T_b - I|^2
 * makes the two tetrahedra deform alike.  When t_a and t_b are nearly
 * coplanar (the other triangle's furthest vertex within 1/10 of the longest
 * edge from the plane) both tetrahedra use t_a's own fourth vertex instead,
 * as the paper says.  Components without markers thus follow those with.
 *
 * Then triangles are paired.  The paper's text reads as if triangles that
 * touch a marker or a vertex with a valid closest point got no source
 * triangle; that would leave almost every triangle unpaired and pair the
 * ones far from the source, so dtx takes the evident intent: a deformed
 * target triangle with at least one vertex that is a marker or found a
 * valid closest point (in the last phase) is paired with the source
 * triangle whose barycenter is nearest (among those whose normal is within
 * max_angle of its own, else among all), and the others are orphans, left
 * to the transfer's E2 and E4 terms.
 */
#include "correspondence_internal.h"
#include "dtx_core.h"
#include "proximity.h"
#include "vec3.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DTX_PI 3.14159265358979323846

/* Rest position of triangle f's fourth vertex (as dtx_frame_inverses). */
static void fourth_vertex(const double *V, const int32_t *F, int32_t f, double *out)
{
    const double *a = V + 3 * (size_t)F[3 * f];
    double e1[3], e2[3], e3[3];
    sub3(V + 3 * (size_t)F[3 * f + 1], a, e1);
    sub3(V + 3 * (size_t)F[3 * f + 2], a, e2);
    fourth_edge(e1, e2, e3);
    for (int k = 0; k < 3; k++)
        out[k] = a[k] + e3[k];
}

/* Fills q for the tetrahedron (v0, v1, v2, var3) with the rest position p3
 * of its fourth unknown; 0 when it is degenerate. */
static int make_tet(const double *V, int32_t v0, int32_t v1, int32_t v2, int32_t var3,
                    const double *p3, double scale, dtx__tet *q)
{
    double c0[3], c1[3], c2[3], inv[9], det;
    sub3(V + 3 * (size_t)v1, V + 3 * (size_t)v0, c0);
    sub3(V + 3 * (size_t)v2, V + 3 * (size_t)v0, c1);
    sub3(p3, V + 3 * (size_t)v0, c2);
    det = inverse_of_columns(c0, c1, c2, inv);
    if (!(fabs(det) > 1e-9 * scale * scale * scale))
        return 0;
    memcpy(q->inv, inv, sizeof inv);
    q->var[0] = v0;
    q->var[1] = v1;
    q->var[2] = v2;
    q->var[3] = var3;
    return 1;
}

static int cmp_pair2(const void *x, const void *y)
{
    const int32_t *p = x, *q = y;
    if (p[0] != q[0])
        return p[0] < q[0] ? -1 : 1;
    return (p[1] > q[1]) - (p[1] < q[1]);
}

/* E_R's tetrahedron pairs from the proximity pairs' triangle pairs (rest
 * positions V, normalised).  *tets: allocated, 2 per pair. */
static dtx_status build_tets(const dtx_mesh *tgt, const double *V, const dtx_proximity *prox,
                             dtx__tet **tets_out, int64_t *ntp, dtx_error *err)
{
    const int32_t nv = tgt->nv;
    const int32_t *F = tgt->F;
    dtx_mesh m = *tgt;
    int32_t *tri = dtx_alloc((size_t)prox->npairs, 2 * sizeof *tri, 0);
    dtx__tet *tets = NULL;
    int64_t n = 0, u = 0;
    dtx_status st;

    *tets_out = NULL;
    *ntp = 0;
    if (!tri)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory building the E_R terms");
    m.V = (double *)V;
    st = dtx_proximity_triangle_pairs(&m, prox, tri, err);
    if (st != DTX_OK) {
        free(tri);
        return st;
    }
    /* Many vertex pairs share a triangle pair: one term each. */
    qsort(tri, (size_t)prox->npairs, 2 * sizeof *tri, cmp_pair2);
    for (int64_t i = 0; i < prox->npairs; i++)
        if (u == 0 || tri[2 * i] != tri[2 * (u - 1)] || tri[2 * i + 1] != tri[2 * (u - 1) + 1]) {
            tri[2 * u] = tri[2 * i];
            tri[2 * u + 1] = tri[2 * i + 1];
            u++;
        }
    tets = dtx_alloc((size_t)u, 2 * sizeof *tets, 0);
    if (!tets) {
        free(tri);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory building the E_R terms");
    }
    for (int64_t i = 0; i < u; i++) {
        int32_t ta = tri[2 * i], tb = tri[2 * i + 1], t[2] = {ta, tb};
        int32_t far[2] = {-1, -1};
        double dist[2] = {-1.0, -1.0}, longest[2] = {0.0, 0.0}, nrm[2][3];
        int ok = 1, coplanar = 0;
        for (int s = 0; s < 2; s++) {
            const int32_t *f = F + 3 * (size_t)t[s];
            double e1[3], e2[3], len;
            sub3(V + 3 * (size_t)f[1], V + 3 * (size_t)f[0], e1);
            sub3(V + 3 * (size_t)f[2], V + 3 * (size_t)f[0], e2);
            cross3(e1, e2, nrm[s]);
            len = sqrt(dot3(nrm[s], nrm[s]));
            if (!(len > 0.0)) {
                ok = 0;
                break;
            }
            for (int k = 0; k < 3; k++)
                nrm[s][k] /= len;
            for (int k = 0; k < 3; k++) {
                double d[3], l;
                sub3(V + 3 * (size_t)f[(k + 1) % 3], V + 3 * (size_t)f[k], d);
                l = sqrt(dot3(d, d));
                longest[s] = l > longest[s] ? l : longest[s];
            }
        }
        if (!ok)
            continue;
        /* The other triangle's vertex furthest from each plane. */
        for (int s = 0; s < 2; s++) {
            const int32_t *f = F + 3 * (size_t)t[s], *g = F + 3 * (size_t)t[1 - s];
            for (int k = 0; k < 3; k++) {
                double d[3], h;
                sub3(V + 3 * (size_t)g[k], V + 3 * (size_t)f[0], d);
                h = fabs(dot3(d, nrm[s]));
                if (h > dist[s]) {
                    dist[s] = h;
                    far[s] = g[k];
                }
            }
            if (dist[s] < 0.1 * longest[s])
                coplanar = 1;
        }
        {
            const int32_t *fa = F + 3 * (size_t)ta, *fb = F + 3 * (size_t)tb;
            double scale = longest[0] > longest[1] ? longest[0] : longest[1];
            double p4[3];
            if (coplanar) {
                fourth_vertex(V, F, ta, p4);
                ok = make_tet(V, fa[0], fa[1], fa[2], nv + ta, p4, scale, &tets[2 * n]) &&
                     make_tet(V, fb[0], fb[1], fb[2], nv + ta, p4, scale, &tets[2 * n + 1]);
            } else {
                ok = make_tet(V, fa[0], fa[1], fa[2], far[0], V + 3 * (size_t)far[0], scale,
                              &tets[2 * n]) &&
                     make_tet(V, fb[0], fb[1], fb[2], far[1], V + 3 * (size_t)far[1], scale,
                              &tets[2 * n + 1]);
            }
            n += ok;
        }
    }
    free(tri);
    *tets_out = tets;
    *ntp = n;
    return DTX_OK;
}

/* E_R's maker (dtx__tet_maker): the target's proximity pairs (in the
 * normalised frame Tn, where the thresholds are the same relative to the
 * mesh), then their tetrahedron pairs, both kept here. */
typedef struct {
    const dtx_mesh *tgt;
    const double *Tn;
    double eps_factor;
    dtx_proximity prox;
    dtx__tet *tets;
} tets_ctx;

static dtx_status make_tets(void *ctx, const dtx__tet **tets, int64_t *ntetpairs, dtx_error *err)
{
    tets_ctx *c = ctx;
    dtx_mesh tn = *c->tgt;
    dtx_status st;
    tn.V = (double *)c->Tn;
    st = dtx_proximity_build(&tn, c->eps_factor, &c->prox, err);
    if (st == DTX_OK)
        st = build_tets(c->tgt, c->Tn, &c->prox, &c->tets, ntetpairs, err);
    *tets = c->tets;
    return st;
}

typedef struct {
    const double *normals;
    const double *n;
    double cosmax;
} nfilter_ctx;

static int nfilter(const void *ctx, int32_t prim)
{
    const nfilter_ctx *c = ctx;
    return dot3(c->normals + 3 * (size_t)prim, c->n) > c->cosmax;
}

/* Pairs every target triangle that touches a marker or a vertex with a
 * valid closest point with the source triangle of nearest barycenter.
 * vhint (tgt->nv): a source triangle near each deformed target vertex (its
 * last closest point) or -1, only where the searches start: the pairs are
 * the same with any hints. */
static dtx_status pair_mc(const dtx_mesh *src, const double *S0, const dtx_mesh *tgt,
                          const double *X, const unsigned char *anchored, const int32_t *vhint,
                          const dtx_corr_params *prm, dtx_corr *out, dtx_error *err)
{
    const int32_t nfs = src->nf, nft = tgt->nf;
    const double cosmax = cos(prm->max_angle_deg * DTX_PI / 180.0);
    double *cs = dtx_alloc((size_t)nfs, 3 * sizeof *cs, 0);
    double *ns = dtx_alloc((size_t)nfs, 3 * sizeof *ns, 0);
    double *nt = dtx_alloc((size_t)nft, 3 * sizeof *nt, 0);
    int32_t *by = dtx_alloc((size_t)nft, sizeof *by, 0);
    dtx_bvh *bs = NULL;
    int32_t orphans = 0;
    int64_t np = 0;
    dtx_status st = DTX_OK;

    if (!cs || !ns || !nt || !by)
        goto nomem;
    for (int32_t f = 0; f < nfs; f++)
        for (int k = 0; k < 3; k++)
            cs[3 * (size_t)f + k] =
                (S0[3 * (size_t)src->F[3 * f] + k] + S0[3 * (size_t)src->F[3 * f + 1] + k] +
                 S0[3 * (size_t)src->F[3 * f + 2] + k]) /
                3.0;
    dtx_face_normals(S0, src->F, nfs, ns);
    dtx_face_normals(X, tgt->F, nft, nt);
    bs = dtx_bvh_build(cs, NULL, nfs);
    if (!bs)
        goto nomem;
#pragma omp parallel for schedule(static)
    for (int32_t f = 0; f < nft; f++) {
        const int32_t *tv = tgt->F + 3 * (size_t)f;
        double c[3];
        nfilter_ctx ctx;
        by[f] = -1;
        if (!anchored[tv[0]] && !anchored[tv[1]] && !anchored[tv[2]])
            continue;
        for (int k = 0; k < 3; k++)
            c[k] = (X[3 * (size_t)tv[0] + k] + X[3 * (size_t)tv[1] + k] +
                    X[3 * (size_t)tv[2] + k]) /
                   3.0;
        ctx.normals = ns;
        ctx.n = nt + 3 * (size_t)f;
        ctx.cosmax = cosmax;
        by[f] = dtx_bvh_closest_from(bs, c, INFINITY, nfilter, &ctx, vhint[tv[0]], NULL, NULL);
        if (by[f] < 0)
            by[f] = dtx_bvh_closest(bs, c, INFINITY, NULL, NULL, NULL, NULL);
    }
    for (int32_t f = 0; f < nft; f++)
        if (by[f] >= 0)
            np++;
        else
            orphans++;
    out->pairs = dtx_alloc((size_t)np, 2 * sizeof *out->pairs, 0);
    if (!out->pairs)
        goto nomem;
    np = 0;
    for (int32_t f = 0; f < nft; f++)
        if (by[f] >= 0) {
            out->pairs[2 * np] = by[f];
            out->pairs[2 * np + 1] = f;
            np++;
        }
    out->npairs = np;
    out->unmatched_tgt = orphans;
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory while pairing triangles");
done:
    dtx_bvh_free(&bs);
    free(cs);
    free(ns);
    free(nt);
    free(by);
    return st;
}

dtx_status dtx_mc_correspond(const dtx_mesh *src, const dtx_mesh *tgt,
                             const dtx_markers *markers, const dtx_corr_params *prm,
                             double eps_factor, dtx_corr *out, dtx_error *err)
{
    dtx_status st;
    double *S0 = NULL, *Tn = NULL, *X = NULL, *snormals = NULL, *fixpos = NULL;
    double center[3] = {0, 0, 0}, diag = 1.0;
    int32_t *fixv = NULL, *closest = NULL;
    unsigned char *anchored = NULL;
    dtx_bvh *sbvh = NULL;
    tets_ctx tc;

    memset(out, 0, sizeof *out);
    memset(&tc, 0, sizeof tc);
    st = dtx__corr_check(src, tgt, markers, prm, err);
    if (st != DTX_OK)
        return st;

    S0 = dtx_alloc((size_t)src->nv, 3 * sizeof *S0, 0);
    Tn = dtx_alloc((size_t)tgt->nv, 3 * sizeof *Tn, 0);
    X = dtx_alloc((size_t)tgt->nv, 3 * sizeof *X, 0);
    snormals = dtx_alloc((size_t)src->nf, 3 * sizeof *snormals, 0);
    anchored = dtx_alloc((size_t)tgt->nv, 1, 1);
    fixv = dtx_alloc((size_t)markers->n, sizeof *fixv, 0);
    fixpos = dtx_alloc((size_t)markers->n, 3 * sizeof *fixpos, 0);
    closest = dtx_alloc((size_t)tgt->nv, sizeof *closest, 0);
    if (!S0 || !Tn || !X || !snormals || !anchored || !fixv || !fixpos || !closest)
        goto nomem;
    st = dtx__corr_normalise(src, tgt, markers, prm->align, S0, Tn, center, &diag, err);
    if (st != DTX_OK)
        goto fail;

    /* Deform the target into the source, markers held on the source, with
     * E_R from the target's proximity pairs (made while the deformation
     * sets up its other terms). */
    tc.tgt = tgt;
    tc.Tn = Tn;
    tc.eps_factor = eps_factor;
    for (int32_t m = 0; m < markers->n; m++) {
        fixv[m] = markers->tgt[m];
        memcpy(fixpos + 3 * (size_t)m, S0 + 3 * (size_t)markers->src[m], 3 * sizeof *fixpos);
    }
    dtx_face_normals(S0, src->F, src->nf, snormals);
    sbvh = dtx_bvh_build(S0, src->F, src->nf);
    if (!sbvh)
        goto nomem;
    memcpy(X, Tn, (size_t)tgt->nv * 3 * sizeof *X);
    {
        /* Weights per element, whatever prm->weights says: weighing E_I and
         * E_C by area would call for E_R's proximity pairs to be weighed
         * too, which is not done (nor measured) yet. */
        dtx_corr_params p = *prm;
        p.weights = DTX_CORR_WEIGHTS_ELEMENT;
        st = dtx__deform_mesh(tgt->F, tgt->nv, tgt->nf, Tn, fixv, fixpos, markers->n, make_tets,
                              &tc, sbvh, snormals, &p, X, anchored, closest, &out->solves,
                              &out->factorizations, err);
    }
    if (st != DTX_OK)
        goto fail;
    for (int32_t m = 0; m < markers->n; m++)
        anchored[markers->tgt[m]] = 1;
    st = pair_mc(src, S0, tgt, X, anchored, closest, prm, out, err);
    if (st != DTX_OK)
        goto fail;

    /* Fit: RMS distance of the deformed target's vertices (those in faces)
     * to the source surface, each search started from the vertex's last
     * closest point (the same figure, found sooner). */
    out->fit_rms = dtx__fit_rms_from(sbvh, X, tgt->nv, tc.prox.comp, closest);
    if (out->fit_rms < 0.0)
        goto nomem;
    for (int32_t i = 0; i < tgt->nv; i++)
        for (int k = 0; k < 3; k++)
            X[3 * (size_t)i + k] = X[3 * (size_t)i + k] * diag + center[k];
    out->deformed_tgt = X;
    out->nv_tgt = tgt->nv;
    X = NULL;
    goto fail; /* success: shared cleanup */

nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory in the multicomponent correspondence");
fail:
    if (st != DTX_OK)
        dtx_corr_free(out);
    dtx_proximity_free(&tc.prox);
    dtx_bvh_free(&sbvh);
    free(S0);
    free(Tn);
    free(X);
    free(snormals);
    free(anchored);
    free(fixv);
    free(fixpos);
    free(closest);
    free(tc.tets);
    return st;
}
