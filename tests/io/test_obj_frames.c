/* test_obj_frames.c: OBJ frames of an asset with its attributes
 * (io/obj_frames.c): vt, usemtl and v/t/n corners are written, normals are
 * the frame's (not the asset's rest normals), material names with white
 * space are made single words, and a mesh without attributes is written
 * as dtx_obj_write writes it. */
#include "check.h"
#include "obj_frames.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SCRATCH DTX_TEST_SCRATCH "/"

static char *slurp(const char *path)
{
    FILE *fp = fopen(path, "rb");
    char *buf;
    long n;
    if (!fp)
        return NULL;
    fseek(fp, 0, SEEK_END);
    n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    buf = calloc((size_t)n + 1, 1);
    if (buf && fread(buf, 1, (size_t)n, fp) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(fp);
    return buf;
}

static int has(const char *text, const char *line)
{
    int ok = text && strstr(text, line) != NULL;
    if (!ok)
        fprintf(stderr, "  expected \"%s\" in:\n%s\n", line, text ? text : "(null)");
    return ok;
}

int main(void)
{
    /* A unit square in z = 0 (two triangles), rest normals +z. */
    double V[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    int32_t F[6] = {0, 1, 2, 0, 2, 3};
    dtx_mesh m = {0};
    dtx_mesh_attrs a = {0};
    dtx_obj_frames w;
    dtx_error e;
    char *text;
    /* The frame: the square rotated to the plane x = 0 (normal +x). */
    double X[12] = {0, 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1};
    m.nv = 4, m.nf = 2, m.V = V, m.F = F;
    a.nuv = 4;
    a.uv = malloc(8 * sizeof *a.uv);
    a.uv_faces = malloc(sizeof F);
    a.nn = 4;
    a.normals = calloc(12, sizeof *a.normals);
    a.normal_faces = malloc(sizeof F);
    a.nmat = 2;
    a.material = malloc(2 * sizeof *a.material);
    a.material_names = malloc(2 * sizeof *a.material_names);
    a.material_names[0] = strdup("Skin Mat");
    a.material_names[1] = strdup("");
    for (int i = 0; i < 8; i++)
        a.uv[i] = 0.25 * i;
    for (int i = 0; i < 4; i++)
        a.normals[3 * i + 2] = 1;
    memcpy(a.uv_faces, F, sizeof F);
    memcpy(a.normal_faces, F, sizeof F);
    a.material[0] = 0, a.material[1] = 1;

    CHECK_OK(dtx_obj_frames_begin(&w, &m, &a, &e), &e);
    CHECK(!dtx_mesh_attrs_any(&a)); /* taken over */
    CHECK_OK(dtx_obj_frames_write(&w, SCRATCH "frame.obj", X, NULL, "test", &e), &e);
    text = slurp(SCRATCH "frame.obj");
    CHECK(has(text, "vt 1.5 1.75\n"));
    CHECK(has(text, "vn 1 0 0\n"));
    CHECK(!strstr(text, "vn 0 0 1"));
    CHECK(has(text, "usemtl Skin_Mat\nf 1/1/1 2/2/2 3/3/3\n"));
    CHECK(has(text, "usemtl material_1\nf 1/1/1 3/3/3 4/4/4\n"));
    free(text);
    /* float32 frames too */
    {
        float Xf[12];
        for (int i = 0; i < 12; i++)
            Xf[i] = (float)X[i];
        CHECK_OK(dtx_obj_frames_write(&w, SCRATCH "framef.obj", NULL, Xf, NULL, &e), &e);
        text = slurp(SCRATCH "framef.obj");
        CHECK(has(text, "vn 1 0 0\n"));
        free(text);
    }
    dtx_obj_frames_end(&w);

    /* No attributes: byte for byte what dtx_obj_write writes. */
    {
        char *t2;
        CHECK_OK(dtx_obj_frames_begin(&w, &m, NULL, &e), &e);
        CHECK_OK(dtx_obj_frames_write(&w, SCRATCH "plain.obj", X, NULL, "c", &e), &e);
        dtx_obj_frames_end(&w);
        CHECK_OK(dtx_obj_write(SCRATCH "plain2.obj", X, 4, F, 2, "c", &e), &e);
        text = slurp(SCRATCH "plain.obj");
        t2 = slurp(SCRATCH "plain2.obj");
        CHECK(text && t2 && strcmp(text, t2) == 0);
        CHECK(!strstr(text, "vt ") && !strstr(text, "vn "));
        free(text);
        free(t2);
    }
    return check_report();
}
