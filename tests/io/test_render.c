/* test_render.c: the software rasteriser and the PNG writer (src/io/render.h).
 *
 * Silhouettes against analytic projected areas (a square facing the camera,
 * from the front and from behind; a unit cube from several directions,
 * whose orthographic shadow has area |tx| + |ty| + |tz|), orientation of the
 * camera axes and the up axis, the depth test, colours by component,
 * determinism (two renders and 1 vs 2 threads bitwise equal), the fitted
 * height, bad arguments, and the PNG round trip through libpng. */
#include "check.h"
#include "core/meshgen.h"
#include "render.h"

#include <png.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#define SCRATCH DTX_TEST_SCRATCH

/* ------------------------------------------------------------ helpers */

/* Options for measuring: W x H pixels, one panel, no margin, outline,
 * separators or supersampling, flat shading, white background. */
static dtx_render_opts measuring_opts(int w, int h, double az, double el)
{
    dtx_render_opts o;
    dtx_render_opts_default(&o);
    o.width = w, o.height = h;
    o.azimuth_deg = az, o.elevation_deg = el;
    o.margin = 0.0;
    o.outline = 0;
    o.separators = 0;
    o.supersample = 1;
    o.smooth = 0;
    return o;
}

static long count_not_bg(const unsigned char *rgb, int w, int h, const unsigned char bg[3])
{
    long n = 0;
    for (long i = 0; i < (long)w * h; i++)
        n += memcmp(rgb + 3 * i, bg, 3) != 0;
    return n;
}

static const unsigned char *px(const unsigned char *rgb, int w, int x, int y)
{
    return rgb + ((size_t)y * w + x) * 3;
}

/* One panel holding X/F with the explicit box [-1, 1]^2: 100 pixels per
 * unit in a 200 x 200 image without margin. */
static dtx_status draw_one(const double *X, int32_t nv, const int32_t *F, int32_t nf,
                           const dtx_render_opts *o, unsigned char *rgb, dtx_error *err)
{
    const double box[4] = {-1, 1, -1, 1};
    dtx_render_panel p;
    memset(&p, 0, sizeof p);
    p.X = X, p.nv = nv, p.F = F, p.nf = nf;
    return dtx_render_panels(&p, 1, box, 1, o, rgb, err);
}

/* The unit cube centred at the origin: 8 vertices, 12 triangles. */
static const double cube_V[] = {-.5, -.5, -.5, .5, -.5, -.5, .5, .5, -.5, -.5, .5, -.5,
                                -.5, -.5, .5,  .5, -.5, .5,  .5, .5, .5,  -.5, .5, .5};
static const int32_t cube_F[] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                 2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};

/* ------------------------------------------------------------ tests */

/* A unit square in the x-y plane covers 100 x 100 pixels, seen from the
 * front or from behind (open meshes are drawn from both sides). */
static void test_square_coverage(void)
{
    const double V[] = {-.5, -.5, 0, .5, -.5, 0, .5, .5, 0, -.5, .5, 0};
    const int32_t F[] = {0, 1, 2, 0, 2, 3};
    const double azs[] = {0.0, 180.0};
    unsigned char *rgb = malloc(200 * 200 * 3);
    dtx_error err;
    for (int i = 0; i < 2; i++) {
        dtx_render_opts o = measuring_opts(200, 200, azs[i], 0.0);
        long n;
        CHECK_OK(draw_one(V, 4, F, 2, &o, rgb, &err), &err);
        n = count_not_bg(rgb, 200, 200, o.background);
        printf("square from azimuth %g: %ld pixels, analytic 10000\n", azs[i], n);
        CHECK_NEAR(n, 10000, 10000 * 0.02);
        /* Centre covered, corners empty. */
        CHECK(memcmp(px(rgb, 200, 100, 100), o.background, 3) != 0);
        CHECK(memcmp(px(rgb, 200, 5, 5), o.background, 3) == 0);
        CHECK(memcmp(px(rgb, 200, 194, 194), o.background, 3) == 0);
        /* Supersampled: edge pixels are blends, so a looser bound. */
        o.supersample = 2;
        CHECK_OK(draw_one(V, 4, F, 2, &o, rgb, &err), &err);
        n = count_not_bg(rgb, 200, 200, o.background);
        printf("square from azimuth %g, 2x2 supersampled: %ld pixels touched\n", azs[i], n);
        CHECK_NEAR(n, 10000, 10000 * 0.05);
    }
    free(rgb);
}

