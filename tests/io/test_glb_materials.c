/* test_glb_materials.c: the .mtl reader and the material lookup for the
 * glb (glb_materials.h).  The reader: newmtl, Kd, d, Tr, map_Kd with
 * options before the file name, statements before the first newmtl,
 * comments and CRLF; malformed Kd and d are DTX_EPARSE naming the line;
 * every truncation of a file parses or fails cleanly.  The lookup: from a
 * result's mesh (source "FILE.h5:/meshes/NAME") through the imported mesh
 * (source "asset.obj", relative to its file's folder) to the OBJ, its .mtl
 * and the PNG it names; what is missing (the .mtl, a material, the image,
 * an image that is not PNG) is a note and no error. */
#include "check.h"
#include "glb_materials.h"
#include "h5layout.h"
#include "h5mesh_attrs.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define SCRATCH DTX_TEST_SCRATCH

static void put(const char *path, const void *bytes, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f)
        return;
    fwrite(bytes, 1, n, f);
    fclose(f);
}

static void puts_file(const char *path, const char *text) { put(path, text, strlen(text)); }

static void test_parse(void)
{
    static const char text[] = "# a library\r\n"
                               "Kd 9 9 9\n" /* before any newmtl: ignored */
                               "newmtl skin\r\n"
                               "Ka 0 0 0\n"
                               "Kd 0.5 0.25 1\n"
                               "d 0.5\n"
                               "map_Kd -s 2 2 1 -clamp on -bm 0.5 tex/skin image.png\n"
                               "newmtl  glass \n"
                               "Tr 0.25\n"
                               "map_Kd plain.jpg\n";
    dtx_mtl m;
    dtx_error err;
    CHECK_OK(dtx_mtl_parse("t.mtl", text, sizeof text - 1, &m, &err), &err);
    CHECK_EQ_INT(m.n, 2);
    if (m.n == 2) {
        CHECK(strcmp(m.m[0].name, "skin") == 0);
        CHECK_EQ_INT(m.m[0].has_kd, 1);
        CHECK_DBL(m.m[0].kd[1], ==, 0.25);
        CHECK_DBL(m.m[0].alpha, ==, 0.5);
        CHECK(m.m[0].map_kd && strcmp(m.m[0].map_kd, "tex/skin image.png") == 0);
        CHECK(strcmp(m.m[1].name, "glass") == 0);
        CHECK_EQ_INT(m.m[1].has_kd, 0);
        CHECK_DBL(m.m[1].alpha, ==, 0.75);
        CHECK(m.m[1].map_kd && strcmp(m.m[1].map_kd, "plain.jpg") == 0);
    }
    dtx_mtl_free(&m);

    /* malformed statements name their line */
    {
        static const char *bad[] = {"newmtl a\nKd 1 2\n", "newmtl a\nKd 1 x 2\n",
                                    "newmtl a\n\nd nan\n", "newmtl a\nTr\n"};
        static const char *where[] = {"b.mtl:2", "b.mtl:2", "b.mtl:3", "b.mtl:2"};
        for (int i = 0; i < 4; i++) {
            dtx_status st = dtx_mtl_parse("b.mtl", bad[i], strlen(bad[i]), &m, &err);
            CHECK_EQ_INT(st, DTX_EPARSE);
            CHECK(strstr(err.msg, where[i]) != NULL);
            CHECK_EQ_INT(m.n, 0);
        }
    }
    /* every prefix (from a heap copy of exactly that size, so ASan sees
     * any read past it) parses or fails cleanly */
    for (size_t n = 0; n <= sizeof text - 1; n++) {
        char *b = malloc(n ? n : 1);
        dtx_status st;
        memcpy(b, text, n);
        st = dtx_mtl_parse("p.mtl", b, n, &m, &err);
        CHECK(st == DTX_OK || st == DTX_EPARSE);
        dtx_mtl_free(&m);
        free(b);
    }
}

