/*
 * pc2.c: PC2 point cache writer and reader (format in pc2.h).
 *
 * Bytes are packed explicitly in little-endian order, so the files are the
 * same on any host.
 */
#include "pc2.h"
#include "byteorder.h"

#include "meshfile_util.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- writing */

dtx_status dtx_pc2_begin(dtx_pc2_writer *w, const char *path, int32_t num_points,
                         int32_t num_samples, float start_frame, float sample_rate, dtx_error *err)
{
    unsigned char head[DTX_PC2_HEADER_BYTES];
    dtx_status st;
    memset(w, 0, sizeof *w);
    if ((st = dtx_point_cache_check(path, num_points, num_samples, err)) != DTX_OK)
        return st;
    /* 12 * 2^31 * 2^31 < 2^63: the size always fits; no check needed beyond
     * the signs above. */
    if (!isfinite(start_frame) || !isfinite(sample_rate) || !(sample_rate > 0.0f))
        return dtx_seterr(err, DTX_EINVAL,
                          "%s: start frame %g and sample rate %g must be finite, the rate > 0",
                          path, (double)start_frame, (double)sample_rate);
    if ((st = dtx_point_cache_open(&w->pc, path, num_points, num_samples, 0, err)) != DTX_OK)
        return st;
    w->h.version = DTX_PC2_VERSION;
    w->h.num_points = num_points;
    w->h.num_samples = num_samples;
    w->h.start_frame = start_frame;
    w->h.sample_rate = sample_rate;
    memset(head, 0, sizeof head);
    memcpy(head, DTX_PC2_SIGNATURE, strlen(DTX_PC2_SIGNATURE)); /* NUL from memset */
    dtx_put_le32(head + 12, DTX_PC2_VERSION);
    dtx_put_le32(head + 16, (uint32_t)num_points);
    dtx_put_lef32(head + 20, start_frame);
    dtx_put_lef32(head + 24, sample_rate);
    dtx_put_le32(head + 28, (uint32_t)num_samples);
    fwrite(head, 1, sizeof head, w->pc.af.fp); /* errors: caught by the commit */
    return DTX_OK;
}

void dtx_pc2_abort(dtx_pc2_writer *w)
{
    dtx_point_cache_abort(&w->pc);
    memset(w, 0, sizeof *w);
}

dtx_status dtx_pc2_write_sample(dtx_pc2_writer *w, const double *X, dtx_error *err)
{
    return dtx_point_cache_write(&w->pc, X, NULL, err);
}

dtx_status dtx_pc2_write_sample_f32(dtx_pc2_writer *w, const float *X, dtx_error *err)
{
    return dtx_point_cache_write(&w->pc, NULL, X, err);
}

dtx_status dtx_pc2_finish(dtx_pc2_writer *w, dtx_error *err)
{
    dtx_status st = dtx_point_cache_finish(&w->pc, err);
    memset(w, 0, sizeof *w);
    return st;
}

/* ---------------------------------------------------------------- reading */

dtx_status dtx_pc2_parse(const char *name, const unsigned char *buf, size_t len, dtx_pc2_header *h,
                         float **P, dtx_error *err)
{
    uint64_t want;
    size_t n;
    float *out;
    *P = NULL;
    memset(h, 0, sizeof *h);
    if (len < DTX_PC2_HEADER_BYTES)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: %zu bytes, shorter than the 32-byte PC2 header (truncated?)", name,
                          len);
    if (memcmp(buf, DTX_PC2_SIGNATURE, sizeof DTX_PC2_SIGNATURE) != 0)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: not a PC2 point cache (no \"POINTCACHE2\\0\" signature)", name);
    h->version = dtx_get_lei32(buf + 12);
    h->num_points = dtx_get_lei32(buf + 16);
    h->start_frame = dtx_get_lef32(buf + 20);
    h->sample_rate = dtx_get_lef32(buf + 24);
    h->num_samples = dtx_get_lei32(buf + 28);
    if (h->version != DTX_PC2_VERSION)
        return dtx_seterr(err, DTX_EPARSE, "%s: PC2 version %d (only version 1 exists)", name,
                          (int)h->version);
    if (h->num_points < 1 || h->num_samples < 1)
        return dtx_seterr(err, DTX_EPARSE, "%s: %d points and %d samples (both must be >= 1)", name,
                          (int)h->num_points, (int)h->num_samples);
    if (!isfinite(h->start_frame) || !isfinite(h->sample_rate) || !(h->sample_rate > 0.0f))
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: start frame %g, sample rate %g (finite, rate > 0 expected)", name,
                          (double)h->start_frame, (double)h->sample_rate);
    want = DTX_PC2_HEADER_BYTES + 12u * (uint64_t)h->num_points * (uint64_t)h->num_samples;
    if ((uint64_t)len != want)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: %zu bytes, but %d points x %d samples need %llu (%s)", name, len,
                          (int)h->num_points, (int)h->num_samples, (unsigned long long)want,
                          (uint64_t)len < want ? "truncated" : "trailing bytes");
    n = (size_t)(want - DTX_PC2_HEADER_BYTES) / 4;
    out = dtx_alloc(n, sizeof *out, 0);
    if (!out)
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for %zu floats", name, n);
    for (size_t i = 0; i < n; i++)
        out[i] = dtx_get_lef32(buf + DTX_PC2_HEADER_BYTES + 4 * i);
    *P = out;
    return DTX_OK;
}

dtx_status dtx_pc2_read(const char *path, dtx_pc2_header *h, float **P, dtx_error *err)
{
    char *buf = NULL;
    size_t len = 0;
    dtx_status st;
    *P = NULL;
    memset(h, 0, sizeof *h);
    st = dtx_file_read_all(path, &buf, &len, err);
    if (st != DTX_OK)
        return st;
    st = dtx_pc2_parse(path, (const unsigned char *)buf, len, h, P, err);
    free(buf);
    return st;
}