/* The orthographic shadow of the unit cube along the unit direction t has
 * area |tx| + |ty| + |tz|. */
static void test_cube_coverage(void)
{
    const double views[][2] = {{0, 0}, {45, 0}, {45, 35.26438968}, {30, 20}, {-120, -50},
                               {10, 90}};
    unsigned char *rgb = malloc(200 * 200 * 3);
    dtx_error err;
    for (size_t i = 0; i < sizeof views / sizeof *views; i++) {
        dtx_render_opts o = measuring_opts(200, 200, views[i][0], views[i][1]);
        double r[3], u[3], t[3], area;
        long n;
        dtx_render_axes(&o, r, u, t);
        area = 1e4 * (fabs(t[0]) + fabs(t[1]) + fabs(t[2]));
        CHECK_OK(draw_one(cube_V, 8, cube_F, 12, &o, rgb, &err), &err);
        n = count_not_bg(rgb, 200, 200, o.background);
        printf("cube from azimuth %g, elevation %g: %ld pixels, analytic %.0f (%+.2f%%)\n",
               views[i][0], views[i][1], n, area, 100.0 * (n - area) / area);
        CHECK_NEAR(n, area, area * 0.03);
        o.smooth = 1;
        o.outline = 1;
        CHECK_OK(draw_one(cube_V, 8, cube_F, 12, &o, rgb, &err), &err);
        CHECK_NEAR(count_not_bg(rgb, 200, 200, o.background), area, area * 0.03);
    }
    free(rgb);
}

/* Camera axes: from the front +x is right and +y up; with up_axis z, +z is
 * up; the axes are orthonormal with right x up = toward. */
static void test_orientation(void)
{
    /* A small square in the upper right quadrant. */
    const double V[] = {.2, .2, 0, .8, .2, 0, .8, .8, 0, .2, .8, 0};
    const double Vz[] = {.2, 0, .2, .8, 0, .2, .8, 0, .8, .2, 0, .8};
    const int32_t F[] = {0, 1, 2, 0, 2, 3};
    const double views[][2] = {{0, 0}, {73, 12}, {-40, 89}, {200, -30}};
    unsigned char *rgb = malloc(200 * 200 * 3);
    dtx_render_opts o = measuring_opts(200, 200, 0, 0);
    dtx_error err;
    CHECK_OK(draw_one(V, 4, F, 2, &o, rgb, &err), &err);
    CHECK(memcmp(px(rgb, 200, 150, 50), o.background, 3) != 0); /* upper right */
    CHECK(memcmp(px(rgb, 200, 50, 150), o.background, 3) == 0);
    CHECK(memcmp(px(rgb, 200, 50, 50), o.background, 3) == 0);
    CHECK(memcmp(px(rgb, 200, 150, 150), o.background, 3) == 0);
    /* z up: the same square lifted into the x-z plane, seen from -y. */
    o.up_axis = 2;
    o.azimuth_deg = 0;
    CHECK_OK(draw_one(Vz, 4, F, 2, &o, rgb, &err), &err);
    CHECK(memcmp(px(rgb, 200, 150, 50), o.background, 3) != 0);
    CHECK(memcmp(px(rgb, 200, 50, 150), o.background, 3) == 0);
    for (int up = 0; up < 3; up++)
        for (size_t i = 0; i < sizeof views / sizeof *views; i++) {
            double r[3], u[3], t[3], c[3];
            o.up_axis = up;
            o.azimuth_deg = views[i][0], o.elevation_deg = views[i][1];
            dtx_render_axes(&o, r, u, t);
            c[0] = r[1] * u[2] - r[2] * u[1];
            c[1] = r[2] * u[0] - r[0] * u[2];
            c[2] = r[0] * u[1] - r[1] * u[0];
            for (int k = 0; k < 3; k++)
                CHECK_NEAR(c[k], t[k], 1e-12);
            CHECK_NEAR(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], 1.0, 1e-12);
            CHECK_NEAR(u[0] * u[0] + u[1] * u[1] + u[2] * u[2], 1.0, 1e-12);
            CHECK_NEAR(r[0] * u[0] + r[1] * u[1] + r[2] * u[2], 0.0, 1e-12);
            /* The screen's up vector never points below the horizon. */
            CHECK_DBL(u[up], >=, -1e-12);
        }
    free(rgb);
}

