/* render.c: a z-buffer software rasteriser for mesh pictures, and the PNG
 * writer.  See render.h for the picture, the camera and the shading. */
#include "render.h"

#include "atomic_file.h"
#include "mesh.h"

#include <float.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

/* Most samples (width x height x supersample^2) drawn at once: 7 bytes
 * each, so about 1.9 GB. */
#define MAX_SAMPLES ((size_t)1 << 28)
/* Fewest sample rows in a unit of parallel work. */
#define MIN_BAND 16
/* Entries of the linear-to-sRGB table. */
#define LUT_SIZE 4096

static const double PI = 3.14159265358979323846;

/* The component palette (sRGB): muted colours that stay apart from each
 * other and from a white background. */
static const unsigned char palette[DTX_RENDER_PALETTE_SIZE][3] = {
    {214, 160, 110}, /* clay */
    {110, 150, 205}, /* blue */
    {130, 182, 120}, /* green */
    {205, 112, 112}, /* red */
    {160, 132, 196}, /* purple */
    {222, 200, 108}, /* yellow */
    {105, 186, 186}, /* teal */
    {204, 140, 172}, /* pink */
    {150, 150, 150}, /* grey */
    {160, 165, 88},  /* olive */
};

/* ------------------------------------------------------------------ */
/* Options and camera                                                  */
/* ------------------------------------------------------------------ */

void dtx_render_opts_default(dtx_render_opts *o)
{
    memset(o, 0, sizeof *o);
    o->width = 800;
    o->height = 600;
    o->rows = o->cols = 1;
    o->azimuth_deg = 60.0;
    o->elevation_deg = 15.0;
    o->up_axis = 1;
    o->color_by_component = 1;
    o->color[0] = 200, o->color[1] = 178, o->color[2] = 150;
    o->background[0] = o->background[1] = o->background[2] = 255;
    o->smooth = 1;
    o->supersample = 2;
    o->margin = 0.04;
    o->same_scale = 1;
    o->outline = 1;
    o->separators = 1;
}

/* A y-up vector v expressed in world coordinates whose up axis is `up`. */
static void to_world(int up, const double v[3], double w[3])
{
    if (up == 2) { /* world (x, y, z) shows as (x, z, -y) */
        w[0] = v[0], w[1] = -v[2], w[2] = v[1];
    } else if (up == 0) { /* world (x, y, z) shows as (-y, x, z) */
        w[0] = v[1], w[1] = -v[0], w[2] = v[2];
    } else {
        w[0] = v[0], w[1] = v[1], w[2] = v[2];
    }
}

void dtx_render_axes(const dtx_render_opts *o, double right[3], double up[3], double toward[3])
{
    double az = o->azimuth_deg * PI / 180.0, el = o->elevation_deg * PI / 180.0;
    double t[3] = {sin(az) * cos(el), sin(el), cos(az) * cos(el)};
    double r[3] = {cos(az), 0.0, -sin(az)};
    double u[3] = {t[1] * r[2] - t[2] * r[1], t[2] * r[0] - t[0] * r[2],
                   t[0] * r[1] - t[1] * r[0]};
    to_world(o->up_axis, r, right);
    to_world(o->up_axis, u, up);
    to_world(o->up_axis, t, toward);
}

void dtx_render_bounds_init(double box[4])
{
    box[0] = box[2] = DBL_MAX;
    box[1] = box[3] = -DBL_MAX;
}

void dtx_render_bounds_add(const double *X, int32_t n, const dtx_render_opts *o, double box[4])
{
    double r[3], u[3], t[3];
    dtx_render_axes(o, r, u, t);
    for (int32_t i = 0; i < n; i++) {
        const double *p = X + 3 * i;
        double x = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
        double y = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
        if (!isfinite(x) || !isfinite(y))
            continue;
        box[0] = x < box[0] ? x : box[0];
        box[1] = x > box[1] ? x : box[1];
        box[2] = y < box[2] ? y : box[2];
        box[3] = y > box[3] ? y : box[3];
    }
}

/* Pixel scale of the label font (5 x 7 glyphs) for panels pw pixels wide. */
static int label_scale(int pw)
{
    int s = pw / 100;
    return s < 1 ? 1 : s > 3 ? 3 : s;
}

/* Height of the band reserved for labels at the top of each panel. */
static int label_band(int pw)
{
    return 10 * label_scale(pw);
}

/* Extent of a box, never zero (a flat or single-point scene still gets a
 * finite scale); an empty box counts as 1 x 1. */
static void box_extent(const double *b, double *w, double *h)
{
    *w = b[1] >= b[0] ? b[1] - b[0] : 1.0;
    *h = b[3] >= b[2] ? b[3] - b[2] : 1.0;
    if (*w <= 0 && *h <= 0)
        *w = *h = 1.0;
    else if (*w <= 0)
        *w = *h * 1e-6;
    else if (*h <= 0)
        *h = *w * 1e-6;
}