/* A one-triangle mesh with two materials' names and mtllib lib. */
static void mesh_file(const char *h5, const char *group, const char *source, const char *lib)
{
    static const double V[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    static int32_t F[3] = {0, 1, 2}, mat[1] = {1};
    static char *names[2] = {"skin", "fur"};
    dtx_mesh m;
    dtx_mesh_attrs a;
    dtx_error err;
    hid_t f = H5I_INVALID_HID;
    struct stat sb;
    m.nv = 3, m.nf = 1, m.V = (double *)V, m.F = F;
    memset(&a, 0, sizeof a);
    a.nmat = 2, a.material = mat, a.material_names = names, a.mtllib = (char *)lib;
    if (stat(h5, &sb) == 0)
        CHECK_OK(dtx_h5_open(h5, MPI_COMM_NULL, 1, &f, &err), &err);
    else
        CHECK_OK(dtx_h5_create(h5, MPI_COMM_NULL, &f, &err), &err);
    CHECK_OK(dtx_h5_write_mesh_with(f, group, &m, &a, source, &err), &err);
    dtx_h5_close(&f, NULL);
}

static void load(const char *h5, const char *group, dtx_glb_materials *out)
{
    dtx_mesh_attrs a;
    dtx_error err;
    hid_t f = H5I_INVALID_HID;
    CHECK_OK(dtx_h5_open(h5, MPI_COMM_NULL, 0, &f, &err), &err);
    CHECK_OK(dtx_h5_read_mesh_attrs(f, group, 3, 1, &a, &err), &err);
    CHECK_OK(dtx_glb_materials_load(f, h5, group, &a, out, &err), &err);
    dtx_mesh_attrs_free(&a);
    dtx_h5_close(&f, NULL);
}

static void test_lookup(void)
{
    static const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 0};
    const char *dir = SCRATCH "/asset";
    dtx_glb_materials g;
    mkdir(dir, 0777);
    mkdir(SCRATCH "/out", 0777);
    remove(SCRATCH "/in.h5");
    remove(SCRATCH "/out/out.h5");
    puts_file(SCRATCH "/asset/lion.obj", "# the asset itself is not read here\n");
    puts_file(SCRATCH "/asset/lion.mtl", "newmtl fur\nKd 0.2 0.5 0.8\nnewmtl skin\nKd 2 -1 0.5\n"
                                         "d 0.5\nmap_Kd skin.png\n");
    put(SCRATCH "/asset/skin.png", png, sizeof png);
    /* imported mesh: source relative to the h5's folder; the result's mesh
     * names it as FILE.h5:/meshes/NAME from another folder */
    mesh_file(SCRATCH "/in.h5", "/meshes/lion", "asset/lion.obj", "lion.mtl");
    mesh_file(SCRATCH "/out/out.h5", "/meshes/lion", SCRATCH "/in.h5:/meshes/lion", "lion.mtl");

    load(SCRATCH "/out/out.h5", "/meshes/lion", &g);
    CHECK_EQ_INT(g.n, 2);
    CHECK(g.obj_path && strstr(g.obj_path, "asset/lion.obj") != NULL);
    CHECK(g.mtl_path && strstr(g.mtl_path, "asset/lion.mtl") != NULL);
    CHECK(strcmp(g.note, "") == 0);
    if (g.n == 2) {
        /* material 0 is "skin": Kd clamped to [0, 1], alpha from d, the PNG */
        CHECK(strcmp(g.mat[0].name, "skin") == 0);
        CHECK_EQ_INT(g.mat[0].has_color, 1);
        CHECK_DBL(g.mat[0].base_color[0], ==, 1.0);
        CHECK_DBL(g.mat[0].base_color[1], ==, 0.0);
        CHECK_DBL(g.mat[0].base_color[3], ==, 0.5);
        CHECK_EQ_INT(g.mat[0].image_len, sizeof png);
        CHECK(g.mat[0].image && memcmp(g.mat[0].image, png, sizeof png) == 0);
        CHECK_DBL(g.mat[1].base_color[2], ==, 0.8f);
        CHECK(g.mat[1].image == NULL);
    }
    CHECK_EQ_INT(g.nimages, 1);
    dtx_glb_materials_free(&g);

    /* an image that is not PNG/JPEG, then a missing image and material */
    puts_file(SCRATCH "/asset/skin.png", "GIF89a");
    load(SCRATCH "/out/out.h5", "/meshes/lion", &g);
    CHECK(strstr(g.note, "neither PNG nor JPEG") != NULL);
    CHECK_EQ_INT(g.nimages, 0);
    dtx_glb_materials_free(&g);
    remove(SCRATCH "/asset/skin.png");
    puts_file(SCRATCH "/asset/lion.mtl", "newmtl skin\nKd 1 1 1\nmap_Kd skin.png\n");
    load(SCRATCH "/out/out.h5", "/meshes/lion", &g);
    CHECK(strstr(g.note, "skin.png not found") != NULL);
    CHECK(strstr(g.note, "material fur is not in") != NULL);
    CHECK_EQ_INT(g.mat[0].has_color, 1);
    dtx_glb_materials_free(&g);

    /* no .mtl anywhere: the names stay, no colours, a note naming the OBJ */
    remove(SCRATCH "/asset/lion.mtl");
    load(SCRATCH "/out/out.h5", "/meshes/lion", &g);
    CHECK_EQ_INT(g.n, 2);
    CHECK(g.mtl_path == NULL);
    CHECK(strstr(g.note, "lion.mtl not found beside") != NULL);
    CHECK_EQ_INT(g.mat[0].has_color + g.mat[1].has_color, 0);
    dtx_glb_materials_free(&g);
}

int main(void)
{
    test_parse();
    test_lookup();
    return check_report();
}