/* Two overlapping squares of different components: where they overlap, the
 * one nearer the camera shows, whichever comes first in the face list; the
 * components get different colours, or one colour when asked. */
static void test_depth_and_components(void)
{
    /* Square A at z = 0 over [-0.6, 0.2]^2, square B at z = 0.3 over
     * [-0.2, 0.6]^2 (nearer the camera at azimuth 0). */
    double V[24];
    int32_t F[12], Fswap[12];
    const int32_t sq[6] = {0, 1, 2, 0, 2, 3};
    unsigned char *a = malloc(200 * 200 * 3), *b = malloc(200 * 200 * 3);
    dtx_render_opts o = measuring_opts(200, 200, 0, 0);
    dtx_error err;
    for (int s = 0; s < 2; s++) {
        double lo = s ? -0.2 : -0.6, hi = s ? 0.6 : 0.2, z = s ? 0.3 : 0.0;
        double c[4][2] = {{lo, lo}, {hi, lo}, {hi, hi}, {lo, hi}};
        for (int i = 0; i < 4; i++) {
            V[12 * s + 3 * i] = c[i][0];
            V[12 * s + 3 * i + 1] = c[i][1];
            V[12 * s + 3 * i + 2] = z;
        }
        for (int i = 0; i < 6; i++)
            F[6 * s + i] = sq[i] + 4 * s;
    }
    memcpy(Fswap, F + 6, 6 * sizeof *F);
    memcpy(Fswap + 6, F, 6 * sizeof *F);
    CHECK_OK(draw_one(V, 8, F, 4, &o, a, &err), &err);
    /* Pixel (x, y) shows world (x/100 - 1, 1 - y/100). */
    {
        const unsigned char *only_a = px(a, 200, 55, 145), *only_b = px(a, 200, 145, 55);
        const unsigned char *both = px(a, 200, 100, 100);
        CHECK(memcmp(only_a, only_b, 3) != 0); /* two components, two colours */
        CHECK(memcmp(both, only_b, 3) == 0);   /* B is in front */
    }
    /* Components are numbered by their first face, so the colours swap,
     * but B still covers A. */
    CHECK_OK(draw_one(V, 8, Fswap, 4, &o, b, &err), &err);
    CHECK(memcmp(px(b, 200, 100, 100), px(b, 200, 145, 55), 3) == 0);
    CHECK(memcmp(px(b, 200, 145, 55), px(a, 200, 55, 145), 3) == 0);
    /* One colour: both squares look the same, and face order does not
     * change a pixel. */
    o.color_by_component = 0;
    CHECK_OK(draw_one(V, 8, F, 4, &o, a, &err), &err);
    CHECK(memcmp(px(a, 200, 55, 145), px(a, 200, 145, 55), 3) == 0);
    CHECK(memcmp(px(a, 200, 100, 100), o.background, 3) != 0);
    CHECK_OK(draw_one(V, 8, Fswap, 4, &o, b, &err), &err);
    CHECK(memcmp(a, b, 200 * 200 * 3) == 0);
    free(a);
    free(b);
}

/* A sheet of 2 x 3 panels of a bent capsule in two camera groups, with
 * labels, supersampling, outlines and smooth shading: the same bytes on
 * every run and with 1 or 2 threads. */