int dtx_render_fit_height(const double *bounds, int ngroups, int labels,
                          const dtx_render_opts *o)
{
    int pw = o->cols > 0 ? o->width / o->cols : o->width;
    double m = o->margin, aw = pw * (1.0 - 2.0 * m), s = DBL_MAX, need = 0.0, ph;
    long long height;
    for (int g = 0; g < ngroups; g++) {
        double w, h;
        box_extent(bounds + 4 * g, &w, &h);
        s = aw / w < s ? aw / w : s;
    }
    for (int g = 0; g < ngroups; g++) {
        double w, h, sg;
        box_extent(bounds + 4 * g, &w, &h);
        sg = o->same_scale ? s : aw / w;
        need = h * sg > need ? h * sg : need;
    }
    ph = need / (1.0 - 2.0 * m) + (labels ? label_band(pw) : 0);
    if (!(ph < DTX_RENDER_MAX_SIZE))
        ph = DTX_RENDER_MAX_SIZE;
    height = (long long)ceil(ph) * (o->rows > 0 ? o->rows : 1);
    return height < 1 ? 1 : height > DTX_RENDER_MAX_SIZE ? DTX_RENDER_MAX_SIZE : (int)height;
}

/* ------------------------------------------------------------------ */
/* Shading                                                             */
/* ------------------------------------------------------------------ */

static double srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

static double linear_to_srgb(double c)
{
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

/* Light intensity on a surface with unit normal n given in camera
 * coordinates (right, up, toward the viewer). */
static float shade(const double n[3])
{
    /* Key light from the upper left and in front, a weaker fill from the
     * right, and ambient; directions are unit vectors. */
    static const double key[3] = {-0.5848, 0.6823, 0.4386};
    static const double fill[3] = {0.8144, -0.1527, 0.5599};
    double k = n[0] * key[0] + n[1] * key[1] + n[2] * key[2];
    double f = n[0] * fill[0] + n[1] * fill[1] + n[2] * fill[2];
    double i = 0.14 + 0.86 * (k > 0 ? k : 0.0) + 0.30 * (f > 0 ? f : 0.0);
    return (float)(i < 1.0 ? i : 1.0);
}

/* ------------------------------------------------------------------ */
/* Per-panel preparation                                               */
/* ------------------------------------------------------------------ */

/* Face flags. */
enum { FACE_SKIP = 0, FACE_FRONT = 1, FACE_BACK = 2 };

typedef struct {
    float *P;          /* nv x 3: x, y in samples, depth in samples (larger is nearer) */
    float *I;          /* nv x 2: smooth intensity of the front and the back side */
    float *fI;         /* nf: flat intensity of the visible side */
    uint8_t *flag;     /* nf: FACE_SKIP, FACE_FRONT or FACE_BACK */
    int32_t *fcomp;    /* nf: component of each face (may be shared) */
    int owns_fcomp;
    int x0, y0, x1, y1; /* the panel's samples [x0, x1) x [y0, y1) */
} panel_prep;

/* Work item w of a banded pass (nbands bands of band_rows rows per panel):
 * panel *i and its rows [*ya, *yb).  Returns 0 when the band is empty (the
 * panel's last bands). */
static int band_of(const panel_prep *pp, long long w, int nbands, int band_rows, int *i, int *ya,
                   int *yb)
{
    const panel_prep *q;
    *i = (int)(w / nbands);
    q = pp + *i;
    *ya = q->y0 + (int)(w % nbands) * band_rows;
    *yb = *ya + band_rows < q->y1 ? *ya + band_rows : q->y1;
    return *ya < *yb;
}

/* Component of each face, numbered in order of first face.  comp and label
 * are nv-long scratch arrays. */
static int face_components(const dtx_render_panel *p, int32_t *fcomp, int32_t *comp,
                           int32_t *label)
{
    dtx_mesh m;
    int32_t next = 0;
    m.nv = p->nv;
    m.nf = p->nf;
    m.V = NULL; /* only the connectivity is used */
    m.F = (int32_t *)p->F;
    if (dtx_mesh_components(&m, comp) < 0)
        return -1;
    for (int32_t i = 0; i < p->nv; i++)
        label[i] = -1;
    for (int32_t f = 0; f < p->nf; f++) {
        int32_t c = comp[p->F[3 * f]];
        if (label[c] < 0)
            label[c] = next++;
        fcomp[f] = label[c];
    }
    return 0;
}

/* Projects the vertices of panel p, computes its intensities and face
 * flags.  N: nv x 3 doubles of scratch.  s: samples per world unit; (bx,
 * by): the world screen-plane point drawn at the panel's centre (cx, cy). */
static void prepare_panel(const dtx_render_panel *p, const double r[3], const double u[3],
                          const double t[3], double s, double bx, double by, double cx,
                          double cy, double *N, panel_prep *pp)
{
    const double *X = p->X;
    memset(N, 0, (size_t)p->nv * 3 * sizeof *N);
    for (int32_t i = 0; i < p->nv; i++) {
        const double *x = X + 3 * i;
        double sr = x[0] * r[0] + x[1] * r[1] + x[2] * r[2];
        double su = x[0] * u[0] + x[1] * u[1] + x[2] * u[2];
        double st = x[0] * t[0] + x[1] * t[1] + x[2] * t[2];
        pp->P[3 * i] = (float)(cx + (sr - bx) * s);
        pp->P[3 * i + 1] = (float)(cy - (su - by) * s);
        pp->P[3 * i + 2] = (float)(st * s);
    }
    for (int32_t f = 0; f < p->nf; f++) {
        const int32_t *v = p->F + 3 * f;
        const double *a = X + 3 * v[0], *b = X + 3 * v[1], *c = X + 3 * v[2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), nc[3];
        int ok = len > 0 && isfinite(len);
        for (int j = 0; j < 3 && ok; j++) {
            const float *q = pp->P + 3 * v[j];
            ok = isfinite(q[0]) && isfinite(q[1]) && isfinite(q[2]) && fabsf(q[0]) < 1e7f &&
                 fabsf(q[1]) < 1e7f;
        }
        if (!ok) {
            pp->flag[f] = FACE_SKIP;
            pp->fI[f] = 0.0f;
            continue;
        }
        /* Area-weighted vertex normals: the unnormalised cross product. */
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                N[3 * v[j] + k] += n[k];
        nc[0] = (n[0] * r[0] + n[1] * r[1] + n[2] * r[2]) / len;
        nc[1] = (n[0] * u[0] + n[1] * u[1] + n[2] * u[2]) / len;
        nc[2] = (n[0] * t[0] + n[1] * t[1] + n[2] * t[2]) / len;
        if (nc[2] >= 0) {
            pp->flag[f] = FACE_FRONT;
        } else {
            pp->flag[f] = FACE_BACK;
            nc[0] = -nc[0], nc[1] = -nc[1], nc[2] = -nc[2];
        }
        pp->fI[f] = shade(nc);
    }
    for (int32_t i = 0; i < p->nv; i++) {
        const double *n = N + 3 * i;
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), nc[3];
        if (!(len > 0) || !isfinite(len)) {
            pp->I[2 * i] = pp->I[2 * i + 1] = shade((const double[3]){0, 0, 1});
            continue;
        }
        nc[0] = (n[0] * r[0] + n[1] * r[1] + n[2] * r[2]) / len;
        nc[1] = (n[0] * u[0] + n[1] * u[1] + n[2] * u[2]) / len;
        nc[2] = (n[0] * t[0] + n[1] * t[1] + n[2] * t[2]) / len;
        pp->I[2 * i] = shade(nc);
        nc[0] = -nc[0], nc[1] = -nc[1], nc[2] = -nc[2];
        pp->I[2 * i + 1] = shade(nc);
    }
}