static void test_determinism(void)
{
    dtx_mesh m;
    double *X = NULL;
    dtx_render_panel p[6];
    char labels[6][16];
    unsigned char *img[3];
    dtx_render_opts o;
    dtx_error err;
    size_t bytes;
    CHECK_OK(gen_capsule(24, 12, 1.5, &m), &err);
    X = malloc((size_t)m.nv * 3 * 6 * sizeof *X);
    dtx_render_opts_default(&o);
    o.width = 600, o.rows = 2, o.cols = 3;
    memset(p, 0, sizeof p);
    for (int i = 0; i < 6; i++) {
        deform(m.V, m.nv, i / 5.0, X + (size_t)i * m.nv * 3);
        p[i].X = X + (size_t)i * m.nv * 3;
        p[i].nv = m.nv, p[i].F = m.F, p[i].nf = m.nf;
        p[i].row = i / 3, p[i].col = i % 3, p[i].group = i / 3;
        p[i].palette_offset = i / 3;
        snprintf(labels[i], sizeof labels[i], "Frame %d", i);
        p[i].label = labels[i];
    }
    {
        double bounds[8];
        dtx_render_bounds_init(bounds);
        dtx_render_bounds_init(bounds + 4);
        for (int i = 0; i < 6; i++)
            dtx_render_bounds_add(p[i].X, p[i].nv, &o, bounds + 4 * p[i].group);
        o.height = dtx_render_fit_height(bounds, 2, 1, &o);
    }
    CHECK_INT(o.height, >, 50);
    bytes = (size_t)o.width * o.height * 3;
    for (int r = 0; r < 3; r++)
        img[r] = malloc(bytes);
#ifdef _OPENMP
    omp_set_num_threads(1);
#endif
    CHECK_OK(dtx_render_panels(p, 6, NULL, 0, &o, img[0], &err), &err);
#ifdef _OPENMP
    omp_set_num_threads(2);
#endif
    CHECK_OK(dtx_render_panels(p, 6, NULL, 0, &o, img[1], &err), &err);
    CHECK_OK(dtx_render_panels(p, 6, NULL, 0, &o, img[2], &err), &err);
    CHECK(memcmp(img[0], img[1], bytes) == 0);
    CHECK(memcmp(img[1], img[2], bytes) == 0);
    /* Something is drawn in every panel, and labels are drawn. */
    for (int i = 0; i < 6; i++) {
        int x0 = p[i].col * 200, y0 = p[i].row * (o.height / 2), ink = 0;
        long drawn = 0;
        for (int y = y0 + 20; y < y0 + o.height / 2; y++)
            for (int x = x0 + 1; x < x0 + 200; x++)
                drawn += memcmp(px(img[0], o.width, x, y), o.background, 3) != 0;
        CHECK_INT(drawn, >, 1000);
        for (int y = y0; y < y0 + 18; y++)
            for (int x = x0 + 1; x < x0 + 40; x++)
                ink += px(img[0], o.width, x, y)[0] < 128;
        CHECK_INT(ink, >, 10);
    }
    for (int r = 0; r < 3; r++)
        free(img[r]);
    free(X);
    dtx_mesh_free(&m);
}

/* The fitted height leaves no empty rows: a 2:1 box in 200-pixel panels
 * without margin is 100 pixels high per row. */
static void test_fit_height(void)
{
    double box[8] = {0, 2, 0, 1, 5, 6, 5, 5.25};
    dtx_render_opts o;
    dtx_render_opts_default(&o);
    o.width = 400, o.cols = 2, o.rows = 3, o.margin = 0.0;
    CHECK_EQ_INT(dtx_render_fit_height(box, 1, 0, &o), 300);
    /* Same scale: the second group (1 x 0.25) gets the first one's scale. */
    CHECK_EQ_INT(dtx_render_fit_height(box, 2, 0, &o), 300);
    /* Separate scales: the second group is 200 x 50 pixels. */
    o.same_scale = 0;
    CHECK_EQ_INT(dtx_render_fit_height(box + 4, 1, 0, &o), 150);
    /* Labels add their band. */
    o.same_scale = 1;
    CHECK_INT(dtx_render_fit_height(box, 1, 1, &o), >, 300);
}