/* ------------------------------------------------------------------ */
/* Rasterisation                                                       */
/* ------------------------------------------------------------------ */

typedef struct {
    int sw, sh;               /* supersampled image size */
    float *z;                 /* sw x sh depths, -FLT_MAX where empty */
    unsigned char *c;         /* sw x sh x 3 colours */
    const unsigned char *lut; /* LUT_SIZE entries: linear -> sRGB byte */
    float base[DTX_RENDER_PALETTE_SIZE + 1][3]; /* linear colours; last: single colour */
    int by_component, smooth;
} raster;

static int clamp_int(double v, int lo, int hi)
{
    if (!(v > lo))
        return lo;
    if (!(v < hi))
        return hi;
    return (int)v;
}

static float min3(float a, float b, float c)
{
    float m = a < b ? a : b;
    return m < c ? m : c;
}

static float max3(float a, float b, float c)
{
    float m = a > b ? a : b;
    return m > c ? m : c;
}

/* Draws the faces of one panel into sample rows [ya, yb) of its rectangle,
 * in face order (the nearest sample wins; a tie keeps the earlier face). */
static void draw_band(const raster *R, const dtx_render_panel *p, const panel_prep *pp,
                      int ya, int yb)
{
    const float *P = pp->P;
    for (int32_t f = 0; f < p->nf; f++) {
        const int32_t *v = p->F + 3 * f;
        const float *a = P + 3 * v[0], *b = P + 3 * v[1], *c = P + 3 * v[2];
        double minx, maxx, miny, maxy, area, inv;
        int xa, xb, y0, y1, side;
        const float *col;
        float ia, ib, ic;
        if (pp->flag[f] == FACE_SKIP)
            continue;
        miny = min3(a[1], b[1], c[1]);
        maxy = max3(a[1], b[1], c[1]);
        y0 = clamp_int(ceil(miny - 0.5), ya, yb);
        y1 = clamp_int(floor(maxy - 0.5) + 1.0, ya, yb);
        if (y0 >= y1)
            continue;
        minx = min3(a[0], b[0], c[0]);
        maxx = max3(a[0], b[0], c[0]);
        xa = clamp_int(ceil(minx - 0.5), pp->x0, pp->x1);
        xb = clamp_int(floor(maxx - 0.5) + 1.0, pp->x0, pp->x1);
        if (xa >= xb)
            continue;
        area = ((double)b[0] - a[0]) * ((double)c[1] - a[1]) -
               ((double)b[1] - a[1]) * ((double)c[0] - a[0]);
        if (area == 0.0)
            continue;
        inv = 1.0 / area;
        col = R->by_component
                  ? R->base[(pp->fcomp[f] + p->palette_offset) % DTX_RENDER_PALETTE_SIZE]
                  : R->base[DTX_RENDER_PALETTE_SIZE];
        side = pp->flag[f] == FACE_FRONT ? 0 : 1;
        if (R->smooth) {
            ia = pp->I[2 * v[0] + side];
            ib = pp->I[2 * v[1] + side];
            ic = pp->I[2 * v[2] + side];
        } else {
            ia = ib = ic = pp->fI[f];
        }
        for (int y = y0; y < y1; y++) {
            double py = y + 0.5;
            float *zrow = R->z + (size_t)y * R->sw;
            unsigned char *crow = R->c + (size_t)y * R->sw * 3;
            for (int x = xa; x < xb; x++) {
                double px = x + 0.5;
                /* Barycentric weights of a, b, c (edge functions over the
                 * signed area, so the winding does not matter). */
                double wa = (((double)c[0] - b[0]) * (py - b[1]) -
                             ((double)c[1] - b[1]) * (px - b[0])) * inv;
                double wb = (((double)a[0] - c[0]) * (py - c[1]) -
                             ((double)a[1] - c[1]) * (px - c[0])) * inv;
                double wc = 1.0 - wa - wb, zf, in;
                if (wa < 0 || wb < 0 || wc < 0)
                    continue;
                zf = wa * a[2] + wb * b[2] + wc * c[2];
                if (!(zf > zrow[x]))
                    continue;
                zrow[x] = (float)zf;
                in = wa * ia + wb * ib + wc * ic;
                for (int k = 0; k < 3; k++) {
                    int li = (int)(col[k] * in * (LUT_SIZE - 1) + 0.5);
                    crow[3 * x + k] = R->lut[li < 0 ? 0 : li >= LUT_SIZE ? LUT_SIZE - 1 : li];
                }
            }
        }
    }
}

/* Darkens the samples of rows [ya, yb) of a panel that lie on a silhouette
 * (next to an empty sample) or on the near side of a depth jump larger than
 * thr, looking rad samples away along the axes. */
static void outline_rows(const raster *R, const panel_prep *pp, int ya, int yb, int rad,
                         float thr)
{
    for (int y = ya; y < yb; y++)
        for (int x = pp->x0; x < pp->x1; x++) {
            float z = R->z[(size_t)y * R->sw + x];
            int edge = 0;
            if (z == -FLT_MAX)
                continue;
            for (int d = 1; d <= rad && !edge; d++) {
                const int nx[4] = {x - d, x + d, x, x}, ny[4] = {y, y, y - d, y + d};
                for (int k = 0; k < 4 && !edge; k++) {
                    float zn;
                    if (nx[k] < pp->x0 || nx[k] >= pp->x1 || ny[k] < pp->y0 || ny[k] >= pp->y1)
                        continue;
                    zn = R->z[(size_t)ny[k] * R->sw + nx[k]];
                    edge = zn < z - thr;
                }
            }
            if (edge) {
                unsigned char *c = R->c + ((size_t)y * R->sw + x) * 3;
                for (int k = 0; k < 3; k++)
                    c[k] = (unsigned char)(c[k] * 2 / 5);
            }
        }
}

/* ------------------------------------------------------------------ */
/* Labels: a 5 x 7 bitmap font                                         */
/* ------------------------------------------------------------------ */

typedef struct {
    char ch;
    unsigned char rows[7]; /* bit 4 is the leftmost column */
} glyph;