static void test_bad_arguments(void)
{
    const double V[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int32_t F[] = {0, 1, 2}, Fbad[] = {0, 1, 3};
    unsigned char *rgb = malloc(100 * 100 * 3);
    dtx_render_panel p[2];
    dtx_render_opts o;
    dtx_error err;
    dtx_render_opts_default(&o);
    o.width = o.height = 100;
    memset(p, 0, sizeof p);
    p[0].X = V, p[0].nv = 3, p[0].F = F, p[0].nf = 1;
    p[1] = p[0];
    CHECK_OK(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), &err);
    CHECK_EQ_INT(dtx_render_panels(p, 2, NULL, 0, &o, rgb, &err), DTX_EINVAL); /* same panel */
    CHECK(strstr(err.msg, "already taken") != NULL);
    p[1].col = 1;
    CHECK_EQ_INT(dtx_render_panels(p, 2, NULL, 0, &o, rgb, &err), DTX_EINVAL); /* outside */
    CHECK(strstr(err.msg, "outside") != NULL);
    p[1].col = 0;
    p[0].F = Fbad;
    CHECK_EQ_INT(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), DTX_ERANGE);
    CHECK(strstr(err.msg, "vertex index 3") != NULL);
    p[0].F = F;
    o.supersample = 5;
    CHECK_EQ_INT(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), DTX_EINVAL);
    o.supersample = 2;
    o.elevation_deg = 91;
    CHECK_EQ_INT(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), DTX_EINVAL);
    o.elevation_deg = 10;
    o.width = 0;
    CHECK_EQ_INT(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), DTX_EINVAL);
    o.width = 100;
    o.cols = 101;
    CHECK_EQ_INT(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), DTX_EINVAL);
    o.cols = 1;
    p[0].group = 2;
    CHECK_EQ_INT(dtx_render_panels(p, 1, (const double[8]){0, 1, 0, 1, 0, 1, 0, 1}, 2, &o,
                                   rgb, &err),
                 DTX_EINVAL);
    /* Degenerate input draws nothing and fails nothing: a flat box, a
     * zero-area face, no faces. */
    p[0].group = 0;
    p[0].nf = 0;
    CHECK_OK(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), &err);
    CHECK_EQ_INT(count_not_bg(rgb, 100, 100, o.background), 0);
    p[0].nf = 1;
    p[0].X = (const double[9]){0};
    CHECK_OK(dtx_render_panels(p, 1, NULL, 0, &o, rgb, &err), &err);
    CHECK_EQ_INT(count_not_bg(rgb, 100, 100, o.background), 0);
    free(rgb);
}

/* Reads a PNG with libpng's simplified API into a new RGB buffer. */
static unsigned char *read_png(const char *path, int *w, int *h)
{
    png_image im;
    unsigned char *buf;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, path))
        return NULL;
    im.format = PNG_FORMAT_RGB;
    buf = malloc(PNG_IMAGE_SIZE(im));
    if (!buf || !png_image_finish_read(&im, NULL, buf, 0, NULL)) {
        free(buf);
        png_image_free(&im);
        return NULL;
    }
    *w = (int)im.width, *h = (int)im.height;
    return buf;
}

static void test_png_round_trip(void)
{
    const int w = 37, h = 23;
    unsigned char *rgb = malloc((size_t)w * h * 3), *back;
    const char *path = SCRATCH "/round-trip.png";
    int rw = 0, rh = 0;
    dtx_error err;
    for (int i = 0; i < w * h * 3; i++)
        rgb[i] = (unsigned char)(i * 7 + i / 3);
    remove(path);
    CHECK_OK(dtx_png_write(path, rgb, w, h, &err), &err);
    back = read_png(path, &rw, &rh);
    CHECK(back != NULL);
    CHECK_EQ_INT(rw, w);
    CHECK_EQ_INT(rh, h);
    CHECK(back && memcmp(back, rgb, (size_t)w * h * 3) == 0);
    free(back);
    /* Overwrites atomically; a missing directory is a clean DTX_EIO. */
    rgb[0] ^= 0xFF;
    CHECK_OK(dtx_png_write(path, rgb, w, h, &err), &err);
    back = read_png(path, &rw, &rh);
    CHECK(back && back[0] == rgb[0]);
    free(back);
    CHECK_EQ_INT(dtx_png_write(SCRATCH "/no-such-dir/x.png", rgb, w, h, &err), DTX_EIO);
    CHECK(strstr(err.msg, "no-such-dir/x.png") != NULL);
    CHECK(access(SCRATCH "/no-such-dir", F_OK) != 0);
    CHECK_EQ_INT(dtx_png_write(path, rgb, 0, h, &err), DTX_EINVAL);
    back = read_png(path, &rw, &rh); /* the old file is intact */
    CHECK(back && back[0] == rgb[0] && rw == w);
    free(back);
    remove(path);
    free(rgb);
}

int main(void)
{
    test_square_coverage();
    test_cube_coverage();
    test_orientation();
    test_depth_and_components();
    test_determinism();
    test_fit_height();
    test_bad_arguments();
    test_png_round_trip();
    return check_report();
}