static const glyph font[] = {
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'A', {0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11}},
    {'B', {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E}},
    {'C', {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}},
    {'D', {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C}},
    {'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}},
    {'F', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}},
    {'G', {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}},
    {'H', {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {'I', {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}},
    {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}},
    {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F}},
    {'M', {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}},
    {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
    {'O', {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
    {'P', {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}},
    {'Q', {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}},
    {'R', {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11}},
    {'S', {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}},
    {'T', {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
    {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
    {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}},
    {'X', {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11}},
    {'Y', {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}},
    {'Z', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
    {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
    {'_', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F}},
    {'#', {0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A}},
    {'>', {0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08}},
};

static const unsigned char *glyph_rows(char ch)
{
    if (ch >= 'a' && ch <= 'z')
        ch = (char)(ch - 'a' + 'A');
    for (size_t i = 0; i < sizeof font / sizeof *font; i++)
        if (font[i].ch == ch)
            return font[i].rows;
    return NULL;
}

/* Draws text at (x, y) (top left) in the image, clipped to [x, xmax) x
 * [y, ymax), each font pixel sc x sc image pixels. */
static void draw_text(unsigned char *rgb, int w, const char *text, int x, int y, int xmax,
                      int ymax, int sc, const unsigned char ink[3])
{
    for (const char *s = text; *s; s++, x += 6 * sc) {
        const unsigned char *g = glyph_rows(*s);
        if (!g)
            continue;
        for (int gy = 0; gy < 7; gy++)
            for (int gx = 0; gx < 5; gx++) {
                if (!(g[gy] & (0x10 >> gx)))
                    continue;
                for (int yy = y + gy * sc; yy < y + (gy + 1) * sc && yy < ymax; yy++)
                    for (int xx = x + gx * sc; xx < x + (gx + 1) * sc && xx < xmax; xx++)
                        memcpy(rgb + ((size_t)yy * w + xx) * 3, ink, 3);
            }
    }
}

/* ------------------------------------------------------------------ */
/* dtx_render_panels                                                   */
/* ------------------------------------------------------------------ */

static dtx_status check_args(const dtx_render_panel *panels, int k, int ngroups,
                             const dtx_render_opts *o, dtx_error *err)
{
    unsigned char *used;
    if (o->width < 1 || o->width > DTX_RENDER_MAX_SIZE || o->height < 1 ||
        o->height > DTX_RENDER_MAX_SIZE)
        return dtx_seterr(err, DTX_EINVAL, "image size %d x %d is outside 1..%d", o->width,
                          o->height, DTX_RENDER_MAX_SIZE);
    if (o->rows < 1 || o->cols < 1 || o->cols > o->width || o->rows > o->height)
        return dtx_seterr(err, DTX_EINVAL,
                          "%d x %d panels do not fit in a %d x %d image (at least one pixel "
                          "each)",
                          o->rows, o->cols, o->width, o->height);
    if (o->supersample < 1 || o->supersample > 4)
        return dtx_seterr(err, DTX_EINVAL, "supersample %d is outside 1..4", o->supersample);
    if ((size_t)o->width * (size_t)o->height * (size_t)(o->supersample * o->supersample) >
        MAX_SAMPLES)
        return dtx_seterr(err, DTX_EINVAL,
                          "a %d x %d image with %dx%d supersampling is too large to draw",
                          o->width, o->height, o->supersample, o->supersample);
    if (!(o->margin >= 0.0 && o->margin <= 0.45))
        return dtx_seterr(err, DTX_EINVAL, "margin %g is outside [0, 0.45]", o->margin);
    if (!(o->elevation_deg >= -90.0 && o->elevation_deg <= 90.0) ||
        !isfinite(o->azimuth_deg))
        return dtx_seterr(err, DTX_EINVAL,
                          "view azimuth %g, elevation %g: the elevation must be in "
                          "[-90, 90]",
                          o->azimuth_deg, o->elevation_deg);
    if (o->up_axis < 0 || o->up_axis > 2)
        return dtx_seterr(err, DTX_EINVAL, "up axis %d is not 0 (x), 1 (y) or 2 (z)",
                          o->up_axis);
    if (k < 0 || (k > 0 && !panels))
        return dtx_seterr(err, DTX_EINVAL, "no panels given");
    used = dtx_alloc((size_t)o->rows * (size_t)o->cols, 1, 1);
    if (!used)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    for (int i = 0; i < k; i++) {
        const dtx_render_panel *p = panels + i;
        if (p->row < 0 || p->row >= o->rows || p->col < 0 || p->col >= o->cols) {
            free(used);
            return dtx_seterr(err, DTX_EINVAL, "panel %d: row %d, column %d is outside the "
                              "%d x %d grid", i, p->row, p->col, o->rows, o->cols);
        }
        if (used[(size_t)p->row * o->cols + p->col]++) {
            free(used);
            return dtx_seterr(err, DTX_EINVAL, "panel %d: row %d, column %d is already taken",
                              i, p->row, p->col);
        }
        if (p->group < 0 || (ngroups > 0 && p->group >= ngroups)) {
            free(used);
            return dtx_seterr(err, DTX_EINVAL, "panel %d: camera group %d is outside 0..%d",
                              i, p->group, ngroups - 1);
        }
        if (p->nv < 0 || p->nf < 0 || (p->nf > 0 && (!p->F || !p->X))) {
            free(used);
            return dtx_seterr(err, DTX_EINVAL, "panel %d: no mesh data (%d vertices, %d faces)",
                              i, (int)p->nv, (int)p->nf);
        }
        for (int64_t j = 0; j < 3 * (int64_t)p->nf; j++)
            if (p->F[j] < 0 || p->F[j] >= p->nv) {
                free(used);
                return dtx_seterr(err, DTX_ERANGE,
                                  "panel %d: face %lld has vertex index %d, outside 0..%d", i,
                                  (long long)(j / 3), (int)p->F[j], (int)p->nv - 1);
            }
    }
    free(used);
    return DTX_OK;
}

static void free_preps(panel_prep *pp, int k)
{
    for (int i = 0; pp && i < k; i++) {
        free(pp[i].P);
        free(pp[i].I);
        free(pp[i].fI);
        free(pp[i].flag);
        if (pp[i].owns_fcomp)
            free(pp[i].fcomp);
    }
    free(pp);
}

dtx_status dtx_render_panels(const dtx_render_panel *panels, int k, const double *bounds,
                             int ngroups, const dtx_render_opts *o, unsigned char *rgb,
                             dtx_error *err)
{
    const int ss = o->supersample;
    raster R;
    panel_prep *pp = NULL;
    double *own_bounds = NULL, *scale = NULL, *N = NULL, r[3], u[3], t[3], s_all = DBL_MAX;
    int32_t *comp = NULL, *label = NULL, maxnv = 0;
    unsigned char *lut = NULL;
    int pw, ph, band = 0, nbands, band_rows, labels = 0;
    long long nwork;
    dtx_status st;

    memset(&R, 0, sizeof R);
    if (!bounds) {
        ngroups = 1;
        for (int i = 0; panels && i < k; i++)
            ngroups = panels[i].group >= ngroups ? panels[i].group + 1 : ngroups;
    } else if (ngroups < 1) {
        return dtx_seterr(err, DTX_EINVAL, "%d camera groups given", ngroups);
    }
    if ((st = check_args(panels, k, ngroups, o, err)) != DTX_OK)
        return st;
    dtx_render_axes(o, r, u, t);
    pw = o->width / o->cols;
    ph = o->height / o->rows;
    for (int i = 0; i < k; i++)
        labels |= panels[i].label && panels[i].label[0];
    if (labels)
        band = label_band(pw) < ph / 2 ? label_band(pw) : ph / 2;

    /* ---- allocation: everything before the parallel loops */
    R.sw = o->width * ss;
    R.sh = o->height * ss;
    R.z = dtx_alloc((size_t)R.sw * (size_t)R.sh, sizeof *R.z, 0);
    R.c = dtx_alloc((size_t)R.sw * (size_t)R.sh, 3, 0);
    lut = dtx_alloc(LUT_SIZE, 1, 0);
    scale = dtx_alloc((size_t)ngroups, sizeof *scale, 0);
    pp = dtx_alloc((size_t)(k > 0 ? k : 1), sizeof *pp, 1);
    if (!bounds)
        own_bounds = dtx_alloc((size_t)ngroups, 4 * sizeof *own_bounds, 0);
    for (int i = 0; i < k; i++)
        maxnv = panels[i].nv > maxnv ? panels[i].nv : maxnv;
    N = dtx_alloc((size_t)maxnv, 3 * sizeof *N, 0);
    comp = dtx_alloc((size_t)maxnv, sizeof *comp, 0);
    label = dtx_alloc((size_t)maxnv, sizeof *label, 0);
    if (!R.z || !R.c || !lut || !scale || !pp || (!bounds && !own_bounds) || !N || !comp ||
        !label)
        goto nomem;
    for (int i = 0; i < k; i++) {
        const dtx_render_panel *p = panels + i;
        pp[i].P = dtx_alloc((size_t)p->nv, 3 * sizeof *pp[i].P, 0);
        pp[i].I = dtx_alloc((size_t)p->nv, 2 * sizeof *pp[i].I, 0);
        pp[i].fI = dtx_alloc((size_t)p->nf, sizeof *pp[i].fI, 0);
        pp[i].flag = dtx_alloc((size_t)p->nf, 1, 0);
        if (!pp[i].P || !pp[i].I || !pp[i].fI || !pp[i].flag)
            goto nomem;
        /* Panels drawing the same connectivity share its components. */
        if (o->color_by_component)
            for (int j = 0; j < i && !pp[i].fcomp; j++)
                if (panels[j].F == p->F && panels[j].nf == p->nf && panels[j].nv == p->nv)
                    pp[i].fcomp = pp[j].fcomp;
        if (o->color_by_component && !pp[i].fcomp) {
            pp[i].fcomp = dtx_alloc((size_t)p->nf, sizeof *pp[i].fcomp, 0);
            pp[i].owns_fcomp = 1;
            if (!pp[i].fcomp || face_components(p, pp[i].fcomp, comp, label) != 0)
                goto nomem;
        }
    }

    /* ---- colours */
    for (int i = 0; i < LUT_SIZE; i++)
        lut[i] = (unsigned char)(255.0 * linear_to_srgb(i / (double)(LUT_SIZE - 1)) + 0.5);
    R.lut = lut;
    for (int i = 0; i <= DTX_RENDER_PALETTE_SIZE; i++)
        for (int c = 0; c < 3; c++)
            R.base[i][c] = (float)srgb_to_linear(
                (i < DTX_RENDER_PALETTE_SIZE ? palette[i][c] : o->color[c]) / 255.0);
    R.by_component = o->color_by_component;
    R.smooth = o->smooth;

    /* ---- cameras: one scale per group (or one for all), fitted to the
     * bounds inside the panel less its margins and label band */
    if (!bounds) {
        for (int g = 0; g < ngroups; g++)
            dtx_render_bounds_init(own_bounds + 4 * g);
        for (int i = 0; i < k; i++)
            dtx_render_bounds_add(panels[i].X, panels[i].nv, o,
                                  own_bounds + 4 * panels[i].group);
        bounds = own_bounds;
    }
    for (int g = 0; g < ngroups; g++) {
        double w, h, aw = pw * (1.0 - 2.0 * o->margin), ah = (ph - band) * (1.0 - 2.0 * o->margin);
        box_extent(bounds + 4 * g, &w, &h);
        if (ah < 1.0)
            ah = 1.0;
        scale[g] = fmin(aw / w, ah / h) * ss;
        s_all = scale[g] < s_all ? scale[g] : s_all;
    }
    for (int i = 0; i < k; i++) {
        const dtx_render_panel *p = panels + i;
        const double *b = bounds + 4 * p->group;
        double bx = b[1] >= b[0] ? 0.5 * (b[0] + b[1]) : 0.0;
        double by = b[3] >= b[2] ? 0.5 * (b[2] + b[3]) : 0.0;
        double cx, cy;
        pp[i].x0 = (int)((long long)p->col * o->width / o->cols) * ss;
        pp[i].x1 = (int)((long long)(p->col + 1) * o->width / o->cols) * ss;
        pp[i].y0 = (int)((long long)p->row * o->height / o->rows) * ss;
        pp[i].y1 = (int)((long long)(p->row + 1) * o->height / o->rows) * ss;
        cx = 0.5 * (pp[i].x0 + pp[i].x1);
        cy = 0.5 * (pp[i].y0 + band * ss + pp[i].y1);
        prepare_panel(p, r, u, t, o->same_scale ? s_all : scale[p->group], bx, by, cx, cy, N,
                      pp + i);
    }

    /* ---- clear, draw, outline: units of work are bands of one panel's
     * rows, so every sample is written by one thread */
    /* Bands of one panel cost a pass over all its faces each: cut panels
     * into bands only as far as the threads need work. */
    {
        int nthreads = 1, prow = (o->height / o->rows + 1) * ss;
#ifdef _OPENMP
        nthreads = omp_get_max_threads();
#endif
        nbands = k > 0 ? (4 * nthreads + k - 1) / k : 1;
        nbands = nbands < (prow + MIN_BAND - 1) / MIN_BAND ? nbands
                                                          : (prow + MIN_BAND - 1) / MIN_BAND;
        band_rows = (prow + nbands - 1) / nbands;
    }
    nwork = (long long)k * nbands;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < R.sh; y++) {
        float *zr = R.z + (size_t)y * R.sw;
        unsigned char *cr = R.c + (size_t)y * R.sw * 3;
        for (int x = 0; x < R.sw; x++) {
            zr[x] = -FLT_MAX;
            memcpy(cr + 3 * x, o->background, 3);
        }
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (long long w = 0; w < nwork; w++) {
        int i, ya, yb;
        if (band_of(pp, w, nbands, band_rows, &i, &ya, &yb))
            draw_band(&R, panels + i, pp + i, ya, yb);
    }
    if (o->outline) {
        int rad = ss > 1 ? ss / 2 + (ss > 2) : 1;
        /* A depth jump of a few pixels' worth of distance. */
        float thr = (float)(6.0 * ss);
#pragma omp parallel for schedule(dynamic, 1)
        for (long long w = 0; w < nwork; w++) {
            int i, ya, yb;
            if (band_of(pp, w, nbands, band_rows, &i, &ya, &yb))
                outline_rows(&R, pp + i, ya, yb, rad, thr);
        }
    }

    /* ---- resolve: the mean of each pixel's samples */
#pragma omp parallel for schedule(static)
    for (int y = 0; y < o->height; y++)
        for (int x = 0; x < o->width; x++)
            for (int c = 0; c < 3; c++) {
                unsigned sum = 0, n = (unsigned)(ss * ss);
                for (int sy = 0; sy < ss; sy++)
                    for (int sx = 0; sx < ss; sx++)
                        sum += R.c[(((size_t)y * ss + sy) * R.sw + (size_t)x * ss + sx) * 3 + c];
                rgb[((size_t)y * o->width + x) * 3 + c] = (unsigned char)((sum + n / 2) / n);
            }

    /* ---- separators and labels */
    if (o->separators) {
        unsigned char line[3];
        for (int c = 0; c < 3; c++)
            line[c] = (unsigned char)(o->background[c] * 7 / 8);
        for (int col = 1; col < o->cols; col++) {
            int x = (int)((long long)col * o->width / o->cols);
            for (int y = 0; y < o->height; y++)
                memcpy(rgb + ((size_t)y * o->width + x) * 3, line, 3);
        }
        for (int row = 1; row < o->rows; row++) {
            int y = (int)((long long)row * o->height / o->rows);
            int block = o->block_rows > 0 && row % o->block_rows == 0;
            for (int x = 0; x < o->width; x++)
                for (int c = 0; c < 3; c++)
                    rgb[((size_t)y * o->width + x) * 3 + c] =
                        block ? (unsigned char)(o->background[c] / 2) : line[c];
        }
    }
    for (int i = 0; labels && i < k; i++) {
        const dtx_render_panel *p = panels + i;
        int sc = label_scale(pw), x0 = pp[i].x0 / ss, y0 = pp[i].y0 / ss;
        unsigned char ink[3];
        for (int c = 0; c < 3; c++)
            ink[c] = (unsigned char)(o->background[c] > 127 ? o->background[c] * 2 / 5
                                                             : 255 - (255 - o->background[c]) * 2 / 5);
        if (p->label)
            draw_text(rgb, o->width, p->label, x0 + 2 * sc + 1, y0 + 2 * sc, pp[i].x1 / ss,
                      pp[i].y1 / ss, sc, ink);
    }
    st = DTX_OK;
    goto done;
nomem:
    st = dtx_seterr(err, DTX_ENOMEM, "out of memory for a %d x %d picture (%dx%d supersampled)",
                    o->width, o->height, ss, ss);
done:
    free_preps(pp, k);
    free(R.z);
    free(R.c);
    free(lut);
    free(scale);
    free(own_bounds);
    free(N);
    free(comp);
    free(label);
    return st;
}

/* ------------------------------------------------------------------ */
/* PNG                                                                 */
/* ------------------------------------------------------------------ */

typedef struct {
    jmp_buf jmp;
    char msg[256];
} png_ctx;

static void png_fail(png_structp png, png_const_charp msg)
{
    png_ctx *ctx = png_get_error_ptr(png);
    snprintf(ctx->msg, sizeof ctx->msg, "%s", msg);
    longjmp(ctx->jmp, 1);
}

static void png_warn(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

dtx_status dtx_png_write(const char *path, const unsigned char *rgb, int width, int height,
                         dtx_error *err)
{
    dtx_atomic_file af;
    png_ctx ctx;
    png_structp png;
    png_infop info = NULL;
    dtx_status st;
    if (width < 1 || height < 1 || width > DTX_RENDER_MAX_SIZE || height > DTX_RENDER_MAX_SIZE)
        return dtx_seterr(err, DTX_EINVAL, "%s: image size %d x %d is outside 1..%d", path,
                          width, height, DTX_RENDER_MAX_SIZE);
    if ((st = dtx_atomic_open(&af, path, err)) != DTX_OK)
        return st;
    ctx.msg[0] = '\0';
    png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &ctx, png_fail, png_warn);
    if (png)
        info = png_create_info_struct(png);
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        dtx_atomic_abort(&af);
        return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", path);
    }
    /* Nothing below changes a local variable that is read after a longjmp
     * except through ctx and af, which are not in registers across it. */
    if (setjmp(ctx.jmp)) {
        png_destroy_write_struct(&png, &info);
        dtx_atomic_abort(&af);
        return dtx_seterr(err, DTX_EIO, "%s: cannot write the PNG: %s", path, ctx.msg);
    }
    png_init_io(png, af.fp);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, 6);
    {
        png_text text;
        memset(&text, 0, sizeof text);
        text.compression = PNG_TEXT_COMPRESSION_NONE;
        text.key = (png_charp) "Software";
        text.text = (png_charp) "dtx " DTX_VERSION;
        png_set_text(png, info, &text, 1);
    }
    png_write_info(png, info);
    for (int y = 0; y < height; y++)
        png_write_row(png, (png_const_bytep)(rgb + (size_t)y * width * 3));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return dtx_atomic_commit(&af, err);
}
